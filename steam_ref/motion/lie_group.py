"""White noise on acceleration on a Lie group, through local variables (Anderson & Barfoot 2015): one class for any group.

:class:`LieGroupWnoa` is written once against the :class:`~steam_ref.lie.LieGroup` protocol; the table's 'se2'
entry builds it with :data:`~steam_ref.lie.SE2`. A state is a pose T on the group and its body twist ϖ
(``GroupState(group)``; on SE(2) :data:`~steam_ref.lie.SE2_STATE`: x = [px, py, θ, vx, vy, ω], θ in (-π, π], the
twist [forward, lateral, yaw rate] in the robot's own frame, Ṫ = T ϖ^), retracted on the right: every covariance
of a state is that of its right tangent at the estimate, the pose block in the body frame. Between two states
the local variable ξ(t) = Log(T₁⁻¹ T(t)) and its rate follow the vector-space WNOA prior of [YIB Eq. 30-31] with
Qc (dim, dim) read as the PSD of the body-frame acceleration (``steam_ref.lie.gp``; derivations §11). Its two
residuals in circulation are both instances: ``residual`` "local-variable" (e = [ξ - Δt ϖ₁; J_r(ξ)⁻¹ ϖ₂ - ϖ₁]:
GTSAM 4.3, STEAM) or "simplified" (e = [ξ - Δt ϖ₁; ϖ₂ - ϖ₁]: gpslam, Theseus).

On such a state a velocity reading is the body twist itself
(:class:`~steam_ref.factors.lie_readings.BodyVelocityFactor`); a range, bearing or bearing-range keeps its
vector-space error with Jacobians in the right tangent (:class:`~steam_ref.factors.lie_readings.PoseReading`, a
planar group's); a reading between states moves onto them through the local GP
(:class:`~steam_ref.factors.lie_readings.LieInterpolatedFactor`); the first state's prior is in the tangent at its
mean (:class:`~steam_ref.factors.lie_prior.LieStatePrior`). What the MotionPrior protocol says in planar terms (a
dead-reckoned pose [x, y, θ], a world-frame velocity [ẋ, ẏ, θ̇]) goes through the group's planar methods
(``from_planar``, ``to_planar``, ``body_twist``, ``world_velocity``): a group that holds no planar pose refuses
them by name.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arguments import time_step
from ..dead_reckoning import wrap_angle
from ..errors import DataError, ShapeError
from ..factors import Factor
from ..factors.lie_prior import LiePriorFactor, LieStatePrior
from ..factors.lie_readings import BodyVelocityFactor, LieInterpolatedFactor, PoseReading, check_pose_reading
from ..factors.measured import measured_vector
from ..gp.interpolate import interpolation_matrices
from ..gp.prior import check_qc, process_noise
from ..lie import GroupState, LieGroup
from ..lie import gp as lie_gp
from ..lie.group import check_group
from ..variables import Key
from .base import MotionPrior, readings_at, sigma_blocks

__all__ = ["LieGroupWnoa", "RESIDUALS"]

RESIDUALS = lie_gp.MODELS  # 'local-variable', 'simplified'


class LieGroupWnoa(MotionPrior):
    """WNOA on the states of ``group`` with the residual ``residual`` (module docstring); ``qc`` (dim, dim) on the
    body twist (SE(2): [vx, vy, ω]). Its ``name`` is the group's, its ``kind`` ``GroupState(group)``."""

    def __init__(self, group: LieGroup, qc: ArrayLike, residual: str = "local-variable"):
        self.group = check_group(group)
        self.kind = GroupState(group)
        self.name = group.name
        self.state_dim = self.kind.size
        self.state_names = group.state_names()
        self.qc = check_qc(qc)
        d = group.dim
        if self.qc.shape != (d, d):
            raise ShapeError(
                f"qc must be ({d}, {d}) on the body twist of a state on {group!r}, got shape {self.qc.shape}"
            )
        self.residual = lie_gp.check_model(residual)

    # --- its factors ------------------------------------------------------------------------------

    # Its qc, residual and group were checked when it was made: its factors are made without checking them again
    # (``of_checked``), the times and readings are checked as they come.

    def prior_factor(self, a: Key, b: Key, dt: float) -> Factor:
        return LiePriorFactor.of_checked(a, b, dt, self.qc, self.residual, self.group)  # [DER 11.11-11.12]

    def interpolated_factor(self, inner: Factor, a: Key, b: Key, ta: float, tb: float, tau: float) -> Factor:
        LieInterpolatedFactor.check_inner(inner, self.kind)
        return LieInterpolatedFactor.of_checked(
            inner, a, b, ta, tb, tau, self.qc, self.residual, self.group
        )  # [YIB Eq. 29; DER 11.16]

    def interpolated_factors(
        self, inners: Sequence[Factor], a: Key, b: Key, ta: float, tb: float, taus: ArrayLike
    ) -> list[Factor]:
        inners, taus = readings_at("inners", inners, taus)
        for inner in inners:
            LieInterpolatedFactor.check_inner(inner, self.kind)
        return list(
            LieInterpolatedFactor.many_of_checked(inners, a, b, ta, tb, taus, self.qc, self.residual, self.group)
        )  # [YIB Eq. 16, 29; DER 11.16]

    def velocity_reading(self, key: Key, measured: NDArray, sigmas: NDArray) -> Factor:
        return BodyVelocityFactor.create(key, measured, sigmas, group=self.group)  # e = ϖ - z

    def pose_reading(self, reading: Factor) -> Factor:
        reading = check_pose_reading(reading, self.state_dim)
        return PoseReading(
            reading.keys, reading.sqrt_information, inner=reading, loss=reading.loss, group=self.group
        )  # [DER 11.14]

    def first_state_prior(self, key: Key, pose: NDArray, velocity: NDArray, sigmas: Sequence[ArrayLike]) -> Factor:
        """Pose at the group's element of ``pose`` (SE(2): θ wrapped), twist at ``velocity``; the sigmas (each
        block dim numbers) read in the tangent at that mean (the pose's in the body frame)."""
        pose, velocity = measured_vector(pose, 3, "pose"), measured_vector(velocity, self.group.dim, "velocity")
        mean = np.concatenate([self.group.from_planar(pose), velocity])
        blocks = sigma_blocks("sigmas", sigmas, 2, self.group.dim)
        return LieStatePrior.create(key, mean, np.concatenate(blocks), group=self.group)

    # --- the state at any time ----------------------------------------------------------------------

    def interpolate(self, ta: float, xa: NDArray, tb: float, xb: NDArray, t: float) -> NDArray:
        xa, xb = self.check_state("xa", xa), self.check_state("xb", xb)
        lam, psi = interpolation_matrices(ta, tb, t, self.qc)  # [YIB Eq. 16]
        return lie_gp.interpolate(xa, xb, lam, psi, self.residual, group=self.group, jacobians=False)  # [DER 11.15]

    def interpolate_covariance(
        self, ta: float, xa: NDArray, tb: float, xb: NDArray, t: float, joint: NDArray
    ) -> NDArray:
        xa, xb = self.check_state("xa", xa), self.check_state("xb", xb)
        return lie_gp.interpolate_covariance(ta, tb, t, self.qc, xa, xb, joint, self.residual, group=self.group)[
            1
        ]  # [DER 11.17]

    def extrapolate(self, t1: float, x1: NDArray, t: float) -> NDArray:
        """(T₁ Exp((t - t₁) ϖ₁), ϖ₁): along the arc of the last twist, either residual.  [DER 11.18]"""
        return lie_gp.extrapolate(self.check_state("x1", x1), t1, t, group=self.group)[0]

    def extrapolate_covariance(self, t1: float, x1: NDArray, t: float, cov1: NDArray) -> NDArray:
        x1 = self.check_state("x1", x1)
        return lie_gp.extrapolate_covariance(x1, t1, t, self.qc, cov1, self.residual, group=self.group)[
            1
        ]  # [DER 11.18; YIB Eq. 17]

    # --- a new state's value ------------------------------------------------------------------------

    def initial_state(self, pose: NDArray, world_velocity: NDArray, dt: float) -> NDArray:
        """The group's element of the pose (SE(2): θ wrapped), and the body twist (``group.body_twist``; SE(2):
        R(θ)ᵀ [ẋ, ẏ]) of the backward difference with its heading rate from the heading change wrapped to
        [-π, π) (a step turns less than half a turn; no ±2π: the scripts' Pose2 quirk belongs to the vector state)."""
        element, dt = self.group.from_planar(measured_vector(pose, 3, "pose")), time_step(dt)
        velocity = measured_vector(world_velocity, 3, "world_velocity")
        velocity[2] = wrap_angle(velocity[2] * dt) / dt
        return np.concatenate([element, self.group.body_twist(element, velocity)])

    # --- evaluation -------------------------------------------------------------------------------------

    def _split(self, states: NDArray) -> tuple[NDArray, NDArray]:
        x = np.asarray(states, dtype=float)
        return x[:, : self.group.size], x[:, self.group.size :]

    def world_states(self, states: NDArray) -> NDArray:
        """[the planar pose, the body twist in the world frame] (``group.to_planar``, ``group.world_velocity``;
        SE(2): [px, py, θ, R(θ) [vx, vy], ω])."""
        poses, twists = self._split(states)
        return np.column_stack([self.group.to_planar(poses), self.group.world_velocity(poses, twists)])

    def errors(self, states: NDArray, truth: NDArray) -> NDArray:
        """x_true ⊖ x̂ = [Log(T̂⁻¹ T); ϖ - ϖ̂], the coordinates of the estimate's covariance (right tangent); the
        truth held as a state through the group (``from_planar``, ``body_twist``)."""
        truth = np.asarray(truth, dtype=float)
        poses = self.group.from_planar(truth[:, :3])
        held = np.column_stack([poses, self.group.body_twist(poses, truth[:, 3:6])])
        return np.array([self.kind.local(x, t) for x, t in zip(states, held, strict=True)]).reshape(
            -1, 2 * self.group.dim
        )

    def body_velocity(self, states: NDArray) -> NDArray:
        return np.array(self._split(states)[1])

    # --- drawing a task from the model -------------------------------------------------------------

    def sample_states(
        self, rng: np.random.Generator, n: int, dt: float, velocity: NDArray, sigmas: Sequence[ArrayLike]
    ) -> NDArray:
        """T₀ = Exp(n₀), n₀ ~ N(0, σ₀²) (the pose prior in the tangent at the identity), ϖ₀ ~ N(velocity, σ₁²);
        each step in the local variables of the state before it [DER 11.10-11.11]: γ₂ = Φ(dt) [0; ϖₖ] + w,
        w ~ N(0, Q(dt)), then Tₖ₊₁ = Tₖ Exp(ξ) and ϖₖ₊₁ = J_r(ξ) ξ̇ ("local-variable") or ξ̇ ("simplified") for
        γ₂ = [ξ; ξ̇], so the model's residual at the truth is w exactly. A step whose turn (``group.angle``) reaches
        π is not a draw the model can represent (its residual would read the wrapped angle): DataError naming it."""
        g, d = self.group, self.group.dim
        pose_sigmas, twist_sigmas = sigma_blocks("sigmas", sigmas, 2, d)
        chol = np.linalg.cholesky(process_noise(dt, self.qc))
        states = np.empty((n, self.state_dim))
        states[0] = np.concatenate(
            [g.exp(pose_sigmas * rng.standard_normal(d)), velocity + twist_sigmas * rng.standard_normal(d)]
        )
        noise = rng.standard_normal((n - 1, 2 * d)) @ chol.T
        local = self.residual == "local-variable"  # ϖ = J_r(ξ) ξ̇, or ξ̇ itself (simplified)
        for k in range(1, n):
            twist = states[k - 1, g.size :]
            gamma = np.concatenate([dt * twist, twist]) + noise[k - 1]  # Φ(dt) [0; ϖ] + w  [YIB Eq. 22; DER 11.11]
            xi, rate = gamma[:d], gamma[d:]
            if not g.angle(xi) < np.pi:
                raise DataError(
                    f"step {k} turned {float(g.angle(xi))!r} rad, outside (-π, π): no {g!r} WNOA residual reads it"
                )
            states[k, : g.size] = g.compose(states[k - 1, : g.size], g.exp(xi))  # Tₖ₊₁ = Tₖ Exp(ξ)
            states[k, g.size :] = g.right_jacobian(xi) @ rate if local else rate
        return states
