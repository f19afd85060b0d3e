"""The vector-space prior of any linear time-invariant SDE: the paper's WNOA, WNOJ, Singer's model, any (A, F, Qc, v).

The state is x = [p; ṗ; ...] with p = [x, y, θ] in the world frame (its velocity [ẋ, ẏ, θ̇] in the world frame
too); it moves by + (:data:`~steam_ref.manifold.VECTOR`). Everything is [YIB Eq. 14-23] for the SDE
ẋ = A x + v + F w: the prior factor e = xᵢ - Φ xᵢ₋₁ - vᵢ (:class:`~steam_ref.factors.GPPriorFactor`), the
interpolated state Λ(τ) x₁ + Ψ(τ) x₂ (+ the input's part) and its covariance, the prediction Φ x + v
after the last state (:mod:`steam_ref.gp.interpolate`). Built from Qc alone it is the paper's WNOA prior
and keeps its memoised closed forms (``gp.prior``, ``gp.interpolate.interpolation_matrices``): the runs it
gives are those of the paper's code path, bit for bit. A reading of the velocity is the projected velocity
[YIB Eq. 32] (:class:`~steam_ref.factors.VelocityFactor`); a range, bearing or bearing-range reads the pose from
the front of the state as it is.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arguments import time_step
from ..dead_reckoning import wrap_angle
from ..errors import SteamError
from ..factors import Factor, GPPriorFactor, InterpolatedFactor, PriorFactor, VelocityFactor
from ..factors.lie_readings import check_pose_reading
from ..factors.measured import measured_vector
from ..gp.interpolate import (
    extrapolate_covariance_sde,
    extrapolate_state_sde,
    interpolate_covariance,
    interpolate_covariance_sde,
    interpolate_state,
    interpolate_state_sde,
)
from ..gp.sde import LinearSDE, check_prior
from ..manifold import VECTOR
from ..variables import Key
from .base import MotionPrior, sigma_blocks

__all__ = ["VectorPrior"]

_DERIVATIVES = ("", "dot", "ddot")  # x, xdot, xddot: the names files give the blocks of a planar state


class VectorPrior(MotionPrior):
    """The prior of an LTI SDE on vector states (module docstring). ``prior``: Qc (d, d) of the paper's WNOA
    prior (its memoised closed forms) or any :class:`~steam_ref.gp.LinearSDE`; ``name``: what a user calls it."""

    kind = VECTOR

    def __init__(self, prior: ArrayLike | LinearSDE, name: str | None = None):
        checked = check_prior(prior)
        self._qc_only = None if isinstance(checked, LinearSDE) else checked  # WNOA from Qc: the closed forms
        self.sde = checked if isinstance(checked, LinearSDE) else LinearSDE.wnoa(checked)
        self.qc = self.sde.qc
        self.state_dim = self.sde.n
        model = self.sde.model
        self.name = name if name is not None else "lti" if model is None else model.name
        d = self.qc.shape[0]
        coordinates = ("x", "y", "theta") if d == 3 else tuple(f"p{i}" for i in range(d))
        blocks = range(self.state_dim // d)
        self.state_names = tuple(c + (_DERIVATIVES[k] if k < 3 else f"d{k}") for k in blocks for c in coordinates)

    @classmethod
    def wnoa(cls, qc: ArrayLike) -> VectorPrior:
        """The paper's white-noise-on-acceleration prior, states [p; ṗ].  [YIB Eq. 30-31]"""
        return cls(qc, "wnoa")

    @classmethod
    def wnoj(cls, qc: ArrayLike) -> VectorPrior:
        """White noise on jerk, states [p; ṗ; p̈] (``LinearSDE.wnoj``)."""
        return cls(LinearSDE.wnoj(qc), "wnoj")

    @classmethod
    def singer(cls, qc: ArrayLike, time_constant: float = 1.0) -> VectorPrior:
        """Singer's model with the acceleration's time constant 1/α, states [p; ṗ; p̈] (``LinearSDE.singer``)."""
        return cls(LinearSDE.singer(qc, time_constant=time_constant), "singer")

    @property
    def _argument(self) -> NDArray | LinearSDE:
        """What the factors take: Qc (the memoised WNOA closed forms) or the SDE."""
        return self.sde if self._qc_only is None else self._qc_only

    # --- its factors ------------------------------------------------------------------------------

    def prior_factor(self, a: Key, b: Key, dt: float) -> Factor:
        if self._qc_only is not None:
            return GPPriorFactor.wnoa(a, b, dt, self._qc_only)  # [YIB Eq. 22, 30-31]
        return GPPriorFactor.from_sde(a, b, dt, self.sde)  # [YIB Eq. 22-23]

    def interpolated_factor(self, inner: Factor, a: Key, b: Key, ta: float, tb: float, tau: float) -> Factor:
        return InterpolatedFactor.create(inner, a, b, ta, tb, tau, self._argument)  # [YIB Eq. 29]

    def velocity_reading(self, key: Key, measured: NDArray, sigmas: NDArray) -> Factor:
        return VelocityFactor.create(key, measured, sigmas, state_dim=self.state_dim)  # [YIB Eq. 32]

    def pose_reading(self, reading: Factor) -> Factor:
        return check_pose_reading(reading, self.state_dim)  # it reads [x, y, θ] from the front of the state as it is

    def first_state_prior(self, key: Key, pose: NDArray, velocity: NDArray, sigmas: Sequence[ArrayLike]) -> Factor:
        blocks = self.state_dim // 3
        pose, velocity = measured_vector(pose, 3, "pose"), measured_vector(velocity, 3, "velocity")
        mean = np.concatenate([pose, velocity, np.zeros(self.state_dim - 6)])
        return PriorFactor.create(key, mean, np.concatenate(sigma_blocks("sigmas", sigmas, blocks)))  # [YIB Eq. 3, 5]

    # --- the state at any time ----------------------------------------------------------------------

    def interpolate(self, ta: float, xa: NDArray, tb: float, xb: NDArray, t: float) -> NDArray:
        xa, xb = self.check_state("xa", xa), self.check_state("xb", xb)
        if self._qc_only is None:
            return interpolate_state_sde(self.sde, ta, xa, tb, xb, t)
        return interpolate_state(ta, xa, tb, xb, t, self._qc_only)  # [YIB Eq. 16, 18]

    def interpolate_covariance(
        self,
        ta: float,
        xa: NDArray,
        tb: float,
        xb: NDArray,
        t: float,
        joint: NDArray,
    ) -> NDArray:
        self.check_state("xa", xa), self.check_state("xb", xb)  # a linear prior's covariance reads neither
        if self._qc_only is None:
            return interpolate_covariance_sde(self.sde, ta, tb, t, joint)
        return interpolate_covariance(ta, tb, t, self._qc_only, joint)

    def extrapolate(self, t1: float, x1: NDArray, t: float) -> NDArray:
        return extrapolate_state_sde(self.sde, t1, self.check_state("x1", x1), t)  # [YIB Eq. 22-23]

    def extrapolate_covariance(self, t1: float, x1: NDArray, t: float, cov1: NDArray) -> NDArray:
        self.check_state("x1", x1)  # a linear prior's covariance does not read it
        return extrapolate_covariance_sde(self.sde, t1, t, cov1)  # [YIB Eq. 17, 22]

    # --- a new state's value ------------------------------------------------------------------------

    def initial_state(self, pose: NDArray, world_velocity: NDArray, dt: float) -> NDArray:
        time_step(dt)  # the step just made, > 0 as for every prior (a vector state keeps the velocity as it is)
        pose, velocity = measured_vector(pose, 3, "pose"), measured_vector(world_velocity, 3, "world_velocity")
        return np.concatenate([pose, velocity, np.zeros(self.state_dim - 6)])

    # --- evaluation -------------------------------------------------------------------------------------

    def world_states(self, states: NDArray) -> NDArray:
        return np.array(np.asarray(states, dtype=float)[:, :6])

    def errors(self, states: NDArray, truth: NDArray) -> NDArray:
        """Pose errors with the heading wrapped to [-π, π) (a heading may differ by whole turns), velocity
        differences, both in the world frame."""
        states, truth = np.asarray(states, dtype=float), np.asarray(truth, dtype=float)
        pose = states[:, :3] - truth[:, :3]
        pose[:, 2] = wrap_angle(pose[:, 2])
        return np.hstack([pose, states[:, 3:6] - truth[:, 3:6]])

    def body_velocity(self, states: NDArray) -> NDArray:
        """[R(θ)ᵀ [ẋ, ẏ]; θ̇], the projected velocity.  [YIB Eq. 32]"""
        th, xd, yd, thd = states[:, 2], states[:, 3], states[:, 4], states[:, 5]
        c, s = np.cos(th), np.sin(th)
        return np.column_stack([c * xd + s * yd, -s * xd + c * yd, thd])

    # --- drawing a task from the model -------------------------------------------------------------

    def sample_states(
        self, rng: np.random.Generator, n: int, dt: float, velocity: NDArray, sigmas: Sequence[ArrayLike]
    ) -> NDArray:
        """x₀ = [p₀; ṗ₀; ...] with p₀ ~ N(0, σ₀²), ṗ₀ ~ N(velocity, σ₁²), higher derivatives ~ N(0, σₖ²); then
        xₖ₊₁ = Φ(dt) xₖ + v(dt) + wₖ, wₖ ~ N(0, Q(dt)), exactly.  [YIB Eq. 16-17, 22-23]"""
        blocks = sigma_blocks("sigmas", sigmas, self.state_dim // 3)
        if self.state_dim != 3 * len(blocks):
            raise SteamError(f"drawing a task needs a planar state (p of 3 numbers), got states of {self.state_dim}")
        phi, chol = self.sde.transition(dt), np.linalg.cholesky(self.sde.process_noise(dt))
        drift = self.sde.input_integral(dt)
        states = np.empty((n, self.state_dim))
        first = [blocks[0] * rng.standard_normal(3), velocity + blocks[1] * rng.standard_normal(3)]
        states[0] = np.concatenate(first + [s * rng.standard_normal(3) for s in blocks[2:]])
        noise = rng.standard_normal((n - 1, self.state_dim)) @ chol.T
        if np.any(drift):
            noise += drift  # [YIB Eq. 23]
        for k in range(1, n):
            states[k] = phi @ states[k - 1] + noise[k - 1]  # [YIB Eq. 22]
        return states
