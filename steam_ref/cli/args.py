"""What the ``steam-ref`` command's arguments accept, and the arguments its commands share.

Every value is checked by its argparse type, so a bad one is a one-line error with exit code 2 before
anything runs. Each command's own options are in its module (``cli/parsers/run.py``, ``cli/parsers/batch.py``...,
:data:`~steam_ref.cli.commands.COMMANDS`); what they share is here: :class:`Parser`, the number types, the
data set and its folder (``--dataset`` offers the registry's names: :mod:`steam_ref.datasets.registry`), the
preset a data set runs with (for a PATH, found by the data search first: :func:`preset_of`), the motion prior and its
options (``--prior``, ``--se2-residual``, checked against :data:`~steam_ref.choices.MOTION_PRIOR_NAMES`),
``--max-poses``, ``--progress`` and ``--save-trajectory``.

Like the parsers, it imports only :mod:`steam_ref.choices`, the registry and the data search (whose readers load
when a file is read): no NumPy, no solver. What a command makes of its arguments once it runs (the data set loaded, Qc scaled) is
:mod:`steam_ref.cli.inputs`.
"""

from __future__ import annotations

import argparse
import math
import re
from pathlib import Path
from typing import Any, Protocol

from ..choices import DECIMAL, MOTION_PRIOR_NAMES, PRESETS, RESIDUALS, parse_decimal, underflowed
from ..datasets.registry import DATASETS, loadable
from ..datasets.search import data_dir_help, dataset_path
from ..errors import SteamError
from .once import StoreOnce, SwitchOnce

__all__ = [
    "MAX_JOBS",
    "MAX_LANDMARKS",
    "MAX_SEEDS",
    "MAX_STEPS",
    "QC_SCALES",
    "SINGER_TIME_CONSTANTS",
    "Parser",
    "add_data_dir",
    "add_dataset",
    "add_max_poses",
    "check_steps",
    "add_prior",
    "add_progress",
    "check_prior_options",
    "check_prior_fits",
    "add_qc",
    "add_seed",
    "add_trajectory_arguments",
    "dataset_name",
    "folder",
    "not_planar",
    "path",
    "jobs_count",
    "landmarks_count",
    "non_negative_float",
    "non_negative_int",
    "number",
    "positive_float",
    "positive_int",
    "preset_for",
    "is_rigid",
    "preset_of",
    "qc_diagonal",
    "scale",
    "seed_of",
    "seeds_count",
    "steps_count",
]


class Subparsers(Protocol):
    """What a command's ``add_parser(sub)`` is given: argparse's subparsers, by the one method it calls."""

    def add_parser(self, name: str, **kwargs: Any) -> argparse.ArgumentParser: ...


def _command_help(kwargs: dict[str, Any]) -> dict[str, Any]:
    """A subcommand's ``add_parser`` keywords with its ``help`` line atop its own ``--help`` too, and ``example=``, one
    command line that runs as written, as the help's last line."""
    kwargs.setdefault("description", kwargs.get("help"))
    example = kwargs.pop("example", None)
    if example is not None:
        kwargs.setdefault("epilog", f"example: {example}")
    return kwargs


class Parser(argparse.ArgumentParser):
    """argparse that reports a usage error as one line and exit code 2, and reads a negative number in any form of
    :data:`~steam_ref.arguments.DECIMAL` (``-1e-3``, not only ``-1`` and ``-0.5``) as a value, not an option.
    Its subcommands repeat their ``help`` atop their own ``--help`` and end it with an ``example=``
    (:func:`_command_help`)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", argparse.RawDescriptionHelpFormatter)  # an example stays one line
        super().__init__(*args, **kwargs)
        self._negative_number_matcher = re.compile(f"^-(?:{DECIMAL.pattern.removeprefix('[+-]?')})$")
        for name in (None, "store"):  # an option given twice with two values is refused (cli/once.py)
            self.register("action", name, StoreOnce)

    def add_subparsers(self, **kwargs: Any) -> Any:
        """argparse's subcommands, each ``add_parser`` given :func:`_command_help`'s keywords."""
        commands = super().add_subparsers(**kwargs)
        plain = commands.add_parser
        # this action's own add_parser (argparse's action class is private: not subclassed)
        commands.add_parser = lambda name, **options: plain(name, **_command_help(options))  # type: ignore[method-assign]
        return commands

    def error(self, message: str) -> None:  # type: ignore[override]
        raise SteamError(f"{message} (see '{self.prog} --help')")


def number(convert: type, lower: float, *, strict: bool, upper: float = math.inf, why: str = ""):
    """An argparse type: ``text`` by the one rule for numbers (:func:`~steam_ref.arguments.parse_decimal`),
    above ``lower`` (``strict``) or at least it, and at most ``upper`` (beyond it, ``why``)."""
    what = f"{'an integer' if convert is int else 'a finite number'} {'>' if strict else '>='} {lower:g}"
    what += f" and <= {upper:g} ({why})" if upper < math.inf else ""

    def parse(text: str):
        value = parse_decimal(text, convert)
        if value is not None and (lost := underflowed(text, value)):  # '1e-400' is not 0
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}{lost}")
        if value is None or not math.isfinite(value) or value < lower or (strict and value == lower) or value > upper:
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
        return value

    return parse


def scale(lower: float, upper: float, why: str):
    """An argparse type: a finite number in [lower, upper] (outside it, ``why``)."""
    what = f"a number from {lower:g} to {upper:g}"

    def parse(text: str) -> float:
        value = parse_decimal(text)
        lost = underflowed(text, value)  # '--turn 1e-400' is not 0
        if lost or value is None or not (math.isfinite(value) and lower <= value <= upper):
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}{lost} ({why})")
        return value

    return parse


# The preset's Qc balances the prior against the readings; a scale s moves the prior's information by 1/s,
# and beyond about sqrt(1/eps) = 6.7e7 either way float64 no longer resolves the readings beside the prior
# (or the prior beside them): the elimination then breaks down, blaming a variable. Past 1e8 refused here, for
# --qc-scale and for the Qc a run ends with (--qc times --qc-scale, each diagonal entry beside the preset's:
# --qc 1e308,1e308,1e308 made the prior's information vanish beside the readings, "x1 is not constrained").
QC_SCALES = (1e-8, 1e8)


def add_qc(parser: argparse.ArgumentParser) -> None:
    """--qc: a diagonal Qc in place of the preset's, as ``steam-ref fit-qc`` prints it."""
    parser.add_argument(
        "--qc",
        type=qc_diagonal,
        default=None,
        metavar="QXX,QYY,QTT",
        help="the prior's Qc, diagonal, in place of the preset's (three numbers > 0 on the preset's GP clock, as "
        "`steam-ref fit-qc` prints them; --qc-scale then multiplies it)",
    )


def qc_diagonal(text: str) -> list[float]:
    """An argparse type: a diagonal Qc as three comma-separated numbers > 0 ('0.0005,0.0005,0.0001')."""
    parts = text.split(",")
    values = [parse_decimal(part.strip()) for part in parts]
    if len(parts) != 3 or any(v is None or not (math.isfinite(v) and v > 0) for v in values):
        raise argparse.ArgumentTypeError(
            f"expected three numbers > 0 separated by commas (Qc's diagonal), got {text!r}"
        )
    return [float(v) for v in values if v is not None]


# Singer's 1/alpha, the acceleration's memory: the prior refuses an alpha*dt too stiff for float64 (1.4e4, naming the
# gap: gp.models.check_singer_step), below 1e-6 s it is no motion's; above 1e8 s it is WNOJ to float64's precision.
SINGER_TIME_CONSTANTS = (1e-6, 1e8)


# Sizes of generated work, bounded so that a typo is a one-line refusal, not numpy's "Unable to allocate" (or
# an empty MemoryError) minutes later. The generator finds each pose's nearest landmarks among all of them:
# steps × landmarks distances, 0.6 GB at 20,000 steps with the default density (the paper's task has 1,500).
MAX_STEPS = 20_000

MAX_LANDMARKS = 10_000


# Worker processes (--jobs): each is a Python with NumPy and SciPy loaded (~100 MB) on a core of its own; past this a
# typo (--jobs 100000) would spend minutes spawning workers, and a count past C's int is loky's OverflowError.
MAX_JOBS = 64

MAX_SEEDS = 100_000  # Monte Carlo runs (the default is 200): each is a whole task, and a line of the log


steps_count = number(int, 0, strict=True, upper=MAX_STEPS, why="the generated task is held in memory")

landmarks_count = number(int, 0, strict=True, upper=MAX_LANDMARKS, why="the generated task is held in memory")

seeds_count = number(int, 0, strict=True, upper=MAX_SEEDS, why="each run is a whole task")

jobs_count = number(int, 0, strict=True, upper=MAX_JOBS, why="each is a worker process of its own")


positive_int = number(int, 0, strict=True)

non_negative_int = number(int, 0, strict=False)


positive_float = number(float, 0, strict=True)

non_negative_float = number(float, 0, strict=False)


def dataset_name(text: str) -> str:
    """An argparse type: a data set name or path, not empty (an empty path would be the working folder)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a data set name or a path, got an empty string")
    return text


def add_dataset(parser: argparse.ArgumentParser, default: str) -> None:
    """--dataset: a name of the registry (datasets/registry.py, read when the parser is built) or a PATH."""
    names = [f"{n} (generated)" if not DATASETS[n].files else n for n in loadable()]
    parser.add_argument(
        "--dataset",
        type=dataset_name,
        default=default,
        help=f"{', '.join(names)}, or a PATH (.mat, CMU text folder, GTSAM .txt); `steam-ref data list` shows "
        "which are present",
    )


def add_prior(parser: argparse.ArgumentParser, head: str, tail: str, se2_residual: str) -> None:
    """--prior (a name of ``MOTION_PRIOR_NAMES``; its help ``head``, each prior with what it is, then ``tail``) and
    --se2-residual (help ``se2_residual``), each None unless given: the preset's then (:func:`check_prior_options`)."""
    parser.add_argument(
        "--prior",
        choices=tuple(MOTION_PRIOR_NAMES),
        default=None,
        help=head + "; ".join(f"{name}, {choice.what}" for name, choice in MOTION_PRIOR_NAMES.items()) + tail,
    )
    parser.add_argument("--se2-residual", choices=RESIDUALS, default=None, help=se2_residual)


def check_prior_options(prior: str, given: dict[str, object]) -> None:
    """SteamError unless each option ``given`` (its name → value, None for not given) is one ``prior`` takes
    (``MOTION_PRIOR_NAMES``), naming the priors that do."""
    for name, value in given.items():
        if value is not None and name not in MOTION_PRIOR_NAMES[prior].options:
            takers = " or ".join(f"--prior {p}" for p, choice in MOTION_PRIOR_NAMES.items() if name in choice.options)
            raise SteamError(f"--{name.replace('_', '-')} applies to {takers} only, not --prior {prior}")


def check_prior_fits(dataset: str, prior: str | None) -> None:
    """SteamError, one line, when the prior named by ``--prior`` (None: not given, the data set's own) moves a body in
    a space of other dimensions than ``--dataset``'s (``PriorChoice.dimensions`` against ``DataSet.dimensions``; a
    PATH is a planar file), naming the sets the prior runs on and the priors the set runs with."""
    if prior is None:
        return
    record = DATASETS.get(dataset)
    space, wanted = (2 if record is None else record.dimensions), MOTION_PRIOR_NAMES[prior].dimensions
    if wanted == space:
        return
    sets = [n for n in loadable() if DATASETS[n].dimensions == wanted]
    priors = [p for p, choice in MOTION_PRIOR_NAMES.items() if choice.dimensions == space]
    raise SteamError(
        f"--prior {prior} moves a body in {wanted}-D and --dataset {dataset} is {space}-D: --prior {prior} runs on "
        f"--dataset {' | '.join(sets)}; --dataset {dataset} runs with --prior {' | '.join(priors)}"
    )


def path(what: str):
    """An argparse type: a non-empty path (``Path("")``, the working folder, no one means); ``what`` names it."""

    def parse(text: str) -> str:
        if not text.strip():
            raise argparse.ArgumentTypeError(f"expected {what}, got an empty path {text!r}")
        return text

    return parse


def folder(text: str) -> str:
    """An argparse type: an existing folder (a mistyped --data-dir must not be passed over in silence)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a folder, got an empty string")
    if not Path(text).is_dir():
        raise argparse.ArgumentTypeError(f"{text!r} {'is not a folder' if Path(text).exists() else 'does not exist'}")
    return text


def add_data_dir(parser: argparse.ArgumentParser, also: str = "") -> None:
    """--data-dir: the one folder the user names, searched first (its help, the whole order: datasets/search.py)."""
    parser.add_argument(
        "--data-dir",
        type=folder,
        default=None,
        help=data_dir_help(also),
    )


def add_trajectory_arguments(parser: argparse.ArgumentParser, which: str = "") -> None:
    """--save-trajectory FILE and its format (run and batch); ``which`` says whose estimate, if need be."""
    parser.add_argument(
        "--save-trajectory",
        metavar="FILE",
        default=None,
        help="write the estimated pose at every time step: TUM (timestamp tx ty tz qx qy qz qw, read by evo) or "
        f"KITTI{which}",
    )
    parser.add_argument(
        "--trajectory-format", choices=("tum", "kitti"), default=None, help="of --save-trajectory (default: tum)"
    )


def add_max_poses(parser: argparse.ArgumentParser) -> None:
    """--max-poses N (>= 2): the first N poses of the data set, as a run streams them (run, batch; 3-D: N states)."""
    first = number(int, 2, strict=False)
    parser.add_argument("--max-poses", type=first, default=None, metavar="N", help="process only the first N poses")


def add_progress(parser: argparse.ArgumentParser) -> None:
    """``--progress`` / ``--no-progress`` (steam_ref.paper.progress.wanted reads it)."""
    parser.add_argument(
        "--progress",
        action=SwitchOnce,
        default=None,
        help="a progress bar on stderr (default: on when stderr is a terminal and without --json)",
    )


def is_rigid(dataset: str) -> bool:
    """Whether ``--dataset`` names a 3-D set of the registry (``DataSet.rigid``): ``run`` and ``batch`` solve it on
    SE(3) (:func:`steam_ref.cli.rigid.run_rigid`, which checks its own options)."""
    return dataset in DATASETS and DATASETS[dataset].rigid


def not_planar(dataset: str) -> SteamError:
    """The refusal of a 3-D set by a command that solves planar ones only (``run`` and ``batch`` solve it)."""
    return SteamError(
        f"--dataset {dataset!r} is a 3-D set: `steam-ref run --dataset {dataset}` or `steam-ref batch --dataset "
        f"{dataset}` solves it"
    )


def preset_of(args: argparse.Namespace) -> str:
    """The preset a command runs with: --preset, else the named data set's; a data file given by PATH needs
    --preset (each preset changes what is done to the file: Plaza's fits a range correction to its truth)."""
    if args.preset is not None:
        return args.preset
    if is_rigid(args.dataset):
        raise not_planar(args.dataset)
    if args.dataset not in DATASETS or DATASETS[args.dataset].loader is None:
        dataset_path(args.dataset, getattr(args, "data_dir", None))  # no set, no file: the search says so first
    if args.dataset not in DATASETS or DATASETS[args.dataset].preset is None:
        raise SteamError(
            f"--dataset {args.dataset!r} is a path: say which parameters it runs with, --preset {{{','.join(PRESETS)}}} "
            "(plaza also fits a range correction to the file's own ground truth)"
        )
    return preset_for(args.dataset)


def preset_for(name: str) -> str:
    """The preset the registry's data set ``name`` runs with (``DataSet.preset``)."""
    preset = DATASETS[name].preset
    if preset is None:
        raise SteamError(f"data set {name!r} names no preset in datasets/registry.py")
    return preset


def add_seed(parser: argparse.ArgumentParser) -> None:
    """--seed: the seed of a generated data set (None unless given: :func:`seed_of`)."""
    parser.add_argument(
        "--seed", type=non_negative_int, default=None, help="seed of the generated synthetic task (default 0)"
    )


def _generated() -> str:
    """The data sets steam_ref generates (no file), as ``--dataset`` takes them: ``synthetic | synthetic-3d``."""
    return " | ".join(n for n in loadable() if not DATASETS[n].files)


def seed_of(args: argparse.Namespace) -> int:
    """``--seed``, 0 when not given; SteamError when it is given with a data set read from a file, which it would
    leave as it is (it draws a generated set only)."""
    if args.seed is None:
        return 0
    if args.dataset not in DATASETS or DATASETS[args.dataset].files:
        raise SteamError(
            f"--seed {args.seed} draws a generated data set (--dataset {_generated()}); --dataset {args.dataset!r} is "
            "read from a file, which no seed changes: drop --seed"
        )
    return args.seed


def check_steps(args: argparse.Namespace) -> None:
    """``run --steps N`` generates the data set (planar or 3-D): SteamError when ``--dataset`` is read from a file."""
    if args.steps is not None and (args.dataset not in DATASETS or DATASETS[args.dataset].files):
        raise SteamError(
            f"--steps generates the synthetic task: it needs --dataset {_generated()}, got {args.dataset!r}"
        )
