"""The local GP on a Lie group of a state with an acceleration: WNOJ (or Singer's model) through local variables.  [TYB19; DER 14]

A state is x = [T; ϖ; ϖ̇] (``GroupState(group, 2)``): a pose, its body twist (Ṫ = T ϖ^) and the twist's rate.
Between x₁ at t₁ and x₂ at t₂ the trajectory is written in the local variable ξ(t) = Log(T₁⁻¹ T(t)), and the
local state γ = [ξ; ξ̇; ξ̈] follows a vector-space LTI model with three blocks, WNOJ (Tang, Yoon & Barfoot 2019,
"A White-Noise-on-Jerk Motion Prior for Continuous-Time Trajectory Estimation on SE(3)"; STEAM's ``const_acc``)
or Singer's, given by its Φ, Q and input (the motion prior holds the ``LinearSDE``). The local variables are the
exact kinematics of ξ (no term dropped):

    ξ̇ = J_r(ξ)⁻¹ ϖ,   ξ̈ = d/dt (J_r(ξ)⁻¹ ϖ) = G(ξ, ϖ) ξ̇ + J_r(ξ)⁻¹ ϖ̇,   G(ξ, v) = ∂(J_r(ξ)⁻¹ v)/∂ξ   [DER 14.1]

so γ₁ = [0; ϖ₁; ϖ̇₁] (G(0, ϖ) ϖ = 0) and γ₂ = [ξ₂₁; J⁻¹ϖ₂; G(ξ₂₁, ϖ₂) J⁻¹ϖ₂ + J⁻¹ϖ̇₂]. Tang et al. and STEAM
replace G(ξ, ϖ) ξ̇ by its first-order term in ξ (½ ξ̇ ⋏ ϖ in their convention); here it is exact, and so are the
Jacobians, which need the second derivative of J_r(ξ)⁻¹ v (``LieGroup.jr_inverse_times_hessian``, [DER 14.3]).
Back from γ = [ξ; ξ̇; ξ̈]: T = T₁ Exp ξ, ϖ = J_r(ξ) ξ̇, ϖ̇ = ∂(J_r(ξ) ξ̇)/∂ξ ξ̇ + J_r(ξ) ξ̈ (the time derivative of
ϖ = J_r ξ̇). Every Jacobian is in the right tangents δ = [δT; δϖ; δϖ̇] of the states; every function takes the
group as ``group=`` and broadcasts over leading axes where it takes arrays of states.
"""

from __future__ import annotations

from typing import Literal, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arguments import check_covariance, real_array
from .group import LieGroup, mv

__all__ = [
    "local_start",
    "local_variables",
    "from_local",
    "prior_error",
    "prior_jacobians",
    "interpolate",
    "interpolate_covariance",
    "extrapolate",
    "extrapolate_covariance",
]


def _rows(*rows: tuple[NDArray, NDArray, NDArray]) -> NDArray:
    return np.concatenate([np.concatenate(r, axis=-1) for r in rows], axis=-2)


def local_start(x1: NDArray, group: LieGroup) -> NDArray:
    """γ₁ = [0; ϖ₁; ϖ̇₁]: ξ(t₁) = 0, J_r(0) = I, G(0, ϖ) ϖ = 0.  [DER 14.1]"""
    return np.concatenate([np.zeros(x1.shape[:-1] + (group.dim,)), x1[..., group.size :]], axis=-1)


@overload
def local_variables(
    x1: NDArray, x2: NDArray, *, group: LieGroup, jacobians: Literal[True] = ...
) -> tuple[NDArray, NDArray, NDArray]: ...
@overload
def local_variables(x1: NDArray, x2: NDArray, *, group: LieGroup, jacobians: Literal[False]) -> NDArray: ...
def local_variables(
    x1: NDArray, x2: NDArray, *, group: LieGroup, jacobians: bool = True
) -> NDArray | tuple[NDArray, NDArray, NDArray]:
    """γ₂ = [ξ; ξ̇; ξ̈] of x₂ in the frame of T₁, with ∂γ₂/∂x₁, ∂γ₂/∂x₂ (each (..., 3d, 3d)) unless ``jacobians``
    is False.  [DER 14.1, 14.4]

    ∂ξ/∂δT₁ = J⁻¹ ∂(T₁⁻¹T₂)/∂δT₁, ∂ξ/∂δT₂ = J⁻¹; ∂ξ̇/∂ξ = G(ξ, ϖ₂), ∂ξ̇/∂ϖ₂ = J⁻¹;
    ∂ξ̈/∂ξ = K(ξ, ϖ₂, ξ̇) + G(ξ, ϖ₂)² + G(ξ, ϖ̇₂) with K(ξ, v, u) = ∂/∂ξ [G(ξ, v) u];
    ∂ξ̈/∂ϖ₂ = DJ⁻¹[ξ̇] + G(ξ, ϖ₂) J⁻¹ with DJ⁻¹[u] = -J⁻¹ DJ[u] J⁻¹; ∂ξ̈/∂ϖ̇₂ = J⁻¹.
    """
    n, d = group.size, group.dim
    T1, T2, w2, a2 = x1[..., :n], x2[..., :n], x2[..., n : n + d], x2[..., n + d :]
    rel, H1, _ = group.between(T1, T2, jacobians=True)
    xi = group.log(rel)  # ξ₂₁ = Log(T₁⁻¹ T₂)
    jinv = group.right_jacobian_inverse(xi)
    rate = mv(jinv, w2)  # ξ̇ = J⁻¹ ϖ₂
    G = group.jr_inverse_times_jacobian(xi, w2)
    accel = mv(G, rate) + mv(jinv, a2)  # ξ̈ = G ξ̇ + J⁻¹ ϖ̇₂  [DER 14.1]
    gamma = np.concatenate([xi, rate, accel], axis=-1)
    if not jacobians:
        return gamma
    K = group.jr_inverse_times_hessian(xi, w2, rate)
    dxi_accel = K + (G @ G) + group.jr_inverse_times_jacobian(xi, a2)  # ∂ξ̈/∂ξ  [DER 14.4]
    dj_rate, _ = group.jr_derivatives(xi, rate)
    dw_accel = -(jinv @ (dj_rate @ jinv)) + (G @ jinv)  # ∂ξ̈/∂ϖ₂
    d1 = jinv @ H1  # ∂ξ/∂δT₁
    zero = np.zeros(xi.shape + (d,))
    g21 = _rows((d1, zero, zero), ((G @ d1), zero, zero), ((dxi_accel @ d1), zero, zero))
    g22 = _rows((jinv, zero, zero), ((G @ jinv), jinv, zero), ((dxi_accel @ jinv), dw_accel, jinv))
    return gamma, g21, g22


@overload
def from_local(
    x1: NDArray, gamma: NDArray, group: LieGroup, jacobians: Literal[True] = ...
) -> tuple[NDArray, NDArray, NDArray]: ...
@overload
def from_local(x1: NDArray, gamma: NDArray, group: LieGroup, jacobians: Literal[False]) -> NDArray: ...
def from_local(
    x1: NDArray, gamma: NDArray, group: LieGroup, jacobians: bool = True
) -> NDArray | tuple[NDArray, NDArray, NDArray]:
    """The state at γ = [ξ; ξ̇; ξ̈] in the frame of T₁: (T₁ Exp ξ, J ξ̇, H(ξ, ξ̇) ξ̇ + J ξ̈), H(ξ, y) = ∂(J_r(ξ) y)/∂ξ;
    unless ``jacobians`` is False also N = ∂[δT; dϖ; dϖ̇]/∂γ and ∂(T₁ Exp ξ)/∂δT₁ = Ad(Exp(-ξ)).  [DER 14.5]

    N = [[J, 0, 0], [H(ξ, ξ̇), J, 0], [∂/∂ξ(H(ξ, ξ̇) u)|_{u=ξ̇} + H(ξ, ξ̈), H(ξ, ξ̇) + DJ[ξ̇], J]].
    """
    n, d = group.size, group.dim
    xi, rate, accel = gamma[..., :d], gamma[..., d : 2 * d], gamma[..., 2 * d :]
    jr = group.right_jacobian(xi)
    H = group.jr_times_jacobian(xi, rate)
    state = [group.compose(x1[..., :n], group.exp(xi)), mv(jr, rate), mv(H, rate) + mv(jr, accel)]
    if not jacobians:
        return np.concatenate(state, axis=-1)
    _, ad, _ = group.compose(x1[..., :n], group.exp(xi), jacobians=True)
    dj_rate, _ = group.jr_derivatives(xi, rate)
    zero = np.zeros(xi.shape + (d,))
    dxi_accel = group.jr_times_hessian(xi, rate, rate) + group.jr_times_jacobian(xi, accel)
    N = _rows((jr, zero, zero), (H, jr, zero), (dxi_accel, H + dj_rate, jr))
    return np.concatenate(state, axis=-1), N, ad


def prior_error(x1: NDArray, x2: NDArray, phi: NDArray, offset: NDArray, *, group: LieGroup) -> NDArray:
    """e = γ₂ - Φ(Δt) γ₁ - v(Δt): the prior's residual in the local variables.  [YIB Eq. 22; DER 14.1]"""
    gamma2 = local_variables(x1, x2, group=group, jacobians=False)
    return gamma2 - mv(phi, local_start(x1, group)) - offset


def prior_jacobians(x1: NDArray, x2: NDArray, phi: NDArray, *, group: LieGroup) -> tuple[NDArray, NDArray]:
    """∂e/∂δ₁ = ∂γ₂/∂δ₁ - Φ ∂γ₁/∂δ₁ (∂γ₁/∂δ₁ = diag(0, I, I)), ∂e/∂δ₂ = ∂γ₂/∂δ₂.  [DER 14.4]"""
    _, g21, g22 = local_variables(x1, x2, group=group)
    d = group.dim
    g21 = g21.copy()
    g21[..., :, d:] -= phi[..., :, d:]
    return g21, g22


def interpolate(
    x1: NDArray, x2: NDArray, lam: NDArray, psi: NDArray, offset: NDArray, *, group: LieGroup, jacobians: bool = True
) -> NDArray | tuple[NDArray, NDArray, NDArray]:
    """The mean x(τ) from γ(τ) = Λ γ₁ + Ψ γ₂ + c [YIB Eq. 18, 23] and, unless ``jacobians`` is False, its
    Jacobians ∂x(τ)/∂x₁ = N (Λ ∂γ₁/∂x₁ + Ψ ∂γ₂/∂x₁) + diag(Ad(Exp(-ξ(τ))), 0, 0), ∂x(τ)/∂x₂ = N Ψ ∂γ₂/∂x₂."""
    gamma1 = local_start(x1, group)
    if not jacobians:
        gamma2 = local_variables(x1, x2, group=group, jacobians=False)
        return from_local(x1, mv(lam, gamma1) + mv(psi, gamma2) + offset, group, jacobians=False)
    gamma2, g21, g22 = local_variables(x1, x2, group=group)
    x, N, ad = from_local(x1, mv(lam, gamma1) + mv(psi, gamma2) + offset, group)
    d = group.dim
    e1 = np.zeros(x1.shape[:-1] + (3 * d, 3 * d))
    e1[..., d:, d:] = np.eye(2 * d)  # ∂γ₁/∂x₁
    J1 = N @ ((lam @ e1) + (psi @ g21))
    J1[..., :d, :d] += ad
    return x, J1, (N @ (psi @ g22))


def _gram(J: NDArray, P: NDArray, N: NDArray, Q: NDArray) -> NDArray:
    """J P Jᵀ + N Q Nᵀ, symmetric to the last bit: a congruence of each PSD matrix (no clipping)."""
    cov = J @ P @ J.T + N @ Q @ N.T
    return (cov + cov.T) / 2


def interpolate_covariance(
    x1: NDArray,
    x2: NDArray,
    lam: NDArray,
    psi: NDArray,
    offset: NDArray,
    q_cond: NDArray,
    joint_cov: ArrayLike,
    *,
    group: LieGroup,
) -> tuple[NDArray, NDArray]:
    """The mean x(τ) and its covariance J P Jᵀ + N Q_cond Nᵀ (right tangent at x(τ)); ``joint_cov`` (6d, 6d) of
    [δ₁; δ₂], ``q_cond`` the local GP's Cov(γ(τ) | γ₁, γ₂) (``gp.interpolate.conditional_covariance``).  [DER 14.6]"""
    d = group.dim
    x, J1, J2 = interpolate(x1, x2, lam, psi, offset, group=group)
    gamma = mv(lam, local_start(x1, group)) + mv(psi, local_variables(x1, x2, group=group, jacobians=False)) + offset
    _, N, _ = from_local(x1, gamma, group)
    P = check_covariance("joint_cov", real_array("joint_cov", joint_cov), 6 * d)
    return x, _gram(np.hstack([J1, J2]), P, N, q_cond)


def extrapolate(x1: NDArray, phi: NDArray, offset: NDArray, *, group: LieGroup) -> tuple[NDArray, NDArray]:
    """The prediction x(t) from γ(t) = Φ(t - t₁) γ₁ + v [YIB Eq. 22] and ∂x(t)/∂x₁ = N Φ ∂γ₁/∂x₁ + diag(Ad, 0, 0)."""
    d = group.dim
    x, N, ad = from_local(x1, mv(phi, local_start(x1, group)) + offset, group)
    e1 = np.zeros(x1.shape[:-1] + (3 * d, 3 * d))
    e1[..., d:, d:] = np.eye(2 * d)
    J = N @ (phi @ e1)
    J[..., :d, :d] += ad
    return x, J


def extrapolate_covariance(
    x1: NDArray, phi: NDArray, offset: NDArray, q: NDArray, cov1: ArrayLike, *, group: LieGroup
) -> tuple[NDArray, NDArray]:
    """The prediction x(t) and its covariance J P₁ Jᵀ + N Q(t - t₁) Nᵀ.  [YIB Eq. 17, 22; DER 14.6]"""
    x, J = extrapolate(x1, phi, offset, group=group)
    _, N, _ = from_local(x1, mv(phi, local_start(x1, group)) + offset, group)
    P = check_covariance("cov1", real_array("cov1", cov1), 3 * group.dim)
    return x, _gram(J, P, N, q)
