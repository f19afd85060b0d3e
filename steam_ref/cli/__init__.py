"""The ``steam-ref`` command: its parser and argument checks (:mod:`~steam_ref.cli.args`) and what each
command does (:mod:`~steam_ref.cli.commands`; ``steam-ref conformance`` is
:mod:`steam_ref.conformance.command`). The top of the package: nothing imports it.

:func:`main` is the console script's entry point. ``steam-ref --version`` is answered here, before the
commands (and NumPy and SciPy with them) load; everything else goes to :func:`steam_ref.cli.commands.main`.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from .._version import __version__

__all__ = ["main"]


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``steam-ref`` console script; returns the exit code."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv == ["--version"]:
        print(f"steam-ref {__version__}")
        return 0
    from .commands import main as run_command  # the commands load only when one is run

    return run_command(argv)
