"""The ``steam-ref`` command: every command registered, the parser built from them, and the entry point.

``steam-ref --help`` lists the commands (:data:`COMMANDS`), and ``steam-ref COMMAND --help`` a command's options,
written once, in its parser (the site's page per command shows the same).

Each command is two modules, registered once in :data:`COMMANDS`: its options, ``add_parser(subparsers)`` (returns
its parser; :mod:`steam_ref.cli.parsers`), and what it does, ``run(args)`` (returns the exit code). The parser reads
only :mod:`steam_ref.choices`, the data sets' registry and :mod:`~steam_ref.cli.args`; the module that runs (and the
solvers, NumPy and SciPy with it) loads once the arguments are parsed, so ``steam-ref --help``, a command's help and
a bad argument's one-line answer cost about what ``--version`` does (``tests/test_cli_startup.py`` checks that they
load neither SciPy's sparse matrices nor the solvers).

Every command with ``--progress`` / ``--no-progress`` shows its progress on stderr when that is a terminal
(:mod:`steam_ref.paper.progress`; ``fit-qc`` and ``homework`` have none, and ``run`` and ``batch`` on a 3-D set
draw none and refuse ``--progress``), and every command runs the solvers at
one BLAS thread unless ``$STEAM_REF_BLAS_THREADS`` says otherwise (:mod:`steam_ref.linear.threads`, entered once
the command's module has loaded: the limit applies to the libraries loaded when it is entered).
Bad arguments and missing or malformed data files give a one-line error and exit code 2. The project's
warnings (:class:`~steam_ref.errors.SteamWarning`: a diverging stream, a cut-short convergence) are one line
each on stderr, ``steam-ref: warning: ...``, the first of each kind shown and the rest counted at the end
(:func:`~steam_ref.cli.streams.warning_lines`); they do not change the exit code: the run finished and wrote
its outputs, and its figures (``--json``: ``divergence``) say what was found. A command that never solves
(``data``: its parser's module says ``SOLVES = False``) does not read ``$STEAM_REF_BLAS_THREADS``.

Ctrl-C stops a command with one line, ``steam-ref: interrupted``, and exit code 130; SIGTERM (``kill``, ``timeout``,
a batch scheduler) is taken the same way, ``steam-ref: terminated`` and 143, so that what an interrupt undoes is
undone (no half-written output; a sweep's worker processes stopped with it, not left running without a parent).
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import threading
from collections.abc import Sequence
from importlib import import_module
from typing import Any

from .._package import __version__
from ..errors import SteamError, SteamWarning
from .args import Parser
from .streams import complain, one_line, quiet_stdout, warning_lines

__all__ = ["COMMANDS", "Terminated", "build_parser", "main"]


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the command is, as Ctrl-C's KeyboardInterrupt is (and caught where it is)."""


class Command(Parser):
    """A subcommand's parser (its own subcommands' too): it refuses an argument it does not know itself, pointing at
    its own ``--help``; argparse hands it up to the top parser, whose error said ``see 'steam-ref --help'``."""

    def parse_known_args(self, args: Any = None, namespace: Any = None) -> Any:
        parsed, extras = super().parse_known_args(args, namespace)
        if extras:
            self.error(f"unrecognized arguments: {' '.join(extras)}")
        return parsed, extras


def _terminate(signum: int, frame: object) -> None:  # noqa: ARG001 (a signal handler's signature)
    raise Terminated


@contextlib.contextmanager
def _sigterm_as_interrupt():
    """SIGTERM raises :class:`Terminated` while the command runs (the main thread only: a handler can be set there
    alone), the handler before restored after."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.signal(signal.SIGTERM, _terminate)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, before)


# Every command of `steam-ref`, in the order its help lists them: its name, the module of its options (which has
# add_parser(sub); light, read by every --help) and the module that runs it (which has run(args)). A command's
# parser loads only when it is the one parsed (or help lists them all), and its running module only once its
# arguments are parsed, so that a run carries none of the kit's, the homework's or the other commands' machinery,
# and --help or a bad argument none of the solvers.
COMMANDS = {
    "run": ("steam_ref.cli.parsers.run", "steam_ref.cli.run"),
    "batch": ("steam_ref.cli.parsers.batch", "steam_ref.cli.batch"),
    "fidelity": ("steam_ref.cli.parsers.fidelity", "steam_ref.cli.fidelity"),
    "reproduce": ("steam_ref.cli.parsers.reproduce", "steam_ref.cli.reproduce"),
    "conformance": ("steam_ref.cli.parsers.conformance", "steam_ref.conformance.command"),
    "data": ("steam_ref.cli.parsers.data", "steam_ref.cli.data"),
    "consistency": ("steam_ref.cli.parsers.consistency", "steam_ref.cli.consistency"),
    "fit-qc": ("steam_ref.cli.parsers.fit_qc", "steam_ref.cli.fit_qc"),
    "homework": ("steam_ref.cli.parsers.homework", "steam_ref.homework.command"),
}


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The argument parser of ``steam-ref``: each command of :data:`COMMANDS` adds its own; given the name
    of one, only that one (the parser of ``steam-ref <command> ...``)."""
    parser = Parser(
        prog="steam-ref",
        description="Incremental sparse GP regression for continuous-time STEAM (Yan, Indelman, Boots).",
        epilog="With no command, steam-ref runs `steam-ref run`. 'steam-ref COMMAND --help' for a command's options.\n"
        "example: steam-ref run --dataset plaza --max-poses 200",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", parser_class=Command, required=True)
    for name in [command] if command in COMMANDS else COMMANDS:
        options, runs = COMMANDS[name]
        module = import_module(options)
        module.add_parser(sub).set_defaults(
            runs=runs, solves=getattr(module, "SOLVES", True), check=getattr(module, "check", None)
        )
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``steam-ref`` console script; returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        argv = argv or ["run"]  # no command at all runs the main job
        try:
            args = build_parser(argv[0]).parse_args(argv)
        except SteamError as exc:  # argparse reads an option before any command as a missing or an unknown command
            said = str(exc)
            if argv[0].startswith("-") and said.startswith(
                ("the following arguments are required: command", "argument command:")
            ):
                raise SteamError(
                    f"unrecognized arguments: {argv[0]} before a command: a command comes first, its options after it "
                    "(as in 'steam-ref run --max-poses 200'; see 'steam-ref --help')"
                ) from None
            raise
        if args.check is not None:  # what the command checks before anything is read, with no solver loaded
            args.check(args)
        command = import_module(args.runs)  # the command's machinery loads only now, its arguments parsed
        from ..linear.threads import limit  # a limit applies to the libraries loaded when it is entered: after that

        # the solvers' small dense algebra at one BLAS thread unless $STEAM_REF_BLAS_THREADS says
        with _sigterm_as_interrupt(), limit() if args.solves else contextlib.nullcontext(), warning_lines(SteamWarning):
            return command.run(args)
    except BrokenPipeError:  # stdout's reader went away (`| head`): what it read is all it wanted
        quiet_stdout()
        return 141  # 128 + SIGPIPE, as a shell reports a command stopped by a closed pipe
    except MemoryError as exc:  # NumPy's names a size, Python's nothing
        complain(f"steam-ref: error: out of memory{f' ({one_line(str(exc))})' if str(exc) else ''}")
        return 2
    except (SteamError, OSError) as exc:
        complain(f"steam-ref: error: {one_line(str(exc))}")
        return 2
    except Terminated:
        complain("steam-ref: terminated")
        return 143  # 128 + SIGTERM, as a shell reports a command it stopped
    except KeyboardInterrupt:
        complain("steam-ref: interrupted")
        return 130
