"""The paper's runs on SE(2) states (``PaperSetup(prior="se2")``): the factors and initial values the front
end makes for them.  [AB15; derivations §11]

With ``prior="se2"`` a state is ``steam_ref.lie.SE2_STATE``, x = [x, y, θ, vx, vy, ω]: the pose and its
*body* twist (forward, lateral, yaw rate), retracted on the right. Every reading keeps its vector-space
meaning and noise; only the factors change:

- the GP prior between states is :class:`~steam_ref.factors.lie_prior.LiePriorFactor` of the set-up's
  ``se2_residual`` ("local-variable" or "simplified") with the set-up's Qc read as the PSD of the
  body-frame acceleration (:attr:`PaperSetup.prior`: the presets' Qc is isotropic in x, y, so it is the
  same numbers in either frame);
- a projected-velocity reading [forward, lateral, yaw rate] is what the body twist is, so it is an
  :class:`~steam_ref.factors.lie_readings.BodyVelocityFactor` (e = ϖ - z), not a projection;
- ranges, bearings and bearing-ranges are :class:`~steam_ref.factors.lie_readings.PoseReading`;
  readings between states :class:`~steam_ref.factors.lie_readings.LieInterpolatedFactor` (the
  local GP of Anderson & Barfoot, the SE(2) form of [YIB Eq. 29]);
- the prior on the first state is :class:`~steam_ref.factors.lie_prior.LieStatePrior`, its sigmas those of
  the vector model read in the tangent at its mean (pose in the body frame).

A new state's initial value (:func:`initial_state`) is the dead-reckoned pose, its heading wrapped to
(-π, π], and the body twist of the front end's backward difference: the world-frame velocity rotated
into the new pose's frame, the heading rate the wrapped heading change (no ±2π: the scripts' Pose2
heading quirk, ``PaperSetup.pose2_heading_rate_guess``, belongs to the vector state).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..dead_reckoning import wrap_angle
from ..factors import Factor, InterpolatedFactor
from ..factors.lie_prior import LiePriorFactor, LieStatePrior
from ..factors.lie_readings import BodyVelocityFactor, LieInterpolatedFactor, PoseReading
from ..robust import RobustLoss
from ..variables import Key
from .presets import PaperSetup

__all__ = ["initial_state", "first_state_prior", "gp_prior", "interpolated", "velocity_reading", "reading_inside"]


def _heading(theta: float) -> float:
    """θ in (-π, π], as an SE(2) state holds it."""
    return float(-wrap_angle(-float(theta)))


def initial_state(pose: NDArray, world_velocity: NDArray, dt: float) -> NDArray:
    """[x, y, θ, vx, vy, ω]: the pose [x, y, θ] with θ wrapped, and the body twist of the backward difference
    ``world_velocity`` = [ẋ, ẏ, θ̇] over a step of ``dt`` (R(θ)ᵀ [ẋ, ẏ]; θ̇ from the heading change wrapped)."""
    theta = _heading(pose[2])
    c, s = np.cos(theta), np.sin(theta)
    vx, vy = c * world_velocity[0] + s * world_velocity[1], -s * world_velocity[0] + c * world_velocity[1]
    rate = float(wrap_angle(world_velocity[2] * dt)) / dt
    return np.array([pose[0], pose[1], theta, vx, vy, rate])


def first_state_prior(key: Key, pose: NDArray, setup: PaperSetup) -> LieStatePrior:
    """The prior on the first state: pose at ``pose``, twist at ``setup.first_velocity``, the set-up's sigmas."""
    mean = np.concatenate([[pose[0], pose[1], _heading(pose[2])], setup.first_velocity])
    return LieStatePrior.create(key, mean, np.concatenate([setup.first_pose_sigmas, setup.first_velocity_sigmas]))


def gp_prior(a: Key, b: Key, dt: float, setup: PaperSetup) -> LiePriorFactor:
    """The SE(2) WNOA prior between two states ``dt`` apart, of the set-up's residual.  [DER 11.11-11.12]"""
    return LiePriorFactor.create(a, b, dt, setup.qc, setup.se2_residual)


def interpolated(
    inner: Factor, a: Key, b: Key, ta: float, tb: float, tau: float, setup: PaperSetup
) -> LieInterpolatedFactor:
    """``inner`` (on the state at τ) moved onto the states a at ta and b at tb.  [YIB Eq. 29; DER 11.16]"""
    return LieInterpolatedFactor.create(inner, a, b, ta, tb, tau, setup.qc, setup.se2_residual)


def velocity_reading(key: Key, reading: NDArray, sigmas: NDArray) -> BodyVelocityFactor:
    """A [forward, lateral, yaw rate] reading: the body twist itself."""
    return BodyVelocityFactor.create(key, reading, sigmas)


def range_reading(key: Key, landmark: Key, value: float, sigma: float, loss: RobustLoss | None) -> PoseReading:
    return PoseReading.range(key, landmark, value, sigma, loss=loss)


def bearing_reading(key: Key, landmark: Key, value: float, sigma: float) -> PoseReading:
    return PoseReading.bearing(key, landmark, value, sigma)


def bearing_range_reading(key: Key, landmark: Key, bearing: float, distance: float, noise: NDArray) -> PoseReading:
    return PoseReading.bearing_range(key, landmark, bearing, distance, noise)


def reading_inside(factor: Factor) -> Factor:
    """The reading a factor holds, through every wrapper: an interpolated factor of either state (vector, SE(2))
    and the SE(2) pose reading hold a range, bearing or bearing-range factor as ``inner``."""
    while isinstance(factor, (InterpolatedFactor, LieInterpolatedFactor, PoseReading)):
        factor = factor.inner
    return factor
