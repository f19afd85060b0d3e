"""The folders searched for data files, and the variables that name where data comes from.

Named files are searched for in exactly four places, in order (:func:`default_data_dirs`): the ``data_dir``
argument (the CLI's ``--data-dir``), ``$STEAM_REF_DATA_DIR``, the user's cache folder where ``steam-ref data fetch``
puts the files it downloads (:func:`data_cache_dir`), the ``Data/`` folder of an installed gtsam wheel; what is
read from them is :mod:`.search`'s. ``--data-dir``'s help (:func:`data_dir_help`) is written beside the order it
states, and ``$STEAM_REF_DATA_URL`` (:data:`DATA_URL_ENV`) names the mirror :mod:`.fetch` downloads from.

Imports no loader and no NumPy: the command's parser reads it for ``--data-dir``'s and ``--base-url``'s help.
"""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

from ..errors import DataError

__all__ = ["DATA_DIR_ENV", "DATA_URL_ENV", "data_cache_dir", "data_dir_help", "default_data_dirs", "gtsam_data_dir"]

DATA_DIR_ENV = "STEAM_REF_DATA_DIR"
DATA_URL_ENV = "STEAM_REF_DATA_URL"  # a mirror of the authors' files, read by steam-ref data fetch (fetch.py)


def data_dir_help(also: str = "") -> str:
    """The help of ``--data-dir`` in every command that has one: the whole search path of
    :func:`default_data_dirs`, written beside it. ``also``: what else the command looks for there."""
    return f"folder searched for data files{also} before ${DATA_DIR_ENV}, the fetched files' cache and gtsam's Data/"


def data_cache_dir() -> Path:
    """The folder ``steam-ref data fetch`` downloads into: ``data/`` in the user's cache folder
    (platformdirs: ``~/.cache/steam_ref/data`` on Linux, ``$XDG_CACHE_HOME`` honoured). It may not exist."""
    import platformdirs  # loaded when a search or a fetch asks, not by the command's parser

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
