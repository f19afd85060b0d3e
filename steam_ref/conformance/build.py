"""Build the kit, and check the installed code against the shipped one (``selftest``).

:func:`build_kit` computes every case's expected values (the oracle's for an independent case,
steam_ref's otherwise), refuses to write a kit that steam_ref fails, and writes ``<suite>/cases.json``,
``<suite>/expected.npz`` and ``index.json``. Regenerating the shipped kit is

    steam-ref conformance build --paper          (from a source checkout, with the paper's data files)

:func:`selftest` regenerates every case from the shipped inputs with the installed code and checks
it against the shipped expected values: steam_ref's results, the oracle's (for independent cases),
and that the inputs defined in :mod:`.cases` are still the shipped ones. The paper suite runs only
when asked (two full runs, about half a minute).
"""

from __future__ import annotations

import importlib.metadata
import os
import platform
import subprocess
from pathlib import Path

import numpy as np
import scipy

from ..errors import SteamError
from ..files import replace_file
from .cases import SUITE_DOCS, Case, suite_cases
from .checker import Outcome, Report, check_cases, compare_quantity
from .conventions import CONVENTION_ALTERNATIVES, CONVENTIONS, RESULTS_LAYOUT, depends_on
from .expected import oracle_alternatives, oracle_case
from .kitio import (
    DATA_FREE,
    KIT_VERSION,
    KITS,
    SHIPPED,
    SUITES,
    kit_files,
    plain,
    read_index,
    read_json,
    read_suite,
    sha256,
    write_json,
    write_npz,
)
from .paper import paper_cases, run_paper_case
from .runner import run_case

__all__ = ["build_kit", "selftest", "case_record"]


def _roundtrip(value):
    """``value`` as the kit stores it (JSON types; floats exact)."""
    return plain(value)


def case_record(case: Case, expected: dict, suite: str = "", alternatives: dict | None = None) -> dict:
    """A case as cases.json lists it: its quantities in computation order, each with the conventions it
    depends on, and (for those) the expected values under the alternative conventions."""
    return {
        "name": case.name,
        "equation": case.equation,
        "description": case.description,
        "independent": case.independent,
        "source": case.source,
        "quantities": [{"name": q, "depends_on": depends_on(suite, q)} for q in case.tolerance],
        "tolerance": _roundtrip(case.tolerance),
        "inputs": _roundtrip(case.inputs),
        "expected": _roundtrip(expected),
        **({"alternatives": _roundtrip(alternatives)} if alternatives else {}),
        **({"notes": _roundtrip(case.notes)} if case.notes else {}),
    }


def _suite_records(suite: str) -> list[dict]:
    records = []
    for case in suite_cases(suite):
        inputs = _roundtrip(case.inputs)
        ours = _roundtrip(run_case(suite, case.name, inputs))
        expected = _roundtrip(oracle_case(suite, case.name, inputs)) if case.independent else ours
        expected = {q: expected[q] for q in case.tolerance}
        record = case_record(case, expected, suite, oracle_alternatives(suite, inputs) if case.independent else None)
        verdict = check_cases(suite, [record], {case.name: ours})
        if verdict.failed:
            raise SteamError(f"steam_ref fails its own kit, so it is not written: {verdict.outcomes[0].line()}")
        records.append(record)
    return records


def _version() -> str:
    try:
        return importlib.metadata.version("steam_ref")
    except importlib.metadata.PackageNotFoundError:
        return "unknown"


# The folder holding the steam_ref package: a source checkout's root, or site-packages when installed.
SOURCE_ROOT = Path(__file__).resolve().parents[2]


def _commit(root: Path = SOURCE_ROOT) -> str:
    """The git commit of the source checkout at ``root``, or 'unknown' when ``root`` is not the top of
    a git work tree: an installed wheel, even one whose site-packages lies inside another project's
    repository (a ``.venv`` there), whose commit is not steam_ref's."""
    try:
        out = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "--show-toplevel", "HEAD"], capture_output=True, text=True, timeout=10
        )
        dirty = subprocess.run(
            ["git", "-C", str(root), "status", "--porcelain", "--", "steam_ref"],
            capture_output=True,
            text=True,
            timeout=10,
        )
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    lines = out.stdout.split()
    if out.returncode != 0 or len(lines) != 2 or Path(lines[0]).resolve() != Path(root).resolve():
        return "unknown"
    return lines[1] + ("+modified" if dirty.stdout.strip() else "")


KEEP_WITHIN = 1e-3  # a rebuilt value within this fraction of its tolerance of the stored one leaves the file be


def _unchanged(old: list[dict], new: list[dict]) -> bool:
    """Whether the rebuilt records ``new`` are the stored ``old`` ones: every field the same, and every expected
    value (and convention alternative) within a thousandth of its tolerance (another machine's last digits)."""
    if [c.get("name") for c in old] != [c["name"] for c in new]:
        return False
    for was, now in zip(old, new, strict=True):
        fields = set(was) | set(now)
        if any(was.get(k) != now.get(k) for k in fields - {"expected", "alternatives"}):
            return False
        pairs = [(was.get("expected", {}), now["expected"])]
        alternatives = was.get("alternatives", {}), now.get("alternatives", {})
        if set(alternatives[0]) != set(alternatives[1]):
            return False
        pairs += [(alternatives[0][k], alternatives[1][k]) for k in alternatives[1]]
        for stored, rebuilt in pairs:
            if set(stored) != set(rebuilt):
                return False
            for q, value in rebuilt.items():
                tolerance = now["tolerance"].get(q, "exact")
                if tolerance != "exact":
                    tolerance = {k: KEEP_WITHIN * float(v) for k, v in tolerance.items()}
                if compare_quantity(stored[q], value, tolerance, q):
                    return False
    return True


def _write_suite(out: Path, suite: str, records: list[dict]) -> None:
    """Write a suite's files, unless those in ``out`` hold the same cases to within a thousandth of each tolerance:
    a build on another machine (another BLAS, another order of summation) leaves the shipped kit be."""
    try:
        stored = read_suite(out, suite)
    except SteamError:
        stored = None
    if (
        stored is not None
        and stored.get("kit_version") == KIT_VERSION
        and stored.get("description") == SUITE_DOCS[suite]
        and (out / suite / "expected.npz").is_file()
        and _unchanged(stored["cases"], records)
    ):
        return
    cases = {"suite": suite, "kit_version": KIT_VERSION, "description": SUITE_DOCS[suite], "cases": records}
    (out / suite).mkdir(parents=True, exist_ok=True)
    _replace(out / suite / "cases.json", lambda name: write_json(name, cases))
    _replace(out / suite / "expected.npz", lambda name: write_npz(name, records))


def _replace(path: Path, write) -> None:
    """A kit file written by ``write(path)`` beside ``path`` and moved over it whole (steam_ref.files.replace_file):
    an interrupt or a full disk leaves the file as it was, and a named pipe there is replaced, not written (which
    blocked the build)."""
    replace_file(path, lambda name: write(Path(name)), "conformance build")


def _refuse_another_version(out: Path) -> None:
    """SteamError when ``out`` holds a kit of another version (its index.json says so): building this version there
    would replace its suites and keep its paper suite under this version's index (``--out`` the folder of kit v4,
    ``conformance/v4``, left a v5 kit with v4's paper cases). A folder without a kit's readable index is built into."""
    try:
        version = read_json(out / "index.json").get("kit_version")
    except (SteamError, AttributeError):
        return
    if version not in (None, KIT_VERSION):
        raise SteamError(
            f"{str(out)!r} holds the conformance kit v{version}: building v{KIT_VERSION} there would replace it; "
            "give a new or empty folder"
        )


def build_kit(
    out: str | os.PathLike | None = None, *, paper: bool = False, data_dir: str | os.PathLike | None = None
) -> dict:
    """Write the kit to ``out`` (default: the package's own folder, in a source checkout only); returns its index.

    ``paper``: rebuild the paper suite from the data files; otherwise keep the one in ``out``, or
    copy the shipped one. The package's own folder is written only when it is a source checkout's (:func:`_commit`
    knows its commit): in an installed package it is the kit the install shipped, which ``selftest`` checks this
    install against, so a rebuild there (or a half-finished one) would check the install against itself; SteamError
    saying to give ``out``.
    """
    if out is None and _commit() == "unknown":
        raise SteamError(
            f"the package's own kit ({SHIPPED}) is an installed copy, not a source checkout's: rebuilding it there "
            "would make `steam-ref conformance selftest` check this install against itself; write the kit elsewhere "
            "with --out DIR (out= in Python), or build in a clone of the repository"
        )
    out = Path(SHIPPED if out is None else out)
    _refuse_another_version(out)
    out.mkdir(parents=True, exist_ok=True)
    for suite in DATA_FREE:
        _write_suite(out, suite, _suite_records(suite))
    if paper:
        _write_suite(out, "paper", [case_record(c, e, "paper") for c, e in paper_cases(data_dir)])
    elif not (out / "paper" / "cases.json").is_file():
        # the paper suite's cases of the newest kit that has them (a new kit version keeps the last one's runs)
        source = next(
            (k for _, k in sorted(KITS.items(), reverse=True) if (k / "paper" / "cases.json").is_file()), None
        )
        if source is None:
            raise SteamError("no paper suite to keep: build with --paper (needs the paper's data files)")
        _write_suite(out, "paper", read_suite(source, "paper")["cases"])
    suites = {}
    for suite in SUITES:
        cases = read_suite(out, suite)["cases"]
        suites[suite] = {
            "description": SUITE_DOCS[suite],
            "files": [f"{suite}/cases.json", f"{suite}/expected.npz"],
            "cases": len(cases),
            "independent": [c["name"] for c in cases if c["independent"]],
            "produced_by_steam_ref": [c["name"] for c in cases if not c["independent"]],
        }
    files = {name: sha256(out / name) for name in kit_files(out) if name != "README.md"}
    try:
        stored_index = read_json(out / "index.json")
    except SteamError:
        stored_index = None
    if isinstance(stored_index, dict) and stored_index.get("files") == files and stored_index.get("suites") == suites:
        return stored_index  # nothing changed: the index (and who generated the kit) stays as it was
    index = {
        "kit": "steam_ref conformance kit",
        "kit_version": KIT_VERSION,
        "paper": (
            "Yan, Indelman, Boots: Incremental Sparse GP Regression for Continuous-time Trajectory Estimation & Mapping"
        ),
        "generated_by": {
            "steam_ref": _version(),
            "commit": _commit(),
            "numpy": np.__version__,
            "scipy": scipy.__version__,
            "python": platform.python_version(),
        },
        "conventions": CONVENTIONS,
        "convention_alternatives": CONVENTION_ALTERNATIVES,
        "results_layout": RESULTS_LAYOUT,
        "suites": suites,
        "files": files,
    }
    _replace(out / "index.json", lambda name: write_json(name, index))
    return index


def _selftest_suite(kit: Path, suite: str, report: Report) -> None:
    shipped = read_suite(kit, suite)["cases"]
    defined = {c.name: c for c in suite_cases(suite)}
    for name in sorted(set(defined) - {c["name"] for c in shipped}):
        report.outcomes.append(
            Outcome(suite, name, ((np.inf, "defined in cases/ but not in the shipped kit: regenerate it", ()),))
        )
    for case in shipped:
        name, failures = case["name"], []
        mine = defined.get(name)
        if mine is None:
            failures.append((np.inf, "in the shipped kit but no longer defined in cases/: regenerate the kit"))
        elif (_roundtrip(mine.inputs), mine.tolerance, mine.independent) != (
            case["inputs"],
            case["tolerance"],
            case["independent"],
        ):
            failures.append(
                (np.inf, "its inputs, tolerances or provenance in cases/ differ from the shipped kit: regenerate it")
            )
        ours = _roundtrip(run_case(suite, name, case["inputs"]))
        sources = [("steam_ref: ", ours)]
        if case["independent"]:
            sources.append(("oracle: ", _roundtrip(oracle_case(suite, name, case["inputs"]))))
            for key, alt in _roundtrip(oracle_alternatives(suite, case["inputs"])).items():
                shipped_alt = case.get("alternatives", {}).get(key, {})
                for q in sorted(set(alt) | set(shipped_alt)):
                    if q not in alt or q not in shipped_alt:
                        failures.append((np.inf, f"alternative {key}: {q} differs in kind from the shipped kit"))
                        continue
                    tolerance = case["tolerance"][q]
                    failures += [
                        (r, f"oracle, {key}: " + m)
                        for r, m, *_ in compare_quantity(shipped_alt[q], alt[q], tolerance, q)
                    ]
        for prefix, got in sources:
            for q, tolerance in case["tolerance"].items():
                failures += [
                    (r, prefix + m) for r, m, *_ in compare_quantity(case["expected"][q], got.get(q), tolerance, q)
                ]
        report.outcomes.append(Outcome(suite, name, tuple((r, m, ()) for r, m in failures)))


def selftest(
    kit: str | os.PathLike | None = None,
    *,
    paper: bool = False,
    data_dir: str | os.PathLike | None = None,
    progress: bool = False,
) -> Report:
    """Regenerate every case from the kit's inputs with the installed code and check it against the kit
    (``progress``: the paper suite's runs show their bars)."""
    kit = Path(SHIPPED if kit is None else kit)
    read_index(kit)  # version and sha256 of every file
    report = Report()
    for suite in DATA_FREE:
        _selftest_suite(kit, suite, report)
    cases = read_suite(kit, "paper")["cases"]
    if paper:
        results = {
            c["name"]: _roundtrip(run_paper_case(c["name"], c["inputs"], data_dir, progress=progress)) for c in cases
        }
        check_cases("paper", cases, results, report)
    else:
        report.notes.append(
            f"paper suite not run ({', '.join(c['name'] for c in cases)}: two full BTGP/1 runs, about half a minute): "
            "add --paper"
        )
    return report


def shipped_index() -> dict:
    """The shipped kit's index.json (not verified)."""
    return read_json(SHIPPED / "index.json")
