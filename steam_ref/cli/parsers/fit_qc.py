"""``steam-ref fit-qc``'s options (the command: :mod:`steam_ref.cli.fit_qc`)."""

from __future__ import annotations

import argparse

from ...choices import PRESETS
from ..args import Subparsers, add_data_dir, add_dataset, add_prior, add_seed, number

__all__ = ["add_parser"]


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
