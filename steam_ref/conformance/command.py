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
``selftest`` does the same for the installed code.
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
from pathlib import Path

from ..datasets.search import data_dir_help
from ..errors import SteamError
from ..paper.progress import wanted
from .checker import Report
from .gate import CONVENTION_NAMES, check_directory
from .kitio import KIT_VERSION, SHIPPED, SUITES, kit_files, read_index
from .readme import export_readme

__all__ = ["add_parser", "run"]

PAPER_FILES = " (the paper suite's, and their authors/ folder)"  # what --data-dir is searched for


def _path(text: str) -> str:
    """An argparse type: a path that is not empty (``Path("")`` is the working folder, which no one means)."""
    if not text.strip():
        raise argparse.ArgumentTypeError(f"expected a folder, got an empty path {text!r}")
    return text


def _data_dir(text: str) -> str:
    """An argparse type: a folder that exists (a mistyped --data-dir must not be passed over in silence)."""
    if not text.strip() or not Path(text).is_dir():
        what = "an empty string" if not text.strip() else "not a folder" if Path(text).exists() else "does not exist"
        raise argparse.ArgumentTypeError(f"expected a folder, got {text!r}: {what}")
    return text


def add_parser(sub) -> argparse.ArgumentParser:
    """Add ``conformance`` and its subcommands to ``sub`` (an argparse subparsers object)."""
    conf = sub.add_parser(
        "conformance",
        help="the conformance kit: export it, check results against it, check this install",
        example="steam-ref conformance selftest",
    )
    commands = conf.add_subparsers(
        dest="conformance_command", parser_class=type(conf), required=True, metavar="{export,check,selftest,build}"
    )
    exp = commands.add_parser(
        "export",
        help="write the kit (inputs, expected outputs, conventions) and a README to DIR",
        example="steam-ref conformance export kit/",
    )
    exp.add_argument("dir", metavar="DIR", type=_path, help="a new or empty folder")
    chk = commands.add_parser(
        "check",
        help="compare results laid out like the kit with its expected values",
        example="steam-ref conformance check results/ --allow-missing",
    )
    chk.add_argument("results", metavar="RESULTS_DIR", type=_path, help="a folder with <suite>/results.json")
    chk.add_argument("--only", nargs="+", choices=SUITES, default=None, metavar="SUITE", help="check these suites only")
    chk.add_argument("--suite", choices=SUITES, default=None, help="the same as --only SUITE (one suite)")
    chk.add_argument(
        "--paper",
        action="store_true",
        help="also check the paper suite (the paper's runs; needs its data files to compute): by default every "
        "other suite of the kit is the gate",
    )
    chk.add_argument(
        "--allow-missing",
        action="store_true",
        help="cases without a result are listed, not a failure (a check in which no case passed still fails)",
    )
    chk.add_argument(
        "--conventions",
        nargs="+",
        choices=CONVENTION_NAMES,
        default=(),
        metavar="NAME",
        help="compare convention-dependent quantities under these documented alternatives: "
        + ", ".join(CONVENTION_NAMES),
    )
    chk.add_argument(
        "--kit",
        type=_path,
        default=None,
        help="check against this exported kit (default: the shipped kit of the results' version)",
    )
    st = commands.add_parser(
        "selftest",
        help="regenerate every case with the installed code and check it against the shipped kit",
        example="steam-ref conformance selftest",
    )
    st.add_argument(
        "--paper", action="store_true", help="also run the paper suite (BTGP/1 on both data sets, about a minute)"
    )
    st.add_argument("--data-dir", type=_data_dir, default=None, help=data_dir_help(PAPER_FILES))
    st.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="the paper suite's progress bars on stderr (default: on when stderr is a terminal)",
    )
    bld = commands.add_parser(
        "build",
        help="regenerate the kit (default: the package's own copy)",
        example="steam-ref conformance build --out rebuilt-kit/",
    )
    bld.add_argument("--out", type=_path, default=None, help="write the kit here instead of into the package")
    bld.add_argument(
        "--paper", action="store_true", help="rebuild the paper suite from the data files (else keep the existing one)"
    )
    bld.add_argument("--data-dir", type=_data_dir, default=None, help=data_dir_help(PAPER_FILES))
    return conf


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
