"""GP interpolation between two estimated states, [YIB Eq. 12, 16, 18].

For t₁ < τ < t₂ the posterior mean at τ depends on the two neighbouring states only:

    x̄(τ) = μ(τ) + [Λ(τ) Ψ(τ)] ([x̄₁; x̄₂] - [μ₁; μ₂])                       [YIB Eq. 18]

With the zero-mean WNOA prior used throughout the paper (v(t) = 0, so μ = 0) this is linear.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..errors import SteamError
from .prior import check_qc, process_noise, process_noise_inverse, transition

__all__ = ["interpolation_matrices", "interpolate_state"]


def interpolation_matrices(t1: float, t2: float, tau: float, qc: NDArray) -> tuple[NDArray, NDArray]:
    """Λ(τ) and Ψ(τ) of the WNOA prior, each (2d, 2d).  [YIB Eq. 16]

    Λ(τ) = Φ(τ, t₁) - Q_τ Φ(t₂, τ)ᵀ Q₂⁻¹ Φ(t₂, t₁)
    Ψ(τ) = Q_τ Φ(t₂, τ)ᵀ Q₂⁻¹
    where Q_τ = Q(τ - t₁) and Q₂ = Q(t₂ - t₁) are the integrals of [YIB Eq. 17].
    """
    if not (t1 < tau < t2):
        raise SteamError(f"interpolation needs t1 < tau < t2, got t1={t1}, tau={tau}, t2={t2}")
    qc = check_qc(qc)
    d = qc.shape[0]
    q_tau = process_noise(tau - t1, qc)
    q2_inv = process_noise_inverse(t2 - t1, qc)
    psi = q_tau @ transition(t2 - tau, d).T @ q2_inv  # [YIB Eq. 16]
    lam = transition(tau - t1, d) - psi @ transition(t2 - t1, d)  # [YIB Eq. 16]
    return lam, psi


def interpolate_state(
    t1: float, x1: NDArray, t2: float, x2: NDArray, tau: float, qc: NDArray
) -> NDArray:
    """x̄(τ) from the neighbouring estimates x̄(t₁), x̄(t₂) of the zero-mean WNOA prior.  [YIB Eq. 18]"""
    lam, psi = interpolation_matrices(t1, t2, tau, qc)
    return lam @ np.asarray(x1, float) + psi @ np.asarray(x2, float)
