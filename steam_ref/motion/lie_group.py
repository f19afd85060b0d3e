"""White noise on acceleration on a Lie group, through local variables (Anderson & Barfoot 2015): SE(2) today.

A state is a pose T on the group and its body twist ϖ (:data:`~steam_ref.lie.SE2_STATE`: x = [px, py, θ, vx,
vy, ω], θ in (-π, π], the twist [forward, lateral, yaw rate] in the robot's own frame, Ṫ = T ϖ^), retracted on
the right: every covariance of a state is that of its right tangent at the estimate, the pose block in the body
frame. Between two states the local variable ξ(t) = Log(T₁⁻¹ T(t)) and its rate follow the vector-space WNOA
prior of [YIB Eq. 30-31] with Qc read as the PSD of the body-frame acceleration (``steam_ref.lie.gp``;
derivations §11). Its two residuals in circulation are both instances: ``residual`` "local-variable"
(e = [ξ - Δt ϖ₁; J_r(ξ)⁻¹ ϖ₂ - ϖ₁]: GTSAM 4.3, STEAM) or "simplified" (e = [ξ - Δt ϖ₁; ϖ₂ - ϖ₁]: gpslam, Theseus).

On such a state a velocity reading [forward, lateral, yaw rate] is the body twist itself
(:class:`~steam_ref.factors.lie_readings.BodyVelocityFactor`); a range, bearing or bearing-range keeps its
vector-space error with Jacobians in the right tangent (:class:`~steam_ref.factors.lie_readings.PoseReading`); a
reading between states moves onto them through the local GP
(:class:`~steam_ref.factors.lie_readings.LieInterpolatedFactor`); the first state's prior is in the tangent at its
mean (:class:`~steam_ref.factors.lie_prior.LieStatePrior`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..dead_reckoning import wrap_angle
from ..errors import DataError, ShapeError
from ..factors import Factor
from ..factors.lie_prior import LiePriorFactor, LieStatePrior
from ..factors.lie_readings import BodyVelocityFactor, LieInterpolatedFactor, PoseReading
from ..gp.interpolate import interpolation_matrices
from ..gp.prior import check_qc, process_noise
from ..lie import SE2, SE2_STATE, STATE_SIZE
from ..lie import gp as lie_gp
from ..variables import Key
from .base import MotionPrior, sigma_blocks

__all__ = ["LieGroupWnoa", "RESIDUALS"]

RESIDUALS = lie_gp.MODELS  # 'local-variable', 'simplified'


def _heading(theta: float) -> float:
    """θ in (-π, π], as a state on the group holds it."""
    return float(-wrap_angle(-float(theta)))


class LieGroupWnoa(MotionPrior):
    """WNOA on SE(2) states with the residual ``residual`` (module docstring); ``qc`` (3, 3) on [vx, vy, ω]."""

    name = "se2"
    kind = SE2_STATE
    state_dim = STATE_SIZE
    state_names = ("x", "y", "theta", "vx", "vy", "omega")

    def __init__(self, qc: ArrayLike, residual: str = "local-variable"):
        self.qc = check_qc(qc)
        if self.qc.shape != (3, 3):
            raise ShapeError(f"qc must be (3, 3) on the body twist [vx, vy, ω], got shape {self.qc.shape}")
        self.residual = lie_gp.check_model(residual)

    # --- its factors ------------------------------------------------------------------------------

    def prior_factor(self, a: Key, b: Key, dt: float) -> Factor:
        return LiePriorFactor.create(a, b, dt, self.qc, self.residual)  # [DER 11.11-11.12]

    def interpolated_factor(self, inner: Factor, a: Key, b: Key, ta: float, tb: float, tau: float) -> Factor:
        return LieInterpolatedFactor.create(inner, a, b, ta, tb, tau, self.qc, self.residual)  # [YIB Eq. 29; DER 11.16]

    def velocity_reading(self, key: Key, measured: NDArray, sigmas: NDArray) -> Factor:
        return BodyVelocityFactor.create(key, measured, sigmas)  # e = ϖ - z

    def pose_reading(self, reading: Factor) -> Factor:
        return PoseReading(reading.keys, reading.sqrt_information, inner=reading, loss=reading.loss)  # [DER 11.14]

    def first_state_prior(self, key: Key, pose: NDArray, velocity: NDArray, sigmas: Sequence[ArrayLike]) -> Factor:
        """Pose at ``pose`` (θ wrapped), twist at ``velocity``; the sigmas read in the tangent at that mean (the
        pose's in the body frame)."""
        mean = np.concatenate([[pose[0], pose[1], _heading(pose[2])], velocity])
        return LieStatePrior.create(key, mean, np.concatenate(sigma_blocks("sigmas", sigmas, 2)))

    # --- the state at any time ----------------------------------------------------------------------

    def interpolate(self, ta: float, xa: NDArray, tb: float, xb: NDArray, t: float) -> NDArray:
        lam, psi = interpolation_matrices(ta, tb, t, self.qc)  # [YIB Eq. 16]
        return lie_gp.interpolate(xa, xb, lam, psi, self.residual)[0]  # [DER 11.15]

    def interpolate_covariance(
        self, ta: float, xa: NDArray, tb: float, xb: NDArray, t: float, joint: NDArray
    ) -> NDArray:
        return lie_gp.interpolate_covariance_se2(ta, tb, t, self.qc, xa, xb, joint, self.residual)[1]  # [DER 11.17]

    def extrapolate(self, t1: float, x1: NDArray, t: float) -> NDArray:
        """(T₁ Exp((t - t₁) ϖ₁), ϖ₁): along the arc of the last twist, either residual.  [DER 11.18]"""
        return lie_gp.extrapolate(x1, t1, t)[0]

    def extrapolate_covariance(self, t1: float, x1: NDArray, t: float, cov1: NDArray) -> NDArray:
        return lie_gp.extrapolate_covariance_se2(x1, t1, t, self.qc, cov1)[1]  # [DER 11.18; YIB Eq. 17]

    # --- a new state's value ------------------------------------------------------------------------

    def initial_state(self, pose: NDArray, world_velocity: NDArray, dt: float) -> NDArray:
        """The pose with θ wrapped, and the body twist of the backward difference: R(θ)ᵀ [ẋ, ẏ], the heading rate
        from the heading change wrapped (no ±2π: the scripts' Pose2 quirk belongs to the vector state)."""
        theta = _heading(pose[2])
        c, s = np.cos(theta), np.sin(theta)
        vx, vy = c * world_velocity[0] + s * world_velocity[1], -s * world_velocity[0] + c * world_velocity[1]
        rate = float(wrap_angle(world_velocity[2] * dt)) / dt
        return np.array([pose[0], pose[1], theta, vx, vy, rate])

    # --- evaluation -------------------------------------------------------------------------------------

    def world_states(self, states: NDArray) -> NDArray:
        """[px, py, θ, R(θ) [vx, vy], ω]."""
        x = np.asarray(states, dtype=float)
        c, s = np.cos(x[:, 2]), np.sin(x[:, 2])
        return np.column_stack([x[:, :3], c * x[:, 3] - s * x[:, 4], s * x[:, 3] + c * x[:, 4], x[:, 5]])

    def errors(self, states: NDArray, truth: NDArray) -> NDArray:
        """x_true ⊖ x̂ = [Log(T̂⁻¹ T); ϖ - ϖ̂], the coordinates of the estimate's covariance (right tangent)."""
        truth = np.asarray(truth, dtype=float)
        c, s = np.cos(truth[:, 2]), np.sin(truth[:, 2])
        body = np.column_stack([c * truth[:, 3] + s * truth[:, 4], -s * truth[:, 3] + c * truth[:, 4], truth[:, 5]])
        held = np.column_stack([truth[:, :3], body])  # the truth as a state (Log reads any θ)
        return np.array([SE2_STATE.local(x, t) for x, t in zip(states, held, strict=True)]).reshape(-1, 6)

    def body_velocity(self, states: NDArray) -> NDArray:
        return np.array(np.asarray(states, dtype=float)[:, 3:6])

    # --- drawing a task from the model -------------------------------------------------------------

    def sample_states(
        self, rng: np.random.Generator, n: int, dt: float, velocity: NDArray, sigmas: Sequence[ArrayLike]
    ) -> NDArray:
        """T₀ = Exp(n₀), n₀ ~ N(0, σ₀²) (the pose prior in the tangent at the identity), ϖ₀ ~ N(velocity, σ₁²);
        each step in the local variables of the state before it [DER 11.10-11.11]: γ₂ = Φ(dt) [0; ϖₖ] + w,
        w ~ N(0, Q(dt)), then Tₖ₊₁ = Tₖ Exp(γ₂[:3]) and ϖₖ₊₁ = J_r(γ₂[:3]) γ₂[3:] ("local-variable") or γ₂[3:]
        ("simplified"), so the model's residual at the truth is w exactly. A step whose turn γ₂[2] leaves (-π, π)
        is not a draw the model can represent (its residual would read the wrapped angle): DataError naming it."""
        pose_sigmas, twist_sigmas = sigma_blocks("sigmas", sigmas, 2)
        chol = np.linalg.cholesky(process_noise(dt, self.qc))
        states = np.empty((n, STATE_SIZE))
        states[0] = np.concatenate(
            [SE2.exp(pose_sigmas * rng.standard_normal(3)), velocity + twist_sigmas * rng.standard_normal(3)]
        )
        noise = rng.standard_normal((n - 1, STATE_SIZE)) @ chol.T
        local = self.residual == "local-variable"  # ϖ = J_r(ξ) ξ̇, or ξ̇ itself (simplified)
        for k in range(1, n):
            twist = states[k - 1, 3:]
            gamma = np.concatenate([dt * twist, twist]) + noise[k - 1]  # Φ(dt) [0; ϖ] + w  [YIB Eq. 22; DER 11.11]
            if not -np.pi < gamma[2] < np.pi:
                raise DataError(f"step {k} turned {gamma[2]!r} rad, outside (-π, π): no SE(2) WNOA residual reads it")
            states[k, :3] = SE2.compose(states[k - 1, :3], SE2.exp(gamma[:3]))  # Tₖ₊₁ = Tₖ Exp(ξ)
            states[k, 3:] = SE2.right_jacobian(gamma[:3]) @ gamma[3:] if local else gamma[3:]
        return states
