"""``steam-ref run``: stream a data set through one solver (BTGP, PB or PBVR) and report what it did.

With no options it runs BTGP/1 on the generated synthetic task. A data set without ground truth
(victoria-park) is not scored unless ``--score-against-optimum`` asks for the converged batch solution of the
same problem (:func:`~steam_ref.paper.problem.score_against_batch`) instead of an RMSE.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..arguments import parse_decimal
from ..bayes_tree import ISAM2Params
from ..datasets import generate_synthetic
from ..datasets.registry import DATASETS
from ..errors import SteamError
from ..evaluate import trajectory_figures
from ..linear.amalgamation import zero_fraction
from ..motion import MOTION_PRIORS
from ..paper.online import StreamingEstimator
from ..paper.options import StreamOptions
from ..paper.presets import DEPARTURES, PAPER_AMALGAMATION_ZEROS, PRESETS, PaperSetup
from ..paper.problem import score_against_batch
from ..paper.readings import Readings
from ..paper.solvers import BayesTreeSolver
from ..plot.figures import plot_trajectory
from ..variables import X
from . import explain
from .args import (
    QC_SCALES,
    SINGER_TIME_CONSTANTS,
    Subparsers,
    add_data_dir,
    add_dataset,
    add_max_poses,
    add_prior,
    add_progress,
    add_qc,
    add_seed,
    add_trajectory_arguments,
    check_prior_fits,
    check_prior_options,
    load_with_note,
    non_negative_float,
    positive_float,
    positive_int,
    preset_of,
    scale,
    scaled_qc,
    seed_of,
    steps_count,
)
from .paths import (
    check_output,
    check_outputs_apart,
    check_outputs_not_inputs,
    check_trajectory_output,
    save_trajectory,
    write_output,
    write_plot,
)
from .rigid import SAVED_ESTIMATE, run_rigid
from .streams import json_line

__all__ = ["add_parser", "run", "save_estimates"]

VECTOR_STATE_NAMES = ("x", "y", "theta", "xdot", "ydot", "thetadot")  # the paper's WNOA state, as files name it
DEFAULT_STEPS, DEFAULT_LANDMARKS = 1500, 298  # generate_synthetic's defaults: a landmark every ~5 steps


def add_parser(sub: Subparsers) -> argparse.ArgumentParser:
    """Add ``run`` and its options to the command's subparsers."""
    what = "stream a data set through one solver: RMSE against ground truth, timing"
    parser = sub.add_parser("run", help=what, example="steam-ref run --dataset plaza --max-poses 200")
    add_dataset(parser, "synthetic")
    parser.add_argument(
        "--method",
        choices=("btgp", "pb", "pbvr"),
        default="btgp",
        help="btgp: the incremental Bayes tree (the paper's Algorithm 1); pb: periodic batch (XL ordering); "
        "pbvr: periodic batch with AMD variable reordering (default %(default)s)",
    )
    parser.add_argument(
        "--every",
        type=positive_int,
        default=None,
        help="update after every N landmark readings (1 or 10 in the paper; default: the preset's, PaperSetup.schedule.every)",
    )
    parser.add_argument("--skip", type=positive_int, default=1, help="time steps between estimated states")
    parser.add_argument(
        "--interpolate",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="interpolate readings between states (Eq. 29) or drop them",
    )
    parser.add_argument(
        "--range-states",
        action="store_true",
        help="also estimate a state at every pose with a range reading (the layout of the Plaza script, plaza_isam2.m)",
    )
    parser.add_argument(
        "--converge-at-end",
        action="store_true",
        help="after the last pose, iterate everything to the batch optimum (steam_ref.paper.converge) and report that estimate",
    )
    parser.add_argument(
        "--departure",
        action="append",
        choices=list(DEPARTURES),
        default=[],
        help="depart from the paper's scripts in this named way (repeatable; docs/experiments.md gives each one's effect)",
    )
    parser.add_argument(
        "--preset", choices=PRESETS, default=None, help="parameter set (default: by data set; required for a PATH)"
    )
    parser.add_argument(
        "--score-against-optimum",
        action="store_true",
        help="a data set without ground truth (victoria-park): score the run against the converged batch optimum of "
        "the same problem (two batch solves after the run: ~100 s on victoria-park)",
    )
    add_prior(
        parser,
        "motion prior: ",
        " (docs/derivations.md); default: the preset's (wnoa)",
        "--prior se2 only: the SE(2) prior's residual, 'local-variable' (Anderson & Barfoot; GTSAM, STEAM) or "
        "'simplified' (gpslam, Theseus) (default: local-variable)",
    )
    parser.add_argument(
        "--qc-scale",
        type=scale(*QC_SCALES, "the prior's information beside the readings must stay within float64's precision"),
        default=1.0,
        help="multiply the preset's Qc by this, 1e-8 to 1e8 (a jerk prior needs its own: tutorial 06 uses 100 on Plaza)",
    )
    add_qc(parser)
    parser.add_argument(
        "--singer-time-constant",
        type=scale(*SINGER_TIME_CONSTANTS, "the Singer prior's process noise must stay within float64's precision"),
        default=None,
        help=f"Singer prior (--prior {' or '.join(p for p, c in MOTION_PRIORS.items() if 'singer_time_constant' in c.options)}"
        f" only): the acceleration's time constant 1/α on the preset's GP clock "
        f"(pose steps for synthetic and plaza, seconds for victoria-park), 1e-6 to 1e8 "
        f"(default: the preset's, {PaperSetup.singer_time_constant})",
    )
    add_data_dir(parser)
    add_seed(parser)
    parser.add_argument(
        "--relinearize-threshold",
        type=non_negative_float,
        default=None,
        help=f"BTGP: relinearize a variable whose increment exceeds this (default: the preset's; GTSAM's is {ISAM2Params.relinearize_threshold})",
    )
    parser.add_argument(
        "--relinearize-skip",
        type=positive_int,
        default=None,
        help=f"BTGP: check relinearization every N-th update (default: the preset's; GTSAM's is {ISAM2Params.relinearize_skip})",
    )
    parser.add_argument(
        "--amalgamation-zeros",
        type=_zero_fraction,
        default=None,
        metavar="Z",
        help="BTGP: merge a clique into its parent while the merged clique's rows of R hold at most this fraction of "
        "explicit zeros, 0 <= Z < 1 (relaxed amalgamation: fewer, larger cliques; default: the preset's, "
        f"{PAPER_AMALGAMATION_ZEROS}; 0 builds GTSAM's cliques; docs/bayes_tree.md)",
    )
    add_max_poses(parser)
    parser.add_argument(
        "--time-budget", type=positive_float, default=None, help="stop after this many seconds (reported)"
    )
    add_progress(parser)
    parser.add_argument(
        "--lag",
        type=positive_float,
        default=None,
        metavar="SECONDS",
        help="BTGP: fixed-lag smoothing: after each update, marginalize the states older than this (t < t_newest - "
        "SECONDS) and the landmarks not seen for this long (a landmark seen again enters anew), in seconds of the "
        "data set's own time stamps, whatever clock the preset's GP prior runs on (docs/derivations.md §10)",
    )
    parser.add_argument(
        "--lag-history",
        action="store_true",
        help="with --lag: keep each forgotten state's conditional (~2 KB) and smooth the past from the final window "
        "at the end (rmse_m; rmse_lagged_m is the estimates as they left the window; derivations §10.5)",
    )
    parser.add_argument(
        "--lag-batch",
        type=non_negative_float,
        default=0.0,
        metavar="SECONDS",
        help="with --lag: let the window grow this many seconds past the lag, then marginalize what is past it at "
        "once, cutting whole subtrees of the tree with no elimination (default 0: at every update; "
        "docs/bayes_tree.md)",
    )
    parser.add_argument(
        "--steps",
        type=steps_count,
        default=None,
        help="--dataset synthetic or synthetic-3d: generate N steps (N + 1 poses), with landmarks as dense as the "
        "default task's",
    )
    parser.add_argument("--json", action="store_true", help="print one JSON line of figures")
    parser.add_argument(
        "--save-estimates",
        metavar="FILE.npz",
        default=None,
        help="write the estimate at every time step (pose and velocity), the landmarks, and their final marginal covariances",
    )
    parser.add_argument(
        "--plot", metavar="FILE.png", default=None, help="draw estimate, ground truth, dead reckoning, landmarks"
    )
    parser.add_argument(
        "--tree-dot",
        metavar="FILE.dot",
        default=None,
        help="write BTGP's final Bayes tree in the Graphviz format of GTSAM's ISAM2.dot() (\"frontals : separator\")",
    )
    add_trajectory_arguments(parser, SAVED_ESTIMATE)
    return parser


def _zero_fraction(text: str) -> float:
    """An argparse type: a number in [0, 1) (:func:`~steam_ref.linear.amalgamation.zero_fraction`)."""
    try:
        return zero_fraction(parse_decimal(text))
    except SteamError:
        raise argparse.ArgumentTypeError(f"expected a fraction >= 0 and < 1, got {text!r}") from None


def run(args: argparse.Namespace) -> int:
    """Stream the data set, write the files asked for, print the figures."""
    check_prior_fits(args.dataset, args.prior)  # a 3-D prior on a planar set, or a planar prior on a 3-D set
    if args.dataset in DATASETS and DATASETS[args.dataset].rigid:  # a 3-D set: solved on SE(3) (cli/rigid.py)
        return run_rigid(args)
    check_output(args.save_estimates, ".npz", "--save-estimates")
    check_trajectory_output(args)
    check_output(args.plot, ".png", "--plot")
    check_output(args.tree_dot, ".dot", "--tree-dot")
    outputs = {
        "--save-estimates": args.save_estimates,
        "--save-trajectory": args.save_trajectory,
        "--plot": args.plot,
        "--tree-dot": args.tree_dot,
    }
    check_outputs_apart(outputs)
    if args.tree_dot and args.method != "btgp":
        raise SteamError(f"--tree-dot writes BTGP's Bayes tree: it needs --method btgp, got --method {args.method}")
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
    check_outputs_not_inputs(outputs, explain.files_of(data.source))
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
            reference = None if data.ground_truth is None else data.ground_truth[:, 1:3]
        where += write_plot(
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


def _run_dataset(args: argparse.Namespace):
    """The data set of ``run``: by name or path, or the generated task of ``--steps`` steps."""
    if args.steps is None:
        return load_with_note(args)
    if args.dataset != "synthetic":
        raise SteamError(
            f"--steps generates the synthetic task: it needs --dataset synthetic (or synthetic-3d), got {args.dataset!r}"
        )
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
