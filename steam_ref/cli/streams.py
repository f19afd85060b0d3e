"""stdout and stderr of the ``steam-ref`` command: what it prints can always be printed, or fails in one line.

- :func:`make_encodable`: a character the stream's encoding lacks (``α`` on an ASCII or cp1252 stdout) is
  written as its backslash escape, never a ``UnicodeEncodeError``; a byte of a path that is not UTF-8 (Python
  holds it as a lone surrogate, U+DC80 to U+DCFF) as the byte, ``\\xff``, not ``\\udcff``;
- :func:`one_line`: an error message on one line however odd the input it quotes, a path's byte that is not
  UTF-8 shown as that byte (``'\\xff.png'``) whether the message quotes the path itself or its ``repr``;
- :func:`json_line`: a summary as one line of JSON, refusing (and naming) a NaN or an infinity rather
  than writing ``NaN``/``Infinity``, which is not JSON;
- :func:`quiet_stdout`: after stdout's reader went away (``| head``), the interpreter's last flush is sent
  to the null device instead of failing again;
- :func:`complain`: a line on stderr that is dropped, not raised, when stderr cannot take it (a full disk,
  ``2>/dev/full``; closed, ``2>&-``): the exit code still says what happened;
- :func:`warning_lines`: the project's warnings as one line each, ``steam-ref: warning: ...`` (no source
  line), the first of each kind shown and the rest counted in one line at the end.

Imports nothing but the standard library and steam_ref's errors: the entry point uses it before NumPy loads.
"""

from __future__ import annotations

import codecs
import contextlib
import json
import math
import os
import re
import sys
import warnings
from collections.abc import Iterator

from ..errors import SteamError

__all__ = ["complain", "make_encodable", "one_line", "json_line", "quiet_stdout", "warning_lines"]


def _byte_of(c: str) -> str | None:
    """``\\xNN`` for a lone surrogate U+DC80 to U+DCFF, the byte NN of a file name that is not UTF-8 (Python's
    ``surrogateescape``); None for any other character."""
    return f"\\x{ord(c) - 0xDC00:02x}" if "\udc80" <= c <= "\udcff" else None


def _escape(error: UnicodeError) -> tuple[str, int]:
    """The ``steam_ref.escape`` error handler: a file name's byte as ``\\xNN``, anything else as
    ``backslashreplace`` writes it."""
    if not isinstance(error, UnicodeEncodeError):
        raise error
    bad = error.object[error.start : error.end]
    return "".join(_byte_of(c) or c.encode("ascii", "backslashreplace").decode() for c in bad), error.end


codecs.register_error("steam_ref.escape", _escape)

# A repr's escape of such a surrogate, "\udcff", not itself escaped (preceded by an even number of backslashes).
_SURROGATE_REPR = re.compile(r"(?<!\\)((?:\\\\)*)\\udc([89a-f][0-9a-f])")


def make_encodable(stream: object) -> None:
    """Make ``stream`` write what its encoding lacks as backslash escapes, a file name's byte that is not UTF-8 as
    ``\\xNN`` (a stream that cannot is left)."""
    reconfigure = getattr(stream, "reconfigure", None)
    if reconfigure is not None:
        with contextlib.suppress(ValueError, OSError):  # closed, or a stream that forbids it
            reconfigure(errors="steam_ref.escape")


def one_line(message: str) -> str:
    """``message`` with its line breaks escaped: an error is one line however odd the input it quotes; a file name's
    byte that is not UTF-8 shows as ``\\xNN``, quoted as it is or by its ``repr`` (which writes ``\\udcNN``)."""
    text = (
        "".join(c if c.isprintable() or c == "\t" else _byte_of(c) or repr(c)[1:-1] for c in message) or "(no message)"
    )
    return _SURROGATE_REPR.sub(r"\1\\x\2", text)


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


def complain(line: str) -> None:
    """``line`` on stderr, dropped when stderr cannot take it (full, closed): never an error of its own."""
    with contextlib.suppress(OSError, ValueError, AttributeError):  # AttributeError: stderr closed, so None
        print(line, file=sys.stderr, flush=True)


@contextlib.contextmanager
def warning_lines(family: type[Warning]) -> Iterator[None]:
    """While the block runs, each warning of ``family`` that the warnings filters let through is shown as one
    line, ``steam-ref: warning: <message>``, without Python's file, line number and source line; of each
    warning class only the first is shown, and when the block ends one line counts the rest ("145 more
    DivergenceWarnings after the first (above), not shown"). Other warnings are shown as Python shows them.

    It changes how a warning is written, not whether it is: the filters (``-W``, ``PYTHONWARNINGS``,
    ``warnings.simplefilter``) and a caller recording warnings (``catch_warnings(record=True)``,
    ``pytest.warns``) see every one as before."""
    original = warnings.formatwarning
    shown: dict[type[Warning], int] = {}

    def one_line_each(message, category, filename, lineno, line=None):  # warnings.formatwarning's signature
        if not issubclass(category, family):
            return original(message, category, filename, lineno, line)
        shown[category] = shown.get(category, 0) + 1
        return f"steam-ref: warning: {one_line(str(message))}\n" if shown[category] == 1 else ""

    warnings.formatwarning = one_line_each
    try:
        yield
    finally:
        warnings.formatwarning = original
        for category, n in shown.items():
            if n > 1:
                complain(f"steam-ref: warning: {n - 1:,} more {category.__name__}s after the first (above), not shown")
