"""GP interpolation between two estimated states, [YIB Eq. 12, 16, 18], and prediction after the last.

For t₁ < τ < t₂ the posterior mean at τ depends on the two neighbouring states only:

    x̄(τ) = μ(τ) + [Λ(τ) Ψ(τ)] ([x̄₁; x̄₂] - [μ₁; μ₂])                       [YIB Eq. 18]

With the zero-mean WNOA prior used throughout the paper (v(t) = 0, so μ = 0) this is linear.
The ``*_sde`` functions do the same for any ``LinearSDE`` (A, F, Qc, v), and
``interpolate_covariance`` adds the posterior covariance at τ, which the paper does not give.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache
from typing import TypeVar

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import lapack

from ..arguments import check_covariance, finite, number, real_array
from ..errors import NumericalError, ShapeError, SteamError
from .prior import (
    check_qc,
    finite_result,
    process_noise,
    process_noise_inverse,
    process_noise_inverse_many,
    process_noise_many,
    qc_key,
    read_only,
    transition,
    transition_many,
)
from .sde import LinearSDE

__all__ = [
    "interpolation_matrices",
    "interpolation_matrices_many",
    "interpolate_state",
    "interpolate_covariance",
    "conditional_covariance",
    "interpolation_matrices_sde",
    "interpolation_terms",
    "interpolate_state_sde",
    "interpolate_covariance_sde",
    "extrapolate_state_sde",
    "extrapolate_covariance_sde",
]

Steps = TypeVar("Steps", float, NDArray)  # one τ's time steps, or a stack's


def _check_tau(t1: float, t2: float, tau: float) -> tuple[float, float, float]:
    """(t1, t2, tau) as finite floats with t1 < tau < t2."""
    t1, t2, tau = number("t1", t1), number("t2", t2), number("tau", tau)
    if not (t1 < tau < t2):
        raise SteamError(f"interpolation needs t1 < tau < t2, got t1={t1}, tau={tau}, t2={t2}")
    return t1, t2, tau


def _state(name: str, x: ArrayLike, n: int) -> NDArray:
    x = real_array(name, x)
    if x.shape != (n,):
        raise ShapeError(f"{name} must be a finite ({n},) vector, got shape {x.shape}")
    return finite(name, x)


def interpolation_matrices(t1: float, t2: float, tau: float, qc: NDArray) -> tuple[NDArray, NDArray]:
    """Λ(τ) and Ψ(τ) of the WNOA prior, each (2d, 2d).  [YIB Eq. 16]

    Λ(τ) = Φ(τ, t₁) - Q_τ Φ(t₂, τ)ᵀ Q₂⁻¹ Φ(t₂, t₁)
    Ψ(τ) = Q_τ Φ(t₂, τ)ᵀ Q₂⁻¹
    where Q_τ = Q(τ - t₁) and Q₂ = Q(t₂ - t₁) are the integrals of [YIB Eq. 17], formed as :func:`_lambda_psi` says
    (each entry to its relative precision next to either state). The pair depends only on (τ - t₁, t₂ - τ, t₂ - t₁,
    Qc); it is memoised on those, and read-only.
    """
    t1, t2, tau = _check_tau(t1, t2, tau)
    return _interpolation_matrices(tau - t1, t2 - tau, t2 - t1, *qc_key(qc))


@lru_cache(maxsize=4096)
def _interpolation_matrices(dtau: float, rest: float, dt: float, d: int, qc_bytes: bytes) -> tuple[NDArray, NDArray]:
    qc = np.frombuffer(qc_bytes, dtype=float).reshape(d, d)
    lam, psi = _lambda_psi(
        dtau,
        rest,
        dt,
        lambda t: process_noise(t, qc),
        lambda t: transition(t, d),
        _times(process_noise_inverse(dt, qc)),
    )
    finite_result("Λ(τ), Ψ(τ)", np.hstack([lam, psi]), tau_minus_t1=dtau, t2_minus_t1=dt)
    read_only(lam, psi)
    return lam, psi


def interpolation_matrices_many(t1: ArrayLike, t2: ArrayLike, tau: ArrayLike, qc: NDArray) -> tuple[NDArray, NDArray]:
    """Λ(τᵢ) and Ψ(τᵢ) of :func:`interpolation_matrices` for many times at once, t1ᵢ < τᵢ < t2ᵢ (``t1``, ``t2``
    numbers or arrays broadcast against ``tau`` (n,)): each (n, 2d, 2d), read-only.  [YIB Eq. 16]

    The readings between two states (a gyro at 100 Hz between GPS fixes) each have their own τ, so no memo helps:
    one call forms them all."""
    tau = real_array("tau", tau)
    if tau.ndim != 1:  # a scalar or a table: its entries may all lie inside, so say the shape, not an entry
        raise ShapeError(f"tau must be a vector of times (n,), got shape {tau.shape}")
    try:
        t1, t2 = (np.broadcast_to(real_array(n, t), tau.shape) for n, t in (("t1", t1), ("t2", t2)))
    except ValueError:
        raise ShapeError(f"t1 and t2 must be numbers or arrays of tau's shape {tau.shape}") from None
    bad = ~((t1 < tau) & (tau < t2))  # true for NaN too
    if bad.any():
        i = int(np.argmax(bad))
        raise SteamError(
            f"interpolation needs t1 < tau < t2 at every time, got at {i}: t1={t1[i]}, tau={tau[i]}, t2={t2[i]}"
        )
    qc = check_qc(qc)
    d, dtau, rest, dt = qc.shape[0], tau - t1, t2 - tau, t2 - t1
    lam, psi = np.empty((2, len(tau), 2 * d, 2 * d))
    first = np.asarray(_nearer_t1(dtau, rest, 0.0))
    for rows in (first, ~first):  # the same formula, each side as one stack
        if rows.any():
            lam[rows], psi[rows] = _lambda_psi(
                dtau[rows], rest[rows], dt[rows], lambda t: process_noise_many(t, qc),
                lambda t: transition_many(t, d), _times(process_noise_inverse_many(dt[rows], qc)),
            )  # fmt: skip
    bad = ~np.isfinite(lam).all(axis=(1, 2)) | ~np.isfinite(psi).all(axis=(1, 2))
    if bad.any():
        i = int(np.argmax(bad))
        finite_result("Λ(τ), Ψ(τ)", np.hstack([lam[i], psi[i]]), tau_minus_t1=dtau[i], t2_minus_t1=dt[i])
    read_only(lam, psi)
    return lam, psi


def _times(right: NDArray) -> Callable[[NDArray], NDArray]:
    """M ↦ M right, M one matrix or a stack."""
    return lambda m: m @ right


def _nearer_t1(dtau: Steps, rest: Steps, decay_rate: float) -> bool | NDArray:
    """Where :func:`_lambda_psi` forms Ψ as a product: τ - t₁ ≤ t₂ - τ, or Φ(τ, t₂) would amplify by more than
    e^{1/2} (``decay_rate``: ``LinearSDE.decay_rate``, Singer's α; 0 for WNOA)."""
    return (dtau <= rest) | (decay_rate * rest > 0.5)


def _lambda_psi(
    dtau: Steps,
    rest: Steps,
    dt: Steps,
    noise: Callable[[Steps], NDArray],
    phi: Callable[[Steps], NDArray],
    times_q2_inv: Callable[[NDArray], NDArray],
    decay_rate: float = 0.0,
) -> tuple[NDArray, NDArray]:
    """Λ(τ) and Ψ(τ) of [YIB Eq. 16] from τ - t₁, t₂ - τ and t₂ - t₁ (floats, or (n,) arrays all on the same side of
    the middle), with ``noise`` giving Q, ``phi`` Φ of a step (negative ones too) and ``times_q2_inv`` M ↦ M Q₂⁻¹:
    each entry to its relative precision at every τ, next to either state too, but where the entry itself changes
    sign inside the interval (WNOA's Λ₂₂ = (1 - u)(1 - 3u), u = (τ - t₁)/(t₂ - t₁)): there, to the matrix's scale
    (derivations §3).

    Q₂ = Φ(t₂, τ) Q_τ Φ(t₂, τ)ᵀ + Q(t₂ - τ) splits Φ(τ, t₂) = Φ(t₂, τ)⁻¹ in two parts,

        Ψ = Q_τ Φ(t₂, τ)ᵀ Q₂⁻¹,   G = Φ(τ, t₂) Q(t₂ - τ) Q₂⁻¹,   Ψ + G = Φ(τ, t₂),   Λ = G Φ(t₂, t₁);

    the one that is small at τ is formed as a product: Ψ where τ - t₁ ≤ t₂ - τ (then Λ = Φ(τ, t₁) - Ψ Φ(t₂, t₁)),
    G elsewhere (then Ψ = Φ(τ, t₂) - G). Each difference is then of a matrix and a small correction, never of two
    nearly equal ones. Φ(τ, t₂) grows as e^{α(t₂ - τ)} for Singer's model, and G with it: Ψ is the product also where
    α (t₂ - τ) > 1/2 (:func:`_nearer_t1`), so Φ(τ, t₂) is formed only where it stays near Φ(t₂, τ)⁻¹'s size 1."""
    with np.errstate(over="ignore", invalid="ignore"):
        nearer_t1 = _nearer_t1(dtau, rest, decay_rate)
        if nearer_t1 if isinstance(nearer_t1, bool) else nearer_t1.all():  # (np.all of a bool: 5 µs of a 70 µs call)
            phi_rest_t = np.swapaxes(phi(rest), -1, -2)
            if phi_rest_t.ndim > 2:
                phi_rest_t = np.ascontiguousarray(phi_rest_t)  # a strided stack multiplies 5 times slower
            psi = times_q2_inv(noise(dtau) @ phi_rest_t)  # [YIB Eq. 16]
            return phi(dtau) - psi @ phi(dt), psi  # [YIB Eq. 16]
        phi_back = phi(-rest)
        g = times_q2_inv(phi_back @ noise(rest))
        return g @ phi(dt), phi_back - g


def interpolate_state(t1: float, x1: NDArray, t2: float, x2: NDArray, tau: float, qc: NDArray) -> NDArray:
    """x̄(τ) from the neighbouring estimates x̄(t₁), x̄(t₂) of the zero-mean WNOA prior.  [YIB Eq. 18]"""
    lam, psi = interpolation_matrices(t1, t2, tau, qc)
    n = lam.shape[0]
    x1, x2 = _state("x1", x1, n), _state("x2", x2, n)
    with np.errstate(over="ignore", invalid="ignore"):
        x = lam @ x1 + psi @ x2  # [YIB Eq. 18]
    return finite_result("the interpolated state", x, tau=tau)


def conditional_covariance(q_tau: NDArray, phi_after: NDArray, q_after: NDArray) -> NDArray:
    """Cov(x(τ) | x(t₁), x(t₂)) = Q_τ - Q_τ Φᵀ Q₂⁻¹ Φ Q_τ in information form, (Q_τ⁻¹ + Φᵀ Q_b⁻¹ Φ)⁻¹, with
    Q_τ = Q(τ - t₁), Φ = Φ(t₂, τ), Q_b = Q(t₂ - τ): the posterior of x(τ) ~ N(·, Q_τ) given x(t₂) = Φ x(τ) + w_b,
    w_b ~ N(0, Q_b). Each entry keeps its relative precision at every τ, next to t₂ as next to t₁, and the result is
    positive semidefinite by construction (a Gram matrix L⁻ᵀ L⁻¹); the difference of two covariances cancels next to
    t₂ (Q_τ → Q₂: every digit of Q_pp lost at t₂ - τ = 1e-6 (t₂ - t₁), and negative variances).
    [YIB Eq. 16-17; derivations §3, §14.6]"""
    root_tau, root_after = _inverse_cholesky(q_tau), _inverse_cholesky(q_after) @ phi_after
    root = _inverse_cholesky(root_tau.T @ root_tau + root_after.T @ root_after)  # the information's L⁻¹
    return root.T @ root


def _inverse_cholesky(m: NDArray) -> NDArray:
    """L⁻¹ for m = L Lᵀ, by LAPACK's potrf and trtri (scipy's solve_triangular threads in OpenBLAS: 100 times slower
    on 6 × 6); NumericalError if m is not positive definite in float64 (τ too near a state)."""
    chol, info = lapack.dpotrf(m, lower=1, clean=1)
    if info == 0 and np.isfinite(chol).all():
        inverse, info = lapack.dtrtri(chol, lower=1)
        if info == 0 and np.isfinite(inverse).all():
            return np.asarray(inverse)
    raise NumericalError("Q(τ - t₁) or Q(t₂ - τ) is not positive definite in float64: τ is too near a state")


def _posterior_covariance(
    lam: NDArray, psi: NDArray, q_tau: NDArray, phi_2tau: NDArray, q_after: NDArray, joint_cov: ArrayLike
) -> NDArray:
    """[Λ Ψ] P [Λ Ψ]ᵀ + Cov(x(τ) | x₁, x₂), symmetrised: (n, n). See interpolate_covariance."""
    n = lam.shape[0]
    P = check_covariance("joint_cov", real_array("joint_cov", joint_cov), 2 * n)
    G = np.hstack([lam, psi])
    cond = conditional_covariance(q_tau, phi_2tau, q_after)  # Q_τ - Q_τ Φ(t₂,τ)ᵀ Q₂⁻¹ Φ(t₂,τ) Q_τ
    with np.errstate(over="ignore", invalid="ignore"):
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

    The conditional term is computed in its information form (:func:`conditional_covariance`), which keeps its
    relative precision next to either state; the difference written above cancels next to t₂.

    When measurements at τ are folded in through [Λ Ψ] as in [YIB Eq. 29], step 3 treats them the
    same way the estimator does, so the result is the covariance consistent with that estimate.
    """
    t1, t2, tau = _check_tau(t1, t2, tau)
    qc = check_qc(qc)
    lam, psi = interpolation_matrices(t1, t2, tau, qc)
    q_tau, q_after = process_noise(tau - t1, qc), process_noise(t2 - tau, qc)  # [YIB Eq. 17]
    cov = _posterior_covariance(lam, psi, q_tau, transition(t2 - tau, qc.shape[0]), q_after, joint_cov)
    return finite_result("the interpolated covariance", cov, t1=t1, t2=t2, tau=tau)


def interpolation_matrices_sde(sde: LinearSDE, t1: float, t2: float, tau: float) -> tuple[NDArray, NDArray]:
    """Λ(τ) and Ψ(τ) for any LinearSDE, each (n, n).  [YIB Eq. 16]

    Same formula as ``interpolation_matrices`` (:func:`_lambda_psi`) with the SDE's Φ and Q (closed forms, or expm
    and Van Loan); Q₂⁻¹ is applied by a Cholesky solve.
    """
    t1, t2, tau = _check_tau(t1, t2, tau)
    try:
        q2 = scipy.linalg.cho_factor(sde.process_noise(t2 - t1))  # [YIB Eq. 17]
    except np.linalg.LinAlgError:
        raise NumericalError(
            f"Q(t2 - t1) is not positive definite in float64 at t2 - t1 = {t2 - t1!r}: "
            "the gap is too small for this prior"
        ) from None
    lam, psi = _lambda_psi(
        tau - t1, t2 - tau, t2 - t1, sde.process_noise, sde.transition, lambda m: scipy.linalg.cho_solve(q2, m.T).T,
        sde.decay_rate,
    )  # fmt: skip
    finite_result("Λ(τ), Ψ(τ)", np.hstack([lam, psi]), t1=t1, t2=t2, tau=tau)
    return lam, psi


def interpolation_terms(
    prior: NDArray | LinearSDE, t1: float, t2: float, tau: float
) -> tuple[NDArray, NDArray, NDArray]:
    """Λ(τ), Ψ(τ) and the offset c = v(τ - t₁) - Ψ v(t₂ - t₁) of x̄(τ) = Λ x̄₁ + Ψ x̄₂ + c  [YIB Eq. 16, 18, 23]
    for a prior given as ``check_prior`` gives it: Qc (the paper's WNOA: the memoised closed forms, c = 0) or
    any LinearSDE (derivation of c in :func:`interpolate_state_sde`). What an interpolated factor holds."""
    if isinstance(prior, LinearSDE):
        lam, psi = interpolation_matrices_sde(prior, t1, t2, tau)  # [YIB Eq. 16]
        return lam, psi, prior.input_integral(tau - t1) - psi @ prior.input_integral(t2 - t1)  # [YIB Eq. 23]
    lam, psi = interpolation_matrices(t1, t2, tau, prior)  # [YIB Eq. 16]
    return lam, psi, np.zeros(lam.shape[0])


def interpolate_state_sde(sde: LinearSDE, t1: float, x1: ArrayLike, t2: float, x2: ArrayLike, tau: float) -> NDArray:
    """x̄(τ) from the estimates x̄(t₁), x̄(t₂), including the mean of the SDE: (n,).  [YIB Eq. 18]

    x̄(τ) = μ(τ) + [Λ Ψ]([x̄₁; x̄₂] - [μ₁; μ₂]). The mean obeys μ(τ) = Φ(τ,t₁) μ₁ + v_τ and
    μ₂ = Φ(t₂,t₁) μ₁ + v₂ with v_τ, v₂ of [YIB Eq. 23], so by [YIB Eq. 16]
    μ(τ) - Λ μ₁ - Ψ μ₂ = v_τ - Ψ v₂ whatever μ₁ is: the result needs no μ(t₀).
    """
    t1, t2, tau = _check_tau(t1, t2, tau)  # floats: a float32 time would make tau - t1 float32 (NumPy 2)
    lam, psi = interpolation_matrices_sde(sde, t1, t2, tau)
    x1, x2 = _state("x1", x1, sde.n), _state("x2", x2, sde.n)
    v_tau, v_2 = sde.input_integral(tau - t1), sde.input_integral(t2 - t1)  # [YIB Eq. 23]
    with np.errstate(over="ignore", invalid="ignore"):
        x = v_tau + lam @ x1 + psi @ (x2 - v_2)  # [YIB Eq. 18] with μ₁ = 0, μ(τ) = v_τ, μ₂ = v₂
    return finite_result("the interpolated state", x, tau=tau)


def interpolate_covariance_sde(sde: LinearSDE, t1: float, t2: float, tau: float, joint_cov: ArrayLike) -> NDArray:
    """Posterior covariance of x(τ) for any LinearSDE; joint_cov is (2n, 2n): (n, n).

    Cov x(τ) = [Λ Ψ] P [Λ Ψ]ᵀ + Q_τ - Q_τ Φ(t₂,τ)ᵀ Q₂⁻¹ Φ(t₂,τ) Q_τ; derivation in
    ``interpolate_covariance``. The input v shifts means only, not covariances.
    """
    t1, t2, tau = _check_tau(t1, t2, tau)  # floats: a float32 time would make tau - t1 float32 (NumPy 2)
    lam, psi = interpolation_matrices_sde(sde, t1, t2, tau)
    q_tau, q_after = sde.process_noise(tau - t1), sde.process_noise(t2 - tau)  # [YIB Eq. 17]
    cov = _posterior_covariance(lam, psi, q_tau, sde.transition(t2 - tau), q_after, joint_cov)
    return finite_result("the interpolated covariance", cov, t1=t1, t2=t2, tau=tau)


# --- beyond the last state: prediction by the prior ---------------------------------------------


def _check_after(t1: float, t: float) -> float:
    t1, t = number("t1", t1), number("t", t)
    if not t > t1:
        raise SteamError(f"extrapolation needs a finite t > t1, got t1={t1}, t={t}")
    return t - t1


def extrapolate_state_sde(sde: LinearSDE, t1: float, x1: ArrayLike, t: float) -> NDArray:
    """x̄(t) = Φ(t, t₁) x̄₁ + v(t, t₁) for t > t₁, the last state: (n,).  [YIB Eq. 22-23]

    With no state after t₁, nothing measured constrains the noise w(s), s > t₁, which is
    independent of everything up to t₁; so the posterior mean of x(t) is the prior's prediction
    from the posterior mean x̄₁ of x(t₁). Derivation: docs/derivations.md, section 7.
    """
    dt = _check_after(t1, t)
    x1 = _state("x1", x1, sde.n)
    with np.errstate(over="ignore", invalid="ignore"):
        x = sde.transition(dt) @ x1 + sde.input_integral(dt)  # [YIB Eq. 22-23]
    return finite_result("the extrapolated state", x, t_minus_t1=dt)


def extrapolate_covariance_sde(sde: LinearSDE, t1: float, t: float, cov1: ArrayLike) -> NDArray:
    """Cov x(t) = Φ(t, t₁) P₁ Φ(t, t₁)ᵀ + Q(t - t₁) for t > t₁, P₁ (n, n) the last state's: (n, n).  [YIB Eq. 17, 22]"""
    dt = _check_after(t1, t)
    P = check_covariance("cov1", real_array("cov1", cov1), sde.n)
    Phi = sde.transition(dt)
    with np.errstate(over="ignore", invalid="ignore"):
        cov = Phi @ P @ Phi.T + sde.process_noise(dt)  # [YIB Eq. 17, 22]
    return finite_result("the extrapolated covariance", (cov + cov.T) / 2, t_minus_t1=dt)
