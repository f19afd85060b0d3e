"""The WNOA GP on a Lie group through local variables, after Anderson & Barfoot 2015.  [AB15; DER 11.10-11.18]

Between two states x₁ = (T₁, ϖ₁) at t₁ and x₂ = (T₂, ϖ₂) at t₂, the trajectory is written in the
local variable ξ(t) = Log(T₁⁻¹ T(t)), whose derivative is ξ̇ = J_r(ξ)⁻¹ ϖ (Ṫ = T ϖ^). The local
state γ(t) = [ξ(t); ξ̇(t)] follows the vector-space WNOA prior of [YIB Eq. 30-31], so

    γ₁ = [0; ϖ₁],   γ₂ = [ξ₂₁; J_r(ξ₂₁)⁻¹ ϖ₂],   ξ₂₁ = Log(T₁⁻¹ T₂)              [DER 11.10]

and the prior's residual is e = γ₂ - Φ(Δt) γ₁ = [ξ₂₁ - Δt ϖ₁; J_r(ξ₂₁)⁻¹ ϖ₂ - ϖ₁] with the
vector-space Q(Δt) ("local-variable": GTSAM 4.3 ``WnoaMotionFactorPose2``, STEAM ``const_vel_se2``).
The "simplified" model takes ξ̇ ≈ ϖ, γ₂ = [ξ₂₁; ϖ₂] (gpslam ``GaussianProcessPriorPose2``, Theseus).
The mean at τ is γ(τ) = Λ(τ) γ₁ + Ψ(τ) γ₂ [YIB Eq. 18], mapped back: T(τ) = T₁ Exp(ξ(τ)),
ϖ(τ) = J_r(ξ(τ)) ξ̇(τ) (simplified: ϖ(τ) = ξ̇(τ)). Every Jacobian here is with respect to the right
tangents of the states (``steam_ref.lie.state``), exact; derivations in [DER 11.10-11.18] (written for
SE(2); every step uses only the group's protocol, ``lie.group``, so the code holds for any group).

Every function takes the group as ``group=`` (a :class:`~steam_ref.lie.group.LieGroup`, always given: the
motion prior on a group passes its own), and a state on it as the flat array [T; ϖ] of ``GroupState(group)``: the pose's ``group.size`` numbers
then the body twist's ``group.dim``. ``local_variables`` and ``interpolate`` give the value and its
Jacobians from one call, or with ``jacobians=False`` the value alone (a factor's error needs no more).
"""

from __future__ import annotations

from typing import Literal, overload

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arguments import check_covariance, number, real_array
from ..choices import RESIDUALS
from ..errors import SteamError
from ..gp.interpolate import conditional_covariance, interpolation_matrices
from ..gp.prior import check_qc, process_noise, transition
from .group import LieGroup, mv

__all__ = [
    "MODELS",
    "check_model",
    "local_variables",
    "interpolate",
    "interpolate_covariance",
    "extrapolate",
    "extrapolate_covariance",
]

MODELS = RESIDUALS  # the two WNOA models on a group (their home: steam_ref.choices, read by the parser)


def check_model(model: object, name: str = "model") -> str:
    """The name of a WNOA model on a group ("local-variable" or "simplified"), or SteamError naming ``name`` and
    the choices."""
    if model not in MODELS:
        raise SteamError(f"{name} must be one of {', '.join(repr(m) for m in MODELS)}, got {name}={model!r}")
    return str(model)


def _blocks(tl: NDArray, tr: NDArray, bl: NDArray, br: NDArray) -> NDArray:
    return np.concatenate([np.concatenate([tl, tr], axis=-1), np.concatenate([bl, br], axis=-1)], axis=-2)


def _joined(xi: NDArray, velocity: NDArray) -> NDArray:
    """[ξ; ξ̇] along the last axis, broadcast only if their shapes differ."""
    if xi.shape == velocity.shape:
        return np.concatenate([xi, velocity], axis=-1)
    return np.concatenate(np.broadcast_arrays(xi, velocity), axis=-1)


def _eye(d: int, shape: tuple[int, ...]) -> NDArray:
    return np.broadcast_to(np.eye(d), shape + (d, d))


@overload
def local_variables(
    x1: NDArray, x2: NDArray, model: str, *, group: LieGroup, jacobians: Literal[True] = ...
) -> tuple[NDArray, NDArray, NDArray]: ...
@overload
def local_variables(x1: NDArray, x2: NDArray, model: str, *, group: LieGroup, jacobians: Literal[False]) -> NDArray: ...
def local_variables(
    x1: NDArray, x2: NDArray, model: str, *, group: LieGroup, jacobians: bool = True
) -> NDArray | tuple[NDArray, NDArray, NDArray]:
    """γ₂ = [ξ₂₁; J_r(ξ₂₁)⁻¹ ϖ₂] in the frame of T₁ (simplified: [ξ₂₁; ϖ₂]), with ∂γ₂/∂x₁, ∂γ₂/∂x₂ unless
    ``jacobians`` is False (γ₂ alone).

    ∂ξ₂₁/∂δT₁ = J_r(ξ₂₁)⁻¹ ∂(T₁⁻¹T₂)/∂δT₁ = -J_r(ξ₂₁)⁻¹ Ad(Exp(-ξ₂₁)), ∂ξ₂₁/∂δT₂ = J_r(ξ₂₁)⁻¹ [DER 11.13];
    ∂(J_r(ξ)⁻¹ ϖ₂)/∂ξ is exact (``group.jr_inverse_times_jacobian``). Shapes (..., 2d), (..., 2d, 2d) twice.
    """
    n, d = group.size, group.dim
    T1, T2, w2 = x1[..., :n], x2[..., :n], x2[..., n:]
    local = model == "local-variable"
    if not jacobians:
        xi, u = group.log_between(T1, T2, w2)  # ξ₂₁ = Log(T₁⁻¹ T₂), u = J_r(ξ₂₁)⁻¹ ϖ₂  [DER 11.10]
        return _joined(xi, u if local else w2)
    xi, u, d1, jinv, G = group.log_between(T1, T2, w2, jacobians=True)  # ∂ξ/∂δT₁, ∂ξ/∂δT₂, ∂u/∂ξ  [DER 11.6, 11.13]
    J1, J2 = np.zeros((2,) + d1.shape[:-2] + (2 * d, 2 * d))
    J1[..., :d, :d], J2[..., :d, :d] = d1, jinv
    if local:  # ξ̇(t₂) = J_r(ξ₂₁)⁻¹ ϖ₂
        J1[..., d:, :d], J2[..., d:, :d], J2[..., d:, d:] = G @ d1, G @ jinv, jinv
    else:
        J2[..., d:, d:] = np.eye(d)
    return _joined(xi, u if local else w2), J1, J2


@overload
def _from_local(
    x1: NDArray, gamma: NDArray, model: str, group: LieGroup, jacobians: Literal[True] = ...
) -> tuple[NDArray, NDArray, NDArray]: ...
@overload
def _from_local(x1: NDArray, gamma: NDArray, model: str, group: LieGroup, jacobians: Literal[False]) -> NDArray: ...
def _from_local(
    x1: NDArray, gamma: NDArray, model: str, group: LieGroup, jacobians: bool = True
) -> NDArray | tuple[NDArray, NDArray, NDArray]:
    """The state at γ = [ξ; ξ̇] in the frame of T₁: (T₁ Exp ξ, J_r(ξ) ξ̇); unless ``jacobians`` is False, also
    N = ∂[δT; dϖ]/∂γ and ∂(T₁ Exp ξ)/∂δT₁ = Ad(Exp(-ξ)) (T₁ Exp(δ) Exp(ξ) = T₁ Exp(ξ) Exp(Ad(Exp(-ξ)) δ))."""
    n, d = group.size, group.dim
    xi, xidot = gamma[..., :d], gamma[..., d:]
    local = model == "local-variable"
    jr = group.right_jacobian(xi) if local or jacobians else np.empty(0)
    twist = mv(jr, xidot) if local else xidot  # ϖ(τ) = J_r(ξ(τ)) ξ̇(τ)  [DER 11.10]
    if not jacobians:
        return np.concatenate([group.compose(x1[..., :n], group.exp(xi)), twist], axis=-1)
    pose, ad, _ = group.compose(x1[..., :n], group.exp(xi), jacobians=True)  # T(τ) = T₁ Exp(ξ(τ))  [DER 11.10]
    zero = np.zeros(xi.shape + (d,))
    dtwist = group.jr_times_jacobian(xi, xidot) if local else zero  # ∂ϖ(τ)/∂ξ
    N = _blocks(jr, zero, dtwist, jr if local else _eye(d, xi.shape[:-1]))
    return np.concatenate([pose, twist], axis=-1), N, ad


@overload
def interpolate(
    x1: NDArray,
    x2: NDArray,
    lam: NDArray,
    psi: NDArray,
    model: str = ...,
    *,
    group: LieGroup,
    jacobians: Literal[True] = ...,
) -> tuple[NDArray, NDArray, NDArray]: ...
@overload
def interpolate(
    x1: NDArray,
    x2: NDArray,
    lam: NDArray,
    psi: NDArray,
    model: str = ...,
    *,
    group: LieGroup,
    jacobians: Literal[False],
) -> NDArray: ...
def interpolate(
    x1: NDArray,
    x2: NDArray,
    lam: NDArray,
    psi: NDArray,
    model: str = "local-variable",
    *,
    group: LieGroup,
    jacobians: bool = True,
) -> NDArray | tuple[NDArray, NDArray, NDArray]:
    """The mean x(τ) between x₁ and x₂ and its Jacobians ∂x(τ)/∂x₁, ∂x(τ)/∂x₂ (right tangents); x(τ) alone
    when ``jacobians`` is False.

    Λ(τ), Ψ(τ) are the vector-space WNOA interpolation matrices of [YIB Eq. 16] (``gp.interpolation_matrices``).
    γ(τ) = Λ γ₁ + Ψ γ₂ [YIB Eq. 18; DER 11.15]; dγ(τ) = Λ dγ₁ + Ψ dγ₂; then δ(τ) = Ad(Exp(-ξ(τ))) δT₁ + N dγ(τ).
    """
    x1, x2 = np.asarray(x1, dtype=float), np.asarray(x2, dtype=float)
    n, d = group.size, group.dim
    gamma1 = np.concatenate([np.zeros(x1.shape[:-1] + (d,)), x1[..., n:]], axis=-1)  # γ₁ = [0; ϖ₁]
    if not jacobians:
        gamma2 = local_variables(x1, x2, model, group=group, jacobians=False)
        return _from_local(x1, mv(lam, gamma1) + mv(psi, gamma2), model, group, jacobians=False)  # [YIB Eq. 18]
    gamma2, g21, g22 = local_variables(x1, x2, model, group=group)
    gamma = mv(lam, gamma1) + mv(psi, gamma2)  # [YIB Eq. 18]
    x, N, ad = _from_local(x1, gamma, model, group)
    e1 = np.zeros(x1.shape[:-1] + (2 * d, 2 * d))
    e1[..., d:, d:] = np.eye(d)  # ∂γ₁/∂x₁
    J1 = N @ ((lam @ e1) + (psi @ g21))  # [DER 11.16]
    J1[..., :d, :d] += ad
    return x, J1, (N @ (psi @ g22))  # [DER 11.16]


def interpolate_covariance(
    t1: float,
    t2: float,
    tau: float,
    qc: NDArray,
    x1: NDArray,
    x2: NDArray,
    joint_cov: ArrayLike,
    model: str = "local-variable",
    *,
    group: LieGroup,
) -> tuple[NDArray, NDArray]:
    """The mean x(τ) and its covariance (in the right tangent at x(τ)), t₁ < τ < t₂: the group form of
    ``gp.interpolate_covariance``, which gives the covariance alone.

    ``joint_cov`` (4d, 4d) is the covariance of [δ₁; δ₂], the right tangents at x₁ and x₂. To first
    order δ(τ) = J₁ δ₁ + J₂ δ₂ + N w, w ~ N(0, Q_c(τ)) the local GP's own conditional noise (that of
    ``gp.interpolate_covariance`` with no state uncertainty), so Cov = J P Jᵀ + N Q_c(τ) Nᵀ.
    """
    model = check_model(model)
    n, d = group.size, group.dim
    lam, psi = interpolation_matrices(t1, t2, tau, qc)
    x, J1, J2 = interpolate(x1, x2, lam, psi, model, group=group)
    gamma2 = local_variables(x1, x2, model, group=group, jacobians=False)
    gamma = np.concatenate([np.zeros(d), x1[n:]]) @ lam.T + gamma2 @ psi.T
    _, N, _ = _from_local(x1, gamma, model, group)
    J = np.hstack([J1, J2])
    t1, t2, tau = float(t1), float(t2), float(tau)  # (checked by interpolation_matrices: t₁ < τ < t₂)
    qc = check_qc(qc)
    cond = conditional_covariance(process_noise(tau - t1, qc), transition(t2 - tau, d), process_noise(t2 - tau, qc))
    P = check_covariance("joint_cov", real_array("joint_cov", joint_cov), 4 * d)
    cov = J @ P @ J.T + N @ cond @ N.T  # [DER 11.17]
    return x, (cov + cov.T) / 2


def _after(t1: float, t: float) -> float:
    t1, t = number("t1", t1), number("t", t)
    if not t > t1:
        raise SteamError(f"extrapolation needs a finite t > t1, got t1={t1}, t={t}")
    return t - t1


def _ahead(x1: NDArray, s: float, group: LieGroup) -> NDArray:
    """γ(t) = Φ(s) γ₁ = [s ϖ₁; ϖ₁] for γ₁ = [0; ϖ₁].  [YIB Eq. 22]"""
    w1 = x1[..., group.size :]
    return np.concatenate([s * w1, w1], axis=-1)


def extrapolate(x1: NDArray, t1: float, t: float, *, group: LieGroup) -> tuple[NDArray, NDArray]:
    """The prediction x(t) = (T₁ Exp((t - t₁) ϖ₁), ϖ₁) after the last state, and ∂x(t)/∂x₁.

    Past the last state nothing constrains the noise, so the mean follows γ(t) = Φ(t - t₁) γ₁ =
    [(t - t₁) ϖ₁; ϖ₁] [YIB Eq. 22]; the twist stays ϖ₁ (J_r(sϖ) ϖ = ϖ). Either model gives the same.
    """
    s = _after(t1, t)
    x1 = np.asarray(x1, dtype=float)
    d = group.dim
    x, N, ad = _from_local(x1, _ahead(x1, s, group), "local-variable", group)
    dgamma = np.zeros(x1.shape[:-1] + (2 * d, 2 * d))
    dgamma[..., :d, d:], dgamma[..., d:, d:] = s * np.eye(d), np.eye(d)
    J = N @ dgamma
    J[..., :d, :d] += ad
    return x, J


def extrapolate_covariance(
    x1: NDArray,
    t1: float,
    t: float,
    qc: NDArray,
    cov1: ArrayLike,
    model: str = "local-variable",
    *,
    group: LieGroup,
) -> tuple[NDArray, NDArray]:
    """The prediction x(t) after the last state and its covariance J P₁ Jᵀ + N Q(t - t₁) Nᵀ, N = ∂x(t)/∂γ(t) of
    ``model`` (the mean and J are either model's; N's twist rows are not: ϖ = J_r(ξ) ξ̇, or ξ̇).  [YIB Eq. 17, 22]"""
    model = check_model(model)
    x, J = extrapolate(x1, t1, t, group=group)
    s = _after(t1, t)
    P = check_covariance("cov1", real_array("cov1", cov1), 2 * group.dim)
    _, N, _ = _from_local(np.asarray(x1, dtype=float), _ahead(np.asarray(x1, dtype=float), s, group), model, group)
    cov = J @ P @ J.T + N @ process_noise(s, check_qc(qc)) @ N.T  # [DER 11.18; YIB Eq. 17]
    return x, (cov + cov.T) / 2
