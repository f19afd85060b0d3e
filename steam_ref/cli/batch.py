"""``steam-ref batch``: batch Gauss-Newton on all of a data set (PB or PBVR): RMSE and a plot.

``--max-poses N`` solves the first N poses, as ``steam-ref run`` streams them (:meth:`Readings.prefix
<steam_ref.paper.readings.Readings.prefix>`). A 3-D set (``synthetic-3d``, ``kitti``) is solved on SE(3) by the 3-D
run's code, batch alone (:func:`~steam_ref.cli.rigid.run_rigid`), and ``--save-trajectory`` writes its estimate.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from ..choices import BATCH_ORDERINGS
from ..evaluate import trajectory_figures
from ..paper.presets import PaperSetup
from ..paper.problem import build_problem, sequential_batch
from ..paper.readings import Readings
from ..paper.results import position_rmse
from ..plot.figures import plot_trajectory
from ..variables import X
from . import explain
from .args import is_rigid, preset_of
from .inputs import load_with_note
from .parsers.batch import check, outputs
from .paths import check_outputs_not_inputs, save_trajectory, write_plot
from .rigid import run_rigid
from .streams import json_line

__all__ = ["run"]


def run(args: argparse.Namespace) -> int:
    """Batch solve of a whole data set, or its first ``--max-poses`` (started chunk by chunk, see
    ``sequential_batch``); a 3-D set by :func:`~steam_ref.cli.rigid.run_rigid`."""
    check(args)  # what is checked before anything is read (commands.main made these checks before this module loaded)
    if is_rigid(args.dataset):  # a 3-D set: solved on SE(3) (cli/rigid.py)
        return run_rigid(args, batch_only=True)
    setup = PaperSetup.named(preset_of(args))
    data = load_with_note(args)
    check_outputs_not_inputs(outputs(args), explain.files_of(data.source))
    readings = Readings.from_dataset(data, setup)
    n = readings.n_poses if args.max_poses is None else min(args.max_poses, readings.n_poses)
    problem = build_problem(readings if n == readings.n_poses else readings.prefix(n), setup)
    t0 = time.perf_counter()
    shown = explain.progress_wanted(args.progress, args.json)
    with explain.working(f"{args.dataset} batch ({args.ordering.upper()})", shown):
        result = sequential_batch(problem, ordering=args.ordering)
    seconds = time.perf_counter() - t0
    poses = np.array([result.values[X(i)][:3] for i in range(n)])
    positions = poses[:, :2]
    truth = None if data.ground_truth is None else data.ground_truth[:n, 1:3]
    summary = {
        "dataset": args.dataset,
        "ordering": args.ordering,
        "n_states": len(problem.states),
        "rmse_m": None if truth is None else round(position_rmse(positions, truth), 6),
        "total_s": round(seconds, 3),
        "iterations": len(result.iterations),
        "factor_nnz": result.factor_nnz,
        "backend": result.backend,
    } | explain.data_figures(data, n)
    if data.ground_truth is not None:
        summary["evaluation"] = trajectory_figures(data.ground_truth[:n, 1:4], poses)
    written = save_trajectory(args, np.asarray(data.times)[:n], poses)
    where = "" if args.json else written
    if args.plot:
        where += write_plot(
            args,
            lambda name: plot_trajectory(
                truth,
                positions,
                landmarks_true=data.landmarks[:, 1:3] if len(data.landmarks) else None,
                landmarks_estimated={k.index: result.values[k][:2] for k in result.values.landmarks()},
                estimate_label=f"{BATCH_ORDERINGS[args.ordering]} estimate",
                title=explain.plot_title(summary, n, readings.n_poses),
                path=name,
            ),
        )
    if args.json:
        print(json_line(summary))
    else:
        print(
            f"batch {BATCH_ORDERINGS[args.ordering]} ({args.ordering.upper()} ordering) on {args.dataset}: "
            f"{summary['n_states']} states, solved in {summary['total_s']:.2f} s ({summary['iterations']} "
            f"iterations), Cholesky factor {summary['factor_nnz']} nonzeros ({summary['backend']})\n"
            + explain.data_lines(summary)
            + explain.rmse_text(summary["rmse_m"], n)
            + explain.evaluation_note(summary)
            + where
        )
    return 0
