"""GP interpolation between two estimated states, [YIB Eq. 12, 16, 18], and prediction after the last.

For t₁ < τ < t₂ the posterior mean at τ depends on the two neighbouring states only:

    x̄(τ) = μ(τ) + [Λ(τ) Ψ(τ)] ([x̄₁; x̄₂] - [μ₁; μ₂])                       [YIB Eq. 18]

With the zero-mean WNOA prior used throughout the paper (v(t) = 0, so μ = 0) this is linear.
The ``*_sde`` functions do the same for any ``LinearSDE`` (A, F, Qc, v), and
``interpolate_covariance`` adds the posterior covariance at τ, which the paper does not give.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from ..errors import ShapeError, SteamError
from .prior import _read_only, check_qc, process_noise, process_noise_inverse, qc_key, transition
from .sde import LinearSDE

__all__ = [
    "interpolation_matrices",
    "interpolate_state",
    "interpolate_covariance",
    "interpolation_matrices_sde",
    "interpolate_state_sde",
    "interpolate_covariance_sde",
    "extrapolate_state_sde",
    "extrapolate_covariance_sde",
]


def _check_tau(t1: float, t2: float, tau: float) -> None:
    if not (t1 < tau < t2):
        raise SteamError(f"interpolation needs t1 < tau < t2, got t1={t1}, tau={tau}, t2={t2}")


def _state(name: str, x: ArrayLike, n: int) -> NDArray:
    x = np.asarray(x, dtype=float)
    if x.shape != (n,) or not np.all(np.isfinite(x)):
        raise ShapeError(f"{name} must be a finite ({n},) vector, got shape {x.shape}")
    return x


def interpolation_matrices(t1: float, t2: float, tau: float, qc: NDArray) -> tuple[NDArray, NDArray]:
    """Λ(τ) and Ψ(τ) of the WNOA prior, each (2d, 2d).  [YIB Eq. 16]

    Λ(τ) = Φ(τ, t₁) - Q_τ Φ(t₂, τ)ᵀ Q₂⁻¹ Φ(t₂, t₁)
    Ψ(τ) = Q_τ Φ(t₂, τ)ᵀ Q₂⁻¹
    where Q_τ = Q(τ - t₁) and Q₂ = Q(t₂ - t₁) are the integrals of [YIB Eq. 17].
    The pair depends only on (τ - t₁, t₂ - t₁, Qc); it is memoised on those, and read-only.
    """
    _check_tau(t1, t2, tau)
    return _interpolation_matrices(float(tau - t1), float(t2 - t1), *qc_key(qc))


@lru_cache(maxsize=4096)
def _interpolation_matrices(dtau: float, dt: float, d: int, qc_bytes: bytes) -> tuple[NDArray, NDArray]:
    qc = np.frombuffer(qc_bytes, dtype=float).reshape(d, d)
    q_tau = process_noise(dtau, qc)
    q2_inv = process_noise_inverse(dt, qc)
    psi = q_tau @ transition(dt - dtau, d).T @ q2_inv  # [YIB Eq. 16]
    lam = transition(dtau, d) - psi @ transition(dt, d)  # [YIB Eq. 16]
    _read_only(lam, psi)
    return lam, psi


def interpolate_state(
    t1: float, x1: NDArray, t2: float, x2: NDArray, tau: float, qc: NDArray
) -> NDArray:
    """x̄(τ) from the neighbouring estimates x̄(t₁), x̄(t₂) of the zero-mean WNOA prior.  [YIB Eq. 18]"""
    lam, psi = interpolation_matrices(t1, t2, tau, qc)
    n = lam.shape[0]
    return lam @ _state("x1", x1, n) + psi @ _state("x2", x2, n)  # [YIB Eq. 18]


def _posterior_covariance(
    lam: NDArray, psi: NDArray, q_tau: NDArray, phi_2tau: NDArray, joint_cov: ArrayLike
) -> NDArray:
    """[Λ Ψ] P [Λ Ψ]ᵀ + Q_τ - Ψ Φ(t₂, τ) Q_τ, symmetrised: (n, n). See interpolate_covariance."""
    n = lam.shape[0]
    P = np.asarray(joint_cov, dtype=float)
    if P.shape != (2 * n, 2 * n) or not np.all(np.isfinite(P)):
        raise ShapeError(f"joint_cov must be a finite ({2 * n}, {2 * n}) matrix, got shape {P.shape}")
    G = np.hstack([lam, psi])
    cond = q_tau - psi @ phi_2tau @ q_tau  # Cov(x(τ) | x₁, x₂) = Q_τ - Q_τ Φ(t₂,τ)ᵀ Q₂⁻¹ Φ(t₂,τ) Q_τ
    cov = G @ P @ G.T + cond  # law of total covariance
    return (cov + cov.T) / 2


def interpolate_covariance(t1: float, t2: float, tau: float, qc: NDArray, joint_cov: ArrayLike) -> NDArray:
    """Posterior covariance of x(τ), t₁ < τ < t₂, for the WNOA prior: (2d, 2d).

    joint_cov is the (4d, 4d) joint posterior covariance P of [x(t₁); x(t₂)]. Then

        Cov x(τ) = [Λ Ψ] P [Λ Ψ]ᵀ + Q_τ - Q_τ Φ(t₂, τ)ᵀ Q₂⁻¹ Φ(t₂, τ) Q_τ

    with Λ, Ψ of [YIB Eq. 16], Q_τ = Q(τ - t₁), Q₂ = Q(t₂ - t₁). Not in the paper; derivation:

    1. The SDE is Markov, so given x₁ = x(t₁) and x₂ = x(t₂) the prior of x(τ) ignores every
       other state. Given x₁: x(τ) = Φ(τ,t₁) x₁ + v_τ + w_τ with w_τ ~ N(0, Q_τ), and
       x₂ = Φ(t₂,τ) x(τ) + v' + w' with w' ~ N(0, Q(t₂ - τ)) independent of w_τ. Hence
       Cov(x(τ), x₂ | x₁) = Q_τ Φ(t₂,τ)ᵀ and Cov(x₂ | x₁) = Φ(t₂,τ) Q_τ Φ(t₂,τ)ᵀ + Q(t₂-τ) = Q₂.
    2. Conditioning that Gaussian on x₂ gives E[x(τ) | x₁, x₂] = μ(τ) + [Λ Ψ]([x₁; x₂] - [μ₁; μ₂])
       (this is [YIB Eq. 18]) and Cov(x(τ) | x₁, x₂) = Q_τ - Q_τ Φ(t₂,τ)ᵀ Q₂⁻¹ Φ(t₂,τ) Q_τ.
    3. If no measurement involves x(τ) except through the states (so y and x(τ) are independent
       given the states), the posterior of x(τ) is this conditional averaged over the posterior
       N(x̄, P) of [x₁; x₂]. The law of total covariance, Cov = E[Cov(· | x₁,x₂)] + Cov(E[· | x₁,x₂]),
       gives the formula above.

    When measurements at τ are folded in through [Λ Ψ] as in [YIB Eq. 29], step 3 treats them the
    same way the estimator does, so the result is the covariance consistent with that estimate.
    """
    _check_tau(t1, t2, tau)
    qc = check_qc(qc)
    lam, psi = interpolation_matrices(t1, t2, tau, qc)
    q_tau = process_noise(tau - t1, qc)  # [YIB Eq. 17]
    return _posterior_covariance(lam, psi, q_tau, transition(t2 - tau, qc.shape[0]), joint_cov)


def interpolation_matrices_sde(sde: LinearSDE, t1: float, t2: float, tau: float) -> tuple[NDArray, NDArray]:
    """Λ(τ) and Ψ(τ) for any LinearSDE, each (n, n).  [YIB Eq. 16]

    Same formula as ``interpolation_matrices`` with Φ = expm and Q from Van Loan; Q₂⁻¹ is
    applied by a Cholesky solve.
    """
    _check_tau(t1, t2, tau)
    q_tau = sde.process_noise(tau - t1)  # [YIB Eq. 17]
    q2 = scipy.linalg.cho_factor(sde.process_noise(t2 - t1))  # [YIB Eq. 17]
    psi = scipy.linalg.cho_solve(q2, sde.transition(t2 - tau) @ q_tau).T  # Q_τ Φ(t₂,τ)ᵀ Q₂⁻¹  [YIB Eq. 16]
    lam = sde.transition(tau - t1) - psi @ sde.transition(t2 - t1)  # [YIB Eq. 16]
    return lam, psi


def interpolate_state_sde(
    sde: LinearSDE, t1: float, x1: ArrayLike, t2: float, x2: ArrayLike, tau: float
) -> NDArray:
    """x̄(τ) from the estimates x̄(t₁), x̄(t₂), including the mean of the SDE: (n,).  [YIB Eq. 18]

    x̄(τ) = μ(τ) + [Λ Ψ]([x̄₁; x̄₂] - [μ₁; μ₂]). The mean obeys μ(τ) = Φ(τ,t₁) μ₁ + v_τ and
    μ₂ = Φ(t₂,t₁) μ₁ + v₂ with v_τ, v₂ of [YIB Eq. 23], so by [YIB Eq. 16]
    μ(τ) - Λ μ₁ - Ψ μ₂ = v_τ - Ψ v₂ whatever μ₁ is: the result needs no μ(t₀).
    """
    lam, psi = interpolation_matrices_sde(sde, t1, t2, tau)
    x1, x2 = _state("x1", x1, sde.n), _state("x2", x2, sde.n)
    v_tau, v_2 = sde.input_integral(tau - t1), sde.input_integral(t2 - t1)  # [YIB Eq. 23]
    return v_tau + lam @ x1 + psi @ (x2 - v_2)  # [YIB Eq. 18] with μ₁ = 0, μ(τ) = v_τ, μ₂ = v₂


def interpolate_covariance_sde(
    sde: LinearSDE, t1: float, t2: float, tau: float, joint_cov: ArrayLike
) -> NDArray:
    """Posterior covariance of x(τ) for any LinearSDE; joint_cov is (2n, 2n): (n, n).

    Cov x(τ) = [Λ Ψ] P [Λ Ψ]ᵀ + Q_τ - Q_τ Φ(t₂,τ)ᵀ Q₂⁻¹ Φ(t₂,τ) Q_τ; derivation in
    ``interpolate_covariance``. The input v shifts means only, not covariances.
    """
    lam, psi = interpolation_matrices_sde(sde, t1, t2, tau)
    q_tau = sde.process_noise(tau - t1)  # [YIB Eq. 17]
    return _posterior_covariance(lam, psi, q_tau, sde.transition(t2 - tau), joint_cov)


# --- beyond the last state: prediction by the prior ---------------------------------------------


def _check_after(t1: float, t: float) -> float:
    t1, t = float(t1), float(t)
    if not t > t1 or not np.isfinite(t):
        raise SteamError(f"extrapolation needs a finite t > t1, got t1={t1}, t={t}")
    return t - t1


def extrapolate_state_sde(sde: LinearSDE, t1: float, x1: ArrayLike, t: float) -> NDArray:
    """x̄(t) = Φ(t, t₁) x̄₁ + v(t, t₁) for t > t₁, the last state: (n,).  [YIB Eq. 22-23]

    With no state after t₁, nothing measured constrains the noise w(s), s > t₁, which is
    independent of everything up to t₁; so the posterior mean of x(t) is the prior's prediction
    from the posterior mean x̄₁ of x(t₁). Derivation: docs/derivations.md, section 7.
    """
    dt = _check_after(t1, t)
    return sde.transition(dt) @ _state("x1", x1, sde.n) + sde.input_integral(dt)  # [YIB Eq. 22-23]


def extrapolate_covariance_sde(sde: LinearSDE, t1: float, t: float, cov1: ArrayLike) -> NDArray:
    """Cov x(t) = Φ(t, t₁) P₁ Φ(t, t₁)ᵀ + Q(t - t₁) for t > t₁, P₁ (n, n) the last state's: (n, n).  [YIB Eq. 17, 22]"""
    dt = _check_after(t1, t)
    P = np.asarray(cov1, dtype=float)
    if P.shape != (sde.n, sde.n) or not np.all(np.isfinite(P)):
        raise ShapeError(f"cov1 must be a finite ({sde.n}, {sde.n}) matrix, got shape {P.shape}")
    Phi = sde.transition(dt)
    cov = Phi @ P @ Phi.T + sde.process_noise(dt)  # [YIB Eq. 17, 22]
    return (cov + cov.T) / 2
