"""The WNOA GP on SE(2) through local variables, after Anderson & Barfoot 2015.  [AB15; DER 11.10-11.18]

Between two states x₁ = (T₁, ϖ₁) at t₁ and x₂ = (T₂, ϖ₂) at t₂, the trajectory is written in the
local variable ξ(t) = Log(T₁⁻¹ T(t)), whose derivative is ξ̇ = J_r(ξ)⁻¹ ϖ (Ṫ = T ϖ^). The local
state γ(t) = [ξ(t); ξ̇(t)] follows the vector-space WNOA prior of [YIB Eq. 30-31], so

    γ₁ = [0; ϖ₁],   γ₂ = [ξ₂₁; J_r(ξ₂₁)⁻¹ ϖ₂],   ξ₂₁ = Log(T₁⁻¹ T₂)              [DER 11.10]

and the prior's residual is e = γ₂ - Φ(Δt) γ₁ = [ξ₂₁ - Δt ϖ₁; J_r(ξ₂₁)⁻¹ ϖ₂ - ϖ₁] with the
vector-space Q(Δt) ("local-variable": GTSAM 4.3 ``WnoaMotionFactorPose2``, STEAM ``const_vel_se2``).
The "simplified" model takes ξ̇ ≈ ϖ, γ₂ = [ξ₂₁; ϖ₂] (gpslam ``GaussianProcessPriorPose2``, Theseus).
The mean at τ is γ(τ) = Λ(τ) γ₁ + Ψ(τ) γ₂ [YIB Eq. 18], mapped back: T(τ) = T₁ Exp(ξ(τ)),
ϖ(τ) = J_r(ξ(τ)) ξ̇(τ) (simplified: ϖ(τ) = ξ̇(τ)). Every Jacobian here is with respect to the right
tangents of the states (``steam_ref.lie.state``), exact; derivations in [DER 11.10-11.18].
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arguments import check_covariance, number, real_array
from ..errors import SteamError
from ..gp.interpolate import interpolate_covariance, interpolation_matrices
from ..gp.prior import check_qc, process_noise
from . import se2

__all__ = [
    "MODELS",
    "check_model",
    "local_variables",
    "interpolate",
    "interpolate_covariance_se2",
    "extrapolate",
    "extrapolate_covariance_se2",
]

MODELS = ("local-variable", "simplified")


def check_model(model: object) -> str:
    """The name of an SE(2) WNOA model, or SteamError naming the choices."""
    if model not in MODELS:
        raise SteamError(f"model must be one of {', '.join(repr(m) for m in MODELS)}, got model={model!r}")
    return str(model)


def _mm(a: NDArray, b: NDArray) -> NDArray:
    return np.einsum("...ij,...jk->...ik", a, b)


def _mv(a: NDArray, v: NDArray) -> NDArray:
    return np.einsum("...ij,...j->...i", a, v)


def _blocks(tl: NDArray, tr: NDArray, bl: NDArray, br: NDArray) -> NDArray:
    return np.concatenate([np.concatenate([tl, tr], axis=-1), np.concatenate([bl, br], axis=-1)], axis=-2)


def local_variables(x1: NDArray, x2: NDArray, model: str) -> tuple[NDArray, NDArray, NDArray]:
    """γ₂ = [ξ₂₁; J_r(ξ₂₁)⁻¹ ϖ₂] in the frame of T₁ (simplified: [ξ₂₁; ϖ₂]), with ∂γ₂/∂x₁, ∂γ₂/∂x₂.

    ∂ξ₂₁/∂δT₁ = -J_r(ξ₂₁)⁻¹ Ad(Exp(-ξ₂₁)), ∂ξ₂₁/∂δT₂ = J_r(ξ₂₁)⁻¹ [DER 11.13];
    ∂(J_r(ξ)⁻¹ ϖ₂)/∂ξ is exact (``se2.jr_inverse_times_jacobian``). Shapes (..., 6), (..., 6, 6) twice.
    """
    T1, T2, w2 = x1[..., :3], x2[..., :3], x2[..., 3:]
    rel = se2.between(T1, T2)
    xi = se2.log(rel)  # ξ₂₁ = Log(T₁⁻¹ T₂)  [DER 11.10]
    jinv = se2.right_jacobian_inverse(xi)
    d1 = -_mm(jinv, se2.adjoint(se2.inverse(rel)))  # ∂ξ/∂δT₁
    zero = np.zeros(xi.shape + (3,))
    if model == "local-variable":
        velocity = _mv(jinv, w2)  # ξ̇(t₂) = J_r(ξ₂₁)⁻¹ ϖ₂  [DER 11.10]
        G = se2.jr_inverse_times_jacobian(xi, w2)  # [DER 11.6, 11.13]
        dv1, dv2, dw2 = _mm(G, d1), _mm(G, jinv), jinv
    else:
        velocity, dv1, dv2 = w2, zero, zero
        dw2 = np.broadcast_to(np.eye(3), zero.shape)
    gamma = np.concatenate([xi, velocity], axis=-1)
    return gamma, _blocks(d1, zero, dv1, zero), _blocks(jinv, zero, dv2, dw2)


def _from_local(x1: NDArray, gamma: NDArray, model: str) -> tuple[NDArray, NDArray, NDArray]:
    """The state at γ = [ξ; ξ̇] in the frame of T₁: (T₁ Exp ξ, J_r(ξ) ξ̇); N = ∂[δT; dϖ]/∂γ and Ad(Exp(-ξ))."""
    xi, xidot = gamma[..., :3], gamma[..., 3:]
    jr = se2.right_jacobian(xi)
    pose = se2.compose(x1[..., :3], se2.exp(xi))  # T(τ) = T₁ Exp(ξ(τ))  [DER 11.10]
    zero = np.zeros(xi.shape + (3,))
    if model == "local-variable":
        twist = _mv(jr, xidot)  # ϖ(τ) = J_r(ξ(τ)) ξ̇(τ)  [DER 11.10]
        N = _blocks(jr, zero, se2.jr_times_jacobian(xi, xidot), jr)
    else:
        twist = xidot
        N = _blocks(jr, zero, zero, np.broadcast_to(np.eye(3), zero.shape))
    ad = se2.adjoint(se2.inverse(se2.exp(xi)))  # T₁ Exp(δ) Exp(ξ) = T₁ Exp(ξ) Exp(Ad(Exp(-ξ)) δ)
    return np.concatenate([pose, twist], axis=-1), N, ad


def interpolate(
    x1: NDArray, x2: NDArray, lam: NDArray, psi: NDArray, model: str = "local-variable"
) -> tuple[NDArray, NDArray, NDArray]:
    """The mean x(τ) between x₁ and x₂ and its Jacobians ∂x(τ)/∂x₁, ∂x(τ)/∂x₂ (right tangents).

    Λ(τ), Ψ(τ) are the vector-space WNOA interpolation matrices of [YIB Eq. 16] (``gp.interpolation_matrices``).
    γ(τ) = Λ γ₁ + Ψ γ₂ [YIB Eq. 18; DER 11.15]; dγ(τ) = Λ dγ₁ + Ψ dγ₂; then δ(τ) = Ad(Exp(-ξ(τ))) δT₁ + N dγ(τ).
    """
    x1, x2 = np.asarray(x1, dtype=float), np.asarray(x2, dtype=float)
    gamma2, g21, g22 = local_variables(x1, x2, model)
    gamma1 = np.concatenate([np.zeros(x1.shape[:-1] + (3,)), x1[..., 3:]], axis=-1)  # γ₁ = [0; ϖ₁]
    gamma = _mv(lam, gamma1) + _mv(psi, gamma2)  # [YIB Eq. 18]
    x, N, ad = _from_local(x1, gamma, model)
    e1 = np.zeros(x1.shape + (6,))
    e1[..., 3:, 3:] = np.eye(3)  # ∂γ₁/∂x₁
    J1 = _mm(N, _mm(lam, e1) + _mm(psi, g21))  # [DER 11.16]
    J1[..., :3, :3] += ad
    return x, J1, _mm(N, _mm(psi, g22))  # [DER 11.16]


def _joint(name: str, joint_cov: ArrayLike) -> NDArray:
    return check_covariance(name, real_array(name, joint_cov), 12)


def interpolate_covariance_se2(
    t1: float,
    t2: float,
    tau: float,
    qc: NDArray,
    x1: NDArray,
    x2: NDArray,
    joint_cov: ArrayLike,
    model: str = "local-variable",
) -> tuple[NDArray, NDArray]:
    """The mean x(τ) and its covariance (in the right tangent at x(τ)), t₁ < τ < t₂.

    ``joint_cov`` (12, 12) is the covariance of [δ₁; δ₂], the right tangents at x₁ and x₂. To first
    order δ(τ) = J₁ δ₁ + J₂ δ₂ + N w, w ~ N(0, Q_c(τ)) the local GP's own conditional noise (that of
    ``gp.interpolate_covariance`` with no state uncertainty), so Cov = J P Jᵀ + N Q_c(τ) Nᵀ.
    """
    model = check_model(model)
    lam, psi = interpolation_matrices(t1, t2, tau, qc)
    x, J1, J2 = interpolate(x1, x2, lam, psi, model)
    gamma = np.concatenate([np.zeros(3), x1[3:]]) @ lam.T + local_variables(x1, x2, model)[0] @ psi.T
    _, N, _ = _from_local(x1, gamma, model)
    J = np.hstack([J1, J2])
    cond = interpolate_covariance(t1, t2, tau, qc, np.zeros((12, 12)))  # Cov(γ(τ) | γ₁, γ₂)
    cov = J @ _joint("joint_cov", joint_cov) @ J.T + N @ cond @ N.T  # [DER 11.17]
    return x, (cov + cov.T) / 2


def _after(t1: float, t: float) -> float:
    t1, t = number("t1", t1), number("t", t)
    if not t > t1:
        raise SteamError(f"extrapolation needs a finite t > t1, got t1={t1}, t={t}")
    return t - t1


def extrapolate(x1: NDArray, t1: float, t: float) -> tuple[NDArray, NDArray]:
    """The prediction x(t) = (T₁ Exp((t - t₁) ϖ₁), ϖ₁) after the last state, and ∂x(t)/∂x₁.

    Past the last state nothing constrains the noise, so the mean follows γ(t) = Φ(t - t₁) γ₁ =
    [(t - t₁) ϖ₁; ϖ₁] [YIB Eq. 22]; the twist stays ϖ₁ (J_r(sϖ) ϖ = ϖ). Either model gives the same.
    """
    s = _after(t1, t)
    x1 = np.asarray(x1, dtype=float)
    gamma = np.concatenate([s * x1[..., 3:], x1[..., 3:]], axis=-1)  # Φ(s) [0; ϖ₁]  [YIB Eq. 22]
    x, N, ad = _from_local(x1, gamma, "local-variable")
    dgamma = np.zeros(x1.shape + (6,))
    dgamma[..., :3, 3:], dgamma[..., 3:, 3:] = s * np.eye(3), np.eye(3)
    J = _mm(N, dgamma)
    J[..., :3, :3] += ad
    return x, J


def extrapolate_covariance_se2(
    x1: NDArray, t1: float, t: float, qc: NDArray, cov1: ArrayLike
) -> tuple[NDArray, NDArray]:
    """The prediction x(t) after the last state and its covariance J P₁ Jᵀ + N Q(t - t₁) Nᵀ.  [YIB Eq. 17, 22]"""
    x, J = extrapolate(x1, t1, t)
    s = _after(t1, t)
    P = check_covariance("cov1", real_array("cov1", cov1), 6)
    _, N, _ = _from_local(x1, np.concatenate([s * x1[3:], x1[3:]]), "local-variable")
    cov = J @ P @ J.T + N @ process_noise(s, check_qc(qc)) @ N.T  # [DER 11.18; YIB Eq. 17]
    return x, (cov + cov.T) / 2
