"""``steam-ref reproduce``: the experiments of Fig. 3 and Fig. 4, plots and a results table."""

from __future__ import annotations

import argparse

from ..errors import SteamError
from ..paper.experiments import reproduce
from . import explain
from .args import MAX_JOBS, Subparsers, add_data_dir, add_progress, jobs_count
from .paths import check_out_folder

__all__ = ["add_parser", "run"]


def add_parser(sub: Subparsers) -> argparse.ArgumentParser:
    """Add ``reproduce`` and its options to the command's subparsers."""
    parser = sub.add_parser(
        "reproduce",
        help="the experiments of Fig. 3 and Fig. 4, plots and a results table",
        example="steam-ref reproduce --quick --out reproduced/",
    )
    parser.add_argument("--quick", action="store_true", help="small prefixes and budgets: minutes, not hours")
    parser.add_argument("--out", default="reproduced", help="folder for plots and the table (default: reproduced)")
    add_data_dir(parser)
    parser.add_argument(
        "--jobs",
        type=jobs_count,
        default=1,
        help=f"accuracy runs in parallel, 1 to {MAX_JOBS} (timing runs stay serial, each in a fresh process)",
    )
    add_progress(parser)
    return parser


def run(args: argparse.Namespace) -> int:
    """Run the experiments, write the plots and the table, print the table."""
    check_out_folder(args.out, "--out")
    try:
        shown = explain.progress_wanted(args.progress, False)
        table = reproduce(args.out, quick=args.quick, data_dir=args.data_dir, jobs=args.jobs, progress=shown)
    except OSError as err:  # a full disk while writing the plots or the table
        raise SteamError(f"--out: cannot write {err.filename or args.out!r} ({err.strerror or err})") from None
    print(table)
    return 0
