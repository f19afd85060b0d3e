"""The ``steam-ref`` command line: its parser, the checks of every argument, and of output paths before a run.

Every value is checked by its argparse type, so a bad one is a one-line error with exit code 2 before
anything runs; :mod:`steam_ref.cli.commands` holds what each command does.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import importlib.util
import math
import os
import secrets
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path

from .._version import __version__
from ..bayes_tree import ISAM2Params
from ..conformance import command as conformance_command
from ..errors import SteamError
from ..paper.presets import DEPARTURES, PRESETS, PRIORS, PaperSetup

__all__ = ["build_parser", "check_output", "check_out_folder", "write_output"]


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


def _scale(lower: float, upper: float, why: str):
    """An argparse type: a finite number in [lower, upper] (outside it, ``why``)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and lower <= value <= upper):
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
    run.add_argument(
        "--dataset",
        type=_dataset,
        default="synthetic",
        help="synthetic (generated), paper-synthetic, plaza, or a PATH (.mat or CMU text folder)",
    )
    run.add_argument("--method", choices=("btgp", "pb", "pbvr"), default="btgp")
    run.add_argument(
        "--every",
        type=_positive_int,
        default=None,
        help="update after every N landmark readings (1 or 10 in the paper; default: the preset's, 10 for victoria-park, else 1)",
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
        "--preset", choices=PRESETS, default=None, help="parameter set (default: by data set; plaza for a PATH)"
    )
    run.add_argument(
        "--prior",
        choices=PRIORS,
        default="wnoa",
        help="motion prior: the paper's white noise on acceleration, or on jerk, or Singer's model (docs/derivations.md)",
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
        help=f"Singer prior (--prior singer only): the acceleration's time constant 1/α in seconds, 1e-6 to 1e8 "
        f"(default {PaperSetup.singer_time_constant})",
    )
    run.add_argument(
        "--data-dir",
        type=_folder,
        default=None,
        help="folder searched for data files before $STEAM_REF_DATA_DIR and gtsam's Data/",
    )
    run.add_argument("--seed", type=_non_negative_int, default=0, help="seed of the generated synthetic task")
    run.add_argument(
        "--relinearize-threshold",
        type=_non_negative_float,
        default=ISAM2Params.relinearize_threshold,
        help="BTGP: relinearize a variable whose increment exceeds this (default %(default)s)",
    )
    run.add_argument(
        "--relinearize-skip",
        type=_positive_int,
        default=ISAM2Params.relinearize_skip,
        help="BTGP: check relinearization every N-th update (default %(default)s, GTSAM's)",
    )
    run.add_argument(
        "--max-poses", type=_number(int, 2, strict=False), default=None, help="process only the first N poses"
    )
    run.add_argument(
        "--time-budget", type=_positive_float, default=None, help="stop after this many seconds (reported)"
    )
    run.add_argument("--progress", action="store_true", help="show a progress bar")
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


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``steam-ref``."""
    parser = _Parser(
        prog="steam-ref",
        description="Incremental sparse GP regression for continuous-time STEAM (Yan, Indelman, Boots).",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", parser_class=_Parser)
    _add_run_arguments(sub.add_parser("run", help="stream a data set through one solver"))
    bat = sub.add_parser("batch", help="batch Gauss-Newton on all of a data set (PB or PBVR): RMSE and a plot")
    bat.add_argument(
        "--dataset", type=_dataset, default="paper-synthetic", help="synthetic, paper-synthetic, plaza or a PATH"
    )
    bat.add_argument("--ordering", choices=("xl", "amd"), default="amd", help="xl: the paper's PB; amd: PBVR")
    bat.add_argument("--preset", choices=PRESETS, default=None, help="parameter set (default: by data set)")
    bat.add_argument(
        "--data-dir",
        type=_folder,
        default=None,
        help="folder searched for data files before $STEAM_REF_DATA_DIR and gtsam's Data/",
    )
    bat.add_argument("--seed", type=_non_negative_int, default=0, help="seed of the generated synthetic task")
    bat.add_argument("--json", action="store_true", help="print one JSON line of figures")
    bat.add_argument("--plot", metavar="FILE.png", default=None, help="draw estimate, ground truth, landmarks")
    fid = sub.add_parser("fidelity", help="BTGP/1 against the authors' saved runs, pose by pose, covariances included")
    fid.add_argument("--dataset", choices=("plaza", "paper-synthetic", "all"), default="all")
    fid.add_argument(
        "--data-dir",
        type=_folder,
        default=None,
        help="folder searched for data files (and its authors/ folder) before $STEAM_REF_DATA_DIR and gtsam's Data/",
    )
    fid.add_argument("--json", action="store_true", help="print one JSON line per data set")
    fid.add_argument(
        "--plot", metavar="FILE.png", default=None, help="draw the per-pose distance to the authors' estimate"
    )
    rep = sub.add_parser("reproduce", help="the experiments of Fig. 3 and Fig. 4, plots and a results table")
    rep.add_argument("--quick", action="store_true", help="small prefixes and budgets: minutes, not hours")
    rep.add_argument("--out", default="results", help="folder for plots and the table (default: results)")
    rep.add_argument(
        "--data-dir",
        type=_folder,
        default=None,
        help="folder searched for data files before $STEAM_REF_DATA_DIR and gtsam's Data/",
    )
    conformance_command.add_parser(sub)
    return parser


_KINDS = {
    stat.S_IFIFO: "a named pipe",
    stat.S_IFCHR: "a character device",
    stat.S_IFBLK: "a block device",
    stat.S_IFSOCK: "a socket",
    stat.S_IFDIR: "a folder",
}


def _kind(mode: int) -> str:
    """What an lstat/stat mode is, in words ("a file" for a regular one)."""
    return "a file" if stat.S_ISREG(mode) else _KINDS.get(stat.S_IFMT(mode), "not a regular file")


def _refuse_path(option: str, path: str, err: OSError) -> SteamError:
    """Why ``path`` cannot be reached, in words: a part of it is a file, a link loop, ..."""
    if err.errno == errno.ELOOP:
        return SteamError(f"{option}: {path!r} is a loop of symbolic links")
    if err.errno == errno.ENOTDIR:
        blocker = next((p for p in Path(path).parents if p.is_file()), None)
        where = f"{str(blocker)!r} is a file, not a folder" if blocker else "a part of it is not a folder"
        return SteamError(f"{option}: cannot write {path!r}: {where}")
    return SteamError(f"{option}: cannot write {path!r} ({err.strerror or err})")


def _writable_folder(folder: Path, option: str, path: str) -> None:
    """``folder`` exists, is a folder, and a file can be made in it (an unnamed temporary file is tried)."""
    try:
        mode = os.stat(folder).st_mode
    except FileNotFoundError:
        raise SteamError(f"{option}: cannot write {path!r}: folder {str(folder)!r} does not exist") from None
    except OSError as err:
        raise _refuse_path(option, path, err) from None
    if not stat.S_ISDIR(mode):
        raise SteamError(f"{option}: cannot write {path!r}: {str(folder)!r} is {_kind(mode)}, not a folder")
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as err:
        raise SteamError(f"{option}: cannot write in {str(folder)!r} ({err.strerror or err})") from None


def check_output(path: str | None, suffix: str, option: str) -> None:
    """Before the run: ``path`` ends in ``suffix`` and is a regular file that can be written, or nothing
    yet, in a folder that can be written in (through symbolic links, a dangling one included).

    Nothing is opened or made at ``path``: opening a named pipe blocks, and making a dangling link's
    target (then removing it) would change the user's files. A named pipe, a device, a socket, a folder
    or a link loop is refused. :func:`write_output` writes it after the run.
    """
    if path is None:
        return
    if not path.endswith(suffix):
        raise SteamError(f"{option} expects a {suffix} file name, got {path!r}")
    try:
        mode = os.stat(path).st_mode  # through links
    except FileNotFoundError:
        real = Path(os.path.realpath(path))  # where it would be made (a dangling link's target)
        _writable_folder(real.parent, option, path)
    except OSError as err:
        raise _refuse_path(option, path, err) from None
    else:
        if stat.S_ISDIR(mode):
            raise SteamError(f"{option}: {path!r} is a folder, not a file")
        if not stat.S_ISREG(mode):
            raise SteamError(
                f"{option}: {path!r} is {_kind(mode)}, not a regular file: refused, writing it could block"
            )
        if not os.access(path, os.W_OK):
            raise SteamError(f"{option}: cannot write {path!r} (permission denied or a read-only file system)")
        _writable_folder(Path(os.path.realpath(path)).parent, option, path)  # the new file is made beside it
    if suffix == ".png" and importlib.util.find_spec("matplotlib") is None:
        raise SteamError(f"{option} needs matplotlib, which is not installed (pip install matplotlib)")


def write_output(path: str, option: str, write: Callable[[str], object]) -> None:
    """Write an output ``path`` checked by :func:`check_output`: ``write(name)`` writes a new file beside
    its real target (a link is followed and stays a link), which then replaces it in one step.

    A failure (a full disk, ...) leaves what was at ``path`` as it was and is a SteamError naming the
    option and the path. A file that was there keeps its permission bits.
    """
    real = Path(os.path.realpath(path))
    temporary = real.parent / f".{real.name}.{os.getpid()}.{secrets.token_hex(4)}{Path(path).suffix}"
    try:
        os.close(os.open(temporary, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))  # the umask applies
        write(str(temporary))
        if real.exists():
            os.chmod(temporary, stat.S_IMODE(os.stat(real).st_mode))
        os.replace(temporary, real)
    except OSError as err:
        raise SteamError(
            f"{option}: cannot write {path!r} ({err.strerror or err}); what was there is left as it was"
        ) from None
    finally:
        with contextlib.suppress(OSError):
            os.unlink(temporary)


def check_out_folder(path: str, option: str) -> None:
    """Before the runs: ``path`` is a folder that exists and can be written, or can be made."""
    if not path.strip():
        raise SteamError(f"{option}: expected a folder, got an empty string")
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        if os.path.islink(path):
            raise SteamError(
                f"{option}: {path!r} is a symbolic link to {os.path.realpath(path)!r}, which does not exist"
            ) from None
        mode = None
    except OSError as err:
        raise _refuse_path(option, path, err) from None
    if mode is not None and not stat.S_ISDIR(mode):
        raise SteamError(f"{option}: {path!r} is {_kind(mode)}, not a folder")
    target = Path(path).resolve()
    existing = next(p for p in (target, *target.parents) if p.exists())
    if not existing.is_dir():
        raise SteamError(f"{option}: cannot make folder {path!r}: {str(existing)!r} is a file")
    try:
        with tempfile.TemporaryFile(dir=existing):
            pass
    except OSError as err:
        raise SteamError(f"{option}: cannot write in {str(existing)!r} ({err.strerror or err})") from None
