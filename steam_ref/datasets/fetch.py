"""The paper's data by name: where each file comes from, its sha256, and the fetch into the user's cache.

The four files of the paper's experiments are in the authors' public repository
(``XinyanGT/online-gpslam-code``, folder ``matlab/Data/``), fetched from a commit pinned here, so that a
later push upstream cannot change what a name means. Each file is fetched by name from a base URL:
:data:`DEFAULT_BASE_URL`, or a mirror named by ``base_url`` (the CLI's ``--base-url``) or
``$STEAM_REF_DATA_URL``. ``pooch`` downloads, checks the sha256 and moves the file into
:func:`~steam_ref.datasets.search.data_cache_dir` only once it matches: a corrupt or truncated download
leaves nothing behind. The search path (:func:`~steam_ref.datasets.search.default_data_dirs`) then finds it.

Victoria Park and Plaza2, and the original Plaza1 files, are not fetched: they ship in the ``gtsam`` wheel's
``Data/`` folder (``pip install gtsam``), which the search path reads as it is.
"""

from __future__ import annotations

import hashlib
import logging
import os
from dataclasses import dataclass
from pathlib import Path

import pooch
import requests

from ..errors import DataError
from .search import _GTSAM_SETS, data_cache_dir, default_data_dirs

__all__ = [
    "DATASETS",
    "DATA_URL_ENV",
    "DEFAULT_BASE_URL",
    "DataFile",
    "DataSet",
    "fetch",
    "file_digest",
    "locate",
    "missing_needs",
]

UPSTREAM_REPOSITORY = "XinyanGT/online-gpslam-code"
UPSTREAM_COMMIT = "094150971844bd53c9b9cb4562b04f61b8a804a4"
DEFAULT_BASE_URL = f"https://raw.githubusercontent.com/{UPSTREAM_REPOSITORY}/{UPSTREAM_COMMIT}/matlab/Data/"
DATA_URL_ENV = "STEAM_REF_DATA_URL"
_UPSTREAM_LICENCE = "none stated upstream (research use; not redistributed by steam_ref)"


@dataclass(frozen=True)
class DataFile:
    """One file: its name at the base URL, where it goes in a data folder, its sha256 and size in bytes."""

    remote: str
    local: str
    sha256: str
    size: int


@dataclass(frozen=True)
class DataSet:
    """A data set by name: what it is, its files, where they come from, and what may be done with them."""

    name: str
    what: str
    files: tuple[DataFile, ...]
    source: str
    licence: str
    fetchable: bool = True
    authors_rmse_m: float | None = None  # the position RMSE of the authors' saved BTGP/1 run on this file


def _upstream(
    name: str, what: str, remote: str, local: str, sha256: str, size: int, rmse: float | None = None
) -> DataSet:
    source = f"{UPSTREAM_REPOSITORY} matlab/Data/{remote} @ {UPSTREAM_COMMIT[:7]}"
    return DataSet(name, what, (DataFile(remote, local, sha256, size),), source, _UPSTREAM_LICENCE, True, rmse)


def _gtsam(name: str, what: str) -> DataSet:
    files = tuple(DataFile(f, f, "", 0) for f in _GTSAM_SETS[name])
    return DataSet(name, what, files, "the gtsam wheel's Data/ folder (pip install gtsam)", "BSD (GTSAM)", False)


# The sha256 of each file was computed from copies of the authors' files (data/README.md): they must match upstream.
DATASETS: dict[str, DataSet] = {
    s.name: s
    for s in (
        _upstream(
            "paper-synthetic",
            "the paper's synthetic task (Sec. IV-A): 1,501 poses, 298 landmarks",
            "Syn_theta_Plaza.mat",
            "Syn_theta_Plaza.mat",
            "2939aadaf29f343339cd20f3b84bc5c0d51b6240f39f521901ecf27fd5675ce8",
            119_549,
            0.0697,  # `diff` of authors/Syn_full_data_run.mat
        ),
        _upstream(
            "plaza",
            "the Plaza lawnmower run, outliers removed (Sec. IV-B): 9,658 poses, 4 beacons",
            "Plaza1_thrown_away_some_range.mat",
            "Plaza1_thrown_away_some_range.mat",
            "5341839031c60d971aab7a9abd1e553650a5f0054897b0a71a29e12ae8f63351",
            681_427,
            0.338,  # `diff` of authors/Plaza1_full_data_run.mat: 0.33823 m, the 0.338 m of docs/experiments.md
        ),
        _upstream(
            "authors-synthetic",
            "the authors' saved BTGP run on paper-synthetic (steam-ref fidelity)",
            "Syn_full_data_run.mat",
            "authors/Syn_full_data_run.mat",
            "f7d82abdbaf02cd0b292a33307f258dee93765b4b582cf19cedb44071c275649",
            120_388,
        ),
        _upstream(
            "authors-plaza",
            "the authors' saved BTGP run on plaza (steam-ref fidelity, tutorial 04)",
            "Plaza1_full_data_run.mat",
            "authors/Plaza1_full_data_run.mat",
            "8bb579cf7eccc9b3bf3f3627cd0918c104cdb70c0c9d05cf0d85b45c96108af4",
            1_752_548,
        ),
        _gtsam("victoria-park", "Victoria Park: 6,969 poses, 151 trees seen by bearing-range, no ground truth"),
        _gtsam("plaza2", "the second Plaza run, all 1,816 ranges"),
    )
}


def file_digest(path: str | os.PathLike) -> str:
    """The sha256 of a file, in hex."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def _dataset(name: str) -> DataSet:
    if name not in DATASETS:
        raise DataError(f"no data set named {name!r}; the names are: {', '.join(DATASETS)}")
    return DATASETS[name]


def locate(name: str, data_dir: str | os.PathLike | None = None) -> list[Path] | None:
    """The files of data set ``name`` in the first searched folder that holds them all, or None."""
    for folder in default_data_dirs(data_dir):
        paths = [folder / f.local for f in _dataset(name).files]
        if all(p.is_file() for p in paths):
            return paths
    return None


def missing_needs(needs: list[str] | tuple[str, ...]) -> list[str]:
    """Which of ``needs`` are absent: ``"data:NAME"`` (data set NAME's files in the search path) or a
    package's import name (found, not imported). A tutorial declares its needs in its metadata."""
    missing = []
    for need in needs:
        kind, _, name = need.partition(":")
        if kind == "data" and name:
            if locate(name) is None:
                missing.append(need)
        elif not _importable(need):
            missing.append(need)
    return missing


def _importable(module: str) -> bool:
    try:
        __import__(module)
    except ImportError:
        return False
    return True


def base_url(given: str | None = None) -> str:
    """``given``, else ``$STEAM_REF_DATA_URL``, else :data:`DEFAULT_BASE_URL`; with one trailing slash."""
    url = given or os.environ.get(DATA_URL_ENV) or DEFAULT_BASE_URL
    if not url.startswith(("http://", "https://")):
        raise DataError(f"the base URL {url!r} is not an http:// or https:// address")
    return url.rstrip("/") + "/"


def fetch(
    names: list[str] | tuple[str, ...] | None = None,
    base: str | None = None,
    cache: str | os.PathLike | None = None,
    progress: bool = False,
) -> dict[str, list[Path]]:
    """Download the files of the data sets ``names`` (default: every fetchable one) into ``cache``
    (default :func:`data_cache_dir`), each checked against its sha256; return each set's files.

    A file already in the cache with the right sha256 is not downloaded again. A download whose sha256
    differs is refused (DataError naming the file, both hashes) and nothing of it is left in the cache;
    an unreachable host or an HTTP error is a DataError of one line. The gtsam wheel's sets are not
    fetched: asking for one is a DataError saying to ``pip install gtsam``.
    """
    wanted = list(names) if names else [n for n, s in DATASETS.items() if s.fetchable]
    sets = [_dataset(n) for n in wanted]
    for s in sets:
        if not s.fetchable:
            raise DataError(f"data set {s.name!r} is not fetched: it ships in {s.source}")
    url = base_url(base)
    folder = Path(cache) if cache is not None else data_cache_dir()
    pooch.get_logger().setLevel(logging.WARNING)  # the caller says what was fetched
    found: dict[str, list[Path]] = {}
    for s in sets:
        found[s.name] = [_fetch_file(f, url, folder, progress) for f in s.files]
    return found


def _fetch_file(f: DataFile, url: str, folder: Path, progress: bool) -> Path:
    target = folder / f.local
    try:
        path = pooch.retrieve(
            url + f.remote,
            known_hash=f"sha256:{f.sha256}",
            fname=target.name,
            path=target.parent,
            progressbar=progress,
        )
    except ValueError as exc:  # pooch: the downloaded file's hash differs (the download is deleted)
        raise DataError(
            f"{url + f.remote}: refused, its sha256 is not the expected {f.sha256[:12]}... ({exc})"
        ) from None
    except requests.exceptions.HTTPError as exc:
        answer = exc.response
        status = "an HTTP error" if answer is None else f"{answer.status_code} {answer.reason}"
        raise DataError(f"{url + f.remote}: {status}") from None
    except (requests.exceptions.RequestException, OSError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise DataError(f"cannot fetch {url + f.remote}: {type(exc).__name__}: {reason}") from None
    return Path(path)
