"""Lie groups for the states of a motion prior on a manifold: the protocol, SE(2), SO(3), SE(3), the state kind, the local GP.

- :mod:`.group`: :class:`LieGroup`, the protocol every group implements (Exp, Log, hat/vee, J_r, J_r⁻¹,
  Ad, compose / inverse / between each with its Jacobians from the same call, the exact derivatives of
  J_r(ξ)^{±1} v; a planar robot's pose and velocity, which a group without one refuses); conventions:
  tangent [ρ; φ] translation first, right Jacobians, flat arrays, broadcasting over leading axes.
- :mod:`.se2`: :data:`SE2`, its first instance (poses [x, y, θ], θ in (-π, π]; series below
  abs(φ) = 1, closed forms above).
- :mod:`.so3`, :mod:`.se3`: :data:`SO3` (rotations stored as R's 9 entries row-major, tangent φ) and :data:`SE3`
  (poses [t; R row-major], tangent [ρ; φ]) and :data:`SE3V` (the same group on poses [t; φ], 6 numbers as its
  tangent, so the solvers run on its states); Log's angle in [0, π], exact up to π; their closed forms' coefficients
  (:mod:`.coefficients`), each from its series below θ = 2 and its closed form above.
- :mod:`.state`: :class:`GroupState`, the state kind of a pose on any group and its body twist,
  retracted on the right (a :class:`~steam_ref.manifold.Manifold`); :data:`SE2_STATE` =
  ``GroupState(SE2)``, the state [px, py, θ, vx, vy, ω]; :func:`world_position_covariance`.
- :mod:`.gp`: the local GP between two group states (Anderson & Barfoot 2015): the local variables of
  both WNOA models, the mean at a time τ with its Jacobians and covariance, the prediction after the last
  state; every function takes the group (``group=``).
"""

from typing import TYPE_CHECKING

from .._package import lazy_names
from .group import LieGroup
from .se2 import SE2
from .state import SE2_STATE, STATE_SIZE, GroupState, world_position_covariance

if TYPE_CHECKING:
    from .se3 import SE3, SE3V
    from .so3 import SO3

# Loaded when first used (PEP 562): a planar run never loads them.
_HOMES = {
    "SO3": "so3",
    "SE3": "se3",
    "SE3V": "se3",
}
__getattr__, __dir__ = lazy_names(globals(), _HOMES)

__all__ = [
    "LieGroup",
    "SE2",
    "SO3",
    "SE3",
    "SE3V",
    "GroupState",
    "SE2_STATE",
    "STATE_SIZE",
    "world_position_covariance",
]
