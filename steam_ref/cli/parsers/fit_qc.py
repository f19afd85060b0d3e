"""``steam-ref fit-qc``'s options (the command: :mod:`steam_ref.cli.fit_qc`), and what it checks before its machinery
loads (:func:`check`)."""

from __future__ import annotations

import argparse

from ...choices import PRESETS
from ...datasets.registry import DATASETS
from ...errors import DataError
from ..args import Subparsers, add_data_dir, add_dataset, add_prior, add_seed, check_prior_fits, number, preset_of

__all__ = ["add_parser", "check"]


def add_parser(sub: Subparsers) -> argparse.ArgumentParser:
    """Add ``fit-qc`` and its options to the command's subparsers."""
    parser = sub.add_parser(
        "fit-qc",
        help="fit a motion prior's Qc to a data set's ground truth (maximum likelihood)",
        example="steam-ref fit-qc --dataset plaza --max-poses 2000",
    )
    add_dataset(parser, "plaza")
    add_prior(
        parser,
        "the motion prior whose Qc is fitted: ",
        "; default: the preset's (wnoa)",
        "--prior se2 only: the SE(2) prior's residual (default: local-variable)",
    )
    parser.add_argument(
        "--preset",
        choices=PRESETS,
        default=None,
        help="the set-up whose GP clock and starting Qc are used (default: by data set; required for a PATH)",
    )
    parser.add_argument(
        "--max-poses", type=number(int, 3, strict=False), default=None, help="fit to the first N poses only"
    )
    add_data_dir(parser)
    add_seed(parser)
    parser.add_argument("--json", action="store_true", help="print one JSON line of figures")
    return parser


def check(args: argparse.Namespace) -> None:
    """What ``fit-qc`` checks before it reads anything, with no solver loaded: a 3-D set is refused (no fit on SE(3)
    yet), then the prior against the data set's space, then the data set's preset (for a PATH, the data search finds
    it: a name that is neither a set nor a file is refused here). :func:`steam_ref.cli.commands.main` calls it before
    it loads the command's module, and :func:`steam_ref.cli.fit_qc.run` first."""
    if args.dataset in DATASETS and DATASETS[args.dataset].dimensions != 2:
        raise DataError(
            f"--dataset {args.dataset}: fit-qc fits Qc to the planar poses of a run's ground truth, and this set is "
            f"{DATASETS[args.dataset].dimensions}-D (a Qc fit on SE(3) is not built yet)"
        )
    check_prior_fits(args.dataset, args.prior)
    preset_of(args)
