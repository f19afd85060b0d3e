"""The ``steam-ref`` command: stream a data set through BTGP, PB or PBVR, or reproduce Fig. 3/4.

Usage::

    steam-ref run [--dataset NAME_OR_PATH] [--method {btgp,pb,pbvr}] [--every N] [--skip K]
                  [--interpolate/--no-interpolate] [--preset {synthetic,plaza,victoria-park}] [--data-dir DIR]
                  [--converge-at-end] [--json] [--save-estimates FILE.npz] [--plot FILE.png]
                  [--lag SECONDS] [--steps N]
    steam-ref batch [--dataset NAME_OR_PATH] [--ordering {xl,amd}] [--json] [--plot FILE.png]
    steam-ref fidelity [--dataset {plaza,paper-synthetic,all}] [--json] [--plot FILE.png]
    steam-ref reproduce [--quick] [--out DIR] [--jobs N]
    steam-ref consistency [--seeds N] [--jobs N] [--backend loky|dask] [--json] [--plot FILE.png] ...
    steam-ref conformance {export DIR, check RESULTS_DIR [--only SUITE...], selftest [--paper], build}

Every command that can run longer than a few seconds shows its progress on stderr when that is a terminal
(``--progress`` / ``--no-progress``: :mod:`steam_ref.paper.progress`), and every command runs the solvers at
one BLAS thread unless ``$STEAM_REF_BLAS_THREADS`` says otherwise (:mod:`steam_ref.linear.threads`).
With no options ``steam-ref run`` runs BTGP/1 on the generated synthetic task. A data set without
ground truth (victoria-park) is not scored unless ``--score-against-optimum`` asks for the converged
batch solution of the same problem (:func:`~steam_ref.paper.problem.score_against_batch`) instead of an RMSE. Bad arguments and missing or
malformed data files give a one-line error and exit code 2.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from ..conformance import command as conformance_command
from ..datasets import LandmarkDataset, RangeDataset, generate_synthetic, load_dataset, load_range_dataset
from ..errors import SteamError, UncleanedDataWarning
from ..evaluate import trajectory_figures, write_kitti, write_tum
from ..linear.threads import limit
from ..paper.experiments import reproduce
from ..paper.fidelity import AUTHORS_RUNS, compare, find_authors_file, load_authors_run
from ..paper.online import StreamingEstimator, run_online
from ..paper.options import StreamOptions
from ..paper.presets import PRESETS, PaperSetup
from ..paper.problem import build_problem, score_against_batch, sequential_batch
from ..paper.readings import Readings
from ..paper.results import position_rmse
from ..paper.solvers import BayesTreeSolver
from ..plot.figures import plot_fidelity, plot_trajectory
from ..variables import X
from . import consistency as consistency_command
from . import data as data_command
from . import explain
from .args import build_parser
from .paths import check_out_folder as _check_out_folder
from .paths import check_output as _check_output
from .paths import check_outputs_apart as _check_outputs_apart
from .paths import write_output as _write_output
from .streams import json_line, one_line, quiet_stdout

__all__ = ["main", "build_parser"]  # build_parser lives in cli/args.py

DEFAULT_STEPS, DEFAULT_LANDMARKS = 1500, 298  # generate_synthetic's defaults: a landmark every ~5 steps
_PRESET_OF = {
    "synthetic": "synthetic",
    "paper-synthetic": "synthetic",
    "plaza": "plaza",
    "plaza2": "plaza",
    "victoria-park": "victoria-park",
}


def _check_trajectory_output(args: argparse.Namespace) -> None:
    """--save-trajectory FILE checked before the run; --trajectory-format needs it (alone it would do nothing)."""
    _check_output(args.save_trajectory, "", "--save-trajectory")
    if args.trajectory_format is not None and args.save_trajectory is None:
        raise SteamError(
            f"--trajectory-format {args.trajectory_format} is the format of --save-trajectory FILE: give it"
        )


def _save_trajectory(args: argparse.Namespace, times: np.ndarray, poses: np.ndarray) -> None:
    """--save-trajectory: the poses (n, 3) at the data set's times, as TUM or KITTI."""
    if args.save_trajectory:
        if args.trajectory_format == "kitti":
            _write_output(args.save_trajectory, "--save-trajectory", lambda name: write_kitti(name, poses))
        else:
            _write_output(args.save_trajectory, "--save-trajectory", lambda name: write_tum(name, times, poses))


def _run(args: argparse.Namespace) -> int:
    _check_output(args.save_estimates, ".npz", "--save-estimates")
    _check_trajectory_output(args)
    _check_output(args.plot, ".png", "--plot")
    _check_output(args.tree_dot, ".dot", "--tree-dot")
    _check_outputs_apart(
        {
            "--save-estimates": args.save_estimates,
            "--save-trajectory": args.save_trajectory,
            "--plot": args.plot,
            "--tree-dot": args.tree_dot,
        }
    )
    if args.tree_dot and args.method != "btgp":
        raise SteamError(f"--tree-dot writes BTGP's Bayes tree: it needs --method btgp, got --method {args.method}")
    setup = PaperSetup.named(_preset(args)).departing(*args.departure)
    prior = setup.prior if args.prior is None else args.prior
    given = {"prior": args.prior, "singer_time_constant": args.singer_time_constant, "se2_residual": args.se2_residual}
    for name, owner in (("singer_time_constant", "singer"), ("se2_residual", "se2")):  # only what was given
        if given[name] is not None and prior != owner:
            raise SteamError(f"--{name.replace('_', '-')} applies to --prior {owner} only, not --prior {prior}")
    setup = setup.replace(qc=args.qc_scale * setup.qc, **{k: v for k, v in given.items() if v is not None})
    isam2 = {"relinearize_threshold": args.relinearize_threshold, "relinearize_skip": args.relinearize_skip}
    if any(v is not None for v in isam2.values()):  # only what was given: the preset owns its iSAM2 settings
        setup = setup.with_isam2(**{k: v for k, v in isam2.items() if v is not None})
    if args.every is not None:
        setup = setup.with_schedule(every=args.every)
    options = StreamOptions(
        method=args.method,
        skip=args.skip,
        interpolate=args.interpolate,
        range_states=args.range_states,
        max_poses=args.max_poses,
        time_budget_s=args.time_budget,
        progress=explain.progress_wanted(args.progress, args.json),
        converge_at_end=args.converge_at_end,
        lag=args.lag,
        lag_history=args.lag_history,
    )
    if args.lag is not None and args.save_estimates is not None:
        raise SteamError("--save-estimates writes every marginal covariance, which --lag forgets: drop one of them")
    if args.lag is not None and args.score_against_optimum:
        raise SteamError(
            "--score-against-optimum compares every state and landmark with the batch optimum, and --lag forgets "
            "the old ones: drop one of them"
        )
    data = _run_dataset(args)
    if args.score_against_optimum and data.ground_truth is not None:
        raise SteamError(
            f"--score-against-optimum: {args.dataset!r} has ground truth, and is scored by RMSE against it"
        )
    estimator = StreamingEstimator(Readings.from_dataset(data, setup), setup, options, name=args.dataset)
    result = estimator.run(data.ground_truth, covariances=args.save_estimates is not None)
    n = len(result.times)
    # the run's own files first: nothing computed from them after (scores, figures) can lose them
    if args.save_estimates:
        _write_output(
            args.save_estimates, "--save-estimates", lambda name: save_estimates(name, result, se2=setup.is_se2)
        )
    if args.tree_dot and isinstance(estimator.solver, BayesTreeSolver):  # GTSAM's ISAM2.dot() text (bayes_tree/dot.py)
        dot = estimator.solver.inner.tree.dot() + "\n"
        _write_output(args.tree_dot, "--tree-dot", lambda name: Path(name).write_text(dot, encoding="utf-8"))
    _save_trajectory(args, result.times, result.trajectory[:, :3])  # --save-estimates' clock: the data's seconds
    summary = result.summary(args.dataset) | {
        "preset": setup.name,
        "score_against_optimum": args.score_against_optimum,
        "departures": args.departure,
        "prior": setup.prior,
        **({"se2_residual": setup.se2_residual} if setup.is_se2 else {}),
        "qc_scale": args.qc_scale,
        "clock": estimator.readings.clock.describe(),
    }
    summary |= {"what": explain.method_text(args.method, result.schedule.every)}
    summary |= explain.data_figures(data, len(result.times))
    if data.ground_truth is None and not args.score_against_optimum:
        summary["score"] = (
            "none: the data set has no ground truth; --score-against-optimum scores it against the converged batch optimum"
        )
    summary |= result.lag_summary()
    score = None
    if data.ground_truth is None and args.score_against_optimum:  # minutes on Victoria Park
        with explain.working("scoring against the batch optimum", options.progress):
            score = score_against_batch(result, Readings.from_dataset(data, setup), setup)
    if score is not None:
        summary |= score.summary()
    if data.ground_truth is not None and n:  # APE, RPE beside the RMSE (evaluate.trajectory_figures)
        summary["evaluation"] = trajectory_figures(data.ground_truth[:n, 1:4], result.trajectory[:, :3])
    where = ""
    if args.plot:
        reference: np.ndarray | None
        if score is not None:
            reference = np.array([score.batch.values[X(int(i))][:2] for i in score.poses])
        else:
            reference = None if data.ground_truth is None else data.ground_truth[:, 1:3]
        where = _write_plot(
            args,
            lambda name: plot_trajectory(
                reference,
                result.trajectory[:, :2],
                landmarks_true=data.landmarks[:, 1:3] if len(data.landmarks) else None,
                landmarks_estimated=result.landmarks,
                dead_reckoning=data.dead_reckoning[:, 1:3],
                estimate_label=f"{result.method.upper()} estimate",
                truth_label="ground truth" if score is None else "batch optimum",
                title=explain.plot_title(summary),
                path=name,
            ),
        )
    # printed last: the files are written even when stdout is a pipe its reader closed (`| head`)
    print(json_line(summary) if args.json else explain.run_text(summary) + explain.evaluation_note(summary) + where)
    return 0


def _preset(args: argparse.Namespace) -> str:
    """The preset a command runs with: --preset, else the named data set's; a data file given by PATH needs
    --preset (each preset changes what is done to the file: Plaza's fits a range correction to its truth)."""
    if args.preset is not None:
        return args.preset
    if args.dataset not in _PRESET_OF:
        raise SteamError(
            f"--dataset {args.dataset!r} is a path: say which parameters it runs with, --preset {{{','.join(PRESETS)}}} "
            "(plaza also fits a range correction to the file's own ground truth)"
        )
    return _PRESET_OF[args.dataset]


def _load_with_note(args: argparse.Namespace) -> RangeDataset | LandmarkDataset:
    """``--dataset`` loaded for a command whose summary says what it read: its NOTE line says uncleaned Plaza data
    (explain.data_lines), so load_dataset's UncleanedDataWarning would only repeat it."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UncleanedDataWarning)
        return load_dataset(args.dataset, data_dir=args.data_dir, seed=args.seed)


def _run_dataset(args: argparse.Namespace):
    """The data set of ``run``: by name or path, or the generated task of ``--steps`` steps."""
    if args.steps is None:
        return _load_with_note(args)
    if args.dataset != "synthetic":
        raise SteamError(f"--steps generates the synthetic task: it needs --dataset synthetic, got {args.dataset!r}")
    n_landmarks = max(1, round(args.steps * DEFAULT_LANDMARKS / DEFAULT_STEPS))  # the default task's density
    return generate_synthetic(n_steps=args.steps, n_landmarks=n_landmarks, seed=args.seed)


def save_estimates(path: str, result, *, se2: bool = False) -> None:
    """Write a run to an .npz file: ``times`` (the data set's seconds, as ``--save-trajectory``), ``x``, ``y``, ``theta``
    and ``xdot``, ``ydot``, ``thetadot`` (rates per unit of the model's clock: per pose step on a 'pose-index' clock,
    per second on 'seconds') at every covered time step (and ``xddot``, ``yddot``, ``thetaddot`` with a WNOJ or Singer
    prior; with ``se2``, SE(2) states: the body twist ``vx``, ``vy``, ``omega``, covariances in the right tangent,
    the pose block in the body frame), ``state_poses`` (pose indices with a state), ``landmark_ids`` and ``landmarks``
    (m, 2), and, when the run has them, the final marginal covariances ``pose_covariance`` (n, 3, 3),
    ``velocity_covariance`` (n, 3, 3) and ``landmark_covariance`` (m, 2, 2), in the order of ``times`` and ids."""
    ids = np.array(sorted(result.landmarks), dtype=int)
    marks = np.array([result.landmarks[i] for i in ids]).reshape(-1, 2)
    tr = result.trajectory
    arrays = dict(
        times=result.times,
        x=tr[:, 0],
        y=tr[:, 1],
        theta=tr[:, 2],
        **dict(zip(("vx", "vy", "omega") if se2 else ("xdot", "ydot", "thetadot"), tr[:, 3:6].T, strict=True)),
        state_poses=result.state_poses,
        landmark_ids=ids,
        landmarks=marks,
    )
    if tr.shape[1] == 9:
        arrays.update(xddot=tr[:, 6], yddot=tr[:, 7], thetaddot=tr[:, 8])
    if result.covariances is not None:
        c = result.covariances
        landmark_covariance = c.landmark[[c.landmark_ids.index(i) for i in ids]].reshape(-1, 2, 2)
        arrays.update(pose_covariance=c.pose, velocity_covariance=c.velocity, landmark_covariance=landmark_covariance)
    np.savez(path, **arrays)


def _batch(args: argparse.Namespace) -> int:
    """Batch solve of a whole data set (started chunk by chunk, see ``sequential_batch``)."""
    _check_output(args.plot, ".png", "--plot")
    _check_trajectory_output(args)
    _check_outputs_apart({"--plot": args.plot, "--save-trajectory": args.save_trajectory})
    setup = PaperSetup.named(_preset(args))
    data = _load_with_note(args)
    problem = build_problem(data, setup)
    t0 = time.perf_counter()
    shown = explain.progress_wanted(args.progress, args.json)
    with explain.working(f"{args.dataset} batch ({args.ordering.upper()})", shown):
        result = sequential_batch(problem, ordering=args.ordering)
    seconds = time.perf_counter() - t0
    poses = np.array([result.values[X(i)][:3] for i in range(data.n_poses)])
    positions = poses[:, :2]
    truth = None if data.ground_truth is None else data.ground_truth[:, 1:3]
    summary = {
        "dataset": args.dataset,
        "ordering": args.ordering,
        "n_states": len(problem.states),
        "rmse_m": None if truth is None else round(position_rmse(positions, truth), 6),
        "total_s": round(seconds, 3),
        "iterations": len(result.iterations),
        "factor_nnz": result.factor_nnz,
        "backend": result.backend,
    } | explain.data_figures(data, data.n_poses)
    if data.ground_truth is not None:
        summary["evaluation"] = trajectory_figures(data.ground_truth[:, 1:4], poses)
    _save_trajectory(args, np.asarray(data.times), poses)
    where = ""
    if args.plot:
        where = _write_plot(
            args,
            lambda name: plot_trajectory(
                truth,
                positions,
                landmarks_true=data.landmarks[:, 1:3] if len(data.landmarks) else None,
                title=f"batch on {args.dataset}",
                path=name,
            ),
        )
    if args.json:
        print(json_line(summary))
    else:
        print(
            f"batch {_BATCH_NAME[args.ordering]} ({args.ordering.upper()} ordering) on {args.dataset}: "
            f"RMSE {summary['rmse_m']} m over {data.n_poses} poses, "
            f"{summary['total_s']:.2f} s, Cholesky factor {summary['factor_nnz']} nonzeros ({summary['backend']})\n"
            + explain.data_lines(summary)
            + explain.evaluation_note(summary)
            + where
        )
    return 0


_BATCH_NAME = {"xl": "PB", "amd": "PBVR"}  # the paper's names of a batch solve by its ordering [YIB Sec. IV]


def _write_plot(args: argparse.Namespace, draw: Callable[[str], object]) -> str:
    """Write ``--plot`` by ``draw(name)``; the line saying where it went, printed after the figures ("" with
    ``--json``: its one line is the figures)."""
    _write_output(args.plot, "--plot", draw)
    return "" if args.json else f"\nplot written to {os.path.abspath(args.plot)}"


def _fidelity(args: argparse.Namespace) -> int:
    """BTGP/1 with the paper's set-up against the authors' saved run of each data set."""

    _check_output(args.plot, ".png", "--plot")
    distances = {}
    for name in AUTHORS_RUNS if args.dataset == "all" else [args.dataset]:
        find_authors_file(name, args.data_dir)  # before loading: gtsam's Plaza files are not the authors' data
        data = load_range_dataset(name, data_dir=args.data_dir)
        authors = load_authors_run(name, data, args.data_dir)
        setup = PaperSetup.named(_PRESET_OF[name])
        options = StreamOptions(progress=explain.progress_wanted(args.progress, args.json))
        result = run_online(data, setup, options, covariances=authors.pose_covariance is not None)
        fid, distances[name] = compare(result, authors, data.ground_truth)
        row = fid.to_dict() | {
            "total_s": round(result.total_s, 2),
            "authors_total_s": round(float(authors.step_seconds.sum()), 2),
            "data_files": explain.data_figures(data, 0)["data_files"]
            + [explain.file_entry(find_authors_file(name, args.data_dir))],
        }
        print(
            json_line(row)
            if args.json
            else explain.fidelity_text(row) + "\n" + explain.data_lines(row | {"data_note": None})
        )
    if args.plot:
        where = _write_plot(args, lambda name: plot_fidelity(distances, path=name))
        if where:
            print(where.strip())
    return 0


def _reproduce(args: argparse.Namespace) -> int:
    _check_out_folder(args.out, "--out")
    try:
        shown = explain.progress_wanted(args.progress, False)
        table = reproduce(args.out, quick=args.quick, data_dir=args.data_dir, jobs=args.jobs, progress=shown)
    except OSError as err:  # a full disk while writing the plots or the table
        raise SteamError(f"--out: cannot write {err.filename or args.out!r} ({err.strerror or err})") from None
    print(table)
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``steam-ref`` console script; returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        args = build_parser().parse_args(argv or ["run"])  # no command at all runs the main job
        commands = {
            "run": _run,
            "batch": _batch,
            "fidelity": _fidelity,
            "reproduce": _reproduce,
            "conformance": conformance_command.run,
            "data": data_command.run,
            "consistency": consistency_command.run,
        }
        with limit():  # the solvers' small dense algebra at one BLAS thread unless $STEAM_REF_BLAS_THREADS says
            return commands[args.command](args)
    except BrokenPipeError:  # stdout's reader went away (`| head`): what it read is all it wanted
        quiet_stdout()
        return 141  # 128 + SIGPIPE, as a shell reports a command stopped by a closed pipe
    except MemoryError as exc:  # NumPy's names a size, Python's nothing
        print(f"steam-ref: error: out of memory{f' ({one_line(str(exc))})' if str(exc) else ''}", file=sys.stderr)
        return 2
    except (SteamError, OSError) as exc:
        print(f"steam-ref: error: {one_line(str(exc))}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("steam-ref: interrupted", file=sys.stderr)
        return 130
