"""Finding data: a data set by name or path, and the folders searched for named files.

Named files are searched for in exactly four places, in order: the ``data_dir`` argument (the
CLI's ``--data-dir``), ``$STEAM_REF_DATA_DIR``, the user's cache folder where ``steam-ref data fetch``
puts the files it downloads (:func:`data_cache_dir`), the ``Data/`` folder of an installed gtsam wheel.
A folder the user names comes first; fetched files before gtsam's, whose ``plaza`` is the original
uncleaned set.

A file found under a published name (:mod:`.registry`) is checked at every read, never trusted by its
name: in the fetched files' cache a file that is not the published one is refused (DataError saying how
to fetch it again); in a folder the user names (or gtsam's) it is the user's own file and is read, but
not as the named set: its name is the file's own, marked "(not the published NAME)", and its ``source``
says how it differs. A file that is not a regular file (a FIFO, a device) is refused before it is opened. A folder
that holds some of a set's files but not all (the user's own GPS file without the IMU's) is named, never passed
over for the next folder's set (:func:`holds_set`).

The readers (and NumPy, SciPy with them) load when a file is read, not with this module: the command's parser reads
``--data-dir``'s help here (:func:`data_dir_help`), and its early answers load no solver.
"""

from __future__ import annotations

import dataclasses
import difflib
import importlib.util
import os
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import DataError, UncleanedDataWarning
from .registry import DATASETS, DataSet, check_cached, check_regular, loadable, published_mismatch

if TYPE_CHECKING:
    from .landmarks import LandmarkDataset
    from .rigid import RigidReadings
    from .table import RangeDataset

__all__ = [
    "DATA_DIR_ENV",
    "data_cache_dir",
    "data_dir_help",
    "gtsam_data_dir",
    "default_data_dirs",
    "dataset_path",
    "find_named",
    "holds_set",
    "not_found",
    "load_dataset",
    "load_range_dataset",
    "uncleaned_plaza",
]

DATA_DIR_ENV = "STEAM_REF_DATA_DIR"


def data_dir_help(also: str = "") -> str:
    """The help of ``--data-dir`` in every command that has one: the whole search path of
    :func:`default_data_dirs`, written beside it. ``also``: what else the command looks for there."""
    return f"folder searched for data files{also} before ${DATA_DIR_ENV}, the fetched files' cache and gtsam's Data/"


def data_cache_dir() -> Path:
    """The folder ``steam-ref data fetch`` downloads into: ``data/`` in the user's cache folder
    (platformdirs: ``~/.cache/steam_ref/data`` on Linux, ``$XDG_CACHE_HOME`` honoured). It may not exist."""
    import platformdirs  # loaded when a search or a fetch asks, not by the command's parser (--data-dir's help)

    return Path(platformdirs.user_cache_dir("steam_ref")) / "data"


def gtsam_data_dir() -> Path | None:
    """The ``Data/`` folder of an installed gtsam wheel, or None (gtsam is found, not imported)."""
    try:
        spec = importlib.util.find_spec("gtsam")
    except (ImportError, ValueError):
        return None
    for location in (spec.submodule_search_locations or []) if spec else []:
        folder = Path(location) / "Data"
        if folder.is_dir():
            return folder
    return None


def _named_folder(value: str | os.PathLike | None, what: str) -> Path | None:
    """``value`` as a folder, or None when not given; DataError when it is empty or not a folder."""
    if value is None:
        return None
    if not str(value):
        raise DataError(f"{what} is empty: give a folder")
    if not Path(value).is_dir():
        state = "is not a folder" if Path(value).exists() else "does not exist"
        raise DataError(f"{what} {str(value)!r} {state}")
    return Path(value)


def default_data_dirs(data_dir: str | os.PathLike | None = None) -> list[Path]:
    """Folders searched for data files, in order, without duplicates.

    Exactly four places: ``data_dir`` (the CLI's ``--data-dir``), then ``$STEAM_REF_DATA_DIR``, then
    the fetched files' folder (:func:`data_cache_dir`, when it exists), then the ``Data/`` folder of an
    installed gtsam wheel. Nothing relative to the working
    directory or to this package's location is searched. A ``data_dir`` given, or a
    ``$STEAM_REF_DATA_DIR`` set (an empty one counts as unset), must be an existing folder, else
    DataError: a mistyped folder would otherwise be passed over for the next place in silence.
    """
    given = _named_folder(data_dir, "data_dir (--data-dir)")
    env = _named_folder(os.environ.get(DATA_DIR_ENV) or None, f"${DATA_DIR_ENV}")
    folders: list[Path] = []
    cache = data_cache_dir() if data_cache_dir().is_dir() else None
    for candidate in (given, env, cache, gtsam_data_dir()):
        if candidate is not None and Path(candidate).resolve() not in folders:
            folders.append(Path(candidate).resolve())
    return folders


def holds_set(folder: Path, file_names: tuple[str, ...]) -> bool:
    """Whether ``folder`` holds every one of a set's ``file_names``, each a regular file (:func:`check_regular`);
    False when it holds none. DataError naming the folder, what it holds and what it lacks when it holds some: the
    next folder's set would pass over the user's file in silence."""
    there = [f for f in file_names if os.path.lexists(folder / f)]
    for f in there:
        check_regular(folder / f)
    if len(there) < len(file_names) and there:
        lacking = ", ".join(f for f in file_names if f not in there)
        raise DataError(
            f"{folder} holds {', '.join(there)} but not {lacking}: a data set's files are read from one folder; put "
            f"{lacking} beside it, or move {', '.join(there)} away to read the set from the next folder searched"
        )
    return bool(there)


def _find(file_names: tuple[str, ...], folders: list[Path]) -> Path | None:
    """The first folder holding all of ``file_names`` (joined to the first name), or None.
    DataError when one of them is there but is not a regular file (a folder of that name, a FIFO, a link to
    a device: none is passed over) or is a cached file that is not the published one (:func:`find_named`)."""
    for folder in folders:
        if holds_set(folder, file_names):
            if folder.resolve() == data_cache_dir().resolve():  # written by `data fetch` alone: never trusted
                for f in file_names:
                    check_cached(folder / f, f)
            return folder / file_names[0]
    return None


def find_named(local: str, data_dir: str | os.PathLike | None = None) -> tuple[Path, str | None] | None:
    """The file ``local`` (e.g. ``"authors/Syn_full_data_run.mat"``) in the first searched folder that holds
    it, with how it differs from the published file of that name (None when it is that file), or None when
    no folder holds it. A cached file that differs, and a file that is not a regular file, raise DataError."""
    found = _find((local,), default_data_dirs(data_dir))
    if found is None:
        return None
    return found, published_mismatch(found, local)


def _load_named(s: DataSet, found: Path, seed: int) -> RangeDataset | LandmarkDataset | RigidReadings:
    """The named set ``s`` read by its loader from ``found`` (its first file); a file that is not the published
    one is read as the user's own file: named by its stem with "(not the published NAME)", and ``source``
    saying how it differs."""
    assert s.loader is not None
    folder = found.parents[len(Path(s.files[0].local).parts) - 1]  # the searched folder that holds them all
    differs = next((why for f in s.files if (why := published_mismatch(folder / f.local, f.local)) is not None), None)
    if differs is None:
        return s.loader(found, s.name, seed)
    data = s.loader(found, f"{found.stem} (not the published {s.name})", seed)
    return dataclasses.replace(data, source=f"{data.source}; not the published {s.name} file: {differs}")


def uncleaned_plaza(data_dir: str | os.PathLike | None = None) -> Path | None:
    """The folder whose original Plaza1 text files ``load_dataset("plaza", data_dir)`` reads, warning
    :class:`~steam_ref.errors.UncleanedDataWarning`, because no folder searched holds the cleaned
    ``Plaza1_thrown_away_some_range.mat``; None when the cleaned file is found, or neither is."""
    folders = default_data_dirs(data_dir)
    plaza = DATASETS["plaza"]
    if _find(tuple(f.local for f in plaza.files), folders) is not None:
        return None
    found = _find(plaza.original, folders)
    return None if found is None else found.parent


def _not_found(what: str, folders: list[Path], hint: str) -> DataError:
    """One line: what is missing, every folder searched, and where to put the file."""
    looked = (
        ", ".join(str(f) for f in folders)
        or f"nowhere (no --data-dir, ${DATA_DIR_ENV} unset, nothing fetched, no gtsam)"
    )
    return DataError(f"{what} not found; looked in: {looked}. {hint}")


def _hint(key: str, put: str = "the file") -> str:
    """Where to put ``put``, and the fetch command when ``key`` names a set ``steam-ref data fetch`` gets (never a
    command that would fail: an unknown name, gtsam's sets)."""
    folder = (
        f"put {put} in a folder and pass that folder as --data-dir (data_dir= in Python) or set ${DATA_DIR_ENV} to it"
    )
    s = DATASETS.get(key)
    if s is not None and s.fetchable:
        return f"Fetch it with `steam-ref data fetch {key}`, or {folder}"
    return folder[0].upper() + folder[1:]


def not_found(what: str, fetch: str, data_dir: str | os.PathLike | None = None, put: str = "the file") -> DataError:
    """The DataError of a search of the data path that found no ``what``: every folder searched (``data_dir`` first)
    and how to get it: ``steam-ref data fetch <fetch>``, or ``put`` in a folder of the search path."""
    return _not_found(what, default_data_dirs(data_dir), _hint(fetch, put) + ".")


def _load_registered(s: DataSet, folders: list[Path], seed: int) -> RangeDataset | LandmarkDataset | RigidReadings:
    """The registry's set ``s`` from the first folder holding all its files; for a set with an original release
    (plaza), that release's files with an UncleanedDataWarning when no folder holds the published file."""
    assert s.loader is not None
    if not s.files:  # generated
        return s.loader(None, s.name, seed)
    files = tuple(f.local for f in s.files)
    found = _find(files, folders)
    if found is not None:
        return _load_named(s, found, seed)
    hint = _hint(s.name)
    if s.original:
        text = _find(s.original, folders)
        if text is not None:
            from .cmu import load_cmu_text  # each reader loads when a file is read (the module docstring)

            release = text.name.removesuffix("_DR.txt")
            data = load_cmu_text(text.parent, release, name=s.name)
            warnings.warn(
                f"load_dataset({s.name!r}): the paper's cleaned {', '.join(files)} is in none of the folders searched, "
                f"so this is the ORIGINAL, uncleaned {release} release in {text.parent} (all {len(data.ranges):,} "
                f"ranges, outliers included), not the paper's data; `steam-ref data fetch {s.name}` gets the cleaned file",
                UncleanedDataWarning,
                stacklevel=3,
            )
            return data
        hint += f" (or `pip install gtsam`: its Data/ has {', '.join(s.original)})"
    elif not s.fetchable:
        hint += " (or `pip install gtsam`: its Data/ has them)"
    raise _not_found(f"data set {s.name!r} ({', '.join(files)})", folders, hint + ".")


def load_dataset(
    name_or_path: str | os.PathLike, data_dir: str | os.PathLike | None = None, seed: int = 0
) -> RangeDataset | LandmarkDataset | RigidReadings:
    """A data set by name or path.

    Names are those of the registry (:data:`~.registry.DATASETS`, each read by its ``loader``):
    "synthetic" (generated, see :func:`generate_synthetic`; ``seed`` applies),
    "paper-synthetic" (``Syn_theta_Plaza.mat``), "plaza" (``Plaza1_thrown_away_some_range.mat``,
    else the original Plaza1 text files with all 3,529 ranges, e.g. from an installed gtsam, with an
    :class:`~steam_ref.errors.UncleanedDataWarning`: :func:`uncleaned_plaza` says beforehand),
    "plaza2" (the CMU text release ``Plaza2_DR.txt``, ``Plaza2_TD.txt``, ``Plaza2_.mat``: all its
    1,816 ranges, none thrown away) and "victoria-park" (``victoria_park.txt``, a
    :class:`LandmarkDataset` read by :func:`load_gtsam_2d`), both as an installed gtsam ships them.
    Named files are searched for in :func:`default_data_dirs`: ``data_dir`` (``--data-dir``),
    ``$STEAM_REF_DATA_DIR``, the installed gtsam's ``Data/``. Anything else is a path: a CMU .mat
    file, a folder of CMU text files, or a GTSAM planar text file (``.txt``); a bare file name that is not in the working directory is
    also searched for there. A missing file raises DataError naming the folders searched and
    where to put it (the fetch command only for a set ``steam-ref data fetch`` gets; the closest
    registered name for a mistyped one); so does an empty name, and a ``data_dir`` that is not a
    folder (even for "synthetic", which reads no file: the caller meant something else). An
    authors' saved run (a registered file with no loader) is named as no data set to run on; a path
    that is there but is no file (a FIFO, a device) is named as such (:func:`.textfile.check_regular`).
    """
    if not isinstance(name_or_path, (str, os.PathLike)):  # str(None) is "None", a file name nobody meant
        raise DataError(f"the data set must be a name or a path, got {name_or_path!r}")
    key = str(name_or_path)
    if not key.strip():
        raise DataError("the data set name is empty: give synthetic, paper-synthetic, plaza, or a file or folder")
    folders = default_data_dirs(data_dir)
    s = DATASETS.get(key)
    if s is not None and s.loader is not None:
        return _load_registered(s, folders, seed)
    path = dataset_path(name_or_path, data_dir)
    from .cmu import load_cmu_mat, load_cmu_text  # each reader loads when a file is read (the module docstring)
    from .gtsam_text import load_gtsam_2d

    if path.is_dir() or path.name.endswith("_DR.txt"):
        return load_cmu_text(path)
    if path.suffix == ".txt":
        return load_gtsam_2d(path)
    return load_cmu_mat(path)


def dataset_path(name_or_path: str | os.PathLike, data_dir: str | os.PathLike | None = None) -> Path:
    """The file or folder :func:`load_dataset` reads for ``name_or_path``, which names no data set of the registry:
    the path as given, else a bare file name found in :func:`default_data_dirs`. DataError when it is neither (the
    folders searched, the closest registered name), when it is there but is no file (a FIFO, a device:
    :func:`.textfile.check_regular`), or when it names a registered file that is no data set (an authors' run)."""
    key = str(name_or_path)
    folders = default_data_dirs(data_dir)
    path = Path(name_or_path)
    if not path.exists() and not path.is_absolute() and len(path.parts) == 1:
        path = _find((path.name,), folders) or path
    if os.path.lexists(path) and not path.is_dir():
        check_regular(path)  # there, but a FIFO, a device or a broken link: named as such, not "not found"
    if path.is_dir() or path.is_file():
        return path
    names = ", ".join(loadable())
    s = DATASETS.get(key)
    if s is not None:  # a registered file that is no data set to run on (an authors' saved run)
        raise DataError(f"{key!r} is not a data set to run on: it is {s.what}; the data sets are: {names}")
    close = difflib.get_close_matches(key, loadable(), n=1)
    guess = f"; did you mean {close[0]!r}?" if close else ""
    raise _not_found(f"data set {key!r} (not one of {names}, nor a file or folder{guess})", folders, _hint(key) + ".")


def load_range_dataset(
    name_or_path: str | os.PathLike, data_dir: str | os.PathLike | None = None, seed: int = 0
) -> RangeDataset:
    """:func:`load_dataset` for a range-only data set in the CMU layout (the paper's, with ground truth);
    DataError naming it when it is another kind (Victoria Park's bearing-ranges, say)."""
    from .table import RangeDataset

    data = load_dataset(name_or_path, data_dir, seed)
    if not isinstance(data, RangeDataset):
        raise DataError(f"data set {str(name_or_path)!r} is a {type(data).__name__}, not a range-only CMU data set")
    return data
