"""The ``steam-ref`` command: each command's options in :mod:`steam_ref.cli.parsers` (``add_parser``, loading no
solver) and what it does in its own module (``run``: ``run.py``, ``batch.py``, ...; ``steam-ref conformance`` is
:mod:`steam_ref.conformance.command`), both registered in :data:`steam_ref.cli.commands.COMMANDS`; what their
arguments accept in :mod:`~steam_ref.cli.args`. The top of the package: nothing imports it.

:func:`main` is the console script's entry point. ``steam-ref --version`` is answered here, before the
commands (and NumPy and SciPy with them) load; everything else goes to :func:`steam_ref.cli.commands.main`.
Before anything is printed, stdout and stderr are made to encode any text (a character their encoding
lacks, ``α`` on an ASCII or cp1252 stream, is written as its ``\\u`` escape, never a traceback), and a
closed stdout, whose figures would be lost, is refused.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from .._package import __version__
from .streams import make_encodable

__all__ = ["main"]


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``steam-ref`` console script; returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    make_encodable(sys.stdout)
    make_encodable(sys.stderr)
    if sys.stdout is None:  # started with stdout closed (`>&-`): Python then drops every print in silence
        if sys.stderr is not None:
            print(
                "steam-ref: error: stdout is closed: the figures would be lost (redirect it to a file)", file=sys.stderr
            )
        return 2
    if argv == ["--version"]:
        print(f"steam-ref {__version__}")
        return 0
    try:
        from .commands import main as run_command  # the commands load only when one is run
    except KeyboardInterrupt:  # Ctrl-C while NumPy and SciPy load: one line, as during a run
        print("steam-ref: interrupted", file=sys.stderr)
        return 130
    return run_command(argv)
