"""LandmarkDataset: a planar SLAM data set of odometry and landmark readings of any kind, and its checks.

:class:`~steam_ref.datasets.RangeDataset` is the CMU range-only layout: ground truth, odometry as
distance and turn, surveyed landmarks. Other data sets have bearings or bearing-ranges, odometry
with a sideways part, landmarks whose positions nobody surveyed, and no ground truth (Victoria
Park). They are a :class:`LandmarkDataset`, one row per record (the table of columns is the class's
docstring, what ``help(steam_ref.LandmarkDataset)`` shows).

Conventions: odometry row k ends at pose k + 1 and carries its time; a reading is taken at a pose
(its time is that pose's, to 1 µs) and belongs to it; bearings are in the robot frame, measured
from its heading. Each reading carries its own sigma, since files give one per row.

Checked on construction, where :class:`RangeDataset`'s checks are shared (the shape and finiteness
of a table, the lookup of ids; :mod:`steam_ref.datasets.table`): at least two poses, strictly increasing pose times,
integer and unique pose and landmark ids, odometry row k stamped with the time of pose k + 1, a
positive definite odometry covariance, reading times in order and each at a pose, every reading's
landmark among ``landmark_ids``, every surveyed landmark among them, positive sigmas, no negative
range, ground truth (when given) at the pose times. Readings no sensor gives are refused, naming them:
a value whose float64 spacing exceeds its sigma (a bearing of 1e17 rad: numbers there are 16 rad apart),
and a range that contradicts the other ranges to its landmark by more than the robot can have moved
between them (the triangle inequality along the odometry's path, with :data:`RANGE_SLACK_SIGMAS` sigmas
of slack; a sighting at 1e6 m of a tree seen at 10 m). A landmark read once cannot be checked so: such
a reading only places its landmark. Errors: a table of the wrong shape raises
:class:`ShapeError`, bad content :class:`DataError` naming ``table[row, column]`` (rows 0-based).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..dead_reckoning import integrate_odometry
from ..errors import DataError
from .table import check_time_origin, frozen_table, ids_text, number_text, rows_of

__all__ = ["LandmarkDataset", "LANDMARK_COLUMNS", "READING_TABLES", "RANGE_SLACK_SIGMAS", "check_integer_ids"]

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
_VALUE_SIGMA = {"ranges": ((2, 3),), "bearings": ((2, 3),), "bearing_ranges": ((2, 4), (3, 5))}  # value, sigma columns
RANGE_SLACK_SIGMAS = 10.0  # two ranges to a landmark may break the triangle inequality by this many sigmas
_UPPER = np.array([[0, 1, 2], [1, 3, 4], [2, 4, 5]])  # (3, 3) entry -> column of the upper triangle


@dataclass(frozen=True, eq=False)
class LandmarkDataset:
    """A planar SLAM data set: odometry, landmark readings of any kind; arrays are read-only float64 copies. One row
    per record (seconds, metres, radians; :data:`LANDMARK_COLUMNS` names the columns)::

        poses                (n_poses, 2)      time, the source's id of the pose
        odometry             (n_poses - 1, 4)  time, dx, dy, dθ: pose k + 1 in the frame of pose k (a Pose2 between)
        odometry_covariance  (n_poses - 1, 6)  its covariance, upper triangle by rows: c11 c12 c13 c22 c23 c33
        ranges               (n, 4)            time, landmark id, range, sigma
        bearings             (n, 4)            time, landmark id, bearing, sigma
        bearing_ranges       (n, 6)            time, landmark id, bearing, range, sigma of the bearing, of the range
        landmark_ids         (m,)              every landmark of the data set
        landmarks            (k, 3)            id, x, y of the landmarks with a surveyed position (k may be 0)
        ground_truth         (n_poses, 4)      time, x, y, heading, or None

    Odometry row k ends at pose k + 1; a reading is taken at a pose (the module docstring has the conventions and
    the checks)."""

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
    time_origin: str = "given"  # where the pose times [s] come from: 'file', 'generated' or 'given' (gp/clock.py)
    dead_reckoning: NDArray = field(init=False, repr=False)  # (n_poses, 4): the odometry composed from ``start_pose``

    def __post_init__(self) -> None:
        check_time_origin(self.time_origin)
        for name in ("poses", "odometry", "odometry_covariance", *READING_TABLES, "landmarks"):
            object.__setattr__(self, name, frozen_table(name, getattr(self, name), LANDMARK_COLUMNS[name]))
        if self.ground_truth is not None:
            object.__setattr__(
                self, "ground_truth", frozen_table("ground_truth", self.ground_truth, LANDMARK_COLUMNS["ground_truth"])
            )
        self._check_poses()
        self._check_landmark_ids()
        for name in READING_TABLES:
            self._check_readings(name)
        self._check_ranges_agree()
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
        """(n_poses,) pose times in seconds (from ``time_origin``), a read-only view of ``poses[:, 0]``."""
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
                f"pose times must increase strictly: poses row {k} has t={number_text(t[k])} after t={number_text(t[k - 1])} at row {k - 1}"
            )
        check_integer_ids("poses", self.poses[:, 1], 1)
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
                f"odometry row {k} has t={number_text(self.odometry[k, 0])} but pose {k + 1} has t={number_text(t[k + 1])}: "
                f"odometry row k must end at pose k+1"
            )
        covariances = self.odometry_covariance[:, _UPPER]
        eigen = np.linalg.eigvalsh(covariances) if n > 1 else np.ones((0, 3))
        bad = np.flatnonzero(eigen[:, 0] <= 0)
        if bad.size:
            k = int(bad[0])
            raise DataError(
                f"odometry_covariance row {k} ({', '.join(number_text(v) for v in self.odometry_covariance[k])}) "
                f"is not positive definite (smallest eigenvalue {number_text(eigen[k, 0])})"
            )
        if self.ground_truth is not None:
            gt = self.ground_truth
            if len(gt) != n:
                raise DataError(f"ground_truth has {len(gt)} rows but poses has {n}")
            off = np.flatnonzero(np.abs(gt[:, 0] - t) > _TIME_TOL)
            if off.size:
                k = int(off[0])
                raise DataError(
                    f"ground_truth row {k} has t={number_text(gt[k, 0])} but pose {k} has t={number_text(t[k])}"
                )

    def _check_landmark_ids(self) -> None:
        check_integer_ids("landmarks", self.landmarks[:, 0], 0)
        if self.landmark_ids is None:
            read = [getattr(self, name)[:, 1] for name in READING_TABLES]
            ids = np.unique(np.concatenate([*read, self.landmarks[:, 0]]))
        else:
            ids = np.array(self.landmark_ids, dtype=float).reshape(-1)
            bad = np.argwhere(~np.isfinite(ids))
            if bad.size:
                raise DataError(f"landmark_ids[{int(bad[0, 0])}] is {ids[int(bad[0, 0])]}: every value must be finite")
            check_integer_ids("landmark_ids", ids, None)
        ids = ids.astype(int)
        ids.setflags(write=False)
        object.__setattr__(self, "landmark_ids", ids)
        missing = rows_of(ids.astype(float), self.landmarks[:, 0])[1]
        if missing is not None:
            raise DataError(
                f"landmarks row {missing} surveys landmark id {self.landmarks[missing, 0]:g}, "
                f"which is not in landmark_ids ({ids_text(ids.astype(float))})"
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
                f"{name} times must not go back: {name} row {k} has t={number_text(t[k])} after t={number_text(t[k - 1])} at row {k - 1}"
            )
        pose = self.reading_poses(name)
        off = np.flatnonzero(np.abs(self.times[pose] - t) > _TIME_TOL)
        if off.size:
            k = int(off[0])
            raise DataError(
                f"{name} row {k} has t={number_text(t[k])}, which is no pose's time (the nearest, pose {int(pose[k])}, "
                f"has t={number_text(self.times[pose[k]])}): a reading is taken at a pose"
            )
        ids = table[:, 1]
        frac = np.flatnonzero(ids != np.round(ids))
        if frac.size:
            k = int(frac[0])
            raise DataError(f"{name}[{k}, 1] (landmark id) = {number_text(ids[k])} is not an integer")
        known = np.zeros(0) if self.landmark_ids is None else self.landmark_ids.astype(float)
        missing = rows_of(known, ids)[1]
        if missing is not None:
            raise DataError(
                f"{name} row {missing} (t={number_text(t[missing])}) names landmark id {ids[missing]:g}, "
                f"which is not in landmark_ids ({ids_text(known)})"
            )
        for c in _SIGMAS[name]:
            bad = np.flatnonzero(table[:, c] <= 0)
            if bad.size:
                k = int(bad[0])
                raise DataError(f"{name}[{k}, {c}] ({columns[c]}) = {number_text(table[k, c])}: a sigma must be > 0")
        if "range" in columns:
            c = columns.index("range")
            bad = np.flatnonzero(table[:, c] < 0)
            if bad.size:
                k = int(bad[0])
                raise DataError(
                    f"{name}[{k}, {c}] (range) = {number_text(table[k, c])} at t={number_text(t[k])} is negative: a range is a distance"
                )
        for c, sc in _VALUE_SIGMA[name]:  # a value whose float64 spacing exceeds its sigma holds no reading
            spacing = np.spacing(np.abs(table[:, c]))
            bad = np.flatnonzero(spacing > table[:, sc])
            if bad.size:
                k = int(bad[0])
                raise DataError(
                    f"{name}[{k}, {c}] ({columns[c]}) = {number_text(table[k, c])} at t={number_text(t[k])}: float64 numbers there "
                    f"are {spacing[k]:.3g} apart, more than its sigma {number_text(table[k, sc])}, so no sensor gives it"
                )

    def _check_ranges_agree(self) -> None:
        """Two ranges to one landmark differ by at most the distance the robot moved between them (the
        triangle inequality), which is at most the odometry's path length between the two poses. Slack:
        :data:`RANGE_SLACK_SIGMAS` times the two ranges' sigmas plus the odometry's translation sigmas
        summed along the path. A reading that breaks it with more of the others than not is named (or
        both, when two contradict each other alone): no sensor gives it, or it is another landmark."""
        rows = [(n, c, sc) for n, c, sc in (("ranges", 2, 3), ("bearing_ranges", 3, 5)) if len(getattr(self, n))]
        if not rows:
            return
        cov = self.odometry_covariance
        along = np.concatenate([[0.0], np.cumsum(np.hypot(self.odometry[:, 1], self.odometry[:, 2]))])
        slack = np.concatenate([[0.0], np.cumsum(np.sqrt(cov[:, 0] + cov[:, 3]))])
        table = np.concatenate([np.repeat(i, len(getattr(self, n))) for i, (n, _, _) in enumerate(rows)])
        row = np.concatenate([np.arange(len(getattr(self, n))) for n, _, _ in rows])
        pose = np.concatenate([self.reading_poses(n) for n, _, _ in rows])
        lid = np.concatenate([getattr(self, n)[:, 1] for n, _, _ in rows])
        r = np.concatenate([getattr(self, n)[:, c] for n, c, _ in rows])
        sigma = np.concatenate([getattr(self, n)[:, sc] for n, _, sc in rows])
        order = np.argsort(lid, kind="stable")
        starts = np.flatnonzero(np.diff(lid[order], prepend=np.nan) != 0)
        for group in np.split(order, starts[1:]):
            p = pose[group]
            if len(group) < 2 or _ranges_agree(along[p] + RANGE_SLACK_SIGMAS * slack[p], r[group], sigma[group]):
                continue  # each pair checked in O(m): the pairs below only where one may break the rule
            moved = np.abs(along[p][:, None] - along[p][None, :])
            allowed = moved + RANGE_SLACK_SIGMAS * (
                sigma[group][:, None] + sigma[group][None, :] + np.abs(slack[p][:, None] - slack[p][None, :])
            )
            excess = np.abs(r[group][:, None] - r[group][None, :]) - allowed
            counts = (excess > 0).sum(axis=1)
            if not counts.any():
                continue
            worst = int(np.argmax(counts))
            other = int(np.argmax(excess[worst]))
            alone = counts[worst] == counts[other] and counts[worst] * 2 <= len(group)
            a, b = group[worst], group[other]
            what = [f"{rows[table[k]][0]}[{row[k]}, {rows[table[k]][1]}] (range) = {number_text(r[k])}" for k in (a, b)]
            raise DataError(
                f"{'one of ' + what[0] + ' and ' + what[1] if alone else what[0]} cannot be right: landmark "
                f"{lid[a]:g} is {number_text(r[a])} m away at t={number_text(self.times[pose[a]])} and {number_text(r[b])} m at "
                f"t={number_text(self.times[pose[b]])}, but the odometry moved {moved[worst, other]:.4g} m in between "
                f"(allowed with {RANGE_SLACK_SIGMAS:g} sigmas of slack: {allowed[worst, other]:.4g} m)"
                + ("" if alone else f"; it contradicts {counts[worst]} of the other {len(group) - 1} ranges to it")
            )


def _ranges_agree(a: NDArray, r: NDArray, sigma: NDArray) -> bool:
    """True when no two ranges r to one landmark break :meth:`LandmarkDataset._check_ranges_agree`'s rule, in O(m):
    with a = along + K slack at each reading's pose (K = RANGE_SLACK_SIGMAS; both sums never decrease along the
    path), the rule for readings i before j is abs(r_j - r_i) ≤ (a_j - a_i) + K σ_i + K σ_j, that is
    r_j - a_j - K σ_j ≤ r_i - a_i + K σ_i and r_i + a_i - K σ_i ≤ r_j + a_j + K σ_j: each reading against the
    running minimum (maximum) of the readings before it. A margin of 1e-9 of the numbers' scale leaves a pair the
    rounding could decide to the exact pairwise check."""
    i = np.argsort(a, kind="stable")
    a, r, k_sigma = a[i], r[i], RANGE_SLACK_SIGMAS * sigma[i]
    margin = 1e-9 * (1.0 + np.abs(r).max() + np.abs(a).max() + k_sigma.max())
    below = np.minimum.accumulate(r - a + k_sigma)[:-1]  # min over i < j of r_i - a_i + K σ_i
    above = np.maximum.accumulate(r + a - k_sigma)[:-1]  # max over i < j of r_i + a_i - K σ_i
    return bool(np.all((r - a - k_sigma)[1:] <= below - margin) and np.all((r + a + k_sigma)[1:] >= above + margin))


def check_integer_ids(name: str, ids: ArrayLike, column: int | None) -> None:
    """Integer and unique ids; DataError naming ``name[row, column]`` (or ``name[row]``) otherwise."""
    ids = np.asarray(ids, dtype=float)
    where = (lambda k: f"{name}[{k}, {column}]") if column is not None else (lambda k: f"{name}[{k}]")
    frac = np.flatnonzero(ids != np.round(ids))
    if frac.size:
        k = int(frac[0])
        raise DataError(f"{where(k)} (id) = {number_text(ids[k])} is not an integer")
    order = np.argsort(ids, kind="stable")
    same = np.flatnonzero(np.diff(ids[order]) == 0)
    if same.size:
        r1, r2 = int(order[same[0]]), int(order[same[0] + 1])
        raise DataError(f"id {ids[r1]:g} appears twice in {name}, rows {r1} and {r2}")
