"""The ``steam-ref`` command: stream a data set through BTGP, PB or PBVR, or reproduce Fig. 3/4.

Usage::

    steam-ref run [--dataset NAME_OR_PATH] [--method {btgp,pb,pbvr}] [--every N] [--skip K]
                  [--interpolate/--no-interpolate] [--preset {synthetic,plaza}] [--data-dir DIR]
                  [--json] [--save-estimates FILE.npz] [--plot FILE.png]
    steam-ref batch [--dataset NAME_OR_PATH] [--ordering {xl,amd}] [--json] [--plot FILE.png]
    steam-ref fidelity [--dataset {plaza,paper-synthetic,all}] [--json] [--plot FILE.png]
    steam-ref reproduce [--quick] [--out DIR]
    steam-ref conformance {export DIR, check RESULTS_DIR [--suite NAME], selftest [--paper], build}

With no options ``steam-ref run`` runs BTGP/1 on the generated synthetic task. Bad arguments and
missing or malformed data files give a one-line error and exit code 2.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from . import __version__
from .bayes_tree import ISAM2Params
from .conformance import command as conformance_command
from .datasets import load_dataset
from .errors import SteamError
from .experiments import reproduce
from .fidelity import AUTHORS_RUNS, compare, find_authors_file, load_authors_run
from .online import StreamOptions, run_online
from .plot import plot_fidelity, plot_trajectory
from .problem import build_problem, sequential_batch
from .readings import DEPARTURES, PRIORS, PaperSetup
from .results import position_rmse
from .variables import X

__all__ = ["main", "build_parser"]

_PRESET_OF = {"synthetic": "synthetic", "paper-synthetic": "synthetic", "plaza": "plaza"}


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error as one line and exit code 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise SteamError(f"{message} (see '{self.prog} --help')")


def _number(convert: type, lower: float, *, strict: bool):
    """An argparse type: ``convert(text)``, finite, and above ``lower`` (``strict``) or at least it."""
    what = f"{'an integer' if convert is int else 'a finite number'} {'>' if strict else '>='} {lower:g}"

    def parse(text: str):
        try:
            value = convert(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        if not math.isfinite(value) or value < lower or (strict and value == lower):
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
        return value

    return parse


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


def _add_run_arguments(run: argparse.ArgumentParser) -> None:
    run.add_argument("--dataset", type=_dataset, default="synthetic", help="synthetic (generated), paper-synthetic, plaza, or a PATH (.mat or CMU text folder)")
    run.add_argument("--method", choices=("btgp", "pb", "pbvr"), default="btgp")
    run.add_argument("--every", type=_positive_int, default=1, help="update after every N range readings (1 or 10 in the paper)")
    run.add_argument("--skip", type=_positive_int, default=1, help="time steps between estimated states")
    run.add_argument("--interpolate", action=argparse.BooleanOptionalAction, default=True, help="interpolate readings between states (Eq. 29) or drop them")
    run.add_argument("--range-states", action="store_true", help="also estimate a state at every pose with a range reading (the layout of the Plaza script, plaza_isam2.m)")
    run.add_argument("--departure", action="append", choices=list(DEPARTURES), default=[],
                     help="depart from the paper's scripts in this named way (repeatable; docs/experiments.md gives each one's effect)")
    run.add_argument("--preset", choices=("synthetic", "plaza"), default=None, help="parameter set (default: by data set; plaza for a PATH)")
    run.add_argument("--prior", choices=PRIORS, default="wnoa",
                     help="motion prior: the paper's white noise on acceleration, or on jerk, or Singer's model (docs/derivations.md)")
    run.add_argument("--qc-scale", type=_positive_float, default=1.0,
                     help="multiply the preset's Qc by this (a jerk prior needs its own: tutorial 06 uses 100 on Plaza)")
    run.add_argument("--singer-time-constant", type=_positive_float, default=PaperSetup.singer_time_constant,
                     help="Singer prior: the acceleration's time constant 1/α in seconds (default %(default)s)")
    run.add_argument("--data-dir", type=_folder, default=None, help="folder searched for data files before $STEAM_REF_DATA_DIR and gtsam's Data/")
    run.add_argument("--seed", type=_non_negative_int, default=0, help="seed of the generated synthetic task")
    run.add_argument("--relinearize-threshold", type=_non_negative_float, default=ISAM2Params.relinearize_threshold,
                     help="BTGP: relinearize a variable whose increment exceeds this (default %(default)s)")
    run.add_argument("--relinearize-skip", type=_positive_int, default=ISAM2Params.relinearize_skip,
                     help="BTGP: check relinearization every N-th update (default %(default)s, GTSAM's)")
    run.add_argument("--max-poses", type=_number(int, 2, strict=False), default=None, help="process only the first N poses")
    run.add_argument("--time-budget", type=_positive_float, default=None, help="stop after this many seconds (reported)")
    run.add_argument("--progress", action="store_true", help="show a progress bar")
    run.add_argument("--json", action="store_true", help="print one JSON line of figures")
    run.add_argument("--save-estimates", metavar="FILE.npz", default=None, help="write the estimate at every time step (pose and velocity), the landmarks, and their final marginal covariances")
    run.add_argument("--plot", metavar="FILE.png", default=None, help="draw estimate, ground truth, dead reckoning, landmarks")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``steam-ref``."""
    parser = _Parser(prog="steam-ref", description="Incremental sparse GP regression for continuous-time STEAM (Yan, Indelman, Boots).")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser)
    _add_run_arguments(sub.add_parser("run", help="stream a data set through one solver"))
    bat = sub.add_parser("batch", help="batch Gauss-Newton on all of a data set (PB or PBVR): RMSE and a plot")
    bat.add_argument("--dataset", type=_dataset, default="paper-synthetic", help="synthetic, paper-synthetic, plaza or a PATH")
    bat.add_argument("--ordering", choices=("xl", "amd"), default="amd", help="xl: the paper's PB; amd: PBVR")
    bat.add_argument("--preset", choices=("synthetic", "plaza"), default=None, help="parameter set (default: by data set)")
    bat.add_argument("--data-dir", type=_folder, default=None, help="folder searched for data files before $STEAM_REF_DATA_DIR and gtsam's Data/")
    bat.add_argument("--seed", type=_non_negative_int, default=0, help="seed of the generated synthetic task")
    bat.add_argument("--json", action="store_true", help="print one JSON line of figures")
    bat.add_argument("--plot", metavar="FILE.png", default=None, help="draw estimate, ground truth, landmarks")
    fid = sub.add_parser("fidelity", help="BTGP/1 against the authors' saved runs, pose by pose, covariances included")
    fid.add_argument("--dataset", choices=("plaza", "paper-synthetic", "all"), default="all")
    fid.add_argument("--data-dir", type=_folder, default=None, help="folder searched for data files (and its authors/ folder) before $STEAM_REF_DATA_DIR and gtsam's Data/")
    fid.add_argument("--json", action="store_true", help="print one JSON line per data set")
    fid.add_argument("--plot", metavar="FILE.png", default=None, help="draw the per-pose distance to the authors' estimate")
    rep = sub.add_parser("reproduce", help="the experiments of Fig. 3 and Fig. 4, plots and a results table")
    rep.add_argument("--quick", action="store_true", help="small prefixes and budgets: minutes, not hours")
    rep.add_argument("--out", default="results", help="folder for plots and the table (default: results)")
    rep.add_argument("--data-dir", type=_folder, default=None, help="folder searched for data files before $STEAM_REF_DATA_DIR and gtsam's Data/")
    conformance_command.add_parser(sub)
    return parser


def _check_output(path: str | None, suffix: str, option: str) -> None:
    """Before the run: ``path`` ends in ``suffix`` and can be written (tried, and left as it was)."""
    if path is None:
        return
    if not path.endswith(suffix):
        raise SteamError(f"{option} expects a {suffix} file name, got {path!r}")
    target = Path(path)
    if target.is_dir():
        raise SteamError(f"{option}: {path!r} is a folder, not a file")
    parent = target.resolve().parent
    if not parent.is_dir():
        raise SteamError(f"{option}: folder {str(parent)!r} does not exist")
    existed = target.exists()
    try:
        with open(target, "ab"):
            pass
    except OSError as err:
        raise SteamError(f"{option}: cannot write {path!r} ({err.strerror or err})") from None
    if not existed:
        target.unlink()
    if suffix == ".png" and importlib.util.find_spec("matplotlib") is None:
        raise SteamError(f"{option} needs matplotlib, which is not installed (pip install matplotlib)")


def _check_out_folder(path: str, option: str) -> None:
    """Before the runs: ``path`` is a folder that exists and can be written, or can be made."""
    if not path.strip():
        raise SteamError(f"{option}: expected a folder, got an empty string")
    target = Path(path).resolve()
    if target.exists() and not target.is_dir():
        raise SteamError(f"{option}: {path!r} is a file, not a folder")
    existing = next(p for p in (target, *target.parents) if p.exists())
    if not existing.is_dir():
        raise SteamError(f"{option}: cannot make folder {path!r}: {str(existing)!r} is a file")
    try:
        with tempfile.TemporaryFile(dir=existing):
            pass
    except OSError as err:
        raise SteamError(f"{option}: cannot write in {str(existing)!r} ({err.strerror or err})") from None


def _run(args: argparse.Namespace) -> int:
    _check_output(args.save_estimates, ".npz", "--save-estimates")
    _check_output(args.plot, ".png", "--plot")
    preset = args.preset or _PRESET_OF.get(args.dataset, "plaza")
    setup = PaperSetup.named(preset).departing(*args.departure)
    setup = setup.replace(prior=args.prior, qc=args.qc_scale * setup.qc, singer_time_constant=args.singer_time_constant)
    options = StreamOptions(
        method=args.method, every=args.every, skip=args.skip, interpolate=args.interpolate,
        range_states=args.range_states, max_poses=args.max_poses, time_budget_s=args.time_budget,
        progress=args.progress,
        isam2=setup.isam2_params().replace(relinearize_threshold=args.relinearize_threshold, relinearize_skip=args.relinearize_skip),
    )
    data = load_dataset(args.dataset, data_dir=args.data_dir, seed=args.seed)
    result = run_online(data, setup, options, covariances=args.save_estimates is not None)
    summary = result.summary(args.dataset) | {"departures": args.departure, "prior": args.prior, "qc_scale": args.qc_scale}
    if args.json:
        print(json.dumps(summary))
    else:
        _print_summary(summary)
    if args.save_estimates:
        save_estimates(args.save_estimates, result)
    if args.plot:
        plot_trajectory(
            data.ground_truth[:, 1:3], result.trajectory[:, :2], landmarks_true=data.landmarks[:, 1:3],
            landmarks_estimated=result.landmarks, dead_reckoning=data.dead_reckoning[:, 1:3],
            estimate_label=f"{result.method.upper()} estimate", path=args.plot,
        )
    return 0


def _print_summary(summary: dict) -> None:
    state = "" if summary["completed"] else "  (cut short: time budget or --max-poses)"
    print(
        f"{summary['method'].upper()}/{summary['every']} on {summary['dataset']}: skip {summary['skip']}, "
        f"{'with' if summary['interpolate'] else 'without'} interpolation, {summary['n_estimated_states']} states\n"
        f"  RMSE {summary['rmse_m']} m over {summary['n_poses']} time steps"
        + ("" if summary["n_estimated_states"] == summary["n_poses"] else f" ({summary['rmse_estimated_m']} m at the estimated states)")
        + f", total {summary['total_s']:.2f} s, "
        f"update median {summary['update_s_median']} s, p95 {summary['update_s_p95']} s, peak RSS {summary['peak_rss_mb']} MB{state}"
    )


def save_estimates(path: str, result) -> None:
    """Write a run to an .npz file: ``times``, ``x``, ``y``, ``theta`` and ``xdot``, ``ydot``,
    ``thetadot`` at every covered time step (and ``xddot``, ``yddot``, ``thetaddot`` with a WNOJ or Singer
    prior), ``state_poses`` (pose indices with a state),
    ``landmark_ids`` and ``landmarks`` (m, 2), and, when the run has them, the final marginal
    covariances ``pose_covariance`` (n, 3, 3), ``velocity_covariance`` (n, 3, 3) and
    ``landmark_covariance`` (m, 2, 2), in the order of ``times`` and ``landmark_ids``."""
    ids = np.array(sorted(result.landmarks), dtype=int)
    marks = np.array([result.landmarks[i] for i in ids]).reshape(-1, 2)
    tr = result.trajectory
    arrays = dict(times=result.times, x=tr[:, 0], y=tr[:, 1], theta=tr[:, 2], xdot=tr[:, 3], ydot=tr[:, 4], thetadot=tr[:, 5],
                  state_poses=result.state_poses, landmark_ids=ids, landmarks=marks)
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
    setup = PaperSetup.named(args.preset or _PRESET_OF.get(args.dataset, "plaza"))
    data = load_dataset(args.dataset, data_dir=args.data_dir, seed=args.seed)
    problem = build_problem(data, setup)
    t0 = time.perf_counter()
    result = sequential_batch(problem, ordering=args.ordering)
    seconds = time.perf_counter() - t0
    positions = np.array([result.values[X(i)][:2] for i in range(data.n_poses)])
    summary = {
        "dataset": args.dataset, "ordering": args.ordering, "n_states": len(problem.states),
        "rmse_m": round(position_rmse(positions, data.ground_truth[:, 1:3]), 6), "total_s": round(seconds, 3),
        "iterations": len(result.iterations), "factor_nnz": result.factor_nnz, "backend": result.backend,
    }
    if args.json:
        print(json.dumps(summary))
    else:
        print(f"batch ({args.ordering.upper()}) on {args.dataset}: RMSE {summary['rmse_m']} m over {data.n_poses} poses, "
              f"{summary['total_s']:.2f} s, Cholesky factor {summary['factor_nnz']} nonzeros ({summary['backend']})")
    if args.plot:
        plot_trajectory(
            data.ground_truth[:, 1:3], positions, landmarks_true=data.landmarks[:, 1:3],
            title=f"batch on {args.dataset}", path=args.plot,
        )
    return 0


def _fidelity(args: argparse.Namespace) -> int:
    """BTGP/1 with the paper's set-up against the authors' saved run of each data set."""

    _check_output(args.plot, ".png", "--plot")
    distances = {}
    for name in AUTHORS_RUNS if args.dataset == "all" else [args.dataset]:
        find_authors_file(name, args.data_dir)  # before loading: gtsam's Plaza files are not the authors' data
        data = load_dataset(name, data_dir=args.data_dir)
        authors = load_authors_run(name, data, args.data_dir)
        setup = PaperSetup.named(_PRESET_OF[name])
        result = run_online(data, setup, covariances=authors.pose_covariance is not None)
        fid, distances[name] = compare(result, authors, data.ground_truth)
        row = fid.to_dict() | {"total_s": round(result.total_s, 2), "authors_total_s": round(float(authors.step_seconds.sum()), 2)}
        print(json.dumps(row) if args.json else _fidelity_text(row))
    if args.plot:
        plot_fidelity(distances, path=args.plot)
    return 0


def _mm(metres: float) -> str:
    return f"{1000 * metres:.2f} mm"


def _fidelity_text(row: dict) -> str:
    cov = "" if row["pose_cov_median"] is None else (
        f"\n  marginal covariances, relative difference: pose median {row['pose_cov_median']:.2%} (max {row['pose_cov_max']:.2%}), "
        f"velocity median {row['velocity_cov_median']:.2%} (max {row['velocity_cov_max']:.2%}), landmarks max {row['landmark_cov_max']:.2%}")
    return (f"{row['dataset']}: {row['n_states']} states; distance to the authors' estimate RMS {_mm(row['pose_rms_m'])}, "
            f"max {_mm(row['pose_max_m'])} at pose {row['pose_max_at']}; landmarks max {_mm(row['landmark_max_m'])}\n"
            f"  position RMSE {row['rmse_m']:.5f} m (authors {row['authors_rmse_m']:.5f} m); {row['total_s']} s "
            f"(authors' MATLAB + GTSAM 3.2: {row['authors_total_s']} s)" + cov)


def _reproduce(args: argparse.Namespace) -> int:
    _check_out_folder(args.out, "--out")
    table = reproduce(args.out, quick=args.quick, data_dir=args.data_dir)
    print(table)
    return 0


def _one_line(message: str) -> str:
    """``message`` with its line breaks escaped: an error is one line however odd the input it quotes."""
    return "".join(c if c.isprintable() or c == "\t" else repr(c)[1:-1] for c in message) or "(no message)"


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``steam-ref`` console script; returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        args = build_parser().parse_args(argv or ["run"])
        if args.command in (None, "run"):
            if args.command is None:
                args = build_parser().parse_args(["run"])
            return _run(args)
        commands = {"batch": _batch, "fidelity": _fidelity, "reproduce": _reproduce, "conformance": conformance_command.run}
        return commands[args.command](args)
    except (SteamError, OSError, MemoryError) as exc:
        print(f"steam-ref: error: {_one_line(str(exc))}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("steam-ref: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
