"""``steam-ref run``'s options (the command: :mod:`steam_ref.cli.run`)."""

from __future__ import annotations

import argparse

from ...choices import (
    DEPARTURES,
    GTSAM_RELINEARIZE_SKIP,
    GTSAM_RELINEARIZE_THRESHOLD,
    METHODS,
    MOTION_PRIOR_NAMES,
    PAPER_AMALGAMATION_ZEROS,
    PRESETS,
    SINGER_TIME_CONSTANT,
    parse_decimal,
    underflowed,
)
from ...errors import SteamError
from ..args import (
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
    check_steps,
    is_rigid,
    non_negative_float,
    positive_float,
    positive_int,
    preset_of,
    scale,
    steps_count,
)
from ..once import SwitchOnce
from ..paths import check_output, check_outputs_apart, check_trajectory_output

__all__ = ["add_parser", "check", "outputs"]

# whose estimate --save-trajectory writes (run's help; the rule is cli.rigid.run_rigid's `written`)
SAVED_ESTIMATE = (
    "; the estimate of --method (with --lag, the fixed-lag one); a 3-D set (synthetic-3d, kitti): BTGP's, or with "
    "--lag the fixed-lag smoother's, its poses in 3-D (`steam-ref batch --save-trajectory` writes batch's)"
)


def add_parser(sub: Subparsers) -> argparse.ArgumentParser:
    """Add ``run`` and its options to the command's subparsers."""
    what = "stream a data set through one solver: RMSE against ground truth, timing"
    parser = sub.add_parser("run", help=what, example="steam-ref run --dataset plaza --max-poses 200")
    add_dataset(parser, "synthetic")
    parser.add_argument(
        "--method",
        choices=METHODS,
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
        action=SwitchOnce,
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
        help=f"Singer prior (--prior {' or '.join(p for p, c in MOTION_PRIOR_NAMES.items() if 'singer_time_constant' in c.options)}"
        f" only): the acceleration's time constant 1/α on the preset's GP clock "
        f"(pose steps for synthetic and plaza, seconds for victoria-park), 1e-6 to 1e8 "
        f"(default: the preset's, {SINGER_TIME_CONSTANT})",
    )
    add_data_dir(parser)
    add_seed(parser)
    parser.add_argument(
        "--relinearize-threshold",
        type=non_negative_float,
        default=None,
        help=f"BTGP: relinearize a variable whose increment exceeds this (default: the preset's; GTSAM's is {GTSAM_RELINEARIZE_THRESHOLD})",
    )
    parser.add_argument(
        "--relinearize-skip",
        type=positive_int,
        default=None,
        help=f"BTGP: check relinearization every N-th update (default: the preset's; GTSAM's is {GTSAM_RELINEARIZE_SKIP})",
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
    from ...linear.amalgamation import zero_fraction  # its home, loaded only when --amalgamation-zeros is given

    what = "a fraction >= 0 and < 1"
    try:
        z = zero_fraction(parse_decimal(text))
    except SteamError:
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
    if lost := underflowed(text, z):  # '1e-400' is not 0
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}{lost}")
    return z


# run's options that only BTGP reads (None: not given), by what each is: given with --method pb or pbvr, which keep no
# Bayes tree and run no iSAM2 (paper.solvers.make_solver gives them neither), each would be passed over in silence
_BTGP_ONLY = {
    "tree_dot": "writes BTGP's Bayes tree",
    "relinearize_threshold": "sets BTGP's iSAM2 relinearization",
    "relinearize_skip": "sets BTGP's iSAM2 relinearization",
    "amalgamation_zeros": "sets how BTGP's iSAM2 merges the Bayes tree's cliques",
}


def outputs(args: argparse.Namespace) -> dict[str, str | None]:
    """The files a planar ``run`` writes, by option (None: not asked for)."""
    return {
        "--save-estimates": args.save_estimates,
        "--save-trajectory": args.save_trajectory,
        "--plot": args.plot,
        "--tree-dot": args.tree_dot,
    }


def check(args: argparse.Namespace) -> None:
    """What ``run`` checks before it reads or solves anything, in its order, with no solver loaded: the prior against
    the data set's space; then, for a planar set, each output path and their being apart, the method of BTGP's own
    options (``_BTGP_ONLY``), and the data set's preset (for a PATH, the data search finds it: a name that is neither a set nor a file is
    refused here). :func:`steam_ref.cli.commands.main` calls it before it loads the command's module, and
    :func:`steam_ref.cli.run.run` first: each check reads the arguments and the file system only."""
    check_prior_fits(args.dataset, args.prior)  # a 3-D prior on a planar set, or a planar prior on a 3-D set
    check_steps(args)  # --steps generates a set: not one read from a file
    if is_rigid(args.dataset):
        return
    check_output(args.save_estimates, ".npz", "--save-estimates")
    check_trajectory_output(args)
    check_output(args.plot, ".png", "--plot")
    check_output(args.tree_dot, ".dot", "--tree-dot")
    check_outputs_apart(outputs(args))
    for name, what in _BTGP_ONLY.items():  # PB and PBVR re-solve in batch: no tree, no iSAM2 to set
        if getattr(args, name) is not None and args.method != "btgp":
            option = f"--{name.replace('_', '-')}"
            raise SteamError(f"{option} {what}: it needs --method btgp, got --method {args.method}")
    preset_of(args)
