"""How the tests run the ``steam-ref`` command: the one home of it, two ways.

- :func:`runner`: in this process, through the command's own entry point (:func:`steam_ref.cli.commands.main`),
  its output caught by pytest's ``capsys``: ``cli = runner("conformance")`` then
  ``code, out, err = cli(capsys, "check", folder)``. Fast; what most tests use.
- :func:`run_module`: ``python -m steam_ref ARGS`` in a fresh interpreter on this tree, as a user's shell runs
  it: for what only a real process shows (exit code after a traceback, a closed or full stderr, the console's
  encoding, the environment read at start-up).
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from steam_ref.cli.commands import main

__all__ = ["ROOT", "run_module", "runner"]

ROOT = Path(__file__).resolve().parents[1]  # the tree under test: run_module's PYTHONPATH

Run = Callable[..., tuple[int, str, str]]


def runner(*command: str) -> Run:
    """A function ``run(capsys, *args)`` that runs ``steam-ref COMMAND... ARGS`` in this process (each argument
    through ``str``) and returns its exit code, stdout and stderr."""

    def run(capsys: pytest.CaptureFixture, *args: object) -> tuple[int, str, str]:
        code = main([*command, *map(str, args)])
        out = capsys.readouterr()
        return code, out.out, out.err

    return run


def run_module(
    *args: object, env: dict[str, str] | None = None, timeout: float = 300, **kwargs
) -> subprocess.CompletedProcess:
    """``python -m steam_ref ARGS`` in a fresh interpreter on this tree (``PYTHONPATH``, ``MPLBACKEND=Agg``
    added to ``env``, by default this process's environment). Its output is caught as text unless ``kwargs``
    say where it goes (``stdout=``, ``stderr=``, ``text=``...: :func:`subprocess.run`'s)."""
    env = {**(os.environ if env is None else env), "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg"}
    if not {"stdout", "stderr", "capture_output"} & set(kwargs):
        kwargs["capture_output"] = True
    kwargs.setdefault("text", True)
    return subprocess.run([sys.executable, "-m", "steam_ref", *map(str, args)], env=env, timeout=timeout, **kwargs)
