"""The paper's set-up: every parameter of its experiments, and the semantics of the authors' scripts.  [YIB Sec. IV]

:class:`PaperSetup` holds every parameter of the paper's experiments, taken from the authors'
public scripts (``matlab/GP/synthetic_isam2.m``, ``plaza_isam2.m``, ``victoria_park_isam2.m`` and
``range_measure_fit.m`` in ``XinyanGT/online-gpslam-code``; summarised in ``shared/data/README.md``).
``PaperSetup.synthetic()``, ``.plaza()`` and ``.victoria_park()`` are the documented defaults: they do
what the scripts did. Any field can be changed with :meth:`PaperSetup.replace`; the fields that depart
from the scripts on purpose say so (:data:`DEPARTURES`), and the motion prior is chosen here
(``prior``, :meth:`PaperSetup.motion_prior`).

A set-up owns the model (noise, Qc, priors, the motion prior), the preset's schedule (:class:`Schedule`:
when the stream updates, what starts it, whether a batch solve seeds it, the updates after the last
pose; every switch explicit) and its iSAM2 settings (``isam2``: the scripts' GTSAM defaults, but with relaxed
amalgamation, :data:`PAPER_AMALGAMATION_ZEROS`). What a single run chooses on top (the
method, the state layout, a prefix, a time budget) is :class:`~steam_ref.paper.options.StreamOptions`.

A set-up also chooses the clock the GP prior runs on (``clock``, :mod:`steam_ref.gp.clock`): the data's
seconds, or the scripts' 'pose-index' (dt = 1 per pose), which the CMU presets ('synthetic', 'plaza') use
to reproduce the paper. The prior's parameters (Qc, the Singer time constant) are on that clock; every
time a user gives or reads (a lag, a query, a file's times) is on the data's, in seconds.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..arguments import integer, is_integer, number, replace_fields
from ..bayes_tree.params import ISAM2Params
from ..choices import DEPARTURES, PAPER_AMALGAMATION_ZEROS, PRESETS, SINGER_TIME_CONSTANT
from ..errors import ShapeError, SteamError
from ..gp.clock import CLOCK_BASES
from ..gp.prior import check_qc
from ..lie.gp import check_model as check_residual
from ..motion import MOTION_PRIORS, RESIDUALS, MotionPrior, motion_prior
from ..robust import Tukey

__all__ = [
    "PaperSetup",
    "SETUP_HOW",
    "Schedule",
    "RANGE_ATTACHMENTS",
    "DEPARTURES",
    "PAPER_AMALGAMATION_ZEROS",
    "PRIORS",
    "PRESETS",
    "SE2_RESIDUALS",
]

RANGE_ATTACHMENTS = ("file-order", "time")
PRIORS = tuple(MOTION_PRIORS)  # the names of steam_ref.motion.MOTION_PRIORS: wnoa, wnoj, singer (§6), se2 (§11)
SE2_RESIDUALS = RESIDUALS  # the two SE(2) WNOA residuals in circulation (derivations §11)
# PRESETS (PaperSetup.named), PAPER_AMALGAMATION_ZEROS (the presets' relaxed amalgamation, [AG89]) and DEPARTURES (the
# deliberate departures from the scripts, by name: the PaperSetup fields each one changes) are steam_ref.choices',
# where the command line's parser reads them without loading this module.


@dataclass(frozen=True)
class Schedule:
    """When a stream gives its new factors to the solver: every switch explicit.  [YIB Sec. IV: '/1', '/10']

    The new factors go to the solver at an estimated state once ``every`` landmark readings (ranges,
    bearings, bearing-ranges) have been released since the last update, and at the last pose. Nothing is
    solved before ``start_after_ranges`` landmark readings have arrived. With ``initial_batch`` the first
    update hands the solver the estimate of one batch Levenberg-Marquardt solve of everything so far
    (AMD ordering; relative and absolute tolerance ``initial_batch_tolerance``, GTSAM's
    ``LevenbergMarquardtParams`` defaults, which ``plaza_isam2.m`` uses); without it, the front end's
    initial guesses. After the last pose the solver runs ``final_updates`` more updates with no new
    factors (``synthetic_isam2.m``: 10).
    """

    every: int = 1
    start_after_ranges: int = 0
    initial_batch: bool = False
    initial_batch_tolerance: float = 1e-5
    final_updates: int = 0

    def __post_init__(self) -> None:
        integer("Schedule.every", self.every, 1)
        integer("Schedule.start_after_ranges", self.start_after_ranges, 0)
        integer("Schedule.final_updates", self.final_updates, 0)
        if not isinstance(self.initial_batch, bool):
            raise SteamError(f"Schedule.initial_batch must be True or False, got {self.initial_batch!r}")
        tolerance = number("Schedule.initial_batch_tolerance", self.initial_batch_tolerance)
        if not 0 < tolerance < 1:
            raise SteamError(
                f"Schedule.initial_batch_tolerance must be in (0, 1), got {self.initial_batch_tolerance!r}"
            )

    def replace(self, **changes) -> Schedule:
        """A copy with some fields changed; SteamError names an unknown field (:func:`~steam_ref.arguments.replace_fields`)."""
        return replace_fields(self, changes)


SETUP_HOW = "PaperSetup.synthetic(), .plaza(), .victoria_park() or PaperSetup.named(name)"  # how one is made


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
    first_pose_sigmas: NDArray = field(
        default_factory=lambda: np.array([1.0, 1.0, np.pi])
    )  # (3,) prior on pose 0 at ground truth
    first_velocity_sigmas: NDArray = field(
        default_factory=lambda: np.array([1.0, 1.0, np.pi])
    )  # (3,) prior on velocity 0
    first_velocity: NDArray = field(default_factory=lambda: np.full(3, 1e-4))  # (3,) its mean
    range_correction_steps: int = 0  # fit r' = a r + b on ranges of the first N poses; 0: none
    landmarks_up_front: bool = False  # True: every landmark and its prior enter at pose 0; else at first sighting
    range_attachment: str = "file-order"  # 'file-order': the scripts' scan; 'time': by time stamp (a departure)
    pose2_heading_rate_guess: bool = (
        True  # initial θ̇ as the scripts' Pose2 difference (±2π at the ±π crossing); False: the plain change
    )
    relinearize_blocks: tuple[int, ...] | None = (
        3,
        3,
    )  # BTGP relinearizes pose and velocity on their own (GTSAM variables P, V); None: the whole state
    prior: str = "wnoa"  # the motion prior by name (steam_ref.motion.MOTION_PRIORS): 'wnoa', 'wnoj', 'singer' or 'se2'
    # 'wnoj' / 'singer': qc is the PSD of jerk, states [p; ṗ; p̈] (9 numbers).
    # 'se2': WNOA on SE(2), states [x, y, θ, vx, vy, ω] (a pose and its body twist); qc is then the PSD of the
    # body-frame acceleration [forward, lateral, yaw] (the same numbers as the vector prior's world-frame Qc:
    # the presets' x and y entries are equal, so the PSD is the same read in any frame about the vertical)
    se2_residual: str = "local-variable"  # an option of 'se2' (MOTION_PRIORS): which SE(2) WNOA residual
    singer_time_constant: float = (
        SINGER_TIME_CONSTANT  # an option of 'singer': 1/α, on the model's clock (seconds, or pose steps)
    )
    first_acceleration_sigmas: NDArray = field(
        default_factory=lambda: np.array([1.0, 1.0, np.pi])
    )  # (3,) prior on acceleration 0 (mean 0), WNOJ and Singer
    schedule: Schedule = field(default_factory=Schedule)  # when the stream updates (the script's '/1', '/10', ...)
    isam2: ISAM2Params = field(
        default_factory=lambda: ISAM2Params(amalgamation_zeros=PAPER_AMALGAMATION_ZEROS)
    )  # BTGP's iSAM2: GTSAM's defaults but for relaxed amalgamation; blocks: relinearize_blocks
    clock: str = (
        "seconds"  # the GP prior's time (steam_ref.gp.clock): the data's 'seconds', or 'pose-index' (dt = 1 per pose)
    )

    def __post_init__(self) -> None:
        """Check every field where it enters; SteamError naming the field and the value."""
        if not isinstance(self.name, str) or not self.name:
            raise SteamError(f"PaperSetup.name must be a non-empty string, got {self.name!r}")
        qc = np.asarray(self.qc, dtype=float) if _numeric(self.qc) else None
        if qc is None or qc.shape != (3, 3):
            raise ShapeError(f"PaperSetup.qc must be a (3, 3) matrix for x, y, θ; got {_show(self.qc)}")
        object.__setattr__(self, "qc", check_qc(qc))
        for name in (
            "velocity_sigmas",
            "interpolated_velocity_sigmas",
            "first_pose_sigmas",
            "first_velocity_sigmas",
            "first_velocity",
            "first_acceleration_sigmas",
        ):
            object.__setattr__(self, name, _vector3(name, getattr(self, name), positive=name != "first_velocity"))
        for name in ("range_sigma", "landmark_prior_sigma") + (("tukey_c",) if self.tukey_c is not None else ()):
            if number(f"PaperSetup.{name}", getattr(self, name)) <= 0:
                raise SteamError(f"PaperSetup.{name} must be a finite number > 0, got {getattr(self, name)!r}")
        integer("PaperSetup.range_correction_steps", self.range_correction_steps, 0)
        if not isinstance(self.schedule, Schedule):
            raise SteamError(f"PaperSetup.schedule must be a Schedule, got {self.schedule!r}")
        if not isinstance(self.isam2, ISAM2Params):
            raise SteamError(f"PaperSetup.isam2 must be an ISAM2Params, got {self.isam2!r}")
        if self.isam2.relinearize_blocks is not None:
            raise SteamError(
                "PaperSetup.isam2.relinearize_blocks must be None: a set-up's blocks are PaperSetup.relinearize_blocks "
                f"(one owner), got {self.isam2.relinearize_blocks!r}"
            )
        for name in ("landmarks_up_front", "pose2_heading_rate_guess"):
            if not isinstance(getattr(self, name), bool):
                raise SteamError(f"PaperSetup.{name} must be True or False, got {getattr(self, name)!r}")
        if self.clock not in CLOCK_BASES:
            raise SteamError(f"PaperSetup.clock must be one of {', '.join(CLOCK_BASES)}, got {self.clock!r}")
        if self.range_attachment not in RANGE_ATTACHMENTS:
            raise SteamError(f"range_attachment must be one of {RANGE_ATTACHMENTS}, got {self.range_attachment!r}")
        blocks = self.relinearize_blocks
        if blocks is not None and not (
            isinstance(blocks, tuple) and all(is_integer(b) and b >= 1 for b in blocks) and sum(blocks) == 6
        ):
            raise SteamError(
                f"PaperSetup.relinearize_blocks must be None or a tuple of positive integers adding up to 6 "
                f"(pose and velocity; a 9-number state adds its acceleration's block), got {blocks!r}"
            )
        if self.prior not in PRIORS:
            raise SteamError(f"prior must be one of {PRIORS}, got {self.prior!r}")
        check_residual(self.se2_residual, "PaperSetup.se2_residual")  # one prior's option, always checked
        if self.tukey_c is not None:
            try:
                Tukey(self.tukey_c)  # a threshold whose square overflows is refused here, not mid-run
            except SteamError as err:
                raise SteamError(f"PaperSetup.tukey_c: {err}") from None
        self.motion_prior()  # checks Qc and the time constant, naming the bad one

    @classmethod
    def synthetic(cls) -> PaperSetup:
        """The synthetic exploration task (Sec. IV-A), as ``synthetic_isam2.m`` runs it.

        The script's GP prior steps 1 per odometry row: the clock is 'pose-index' (dt = 1 per pose; the
        file's poses are stamped 1 s apart, so it is the data's seconds shifted by the first stamp).
        """
        return cls(
            name="synthetic",
            clock="pose-index",
            qc=0.01 * np.diag([1.0, 1.0, 25.0]),
            velocity_sigmas=np.array([0.5, 0.5, 1.0]),
            interpolated_velocity_sigmas=np.array([0.5, 0.5, 1.0]),
            range_sigma=1.0,
            schedule=Schedule(final_updates=10),
        )

    @classmethod
    def plaza(cls) -> PaperSetup:
        """The Autonomous Lawnmower 'Plaza' run (Sec. IV-B), as ``plaza_isam2.m`` runs it.

        The script's GP prior steps 1 per odometry row, whatever the stamps: the clock is 'pose-index'
        (dt = 1 per pose, which on Plaza is 0.171-0.232 s, median 0.200 s, so Qc is per pose step, not
        per second). Reproducing the paper's figures needs it; a lag or a query is still in seconds.
        """
        return cls(
            name="plaza",
            clock="pose-index",
            qc=0.05 * np.diag([1.0, 1.0, 2.0]),
            velocity_sigmas=np.array([0.05, 0.01, 0.02]),
            interpolated_velocity_sigmas=np.array([0.5, 0.01, 0.02]),
            range_sigma=20.0,
            range_correction_steps=3000,
            schedule=Schedule(start_after_ranges=50, initial_batch=True),
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
            schedule=Schedule(every=10),
        )

    @classmethod
    def named(cls, name: str) -> PaperSetup:
        """The preset called 'synthetic', 'plaza' or 'victoria-park'."""
        if name not in PRESETS:
            raise SteamError(f"unknown preset {name!r}; use one of {', '.join(PRESETS)}")
        return {"synthetic": cls.synthetic, "plaza": cls.plaza, "victoria-park": cls.victoria_park}[name]()

    def replace(self, **changes) -> PaperSetup:
        """A copy with some fields changed; SteamError names an unknown field (:func:`~steam_ref.arguments.replace_fields`)."""
        return replace_fields(self, changes)

    def with_schedule(self, **changes) -> PaperSetup:
        """A copy whose schedule has some fields changed (``setup.with_schedule(every=10)``)."""
        return self.replace(schedule=self.schedule.replace(**changes))

    def with_isam2(self, **changes) -> PaperSetup:
        """A copy whose iSAM2 settings have some fields changed (``setup.with_isam2(relinearize_skip=1)``)."""
        return self.replace(isam2=self.isam2.replace(**changes))

    def motion_prior(self) -> MotionPrior:
        """The motion prior of the states (:mod:`steam_ref.motion`): ``prior`` by its name in
        :data:`~steam_ref.motion.MOTION_PRIORS`, with ``qc`` and the options that prior takes (``singer_time_constant``,
        ``se2_residual``). Everything that differs between priors is asked of it."""
        return motion_prior(self.prior, self.qc, **self.prior_options())

    def prior_options(self) -> dict[str, object]:
        """The fields of this set-up that its prior takes beside Qc, by name (a run's report names them)."""
        return {name: getattr(self, name) for name in MOTION_PRIORS[self.prior].options}

    def isam2_params(self) -> ISAM2Params:
        """BTGP's iSAM2 settings for this set-up: ``isam2`` with the state's relinearization blocks.

        ``relinearize_blocks`` (3, 3) is pose and velocity on their own; a 9-number state adds its acceleration.
        """
        blocks, size = self.relinearize_blocks, self.motion_prior().state_dim
        if blocks is not None and sum(blocks) < size:
            blocks = tuple(blocks) + (3,) * ((size - sum(blocks)) // 3)
        return self.isam2.replace(relinearize_blocks=None if blocks is None else {"x": blocks})

    def departing(self, *names: str) -> PaperSetup:
        """A copy with the named departures from the scripts (:data:`DEPARTURES`) applied."""
        changes: dict[str, object] = {}
        for name in names:
            if not isinstance(name, str) or name not in DEPARTURES:
                raise SteamError(f"unknown departure {name!r}; use one of {', '.join(DEPARTURES)}")
            changes.update(DEPARTURES[name])
        return self.replace(**changes)

    @property
    def range_loss(self) -> Tukey | None:
        """The robust loss on ranges."""
        return None if self.tukey_c is None else Tukey(self.tukey_c)


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
        raise SteamError(
            f"PaperSetup.{name} must be 3 finite numbers{' > 0' if positive else ''} (x, y, θ), got {_show(value)}"
        )
    v.setflags(write=False)
    return v
