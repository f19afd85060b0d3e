"""The paper's data by name: where each file comes from, its sha256, and the fetch into the user's cache.

The four files of the paper's experiments are in the authors' public repository
(``XinyanGT/online-gpslam-code``, folder ``matlab/Data/``), fetched from a commit pinned here, so that a
later push upstream cannot change what a name means. Each file is fetched by name from a base URL:
:data:`DEFAULT_BASE_URL`, or a mirror named by ``base_url`` (the CLI's ``--base-url``) or
``$STEAM_REF_DATA_URL``. ``pooch`` downloads, checks the sha256 and moves the file into
:func:`~steam_ref.datasets.search.data_cache_dir` only once it matches: a corrupt or truncated download
leaves nothing behind, and a download is cut as soon as it exceeds the registry's size. The search path
(:func:`~steam_ref.datasets.search.default_data_dirs`) then finds it, and checks it again at every read
(:mod:`.registry`).

Everything is checked before a byte is downloaded: every name asked for, the URL (http or https, a
host, a port that is a number), the cache folder (a folder that can be written, else an error naming it,
not the download), and a file already under a data file's name (a FIFO or a device there is refused,
not hashed). A user name or password in the URL, and every value of its query (where a token or a
signature travels: ``?token=***``), is shown as ``***`` in every message (:func:`shown_url`, the one home of
that masking). A mirror is flat, as upstream's ``matlab/Data/`` is: each file is fetched from the base URL's
folder by its upstream name (``<base>/Plaza1_full_data_run.mat``, though it is kept in the cache's
``authors/``), the base URL's query, if any, kept after it (``<base>/Syn_theta_Plaza.mat?token=...``).

A fetch killed mid-download (SIGKILL, a power cut: no clean-up runs) leaves pooch's temporary file in the
folder of the file it was downloading. Pooch names it as :func:`tempfile.NamedTemporaryFile` does
(``pooch.utils.temporary_file``): ``tmp`` and 8 characters of ``a-z0-9_``, no suffix, e.g. ``tmpk3_x9q0a``. It is never
read (the search path asks for the data files' names), but it would stay. The next fetch into the default cache
folder removes, in each folder it downloads into, a regular file named exactly so that has not been written to for
:data:`STALE_AFTER` seconds (an hour). The rule is conservative on both sides: only in the default cache, which fetch
alone writes (in a folder given as ``cache`` such a name could be one of the user's files: it is left there); and
never a temporary a fetch running beside it is still writing, since a live download writes each chunk through to the
file as it arrives (:class:`_Capped`) and its reads time out after 60 s, so the file's time of last change is never
more than a minute or so old (then its sha256 is checked and it is renamed). A fetch stopped (not killed) for more
than an hour finds its temporary gone when it resumes: a DataError, and fetching again works.

Victoria Park and Plaza2, and the original Plaza1 files, are not fetched: they ship in the ``gtsam`` wheel's
``Data/`` folder (``pip install gtsam``), which the search path reads as it is.
"""

from __future__ import annotations

import logging
import os
import re
import stat
import tempfile
import time
import urllib.parse
from pathlib import Path

from ..errors import DataError
from .registry import (
    DATASETS,
    UPSTREAM_COMMIT,
    UPSTREAM_REPOSITORY,
    DataFile,
    DataSet,
    check_regular,
    file_digest,
    published_mismatch,
)
from .search import data_cache_dir, default_data_dirs, holds_set

__all__ = [
    "DATASETS",
    "DATA_URL_ENV",
    "DEFAULT_BASE_URL",
    "DataFile",
    "DataSet",
    "STALE_AFTER",
    "UPSTREAM_COMMIT",
    "UPSTREAM_REPOSITORY",
    "fetch",
    "file_digest",
    "file_url",
    "found",
    "locate",
    "missing_needs",
    "shown_url",
]

DEFAULT_BASE_URL = f"https://raw.githubusercontent.com/{UPSTREAM_REPOSITORY}/{UPSTREAM_COMMIT}/matlab/Data/"
DATA_URL_ENV = "STEAM_REF_DATA_URL"
_USERINFO = re.compile(r"([A-Za-z][A-Za-z0-9+.-]*://)[^/?#\s]*@")  # scheme://user:password@ (to the last @)
_QUERY = re.compile(r"\?([^\s#'\"<>()]+)")  # a URL's query, up to its fragment or the end of the quoted URL
STALE_AFTER = 3600.0  # s: a pooch temporary not written to for this long is a killed fetch's (module docstring)
# pooch.utils.temporary_file's name: tempfile.NamedTemporaryFile(dir=folder), its prefix and 8 random characters
_POOCH_TEMPORARY = re.compile(re.escape(tempfile.gettempprefix()) + r"[a-z0-9_]{8}")


def _dataset(name: str) -> DataSet:
    if name not in DATASETS:
        with_files = (n for n, s in DATASETS.items() if s.files)
        raise DataError(f"no data set named {name!r}; the names are: {', '.join(with_files)}")
    return DATASETS[name]


def found(name: str, data_dir: str | os.PathLike | None = None) -> tuple[list[Path], list[str]] | None:
    """The files of data set ``name`` in the first searched folder that holds them all, with how each that is
    not the published file differs (empty: they all are), or None. DataError when one is not a regular file, or a
    folder holds some of them only (:func:`~.search.holds_set`)."""
    if not _dataset(name).files:  # generated: nothing to find
        return None
    for folder in default_data_dirs(data_dir):
        paths = [folder / f.local for f in _dataset(name).files]
        if holds_set(folder, tuple(f.local for f in _dataset(name).files)):
            differs = [
                f"{p}: {why}"
                for p, f in zip(paths, _dataset(name).files, strict=True)
                if (why := published_mismatch(p, f.local))
            ]
            return paths, differs
    return None


def locate(name: str, data_dir: str | os.PathLike | None = None) -> list[Path] | None:
    """The files of data set ``name`` in the first searched folder that holds them all, when they are the
    published files (sha256 and size, :mod:`.registry`), else None."""
    got = found(name, data_dir)
    return got[0] if got is not None and not got[1] else None


def missing_needs(needs: list[str] | tuple[str, ...]) -> list[str]:
    """Which of ``needs`` are absent: ``"data:NAME"`` (data set NAME's published files in the search path)
    or a package's import name (found, not imported). A tutorial declares its needs in its metadata."""
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


def shown_url(text: str) -> str:
    """``text`` (a URL, or a message quoting one, as requests' do) as a message may show it: a user name or
    password (``scheme://***@host``) and the value of every query field (``?token=***&expires=***``; a field
    without ``=``, ``***``) replaced by ``***``. The one home of hiding a URL's secrets."""

    def fields(query: re.Match) -> str:
        return "?" + "&".join(
            f"{k}=***" if sep else "***" for k, sep, _ in (f.partition("=") for f in query[1].split("&"))
        )

    return _QUERY.sub(fields, _USERINFO.sub(r"\1***@", text))


def file_url(base: str, remote: str) -> str:
    """The URL of the file ``remote`` under the base URL ``base`` (as :func:`base_url` returns it): the name
    appended to its path, its query (a token) kept after it."""
    parts = urllib.parse.urlsplit(base)
    return urllib.parse.urlunsplit(
        (parts.scheme, parts.netloc, parts.path + urllib.parse.quote(remote), parts.query, "")
    )


def base_url(given: str | None = None) -> str:
    """``given``, else ``$STEAM_REF_DATA_URL``, else :data:`DEFAULT_BASE_URL`; its path with one trailing slash.
    DataError, naming it (credentials masked), when it is not an http:// or https:// address with a host
    and, if it gives one, a numeric port."""
    url = given if given is not None else os.environ.get(DATA_URL_ENV) or DEFAULT_BASE_URL  # --base-url '' is refused
    try:
        parts = urllib.parse.urlsplit(url)
        parts.port  # noqa: B018 -- a port that is not a number in 0-65535 raises ValueError here
    except ValueError as exc:
        raise DataError(f"the base URL {shown_url(url)!r} cannot be parsed: {exc}") from None
    if parts.scheme not in ("http", "https") or not url.startswith(("http://", "https://")):
        raise DataError(f"the base URL {shown_url(url)!r} is not an http:// or https:// address")
    if not parts.hostname or any(c.isspace() for c in url):
        raise DataError(f"the base URL {shown_url(url)!r} names no host (or holds a blank)")
    return urllib.parse.urlunsplit(
        (parts.scheme, parts.netloc, parts.path.rstrip("/") + "/", parts.query, parts.fragment)
    )


_OTHER_CACHE = "set XDG_CACHE_HOME to a folder you can write (its steam_ref/data/ then holds the files)"
_HASH = re.compile(r"but got ([0-9a-f]{64})")  # the downloaded file's sha256 in pooch's message


def _try_again(name: str) -> str:
    """What a failed download tells its user to do: nothing of it was kept, so fetch again, or from another server."""
    return (
        f"nothing of it was kept; `steam-ref data fetch {name}` tries again "
        f"(--base-url or ${DATA_URL_ENV} names another server)"
    )


def _by_hand(f: DataFile, target: Path, others: list[tuple[str, Path]]) -> str:
    """What to do where this machine cannot reach the server at all: the file fetched elsewhere, put where the search
    path (:func:`~steam_ref.datasets.search.default_data_dirs`) reads it, checked there at every read; and the same for
    ``others`` (URL, path), the files of the same fetch after it, still absent (one trip to a connected machine, not
    one per file)."""
    rest = "; ".join(f"{where} to {path}" for where, path in others)
    return (
        f"where this machine has no connection to it, download that URL on one that has and copy the file to {target} "
        f"(or to {f.local} in a folder given as --data-dir, data_dir= in Python, or $STEAM_REF_DATA_DIR)"
        + (f"; this fetch's other files, not fetched either, the same way: {rest}" if rest else "")
    )


def _writable_folder(folder: Path) -> None:
    """DataError naming ``folder`` when it cannot hold downloads: not a folder, or not creatable/writable."""
    if folder.exists() and not folder.is_dir():
        raise DataError(f"the cache folder {folder} is not a folder; remove it, or {_OTHER_CACHE}")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        raise DataError(
            f"the cache folder {folder} cannot be written: {exc.strerror or type(exc).__name__}; {_OTHER_CACHE}"
        ) from None


def fetch(
    names: list[str] | tuple[str, ...] | None = None,
    base: str | None = None,
    cache: str | os.PathLike | None = None,
    progress: bool = False,
) -> dict[str, list[Path]]:
    """Download the files of the data sets ``names`` (default: every fetchable one) into ``cache``
    (default :func:`data_cache_dir`), each checked against its sha256; return each set's files.

    Every name, the URL, the cache folder and the files already there are checked before anything is
    downloaded (see the module docstring). A file already in the cache with the right sha256 is not
    downloaded again; one that differs is replaced in the default cache folder (only ``fetch`` writes it), and refused,
    never overwritten, in a folder given as ``cache`` (the user's file). A download larger than the registry's size is cut and
    refused; one whose sha256 differs is refused (DataError naming the file, both hashes) and nothing of it
    is left in the cache; an unreachable host, a download cut short or an HTTP error is a DataError of one line.
    Each says what to do: nothing was kept, ``steam-ref data fetch NAME`` tries again, ``--base-url`` or
    ``$STEAM_REF_DATA_URL`` names another server, and a host that cannot be reached at all, where to copy the file
    downloaded on another machine, and every later file of the fetch still absent with it (a cache folder that
    cannot be written: XDG_CACHE_HOME). The gtsam wheel's sets are not fetched: asking for one is a DataError saying
    to ``pip install gtsam``. In the default cache folder,
    the temporary files of downloads killed more than :data:`STALE_AFTER` seconds ago are removed (module docstring).
    """
    wanted = list(names) if names else [n for n, s in DATASETS.items() if s.fetchable]
    sets = [_dataset(n) for n in wanted]
    for s in sets:
        if not s.fetchable:
            where = f"it ships in {s.source}" if s.files else "it is generated, from no file"
            raise DataError(f"data set {s.name!r} is not fetched: {where}")
    url = base_url(base)
    folder = Path(cache) if cache is not None else data_cache_dir()
    # the default cache is written by fetch alone: a file there that differs is replaced, never one of the user's
    own = folder.resolve() == data_cache_dir().resolve()
    for f in {f for s in sets for f in s.files}:
        target = folder / f.local
        _writable_folder(target.parent)
        if os.path.lexists(target):
            check_regular(target)  # pooch would hash a FIFO or /dev/zero for ever
            why = None if own else published_mismatch(target, f.local)
            if why is not None:  # pooch would download over it: in a folder of the user's, it is the user's file
                raise DataError(
                    f"{target} is there and is not the published file ({why}); fetch replaces a file only in its own "
                    f"cache folder ({data_cache_dir()}): move it away, or fetch into another folder"
                )
    if own:  # only fetch writes there: a file under pooch's temporary name is a killed fetch's
        for parent in {(folder / f.local).parent for s in sets for f in s.files}:
            _remove_stale_temporaries(parent)
    import pooch  # here, not at the top: every command loads this module, only a download needs pooch (~4 MB)

    pooch.get_logger().setLevel(logging.WARNING)  # the caller says what was fetched
    order = [(s.name, f) for s in sets for f in s.files]
    got: dict[str, list[Path]] = {s.name: [] for s in sets}
    for i, (name, f) in enumerate(order):
        later = dict.fromkeys(g for _, g in order[i + 1 :] if g != f and not os.path.lexists(folder / g.local))
        others = [(shown_url(file_url(url, g.remote)), folder / g.local) for g in later]
        got[name].append(_fetch_file(name, f, url, folder, progress, others))
    return got


def _remove_stale_temporaries(folder: Path) -> None:
    """Remove from ``folder`` (fetch's own cache) the temporaries of pooch's downloads killed before their end: regular
    files named as pooch names them, not written to for :data:`STALE_AFTER` seconds (the module docstring)."""
    for entry in os.scandir(folder):
        if not _POOCH_TEMPORARY.fullmatch(entry.name):
            continue
        try:
            info = entry.stat(follow_symlinks=False)
            if stat.S_ISREG(info.st_mode) and time.time() - info.st_mtime > STALE_AFTER:
                os.unlink(entry.path)
        except OSError:  # removed first by another fetch, or not ours to remove (a shared folder): left as it is
            pass


class _TooLarge(Exception):
    """A download went past the registry's size of its file."""


class _Capped:
    """The file a download is written to, refusing to grow past ``limit`` bytes, each chunk written through."""

    def __init__(self, handle, limit: int) -> None:
        self._handle, self._limit, self._written = handle, limit, 0

    def write(self, chunk: bytes) -> int:
        self._written += len(chunk)
        if self._written > self._limit:
            raise _TooLarge(f"more than the registry's {self._limit:,} B")
        written = self._handle.write(chunk)
        self._handle.flush()  # through to the file: its time of last change shows the download is alive
        return written

    def flush(self) -> None:
        self._handle.flush()


def _capped_download(limit: int, progress: bool):
    """A pooch downloader that writes at most ``limit`` bytes (the registry's size of the file)."""
    import pooch

    http = pooch.HTTPDownloader(progressbar=progress, timeout=60)

    def download(url: str, output_file: str, pooch_instance: object) -> None:
        with open(output_file, "w+b") as handle:
            http(url, _Capped(handle, limit), pooch_instance)

    return download


def _fetch_file(name: str, f: DataFile, url: str, folder: Path, progress: bool, others: list[tuple[str, Path]]) -> Path:
    """One file of data set ``name`` into ``folder``, verified; DataError of one line saying what to do (where the
    server cannot be reached, for ``others`` too: the (URL, path) of the fetch's files after it, still absent)."""
    import pooch
    import requests

    target = folder / f.local
    where = shown_url(file_url(url, f.remote))
    again = _try_again(name)
    try:
        path = pooch.retrieve(
            file_url(url, f.remote),
            known_hash=f"sha256:{f.sha256}",
            fname=target.name,
            path=target.parent,
            progressbar=progress,
            downloader=_capped_download(f.size, progress),
        )
    except _TooLarge as exc:
        raise DataError(f"{where}: refused, the download grew past its size ({exc}); {again}") from None
    except requests.exceptions.HTTPError as exc:
        answer = exc.response
        status = "an HTTP error" if answer is None else f"{answer.status_code} {answer.reason}"
        raise DataError(f"{where}: {status}; {again}") from None
    except requests.exceptions.RequestException as exc:  # before ValueError: requests' InvalidURL is both
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        unreachable = isinstance(exc, requests.exceptions.ConnectionError | requests.exceptions.Timeout)
        by_hand = f"; {_by_hand(f, target, others)}" if unreachable else ""
        raise DataError(f"cannot fetch {where}: {type(exc).__name__}: {shown_url(reason)}; {again}{by_hand}") from None
    except ValueError as exc:  # pooch: the downloaded file's hash differs (pooch has deleted the download)
        got = _HASH.search(str(exc))
        shown = f"got {got[1][:12]}..." if got else shown_url(str(exc))
        raise DataError(
            f"{where}: refused, its sha256 is not the expected {f.sha256[:12]}... ({shown}); {again}"
        ) from None
    except OSError as exc:
        raise DataError(f"cannot write {target}: {type(exc).__name__}: {exc.strerror or exc}; {_OTHER_CACHE}") from None
    return Path(path)
