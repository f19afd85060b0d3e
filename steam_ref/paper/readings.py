"""A data set's readings in the solver's terms.  [YIB Sec. IV]

The parameters of a run (:class:`~steam_ref.paper.presets.PaperSetup`) live in
:mod:`steam_ref.paper.presets`.

:class:`Readings` turns a :class:`~steam_ref.datasets.RangeDataset` into the measurement stream the
front end consumes: pose i is ground-truth row i, odometry row k is a projected-velocity reading of pose
k + 1 (its distance and heading change over the model's time step), and each range reading is attached
to a pose by :func:`attach_ranges`. A :class:`~steam_ref.datasets.LandmarkDataset` (Victoria Park): its
odometry [dx, dy, dθ] / dt is the projected velocity of the pose it ends at, and its readings (ranges,
bearings, bearing-ranges, each with its own sigma) are taken at their poses.

Time: the readings carry the data set's pose times in seconds and the model's time of each pose, related
by one :class:`~steam_ref.gp.clock.Clock` built from the set-up's choice (``PaperSetup.clock``): the CMU
presets' 'pose-index' (dt = 1 per pose, as the scripts) or the data's 'seconds'.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from ..arguments import instance, is_integer
from ..datasets import LandmarkDataset, RangeDataset
from ..errors import DataError, SteamError
from ..gp.clock import Clock
from .presets import RANGE_ATTACHMENTS, SETUP_HOW, PaperSetup

__all__ = [
    "Readings",
    "Sightings",
    "attach_ranges",
    "range_correction",
    "RANGE_CORRECTION_SLOPES",
]


def attach_ranges(pose_times: NDArray, range_times: NDArray, rule: str = "file-order") -> NDArray:
    """The pose each range reading belongs to: (n_ranges,) int, in the rows' order.

    'file-order' is the paper's scripts: a scan that walks the readings in file order and, at pose i,
    takes every next reading stamped at or before tᵢ (``while t >= TD(k,1)``). A reading whose time
    stamp goes back (Plaza's file does so twice) is taken at the pose the scan has reached, later
    than its own time. 'time' attaches every reading to the first pose at or after its time stamp.
    A reading earlier than the first pose, or later than the last, raises :class:`DataError`: the
    trajectory has no state there to attach it to.
    """
    pose_times, range_times = np.asarray(pose_times, float), np.asarray(range_times, float)
    if rule == "time":
        pose = np.searchsorted(pose_times, range_times, side="left")
    elif rule == "file-order":
        # The scan's pose is the first pose at or after the running maximum of the time stamps.
        pose = (
            np.searchsorted(pose_times, np.maximum.accumulate(range_times), side="left")
            if len(range_times)
            else np.zeros(0, int)
        )
    else:
        raise SteamError(f"unknown range attachment rule {rule!r}; use one of {RANGE_ATTACHMENTS}")
    early = np.flatnonzero(range_times < pose_times[0]) if len(pose_times) else np.zeros(0, int)
    if early.size:
        k = int(early[0])
        raise DataError(
            f"range row {k} at t={float(range_times[k])!r} is before the first pose (t={float(pose_times[0])!r}): "
            "no pose to attach it to"
        )
    late = np.flatnonzero(pose >= len(pose_times))
    if late.size:
        k = int(late[0])
        raise DataError(
            f"range row {k} at t={float(range_times[k])!r} is after the last pose (t={float(pose_times[-1])!r}): no pose to attach it to"
        )
    return pose.astype(int)


RANGE_CORRECTION_SLOPES = (0.5, 2.0)  # a fitted slope a outside this is refused (see range_correction)


def range_correction(data: RangeDataset, n_steps: int) -> tuple[float, float]:
    """(a, b) of the affine range correction r' = a r + b, fitted as ``range_measure_fit.m`` does.

    The readings are walked in file order with a pose index that only moves forward over the first
    ``n_steps`` ground-truth rows; each is paired with the nearer in time of the two poses around
    its time stamp, and the walk stops at the first reading later than pose ``n_steps - 1``. Then
    a, b solve min Σ (a r + b - ‖p - ℓ‖)² over the pairs (p the paired ground-truth position).

    The fit is plain least squares, as the script's (``A \\ b``), so one wild reading moves it: a
    single 1e6 m range in Plaza's window turns the slope negative and every corrected range into
    about 3.5 m. The script has no check (its file had the outliers thrown away); here the fit is
    checked, not made robust (that would change the paper's correction on the clean file): a
    slope outside :data:`RANGE_CORRECTION_SLOPES` = [0.5, 2], a fit that is not finite, or
    readings that cannot fix a slope (fewer than 2, or all equal) raise :class:`DataError` naming
    the fit (slope, offset, number of readings) and the reading farthest from its true range.
    Plaza's clean file fits a = 0.935, b = -0.016 m over 3,000 poses. The bound is wide on
    purpose: least squares of true on measured ranges pulls the slope below 1 by
    var(true) / (var(true) + σ²) (0.66 for 0.3 m of noise on ranges spread over 2-5 m), and a
    slope of 0.5 already halves every range's distance from the mean.
    """
    t_pose, t_range = data.times[:n_steps], data.ranges[:, 0]
    poses, rows, p = [], [], 0
    for k, t in enumerate(t_range):
        while p < len(t_pose) and t_pose[p] < t:
            p += 1
        if p == len(t_pose):
            break
        nearer = p - 1 if p > 0 and abs(t_pose[p - 1] - t) <= abs(t_pose[p] - t) else p
        poses.append(nearer)
        rows.append(k)
    where = f"range correction over the first {n_steps} poses"
    if len(rows) < 2:
        raise DataError(f"{where} needs at least 2 readings in its window, got {len(rows)}")
    kept = np.array(rows)
    marks = data.landmarks[data.landmark_rows(data.ranges[kept, 2]), 1:3]
    true = np.hypot(*(data.ground_truth[poses, 1:3] - marks).T)
    measured = data.ranges[rows, 3]
    if np.ptp(measured) == 0:
        raise DataError(f"{where}: all {len(rows)} readings are {float(measured[0])!r} m, which cannot fix a slope")
    M = np.column_stack([measured, np.ones(len(rows))])
    (a, b), *_ = np.linalg.lstsq(M, true, rcond=None)
    lo, hi = RANGE_CORRECTION_SLOPES
    if not (np.isfinite(a) and np.isfinite(b) and lo <= a <= hi):
        k = int(np.argmax(np.abs(measured - true)))
        raise DataError(
            f"{where}: the least-squares fit r' = a r + b has slope a = {float(a)!r}, offset b = {float(b)!r} over {len(rows)} "
            f"readings; a slope outside [{lo:g}, {hi:g}] means the readings do not match the ground truth (an outlier, "
            f"or too little spread against their noise); the farthest is ranges row {int(rows[k])}, {float(measured[k])!r} m "
            f"against {float(true[k])!r} m. Without a correction (range_correction_steps=0, as the synthetic preset) "
            f"the ranges are used as they are"
        )
    return float(a), float(b)


@dataclass(frozen=True)
class Sightings:
    """Landmark readings of one kind (bearings, or bearing-ranges) by pose, each with its own sigmas."""

    pose: NDArray  # (n,) the pose each reading is taken at, non-decreasing
    landmark: NDArray  # (n,) landmark id
    value: NDArray  # (n, d): [bearing] or [bearing, range] (rad, m)
    sigma: NDArray  # (n, d) their sigmas

    @classmethod
    def empty(cls, d: int) -> Sightings:
        """No readings of size d."""
        return cls(np.zeros(0, int), np.zeros(0, int), np.zeros((0, d)), np.ones((0, d)))

    def rows(self, n_poses: int) -> NDArray:
        """(n_poses + 1,) bounds: the readings of pose i are rows ``bounds[i]:bounds[i + 1]``."""
        return np.searchsorted(self.pose, np.arange(n_poses + 1), side="left")

    def take(self, rows: NDArray) -> Sightings:
        """The readings in ``rows``."""
        return Sightings(self.pose[rows], self.landmark[rows], self.value[rows], self.sigma[rows])


@dataclass(frozen=True)
class Readings:
    """The measurement stream of a data set, in solver terms; ``clock`` relates its seconds to the model's time.

    Ranges are listed in the order the front end meets them: by pose, and at one pose in the
    order of the file (or of time, with the 'time' attachment rule). A pose releases its ranges,
    then its bearings, then its bearing-ranges.
    """

    clock: Clock  # pose i's time: clock.seconds[i] on the data's clock, clock.model[i] on the GP prior's
    velocity: NDArray  # (n_poses, 3) projected velocity reading of pose i, per model time unit; row 0 unused (NaN)
    range_pose: NDArray  # (n_ranges,) pose each range belongs to, non-decreasing
    range_landmark: NDArray  # (n_ranges,) landmark id
    range_value: NDArray  # (n_ranges,) range [m], corrected if the set-up says so
    range_correction: tuple[float, float]  # (a, b) of r' = a r + b; (1, 0) when not corrected
    first_pose: NDArray  # (3,) pose 0 [x, y, θ]: ground truth, or the origin of a data set without it
    landmarks: dict[int, NDArray]  # id → surveyed position (2,), in the data set's row order
    range_sigma: NDArray  # (n_ranges,) each range's sigma: a CMU set's are all the set-up's range_sigma
    bearings: Sightings = field(default_factory=lambda: Sightings.empty(1))  # bearings [rad]
    bearing_ranges: Sightings = field(default_factory=lambda: Sightings.empty(2))  # [bearing rad, range m]

    @classmethod
    def from_dataset(cls, data: RangeDataset | LandmarkDataset, setup: PaperSetup) -> Readings:
        """Convert a data set following the paper's scripts (see the module docstring)."""
        instance("setup", setup, PaperSetup, SETUP_HOW)
        if isinstance(data, LandmarkDataset):
            return cls._from_landmark_dataset(data, setup)
        if not isinstance(data, RangeDataset):
            raise SteamError(f"expected a RangeDataset or LandmarkDataset, got {type(data).__name__}")
        n, clock = data.n_poses, Clock.of(data.times, setup.clock, data.time_origin)
        dt = np.diff(clock.model)  # 1 on the scripts' pose-index clock
        velocity = np.full((n, 3), np.nan)
        velocity[1:, 0] = data.odometry[:, 1] / dt  # distance / dt
        velocity[1:, 1] = 0.0  # no lateral motion
        velocity[1:, 2] = data.odometry[:, 2] / dt  # heading change / dt
        t = data.ranges[:, 0]
        pose = attach_ranges(data.times, t, setup.range_attachment)
        order = np.lexsort((t, pose)) if setup.range_attachment == "time" else np.arange(len(pose))
        a, b = range_correction(data, setup.range_correction_steps) if setup.range_correction_steps > 0 else (1.0, 0.0)
        value = (
            a * data.ranges[order, 3] + b if setup.range_correction_steps > 0 else data.ranges[order, 3].astype(float)
        )
        negative = np.flatnonzero(value < 0)
        if negative.size:
            k = int(order[negative[0]])
            raise DataError(
                f"ranges row {k}: {float(data.ranges[k, 3])!r} m corrected to {a!r} r + {b!r} = "
                f"{float(value[negative[0]])!r} m, a negative range ({negative.size} in all)"
            )
        coarse = np.flatnonzero(np.spacing(np.abs(value)) > setup.range_sigma)
        if coarse.size:  # float64 cannot resolve it to its sigma: no sensor gives it
            k = int(order[coarse[0]])
            raise DataError(
                f"ranges row {k}: {float(data.ranges[k, 3])!r} m: float64 numbers there are "
                f"{float(np.spacing(abs(value[coarse[0]]))):.3g} apart, more than the range sigma {setup.range_sigma!r} m"
            )
        marks = {int(i): np.array([x, y]) for i, x, y in data.landmarks}
        return cls(
            clock,
            velocity,
            pose[order],
            data.ranges[order, 2].astype(int),
            value,
            (a, b),
            data.ground_truth[0, 1:4].copy(),
            marks,
            np.full(len(value), float(setup.range_sigma)),  # a CMU file gives no sigma: the set-up's, for every range
        )

    @classmethod
    def _from_landmark_dataset(cls, data: LandmarkDataset, setup: PaperSetup) -> Readings:
        """A :class:`LandmarkDataset`: its times, odometry / dt as projected velocity, readings at their poses."""
        if setup.range_correction_steps > 0:
            raise SteamError(
                f"the set-up {setup.name!r} fits a range correction on ground truth (range_correction_steps="
                f"{setup.range_correction_steps}); {data.name!r} is not a CMU range data set: set it to 0"
            )
        clock = Clock.of(data.times, setup.clock, data.time_origin)
        velocity = np.full((data.n_poses, 3), np.nan)
        velocity[1:] = data.odometry[:, 1:4] / np.diff(clock.model)[:, None]
        r, b, br = data.ranges, data.bearings, data.bearing_ranges
        return cls(
            clock,
            velocity,
            data.reading_poses("ranges"),
            r[:, 1].astype(int),
            r[:, 2].copy(),
            (1.0, 0.0),
            data.start_pose,
            {int(i): np.array([x, y]) for i, x, y in data.landmarks},
            r[:, 3].copy(),
            Sightings(data.reading_poses("bearings"), b[:, 1].astype(int), b[:, 2:3].copy(), b[:, 3:4].copy()),
            Sightings(data.reading_poses("bearing_ranges"), br[:, 1].astype(int), br[:, 2:4].copy(), br[:, 4:6].copy()),
        )

    @property
    def times(self) -> NDArray:
        """(n_poses,) pose times in seconds, on the data's clock (a lag, a query, a written file use these)."""
        return self.clock.seconds

    @property
    def model_times(self) -> NDArray:
        """(n_poses,) pose times on the model's clock: what the GP prior sees (``clock.model``)."""
        return self.clock.model

    @property
    def n_poses(self) -> int:
        """Number of poses (time steps + 1)."""
        return self.clock.n_poses

    @property
    def n_landmark_readings(self) -> int:
        """Ranges, bearings and bearing-ranges."""
        return len(self.range_pose) + len(self.bearings.pose) + len(self.bearing_ranges.pose)

    def prefix(self, n_poses: int) -> Readings:
        """The stream of the first ``n_poses`` poses: their odometry and the readings taken at them."""
        if not is_integer(n_poses) or not 2 <= n_poses <= self.n_poses:
            raise SteamError(f"a prefix has 2 to {self.n_poses} poses, got {n_poses!r}")
        ranges = self.range_pose < n_poses
        return replace(
            self,
            clock=self.clock.prefix(n_poses),
            velocity=self.velocity[:n_poses],
            range_pose=self.range_pose[ranges],
            range_landmark=self.range_landmark[ranges],
            range_value=self.range_value[ranges],
            range_sigma=self.range_sigma[ranges],
            bearings=self.bearings.take(self.bearings.pose < n_poses),
            bearing_ranges=self.bearing_ranges.take(self.bearing_ranges.pose < n_poses),
        )

    def range_rows(self) -> NDArray:
        """(n_poses + 1,) bounds: the ranges of pose i are rows ``bounds[i]:bounds[i + 1]``."""
        return np.searchsorted(self.range_pose, np.arange(self.n_poses + 1), side="left")
