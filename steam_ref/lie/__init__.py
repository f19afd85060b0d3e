"""Lie groups for the states of a motion prior on a manifold: SE(2) and its state kind.

- :mod:`.se2`: the group SE(2) (Exp, Log, J_r, J_r⁻¹, Ad, compose, inverse, between and their
  Jacobians), every function broadcasting over leading axes.
- :mod:`.state`: :data:`SE2_STATE`, the state kind [px, py, θ, vx, vy, ω] (a pose and its body twist),
  retracted on the right (a :class:`~steam_ref.manifold.Manifold`).
- :mod:`.interpolate`: the local GP between two SE(2) states (Anderson & Barfoot 2015): the mean at
  a time τ, its Jacobians and covariance; prediction after the last state.
"""

from . import se2
from .state import SE2_STATE, STATE_SIZE, SE2State, world_position_covariance

__all__ = ["se2", "SE2_STATE", "SE2State", "STATE_SIZE", "world_position_covariance"]
