"""The paper's set-up, and a data set's readings in the solver's terms.  [YIB Sec. IV]

:class:`PaperSetup` holds every parameter of the paper's experiments, taken from the authors'
public scripts (``matlab/GP/synthetic_isam2.m``, ``plaza_isam2.m`` and ``range_measure_fit.m`` in
``XinyanGT/online-gpslam-code``; summarised in ``shared/data/README.md``). ``PaperSetup.synthetic()``
and ``PaperSetup.plaza()`` are the documented defaults: they do what the scripts did. Any field can be
changed with :meth:`PaperSetup.replace`; the fields that depart from the scripts on purpose say so.

:class:`Readings` turns a :class:`~steam_ref.datasets.RangeDataset` into the measurement stream the
front end consumes: time is the odometry row index (dt = 1), pose i is ground-truth row i, odometry
row k is a projected-velocity reading of pose k + 1, and each range reading is attached to a pose by
:func:`attach_ranges`.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field, fields, replace

import numpy as np
from numpy.typing import NDArray

from .bayes_tree.params import ISAM2Params
from .datasets import RangeDataset
from .errors import DataError, ShapeError, SteamError
from .gp.prior import check_qc
from .gp.sde import LinearSDE
from .robust import Tukey

__all__ = [
    "PaperSetup", "Readings", "attach_ranges", "range_correction", "RANGE_ATTACHMENTS", "RANGE_CORRECTION_SLOPES",
    "DEPARTURES", "PRIORS",
]

RANGE_ATTACHMENTS = ("file-order", "time")
PRIORS = ("wnoa", "wnoj", "singer")  # the paper's prior, and two extensions (docs/derivations.md §6)

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

    name: str  # 'synthetic' or 'plaza'
    qc: NDArray  # (3, 3) power spectral density of the WNOA prior [YIB Eq. 31]
    velocity_sigmas: NDArray  # (3,) projected-velocity noise at an estimated state
    interpolated_velocity_sigmas: NDArray  # (3,) the same reading when interpolated (Eq. 29)
    range_sigma: float  # [m]
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

    def __post_init__(self) -> None:
        """Check every field where it enters; SteamError naming the field and the value."""
        if not isinstance(self.name, str) or not self.name:
            raise SteamError(f"PaperSetup.name must be a non-empty string, got {self.name!r}")
        qc = np.asarray(self.qc, dtype=float) if _numeric(self.qc) else None
        if qc is None or qc.shape != (3, 3):
            raise ShapeError(f"PaperSetup.qc must be a (3, 3) matrix for x, y, θ; got {_show(self.qc)}")
        object.__setattr__(self, "qc", check_qc(qc))
        for name in ("velocity_sigmas", "interpolated_velocity_sigmas", "first_pose_sigmas", "first_velocity_sigmas", "first_velocity",
                     "first_acceleration_sigmas"):
            object.__setattr__(self, name, _vector3(name, getattr(self, name), positive=name != "first_velocity"))
        for name in ("range_sigma", "landmark_prior_sigma") + (("tukey_c",) if self.tukey_c is not None else ()):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real) or not (math.isfinite(value) and value > 0):
                raise SteamError(f"PaperSetup.{name} must be a finite number > 0, got {value!r}")
        for name in ("range_correction_steps", "start_after_ranges", "final_updates"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
                raise SteamError(f"PaperSetup.{name} must be an integer >= 0, got {value!r}")
        for name in ("landmarks_up_front", "pose2_heading_rate_guess"):
            if not isinstance(getattr(self, name), bool):
                raise SteamError(f"PaperSetup.{name} must be True or False, got {getattr(self, name)!r}")
        if self.range_attachment not in RANGE_ATTACHMENTS:
            raise SteamError(f"range_attachment must be one of {RANGE_ATTACHMENTS}, got {self.range_attachment!r}")
        blocks = self.relinearize_blocks
        if blocks is not None and not (isinstance(blocks, tuple) and all(_is_int(b) and b >= 1 for b in blocks) and sum(blocks) == 6):
            raise SteamError(f"PaperSetup.relinearize_blocks must be None or a tuple of positive integers adding up to 6 "
                             f"(pose and velocity; a 9-number state adds its acceleration's block), got {blocks!r}")
        if self.prior not in PRIORS:
            raise SteamError(f"prior must be one of {PRIORS}, got {self.prior!r}")
        self.motion_prior()  # checks Qc and the time constant, naming the bad one

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
    def named(cls, name: str) -> PaperSetup:
        """The preset called 'synthetic' or 'plaza'."""
        if name not in ("synthetic", "plaza"):
            raise SteamError(f"unknown preset {name!r}; use 'synthetic' or 'plaza'")
        return cls.synthetic() if name == "synthetic" else cls.plaza()

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


def _is_int(value: object) -> bool:
    return not isinstance(value, bool) and isinstance(value, (int, np.integer))


def _numeric(value: object) -> bool:
    """True when ``value`` converts to a float array (numbers, not strings or objects)."""
    try:
        return np.asarray(value).dtype.kind in "biuf"
    except (TypeError, ValueError):
        return False


def _show(value: object) -> str:
    """A value on one line: numbers as a (nested) list, anything else as its repr."""
    return repr(np.asarray(value).tolist()) if _numeric(value) else repr(value)


def _vector3(name: str, value: object, positive: bool) -> NDArray:
    """``value`` as a read-only float (3,), finite (and > 0 when ``positive``); else SteamError naming it."""
    v = np.array(value, dtype=float) if _numeric(value) else None
    if v is None or v.shape != (3,) or not np.all(np.isfinite(v)) or (positive and np.any(v <= 0)):
        raise SteamError(f"PaperSetup.{name} must be 3 finite numbers{' > 0' if positive else ''} (x, y, θ), got {_show(value)}")
    v.setflags(write=False)
    return v


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
    rows = np.array(rows)
    marks = data.landmarks[data.landmark_rows(data.ranges[rows, 2]), 1:3]
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
class Readings:
    """The measurement stream of a data set, in solver terms (time = pose index, dt = 1).

    Ranges are listed in the order the front end meets them: by pose, and at one pose in the
    order of the file (or of time, with the 'time' attachment rule).
    """

    times: NDArray  # (n_poses,) time of pose i: i
    velocity: NDArray  # (n_poses, 3) projected velocity reading of pose i; row 0 unused (NaN)
    range_pose: NDArray  # (n_ranges,) pose each range belongs to, non-decreasing
    range_landmark: NDArray  # (n_ranges,) landmark id
    range_value: NDArray  # (n_ranges,) range [m], corrected if the set-up says so
    range_correction: tuple[float, float]  # (a, b) of r' = a r + b; (1, 0) when not corrected
    first_pose: NDArray  # (3,) ground-truth pose 0 [x, y, θ]
    landmarks: dict[int, NDArray]  # id → surveyed position (2,), in the data set's row order

    @classmethod
    def from_dataset(cls, data: RangeDataset, setup: PaperSetup) -> Readings:
        """Convert a data set following the paper's scripts (see the module docstring)."""
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
        negative = np.flatnonzero(value < 0)
        if negative.size:
            k = int(order[negative[0]])
            raise DataError(f"ranges row {k}: {float(data.ranges[k, 3])!r} m corrected to {a!r} r + {b!r} = "
                            f"{float(value[negative[0]])!r} m, a negative range ({negative.size} in all)")
        marks = {int(i): np.array([x, y]) for i, x, y in data.landmarks}
        return cls(
            np.arange(n, dtype=float), velocity, pose[order], data.ranges[order, 2].astype(int), value, (a, b),
            data.ground_truth[0, 1:4].copy(), marks,
        )

    @property
    def n_poses(self) -> int:
        """Number of poses (time steps + 1)."""
        return len(self.times)

    def range_rows(self) -> NDArray:
        """(n_poses + 1,) bounds: the ranges of pose i are rows ``bounds[i]:bounds[i + 1]``."""
        return np.searchsorted(self.range_pose, np.arange(self.n_poses + 1), side="left")
