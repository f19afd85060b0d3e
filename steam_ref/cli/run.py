"""``steam-ref run``: stream a data set through one solver (BTGP, PB or PBVR) and report what it did.

With no options it runs BTGP/1 on the generated synthetic task. A data set without ground truth
(victoria-park) is not scored unless ``--score-against-optimum`` asks for the converged batch solution of the
same problem (:func:`~steam_ref.paper.problem.score_against_batch`) instead of an RMSE.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..datasets import generate_synthetic
from ..errors import SteamError
from ..evaluate import trajectory_figures
from ..paper.online import StreamingEstimator
from ..paper.options import StreamOptions
from ..paper.presets import PaperSetup
from ..paper.problem import score_against_batch
from ..paper.readings import Readings
from ..paper.solvers import BayesTreeSolver
from ..plot.figures import plot_trajectory
from ..variables import X
from . import explain
from .args import check_prior_options, is_rigid, preset_of, seed_of
from .inputs import load_with_note, scaled_qc
from .parsers.run import check, outputs
from .paths import (
    check_outputs_not_inputs,
    save_trajectory,
    write_output,
    write_plot,
)
from .rigid import run_rigid
from .streams import json_line

__all__ = ["run", "save_estimates"]

VECTOR_STATE_NAMES = ("x", "y", "theta", "xdot", "ydot", "thetadot")  # the paper's WNOA state, as files name it
DEFAULT_STEPS, DEFAULT_LANDMARKS = 1500, 298  # generate_synthetic's defaults: a landmark every ~5 steps


def run(args: argparse.Namespace) -> int:
    """Stream the data set, write the files asked for, print the figures."""
    check(args)  # what is checked before anything is read (commands.main made these checks before this module loaded)
    if is_rigid(args.dataset):  # a 3-D set: solved on SE(3) (cli/rigid.py)
        return run_rigid(args)
    setup = PaperSetup.named(preset_of(args)).departing(*args.departure)
    prior = setup.prior if args.prior is None else args.prior
    given = {"prior": args.prior, "singer_time_constant": args.singer_time_constant, "se2_residual": args.se2_residual}
    check_prior_options(prior, {name: given[name] for name in ("singer_time_constant", "se2_residual")})
    qc = scaled_qc(setup.qc, args.qc, args.qc_scale)  # --qc, then --qc-scale
    setup = setup.replace(qc=qc, **{k: v for k, v in given.items() if v is not None})
    isam2 = {
        "relinearize_threshold": args.relinearize_threshold,
        "relinearize_skip": args.relinearize_skip,
        "amalgamation_zeros": args.amalgamation_zeros,
    }
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
        lag_batch=args.lag_batch,
    )
    if args.lag is not None and args.save_estimates is not None:
        raise SteamError("--save-estimates writes every marginal covariance, which --lag forgets: drop one of them")
    if args.lag is not None and args.score_against_optimum:
        raise SteamError(
            "--score-against-optimum compares every state and landmark with the batch optimum, and --lag forgets "
            "the old ones: drop one of them"
        )
    data = _run_dataset(args)
    check_outputs_not_inputs(outputs(args), explain.files_of(data.source))
    if args.score_against_optimum and data.ground_truth is not None:
        raise SteamError(
            f"--score-against-optimum: {args.dataset!r} has ground truth, and is scored by RMSE against it"
        )
    estimator = StreamingEstimator(Readings.from_dataset(data, setup), setup, options, name=args.dataset)
    result = estimator.run(data.ground_truth, covariances=args.save_estimates is not None)
    n = len(result.times)
    # the run's own files first: nothing computed from them after (scores, figures) can lose them; `written` says where
    written = save_trajectory(args, result.times, result.trajectory[:, :3])  # the data's seconds, as --save-estimates
    if args.save_estimates:
        written += write_output(
            args.save_estimates,
            "--save-estimates",
            lambda name: save_estimates(name, result, state_names=estimator.front.prior.state_names),
        )
    if args.tree_dot and isinstance(estimator.solver, BayesTreeSolver):  # GTSAM's ISAM2.dot() text (bayes_tree/dot.py)
        dot = estimator.solver.inner.tree.dot() + "\n"
        written += write_output(args.tree_dot, "--tree-dot", lambda name: Path(name).write_text(dot, encoding="utf-8"))
    summary = result.summary(args.dataset) | {
        "preset": setup.name,
        "score_against_optimum": args.score_against_optimum,
        "departures": args.departure,
        "prior": setup.prior,
        **setup.prior_options(),
        "qc_scale": args.qc_scale,
        "qc": setup.qc.tolist(),
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
    where = "" if args.json else written
    if args.plot:
        reference: np.ndarray | None
        if score is not None:
            reference = np.array([score.batch.values[X(int(i))][:2] for i in score.poses])
        else:
            reference = None if data.ground_truth is None else data.ground_truth[:n, 1:3]  # the poses run
        where += write_plot(
            args,
            lambda name: plot_trajectory(
                reference,
                result.trajectory[:, :2],
                landmarks_true=data.landmarks[:, 1:3] if len(data.landmarks) else None,
                landmarks_estimated=result.landmarks,
                dead_reckoning=data.dead_reckoning[:n, 1:3],
                estimate_label=f"{result.method.upper()} estimate",
                truth_label="ground truth" if score is None else "batch optimum",
                title=explain.plot_title(summary, n, result.n_poses_total),
                path=name,
            ),
        )
    # printed last: the files are written even when stdout is a pipe its reader closed (`| head`)
    print(json_line(summary) if args.json else explain.run_text(summary) + explain.evaluation_note(summary) + where)
    return 0


def _run_dataset(args: argparse.Namespace):
    """The data set of ``run``: by name or path, or the generated task of ``--steps`` steps."""
    if args.steps is None:
        return load_with_note(args)
    n_landmarks = max(1, round(args.steps * DEFAULT_LANDMARKS / DEFAULT_STEPS))  # the default task's density
    return generate_synthetic(n_steps=args.steps, n_landmarks=n_landmarks, seed=seed_of(args))


def save_estimates(path: str, result, *, state_names: tuple[str, ...] = VECTOR_STATE_NAMES) -> None:
    """Write a run to an .npz file: ``times`` (the data set's seconds, as ``--save-trajectory``), one array per number
    of a state at every covered time step, named by the motion prior (``MotionPrior.state_names``: ``x``, ``y``,
    ``theta``, then ``xdot``, ``ydot``, ``thetadot`` (rates per unit of the model's clock: per pose step on a
    'pose-index' clock, per second on 'seconds') and with a WNOJ or Singer prior ``xddot``, ``yddot``, ``thetaddot``;
    on SE(2) states the body twist ``vx``, ``vy``, ``omega``, covariances in the right tangent, the pose block in the
    body frame), ``state_poses`` (pose indices with a state), ``landmark_ids`` and ``landmarks`` (m, 2), and, when the
    run has them, the final marginal covariances ``pose_covariance`` (n, 3, 3), ``velocity_covariance`` (n, 3, 3) and
    ``landmark_covariance`` (m, 2, 2), in the order of ``times`` and ids."""
    ids = np.array(sorted(result.landmarks), dtype=int)
    marks = np.array([result.landmarks[i] for i in ids]).reshape(-1, 2)
    tr = result.trajectory
    if len(state_names) != tr.shape[1]:
        raise SteamError(f"the run's states have {tr.shape[1]} numbers, but {len(state_names)} names were given")
    arrays = dict(
        times=result.times,
        **dict(zip(state_names, tr.T, strict=True)),
        state_poses=result.state_poses,
        landmark_ids=ids,
        landmarks=marks,
    )
    if result.covariances is not None:
        c = result.covariances
        landmark_covariance = c.landmark[[c.landmark_ids.index(i) for i in ids]].reshape(-1, 2, 2)
        arrays.update(pose_covariance=c.pose, velocity_covariance=c.velocity, landmark_covariance=landmark_covariance)
    np.savez(path, **arrays)
