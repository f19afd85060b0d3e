"""The paper's set-up, and a data set's readings in the solver's terms.  [YIB Sec. IV]

:class:`PaperSetup` holds every parameter of the paper's experiments, taken from the authors'
public scripts (``matlab/GP/synthetic_isam2.m``, ``plaza_isam2.m``, ``victoria_park_isam2.m`` and
``range_measure_fit.m`` in ``XinyanGT/online-gpslam-code``; summarised in ``shared/data/README.md``).
``PaperSetup.synthetic()``, ``.plaza()`` and ``.victoria_park()`` are the documented defaults: they do
what the scripts did. Any field can be
changed with :meth:`PaperSetup.replace`; the fields that depart from the scripts on purpose say so.

:class:`Readings` turns a :class:`~steam_ref.datasets.RangeDataset` into the measurement stream the
front end consumes: time is the odometry row index (dt = 1), pose i is ground-truth row i, odometry
row k is a projected-velocity reading of pose k + 1, and each range reading is attached to a pose by
:func:`attach_ranges`. A :class:`~steam_ref.datasets.LandmarkDataset` (Victoria Park) keeps its own
times, its odometry [dx, dy, dθ] / dt is the projected velocity of the pose it ends at, and its
readings (ranges, bearings, bearing-ranges, each with its own sigma) are taken at their poses.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace

import numpy as np
from numpy.typing import NDArray

from .bayes_tree.params import ISAM2Params
from .datasets import LandmarkDataset, RangeDataset
from .errors import DataError, SteamError
from .gp.sde import LinearSDE
from .robust import Tukey

__all__ = ["PaperSetup", "Readings", "Sightings", "attach_ranges", "range_correction", "RANGE_ATTACHMENTS", "DEPARTURES", "PRIORS", "PRESETS"]

RANGE_ATTACHMENTS = ("file-order", "time")
PRIORS = ("wnoa", "wnoj", "singer")  # the paper's prior, and two extensions (docs/derivations.md §6)
PRESETS = ("synthetic", "plaza", "victoria-park")  # PaperSetup.named

# The deliberate departures from the scripts, by name: the PaperSetup fields each one changes
# (docs/experiments.md gives each one's measured effect on the Plaza run).
DEPARTURES = {
    "time-attachment": dict(range_attachment="time"),  # a range goes to the first pose at or after its time stamp
    "plain-heading-rate": dict(pose2_heading_rate_guess=False),  # a new state's θ̇ starts from the plain heading change
    "whole-state-relinearization": dict(relinearize_blocks=None),  # iSAM2 relinearizes the 6-vector state at once
    "landmarks-at-sighting": dict(landmarks_up_front=False),  # a landmark enters with its first range reading
}


@dataclass(frozen=True)
class PaperSetup:
    """Parameters of one of the paper's experiments; a field's default is what both scripts share."""

    name: str  # 'synthetic', 'plaza' or 'victoria-park'
    qc: NDArray  # (3, 3) power spectral density of the WNOA prior [YIB Eq. 31]
    velocity_sigmas: NDArray  # (3,) projected-velocity noise at an estimated state
    interpolated_velocity_sigmas: NDArray  # (3,) the same reading when interpolated (Eq. 29)
    range_sigma: float  # [m] of a CMU range (a LandmarkDataset's readings carry their own sigmas)
    tukey_c: float | None = 15.0  # Tukey threshold on whitened range errors (both scripts); None: plain least squares
    landmark_prior_sigma: float = 1.0  # [m] prior on landmarks at their surveyed positions (Eq. 4)
    first_pose_sigmas: NDArray = field(default_factory=lambda: np.array([1.0, 1.0, np.pi]))  # (3,) prior on pose 0 at ground truth
    first_velocity_sigmas: NDArray = field(default_factory=lambda: np.array([1.0, 1.0, np.pi]))  # (3,) prior on velocity 0
    first_velocity: NDArray = field(default_factory=lambda: np.full(3, 1e-4))  # (3,) its mean
    range_correction_steps: int = 0  # fit r' = a r + b on ranges of the first N poses; 0: none
    start_after_ranges: int = 0  # incremental solvers start after this many ranges (batch LM first)
    landmarks_up_front: bool = False  # True: every landmark and its prior enter at pose 0; else at first sighting
    range_attachment: str = "file-order"  # 'file-order': the scripts' scan; 'time': by time stamp (a departure)
    pose2_heading_rate_guess: bool = True  # initial θ̇ as the scripts' Pose2 difference (±2π at the ±π crossing); False: the plain change
    relinearize_blocks: tuple[int, ...] | None = (3, 3)  # BTGP relinearizes pose and velocity on their own (GTSAM variables P, V); None: the whole state
    final_updates: int = 0  # extra solver updates with no new factors after the last pose (synthetic script: 10)
    prior: str = "wnoa"  # motion prior: the paper's 'wnoa', or 'wnoj' / 'singer' (then qc is the PSD of jerk)
    singer_time_constant: float = 1.0  # [s] 1/α of the Singer prior
    first_acceleration_sigmas: NDArray = field(default_factory=lambda: np.array([1.0, 1.0, np.pi]))  # (3,) prior on acceleration 0 (mean 0), WNOJ and Singer
    every: int = 1  # the script's schedule: update after this many landmark readings (victoria_park_isam2.m: 10); the CLI's default --every

    def __post_init__(self) -> None:
        if self.range_attachment not in RANGE_ATTACHMENTS:
            raise SteamError(f"range_attachment must be one of {RANGE_ATTACHMENTS}, got {self.range_attachment!r}")
        if self.prior not in PRIORS:
            raise SteamError(f"prior must be one of {PRIORS}, got {self.prior!r}")
        self.motion_prior()  # checks Qc and the time constant, naming the bad one
        if isinstance(self.every, bool) or not isinstance(self.every, (int, np.integer)) or self.every < 1:
            raise SteamError(f"PaperSetup.every must be a positive integer, got {self.every!r}")

    @classmethod
    def synthetic(cls) -> PaperSetup:
        """The synthetic exploration task (Sec. IV-A), as ``synthetic_isam2.m`` runs it."""
        return cls(
            name="synthetic",
            qc=0.01 * np.diag([1.0, 1.0, 25.0]),
            velocity_sigmas=np.array([0.5, 0.5, 1.0]),
            interpolated_velocity_sigmas=np.array([0.5, 0.5, 1.0]),
            range_sigma=1.0,
            final_updates=10,
        )

    @classmethod
    def plaza(cls) -> PaperSetup:
        """The Autonomous Lawnmower 'Plaza' run (Sec. IV-B), as ``plaza_isam2.m`` runs it."""
        return cls(
            name="plaza",
            qc=0.05 * np.diag([1.0, 1.0, 2.0]),
            velocity_sigmas=np.array([0.05, 0.01, 0.02]),
            interpolated_velocity_sigmas=np.array([0.5, 0.01, 0.02]),
            range_sigma=20.0,
            range_correction_steps=3000,
            start_after_ranges=50,
            landmarks_up_front=True,
        )

    @classmethod
    def victoria_park(cls) -> PaperSetup:
        """Victoria Park (bearing-range sightings of trees), as ``victoria_park_isam2.m`` runs it.

        Odometry is a projected-velocity reading [dx, dy, dθ] / dt (dt = 1) with sigmas (0.01, 0.002,
        0.002), the file's own diagonal; the script estimates every pose, so the interpolated sigmas
        (used only with ``skip`` > 1) are the same. Pose 0 has a prior at zero, the origin of the data's
        frame, sigmas (1, 1, π); velocity 0 at 1e-4 with (0.1, 0.1, π/10). The trees are not surveyed:
        each enters at its first sighting, placed by it from the predicted pose, with no prior. A
        sighting's sigmas come from the file (GTSAM's ``load2D``); no robust loss; an update after
        every 10 sightings (BTGP/10).
        """
        return cls(
            name="victoria-park",
            qc=0.01 * np.diag([1.0, 1.0, 2.0]),
            velocity_sigmas=np.array([0.01, 0.002, 0.002]),
            interpolated_velocity_sigmas=np.array([0.01, 0.002, 0.002]),
            range_sigma=1.0,  # no ranges in the file; a LandmarkDataset's ranges carry their own sigmas anyway
            tukey_c=None,
            first_velocity_sigmas=np.array([0.1, 0.1, np.pi / 10]),
            every=10,
        )

    @classmethod
    def named(cls, name: str) -> PaperSetup:
        """The preset called 'synthetic', 'plaza' or 'victoria-park'."""
        if name not in PRESETS:
            raise SteamError(f"unknown preset {name!r}; use one of {', '.join(PRESETS)}")
        return {"synthetic": cls.synthetic, "plaza": cls.plaza, "victoria-park": cls.victoria_park}[name]()

    def replace(self, **changes) -> PaperSetup:
        """A copy with some fields changed; SteamError names an unknown field."""
        unknown = sorted(set(changes) - {f.name for f in fields(self)})
        if unknown:
            raise SteamError(f"PaperSetup has no field {unknown[0]!r}")
        return replace(self, **changes)

    def motion_prior(self) -> NDArray | LinearSDE:
        """The GP prior of the states: Qc for the paper's WNOA (its memoised closed forms), else a LinearSDE."""
        if self.prior == "wnoa":
            return self.qc
        if self.prior == "wnoj":
            return LinearSDE.wnoj(self.qc)
        return LinearSDE.singer(self.qc, time_constant=self.singer_time_constant)

    @property
    def state_dim(self) -> int:
        """Size of a state: [p; ṗ] (6) for WNOA, [p; ṗ; p̈] (9) for WNOJ and Singer."""
        return 6 if self.prior == "wnoa" else 9

    def isam2_params(self) -> ISAM2Params:
        """BTGP's iSAM2 settings for this set-up: GTSAM's defaults, with the state's relinearization blocks.

        ``relinearize_blocks`` (3, 3) is pose and velocity on their own; a 9-number state adds its acceleration.
        """
        blocks = self.relinearize_blocks
        if blocks is not None and sum(blocks) < self.state_dim:
            blocks = tuple(blocks) + (3,) * ((self.state_dim - sum(blocks)) // 3)
        return ISAM2Params(relinearize_blocks=None if blocks is None else {"x": blocks})

    def departing(self, *names: str) -> PaperSetup:
        """A copy with the named departures from the scripts (:data:`DEPARTURES`) applied."""
        changes = {}
        for name in names:
            if not isinstance(name, str) or name not in DEPARTURES:
                raise SteamError(f"unknown departure {name!r}; use one of {', '.join(DEPARTURES)}")
            changes.update(DEPARTURES[name])
        return self.replace(**changes)

    @property
    def range_loss(self) -> Tukey | None:
        """The robust loss on ranges."""
        return None if self.tukey_c is None else Tukey(self.tukey_c)


def attach_ranges(pose_times: NDArray, range_times: NDArray, rule: str = "file-order") -> NDArray:
    """The pose each range reading belongs to: (n_ranges,) int, in the rows' order.

    'file-order' is the paper's scripts: a scan that walks the readings in file order and, at pose i,
    takes every next reading stamped at or before tᵢ (``while t >= TD(k,1)``). A reading whose time
    stamp goes back (Plaza's file does so twice) is taken at the pose the scan has reached, later
    than its own time. 'time' attaches every reading to the first pose at or after its time stamp.
    A reading later than the last pose raises :class:`DataError`.
    """
    pose_times, range_times = np.asarray(pose_times, float), np.asarray(range_times, float)
    if rule == "time":
        pose = np.searchsorted(pose_times, range_times, side="left")
    elif rule == "file-order":
        # The scan's pose is the first pose at or after the running maximum of the time stamps.
        pose = np.searchsorted(pose_times, np.maximum.accumulate(range_times), side="left") if len(range_times) else np.zeros(0, int)
    else:
        raise SteamError(f"unknown range attachment rule {rule!r}; use one of {RANGE_ATTACHMENTS}")
    late = np.flatnonzero(pose >= len(pose_times))
    if late.size:
        k = int(late[0])
        raise DataError(f"range row {k} at t={float(range_times[k])!r} is after the last pose (t={float(pose_times[-1])!r}): no pose to attach it to")
    return pose.astype(int)


def range_correction(data: RangeDataset, n_steps: int) -> tuple[float, float]:
    """(a, b) of the affine range correction r' = a r + b, fitted as ``range_measure_fit.m`` does.

    The readings are walked in file order with a pose index that only moves forward over the first
    ``n_steps`` ground-truth rows; each is paired with the nearer in time of the two poses around
    its time stamp, and the walk stops at the first reading later than pose ``n_steps - 1``. Then
    a, b solve min Σ (a r + b - ‖p - ℓ‖)² over the pairs (p the paired ground-truth position).
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
    if len(rows) < 2:
        raise SteamError(f"range correction needs at least 2 readings in its window of {n_steps} poses, got {len(rows)}")
    rows = np.array(rows)
    marks = data.landmarks[data.landmark_rows(data.ranges[rows, 2]), 1:3]
    true = np.hypot(*(data.ground_truth[poses, 1:3] - marks).T)
    M = np.column_stack([data.ranges[rows, 3], np.ones(len(rows))])
    (a, b), *_ = np.linalg.lstsq(M, true, rcond=None)
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
    """The measurement stream of a data set, in solver terms (time = pose index, dt = 1 for the CMU sets).

    Ranges are listed in the order the front end meets them: by pose, and at one pose in the
    order of the file (or of time, with the 'time' attachment rule). A pose releases its ranges,
    then its bearings, then its bearing-ranges.
    """

    times: NDArray  # (n_poses,) time of pose i: i
    velocity: NDArray  # (n_poses, 3) projected velocity reading of pose i; row 0 unused (NaN)
    range_pose: NDArray  # (n_ranges,) pose each range belongs to, non-decreasing
    range_landmark: NDArray  # (n_ranges,) landmark id
    range_value: NDArray  # (n_ranges,) range [m], corrected if the set-up says so
    range_correction: tuple[float, float]  # (a, b) of r' = a r + b; (1, 0) when not corrected
    first_pose: NDArray  # (3,) pose 0 [x, y, θ]: ground truth, or the origin of a data set without it
    landmarks: dict[int, NDArray]  # id → surveyed position (2,), in the data set's row order
    range_sigma: NDArray | None = None  # (n_ranges,) each range's own sigma; None: the set-up's range_sigma (CMU)
    bearings: Sightings = field(default_factory=lambda: Sightings.empty(1))  # bearings [rad]
    bearing_ranges: Sightings = field(default_factory=lambda: Sightings.empty(2))  # [bearing rad, range m]

    @classmethod
    def from_dataset(cls, data: RangeDataset | LandmarkDataset, setup: PaperSetup) -> Readings:
        """Convert a data set following the paper's scripts (see the module docstring)."""
        if isinstance(data, LandmarkDataset):
            return cls._from_landmark_dataset(data, setup)
        n = data.n_poses
        velocity = np.full((n, 3), np.nan)
        velocity[1:, 0] = data.odometry[:, 1]  # distance / dt with dt = 1
        velocity[1:, 1] = 0.0  # no lateral motion
        velocity[1:, 2] = data.odometry[:, 2]  # heading change / dt
        t = data.ranges[:, 0]
        pose = attach_ranges(data.times, t, setup.range_attachment)
        order = np.lexsort((t, pose)) if setup.range_attachment == "time" else np.arange(len(pose))
        a, b = range_correction(data, setup.range_correction_steps) if setup.range_correction_steps > 0 else (1.0, 0.0)
        value = a * data.ranges[order, 3] + b if setup.range_correction_steps > 0 else data.ranges[order, 3].astype(float)
        marks = {int(i): np.array([x, y]) for i, x, y in data.landmarks}
        return cls(
            np.arange(n, dtype=float), velocity, pose[order], data.ranges[order, 2].astype(int), value, (a, b),
            data.ground_truth[0, 1:4].copy(), marks,
        )

    @classmethod
    def _from_landmark_dataset(cls, data: LandmarkDataset, setup: PaperSetup) -> Readings:
        """A :class:`LandmarkDataset`: its times, odometry / dt as projected velocity, readings at their poses."""
        if setup.range_correction_steps > 0:
            raise SteamError(f"the set-up {setup.name!r} fits a range correction on ground truth (range_correction_steps="
                             f"{setup.range_correction_steps}); {data.name!r} is not a CMU range data set: set it to 0")
        velocity = np.full((data.n_poses, 3), np.nan)
        velocity[1:] = data.odometry[:, 1:4] / np.diff(data.times)[:, None]
        r, b, br = data.ranges, data.bearings, data.bearing_ranges
        return cls(
            data.times.copy(), velocity, data.reading_poses("ranges"), r[:, 1].astype(int), r[:, 2].copy(), (1.0, 0.0),
            data.start_pose, {int(i): np.array([x, y]) for i, x, y in data.landmarks}, r[:, 3].copy(),
            Sightings(data.reading_poses("bearings"), b[:, 1].astype(int), b[:, 2:3].copy(), b[:, 3:4].copy()),
            Sightings(data.reading_poses("bearing_ranges"), br[:, 1].astype(int), br[:, 2:4].copy(), br[:, 4:6].copy()),
        )

    @property
    def n_poses(self) -> int:
        """Number of poses (time steps + 1)."""
        return len(self.times)

    @property
    def n_landmark_readings(self) -> int:
        """Ranges, bearings and bearing-ranges."""
        return len(self.range_pose) + len(self.bearings.pose) + len(self.bearing_ranges.pose)

    def prefix(self, n_poses: int) -> Readings:
        """The stream of the first ``n_poses`` poses: their odometry and the readings taken at them."""
        if isinstance(n_poses, bool) or not isinstance(n_poses, (int, np.integer)) or not 2 <= n_poses <= self.n_poses:
            raise SteamError(f"a prefix has 2 to {self.n_poses} poses, got {n_poses!r}")
        ranges = self.range_pose < n_poses
        return replace(
            self, times=self.times[:n_poses], velocity=self.velocity[:n_poses], range_pose=self.range_pose[ranges],
            range_landmark=self.range_landmark[ranges], range_value=self.range_value[ranges],
            range_sigma=None if self.range_sigma is None else self.range_sigma[ranges],
            bearings=self.bearings.take(self.bearings.pose < n_poses),
            bearing_ranges=self.bearing_ranges.take(self.bearing_ranges.pose < n_poses),
        )

    def range_rows(self) -> NDArray:
        """(n_poses + 1,) bounds: the ranges of pose i are rows ``bounds[i]:bounds[i + 1]``."""
        return np.searchsorted(self.range_pose, np.arange(self.n_poses + 1), side="left")
