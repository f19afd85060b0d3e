"""A file written whole or not at all: :func:`replace_file`, the one home of the temporary-file-and-replace write."""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
import stat
from collections.abc import Callable
from pathlib import Path

from ..errors import SteamError

__all__ = ["replace_file"]

NAME_MAX = 255  # bytes in a file's name (Linux, macOS; Windows: 255 characters)
_WRITING: set[Path] = set()  # the temporaries being written now: one is already written whole or not at all


def replace_file(path: str | os.PathLike[str], write: Callable[[str], object], what: str) -> None:
    """Write ``path`` by ``write(name)``, which writes a new file ``name`` beside its real target (a link is followed
    and stays a link); that file then replaces the target in one step (:func:`os.replace`).

    A failure (a full disk, ...) leaves what was at ``path`` as it was and is a SteamError starting with ``what``
    (the option or the command that writes it) and naming the path; any other exception (an interrupt, an error of
    ``write``) propagates as it is. Either way the temporary file is removed. A file that was there keeps its
    permission bits; a new one gets the umask's.
    """
    real = Path(os.path.realpath(path))
    if real in _WRITING:  # a writer that replaces its file (write_tum) called on ours: one temporary, one message
        write(str(path))
        return
    if real.is_dir():  # refused before a temporary is made beside it, in a folder the caller never named
        raise SteamError(f"{what}: cannot write {str(path)!r} ({os.strerror(errno.EISDIR)}); it is a folder")
    # the temporary's name ends in the whole name, so it keeps the extension a writer goes by (np.savez adds
    # ".npz" to a name without one, matplotlib picks its format by it) even for a dotfile such as ".npz"; of a long
    # name, its end within NAME_MAX bytes
    prefix, tail = f".{os.getpid()}.{secrets.token_hex(4)}.", real.name
    while len(os.fsencode(prefix + tail)) > NAME_MAX:
        tail = tail[1:]
    temporary = real.parent / (prefix + tail)
    try:
        os.close(os.open(temporary, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o666))  # the umask applies
        _WRITING.add(temporary)
        write(str(temporary))
        if real.exists():
            os.chmod(temporary, stat.S_IMODE(os.stat(real).st_mode))
        os.replace(temporary, real)
    except OSError as err:
        raise SteamError(
            f"{what}: cannot write {str(path)!r} ({err.strerror or err}); what was there is left as it was"
        ) from None
    finally:
        _WRITING.discard(temporary)
        with contextlib.suppress(OSError):
            os.unlink(temporary)
