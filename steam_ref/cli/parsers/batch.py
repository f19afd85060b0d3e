"""``steam-ref batch``'s options (the command: :mod:`steam_ref.cli.batch`)."""

from __future__ import annotations

import argparse

from ...choices import BATCH_ORDERINGS, PRESETS
from ..args import (
    Subparsers,
    add_data_dir,
    add_dataset,
    add_max_poses,
    add_progress,
    add_seed,
    add_trajectory_arguments,
)

__all__ = ["add_parser"]


def add_parser(sub: Subparsers) -> argparse.ArgumentParser:
    """Add ``batch`` and its options to the command's subparsers."""
    parser = sub.add_parser(
        "batch",
        help="batch Gauss-Newton on all of a data set (PB or PBVR): RMSE and a plot",
        example="steam-ref batch --dataset paper-synthetic --plot batch.png",
    )
    add_dataset(parser, "paper-synthetic")
    parser.add_argument(
        "--ordering", choices=tuple(BATCH_ORDERINGS), default="amd", help="xl: the paper's PB; amd: PBVR (default amd)"
    )
    parser.add_argument(
        "--preset", choices=PRESETS, default=None, help="parameter set (default: by data set; required for a PATH)"
    )
    add_data_dir(parser)
    add_seed(parser)
    add_max_poses(parser)
    parser.add_argument("--json", action="store_true", help="print one JSON line of figures")
    parser.add_argument("--plot", metavar="FILE.png", default=None, help="draw estimate, ground truth, landmarks")
    add_trajectory_arguments(parser, "; a 3-D set (synthetic-3d, kitti): its poses in 3-D")
    add_progress(parser)
    return parser
