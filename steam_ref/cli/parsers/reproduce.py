"""``steam-ref reproduce``'s options (the command: :mod:`steam_ref.cli.reproduce`)."""

from __future__ import annotations

import argparse

from ..args import MAX_JOBS, Subparsers, add_data_dir, add_progress, jobs_count

__all__ = ["add_parser"]


def add_parser(sub: Subparsers) -> argparse.ArgumentParser:
    """Add ``reproduce`` and its options to the command's subparsers."""
    parser = sub.add_parser(
        "reproduce",
        help="the experiments of Fig. 3 and Fig. 4, plots and a results table",
        example="steam-ref reproduce --quick --out reproduced/",
    )
    parser.add_argument(
        "--quick", action="store_true", help="1,000-pose prefixes and 20 s budgets (the full run takes about 30 min)"
    )
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
