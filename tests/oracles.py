"""Dense, deliberately slow reference computations shared by the tests.

A plain module of functions: each one is obviously right from its definition and independent of
the code it checks (no steam_ref factor, prior or interpolation code is called here).
"""

from __future__ import annotations

import numpy as np
import scipy.integrate
import scipy.linalg
from numpy.typing import NDArray

# ---------------------------------------------------------------------------------------------
# GP prior [YIB Sec. II]


def random_spd(rng: np.random.Generator, n: int, scale: float = 1.0) -> NDArray:
    """A random symmetric positive definite (n, n) matrix with eigenvalues in [0.5, 2.5]·scale."""
    U, _ = np.linalg.qr(rng.normal(size=(n, n)))
    return scale * (U * rng.uniform(0.5, 2.5, size=n)) @ U.T


def random_lti(rng: np.random.Generator, n: int = 4, m: int = 2) -> dict[str, NDArray]:
    """Coefficients A (n, n), F (n, m), qc (m, m), v (n,) of a generic, non-WNOA LTI SDE."""
    return dict(
        A=0.4 * rng.normal(size=(n, n)),
        F=rng.normal(size=(n, m)),
        qc=random_spd(rng, m),
        v=rng.normal(size=n),
    )


def sde_transition(sde, dt: float) -> NDArray:
    """Φ(t + dt, t) = exp(A dt), straight from the definition."""
    return scipy.linalg.expm(np.asarray(sde.A) * dt)


_QUADRATURES: dict[tuple, NDArray] = {}


def _quadrature(name: str, integrand, dt: float, *arrays: NDArray) -> NDArray:
    """∫₀^dt integrand(s) ds by adaptive quadrature, computed once per integral's name, dt and the exact arrays it
    reads (a pure function of them: a dense kernel asks the same few steps again and again); a fresh copy each call."""
    key = (name, float(dt), *((a.shape, a.tobytes()) for a in arrays))
    if key not in _QUADRATURES:
        _QUADRATURES[key], _ = scipy.integrate.quad_vec(integrand, 0.0, dt, epsabs=1e-13, epsrel=1e-12)
    return _QUADRATURES[key].copy()


def sde_process_noise(sde, dt: float) -> NDArray:
    """Q(dt) = ∫₀^dt Φ(dt, s) F Qc Fᵀ Φ(dt, s)ᵀ ds by adaptive quadrature.  [YIB Eq. 17]"""
    A, F, qc = (np.asarray(a, float) for a in (sde.A, sde.F, sde.qc))

    def integrand(s: float) -> NDArray:
        Phi = scipy.linalg.expm(A * (dt - s))
        return Phi @ F @ qc @ F.T @ Phi.T

    return _quadrature("Q", integrand, dt, A, F, qc)


def sde_input_integral(sde, dt: float) -> NDArray:
    """v_i = ∫₀^dt Φ(dt, s) v ds by adaptive quadrature.  [YIB Eq. 23]"""
    A, v = np.asarray(sde.A, float), np.asarray(sde.v, float)
    return _quadrature("v_i", lambda s: scipy.linalg.expm(A * (dt - s)) @ v, dt, A, v)


def gp_kernel(times: NDArray, sde, P0: NDArray) -> NDArray:
    """Dense kernel K of [YIB Eq. 3] at sorted `times`, with Cov x(times[0]) = P0: (M n, M n).

    K(t, t') = Φ(t, t₀) P0 Φ(t', t₀)ᵀ + ∫_{t₀}^{min(t,t')} Φ(t, s) F Qc Fᵀ Φ(t', s)ᵀ ds, built by
    the recursion P_k = Φ_k P_{k-1} Φ_kᵀ + Q_k and K(t_j, t_k) = Φ(t_j, t_k) P_k for j ≥ k, with
    Φ from expm and Q from quadrature.
    """
    times = np.asarray(times, float)
    assert np.all(np.diff(times) > 0), "gp_kernel needs strictly increasing times"
    n, M = np.asarray(sde.A).shape[0], times.size
    P = [np.asarray(P0, float)]
    for k in range(1, M):
        dt = times[k] - times[k - 1]
        Phi = sde_transition(sde, dt)
        P.append(Phi @ P[-1] @ Phi.T + sde_process_noise(sde, dt))
    K = np.zeros((M * n, M * n))
    for j in range(M):
        for k in range(j + 1):
            block = sde_transition(sde, times[j] - times[k]) @ P[k]  # Cov(x_j, x_k), t_j ≥ t_k
            K[j * n : (j + 1) * n, k * n : (k + 1) * n] = block
            K[k * n : (k + 1) * n, j * n : (j + 1) * n] = block.T
    return K


def gp_mean(times: NDArray, sde, mu0: NDArray) -> NDArray:
    """Stacked prior mean μ of [YIB Eq. 3] at sorted `times` with μ(times[0]) = mu0: (M n,).

    μ_k = Φ(t_k, t_{k-1}) μ_{k-1} + v_k, with v_k by quadrature.  [YIB Eq. 22-23]
    """
    times = np.asarray(times, float)
    mu = [np.asarray(mu0, float)]
    for dt in np.diff(times):
        mu.append(sde_transition(sde, dt) @ mu[-1] + sde_input_integral(sde, dt))
    return np.concatenate(mu)


def condition_gaussian(mean: NDArray, cov: NDArray, H: NDArray, R: NDArray, y: NDArray) -> tuple[NDArray, NDArray]:
    """Posterior of x ~ N(mean, cov) given y = H x + n, n ~ N(0, R), in covariance form."""
    S = H @ cov @ H.T + R
    gain = np.linalg.solve(S, H @ cov).T  # cov Hᵀ S⁻¹
    post_cov = cov - gain @ H @ cov
    return mean + gain @ (y - H @ mean), (post_cov + post_cov.T) / 2
