"""A data file's bytes and lines: the one home of what every reader checks before it parses a number.

:func:`check_regular` refuses what is not a regular file (a folder, a FIFO, a device, a link to one) before it
is opened: reading a FIFO waits for a writer for ever, ``/dev/zero`` never ends. :func:`text_lines` reads a text
file of numbers (the CMU tables, GTSAM's planar text, the KITTI files) by one rule: a regular file; ASCII (a
byte that is not, a BOM or Latin-1, is named with its line); every line ends with a newline (``\\n`` or
``\\r\\n``), the last one too: a file cut inside its last number keeps its field count and still parses
(``5.29560000000000031e+01`` cut after ``5.2956`` reads as 5.2956), so the missing newline is the only sign
of the cut. Errors are :class:`~steam_ref.errors.DataError` naming the file and the line (1-based).
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

from ..errors import DataError

__all__ = ["check_regular", "text_lines"]


def check_regular(path: str | os.PathLike) -> os.stat_result:
    """The ``stat`` of ``path`` (links followed); DataError naming it when it is not a regular file."""
    try:
        info = os.stat(path)
    except OSError as exc:
        raise DataError(f"{path}: cannot read it ({exc.strerror or type(exc).__name__})") from None
    if not stat.S_ISREG(info.st_mode):
        kind = next(
            (
                w
                for test, w in ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISSOCK, "a socket"))
                if test(info.st_mode)
            ),
            "a device",
        )
        raise DataError(f"{path}: not a file ({kind}); a data file must be a regular file")
    return info


def text_lines(path: Path, separator: str = "") -> list[str]:
    """The lines of the text file ``path``, each without its line end (``\\n`` or ``\\r\\n``), by the module's
    rule; DataError naming the file and the line. ``separator`` goes between the path and "line N" in messages
    (a reader's own style: ``", "`` for KITTI's)."""
    check_regular(path)
    try:
        raw = path.read_bytes()
    except OSError as err:
        raise DataError(f"{path}: cannot read it ({type(err).__name__}: {err.strerror or err})") from None
    try:
        text = raw.decode("ascii")
    except UnicodeDecodeError as err:
        line = raw.count(b"\n", 0, err.start) + 1
        bom = " (a byte-order mark: save the file without one)" if raw.startswith(b"\xef\xbb\xbf") else ""
        raise DataError(
            f"{path}{separator} line {line}: byte {raw[err.start]:#04x} is not ASCII{bom}; a data file of text holds "
            f"plain numbers"
        ) from None
    lines = text.split("\n")
    if lines[-1].strip(" \t\r"):
        raise DataError(
            f"{path}{separator} line {len(lines)}: the last line does not end with a newline, so the file may be cut "
            f"short (a number cut short still reads as a number); if that line is whole, end the file with a newline"
        )
    return [line.removesuffix("\r") for line in lines[:-1]]
