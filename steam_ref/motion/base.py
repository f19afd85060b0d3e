"""The protocol every motion prior implements: :class:`MotionPrior`.  [YIB Sec. II-A, II-B]

A motion prior is the GP x(t) ~ GP(μ(t), K(t, t')) that links a trajectory's states [YIB Eq. 1, 3, 14]. What
differs between priors (which numbers a state holds and how it moves, the factor between two states, the state
at a time between them and after the last one, what a velocity or pose reading becomes on such a state, the
first state's prior, a new state's first value, how a task is drawn from the model) is owned by one object. The
front end, :class:`~steam_ref.trajectory.Trajectory`, the samplers, the consistency study and the command line
ask it, and never test which prior they hold; a new prior is a new subclass (docs/architecture.md, "Add a
motion prior").

Conventions shared by every prior (docs/api.md, "Choose a motion prior"): a state is a flat 1-D array. On the
plane its first three numbers are the pose [x, y, θ] in the world frame and the next three its velocity, in the frame
the prior says (the world frame's [ẋ, ẏ, θ̇] for a vector-space prior, the body twist [vx, vy, ω] on SE(2)); on any
group it is the group's element, then its body twist (and the twist's rate: ``GroupState(group, 2)``), so on SE(3)
[t; φ; ϖ]. A covariance of a state is that of its tangent under the prior's ``kind``
(:class:`~steam_ref.manifold.Manifold`).
Times are on the prior's clock (the model's times of :class:`~steam_ref.gp.clock.Clock`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arguments import finite, real_array
from ..errors import ShapeError, SteamError
from ..factors import Factor, InterpolatedFactor, check_factors
from ..factors.lie_prior import LieAccelInterpolatedFactor
from ..factors.lie_readings import LieInterpolatedFactor, PoseReading
from ..manifold import Manifold
from ..variables import Key

__all__ = ["MotionPrior", "reading_inside", "is_interpolated", "sigma_blocks", "readings_at"]

_INTERPOLATED = (InterpolatedFactor, LieInterpolatedFactor, LieAccelInterpolatedFactor)
_WRAPPERS = (*_INTERPOLATED, PoseReading)  # the factors a prior wraps a reading in


class MotionPrior(ABC):
    """One motion prior: everything that differs between priors (module docstring).

    Every instance sets ``name`` (what a user calls it: 'wnoa', 'wnoj', 'singer', 'se2', 'se3-wnoj', ...), ``kind`` (how a
    state moves under a solver), ``state_dim`` (numbers in a state), ``qc`` (the (d, d) power spectral density
    of the white noise that drives it [YIB Eq. 14]) and ``state_names`` (a name for each number of a state, as
    files write them). The methods come in five groups: its factors, the state at any time, a new state's
    value, evaluation, and drawing a task from the model.
    """

    name: str
    kind: Manifold
    state_dim: int
    qc: NDArray
    state_names: tuple[str, ...]

    # --- its factors ------------------------------------------------------------------------------

    @abstractmethod
    def prior_factor(self, a: Key, b: Key, dt: float) -> Factor:
        """The prior factor between the state ``a`` and the state ``b`` ``dt`` > 0 later.  [YIB Eq. 22]"""

    @abstractmethod
    def interpolated_factor(self, inner: Factor, a: Key, b: Key, ta: float, tb: float, tau: float) -> Factor:
        """``inner`` (a reading of the state at ``tau``, its first key standing for that state) moved onto the
        states ``a`` at ``ta`` and ``b`` at ``tb``, ta < tau < tb.  [YIB Eq. 29]"""

    def interpolated_factors(
        self, inners: Sequence[Factor], a: Key, b: Key, ta: float, tb: float, taus: ArrayLike
    ) -> list[Factor]:
        """:meth:`interpolated_factor` of each of ``inners`` at its time in ``taus`` (n,), all between the same two
        states: the same factors, which a prior may form in one call (``LieGroupWnoa``: every Λ(τ), Ψ(τ) at once).
        [YIB Eq. 29]"""
        inners, taus = readings_at("inners", inners, taus)
        return [self.interpolated_factor(f, a, b, ta, tb, t) for f, t in zip(inners, taus, strict=True)]

    @abstractmethod
    def velocity_reading(self, key: Key, measured: NDArray, sigmas: NDArray) -> Factor:
        """A reading [forward, lateral, yaw rate] of the robot's velocity in its own frame, on state ``key``."""

    @abstractmethod
    def pose_reading(self, reading: Factor) -> Factor:
        """``reading`` (a range, bearing or bearing-range factor made with ``state_dim=self.state_dim``: it reads
        [x, y, θ] from the front of the state) as a factor on this prior's state."""

    @abstractmethod
    def first_state_prior(self, key: Key, pose: NDArray, velocity: NDArray, sigmas: Sequence[ArrayLike]) -> Factor:
        """The prior on the first state: its pose at ``pose`` [x, y, θ], its velocity at ``velocity`` (in the
        frame the state holds it), any higher derivative at zero; ``sigmas`` the sigmas of each block in order (pose,
        velocity, acceleration, ...; 3 numbers a block on the plane, the group's dim on a group), at least as many
        blocks as the state has."""

    # --- the state at any time ----------------------------------------------------------------------

    @abstractmethod
    def interpolate(self, ta: float, xa: NDArray, tb: float, xb: NDArray, t: float) -> NDArray:
        """The posterior mean of x(t), ta < t < tb, from the states' estimates xa and xb.  [YIB Eq. 18]"""

    @abstractmethod
    def interpolate_covariance(
        self, ta: float, xa: NDArray, tb: float, xb: NDArray, t: float, joint: NDArray
    ) -> NDArray:
        """The covariance of x(t), ta < t < tb, from the joint covariance (2n, 2n) of the two states."""

    @abstractmethod
    def extrapolate(self, t1: float, x1: NDArray, t: float) -> NDArray:
        """The prior's prediction of x(t) after the last state x1 at t1 < t.  [YIB Eq. 22]"""

    @abstractmethod
    def extrapolate_covariance(self, t1: float, x1: NDArray, t: float, cov1: NDArray) -> NDArray:
        """The covariance of the prediction x(t), t > t1, from the last state's covariance ``cov1``."""

    # --- a new state's value ------------------------------------------------------------------------

    @abstractmethod
    def initial_state(self, pose: NDArray, world_velocity: NDArray, dt: float) -> NDArray:
        """A new state's first value from a pose [x, y, θ] and the world-frame velocity [ẋ, ẏ, θ̇] of the
        backward difference over the step ``dt`` just made (a front end's guess; higher derivatives zero)."""

    # --- evaluation -------------------------------------------------------------------------------------

    @abstractmethod
    def world_states(self, states: NDArray) -> NDArray:
        """(n, 6) [x, y, θ, ẋ, ẏ, θ̇] of states (n, state_dim): each pose and its velocity in the world frame."""

    @abstractmethod
    def errors(self, states: NDArray, truth: NDArray) -> NDArray:
        """(n, 6) errors of the estimated ``states`` (n, state_dim) against ``truth`` (n, 6, as
        :meth:`world_states` gives it), in the coordinates of the states' covariance: pose error, velocity error."""

    @abstractmethod
    def body_velocity(self, states: NDArray) -> NDArray:
        """(n, 3) what a velocity reading (:meth:`velocity_reading`) measures on each state, noise-free."""

    # --- drawing a task from the model -------------------------------------------------------------

    @abstractmethod
    def sample_states(
        self, rng: np.random.Generator, n: int, dt: float, velocity: NDArray, sigmas: Sequence[ArrayLike]
    ) -> NDArray:
        """(n, state_dim) states drawn from the model, ``dt`` apart: the first from the first state's prior
        (pose about the origin, velocity about ``velocity``, each block's ``sigmas`` as :meth:`first_state_prior`
        reads them), each next one by the prior's exact transition and noise [YIB Eq. 22]."""

    # --- shared -------------------------------------------------------------------------------------------

    def check_state(self, name: str, x: ArrayLike) -> NDArray:
        """``x`` as a float array of finite states of this prior: one, (state_dim,), or a stack (..., state_dim) where
        the method broadcasts (a group prior's mean); ShapeError naming ``name`` and the shape otherwise. What every
        method taking a state checks it with, before any matrix meets it."""
        x = real_array(name, x)
        if x.ndim == 0 or x.shape[-1] != self.state_dim:
            raise ShapeError(
                f"{name} must be a state of the {self.name} prior ({self.state_dim} numbers), got shape {x.shape}"
            )
        return finite(name, x)

    def predict(self, x: NDArray, dt: float) -> NDArray:
        """The prior's mean ``dt`` > 0 after the state ``x``: a new state's starting value.  [YIB Eq. 14, 22]"""
        return self.extrapolate(0.0, x, dt)

    def __repr__(self) -> str:
        return f"<motion prior {self.name}: states of {self.state_dim} numbers, kind {self.kind!r}>"


def readings_at(name: str, inners: object, taus: object) -> tuple[list[Factor], NDArray]:
    """``inners`` as a list of factors (:func:`~steam_ref.factors.check_factors`) and ``taus`` as a float array of one
    finite time each, what :meth:`MotionPrior.interpolated_factors` takes; SteamError naming what does not fit."""
    factors, times = check_factors(name, inners), finite("taus", real_array("taus", taus))
    if times.shape != (len(factors),):
        raise ShapeError(f"taus must hold one time per reading of {name} ({len(factors)}), got shape {times.shape}")
    return factors, times


def sigma_blocks(name: str, sigmas: Sequence[ArrayLike] | NDArray, blocks: int, size: int = 3) -> list[NDArray]:
    """The first ``blocks`` of ``sigmas`` (pose, velocity, acceleration, ...; a sequence, or an array of one block a
    row) as (size,) float arrays (3 on a plane; a group's tangent dim on a group), each numbers only
    (:func:`~steam_ref.arguments.real_array`)."""
    if isinstance(sigmas, np.ndarray) and sigmas.ndim == 2:
        sigmas = list(sigmas)
    if isinstance(sigmas, (str, bytes)) or not isinstance(sigmas, Sequence) or len(sigmas) < blocks:
        raise SteamError(
            f"{name} must be a sequence of at least {blocks} blocks of {size} sigmas (pose, velocity, ...), "
            f"got {sigmas!r:.80}"
        )
    out = [real_array(f"{name}[{k}]", s) for k, s in enumerate(sigmas[:blocks])]
    for k, s in enumerate(out):
        if s.shape != (size,) or not np.all(np.isfinite(s)) or np.any(s <= 0):
            raise SteamError(f"{name}[{k}] must be {size} finite numbers > 0, got {s.tolist()!r}")
    return out


def reading_inside(factor: Factor) -> Factor:
    """The reading a factor holds through every wrapper a motion prior puts it in (an interpolated factor of any
    prior, a pose reading on a Lie group): a range, bearing, bearing-range or velocity factor."""
    while isinstance(factor, _WRAPPERS):
        factor = factor.inner
    return factor


def is_interpolated(factor: Factor) -> bool:
    """True when ``factor`` is a reading at a time between two states, moved onto them (of any prior)."""
    return isinstance(factor, _INTERPOLATED)
