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

With no options ``steam-ref run`` runs BTGP/1 on the generated synthetic task. A data set without
ground truth (victoria-park) is not scored unless ``--score-against-optimum`` asks for the converged
batch solution of the same problem (:func:`~steam_ref.paper.problem.score_against_batch`) instead of an RMSE. Bad arguments and missing or
malformed data files give a one-line error and exit code 2.
"""

from __future__ import annotations

import argparse
import json
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
from .paths import write_output as _write_output

__all__ = ["main", "build_parser"]  # build_parser lives in cli/args.py

DEFAULT_STEPS, DEFAULT_LANDMARKS = 1500, 298  # generate_synthetic's defaults: a landmark every ~5 steps
_PRESET_OF = {
    "synthetic": "synthetic",
    "paper-synthetic": "synthetic",
    "plaza": "plaza",
    "plaza2": "plaza",
    "victoria-park": "victoria-park",
}


def _save_trajectory(args: argparse.Namespace, times: np.ndarray, poses: np.ndarray) -> None:
    """--save-trajectory: the poses (n, 3) at the data set's times, as TUM or KITTI."""
    if args.save_trajectory:
        if args.trajectory_format == "kitti":
            _write_output(args.save_trajectory, "--save-trajectory", lambda name: write_kitti(name, poses))
        else:
            _write_output(args.save_trajectory, "--save-trajectory", lambda name: write_tum(name, times, poses))


def _run(args: argparse.Namespace) -> int:
    _check_output(args.save_estimates, ".npz", "--save-estimates")
    _check_output(args.save_trajectory, "", "--save-trajectory")
    _check_output(args.plot, ".png", "--plot")
    _check_output(args.tree_dot, ".dot", "--tree-dot")
    if args.tree_dot and args.method != "btgp":
        raise SteamError(f"--tree-dot writes BTGP's Bayes tree: it needs --method btgp, got --method {args.method}")
    setup = PaperSetup.named(_preset(args)).departing(*args.departure)
    prior = setup.prior if args.prior is None else args.prior
    if args.singer_time_constant is not None and prior != "singer":
        raise SteamError(f"--singer-time-constant applies to --prior singer only, not --prior {prior}")
    if args.se2_residual is not None and prior != "se2":
        raise SteamError(f"--se2-residual applies to --prior se2 only, not --prior {prior}")
    given = {"prior": args.prior, "singer_time_constant": args.singer_time_constant, "se2_residual": args.se2_residual}
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
    data = _run_dataset(args)
    if args.score_against_optimum and data.ground_truth is not None:
        raise SteamError(
            f"--score-against-optimum: {args.dataset!r} has ground truth, and is scored by RMSE against it"
        )
    estimator = StreamingEstimator(Readings.from_dataset(data, setup), setup, options)
    result = estimator.run(data.ground_truth, covariances=args.save_estimates is not None)
    summary = result.summary(args.dataset) | {
        "preset": setup.name,
        "score_against_optimum": args.score_against_optimum,
        "departures": args.departure,
        "prior": setup.prior,
        **({"se2_residual": setup.se2_residual} if setup.is_se2 else {}),
        "qc_scale": args.qc_scale,
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
    n = len(result.times)
    if data.ground_truth is not None and n:  # APE, RPE beside the RMSE (evaluate.trajectory_figures)
        summary["evaluation"] = trajectory_figures(data.ground_truth[:n, 1:4], result.trajectory[:, :3])
    if args.json:
        print(json.dumps(summary))
    else:
        print(explain.run_text(summary) + _evaluation_note(summary))
    if args.save_estimates:
        _write_output(
            args.save_estimates, "--save-estimates", lambda name: save_estimates(name, result, se2=setup.is_se2)
        )
    if args.tree_dot and isinstance(estimator.solver, BayesTreeSolver):  # GTSAM's ISAM2.dot() text (bayes_tree/dot.py)
        dot = estimator.solver.inner.tree.dot() + "\n"
        _write_output(args.tree_dot, "--tree-dot", lambda name: Path(name).write_text(dot, encoding="utf-8"))
    _save_trajectory(args, np.asarray(data.times)[:n], result.trajectory[:, :3])
    if args.plot:
        reference: np.ndarray | None
        if score is not None:
            reference = np.array([score.batch.values[X(int(i))][:2] for i in score.poses])
        else:
            reference = None if data.ground_truth is None else data.ground_truth[:, 1:3]
        _write_plot(
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


def _evaluation_note(summary: dict) -> str:
    """APE (unaligned and SE(2)-aligned) and RPE over one pose, for the human-readable summary."""
    e = summary.get("evaluation")
    if not e:
        return ""
    rpe = f", RPE/1 {e['rpe']['translation_m']['rmse']:.4g} m" if "rpe" in e else ""
    aligned = f" ({e['ape_se2']['translation_m']['rmse']:.4g} m SE(2)-aligned)" if "ape_se2" in e else ""
    return (
        f"\n  APE RMSE {e['ape']['translation_m']['rmse']:.4g} m{aligned}, "
        f"heading {e['ape']['heading_rad']['rmse']:.4g} rad{rpe}"
    )


def save_estimates(path: str, result, *, se2: bool = False) -> None:
    """Write a run to an .npz file: ``times``, ``x``, ``y``, ``theta`` and ``xdot``, ``ydot``,
    ``thetadot`` at every covered time step (and ``xddot``, ``yddot``, ``thetaddot`` with a WNOJ or Singer
    prior), ``state_poses`` (pose indices with a state),
    ``landmark_ids`` and ``landmarks`` (m, 2), and, when the run has them, the final marginal
    covariances ``pose_covariance`` (n, 3, 3), ``velocity_covariance`` (n, 3, 3) and
    ``landmark_covariance`` (m, 2, 2), in the order of ``times`` and ``landmark_ids``. With ``se2`` (SE(2)
    states) the rates are the body twist ``vx``, ``vy``, ``omega`` and the covariances those of the right
    tangent at the estimate: the pose block in the body frame (``steam_ref.lie.world_position_covariance``)."""
    ids = np.array(sorted(result.landmarks), dtype=int)
    marks = np.array([result.landmarks[i] for i in ids]).reshape(-1, 2)
    tr = result.trajectory
    arrays = dict(
        times=result.times,
        x=tr[:, 0],
        y=tr[:, 1],
        theta=tr[:, 2],
        **(
            dict(vx=tr[:, 3], vy=tr[:, 4], omega=tr[:, 5])
            if se2
            else dict(xdot=tr[:, 3], ydot=tr[:, 4], thetadot=tr[:, 5])
        ),
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
    _check_output(args.save_trajectory, "", "--save-trajectory")
    setup = PaperSetup.named(_preset(args))
    data = _load_with_note(args)
    problem = build_problem(data, setup)
    t0 = time.perf_counter()
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
    if args.json:
        print(json.dumps(summary))
    else:
        print(
            f"batch {_BATCH_NAME[args.ordering]} ({args.ordering.upper()} ordering) on {args.dataset}: "
            f"RMSE {summary['rmse_m']} m over {data.n_poses} poses, "
            f"{summary['total_s']:.2f} s, Cholesky factor {summary['factor_nnz']} nonzeros ({summary['backend']})\n"
            + explain.data_lines(summary)
        )
    if args.plot:
        _write_plot(
            args,
            lambda name: plot_trajectory(
                truth,
                positions,
                landmarks_true=data.landmarks[:, 1:3] if len(data.landmarks) else None,
                title=f"batch on {args.dataset}",
                path=name,
            ),
        )
    return 0


_BATCH_NAME = {"xl": "PB", "amd": "PBVR"}  # the paper's names of a batch solve by its ordering [YIB Sec. IV]


def _write_plot(args: argparse.Namespace, draw: Callable[[str], object]) -> None:
    """Write ``--plot`` by ``draw(name)`` and say where it went (not with ``--json``: its one line is the figures)."""
    _write_output(args.plot, "--plot", draw)
    if not args.json:
        print(f"plot written to {os.path.abspath(args.plot)}")


def _fidelity(args: argparse.Namespace) -> int:
    """BTGP/1 with the paper's set-up against the authors' saved run of each data set."""

    _check_output(args.plot, ".png", "--plot")
    distances = {}
    for name in AUTHORS_RUNS if args.dataset == "all" else [args.dataset]:
        find_authors_file(name, args.data_dir)  # before loading: gtsam's Plaza files are not the authors' data
        data = load_range_dataset(name, data_dir=args.data_dir)
        authors = load_authors_run(name, data, args.data_dir)
        setup = PaperSetup.named(_PRESET_OF[name])
        result = run_online(data, setup, covariances=authors.pose_covariance is not None)
        fid, distances[name] = compare(result, authors, data.ground_truth)
        row = fid.to_dict() | {
            "total_s": round(result.total_s, 2),
            "authors_total_s": round(float(authors.step_seconds.sum()), 2),
            "data_files": explain.data_figures(data, 0)["data_files"]
            + [explain.file_entry(find_authors_file(name, args.data_dir))],
        }
        print(
            json.dumps(row) if args.json else _fidelity_text(row) + "\n" + explain.data_lines(row | {"data_note": None})
        )
    if args.plot:
        _write_plot(args, lambda name: plot_fidelity(distances, path=name))
    return 0


def _mm(metres: float) -> str:
    return f"{1000 * metres:.2f} mm"


def _fidelity_text(row: dict) -> str:
    cov = (
        ""
        if row["pose_cov_median"] is None
        else (
            f"\n  marginal covariances, relative difference: pose median {row['pose_cov_median']:.2%} (max {row['pose_cov_max']:.2%}), "
            f"velocity median {row['velocity_cov_median']:.2%} (max {row['velocity_cov_max']:.2%}), landmarks max {row['landmark_cov_max']:.2%}"
        )
    )
    return (
        f"{row['dataset']}: {row['n_states']} states; distance to the authors' estimate RMS {_mm(row['pose_rms_m'])}, "
        f"max {_mm(row['pose_max_m'])} at pose {row['pose_max_at']}; landmarks max {_mm(row['landmark_max_m'])}\n"
        f"  position RMSE {row['rmse_m']:.5f} m (authors {row['authors_rmse_m']:.5f} m); {row['total_s']} s "
        f"(authors' MATLAB + GTSAM 3.2: {row['authors_total_s']} s)" + cov
    )


def _reproduce(args: argparse.Namespace) -> int:
    _check_out_folder(args.out, "--out")
    try:
        table = reproduce(args.out, quick=args.quick, data_dir=args.data_dir, jobs=args.jobs)
    except OSError as err:  # a full disk while writing the plots or the table
        raise SteamError(f"--out: cannot write {err.filename or args.out!r} ({err.strerror or err})") from None
    print(table)
    return 0


def _one_line(message: str) -> str:
    """``message`` with its line breaks escaped: an error is one line however odd the input it quotes."""
    return "".join(c if c.isprintable() or c == "\t" else repr(c)[1:-1] for c in message) or "(no message)"


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
        return commands[args.command](args)
    except (SteamError, OSError, MemoryError) as exc:
        print(f"steam-ref: error: {_one_line(str(exc))}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("steam-ref: interrupted", file=sys.stderr)
        return 130
