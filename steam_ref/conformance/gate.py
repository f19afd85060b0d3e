"""``check`` as a gate: every case of the kit has a result, or the check fails.

:func:`check_directory` reads ``RESULTS_DIR/<suite>/results.json`` for every data-free suite of the
kit (every suite but ``paper``, which needs the paper's data files: it joins the gate with
``paper=True``, ``check --paper``, or when ``only`` names it) and compares each case. A case or a
suite of the gate without a result is *missing*, and a check with anything missing fails (exit 1)
unless ``only`` names the suites to check or ``allow_missing`` says so; what was skipped is printed
either way. A check in which no case passed fails, ``allow_missing`` or not: nothing was shown to
conform. A results folder with no results at all, a malformed file, or results for another kit
version is bad input (exit 2); a quantity a case does not have is a warning line, and the rest is
checked.

A results file names the kit version it was computed against (``"kit_version": 4``); one without
it was written for kit v1, before the field existed, and is checked against the shipped v1. Results
for a suite the kit does not have (``fixed_lag`` results naming kit v2), or ``only`` naming one, are
bad input: nothing would be compared, and nothing is passed unchecked.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

from ..choices import CONFORMANCE_CONVENTIONS
from ..errors import DataError, SteamError
from .checker import Report, check_cases, convention_key
from .kitio import DATA_FREE, KITS, SUITES, printable, read_index, read_json, read_suite
from .validate import kit_cases, results_cases, results_version

__all__ = ["check_directory", "load_kit", "CONVENTION_NAMES"]

CONVENTION_NAMES = CONFORMANCE_CONVENTIONS  # its home: steam_ref.choices, read by the parser


def load_kit(kit: Path) -> tuple[dict, dict[str, list[dict]]]:
    """A kit's index (verified) and each suite's checked case list."""
    index = read_index(kit)
    suites = {}
    for suite in index["suites"]:
        where = printable(Path(kit) / suite / "cases.json")
        suites[suite] = kit_cases(where, read_suite(kit, suite)["cases"])
    return index, suites


def _present(path: Path) -> bool:
    """Whether anything (a file, a folder, even a dangling link) sits at ``path``."""
    return os.path.lexists(path)


def check_directory(
    results_dir: str | os.PathLike,
    kit: str | os.PathLike | None = None,
    *,
    only: Sequence[str] | None = None,
    allow_missing: bool = False,
    conventions: Sequence[str] = (),
    paper: bool = False,
) -> Report:
    """Check every suite of the kit (or of ``only``) against ``results_dir``; see the module docstring."""
    for what, path in (("results folder", results_dir), ("kit", kit)):
        if isinstance(path, str) and not path.strip():  # Path("") is the working folder, which no one means
            raise SteamError(f"the {what} is an empty path {path!r}: name a folder")
    results_dir = Path(results_dir)
    if not results_dir.is_dir():
        raise SteamError(f"results folder '{printable(results_dir)}' does not exist (or is not a folder)")
    unknown = [s for s in (only or ()) if s not in SUITES]
    if unknown:
        raise SteamError(f"unknown suite '{printable(unknown[0])}'; the suites are {', '.join(SUITES)}")
    bad = [c for c in conventions if c not in CONVENTION_NAMES]
    if bad:
        raise SteamError(
            f"unknown convention '{printable(bad[0])}'; the alternatives are {', '.join(CONVENTION_NAMES)}"
        )
    given = load_kit(Path(kit)) if kit is not None else None  # a kit named is checked first
    gate = DATA_FREE if only is None else only
    chosen = [s for s in SUITES if s in gate or (paper and s == "paper")]
    files = {s: results_dir / s / "results.json" for s in chosen if _present(results_dir / s / "results.json")}
    if not files:
        raise SteamError(
            f"no results in '{printable(results_dir)}': expected <suite>/results.json for "
            f"{'a suite of ' if only is None else ''}{', '.join(chosen)}"
        )
    data = {s: read_json(p) for s, p in files.items()}
    versions = {s: results_version(printable(files[s]), d) for s, d in data.items()}
    named = {v for v in versions.values() if v is not None}
    if len(named) > 1 or (named and None in versions.values()):
        raise DataError(
            f"{printable(results_dir)}: results for different kit versions ("
            + ", ".join(f"{s}: {v if v is not None else 'none'}" for s, v in versions.items())
            + ")"
        )
    version = next(iter(named)) if named else 1
    kit_path = Path(kit) if kit is not None else KITS[version]
    index, suites = given if given is not None else load_kit(kit_path)
    if index["kit_version"] != version:
        said = f"kit_version {version}" if named else "no kit_version (kit v1)"
        raise DataError(
            f"{printable(results_dir)}: the results name {said}, the kit {printable(kit_path)} is v{index['kit_version']}"
        )
    if conventions and not index.get("convention_alternatives"):
        raise SteamError(f"kit v{index['kit_version']} has no convention alternatives (kits v2 and later have them)")
    lacking = [c for c in conventions if c not in index.get("convention_alternatives", {})]
    if lacking:
        raise SteamError(
            f"kit v{index['kit_version']} has no convention alternative '{printable(lacking[0])}' (its alternatives: "
            f"{', '.join(name for name in index['convention_alternatives'] if '+' not in name)})"
        )
    absent = [s for s in chosen if s not in suites and (only is not None or s in files)]
    if absent:
        raise SteamError(
            f"kit v{index['kit_version']} has no suite '{absent[0]}' (its suites: {', '.join(suites)}), "
            f"so its results cannot be checked against it"
        )
    report = Report(allow_missing=allow_missing)
    if None in versions.values():
        report.notes.append("the results name no kit_version: checked as kit v1 results against the shipped kit v1")
    if conventions:
        report.notes.append(f"conventions: {convention_key(conventions)} for the quantities that depend on them")
    report.excluded = [s for s in suites if s not in chosen and s != "paper"]
    if "paper" in suites and "paper" not in chosen:
        said = " (its results are here)" if _present(results_dir / "paper" / "results.json") else ""
        report.notes.append(f"not checked: paper{said}, which needs the paper's data files: add --paper")
    for suite in (s for s in chosen if s in suites):
        if suite not in data:
            report.not_run += [f"{suite}/{c['name']}" for c in suites[suite]]
            continue
        results = results_cases(printable(files[suite]), data[suite], suites[suite], report.warnings)
        check_cases(suite, suites[suite], results, report, conventions)
    return report
