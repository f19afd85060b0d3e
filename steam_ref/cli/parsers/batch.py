"""``steam-ref batch``'s options (the command: :mod:`steam_ref.cli.batch`), and what it checks before its machinery
loads (:func:`check`)."""

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
    is_rigid,
    preset_of,
)
from ..paths import check_output, check_outputs_apart, check_trajectory_output

__all__ = ["add_parser", "check", "outputs"]


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


def outputs(args: argparse.Namespace) -> dict[str, str | None]:
    """The files a planar ``batch`` writes, by option (None: not asked for)."""
    return {"--plot": args.plot, "--save-trajectory": args.save_trajectory}


def check(args: argparse.Namespace) -> None:
    """What ``batch`` checks before it reads or solves anything, with no solver loaded: a 3-D set's checks are the 3-D
    run's (:func:`steam_ref.cli.rigid.run_rigid`); a planar set's output paths and their being apart, then its preset
    (for a PATH, the data search finds it: a name that is neither a set nor a file is refused here).
    :func:`steam_ref.cli.commands.main` calls it before it loads the command's module, and
    :func:`steam_ref.cli.batch.run` first: each check reads the arguments and the file system only."""
    if is_rigid(args.dataset):
        return
    check_output(args.plot, ".png", "--plot")
    check_trajectory_output(args)
    check_outputs_apart(outputs(args))
    preset_of(args)
