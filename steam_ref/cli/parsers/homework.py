"""``steam-ref homework``'s subcommands and options (the command: :mod:`steam_ref.homework.command`,
which loads the marking)."""

from __future__ import annotations

import argparse

from ..args import jobs_count, number, path
from ..paths import check_output, check_outputs_apart

__all__ = ["add_parser"]

_path = path("a path")  # an empty path is refused (args.path)


MAX_SECONDS = 86_400  # --timeout's largest: a day


# The one rule for numbers written as text (args.number: 1_0, ５ and blanks are not numbers), as every command reads them
_seconds = number(int, 1, strict=False, upper=MAX_SECONDS, why="a day")


def add_parser(sub) -> argparse.ArgumentParser:
    """Add ``homework`` and its two subcommands to ``sub`` (an argparse subparsers object)."""
    hw = sub.add_parser(
        "homework",
        help="the tutorials as homework: build the student handouts, mark submissions",
        example="steam-ref homework handout tutorials/ --out handout/",
    )
    commands = hw.add_subparsers(
        dest="homework_command", parser_class=type(hw), required=True, metavar="{handout,mark}"
    )
    out = commands.add_parser(
        "handout",
        help="the teacher's notebooks without solutions or marking checks",
        example="steam-ref homework handout tutorials/ --out handout/",
    )
    out.add_argument("notebooks", nargs="+", type=_path, metavar="NOTEBOOK_OR_FOLDER", help="teacher's notebooks")
    out.add_argument("--out", type=_path, default="handout", help="folder to write the handouts to (default handout)")
    mark = commands.add_parser(
        "mark",
        help="run submitted notebooks with the teacher's checks; a score per exercise",
        example="steam-ref homework mark submitted/ --source tutorials/",
    )
    mark.add_argument(
        "submissions", nargs="+", type=_path, metavar="SUBMISSION_OR_FOLDER", help="notebooks, or folders of them"
    )
    mark.add_argument(
        "--source", type=_path, default="tutorials", help="folder of the teacher's notebooks (default tutorials)"
    )
    mark.add_argument(
        "--timeout",
        type=_seconds,
        default=300,
        help="seconds a cell of the teacher's, or an answer (its cells together), may run before it is stopped (default 300)",
    )
    mark.add_argument(
        "--jobs", type=jobs_count, default=1, help="submissions marked at once, each in its own kernel (default 1)"
    )
    mark.add_argument("--json", action="store_true", help="print the marks as one JSON document")
    mark.add_argument(
        "--csv",
        type=_path,
        metavar="FILE.csv",
        help="also write a grade book: one row per submission, its score and each exercise's points",
    )
    return hw


def check(args: argparse.Namespace) -> None:
    """Before any kernel starts: ``mark --csv`` is a file that can be written (:func:`~steam_ref.cli.paths.check_output`),
    not the file stdout goes to."""
    if args.homework_command == "mark" and args.csv is not None:
        check_output(args.csv, ".csv", "--csv")
        check_outputs_apart({"--csv": args.csv})
