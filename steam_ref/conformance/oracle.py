"""Independent expected values for the kit: the GP prior and the factors, from their definitions.

Nothing here calls steam_ref's GP, factor or solver code (only its errors): every quantity is
computed a second way, from the equation it stands for, so the kit's "independent" cases check
steam_ref rather than restate it.

- Φ(Δt) = expm(A Δt) by SciPy [YIB Eq. 16]; Q(Δt) and vᵢ by 24-node Gauss-Legendre quadrature of
  their integrals [YIB Eq. 17, 23] (exact up to rounding for WNOA's and WNOJ's polynomial
  integrands, converged to rounding for Singer's and the general SDE's exponentials).
- Λ(τ), Ψ(τ) and the covariance at τ by conditioning the dense prior of [x(t₁); x(τ); x(t₂)]
  (the kernel route of [YIB Eq. 12], K(τ) K⁻¹), not by the formula of [YIB Eq. 16].
- W with WᵀW = Σ⁻¹ from the reversed Cholesky factor of Σ (Σ = U Uᵀ, U upper, W = U⁻¹); the
  symmetric alternative Σ^(-1/2) from Σ's eigendecomposition.
- The alternatives of the conventions (kit v2): the GP prior's error with the sign of [YIB Eq. 22]
  (``paper_sign``), and the symmetric whitener (``symmetric``).
- Factor errors written out from [YIB Eq. 22, 29, 32, 33] and the bearing model, and their
  Jacobians by complex-step differentiation (exact to rounding: no cancellation).
- What both Lie oracles (:mod:`.oracle_lie`, :mod:`.oracle_rigid`) make of a factor once they have its error and
  a Jacobian through their retraction: :func:`error_and_jacobians`, :func:`whitened` (no robust losses there); and
  of a covariance through the local GP: :func:`mapped_covariance`.

A factor is given as the kit writes it (a dict, see docs/conformance.md), so this module reads the
kit's own format.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from functools import lru_cache

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from ..errors import SteamError

__all__ = [
    "model_matrices",
    "transition",
    "process_noise",
    "input_integral",
    "sqrt_information",
    "noise_covariance",
    "interpolation",
    "extrapolation",
    "factor_error",
    "linearize_factor",
    "error_and_jacobians",
    "whitened",
    "mapped_covariance",
    "loss_rho",
    "loss_weight",
]

_GAUSS = np.polynomial.legendre.leggauss(24)  # nodes and weights on [-1, 1]
_STEP = 1e-30  # complex-step size


# --- the GP prior -------------------------------------------------------------------------------


def model_matrices(model: str, d: int, alpha: float | None = None) -> tuple[NDArray, NDArray]:
    """A and F of 'wnoa' (p̈ = w), 'wnoj' (p⃛ = w) or 'singer' (p⃛ = -α p̈ + w) for p of size d."""
    I, O = np.eye(d), np.zeros((d, d))
    if model == "wnoa":
        return np.block([[O, I], [O, O]]), np.vstack([O, I])  # [YIB Eq. 31]
    if model in ("wnoj", "singer"):
        if model == "singer" and alpha is None:
            raise SteamError("the singer model needs alpha")
        a = 0.0 if alpha is None or model == "wnoj" else float(alpha)
        A = np.block([[O, I, O], [O, O, I], [O, O, -a * I]])
        return A, np.vstack([O, O, I])
    raise SteamError(f"unknown model {model!r}")


def transition(A: NDArray, dt: float) -> NDArray:
    """Φ(t + Δt, t) = exp(A Δt).  [YIB Eq. 16]"""
    return scipy.linalg.expm(np.asarray(A, float) * dt)


def _quadrature(f, dt: float) -> NDArray:
    """∫₀^Δt f(s) ds by 24-node Gauss-Legendre: exact for polynomials of degree ≤ 47 (WNOA's and WNOJ's
    integrands have degree ≤ 4), and for the exponentials of the kit's Singer and LTI cases (|eigenvalue| Δt ≤ 5)
    the error bound (|λ|Δt/2)⁴⁸/48! is far below rounding."""
    x, w = _GAUSS
    total: NDArray = np.zeros(())
    for xi, wi in zip(x, w, strict=True):
        total = total + (dt / 2) * wi * f((xi + 1) * dt / 2)
    return total


def process_noise(A: NDArray, F: NDArray, qc: NDArray, dt: float) -> NDArray:
    """Q(Δt) = ∫₀^Δt Φ(Δt, s) F Qc Fᵀ Φ(Δt, s)ᵀ ds by quadrature.  [YIB Eq. 17]"""
    G = np.asarray(F, float) @ np.asarray(qc, float) @ np.asarray(F, float).T

    def integrand(s: float) -> NDArray:
        P = transition(A, dt - s)
        return P @ G @ P.T

    Q = _quadrature(integrand, dt)
    return (Q + Q.T) / 2


def input_integral(A: NDArray, v: NDArray, dt: float) -> NDArray:
    """vᵢ = ∫₀^Δt Φ(Δt, s) v ds by quadrature.  [YIB Eq. 23]"""
    return _quadrature(lambda s: transition(A, dt - s) @ np.asarray(v, float), dt)


def noise_covariance(spec: Mapping, m: int) -> NDArray:
    """Σ of a factor spec: 'sigma' (scalar), 'sigmas' (m,) or 'covariance' (m, m)."""
    if "covariance" in spec:
        return np.asarray(spec["covariance"], float)
    sigmas = np.full(m, float(spec["sigma"])) if "sigma" in spec else np.asarray(spec["sigmas"], float)
    return np.diag(sigmas**2)


def sqrt_information(sigma: NDArray, symmetric: bool = False) -> NDArray:
    """Upper-triangular W, positive diagonal, WᵀW = Σ⁻¹: Σ = U Uᵀ with U upper, W = U⁻¹.

    ``symmetric``: the other documented whitener, W = Σ^(-1/2) = V diag(λ^(-1/2)) Vᵀ for Σ = V diag(λ) Vᵀ.
    """
    if symmetric:
        lam, V = np.linalg.eigh(np.asarray(sigma, float))
        W = (V / np.sqrt(lam)) @ V.T
        return (W + W.T) / 2
    J = np.eye(len(sigma))[::-1]
    U = J @ np.linalg.cholesky(J @ np.asarray(sigma, float) @ J) @ J  # upper, U Uᵀ = Σ
    return scipy.linalg.solve_triangular(U, np.eye(len(sigma)), lower=False)


def _gaussian_blocks(A: NDArray, F: NDArray, qc: NDArray, times: Sequence[float]) -> NDArray:
    """Dense prior covariance of [x(t₀); x(t₁); ...] with x(t₀) ~ N(0, I): the kernel of [YIB Eq. 3]."""
    n, M = A.shape[0], len(times)
    marg = [np.eye(n)]
    for k in range(1, M):
        P = transition(A, times[k] - times[k - 1])
        marg.append(P @ marg[-1] @ P.T + process_noise(A, F, qc, times[k] - times[k - 1]))
    K = np.zeros((M * n, M * n))
    for j in range(M):
        for k in range(j + 1):
            block = transition(A, times[j] - times[k]) @ marg[k]  # Cov(x_j, x_k), t_j ≥ t_k
            K[j * n : (j + 1) * n, k * n : (k + 1) * n] = block
            K[k * n : (k + 1) * n, j * n : (j + 1) * n] = block.T
    return K


def interpolation(
    A: NDArray, F: NDArray, qc: NDArray, t1: float, t2: float, tau: float
) -> tuple[NDArray, NDArray, NDArray]:
    """Λ(τ), Ψ(τ) and Cov(x(τ) | x(t₁), x(t₂)) by conditioning the dense prior of the three states.

    [Λ Ψ] = K(τ) K⁻¹ of [YIB Eq. 12]: Cov(x(τ), [x₁; x₂]) Cov([x₁; x₂])⁻¹. The SDE is Markov, so
    the result does not depend on the covariance given to x(t₁) (here I).
    """
    A = np.asarray(A, float)
    n = A.shape[0]
    K = _gaussian_blocks(A, np.asarray(F, float), np.asarray(qc, float), [t1, tau, t2])
    ends = np.r_[0:n, 2 * n : 3 * n]
    mid = np.arange(n, 2 * n)
    K_ee = K[np.ix_(ends, ends)]
    K_me = K[np.ix_(mid, ends)]
    G = np.linalg.solve(K_ee, K_me.T).T  # K(τ) K⁻¹
    C = K[np.ix_(mid, mid)] - G @ K_me.T
    return G[:, :n], G[:, n:], (C + C.T) / 2


def extrapolation(
    A: NDArray, F: NDArray, qc: NDArray, dt: float, x1: NDArray, cov1: NDArray
) -> tuple[NDArray, NDArray]:
    """Mean and covariance of x(t₁ + Δt) from the last state's N(x₁, P₁): the prior's prediction.  [YIB Eq. 17, 22]"""
    P = transition(A, dt)
    cov = P @ np.asarray(cov1, float) @ P.T + process_noise(A, F, qc, dt)
    return P @ np.asarray(x1, float), (cov + cov.T) / 2


# --- factors --------------------------------------------------------------------------------------


def _wrap(a):
    """Angle to [-π, π) (the real part decides; a complex step's imaginary part is kept)."""
    k = math.floor((float(np.real(a)) + math.pi) / (2 * math.pi))
    return a - 2 * math.pi * k


def _atan2(y, x):
    """atan2 that a complex step passes through (branch chosen on the real parts)."""
    yr, xr = float(np.real(y)), float(np.real(x))
    if abs(xr) >= abs(yr):
        base = np.arctan(y / x)
        return base if xr > 0 else base + (math.pi if yr >= 0 else -math.pi)
    return (math.pi / 2 if yr > 0 else -math.pi / 2) - np.arctan(x / y)


def _measurement(kind: str, spec: Mapping, x, l=None):
    """h(x[, ℓ]) - y of a measurement on one state (x = [x, y, θ, ẋ, ẏ, θ̇]) and maybe a landmark."""
    y = np.atleast_1d(np.asarray(spec["measured"], float))
    if kind == "odometry":  # [YIB Eq. 32]
        return np.array([np.cos(x[2]) * x[3] + np.sin(x[2]) * x[4] - y[0], x[5] - y[1]])
    if kind == "velocity":  # the scripts' projected velocity
        c, s = np.cos(x[2]), np.sin(x[2])
        return np.array([c * x[3] + s * x[4] - y[0], -s * x[3] + c * x[4] - y[1], x[5] - y[2]])
    dx, dy = l[0] - x[0], l[1] - x[1]
    r = np.sqrt(dx * dx + dy * dy)  # [YIB Eq. 33]
    if kind == "range":
        return np.array([r - y[0]])
    bearing = _wrap(_atan2(dy, dx) - x[2] - y[0])
    if kind == "bearing":
        return np.array([bearing])
    if kind == "bearing_range":
        return np.array([bearing, r - y[1]])
    raise SteamError(f"unknown measurement type {kind!r}")


def measurement_error(kind: str, spec: Mapping, x, l=None) -> NDArray:
    """h(x[, ℓ]) - y of a measurement ``kind`` (range, bearing, bearing_range, velocity, odometry) on a state whose
    first three numbers are [x, y, θ] (a vector state, or an SE(2) state [x, y, θ, vx, vy, ω] for the pose readings)."""
    return _measurement(kind, spec, x, *(() if l is None else (l,)))


def factor_error(spec: Mapping, xs: Sequence, paper_sign: bool = False) -> NDArray:
    """The unwhitened error e of a factor spec at its variables ``xs`` (in its key order).

    ``paper_sign``: the GP prior's error as [YIB Eq. 22] writes it, Φ x₁ + vᵢ - x₂ (the kit's is its negative).
    """
    kind = spec["type"]
    if kind == "prior":
        return xs[0] - np.asarray(spec["mean"], float)
    if kind == "gp_prior":  # e = x₂ - Φ x₁ - vᵢ, zero-mean WNOA  [YIB Eq. 22, 30-31]
        qc = np.asarray(spec["qc"], float)
        A, _ = model_matrices("wnoa", qc.shape[0])
        e = xs[1] - transition(A, float(spec["dt"])) @ xs[0]
        return -e if paper_sign else e
    if kind == "interpolated":  # e_inner(Λ x₁ + Ψ x₂, ...), [Λ Ψ] = K(τ) K⁻¹ densely  [YIB Eq. 13, 28; 18, 29]
        lam, psi = interpolated_matrices(spec)
        x_tau = lam @ xs[0] + psi @ xs[1]
        return _measurement(spec["inner"]["type"], spec["inner"], x_tau, *xs[2:])
    return _measurement(kind, spec, *xs)


def interpolated_matrices(spec: Mapping) -> tuple[NDArray, NDArray]:
    """Λ(τ), Ψ(τ) of an 'interpolated' factor spec (WNOA with its Qc)."""
    qc = tuple(map(tuple, np.asarray(spec["qc"], float)))
    return _wnoa_interpolation(qc, float(spec["t1"]), float(spec["t2"]), float(spec["tau"]))


@lru_cache(maxsize=64)
def _wnoa_interpolation(qc: tuple, t1: float, t2: float, tau: float) -> tuple[NDArray, NDArray]:
    q = np.array(qc)
    A, F = model_matrices("wnoa", q.shape[0])
    lam, psi, _ = interpolation(A, F, q, t1, t2, tau)
    return lam, psi


def _noise_spec(spec: Mapping) -> Mapping:
    return spec["inner"] if spec["type"] == "interpolated" else spec


def loss_rho(loss: Mapping | None, s: float) -> float:
    """ρ(s) of a loss spec (None: s²/2)."""
    if loss is None:
        return 0.5 * s * s
    if loss["type"] == "huber":
        k = float(loss["k"])
        return 0.5 * s * s if s <= k else k * s - 0.5 * k * k
    c = float(loss["c"])
    return c * c / 6 * (1 - (1 - (s / c) ** 2) ** 3) if s <= c else c * c / 6


def loss_weight(loss: Mapping | None, s: float) -> float:
    """IRLS weight w(s) = ρ'(s)/s of a loss spec (None: 1)."""
    if loss is None:
        return 1.0
    if loss["type"] == "huber":
        k = float(loss["k"])
        return 1.0 if s <= k else k / s
    c = float(loss["c"])
    return (1 - (s / c) ** 2) ** 2 if s <= c else 0.0


def _range_at_landmark(spec: Mapping, xs: Sequence[NDArray]) -> bool:
    """Whether ``spec`` is a range (plain or interpolated) evaluated with the robot exactly at the landmark."""
    if spec["type"] == "interpolated":
        if spec["inner"]["type"] != "range":
            return False
        lam, psi = interpolated_matrices(spec)
        x = lam @ xs[0] + psi @ xs[1]
    elif spec["type"] == "range":
        x = xs[0]
    else:
        return False
    return bool(xs[-1][0] - x[0] == 0 and xs[-1][1] - x[1] == 0)


def linearize_factor(spec: Mapping, xs: Sequence[NDArray], paper_sign: bool = False, symmetric: bool = False) -> dict:
    """Everything the kit records of one factor at ``xs``: e, W e, Hₖ, Aₖ, b, cost (and weight if robust).

    ``paper_sign``, ``symmetric``: under the alternative conventions (see :func:`factor_error`,
    :func:`sqrt_information`).
    """
    xs = [np.asarray(x, float) for x in xs]
    e = np.real(factor_error(spec, xs, paper_sign)).astype(float)
    H = []
    for k, x in enumerate(xs):
        cols = []
        for j in range(len(x)):
            shifted = [xx.astype(complex) for xx in xs]
            shifted[k][j] += 1j * _STEP
            cols.append(np.imag(factor_error(spec, shifted, paper_sign)) / _STEP)
        H.append(np.stack(cols, axis=1))
    if _range_at_landmark(spec, xs):  # no derivative exists: the kit's convention (range_at_landmark), zero rows
        H = [np.zeros_like(h) for h in H]
    noise = _noise_spec(spec)
    if spec["type"] == "gp_prior":  # Σ = Q(Δt) of [YIB Eq. 17]
        qc = np.asarray(spec["qc"], float)
        sigma = process_noise(*model_matrices("wnoa", qc.shape[0]), qc, float(spec["dt"]))
    else:
        sigma = noise_covariance(noise, len(e))
    W = sqrt_information(sigma, symmetric)
    we = W @ e
    s = float(np.linalg.norm(we))
    loss = noise.get("loss")
    w = loss_weight(loss, s)
    out = {"error": e, "whitened_error": we}
    out.update({f"H_{k}": h for k, h in enumerate(H)})
    out.update({f"A_{k}": math.sqrt(w) * W @ h for k, h in enumerate(H)})
    out["b"] = -math.sqrt(w) * we
    out["cost"] = loss_rho(loss, s)
    if loss is not None:
        out["weight"] = w
    return out


# --- factors on a Lie group: what both Lie oracles make of a factor ----------------------------------


def error_and_jacobians(
    error: Callable[..., NDArray], jacobian: Callable[..., NDArray], xs: Sequence[NDArray]
) -> tuple[NDArray, list[NDArray]]:
    """``error(*xs)`` and Hₖ = ``jacobian(error, xs, k)`` for each key k: a Lie oracle passes its factor's error and
    its ``numeric_jacobian`` (differences through its retraction), both looked up when it calls, so a test that
    swaps either for a wrong port's reaches every factor."""
    xs = [np.asarray(x, float) for x in xs]
    return error(*xs), [jacobian(error, xs, k) for k in range(len(xs))]


def whitened(e: NDArray, H: Sequence[NDArray], sigma: NDArray) -> dict:
    """e, W e, Hₖ, Aₖ = W Hₖ, b = -W e and the cost ½‖W e‖² of a factor without a robust loss whose error is e,
    its Jacobians H and its noise Σ (W of :func:`sqrt_information`); :func:`linearize_factor` is the vector
    states' record, with robust losses and ρ(‖W e‖) for the cost."""
    W = sqrt_information(sigma)
    we = W @ e
    out = {"error": e, "whitened_error": we, **{f"H_{k}": h for k, h in enumerate(H)}}
    out.update({f"A_{k}": W @ h for k, h in enumerate(H)})
    out["b"], out["cost"] = -we, 0.5 * float(np.sum(we**2))
    return out


def mapped_covariance(J: NDArray, P: NDArray, N: NDArray, Q: NDArray) -> NDArray:
    """J P Jᵀ + N Q Nᵀ, symmetrized: the covariance of a Lie oracle's x(τ) or x(t) in its right tangent, from the
    states' covariance P through J and the local GP's Q through N = ∂x/∂γ."""
    cov = J @ np.asarray(P, float) @ J.T + N @ Q @ N.T
    return (cov + cov.T) / 2
