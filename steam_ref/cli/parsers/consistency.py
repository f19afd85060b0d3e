"""``steam-ref consistency``'s options (the command: :mod:`steam_ref.cli.consistency`)."""

from __future__ import annotations

import argparse
import math

from ...choices import CONSISTENCY_STUDIES, RESIDUALS
from ..args import (
    MAX_JOBS,
    Subparsers,
    add_progress,
    jobs_count,
    landmarks_count,
    non_negative_int,
    scale,
    seeds_count,
    steps_count,
)

__all__ = ["add_parser"]


def add_parser(sub: Subparsers) -> argparse.ArgumentParser:
    """Add ``consistency`` and its options to the command's subparsers."""
    parser = sub.add_parser(
        "consistency",
        help="ANEES of each estimator over Monte Carlo runs, with its band",
        example="steam-ref consistency --seeds 20 --jobs 2",
    )
    parser.add_argument("--dataset", choices=("synthetic",), default="synthetic", help="tasks drawn from the model")
    parser.add_argument(
        "--prior",
        choices=CONSISTENCY_STUDIES,
        default="wnoa",
        help="the model the tasks are drawn from and the estimators assume: the paper's WNOA, WNOA on SE(2) "
        "(then the estimators are batch, btgp/1 and btgp/1 with the vector-space prior), or WNOA or WNOJ on SE(3) "
        "(3-D tasks; batch and btgp; NEES of each state's pose and twist)",
    )
    parser.add_argument(
        "--se2-residual", choices=RESIDUALS, default=None, help="--prior se2: the model's residual (local-variable)"
    )
    parser.add_argument(
        "--turn",
        type=scale(-math.pi, math.pi, "a yaw rate in rad a step"),  # the one rule for numbers; ±π: cli.consistency
        default=None,
        help="--prior se2: the task's yaw rate at the start, rad a step (default 0; 1.0 is the fast-turning task)",
    )
    parser.add_argument("--seeds", type=seeds_count, default=200, help="Monte Carlo runs (default %(default)s)")
    parser.add_argument("--seed", type=non_negative_int, default=0, help="root of the seeds (SeedSequence(seed).spawn)")
    parser.add_argument("--steps", type=steps_count, default=40, help="time steps of a task (default %(default)s)")
    parser.add_argument(
        "--landmarks", type=landmarks_count, default=8, help="landmarks of a task (default %(default)s)"
    )
    parser.add_argument(
        "--jobs", type=jobs_count, default=1, help=f"worker processes, 1 to {MAX_JOBS} (default %(default)s)"
    )
    parser.add_argument("--backend", choices=("loky", "dask"), default="loky", help="joblib's loky processes, or Dask")
    parser.add_argument(
        "--scheduler", default=None, help="Dask scheduler address (default: a LocalCluster on 127.0.0.1)"
    )
    logs = parser.add_mutually_exclusive_group()
    logs.add_argument("--log", metavar="FILE.jsonl", default=None, help="stream each run's NEES to a new file")
    logs.add_argument("--resume", metavar="FILE.jsonl", default=None, help="continue this file (or start it)")
    parser.add_argument("--json", action="store_true", help="print one JSON line of figures")
    parser.add_argument("--plot", metavar="FILE.png", default=None, help="ANEES pose by pose against its band")
    add_progress(parser)
    return parser
