"""Factors of the STEAM factor graph: the GP prior, measurements and priors.  [YIB Eq. 2, 22, 26-33]

- :mod:`.base`: :class:`Factor` (keys, unwhitened error and Jacobians, whitening, stacking into
  batches) and :func:`sqrt_information`.
- :mod:`.gp`: :class:`GPPriorFactor` and :func:`gp_prior_factors` (Eq. 22), and
  :class:`InterpolatedFactor`, a measurement at a time with no state (Eq. 29).
- :mod:`.measurements`: :class:`PriorFactor`, :class:`OdometryFactor` (Eq. 32),
  :class:`VelocityFactor`, :class:`RangeFactor` (Eq. 33), :class:`BearingFactor`,
  :class:`BearingRangeFactor`.
- :mod:`.marginal`: :class:`MarginalFactor`, the linear factor a marginalization leaves (Eq. 10.4 of the
  derivations).
- :mod:`.lie_prior`, :mod:`.lie_readings`: factors on SE(2) states (``steam_ref.lie.SE2_STATE``, Jacobians
  in the right tangent): :class:`LiePriorFactor` (the WNOA prior, "local-variable" or "simplified"),
  :func:`lie_prior_factors`, :class:`LieStatePrior`, :class:`PoseReading` (range, bearing,
  bearing-range), :class:`BodyVelocityFactor` (the body twist), :class:`LieInterpolatedFactor`.

The paper's trajectory state is x = [x, y, θ, ẋ, ẏ, θ̇] (d = 3, so 6 numbers); the WNOJ and Singer
priors append [ẍ, ÿ, θ̈]. The GP factors take any LTI prior (a Qc for WNOA, or a
:class:`~steam_ref.gp.LinearSDE`) and measurements read the pose and velocity from the front of the
state (``state_dim``). Landmarks are ℓ = [x, y].
"""

from .base import LANDMARK_DIM, STATE_DIM, Factor, check_factors, kinds_of, sqrt_information, wrong_size
from .gp import GPPriorFactor, InterpolatedFactor, gp_prior_factors
from .lie_prior import LiePriorFactor, LieStatePrior, lie_prior_factors
from .lie_readings import BodyVelocityFactor, LieInterpolatedFactor, PoseReading
from .marginal import MarginalFactor
from .measurements import (
    BearingFactor,
    BearingRangeFactor,
    OdometryFactor,
    PriorFactor,
    RangeFactor,
    StateMeasurement,
    VelocityFactor,
)

__all__ = [
    "Factor",
    "GPPriorFactor",
    "PriorFactor",
    "OdometryFactor",
    "VelocityFactor",
    "RangeFactor",
    "BearingFactor",
    "BearingRangeFactor",
    "InterpolatedFactor",
    "MarginalFactor",
    "StateMeasurement",
    "gp_prior_factors",
    "sqrt_information",
    "check_factors",
    "kinds_of",
    "wrong_size",
    "STATE_DIM",
    "LANDMARK_DIM",
    "LiePriorFactor",
    "lie_prior_factors",
    "LieStatePrior",
    "PoseReading",
    "BodyVelocityFactor",
    "LieInterpolatedFactor",
]
