"""``steam-ref conformance``'s subcommands and options (the command: :mod:`steam_ref.conformance.command`).

Reads the kit's suites and conventions from :mod:`steam_ref.choices` (``kitio.SUITES``, ``gate.CONVENTION_NAMES``),
so that the command's help and a bad argument load none of the kit's machinery, nor NumPy.
"""

from __future__ import annotations

import argparse

from ...choices import CONFORMANCE_CONVENTIONS, CONFORMANCE_SUITES
from ..args import add_data_dir, path
from ..once import SwitchOnce
from ..paths import check_out_folder

__all__ = ["add_parser", "check"]

_path = path("a folder")  # an empty path is refused (args.path)

PAPER_FILES = " (the paper suite's, and their authors/ folder)"  # what --data-dir is searched for


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
    chk.add_argument(
        "--only",
        nargs="+",
        action="extend",  # given twice, both lists: the first was dropped in silence
        choices=CONFORMANCE_SUITES,
        default=None,
        metavar="SUITE",
        help="check these suites only",
    )
    chk.add_argument("--suite", choices=CONFORMANCE_SUITES, default=None, help="the same as --only SUITE (one suite)")
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
        action="extend",  # given twice, both lists
        choices=CONFORMANCE_CONVENTIONS,
        default=[],  # extend copies a list default, never a tuple
        metavar="NAME",
        help="compare convention-dependent quantities under these documented alternatives: "
        + ", ".join(CONFORMANCE_CONVENTIONS),
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
        "--paper", action="store_true", help="also run the paper suite (BTGP/1 on both data sets, about half a minute)"
    )
    add_data_dir(st, PAPER_FILES)  # the one --data-dir of every command (args.folder: an existing folder)
    st.add_argument(
        "--progress",
        action=SwitchOnce,
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
    add_data_dir(bld, PAPER_FILES)
    return conf


def check(args: argparse.Namespace) -> None:
    """Before the kit's machinery loads: ``build --out`` is a folder that exists and can be written, or can be made
    (:func:`~steam_ref.cli.paths.check_out_folder`: a named pipe or a file there is named, not "[Errno 17]")."""
    if args.conformance_command == "build" and args.out is not None:
        check_out_folder(args.out, "--out")
