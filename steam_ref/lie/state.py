"""The SE(2) state kind: a planar pose and its body-frame twist, retracted on the right.

A state is stored as the flat array x = [px, py, θ, vx, vy, ω] (θ in (-π, π]): the pose
T = (R(θ), [px, py]) ∈ SE(2) and the body twist ϖ = [vx, vy, ω] ∈ R³ (the velocity in the robot's
own frame: Ṫ = T ϖ^). Its tangent is 6-D, δ = [δρ; δφ; δϖ], and

    x ⊕ δ = (T Exp(δ[:3]),  ϖ + δ[3:])              (retraction on the right)
    x ⊖ x₀ = [Log(T₀⁻¹ T);  ϖ - ϖ₀]

**What the right retraction means for a covariance.** A solver's covariance of this state is the
covariance of δ at the estimate x̄, x = x̄ ⊕ δ with δ ~ N(0, P): its pose block is in the *body frame
at the estimate*. δρ is a displacement along the robot's own forward and left axes at x̄ (the world
displacement is R(θ̄) δρ, to first order), δφ a turn about the robot; the twist block is in the
body frame already. To read a world-frame (x, y) covariance, rotate: R(θ̄) P_ρρ R(θ̄)ᵀ. A covariance
taken at one estimate moves to another x̄' by the Jacobian of x̄' ⊖ (x̄ ⊕ δ) (the adjoint of the
pose difference, to first order), never by copying it. [DER 11.9; B17 Ch. 7]
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..arguments import real_array
from ..errors import ShapeError, SteamError
from ..manifold import Manifold
from . import se2

__all__ = ["SE2State", "SE2_STATE", "STATE_SIZE", "world_position_covariance"]

STATE_SIZE = 6  # [px, py, θ, vx, vy, ω]


def _state(name: str, x: NDArray) -> NDArray:
    x = real_array(name, x)
    if x.shape[-1:] != (STATE_SIZE,):
        raise ShapeError(f"{name} must be an SE(2) state [px, py, θ, vx, vy, ω] (6 numbers), got shape {x.shape}")
    return x


class SE2State(Manifold):
    """A pose T ∈ SE(2) and a body twist ϖ ∈ R³, retracted on the right (module docstring)."""

    name = "se2"
    size = STATE_SIZE

    def check(self, name: str, x: NDArray) -> None:
        """Six numbers, the heading θ in (-π, π] (refused outside it, not wrapped: wrap it with ``lie.se2.wrap``)."""
        super().check(name, x)
        if not -np.pi < x[2] <= np.pi:
            raise SteamError(
                f"{name}: the heading of an SE(2) state must lie in (-π, π], got θ={float(x[2])!r} "
                "(wrap it: steam_ref.lie.se2.wrap)"
            )

    def retract(self, x: NDArray, delta: NDArray) -> NDArray:
        """x ⊕ δ = (T Exp(δ[:3]), ϖ + δ[3:]): θ comes back in (-π, π]."""
        x, delta = _state("x", x), _state("delta", delta)
        return np.concatenate([se2.compose(x[..., :3], se2.exp(delta[..., :3])), x[..., 3:] + delta[..., 3:]], axis=-1)

    def local(self, x0: NDArray, x: NDArray) -> NDArray:
        """x ⊖ x₀ = [Log(T₀⁻¹ T); ϖ - ϖ₀], the angle in (-π, π]; retract(x0, local(x0, x)) == x."""
        x0, x = _state("x0", x0), _state("x", x)
        return np.concatenate([se2.log(se2.between(x0[..., :3], x[..., :3])), x[..., 3:] - x0[..., 3:]], axis=-1)

    def __repr__(self) -> str:
        return "SE2_STATE"


SE2_STATE = SE2State()


def world_position_covariance(x: NDArray, cov: NDArray) -> NDArray:
    """The (2, 2) covariance of the world-frame position of state ``x``, from the covariance ``cov`` of its right
    tangent at ``x`` (a pose (3, 3) or state (6, 6) covariance, or any (≥2, ≥2) whose first block is δρ):
    R(θ) P_ρρ R(θ)ᵀ, the world displacement R(θ) δρ to first order (module docstring). [DER 11.9]"""
    x, cov = real_array("x", x), real_array("cov", cov)
    if x.shape[-1:] not in ((3,), (STATE_SIZE,)) or cov.ndim != 2 or cov.shape[0] != cov.shape[1] or cov.shape[0] < 2:
        raise ShapeError(f"need a pose or state x and a square covariance of its tangent, got {x.shape}, {cov.shape}")
    c, s = np.cos(x[2]), np.sin(x[2])
    R = np.array([[c, -s], [s, c]])
    return R @ cov[:2, :2] @ R.T
