"""RangeDataset: a 2-D range-only SLAM data set in the CMU layout, and its checks.  [YIB Sec. IV]

Every source ends up as a :class:`RangeDataset` in the CMU range-only layout (one row per record; the table of
columns is the class's docstring, what ``help(steam_ref.RangeDataset)`` shows).

Conventions, checked on the reference files (see ``data/README.md`` for the figures):

- Odometry row k ends at pose k + 1: its time stamp equals that of ground-truth row k + 1, and it
  holds the distance travelled and the heading change from pose k to pose k + 1. Both CMU .mat
  files (paper-synthetic and Plaza, cleaned or original) follow this exactly; a file that does
  not is rejected with a :class:`DataError`, never re-aligned.
- Which pose a range reading belongs to is the front end's rule, not the data set's
  (:func:`steam_ref.paper.readings.attach_ranges`).
- Range rows are kept in the order given, even where their time goes back
  (:meth:`RangeDataset.ranges_going_back` names those rows).

Times are in seconds; ``time_origin`` says where they come from: a file's stamps ('file'), a generator's
('generated'), or the caller's arrays ('given'). The clock the GP prior runs on is the set-up's choice
(:mod:`steam_ref.gp.clock`), not the data set's.

Errors: a table of the wrong shape raises :class:`ShapeError`; bad content (NaN or inf, fewer than
two poses, pose times not increasing, unknown landmark ids, a negative range) raises
:class:`DataError`. Rows are 0-based in ``array[row, column]`` messages.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import DataError, ShapeError, SteamError
from ..gp.clock import TIME_ORIGINS

__all__ = ["RangeDataset", "check_time_origin", "MAX_EXACT"]

_TIME_TOL = 1e-6  # [s] odometry row k and pose k + 1 must agree to this
MAX_EXACT = (
    2**53
)  # the largest integer a float64 table holds exactly, with every integer below it (ids read as numbers)
CMU_COLUMNS = {  # field -> (CMU array name, column names)
    "ground_truth": ("GT", ("time", "x", "y", "heading")),
    "odometry": ("DR", ("time", "distance", "heading change")),
    "dead_reckoning": ("DRp", ("time", "x", "y", "heading")),
    "landmarks": ("TL", ("id", "x", "y")),
    "ranges": ("TD", ("time", "sender id", "landmark id", "range")),
}


def number_text(value: float) -> str:
    """A number for an error message, every digit kept (repr of the float)."""
    return repr(float(value))


@dataclass(frozen=True, eq=False)
class RangeDataset:
    """A 2-D range-only SLAM data set in the CMU layout; arrays are read-only float64 copies. One row per record
    (seconds, metres, radians)::

        ground_truth    GT   (n_poses, 4)      time, x, y, heading
        odometry        DR   (n_poses - 1, 3)  time, distance travelled, heading change
        dead_reckoning  DRp  (n_poses, 4)      time, x, y, heading
        landmarks       TL   (n_landmarks, 3)  id, x, y
        ranges          TD   (n_ranges, 4)     time, sender id, landmark id, range

    Odometry row k ends at pose k + 1 (the module docstring has the conventions).

    Checked on construction: table shapes (ShapeError); finite values, at least two poses (one
    odometry step), strictly increasing pose times (in ground truth and in dead reckoning),
    odometry row k stamped with the time of pose k + 1 (to 1 µs), one dead-reckoning row per
    pose, integer and unique landmark ids, integer sender ids, every ranged landmark id present
    in ``landmarks``, and no negative range (DataError). Dead-reckoning times are not compared
    with pose times: Plaza's DRp row 0 is stamped 0.0226 s after GT row 0 (and Plaza2's 0.0106 s,
    more than its shortest step).
    """

    name: str  # short label, e.g. "plaza"
    ground_truth: NDArray = field(repr=False)  # (n_poses, 4): time [s], x [m], y [m], heading [rad]
    odometry: NDArray = field(repr=False)  # (n_poses - 1, 3): time, distance [m], heading change [rad]
    dead_reckoning: NDArray = field(repr=False)  # (n_poses, 4): time, x, y, heading
    landmarks: NDArray = field(repr=False)  # (n_landmarks, 3): id, x, y
    ranges: NDArray = field(repr=False)  # (n_ranges, 4): time, sender id, landmark id, range [m]
    source: str = ""  # a path, or "generated(seed=...)", plus notes on any rework
    time_origin: str = "given"  # where the pose times [s] come from: 'file', 'generated' or 'given' (gp/clock.py)

    def __post_init__(self) -> None:
        check_time_origin(self.time_origin)
        for name, (_, columns) in CMU_COLUMNS.items():
            object.__setattr__(self, name, frozen_table(name, getattr(self, name), columns))
        self._check_times()
        self._check_ids()
        self._check_ranges()

    def __repr__(self) -> str:
        return (
            f"RangeDataset(name={self.name!r}, n_poses={self.n_poses}, n_landmarks={self.n_landmarks}, "
            f"n_ranges={self.n_ranges}, source={self.source!r}, time_origin={self.time_origin!r})"
        )

    @property
    def n_poses(self) -> int:
        return self.ground_truth.shape[0]

    @property
    def n_landmarks(self) -> int:
        return self.landmarks.shape[0]

    @property
    def n_ranges(self) -> int:
        return self.ranges.shape[0]

    @property
    def landmark_ids(self) -> NDArray:
        """(n_landmarks,) int ids, in the row order of ``landmarks`` (not necessarily sorted)."""
        return self.landmarks[:, 0].astype(int)

    @property
    def times(self) -> NDArray:
        """(n_poses,) pose times in seconds (from ``time_origin``), a read-only view of ``ground_truth[:, 0]``."""
        return self.ground_truth[:, 0]

    def landmark_rows(self, ids: ArrayLike) -> NDArray:
        """(n,) row of ``landmarks`` holding each id; DataError naming the first unknown id."""
        ids = np.asarray(ids, dtype=float).ravel()
        rows, missing = rows_of(self.landmarks[:, 0], ids)
        if missing is not None:
            raise DataError(
                f"landmark id {ids[missing]:g} (entry {missing}) is not in landmarks; "
                f"known ids: {ids_text(self.landmarks[:, 0])}"
            )
        return rows

    def ranges_going_back(self) -> NDArray:
        """(k,) rows of ``ranges`` whose time is earlier than the row before's (kept in file order)."""
        return np.flatnonzero(np.diff(self.ranges[:, 0]) < 0) + 1

    def to_cmu_arrays(self) -> dict[str, NDArray]:
        """Writable copies under the CMU names GT, DR, DRp, TL, TD (for ``scipy.io.savemat``)."""
        return {cmu: np.array(getattr(self, name)) for name, (cmu, _) in CMU_COLUMNS.items()}

    def _check_times(self) -> None:
        t, n = self.times, self.n_poses
        if n < 2:
            raise DataError(f"ground_truth has {n} row(s): a data set needs at least two poses (one odometry step)")
        for name, rows in (("odometry", n - 1), ("dead_reckoning", n)):
            if getattr(self, name).shape[0] != rows:
                raise DataError(
                    f"{name} has {getattr(self, name).shape[0]} rows but ground_truth has {n} poses: expected {rows}"
                )
        for name, times in (("ground_truth", t), ("dead_reckoning", self.dead_reckoning[:, 0])):
            bad = np.flatnonzero(np.diff(times) <= 0)
            if bad.size:
                k = int(bad[0]) + 1
                raise DataError(
                    f"pose times must increase strictly: {name} row {k} has t={number_text(times[k])} "
                    f"after t={number_text(times[k - 1])} at row {k - 1}"
                )
        off = np.flatnonzero(np.abs(self.odometry[:, 0] - t[1:]) > _TIME_TOL)
        if off.size:
            k = int(off[0])
            raise DataError(
                f"odometry row {k} has t={number_text(self.odometry[k, 0])} but pose {k + 1} has "
                f"t={number_text(t[k + 1])}: odometry row k must end at pose k+1"
            )

    def _check_ids(self) -> None:
        for name, column in (("landmarks", 0), ("ranges", 1), ("ranges", 2)):
            values = getattr(self, name)[:, column]
            bad = np.flatnonzero(values != np.round(values))
            if bad.size:
                k = int(bad[0])
                label = CMU_COLUMNS[name][1][column]
                raise DataError(f"{name}[{k}, {column}] ({label}) = {number_text(values[k])} is not an integer")
        ids = self.landmarks[:, 0]
        order = np.argsort(ids, kind="stable")
        same = np.flatnonzero(np.diff(ids[order]) == 0)
        if same.size:
            r1, r2 = int(order[same[0]]), int(order[same[0] + 1])
            raise DataError(f"landmark id {ids[r1]:g} appears twice, in landmarks rows {r1} and {r2}")
        missing = rows_of(ids, self.ranges[:, 2])[1]
        if missing is not None:
            raise DataError(
                f"ranges row {missing} (t={number_text(self.ranges[missing, 0])}) names landmark id "
                f"{self.ranges[missing, 2]:g}, which is not in landmarks; known ids: {ids_text(ids)}"
            )

    def _check_ranges(self) -> None:
        negative = np.flatnonzero(self.ranges[:, 3] < 0)
        if negative.size:
            k = int(negative[0])
            raise DataError(
                f"ranges[{k}, 3] (range) = {number_text(self.ranges[k, 3])} at t={number_text(self.ranges[k, 0])} is negative: "
                f"a range is a distance ({negative.size} negative range(s) in all)"
            )


def check_time_origin(origin: object) -> str:
    """``origin`` if it is one of TIME_ORIGINS ('file', 'generated', 'given'); else SteamError naming it."""
    if not isinstance(origin, str) or origin not in TIME_ORIGINS:
        raise SteamError(
            f"time_origin must be one of {', '.join(TIME_ORIGINS)} (where the pose times come from), got {origin!r}"
        )
    return origin


def rows_of(known: NDArray, ids: NDArray) -> tuple[NDArray, int | None]:
    """Row of ``known`` holding each of ``ids``, and the index of the first id not there (or None)."""
    order = np.argsort(known, kind="stable")
    pos = np.minimum(np.searchsorted(known[order], ids), max(len(known) - 1, 0))
    found = known[order][pos] == ids if len(known) else np.zeros(len(ids), bool)
    missing = np.flatnonzero(~found)
    return order[pos] if len(known) else pos, (int(missing[0]) if missing.size else None)


def ids_text(ids: NDArray) -> str:
    """Ids for an error message: all of them up to 12, else how many and their range."""
    ids = np.sort(ids)
    if len(ids) <= 12:
        return "[" + ", ".join(f"{i:g}" for i in ids) + "]"
    return f"{len(ids)} ids from {ids[0]:g} to {ids[-1]:g}"


def frozen_table(name: str, value: ArrayLike, columns: tuple[str, ...]) -> NDArray:
    """A read-only float64 copy of one table, checked for shape (ShapeError) and finiteness (DataError)."""
    try:
        table = np.array(value, dtype=float)
    except (TypeError, ValueError) as err:
        raise ShapeError(f"{name} must be a numeric array, got {type(value).__name__}: {err}") from None
    if table.size == 0:
        table = table.reshape(0, len(columns))
    if table.ndim != 2 or table.shape[1] != len(columns):
        raise ShapeError(
            f"{name} must have shape (n, {len(columns)}) with columns {', '.join(columns)}; got shape {table.shape}"
        )
    bad = np.argwhere(~np.isfinite(table))
    if bad.size:
        r, c = (int(i) for i in bad[0])
        raise DataError(f"{name}[{r}, {c}] ({columns[c]}) is {table[r, c]}: every value must be finite")
    table.setflags(write=False)
    return table
