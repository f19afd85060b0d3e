"""LandmarkDataset: a planar SLAM data set of odometry and landmark readings of any kind, and its checks.

:class:`~steam_ref.datasets.RangeDataset` is the CMU range-only layout: ground truth, odometry as
distance and turn, surveyed landmarks. Other data sets have bearings or bearing-ranges, odometry
with a sideways part, landmarks whose positions nobody surveyed, and no ground truth (Victoria
Park). They are a :class:`LandmarkDataset`, one row per record:

    poses                (n_poses, 2)      time, the source's id of the pose
    odometry             (n_poses - 1, 4)  time, dx, dy, dθ: pose k + 1 in the frame of pose k (a Pose2 between)
    odometry_covariance  (n_poses - 1, 6)  its covariance, upper triangle by rows: c11 c12 c13 c22 c23 c33
    ranges               (n, 4)            time, landmark id, range, sigma
    bearings             (n, 4)            time, landmark id, bearing, sigma
    bearing_ranges       (n, 6)            time, landmark id, bearing, range, sigma of the bearing, of the range
    landmark_ids         (m,)              every landmark of the data set
    landmarks            (k, 3)            id, x, y of the landmarks with a surveyed position (k may be 0)
    ground_truth         (n_poses, 4)      time, x, y, heading, or None

Conventions: odometry row k ends at pose k + 1 and carries its time; a reading is taken at a pose
(its time is that pose's, to 1 µs) and belongs to it; bearings are in the robot frame, measured
from its heading. Each reading carries its own sigma, since files give one per row.

Checked on construction, where :class:`RangeDataset`'s checks are shared (the shape and finiteness
of a table, the lookup of ids; :mod:`.table`): at least two poses, strictly increasing pose times,
integer and unique pose and landmark ids, odometry row k stamped with the time of pose k + 1, a
positive definite odometry covariance, reading times in order and each at a pose, every reading's
landmark among ``landmark_ids``, every surveyed landmark among them, positive sigmas, no negative
range, ground truth (when given) at the pose times. Errors: a table of the wrong shape raises
:class:`ShapeError`, bad content :class:`DataError` naming ``table[row, column]`` (rows 0-based).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import DataError
from ..pose2 import integrate_odometry
from .table import _frozen_table, _ids_text, _num, _rows_of

__all__ = ["LandmarkDataset", "LANDMARK_COLUMNS", "READING_TABLES"]

_TIME_TOL = 1e-6  # [s] a reading's time and its pose's must agree to this
LANDMARK_COLUMNS = {  # table -> column names
    "poses": ("time", "id"),
    "odometry": ("time", "dx", "dy", "dtheta"),
    "odometry_covariance": ("c11", "c12", "c13", "c22", "c23", "c33"),
    "ranges": ("time", "landmark id", "range", "sigma"),
    "bearings": ("time", "landmark id", "bearing", "sigma"),
    "bearing_ranges": ("time", "landmark id", "bearing", "range", "sigma bearing", "sigma range"),
    "landmarks": ("id", "x", "y"),
    "ground_truth": ("time", "x", "y", "heading"),
}
READING_TABLES = ("ranges", "bearings", "bearing_ranges")  # the landmark readings, in the order a pose releases them
_SIGMAS = {"ranges": (3,), "bearings": (3,), "bearing_ranges": (4, 5)}  # columns holding sigmas
_UPPER = np.array([[0, 1, 2], [1, 3, 4], [2, 4, 5]])  # (3, 3) entry -> column of the upper triangle


@dataclass(frozen=True, eq=False)
class LandmarkDataset:
    """A planar SLAM data set: odometry, landmark readings of any kind; arrays are read-only float64 copies."""

    name: str  # short label, e.g. "victoria-park"
    poses: NDArray = field(repr=False)  # (n_poses, 2): time, source id
    odometry: NDArray = field(repr=False)  # (n_poses - 1, 4): time, dx, dy, dθ
    odometry_covariance: NDArray = field(repr=False)  # (n_poses - 1, 6): upper triangle of each 3x3 covariance
    ranges: NDArray = field(default_factory=lambda: np.zeros((0, 4)), repr=False)  # (n, 4)
    bearings: NDArray = field(default_factory=lambda: np.zeros((0, 4)), repr=False)  # (n, 4)
    bearing_ranges: NDArray = field(default_factory=lambda: np.zeros((0, 6)), repr=False)  # (n, 6)
    landmark_ids: NDArray | None = field(default=None, repr=False)  # (m,) every landmark; None: those read or surveyed
    landmarks: NDArray = field(default_factory=lambda: np.zeros((0, 3)), repr=False)  # (k, 3) surveyed: id, x, y
    ground_truth: NDArray | None = field(default=None, repr=False)  # (n_poses, 4) or None
    source: str = ""  # a path, plus notes on how the file was read
    dead_reckoning: NDArray = field(init=False, repr=False)  # (n_poses, 4): the odometry composed from ``start_pose``

    def __post_init__(self) -> None:
        for name in ("poses", "odometry", "odometry_covariance", *READING_TABLES, "landmarks"):
            object.__setattr__(self, name, _frozen_table(name, getattr(self, name), LANDMARK_COLUMNS[name]))
        if self.ground_truth is not None:
            object.__setattr__(
                self, "ground_truth", _frozen_table("ground_truth", self.ground_truth, LANDMARK_COLUMNS["ground_truth"])
            )
        self._check_poses()
        self._check_landmark_ids()
        for name in READING_TABLES:
            self._check_readings(name)
        start = np.concatenate([[self.times[0]], self.start_pose])
        drp = integrate_odometry(start, self.odometry)
        drp.setflags(write=False)
        object.__setattr__(self, "dead_reckoning", drp)

    def __repr__(self) -> str:
        counts = ", ".join(f"n_{name}={len(getattr(self, name))}" for name in READING_TABLES)
        return (
            f"LandmarkDataset(name={self.name!r}, n_poses={self.n_poses}, n_landmarks={self.n_landmarks}, {counts}, "
            f"surveyed={len(self.landmarks)}, ground_truth={self.ground_truth is not None}, source={self.source!r})"
        )

    @property
    def n_poses(self) -> int:
        return self.poses.shape[0]

    @property
    def n_landmarks(self) -> int:
        return 0 if self.landmark_ids is None else len(self.landmark_ids)

    @property
    def n_readings(self) -> int:
        """Landmark readings of every kind."""
        return sum(len(getattr(self, name)) for name in READING_TABLES)

    @property
    def times(self) -> NDArray:
        """(n_poses,) pose times, a read-only view of ``poses[:, 0]``."""
        return self.poses[:, 0]

    @property
    def start_pose(self) -> NDArray:
        """[x, y, θ] of pose 0: ground truth when there is some, else the origin of the data's frame (zero)."""
        return self.ground_truth[0, 1:4].copy() if self.ground_truth is not None else np.zeros(3)

    def covariance(self, k: int) -> NDArray:
        """(3, 3) covariance of odometry row k."""
        return self.odometry_covariance[k][_UPPER]

    def reading_poses(self, name: str) -> NDArray:
        """(n,) the pose each row of reading table ``name`` belongs to (its time is that pose's)."""
        if name not in READING_TABLES:
            raise DataError(f"unknown reading table {name!r}; use one of {', '.join(READING_TABLES)}")
        t = getattr(self, name)[:, 0]
        pose = np.clip(np.searchsorted(self.times, t), 1, max(self.n_poses - 1, 1))
        return np.where(np.abs(self.times[pose - 1] - t) <= np.abs(self.times[pose] - t), pose - 1, pose)

    # -- checks --

    def _check_poses(self) -> None:
        t, n = self.times, self.n_poses
        if n < 2:
            raise DataError(f"poses has {n} row(s): a data set needs at least two poses (one odometry step)")
        bad = np.flatnonzero(np.diff(t) <= 0)
        if bad.size:
            k = int(bad[0]) + 1
            raise DataError(
                f"pose times must increase strictly: poses row {k} has t={_num(t[k])} after t={_num(t[k - 1])} at row {k - 1}"
            )
        _check_integer_ids("poses", self.poses[:, 1], 1)
        if len(self.odometry) != n - 1:
            raise DataError(
                f"odometry has {len(self.odometry)} rows but poses has {n}: expected {n - 1} (row k ends at pose k + 1)"
            )
        if len(self.odometry_covariance) != n - 1:
            raise DataError(f"odometry_covariance has {len(self.odometry_covariance)} rows but odometry has {n - 1}")
        off = np.flatnonzero(np.abs(self.odometry[:, 0] - t[1:]) > _TIME_TOL)
        if off.size:
            k = int(off[0])
            raise DataError(
                f"odometry row {k} has t={_num(self.odometry[k, 0])} but pose {k + 1} has t={_num(t[k + 1])}: "
                f"odometry row k must end at pose k+1"
            )
        covariances = self.odometry_covariance[:, _UPPER]
        eigen = np.linalg.eigvalsh(covariances) if n > 1 else np.ones((0, 3))
        bad = np.flatnonzero(eigen[:, 0] <= 0)
        if bad.size:
            k = int(bad[0])
            raise DataError(
                f"odometry_covariance row {k} ({', '.join(_num(v) for v in self.odometry_covariance[k])}) "
                f"is not positive definite (smallest eigenvalue {_num(eigen[k, 0])})"
            )
        if self.ground_truth is not None:
            gt = self.ground_truth
            if len(gt) != n:
                raise DataError(f"ground_truth has {len(gt)} rows but poses has {n}")
            off = np.flatnonzero(np.abs(gt[:, 0] - t) > _TIME_TOL)
            if off.size:
                k = int(off[0])
                raise DataError(f"ground_truth row {k} has t={_num(gt[k, 0])} but pose {k} has t={_num(t[k])}")

    def _check_landmark_ids(self) -> None:
        _check_integer_ids("landmarks", self.landmarks[:, 0], 0)
        if self.landmark_ids is None:
            read = [getattr(self, name)[:, 1] for name in READING_TABLES]
            ids = np.unique(np.concatenate([*read, self.landmarks[:, 0]]))
        else:
            ids = np.array(self.landmark_ids, dtype=float).reshape(-1)
            bad = np.argwhere(~np.isfinite(ids))
            if bad.size:
                raise DataError(f"landmark_ids[{int(bad[0, 0])}] is {ids[int(bad[0, 0])]}: every value must be finite")
            _check_integer_ids("landmark_ids", ids, None)
        ids = ids.astype(int)
        ids.setflags(write=False)
        object.__setattr__(self, "landmark_ids", ids)
        missing = _rows_of(ids.astype(float), self.landmarks[:, 0])[1]
        if missing is not None:
            raise DataError(
                f"landmarks row {missing} surveys landmark id {self.landmarks[missing, 0]:g}, "
                f"which is not in landmark_ids ({_ids_text(ids.astype(float))})"
            )

    def _check_readings(self, name: str) -> None:
        table, columns = getattr(self, name), LANDMARK_COLUMNS[name]
        if not len(table):
            return
        t = table[:, 0]
        back = np.flatnonzero(np.diff(t) < 0)
        if back.size:
            k = int(back[0]) + 1
            raise DataError(
                f"{name} times must not go back: {name} row {k} has t={_num(t[k])} after t={_num(t[k - 1])} at row {k - 1}"
            )
        pose = self.reading_poses(name)
        off = np.flatnonzero(np.abs(self.times[pose] - t) > _TIME_TOL)
        if off.size:
            k = int(off[0])
            raise DataError(
                f"{name} row {k} has t={_num(t[k])}, which is no pose's time (the nearest, pose {int(pose[k])}, "
                f"has t={_num(self.times[pose[k]])}): a reading is taken at a pose"
            )
        ids = table[:, 1]
        frac = np.flatnonzero(ids != np.round(ids))
        if frac.size:
            k = int(frac[0])
            raise DataError(f"{name}[{k}, 1] (landmark id) = {_num(ids[k])} is not an integer")
        known = np.zeros(0) if self.landmark_ids is None else self.landmark_ids.astype(float)
        missing = _rows_of(known, ids)[1]
        if missing is not None:
            raise DataError(
                f"{name} row {missing} (t={_num(t[missing])}) names landmark id {ids[missing]:g}, "
                f"which is not in landmark_ids ({_ids_text(known)})"
            )
        for c in _SIGMAS[name]:
            bad = np.flatnonzero(table[:, c] <= 0)
            if bad.size:
                k = int(bad[0])
                raise DataError(f"{name}[{k}, {c}] ({columns[c]}) = {_num(table[k, c])}: a sigma must be > 0")
        if "range" in columns:
            c = columns.index("range")
            bad = np.flatnonzero(table[:, c] < 0)
            if bad.size:
                k = int(bad[0])
                raise DataError(
                    f"{name}[{k}, {c}] (range) = {_num(table[k, c])} at t={_num(t[k])} is negative: a range is a distance"
                )


def _check_integer_ids(name: str, ids: ArrayLike, column: int | None) -> None:
    """Integer and unique ids; DataError naming ``name[row, column]`` (or ``name[row]``) otherwise."""
    ids = np.asarray(ids, dtype=float)
    where = (lambda k: f"{name}[{k}, {column}]") if column is not None else (lambda k: f"{name}[{k}]")
    frac = np.flatnonzero(ids != np.round(ids))
    if frac.size:
        k = int(frac[0])
        raise DataError(f"{where(k)} (id) = {_num(ids[k])} is not an integer")
    order = np.argsort(ids, kind="stable")
    same = np.flatnonzero(np.diff(ids[order]) == 0)
    if same.size:
        r1, r2 = int(order[same[0]]), int(order[same[0] + 1])
        raise DataError(f"id {ids[r1]:g} appears twice in {name}, rows {r1} and {r2}")
