"""The state kind of a motion prior on a Lie group: a pose and its body twist, retracted on the right.

:class:`GroupState` is written once for any :class:`~steam_ref.lie.group.LieGroup`; :data:`SE2_STATE`
is ``GroupState(SE2)``. A state is stored as the flat array x = [T; ϖ]: the pose T on the group (its
``size`` numbers; SE(2): [px, py, θ], θ in (-π, π]) and the body twist ϖ ∈ R^dim (the velocity in the
robot's own frame: Ṫ = T ϖ^; SE(2): [vx, vy, ω]). Its tangent has 2·dim entries, δ = [δT; δϖ], and

    x ⊕ δ = (T Exp(δT),  ϖ + δϖ)              (retraction on the right)
    x ⊖ x₀ = [Log(T₀⁻¹ T);  ϖ - ϖ₀]

**What the right retraction means for a covariance.** A solver's covariance of this state is the
covariance of δ at the estimate x̄ (for an incremental solver, its linearization point:
:mod:`steam_ref.covariance`), x = x̄ ⊕ δ with δ ~ N(0, P): its pose block is in the *body frame at x̄*.
δρ is a displacement along the robot's own axes at x̄ (the world displacement is R(θ̄) δρ, to first
order), δφ a turn about the robot; the twist block is in the body frame already. To read a world-frame
position covariance, rotate: R(θ̄) P_ρρ R(θ̄)ᵀ (:func:`world_position_covariance`). A covariance taken
at one estimate moves to another x̄' by the Jacobian of x̄' ⊖ (x̄ ⊕ δ) (the adjoint of the pose
difference, to first order), never by copying it. [DER 11.9; B17 Ch. 7]
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..arguments import check_covariance, finite, real_array
from ..errors import ShapeError, SteamError
from ..manifold import Manifold
from .group import LieGroup, check_group
from .se2 import SE2

__all__ = ["GroupState", "SE2_STATE", "STATE_SIZE", "group_state", "world_position_covariance"]


class GroupState(Manifold):
    """A pose on ``group`` and its body twist (and, with ``derivatives`` = 2, its body acceleration ϖ̇), retracted
    on the right (module docstring): x = [T; ϖ; ϖ̇], x ⊕ δ = (T Exp(δT), ϖ + δϖ, ϖ̇ + δϖ̇).

    ``size`` is the stored size of a state (group.size + derivatives · group.dim), ``dim`` its tangent's
    ((1 + derivatives) group.dim), ``name`` the group's (with '+acc' for the acceleration). There is one kind per
    group and number of derivatives.
    """

    _kinds: ClassVar[dict[tuple[LieGroup, int], GroupState]] = {}
    size: int  # always known for a state on a group (a vector space may leave it None)

    def __new__(cls, group: LieGroup, derivatives: int = 1) -> GroupState:
        """The one kind of each group and number of derivatives: ``GroupState(SE2) is SE2_STATE`` (the solvers
        compare kinds by identity)."""
        known = (  # a factor's key_kinds: the kind made already (an unhashable group goes on to check_group's error)
            cls._kinds.get((group, derivatives)) if isinstance(group, LieGroup) and type(derivatives) is int else None
        )
        if known is not None:
            return known
        check_group(group)
        if derivatives not in (1, 2) or isinstance(derivatives, bool):
            raise SteamError(
                f"a state on a group holds its twist (derivatives=1) or also its acceleration (2), got {derivatives!r}"
            )
        if (group, derivatives) not in cls._kinds:
            cls._kinds[group, derivatives] = super().__new__(cls)
        return cls._kinds[group, derivatives]

    def __init__(self, group: LieGroup, derivatives: int = 1):
        if getattr(self, "group", None) is group:  # the one kind, made already (``__new__``)
            return
        self.derivatives = derivatives
        self.name = group.name if derivatives == 1 else f"{group.name}+acc"
        self.size = group.size + derivatives * group.dim
        self.dim = (1 + derivatives) * group.dim
        self.group = group  # last: the test above must not see a kind half made

    def _state(self, name: str, x: NDArray) -> NDArray:
        x = real_array(name, x)
        if x.shape[-1:] != (self.size,):
            raise ShapeError(
                f"{name} must be an {self!r} state: a pose on {self.group!r} and its body twist, {self.size} numbers; "
                f"got shape {x.shape}"
            )
        return x

    def _step(self, name: str, delta: NDArray) -> NDArray:
        delta = real_array(name, delta)
        if delta.shape[-1:] != (self.dim,):
            raise ShapeError(
                f"{name} must be a step in the tangent of an {self!r} state ({self.dim} numbers), got shape {delta.shape}"
            )
        return delta

    def check(self, name: str, x: object) -> NDArray:
        """One finite state (size,) whose pose is an element of the group in its stored form (SE(2): θ in
        (-π, π]); ShapeError or SteamError naming ``name`` otherwise."""
        x = real_array(name, x)
        if x.shape != (self.size,):
            raise ShapeError(f"{name} must be one {self!r} state ({self.size} numbers), got shape {x.shape}")
        self.group.check_stored(name, finite(name, x)[: self.group.size])  # the numbers are checked: the form alone
        return x

    def retract(self, x: NDArray, delta: NDArray) -> NDArray:
        """x ⊕ δ = (T Exp(δT), ϖ + δϖ): the pose comes back in its stored form (SE(2): θ in (-π, π])."""
        x, delta = self._state("x", x), self._step("delta", delta)
        g, n = self.group, self.group.size
        d = g.dim
        return np.concatenate([g.compose_exp(x[..., :n], delta[..., :d]), x[..., n:] + delta[..., d:]], axis=-1)

    def retract_many(self, xs: Sequence[NDArray], deltas: Sequence[NDArray]) -> list[NDArray]:
        """x ⊕ δ of many states (a solver's own, of this kind) in one pass: one ``compose_exp`` on the stacked poses,
        the twists added; the numbers of :meth:`retract`, each row a new array."""
        if not xs:
            return []
        out, delta = np.array(xs, dtype=float), np.array(deltas, dtype=float)
        g, n, d = self.group, self.group.size, self.group.dim
        out[:, :n] = g.compose_exp(out[:, :n], delta[:, :d])
        out[:, n:] += delta[:, d:]
        return [row.copy() for row in out]

    def local(self, x0: NDArray, x: NDArray) -> NDArray:
        """x ⊖ x₀ = [Log(T₀⁻¹ T); ϖ - ϖ₀] (SE(2): the angle in (-π, π]); retract(x0, local(x0, x)) == x."""
        x0, x = self._state("x0", x0), self._state("x", x)
        g, n = self.group, self.group.size
        return np.concatenate([g.log(g.between(x0[..., :n], x[..., :n])), x[..., n:] - x0[..., n:]], axis=-1)

    def turned(self, x: NDArray, angle: float) -> NDArray:
        """The state ``x`` with the world turned by ``angle`` about its origin: the pose's planar pose rotated and
        its heading shifted (through the group's ``to_planar`` / ``from_planar``; SE(2): the heading wrapped), the
        body twist unchanged (it is in the robot's own frame). A group without a planar pose refuses."""
        x = self._state("x", x)
        g, n = self.group, self.group.size
        pose = g.to_planar(x[:n])
        c, s = np.cos(angle), np.sin(angle)
        pose[0], pose[1] = c * pose[0] - s * pose[1], s * pose[0] + c * pose[1]
        pose[2] = pose[2] + angle
        return np.concatenate([g.from_planar(pose), x[n:]])

    def __repr__(self) -> str:
        return f"{self.group!r}_STATE" if self.derivatives == 1 else f"{self.group!r}_ACC_STATE"

    def __reduce__(self) -> tuple:
        return (GroupState, (self.group, self.derivatives))  # unpickled as the one kind of its group


SE2_STATE = GroupState(SE2)  # [px, py, θ, vx, vy, ω]: an SE(2) pose and its body twist
STATE_SIZE = SE2_STATE.size


def world_position_covariance(x: NDArray, cov: NDArray, *, group: LieGroup = SE2) -> NDArray:
    """The covariance of the world-frame position of a pose or state ``x`` on ``group``, from the covariance
    ``cov`` of its right tangent at ``x`` (a pose or state covariance, or any square one whose first block is
    δρ): R P_ρρ Rᵀ, R the pose's rotation, the world displacement R δρ to first order (module docstring).
    A NaN, infinite or non-symmetric ``cov`` is refused (SteamError naming it). [DER 11.9]"""
    x, cov = real_array("x", x), real_array("cov", cov)
    n = group.matrix(group.identity()).shape[-1] - 1  # the dimension of the space the group moves
    if x.shape not in ((group.size,), (group.size + group.dim,)) or cov.ndim != 2 or cov.shape[0] < n:
        raise ShapeError(
            f"need a pose or state x on {group!r} and a square covariance of its tangent, got {x.shape}, {cov.shape}"
        )
    cov = check_covariance("cov", cov, cov.shape[0])
    R = group.matrix(finite("x", x)[: group.size])[:n, :n]
    return R @ cov[:n, :n] @ R.T


def group_state(kind: object, what: str = "the prior's state") -> GroupState:
    """``kind`` itself when it is a state on a group (:class:`GroupState`); SteamError naming ``what`` otherwise (a
    3-D run, a rigid body's reading, needs a pose on a group, not a vector)."""
    if not isinstance(kind, GroupState):
        raise SteamError(f"{what} must be a pose on a group of rigid motions (a GroupState), got {kind!r}")
    return kind
