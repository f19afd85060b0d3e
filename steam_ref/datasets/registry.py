"""Every data set by name, in one record each, and the check of a file found under a published name.

:data:`DATASETS` is the registry, the one list of named data sets: each :class:`DataSet` says what it is,
its files (each file's source at a pinned commit, sha256 and size), where they come from and under what
licence, whether ``steam-ref data fetch`` gets them, how they are read (its ``loader``), the preset it runs
with, and the authors' saved run on it, if any. The search path (:func:`~.search.load_dataset`), the
fetcher (:mod:`.fetch`), the command's ``--dataset`` choices and help, ``steam-ref data`` and
``steam-ref fidelity`` all read it; to add a data set, add its record here (docs/architecture.md).

A file is never trusted by its name alone. :func:`published_mismatch` says how a file found under a
registry name differs from the published one (its size, else its sha256), and :func:`check_cached`
refuses a file in the fetched files' cache that differs: that folder is written only by
``steam-ref data fetch``, so a file there that is not the published one (truncated, replaced, or another
set's file under this name) is never read as the named set.

Cost: a size differs by ``stat`` alone, checked at every use. The sha256 of a file of the right size is
computed once per process for each (device, inode, size, mtime, ctime) of the file: a write to it changes
its ctime, which no user call can set back, so a changed file is hashed again; the largest file is 1.7 MB
(its hashing time: docs/experiments.md). A non-regular file (a FIFO, a device, a link to one) is refused before it is opened:
hashing one would block or never end.

Loaded by :mod:`.search` on every named read, by :mod:`.fetch`, and by the command's parser (``--dataset``'s help and
choices): it imports no loader (each reader loads its own when a set is read), no NumPy, never pooch.
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from ..errors import DataError
from .textfile import check_regular  # its home: every reader checks a file before opening it

if TYPE_CHECKING:
    from .landmarks import LandmarkDataset
    from .rigid import RigidReadings
    from .table import RangeDataset

__all__ = [
    "DATASETS",
    "DataFile",
    "DataSet",
    "Loader",
    "UPSTREAM_COMMIT",
    "UPSTREAM_REPOSITORY",
    "check_cached",
    "check_regular",
    "file_digest",
    "loadable",
    "published_mismatch",
    "with_authors_run",
]

UPSTREAM_REPOSITORY = "XinyanGT/online-gpslam-code"
UPSTREAM_COMMIT = "094150971844bd53c9b9cb4562b04f61b8a804a4"
_UPSTREAM_LICENCE = "none stated upstream (research use; not redistributed by steam_ref)"
_GTSAM_SOURCE = "the gtsam wheel's Data/ folder (pip install gtsam)"

# How a data set is read: ``loader(path, name, seed)``, where ``path`` is its first file as found in a data folder
# (None for a set with no file) and ``seed`` applies to a generated set only.
Loader = Callable[[Path | None, str, int], "RangeDataset | LandmarkDataset | RigidReadings"]


@dataclass(frozen=True)
class DataFile:
    """One file: its name at the base URL, where it goes in a data folder, its sha256 and size in bytes (a file
    of the gtsam wheel is not pinned: sha256 "" and size 0)."""

    remote: str
    local: str
    sha256: str
    size: int


@dataclass(frozen=True)
class DataSet:
    """A data set by name: what it is, its files, where they come from, what may be done with them, how it is
    read and run, and the authors' saved run on it."""

    name: str
    what: str
    files: tuple[DataFile, ...]
    source: str
    licence: str
    fetchable: bool = True  # `steam-ref data fetch NAME` downloads its files
    loader: Loader | None = None  # None: not a data set to run on (an authors' saved run)
    preset: str | None = None  # the PaperSetup it runs with (PaperSetup.named), as `--preset` would name it
    authors_run: str | None = None  # the name of the authors' saved BTGP/1 run on it (`steam-ref fidelity`)
    authors_rmse_m: float | None = None  # the position RMSE of that run on this file
    original: tuple[str, ...] = ()  # the original release's files, read when no folder holds the published one
    # other runs' position RMSE on all of this file, to read a run by: (what ran, metres), measured by the command
    # or benchmark each names (docs/experiments.md)
    yardsticks: tuple[tuple[str, float], ...] = ()
    rigid: bool = False  # its loader gives RigidReadings: a 3-D run on SE(3) states (`steam-ref run`, paper/rigid.py)
    dimensions: int = 2  # of the space its body moves in: a prior runs on it when it says the same (PriorChoice)


# Each reader loads its loader's module when a set is read, not when the registry is: the command line's parser reads
# the registry (--dataset's help) without NumPy or SciPy.


def _read_mat(path: Path | None, name: str, _seed: int) -> RangeDataset:
    from .cmu import load_cmu_mat

    return load_cmu_mat(_given(path, name), name=name)


def _read_cmu_text(path: Path | None, name: str, _seed: int) -> RangeDataset:
    from .cmu import load_cmu_text

    path = _given(path, name)  # the first file, PREFIX_DR.txt; its folder holds the others
    return load_cmu_text(path.parent, path.name.removesuffix("_DR.txt"), name=name)


def _read_gtsam_2d(path: Path | None, name: str, _seed: int) -> LandmarkDataset:
    from .gtsam_text import load_gtsam_2d

    return load_gtsam_2d(_given(path, name), name=name)


def _read_kitti(path: Path | None, name: str, _seed: int) -> RigidReadings:
    from ..lie import SE3V  # SE(3) loads when a 3-D set is read (lie/__init__.py, PEP 562)
    from .kitti import load_kitti

    return load_kitti(_given(path, name).parent, group=SE3V, name=name)  # the table's SE(3) priors' group


def _generate(_path: Path | None, _name: str, seed: int) -> RangeDataset:
    from .synthetic import generate_synthetic

    return generate_synthetic(seed=seed)


def _generate_rigid(_path: Path | None, _name: str, seed: int) -> RigidReadings:
    from .rigid import generate_rigid

    return generate_rigid(seed=seed)


def _given(path: Path | None, name: str) -> Path:
    if path is None:
        raise DataError(f"data set {name!r} is read from a file, and none was given")
    return path


def _upstream(name: str, what: str, remote: str, local: str, sha256: str, size: int, **record) -> DataSet:
    """A set of one file of the authors' repository, at the pinned commit."""
    source = f"{UPSTREAM_REPOSITORY} matlab/Data/{remote} @ {UPSTREAM_COMMIT[:7]}"
    return DataSet(name, what, (DataFile(remote, local, sha256, size),), source, _UPSTREAM_LICENCE, **record)


def _gtsam(name: str, what: str, files: tuple[str, ...], **record) -> DataSet:
    """A set read from the files in gtsam's Data/ folder (found in any searched folder), all in one folder."""
    return DataSet(
        name, what, tuple(DataFile(f, f, "", 0) for f in files), _GTSAM_SOURCE, "BSD (GTSAM)", False, **record
    )


# The sha256 of each file was computed from copies of the authors' files (data/README.md): they must match upstream.
DATASETS: dict[str, DataSet] = {
    s.name: s
    for s in (
        DataSet(
            "synthetic",
            "a task like the paper's Sec. IV-A, generated (generate_synthetic; --seed applies)",
            (),
            "steam_ref.datasets.generate_synthetic (no file)",
            "steam_ref's own",
            fetchable=False,
            loader=_generate,
            preset="synthetic",
        ),
        _upstream(
            "paper-synthetic",
            "the paper's synthetic task (Sec. IV-A): 1,501 poses, 298 landmarks",
            "Syn_theta_Plaza.mat",
            "Syn_theta_Plaza.mat",
            "2939aadaf29f343339cd20f3b84bc5c0d51b6240f39f521901ecf27fd5675ce8",
            119_549,
            loader=_read_mat,
            preset="synthetic",
            authors_run="authors-synthetic",
            authors_rmse_m=0.0697,  # `diff` of authors/Syn_full_data_run.mat
        ),
        _upstream(
            "plaza",
            "the Plaza lawnmower run, outliers removed (Sec. IV-B): 9,658 poses, 4 beacons",
            "Plaza1_thrown_away_some_range.mat",
            "Plaza1_thrown_away_some_range.mat",
            "5341839031c60d971aab7a9abd1e553650a5f0054897b0a71a29e12ae8f63351",
            681_427,
            loader=_read_mat,
            preset="plaza",
            authors_run="authors-plaza",
            authors_rmse_m=0.338,  # `diff` of authors/Plaza1_full_data_run.mat: 0.33823 m, the 0.338 m of docs/experiments.md
            original=("Plaza1_DR.txt", "Plaza1_TD.txt", "Plaza1_.mat"),  # the first release, as gtsam's Data/ has it
            yardsticks=(
                ("steam_ref BTGP/1 with the vector-space WNOA prior (steam-ref run --dataset plaza)", 0.338271),
                ("steam_ref BTGP/1 with the SE(2) prior (steam-ref run --dataset plaza --prior se2)", 0.380011),
                ("GTSAM 4.3's ISAM2 with WnoaMotionFactorPose2 (python benchmarks/se2_vs_gtsam.py)", 0.380795),
            ),
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
        _gtsam(
            "victoria-park",
            "Victoria Park: 6,969 poses, 151 trees seen by bearing-range, no ground truth",
            ("victoria_park.txt",),
            loader=_read_gtsam_2d,
            preset="victoria-park",
        ),
        DataSet(
            "synthetic-3d",
            "a vehicle turning and climbing in 3-D with GPS, gyro and 3-D landmarks, generated from the SE(3) model "
            "(generate_rigid; --seed, --steps apply)",
            (),
            "steam_ref.datasets.generate_rigid (no file)",
            "steam_ref's own",
            fetchable=False,
            loader=_generate_rigid,
            rigid=True,
            dimensions=3,
        ),
        _gtsam(
            "kitti",
            "KITTI: 470 GPS fixes and 46,968 IMU rows over 470 s (gtsam's IMU example), 3-D, no ground truth",
            ("KittiGps_converted.txt", "KittiEquivBiasedImu.txt"),
            loader=_read_kitti,
            rigid=True,
            dimensions=3,
        ),
        _gtsam(
            "plaza2",
            "the second Plaza run, all 1,816 ranges",
            ("Plaza2_DR.txt", "Plaza2_TD.txt", "Plaza2_.mat"),
            loader=_read_cmu_text,
            preset="plaza",
        ),
    )
}


def loadable() -> list[str]:
    """The names ``--dataset`` and :func:`~.search.load_dataset` accept (every set with a loader), in order."""
    return [n for n, s in DATASETS.items() if s.loader is not None]


def with_authors_run() -> list[str]:
    """The names of the sets the authors' saved runs are on (``steam-ref fidelity --dataset``), in order."""
    return [n for n, s in DATASETS.items() if s.authors_run is not None]


# A published file by its place in a data folder ("authors/Syn_full_data_run.mat"): its set and its entry.
_PUBLISHED = {f.local: (s.name, f) for s in DATASETS.values() for f in s.files if f.sha256}
_DIGESTS: dict[tuple[int, int, int, int, int], str] = {}  # (st_dev, st_ino, size, mtime_ns, ctime_ns) → sha256


def file_digest(path: str | os.PathLike) -> str:
    """The sha256 of a regular file, in hex (memoized per device, inode, size, mtime and ctime)."""
    info = check_regular(path)
    key = (info.st_dev, info.st_ino, info.st_size, info.st_mtime_ns, info.st_ctime_ns)
    if key not in _DIGESTS:
        digest = hashlib.sha256()
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                digest.update(block)
        _DIGESTS[key] = digest.hexdigest()
    return _DIGESTS[key]


def published_mismatch(path: str | os.PathLike, local: str) -> str | None:
    """How the file ``path``, found as ``local`` in a data folder, differs from the published file of that
    name (its size, else its sha256), or None when it is that file or ``local`` is no published file's name."""
    if local not in _PUBLISHED:
        return None
    _, expected = _PUBLISHED[local]
    size = check_regular(path).st_size
    if size != expected.size:
        return f"{size:,} B where the published file has {expected.size:,} B"
    found = file_digest(path)
    if found != expected.sha256:
        return f"sha256 {found[:12]}... where the published file's is {expected.sha256[:12]}..."
    return None


def check_cached(path: str | os.PathLike, local: str) -> Path:
    """``path``, a file of the fetched files' cache found as ``local``; DataError naming it, the data set and
    how to replace it when it is not the published file (a file there is never trusted by its name)."""
    why = published_mismatch(path, local)
    if why is not None:
        name = _PUBLISHED[local][0]
        raise DataError(
            f"{path}: the cached file of data set {name!r} is not the published one ({why}); "
            f"`steam-ref data fetch {name}` replaces it"
        )
    return Path(path)
