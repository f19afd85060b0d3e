"""stdout and stderr of the ``steam-ref`` command: what it prints can always be printed, or fails in one line.

- :func:`make_encodable`: a character the stream's encoding lacks (``α`` on an ASCII or cp1252 stdout) is
  written as its backslash escape, never a ``UnicodeEncodeError``;
- :func:`one_line`: an error message on one line however odd the input it quotes;
- :func:`json_line`: a summary as one line of JSON, refusing (and naming) a NaN or an infinity rather
  than writing ``NaN``/``Infinity``, which is not JSON;
- :func:`quiet_stdout`: after stdout's reader went away (``| head``), the interpreter's last flush is sent
  to the null device instead of failing again.

Imports nothing but the standard library and steam_ref's errors: the entry point uses it before NumPy loads.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import sys

from ..errors import SteamError

__all__ = ["make_encodable", "one_line", "json_line", "quiet_stdout"]


def make_encodable(stream: object) -> None:
    """Make ``stream`` write what its encoding lacks as backslash escapes (a stream that cannot is left)."""
    reconfigure = getattr(stream, "reconfigure", None)
    if reconfigure is not None:
        with contextlib.suppress(ValueError, OSError):  # closed, or a stream that forbids it
            reconfigure(errors="backslashreplace")


def one_line(message: str) -> str:
    """``message`` with its line breaks escaped: an error is one line however odd the input it quotes."""
    return "".join(c if c.isprintable() or c == "\t" else repr(c)[1:-1] for c in message) or "(no message)"


def json_line(summary: dict) -> str:
    """One JSON line; a NaN or an infinity among the figures is refused, naming it, never written as non-JSON."""
    try:
        return json.dumps(summary, allow_nan=False)
    except ValueError:
        raise SteamError(f"the figure {_not_finite(summary)} is not finite, which JSON cannot carry") from None


def _not_finite(value: object, where: str = "") -> str | None:
    """Where the first NaN or infinity in ``value`` is ("evaluation.ape.translation_m.rmse = inf"), or None."""
    if isinstance(value, float) and not math.isfinite(value):
        return f"{where} = {value}"
    items = value.items() if isinstance(value, dict) else enumerate(value) if isinstance(value, (list, tuple)) else ()
    for key, item in items:
        found = _not_finite(item, f"{where}.{key}" if where else str(key))
        if found:
            return found
    return None


def quiet_stdout() -> None:
    """Point stdout at the null device, so the interpreter's last flush does not fail on the closed pipe again."""
    with contextlib.suppress(OSError, AttributeError, ValueError):
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, sys.stdout.fileno())
        os.close(null)
