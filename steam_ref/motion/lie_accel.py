"""A prior with an acceleration on a Lie group (WNOJ, Singer's model) through exact local variables: one class for any group.

:class:`LieGroupAccelPrior` is written once against the :class:`~steam_ref.lie.LieGroup` protocol and the
vector-space LTI model of its local variables (a :class:`~steam_ref.gp.LinearSDE` of three blocks: ``.wnoj``,
white noise on jerk, Tang, Yoon & Barfoot 2019 and STEAM's ``const_acc``; ``.singer``, Singer's model): the same
code for both, each with its own Φ, Q (no branch on the model). A state is x = [T; ϖ; ϖ̇] (``GroupState(group, 2)``),
a pose, its body twist and the twist's rate, retracted on the right. Between two states the local variable
ξ(t) = Log(T₁⁻¹ T(t)) and its first two derivatives, exact (``lie.gp_accel``; derivations §14), follow the model
with Qc (dim, dim) read as the PSD of the body-frame jerk. The covariance at a time between two states is
J P Jᵀ + N Q_cond Nᵀ with Q_cond the local GP's conditional covariance in information form: positive semidefinite by
construction, also where a dimension is unobserved. What the protocol says in planar terms (a dead-reckoned
pose, a world-frame velocity) and evaluation read the pose and twist at the front of the state through the WNOA
prior on the same group (:class:`~steam_ref.motion.lie_group.LieGroupWnoa`), which says it once.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arguments import number
from ..errors import DataError, ShapeError, SteamError
from ..factors import Factor
from ..factors.lie_prior import LieAccelInterpolatedFactor, LieAccelPriorFactor, LieStatePrior
from ..factors.lie_readings import BodyVelocityFactor, PoseReading, check_pose_reading
from ..factors.measured import measured_vector
from ..gp.interpolate import conditional_covariance, interpolation_terms
from ..gp.sde import LinearSDE, check_sde
from ..lie import GroupState, LieGroup, gp_accel
from ..lie.group import check_group
from ..variables import Key
from .base import MotionPrior, sigma_blocks
from .lie_group import LieGroupWnoa

__all__ = ["LieGroupAccelPrior"]


class LieGroupAccelPrior(MotionPrior):
    """A three-block LTI model ``sde`` (its states [p; ṗ; p̈] of the group's dim) on the states of ``group``
    (module docstring); ``name`` what a user calls it. Build it with :meth:`wnoj` or :meth:`singer`."""

    def __init__(self, group: LieGroup, sde: LinearSDE, name: str):
        self.group = check_group(group)
        self.sde = check_sde(sde)
        d = group.dim
        if self.sde.n != 3 * d:
            raise ShapeError(
                f"qc must be ({d}, {d}) on the body jerk of a state on {group!r} (a model of {3 * d} numbers), got a "
                f"model of {self.sde.n} numbers (qc of shape {self.sde.qc.shape})"
            )
        self.kind = GroupState(group, 2)
        self.name = name
        self.qc = self.sde.qc
        self.state_dim = self.kind.size
        self._front = LieGroupWnoa(group, self.qc)  # the pose and twist at the front of a state
        self.state_names = group.state_names() + tuple(f"accel{i}" for i in range(d))

    @classmethod
    def wnoj(cls, group: LieGroup, qc: ArrayLike) -> LieGroupAccelPrior:
        """White noise on jerk on ``group`` [TYB19]: the local variables follow ``LinearSDE.wnoj(qc)``."""
        return cls(group, LinearSDE.wnoj(qc), f"{check_group(group).name}-wnoj")

    @classmethod
    def singer(cls, group: LieGroup, qc: ArrayLike, time_constant: float = 1.0) -> LieGroupAccelPrior:
        """Singer's model on ``group``: the local variables follow ``LinearSDE.singer(qc, time_constant)``."""
        return cls(group, LinearSDE.singer(qc, time_constant=time_constant), f"{check_group(group).name}-singer")

    # --- its factors ------------------------------------------------------------------------------

    def prior_factor(self, a: Key, b: Key, dt: float) -> Factor:
        return LieAccelPriorFactor.create(a, b, dt, self.sde, group=self.group)  # [DER 14.1, 14.4]

    def interpolated_factor(self, inner: Factor, a: Key, b: Key, ta: float, tb: float, tau: float) -> Factor:
        return LieAccelInterpolatedFactor.create(inner, a, b, ta, tb, tau, self.sde, group=self.group)  # [DER 14.5]

    def velocity_reading(self, key: Key, measured: NDArray, sigmas: NDArray) -> Factor:
        return BodyVelocityFactor.create(key, measured, sigmas, group=self.group, derivatives=2)  # e = ϖ - z

    def pose_reading(self, reading: Factor) -> Factor:
        reading = check_pose_reading(reading, self.state_dim)
        return PoseReading(
            reading.keys, reading.sqrt_information, inner=reading, loss=reading.loss, group=self.group, derivatives=2
        )

    def first_state_prior(self, key: Key, pose: NDArray, velocity: NDArray, sigmas: Sequence[ArrayLike]) -> Factor:
        """Pose at the group's element of ``pose``, twist at ``velocity``, acceleration at zero; the sigmas (three
        blocks of dim numbers) read in the tangent at that mean."""
        pose, velocity = measured_vector(pose, 3, "pose"), measured_vector(velocity, self.group.dim, "velocity")
        mean = np.concatenate([self.group.from_planar(pose), velocity, np.zeros(self.group.dim)])
        blocks = sigma_blocks("sigmas", sigmas, 3, self.group.dim)
        return LieStatePrior.create(key, mean, np.concatenate(blocks), group=self.group, derivatives=2)

    # --- the state at any time ----------------------------------------------------------------------

    def interpolate(self, ta: float, xa: NDArray, tb: float, xb: NDArray, t: float) -> NDArray:
        xa, xb = self.check_state("xa", xa), self.check_state("xb", xb)
        lam, psi, offset = interpolation_terms(self.sde, ta, tb, t)  # [YIB Eq. 16, 23]
        return np.asarray(gp_accel.interpolate(xa, xb, lam, psi, offset, group=self.group, jacobians=False))

    def interpolate_covariance(
        self, ta: float, xa: NDArray, tb: float, xb: NDArray, t: float, joint: NDArray
    ) -> NDArray:
        lam, psi, offset = interpolation_terms(self.sde, ta, tb, t)  # checks ta < t < tb
        ta, tb, t = float(ta), float(tb), float(t)
        q_cond = conditional_covariance(
            self.sde.process_noise(t - ta), self.sde.transition(tb - t), self.sde.process_noise(tb - t)
        )  # [DER 14.6]
        xa, xb = self.check_state("xa", xa), self.check_state("xb", xb)
        return gp_accel.interpolate_covariance(xa, xb, lam, psi, offset, q_cond, joint, group=self.group)[1]

    def _ahead(self, t1: float, t: float) -> float:
        t1, t = number("t1", t1), number("t", t)
        if not t > t1:
            raise SteamError(f"extrapolation needs a finite t > t1, got t1={t1}, t={t}")
        return t - t1

    def extrapolate(self, t1: float, x1: NDArray, t: float) -> NDArray:
        """From γ(t) = Φ(t - t₁) [0; ϖ₁; ϖ̇₁] + v: along the arc the twist and acceleration draw.  [YIB Eq. 22]"""
        s = self._ahead(t1, t)
        x1 = self.check_state("x1", x1)
        return gp_accel.extrapolate(x1, self.sde.transition(s), self.sde.input_integral(s), group=self.group)[0]

    def extrapolate_covariance(self, t1: float, x1: NDArray, t: float, cov1: NDArray) -> NDArray:
        s = self._ahead(t1, t)
        x1 = self.check_state("x1", x1)
        return gp_accel.extrapolate_covariance(
            x1, self.sde.transition(s), self.sde.input_integral(s), self.sde.process_noise(s), cov1, group=self.group
        )[1]  # [YIB Eq. 17, 22; DER 14.6]

    # --- a new state's value ------------------------------------------------------------------------

    def initial_state(self, pose: NDArray, world_velocity: NDArray, dt: float) -> NDArray:
        """The WNOA prior's (the group's element, the body twist of the backward difference), acceleration zero."""
        return np.concatenate([self._front.initial_state(pose, world_velocity, dt), np.zeros(self.group.dim)])

    # --- evaluation -------------------------------------------------------------------------------------

    def _front_of(self, states: NDArray) -> NDArray:
        return np.asarray(states, dtype=float)[:, : self._front.state_dim]

    def world_states(self, states: NDArray) -> NDArray:
        return self._front.world_states(self._front_of(states))

    def errors(self, states: NDArray, truth: NDArray) -> NDArray:
        """The pose and twist errors (the first 2 dim numbers of the tangent), as the WNOA prior's."""
        return self._front.errors(self._front_of(states), truth)

    def body_velocity(self, states: NDArray) -> NDArray:
        return self._front.body_velocity(self._front_of(states))

    # --- drawing a task from the model -------------------------------------------------------------

    def sample_states(
        self, rng: np.random.Generator, n: int, dt: float, velocity: NDArray, sigmas: Sequence[ArrayLike]
    ) -> NDArray:
        """T₀ = Exp(n₀), ϖ₀ ~ N(velocity, σ₁²), ϖ̇₀ ~ N(0, σ₂²); each step γ₂ = Φ(dt) γ₁ + v + w, w ~ N(0, Q(dt)), in
        the local variables of the state before it, mapped back exactly (``gp_accel.from_local``): the prior's
        residual at the truth is w. A step whose turn reaches π is refused (DataError naming it)."""
        g, d = self.group, self.group.dim
        pose_sigmas, twist_sigmas, accel_sigmas = sigma_blocks("sigmas", sigmas, 3, d)
        phi, offset = self.sde.transition(dt), self.sde.input_integral(dt)
        chol = np.linalg.cholesky(self.sde.process_noise(dt))
        states = np.empty((n, self.state_dim))
        states[0] = np.concatenate(
            [
                g.exp(pose_sigmas * rng.standard_normal(d)),
                velocity + twist_sigmas * rng.standard_normal(d),
                accel_sigmas * rng.standard_normal(d),
            ]
        )
        noise = rng.standard_normal((n - 1, 3 * d)) @ chol.T
        for k in range(1, n):
            gamma = phi @ gp_accel.local_start(states[k - 1], g) + offset + noise[k - 1]  # [YIB Eq. 22]
            if not g.angle(gamma[:d]) < np.pi:
                raise DataError(
                    f"step {k} turned {float(g.angle(gamma[:d]))!r} rad, outside (-π, π): no residual reads it"
                )
            states[k] = gp_accel.from_local(states[k - 1], gamma, g, jacobians=False)
        return states
