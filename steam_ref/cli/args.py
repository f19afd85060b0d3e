"""The ``steam-ref`` command line: its parser, the checks of every argument, and of output paths before a run.

Every value is checked by its argparse type, so a bad one is a one-line error with exit code 2 before
anything runs; :mod:`steam_ref.cli.commands` holds what each command does.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from .._version import __version__
from ..arguments import parse_decimal
from ..bayes_tree import ISAM2Params
from ..conformance import command as conformance_command
from ..errors import SteamError
from ..paper.presets import DEPARTURES, PRESETS, PRIORS, SE2_RESIDUALS, PaperSetup
from . import data as data_command

__all__ = ["build_parser"]


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error as one line and exit code 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise SteamError(f"{message} (see '{self.prog} --help')")


def _number(convert: type, lower: float, *, strict: bool, upper: float = math.inf, why: str = ""):
    """An argparse type: ``text`` by the one rule for numbers (:func:`~steam_ref.arguments.parse_decimal`),
    above ``lower`` (``strict``) or at least it, and at most ``upper`` (beyond it, ``why``)."""
    what = f"{'an integer' if convert is int else 'a finite number'} {'>' if strict else '>='} {lower:g}"
    what += f" and <= {upper:g} ({why})" if upper < math.inf else ""

    def parse(text: str):
        value = parse_decimal(text, convert)
        if value is None or not math.isfinite(value) or value < lower or (strict and value == lower) or value > upper:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
        return value

    return parse


def _scale(lower: float, upper: float, why: str):
    """An argparse type: a finite number in [lower, upper] (outside it, ``why``)."""

    def parse(text: str) -> float:
        value = parse_decimal(text)
        if value is None or not (math.isfinite(value) and lower <= value <= upper):
            raise argparse.ArgumentTypeError(f"expected a number from {lower:g} to {upper:g}, got {text!r} ({why})")
        return value

    return parse


# The preset's Qc balances the prior against the readings; a scale s moves the prior's information by 1/s,
# and beyond about sqrt(1/eps) = 6.7e7 either way float64 no longer resolves the readings beside the prior
# (or the prior beside them): the elimination then breaks down, blaming a variable. Past 1e8 refused here.
QC_SCALES = (1e-8, 1e8)
# Singer's 1/alpha: the acceleration's memory. Below 1e-6 s (alpha dt > 1e6 at the data sets' dt of 1 s to
# 0.1 s) its process noise spans more than float64 resolves; above 1e8 s it is WNOJ to float64's precision.
SINGER_TIME_CONSTANTS = (1e-6, 1e8)

# Sizes of generated work, bounded so that a typo is a one-line refusal, not numpy's "Unable to allocate" (or
# an empty MemoryError) minutes later. The generator finds each pose's nearest landmarks among all of them:
# steps × landmarks distances, 0.6 GB at 20,000 steps with the default density (the paper's task has 1,500).
MAX_STEPS = 20_000
MAX_LANDMARKS = 10_000
MAX_SEEDS = 100_000  # Monte Carlo runs (the default is 200): each is a whole task, and a line of the log
_steps = _number(int, 0, strict=True, upper=MAX_STEPS, why="the generated task is held in memory")
_landmarks = _number(int, 0, strict=True, upper=MAX_LANDMARKS, why="the generated task is held in memory")
_seeds = _number(int, 0, strict=True, upper=MAX_SEEDS, why="each run is a whole task")

_positive_int = _number(int, 0, strict=True)
_non_negative_int = _number(int, 0, strict=False)
_positive_float = _number(float, 0, strict=True)
_non_negative_float = _number(float, 0, strict=False)


def _dataset(text: str) -> str:
    """An argparse type: a data set name or path, not empty (an empty path would be the working folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a data set name or a path, got an empty string")
    return text


def _folder(text: str) -> str:
    """An argparse type: an existing folder (a mistyped --data-dir must not be passed over in silence)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a folder, got an empty string")
    if not Path(text).is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} {'is not a folder' if Path(text).exists() else 'does not exist'}")
    return text


def _add_data_dir(parser: argparse.ArgumentParser, also: str = "") -> None:
    """--data-dir: the one folder the user names, searched first (datasets/search.py gives the whole order)."""
    parser.add_argument(
        "--data-dir",
        type=_folder,
        default=None,
        help=f"folder searched for data files{also} before $STEAM_REF_DATA_DIR, the fetched files' cache and gtsam's Data/",
    )


def _add_run_arguments(run: argparse.ArgumentParser) -> None:
    run.add_argument(
        "--dataset",
        type=_dataset,
        default="synthetic",
        help="synthetic (generated), paper-synthetic, plaza, plaza2, victoria-park, or a PATH (.mat, CMU text folder, "
        "GTSAM .txt); `steam-ref data list` shows which are present",
    )
    run.add_argument(
        "--method",
        choices=("btgp", "pb", "pbvr"),
        default="btgp",
        help="btgp: the incremental Bayes tree (the paper's Algorithm 1); pb: periodic batch (XL ordering); "
        "pbvr: periodic batch with AMD variable reordering (default %(default)s)",
    )
    run.add_argument(
        "--every",
        type=_positive_int,
        default=None,
        help="update after every N landmark readings (1 or 10 in the paper; default: the preset's, PaperSetup.schedule.every)",
    )
    run.add_argument("--skip", type=_positive_int, default=1, help="time steps between estimated states")
    run.add_argument(
        "--interpolate",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="interpolate readings between states (Eq. 29) or drop them",
    )
    run.add_argument(
        "--range-states",
        action="store_true",
        help="also estimate a state at every pose with a range reading (the layout of the Plaza script, plaza_isam2.m)",
    )
    run.add_argument(
        "--converge-at-end",
        action="store_true",
        help="after the last pose, iterate everything to the batch optimum (steam_ref.paper.converge) and report that estimate",
    )
    run.add_argument(
        "--departure",
        action="append",
        choices=list(DEPARTURES),
        default=[],
        help="depart from the paper's scripts in this named way (repeatable; docs/experiments.md gives each one's effect)",
    )
    run.add_argument(
        "--preset", choices=PRESETS, default=None, help="parameter set (default: by data set; required for a PATH)"
    )
    run.add_argument(
        "--score-against-optimum",
        action="store_true",
        help="a data set without ground truth (victoria-park): score the run against the converged batch optimum of "
        "the same problem (two batch solves after the run: ~100 s on victoria-park)",
    )
    run.add_argument(
        "--prior",
        choices=PRIORS,
        default=None,
        help="motion prior: the paper's white noise on acceleration, or on jerk, or Singer's model, or white noise on "
        "acceleration on SE(2) (states: pose and body twist; docs/derivations.md); default: the preset's (wnoa)",
    )
    run.add_argument(
        "--se2-residual",
        choices=SE2_RESIDUALS,
        default=None,
        help="--prior se2 only: the SE(2) prior's residual, 'local-variable' (Anderson & Barfoot; GTSAM, STEAM) or "
        "'simplified' (gpslam, Theseus) (default: local-variable)",
    )
    run.add_argument(
        "--qc-scale",
        type=_scale(*QC_SCALES, "the prior's information beside the readings must stay within float64's precision"),
        default=1.0,
        help="multiply the preset's Qc by this, 1e-8 to 1e8 (a jerk prior needs its own: tutorial 06 uses 100 on Plaza)",
    )
    run.add_argument(
        "--singer-time-constant",
        type=_scale(*SINGER_TIME_CONSTANTS, "the Singer prior's process noise must stay within float64's precision"),
        default=None,
        help=f"Singer prior (--prior singer only): the acceleration's time constant 1/α on the preset's GP clock "
        f"(pose steps for synthetic and plaza, seconds for victoria-park), 1e-6 to 1e8 "
        f"(default: the preset's, {PaperSetup.singer_time_constant})",
    )
    _add_data_dir(run)
    run.add_argument("--seed", type=_non_negative_int, default=0, help="seed of the generated synthetic task")
    run.add_argument(
        "--relinearize-threshold",
        type=_non_negative_float,
        default=None,
        help=f"BTGP: relinearize a variable whose increment exceeds this (default: the preset's; GTSAM's is {ISAM2Params.relinearize_threshold})",
    )
    run.add_argument(
        "--relinearize-skip",
        type=_positive_int,
        default=None,
        help=f"BTGP: check relinearization every N-th update (default: the preset's; GTSAM's is {ISAM2Params.relinearize_skip})",
    )
    run.add_argument(
        "--max-poses", type=_number(int, 2, strict=False), default=None, help="process only the first N poses"
    )
    run.add_argument(
        "--time-budget", type=_positive_float, default=None, help="stop after this many seconds (reported)"
    )
    _add_progress(run)
    run.add_argument(
        "--lag",
        type=_positive_float,
        default=None,
        metavar="SECONDS",
        help="BTGP: fixed-lag smoothing: after each update, marginalize the states older than this (t < t_newest - "
        "SECONDS) and the landmarks not seen for this long (a landmark seen again enters anew), in seconds of the "
        "data set's own time stamps, whatever clock the preset's GP prior runs on (docs/derivations.md §10)",
    )
    run.add_argument(
        "--lag-history",
        action="store_true",
        help="with --lag: keep each forgotten state's conditional (~2 KB) and smooth the past from the final window "
        "at the end (rmse_m; rmse_lagged_m is the estimates as they left the window; derivations §10.5)",
    )
    run.add_argument(
        "--steps",
        type=_steps,
        default=None,
        help="--dataset synthetic: generate N steps (N + 1 poses), with landmarks as dense as the default task's",
    )
    run.add_argument("--json", action="store_true", help="print one JSON line of figures")
    run.add_argument(
        "--save-estimates",
        metavar="FILE.npz",
        default=None,
        help="write the estimate at every time step (pose and velocity), the landmarks, and their final marginal covariances",
    )
    run.add_argument(
        "--plot", metavar="FILE.png", default=None, help="draw estimate, ground truth, dead reckoning, landmarks"
    )
    run.add_argument(
        "--tree-dot",
        metavar="FILE.dot",
        default=None,
        help="write BTGP's final Bayes tree in the Graphviz format of GTSAM's ISAM2.dot() (\"frontals : separator\")",
    )
    _add_trajectory_arguments(run)


def _add_trajectory_arguments(parser: argparse.ArgumentParser) -> None:
    """--save-trajectory FILE and its format (run and batch)."""
    parser.add_argument(
        "--save-trajectory",
        metavar="FILE",
        default=None,
        help="write the estimated pose at every time step: TUM (timestamp tx ty tz qx qy qz qw, read by evo) or KITTI",
    )
    parser.add_argument(
        "--trajectory-format", choices=("tum", "kitti"), default=None, help="of --save-trajectory (default: tum)"
    )


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``steam-ref``."""
    parser = _Parser(
        prog="steam-ref",
        description="Incremental sparse GP regression for continuous-time STEAM (Yan, Indelman, Boots).",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser, required=True)
    _add_run_arguments(sub.add_parser("run", help="stream a data set through one solver"))
    bat = sub.add_parser("batch", help="batch Gauss-Newton on all of a data set (PB or PBVR): RMSE and a plot")
    bat.add_argument(
        "--dataset",
        type=_dataset,
        default="paper-synthetic",
        help="synthetic, paper-synthetic, plaza, plaza2, victoria-park or a PATH",
    )
    bat.add_argument("--ordering", choices=("xl", "amd"), default="amd", help="xl: the paper's PB; amd: PBVR")
    bat.add_argument(
        "--preset", choices=PRESETS, default=None, help="parameter set (default: by data set; required for a PATH)"
    )
    _add_data_dir(bat)
    bat.add_argument("--seed", type=_non_negative_int, default=0, help="seed of the generated synthetic task")
    bat.add_argument("--json", action="store_true", help="print one JSON line of figures")
    bat.add_argument("--plot", metavar="FILE.png", default=None, help="draw estimate, ground truth, landmarks")
    _add_trajectory_arguments(bat)
    _add_progress(bat)
    fid = sub.add_parser("fidelity", help="BTGP/1 against the authors' saved runs, pose by pose, covariances included")
    fid.add_argument("--dataset", choices=("plaza", "paper-synthetic", "all"), default="all")
    _add_data_dir(fid, " (and its authors/ folder)")
    fid.add_argument("--json", action="store_true", help="print one JSON line per data set")
    fid.add_argument(
        "--plot", metavar="FILE.png", default=None, help="draw the per-pose distance to the authors' estimate"
    )
    _add_progress(fid)
    rep = sub.add_parser("reproduce", help="the experiments of Fig. 3 and Fig. 4, plots and a results table")
    rep.add_argument("--quick", action="store_true", help="small prefixes and budgets: minutes, not hours")
    rep.add_argument("--out", default="results", help="folder for plots and the table (default: results)")
    _add_data_dir(rep)
    rep.add_argument(
        "--jobs",
        type=_positive_int,
        default=1,
        help="accuracy runs in parallel (timing runs stay serial, each in a fresh process)",
    )
    _add_progress(rep)
    conformance_command.add_parser(sub)
    data_command.add_parser(sub)
    _add_consistency_arguments(
        sub.add_parser("consistency", help="ANEES of each estimator over Monte Carlo runs, with its band")
    )
    return parser


def _add_progress(parser: argparse.ArgumentParser) -> None:
    """``--progress`` / ``--no-progress`` (steam_ref.paper.progress.wanted reads it)."""
    parser.add_argument(
        "--progress",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="a progress bar on stderr (default: on when stderr is a terminal and without --json)",
    )


def _add_consistency_arguments(con: argparse.ArgumentParser) -> None:
    """``steam-ref consistency`` (steam_ref.cli.consistency)."""
    con.add_argument("--dataset", choices=("synthetic",), default="synthetic", help="tasks drawn from the model")
    con.add_argument(
        "--prior",
        choices=("wnoa", "se2"),
        default="wnoa",
        help="the model the tasks are drawn from and the estimators assume: the paper's WNOA, or WNOA on SE(2) "
        "(then the estimators are batch, btgp/1 and btgp/1 with the vector-space prior)",
    )
    con.add_argument(
        "--se2-residual", choices=SE2_RESIDUALS, default=None, help="--prior se2: the model's residual (local-variable)"
    )
    con.add_argument(
        "--turn",
        type=float,
        default=None,
        help="--prior se2: the task's yaw rate at the start, rad a step (default 0; 1.0 is the fast-turning task)",
    )
    con.add_argument("--seeds", type=_seeds, default=200, help="Monte Carlo runs (default %(default)s)")
    con.add_argument("--seed", type=_non_negative_int, default=0, help="root of the seeds (SeedSequence(seed).spawn)")
    con.add_argument("--steps", type=_steps, default=40, help="time steps of a task (default %(default)s)")
    con.add_argument("--landmarks", type=_landmarks, default=8, help="landmarks of a task (default %(default)s)")
    con.add_argument("--jobs", type=_positive_int, default=1, help="worker processes (default %(default)s)")
    con.add_argument("--backend", choices=("loky", "dask"), default="loky", help="joblib's loky processes, or Dask")
    con.add_argument("--scheduler", default=None, help="Dask scheduler address (default: a LocalCluster on 127.0.0.1)")
    logs = con.add_mutually_exclusive_group()
    logs.add_argument("--log", metavar="FILE.jsonl", default=None, help="stream each run's NEES to a new file")
    logs.add_argument("--resume", metavar="FILE.jsonl", default=None, help="continue this file (or start it)")
    con.add_argument("--json", action="store_true", help="print one JSON line of figures")
    con.add_argument("--plot", metavar="FILE.png", default=None, help="ANEES pose by pose against its band")
    _add_progress(con)
