"""The ``steam-ref`` command: every command registered, the parser built from them, and the entry point.

Usage::

    steam-ref run [--dataset NAME_OR_PATH] [--method {btgp,pb,pbvr}] [--every N] [--skip K]
                  [--interpolate/--no-interpolate] [--preset {synthetic,plaza,victoria-park}] [--data-dir DIR]
                  [--converge-at-end] [--json] [--save-estimates FILE.npz] [--plot FILE.png]
                  [--lag SECONDS] [--steps N]
    steam-ref batch [--dataset NAME_OR_PATH] [--ordering {xl,amd}] [--json] [--plot FILE.png]
    steam-ref fidelity [--dataset {paper-synthetic,plaza,all}] [--json] [--plot FILE.png]
    steam-ref reproduce [--quick] [--out DIR] [--jobs N]
    steam-ref conformance {export DIR, check RESULTS_DIR [--only SUITE...], selftest [--paper], build}
    steam-ref data {list, fetch [NAME ...]}
    steam-ref consistency [--seeds N] [--jobs N] [--backend loky|dask] [--json] [--plot FILE.png] ...
    steam-ref homework {handout NOTEBOOK... [--out DIR], mark SUBMISSION... [--source DIR] [--json]}

Each command is one module with ``add_parser(subparsers)`` (its options; returns its parser) and
``run(args)`` (what it does; returns the exit code), registered once in :data:`COMMANDS`.

Every command that can run longer than a few seconds shows its progress on stderr when that is a terminal
(``--progress`` / ``--no-progress``: :mod:`steam_ref.paper.progress`), and every command runs the solvers at
one BLAS thread unless ``$STEAM_REF_BLAS_THREADS`` says otherwise (:mod:`steam_ref.linear.threads`).
Bad arguments and missing or malformed data files give a one-line error and exit code 2. The project's
warnings (:class:`~steam_ref.errors.SteamWarning`: a diverging stream, a cut-short convergence) are one line
each on stderr, ``steam-ref: warning: ...``, the first of each kind shown and the rest counted at the end
(:func:`~steam_ref.cli.streams.warning_lines`); they do not change the exit code: the run finished and wrote
its outputs, and its figures (``--json``: ``divergence``) say what was found. A command that never solves
(``data``: its module says ``SOLVES = False``) does not read ``$STEAM_REF_BLAS_THREADS``.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Sequence

from .._version import __version__
from ..conformance import command as conformance
from ..errors import SteamError, SteamWarning
from ..homework import command as homework
from ..linear.threads import limit
from . import batch, consistency, data, fidelity, reproduce, run
from .args import Parser
from .streams import complain, one_line, quiet_stdout, warning_lines

__all__ = ["COMMANDS", "build_parser", "main"]

# Every command of `steam-ref`, in the order its help lists them: a module with add_parser(sub) and run(args).
COMMANDS = (run, batch, fidelity, reproduce, conformance, data, consistency, homework)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``steam-ref``: each command of :data:`COMMANDS` adds its own."""
    parser = Parser(
        prog="steam-ref",
        description="Incremental sparse GP regression for continuous-time STEAM (Yan, Indelman, Boots).",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", parser_class=Parser, required=True)
    for command in COMMANDS:
        command.add_parser(sub).set_defaults(handler=command.run, solves=getattr(command, "SOLVES", True))
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``steam-ref`` console script; returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        args = build_parser().parse_args(argv or ["run"])  # no command at all runs the main job
        # the solvers' small dense algebra at one BLAS thread unless $STEAM_REF_BLAS_THREADS says
        with limit() if args.solves else contextlib.nullcontext(), warning_lines(SteamWarning):
            return args.handler(args)
    except BrokenPipeError:  # stdout's reader went away (`| head`): what it read is all it wanted
        quiet_stdout()
        return 141  # 128 + SIGPIPE, as a shell reports a command stopped by a closed pipe
    except MemoryError as exc:  # NumPy's names a size, Python's nothing
        complain(f"steam-ref: error: out of memory{f' ({one_line(str(exc))})' if str(exc) else ''}")
        return 2
    except (SteamError, OSError) as exc:
        complain(f"steam-ref: error: {one_line(str(exc))}")
        return 2
    except KeyboardInterrupt:
        complain("steam-ref: interrupted")
        return 130
