"""Output paths of the ``steam-ref`` command: checked before a run, written after it.

Nothing is opened or created at a path before the run (a named pipe would hang it, a dangling link would
be destroyed); a non-regular file, a folder, a link loop, a dangling link or a folder that is not there is
refused with one line naming the option. A dangling link is refused because writing through it would make a
file wherever it points, which the user never named (run as root, a link into ``/etc`` would write there); a
link to a file that exists is written through and stays a link. After the run, :func:`write_output` writes beside the target and moves the
file over it, so a full disk names the option and the path and leaves any old file as it was.

The checks load no solver and no NumPy: a command checks its outputs before its machinery loads
(:func:`steam_ref.cli.parsers.run.check`).
"""

from __future__ import annotations

import argparse
import errno
import importlib.util
import os
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import SteamError
from ..files import replace_file

if TYPE_CHECKING:
    import numpy as np

    from ..lie import LieGroup

__all__ = [
    "refuse_dangling",
    "check_output",
    "check_outputs_apart",
    "check_outputs_not_inputs",
    "write_output",
    "check_out_folder",
    "check_trajectory_output",
    "save_trajectory",
    "write_plot",
]


_KINDS = {
    stat.S_IFIFO: "a named pipe",
    stat.S_IFCHR: "a character device",
    stat.S_IFBLK: "a block device",
    stat.S_IFSOCK: "a socket",
    stat.S_IFDIR: "a folder",
}


def _kind(mode: int) -> str:
    """What an lstat/stat mode is, in words ("a file" for a regular one)."""
    return "a file" if stat.S_ISREG(mode) else _KINDS.get(stat.S_IFMT(mode), "not a regular file")


def _refuse_path(option: str, path: str, err: OSError) -> SteamError:
    """Why ``path`` cannot be reached, in words: a part of it is a file, a link loop, ..."""
    if err.errno == errno.ELOOP:
        return SteamError(f"{option}: {path!r} is a loop of symbolic links")
    if err.errno == errno.ENOTDIR:
        blocker = next((p for p in Path(path).parents if p.is_file()), None)
        where = f"{str(blocker)!r} is a file, not a folder" if blocker else "a part of it is not a folder"
        return SteamError(f"{option}: cannot write {path!r}: {where}")
    return SteamError(f"{option}: cannot write {path!r} ({err.strerror or err})")


def _relative_ok(path: str, option: str) -> None:
    """A relative ``path`` needs the working folder: one deleted under the command is named, not "[Errno 2]"."""
    if os.path.isabs(path):
        return
    try:
        os.getcwd()
    except OSError:
        where = os.environ.get("PWD", "the working folder")
        raise SteamError(
            f"{option}: {path!r} is relative to the working folder {where!r}, which no longer exists: "
            "give an absolute path, or change to a folder that exists"
        ) from None


def _writable_folder(folder: Path, option: str, path: str) -> None:
    """``folder`` exists, is a folder, and a file can be made in it (an unnamed temporary file is tried)."""
    try:
        mode = os.stat(folder).st_mode
    except FileNotFoundError:
        raise SteamError(f"{option}: cannot write {path!r}: folder {str(folder)!r} does not exist") from None
    except OSError as err:
        raise _refuse_path(option, path, err) from None
    if not stat.S_ISDIR(mode):
        raise SteamError(f"{option}: cannot write {path!r}: {str(folder)!r} is {_kind(mode)}, not a folder")
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as err:
        raise SteamError(f"{option}: cannot write in {str(folder)!r} ({err.strerror or err})") from None


def check_output(path: str | None, suffix: str, option: str) -> None:
    """Before the run: ``path`` ends in ``suffix`` and is a regular file that can be written (through
    symbolic links), or nothing yet, in a folder that can be written in.

    Nothing is opened or made at ``path``: opening a named pipe blocks, and making a dangling link's
    target (then removing it) would change the user's files. A named pipe, a device, a socket, a folder,
    a link loop or a dangling link (:func:`refuse_dangling`) is refused. :func:`write_output` writes it after
    the run.
    """
    if path is None:
        return
    if not path.strip():
        raise SteamError(f"{option}: expected a file name, got {path!r}")
    if not path.endswith(suffix):
        raise SteamError(f"{option} expects a {suffix} file name, got {path!r}")
    _relative_ok(path, option)
    try:
        mode = os.stat(path).st_mode  # through links
    except FileNotFoundError:
        refuse_dangling(path, option)
        _writable_folder(Path(os.path.realpath(path)).parent, option, path)
    except OSError as err:
        raise _refuse_path(option, path, err) from None
    else:
        if stat.S_ISDIR(mode):
            raise SteamError(f"{option}: {path!r} is a folder, not a file")
        if not stat.S_ISREG(mode):
            raise SteamError(
                f"{option}: {path!r} is {_kind(mode)}, not a regular file: refused, writing it could block"
            )
        if not os.access(path, os.W_OK):
            raise SteamError(f"{option}: cannot write {path!r} (permission denied or a read-only file system)")
        _writable_folder(Path(os.path.realpath(path)).parent, option, path)  # the new file is made beside it
    if suffix == ".png" and importlib.util.find_spec("matplotlib") is None:
        raise SteamError(f"{option} needs matplotlib, which is not installed (pip install matplotlib)")


def refuse_dangling(path: str, option: str) -> None:
    """SteamError naming ``option``, ``path`` and where it points when ``path`` is a symbolic link to nothing:
    writing through it would make a file the user never named (as root, a link into /etc writes there)."""
    if os.path.islink(path) and not os.path.exists(path):
        raise SteamError(
            f"{option}: {path!r} is a symbolic link to {os.readlink(path)!r}, which does not exist: refused, "
            "writing through it would make a file there (name the target itself, or remove the link)"
        )


def _identity(path: str) -> tuple[str, object]:
    """What ``path`` writes to: its file (device, inode) when it exists, else its real path."""
    try:
        st = os.stat(path)
    except OSError:
        return ("path", os.path.realpath(path))
    return ("file", (st.st_dev, st.st_ino))


def _stream_identity(fd: int) -> tuple[str, object] | None:
    try:
        st = os.fstat(fd)
    except OSError:
        return None
    return ("file", (st.st_dev, st.st_ino)) if stat.S_ISREG(st.st_mode) else None


def check_outputs_apart(outputs: dict[str, str | None]) -> None:
    """Before the run: the outputs given (option -> path) name different files, none of them the file stdout
    or stderr is redirected to (replacing it would lose the printed figures); else a SteamError naming both."""
    seen: dict[tuple[str, object], str] = {}
    for option, path in outputs.items():
        if path is None:
            continue
        key = _identity(path)
        if key in seen:
            raise SteamError(f"{seen[key]} and {option} both name {path!r}: one would overwrite the other")
        seen[key] = option
        for fd, stream in ((1, "stdout"), (2, "stderr")):
            if key == _stream_identity(fd):
                raise SteamError(
                    f"{option}: {path!r} is the file {stream} is redirected to: writing it would replace what is printed"
                )


def check_outputs_not_inputs(outputs: dict[str, str | None], inputs: list[Path]) -> None:
    """After the data are read, before the run: no output given (option -> path) is one of the files ``inputs`` the
    run read, by name or through a link (replacing it would destroy the data); else a SteamError naming both."""
    read = {_identity(str(p)): p for p in inputs}
    for option, path in outputs.items():
        if path is not None and _identity(path) in read:
            raise SteamError(
                f"{option}: {path!r} is the data file {str(read[_identity(path)])!r} this run reads: writing it "
                "would destroy the data (give another file)"
            )


def write_output(path: str, option: str, write: Callable[[str], object]) -> str:
    """Write an output ``path`` checked by :func:`check_output` by ``write(name)``, through
    :func:`~steam_ref.files.replace_file` (a new file beside its real target replaces it in one step). Returns the
    line saying where it went (``--save-estimates``: "estimates written to /abs/path", and "(replaced the file
    there)" when one was), for the text output.

    A failure (a full disk, ...) leaves what was at ``path`` as it was and is a SteamError naming the
    option and the path. A file that was there keeps its permission bits.
    """
    refuse_dangling(path, option)  # checked before the run; a link made dangling since is refused too
    replaced = " (replaced the file there)" if os.path.exists(path) else ""
    replace_file(path, write, option)
    what = option.removeprefix("--").removeprefix("save-").replace("-", " ")
    return f"\n{what} written to {os.path.abspath(path)}{replaced}"


def check_out_folder(path: str, option: str) -> None:
    """Before the runs: ``path`` is a folder that exists and can be written, or can be made."""
    if not path.strip():
        raise SteamError(f"{option}: expected a folder, got an empty string")
    _relative_ok(path, option)
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        if os.path.islink(path):
            raise SteamError(
                f"{option}: {path!r} is a symbolic link to {os.path.realpath(path)!r}, which does not exist"
            ) from None
        mode = None
    except OSError as err:
        raise _refuse_path(option, path, err) from None
    if mode is not None and not stat.S_ISDIR(mode):
        raise SteamError(f"{option}: {path!r} is {_kind(mode)}, not a folder")
    target = Path(path).resolve()
    existing = next(p for p in (target, *target.parents) if p.exists())
    if not existing.is_dir():
        raise SteamError(f"{option}: cannot make folder {path!r}: {str(existing)!r} is a file")
    try:
        with tempfile.TemporaryFile(dir=existing):
            pass
    except OSError as err:
        raise SteamError(f"{option}: cannot write in {str(existing)!r} ({err.strerror or err})") from None


def check_trajectory_output(args: argparse.Namespace) -> None:
    """--save-trajectory FILE checked before the run; --trajectory-format needs it (alone it would do nothing).

    The file's name may end in anything (a TUM or KITTI file has no suffix of its own), so an existing file is
    replaced only if it is text: one with a NUL byte in its first 4 KiB (a .mat data set, an .npz, a picture) is
    never a trajectory this command wrote, and replacing it would lose it."""
    check_output(args.save_trajectory, "", "--save-trajectory")
    if args.save_trajectory is not None and os.path.isfile(args.save_trajectory):  # a regular file: no pipe opened
        try:
            with open(args.save_trajectory, "rb") as existing:
                binary = b"\0" in existing.read(4096)
        except OSError as err:
            raise _refuse_path("--save-trajectory", args.save_trajectory, err) from None
        if binary:
            raise SteamError(
                f"--save-trajectory: {args.save_trajectory!r} holds binary data, not a trajectory (a data set, an "
                "array file, a picture?): replacing it would lose it; give another file, or remove it first"
            )
    if args.trajectory_format is not None and args.save_trajectory is None:
        raise SteamError(
            f"--trajectory-format {args.trajectory_format} is the format of --save-trajectory FILE: give it"
        )


def save_trajectory(
    args: argparse.Namespace, times: np.ndarray, poses: np.ndarray, *, group: LieGroup | None = None
) -> str:
    """--save-trajectory: the poses (n, 3) at the data set's times, as TUM or KITTI; with ``group`` (a 3-D run's:
    SE3V) the poses in 3-D (n, group.size) (:func:`~steam_ref.evaluate.write_tum`'s ``group``). Returns the line
    saying where (:func:`write_output`), "" without it."""
    if not args.save_trajectory:
        return ""
    from ..evaluate import write_kitti, write_tum  # the writers load with the run, not with the checks before it

    if args.trajectory_format == "kitti":
        return write_output(
            args.save_trajectory, "--save-trajectory", lambda name: write_kitti(name, poses, group=group)
        )
    return write_output(
        args.save_trajectory, "--save-trajectory", lambda name: write_tum(name, times, poses, group=group)
    )


def write_plot(args: argparse.Namespace, draw: Callable[[str], object]) -> str:
    """Write ``--plot`` by ``draw(name)``; the line saying where it went, printed after the figures ("" with
    ``--json``: its one line is the figures)."""
    where = write_output(args.plot, "--plot", draw)
    return "" if args.json else where
