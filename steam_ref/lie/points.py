"""Points moved by a group of rigid motions: a pose's position and a world point in its body frame, with their
Jacobians in the right tangent, written once for any group whose elements are homogeneous matrices.  [DER 15.1-15.3]

A group of rigid motions of k-space (SE(2): k = 2, SE(3): k = 3) has elements T = [[R, t], [0, 1]] and a tangent
[ρ; φ], translation first (the protocol's convention, ``lie.group``). Everything a reading of a point needs follows
from the group's ``matrix`` and ``hat`` alone, so no group is named here:

- the position t of T, and ∂t/∂δ = R E_j[:k, k] column by column (T Exp δ [0; 1] ≈ T (I + δ^) [0; 1]), which is
  [R, 0] for a tangent whose first k generators are the unit translations;
- a world point p in the body frame, q = Rᵀ(p - t), with ∂q/∂δ_j = -(E_j [q; 1])[:k] ((T Exp δ)⁻¹ ≈ (I - δ^) T⁻¹)
  and ∂q/∂p = Rᵀ;
- the rotational part of a twist, its entries from k on (a gyro reads it: SE(3)'s body angular velocity, SE(2)'s
  yaw rate),

where E_j = hat(e_j) are the group's generators. A group whose generators are not of that form (SO(3) moves no
point's origin) is refused by name (:func:`point_dim`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..errors import SteamError
from .group import LieGroup, check_group

__all__ = ["point_dim", "position", "to_body", "rotation_part"]

_DIMS: dict[LieGroup, tuple[int, NDArray]] = {}  # group → (k, its generators E (dim, k+1, k+1))


def _generators(group: LieGroup) -> tuple[int, NDArray]:
    group = check_group(group)
    if group not in _DIMS:
        E = np.asarray(group.hat(np.eye(group.dim)), dtype=float)
        k = E.shape[-1] - 1
        rigid = (
            k >= 1
            and group.dim > k
            and not np.any(E[:, k, :])  # the last row of every generator is zero: [[ω^, v], [0, 0]]
            and np.array_equal(E[:k, :k, k], np.eye(k))  # the first k are the unit translations
            and not np.any(E[:k, :k, :k])
            and not np.any(E[k:, :k, k])  # the rest turn without moving the origin
        )
        if not rigid:
            raise SteamError(
                f"{group!r} moves no points: its elements are not homogeneous matrices [[R, t], [0, 1]] with the "
                "translation first in the tangent, so it has no position, body-frame point or angular velocity "
                "(SE2 and SE3 have)"
            )
        _DIMS[group] = (k, E)
    return _DIMS[group]


def point_dim(group: LieGroup) -> int:
    """k, the dimension of the space ``group`` moves points in (SE(2): 2, SE(3): 3); SteamError naming a group
    that moves none."""
    return _generators(group)[0]


def rotation_part(group: LieGroup) -> slice:
    """Where the rotational part of a twist sits: its entries from k on (SE(3): [ωx, ωy, ωz], SE(2): [ω])."""
    return slice(point_dim(group), group.dim)


def position(group: LieGroup, a: NDArray) -> tuple[NDArray, NDArray]:
    """The position t (..., k) of the elements ``a`` (..., size) and ∂t/∂δ (..., k, dim) = R [I, 0].  [DER 15.1]"""
    k, E = _generators(group)
    M = group.matrix(a)
    R = M[..., :k, :k]
    return M[..., :k, k], np.einsum("...ij,dj->...id", R, E[:, :k, k])


def to_body(group: LieGroup, a: NDArray, point: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """The world ``point`` (..., k) in the body frame of ``a``: q = Rᵀ(p - t) (..., k), ∂q/∂δ (..., k, dim) with
    column j -(E_j [q; 1])[:k], and ∂q/∂p = Rᵀ (..., k, k).  [DER 15.2]"""
    k, E = _generators(group)
    M = group.matrix(a)
    Rt = np.swapaxes(M[..., :k, :k], -1, -2)
    q = np.einsum("...ij,...j->...i", Rt, np.asarray(point, dtype=float) - M[..., :k, k])
    dq = -(np.einsum("dij,...j->...id", E[:, :k, :k], q) + E[:, :k, k].T)
    return q, dq, Rt
