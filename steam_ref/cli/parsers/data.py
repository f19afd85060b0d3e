"""``steam-ref data``'s subcommands and options (the command: :mod:`steam_ref.cli.data`)."""

from __future__ import annotations

import argparse

from ...datasets.fetch import DATA_URL_ENV
from ...datasets.registry import DATASETS
from ..args import Subparsers

__all__ = ["add_parser", "SOLVES"]

SOLVES = False  # lists and downloads files: runs no solver, so $STEAM_REF_BLAS_THREADS is not read


def add_parser(sub: Subparsers) -> argparse.ArgumentParser:
    """Add ``data`` with its ``list`` and ``fetch`` subcommands to the command's subparsers."""
    data = sub.add_parser(
        "data",
        help="the paper's data by name: list them, fetch them (sha256-checked)",
        example="steam-ref data list",
    )
    what = data.add_subparsers(dest="data_command", required=True, parser_class=type(data), metavar="{list,fetch}")
    what.add_parser(
        "list",
        help="each data set: source, licence note, size, present or not and where",
        example="steam-ref data list",
    )
    get = what.add_parser(
        "fetch",
        help="download data sets from the authors' repository (pinned commit) into the user's cache folder",
        example="steam-ref data fetch plaza",
    )
    get.add_argument(
        "names",
        nargs="*",
        metavar="NAME",
        help=f"data sets to fetch (default: all of {', '.join(n for n, s in DATASETS.items() if s.fetchable)})",
    )
    get.add_argument(
        "--base-url",
        default=None,
        help=f"a mirror to fetch the files from by name (default: ${DATA_URL_ENV}, else the authors' repository)",
    )
    return data
