"""``steam-ref conformance``: export the kit, check results against it, check the installed code::

    steam-ref conformance export DIR                      the kit and a README on producing results
    steam-ref conformance check RESULTS_DIR [--paper] [--only SUITE...] [--allow-missing] [--conventions NAME...]
                                            [--kit DIR]
    steam-ref conformance selftest [--paper] [--data-dir DIR]
    steam-ref conformance build [--out DIR] [--paper] [--data-dir DIR]   regenerate the kit

``check`` prints every failing case (each failing quantity with its worst entries, expected and
got; the first in computation order flagged as the likely cause), what had no result, and ends
with ``N passed, N failed``; it exits 0 only when some case passed, none failed and no case of the
gate is missing, unless ``--allow-missing`` (1 otherwise, 2 on bad input). The gate is every data-free
suite of the kit (all but ``paper``, which ``--paper`` adds), or the suites ``--only`` names.
``selftest`` does the same for the installed code. The subcommands' options are
:mod:`steam_ref.cli.parsers.conformance`'s.
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
from pathlib import Path

from ..errors import SteamError
from ..paper.progress import wanted
from .checker import Report
from .gate import check_directory
from .kitio import KIT_VERSION, SHIPPED, SUITES, kit_files, read_index
from .readme import export_readme

__all__ = ["run"]


def _print(report: Report) -> int:
    for line in report.lines():
        print(line)
    return 0 if report.ok else 1


def _export(target: Path) -> int:
    """The kit and its README written to a temporary folder beside ``target``, renamed to it once complete:
    a failure (a full disk, say) leaves no partial kit to block a retry, and says which folder and why."""
    if target.exists() and (not target.is_dir() or any(target.iterdir())):
        raise SteamError(f"export needs a new or empty folder, and {str(target)!r} is not one")
    read_index(SHIPPED)  # refuse to export a damaged kit
    staging = None
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".partial", dir=target.parent))
        for name in [*kit_files(SHIPPED), "index.json"]:  # file by file: the first failure is the one reported
            (staging / "kit" / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(SHIPPED / name, staging / "kit" / name)
        (staging / "kit" / "README.md").write_text(export_readme(), encoding="utf-8")
        os.replace(staging / "kit", target)  # an empty folder is replaced; nothing else can be there
    except OSError as exc:
        raise SteamError(
            f"cannot export the kit to {str(target)!r}: {exc.strerror or exc}; nothing was left there"
        ) from None
    finally:
        if staging is not None:
            shutil.rmtree(staging, ignore_errors=True)
    print(f"wrote the conformance kit v{KIT_VERSION} to {target} (index.json, {len(SUITES)} suites, README.md)")
    return 0


def run(args: argparse.Namespace) -> int:
    """Run a parsed ``steam-ref conformance ...`` command; returns the exit code."""
    command = args.conformance_command
    if command == "export":
        return _export(Path(args.dir))
    if command == "check":
        only = list(args.only or []) + ([args.suite] if args.suite else []) or None
        report = check_directory(
            Path(args.results),
            args.kit,
            only=only,
            allow_missing=args.allow_missing,
            conventions=args.conventions,
            paper=args.paper,
        )
        return _print(report)
    from .build import build_kit, selftest  # the solvers and oracles load only for the commands that use them

    if command == "selftest":
        return _print(selftest(paper=args.paper, data_dir=args.data_dir, progress=wanted(args.progress)))
    index = build_kit(args.out, paper=args.paper, data_dir=args.data_dir)
    counts = ", ".join(f"{s} {v['cases']}" for s, v in index["suites"].items())
    print(f"wrote the conformance kit v{KIT_VERSION} to {args.out or SHIPPED}: {counts} cases")
    return 0
