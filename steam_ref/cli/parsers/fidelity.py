"""``steam-ref fidelity``'s options (the command: :mod:`steam_ref.cli.fidelity`)."""

from __future__ import annotations

import argparse

from ...datasets.registry import with_authors_run
from ..args import Subparsers, add_data_dir, add_progress

__all__ = ["add_parser"]


def add_parser(sub: Subparsers) -> argparse.ArgumentParser:
    """Add ``fidelity`` and its options to the command's subparsers."""
    parser = sub.add_parser(
        "fidelity",
        help="BTGP/1 against the authors' saved runs, pose by pose, covariances included",
        example="steam-ref fidelity --dataset paper-synthetic",
    )
    parser.add_argument(
        "--dataset",
        choices=[*with_authors_run(), "all"],
        default="all",
        help="the data set whose saved run is compared (default all)",
    )
    add_data_dir(parser, " (and its authors/ folder)")
    parser.add_argument("--json", action="store_true", help="print one JSON line per data set")
    parser.add_argument(
        "--plot", metavar="FILE.png", default=None, help="draw the per-pose distance to the authors' estimate"
    )
    add_progress(parser)
    return parser
