"""One Gauss-Newton step of the factor graph is the paper's Eq. 11, written out densely from Eq. 3-13.

The oracle builds the problem the way Section II states it, with no steam_ref factor, linearization or
solver: the kernel K of the states (and of a time τ with no state) from Φ and Q of Eq. 17 integrated by
quadrature (Eq. 3), the prior N(η, P) with P = diag(K, W) (Eq. 4-5), the stacked ranges h(θ) (Eq. 7, 33) and
R = diag(Rᵢ) (Eq. 8), H by central differences (Eq. 9), and the reading at τ through the kernel's posterior
mean x(τ) = μ(τ) + K(τ) K⁻¹ (x - μ) (Eq. 12-13). Setting the gradient of Eq. 10 to zero gives

    (P⁻¹ + Hᵀ R⁻¹ H) δθ* = P⁻¹ (η - θ̄) + Hᵀ R⁻¹ (y - h̄),

which is Eq. 11 with the P⁻¹ of the prior's term that the paper's print drops. steam_ref writes the prior as
the first state's prior factor, the GP prior factors (Eq. 22) and landmark priors, and the reading at τ as an
interpolated factor (Eq. 29); its step must be the one above, and not the one of Eq. 11 as printed.
"""

from __future__ import annotations

import numpy as np
import scipy.integrate
import scipy.linalg

import steam_ref as sr

D = 3  # [x, y, θ]: the state is [p; ṗ], 6 numbers
QC = np.diag([0.4, 0.25, 0.1])


def phi(dt):
    """Φ(t + dt, t) of p̈ = w: [[I, dt I], [0, I]]  (Eq. 30-31)."""
    return np.block([[np.eye(D), dt * np.eye(D)], [np.zeros((D, D)), np.eye(D)]])


def q(dt):
    """Q(dt) = ∫₀^dt Φ(dt, s) F Qc Fᵀ Φ(dt, s)ᵀ ds by adaptive quadrature (Eq. 17)."""
    F = np.vstack([np.zeros((D, D)), np.eye(D)])
    if dt == 0.0:
        return np.zeros((2 * D, 2 * D))
    out, _ = scipy.integrate.quad_vec(lambda s: phi(dt - s) @ F @ QC @ F.T @ phi(dt - s).T, 0.0, dt, epsabs=1e-14)
    return out


def kernel(times, P0):
    """K of Eq. 3 for x(t₀) ~ N(·, P0) at sorted ``times``: Cov(xᵢ, xⱼ) = Cov(xᵢ) Φ(tⱼ, tᵢ)ᵀ for tᵢ ≤ tⱼ."""
    n = 2 * D
    cov = [phi(t - times[0]) @ P0 @ phi(t - times[0]).T + q(t - times[0]) for t in times]
    K = np.zeros((len(times) * n, len(times) * n))
    for i, ti in enumerate(times):
        for j, tj in enumerate(times):
            block = cov[i] @ phi(tj - ti).T if ti <= tj else phi(ti - tj) @ cov[j]
            K[i * n : (i + 1) * n, j * n : (j + 1) * n] = block
    return K


def test_one_gauss_newton_step_is_eq_11_with_the_priors_information(rng):
    n, M = 2 * D, 5
    times = np.array([0.0, 0.7, 1.2, 2.1, 2.5])
    tau, left = 1.6, 2  # a range reading at τ, between the states at times[2] and times[3]
    m0, s0 = np.array([0.0, 0.0, 0.3, 1.0, 0.4, 0.1]), np.array([0.2, 0.2, 0.1, 0.3, 0.3, 0.2])
    d, w = np.array([[3.0, 2.0], [-1.0, 4.0]]), 0.5  # landmark means and their sigma (Eq. 4)
    sigma_r = 0.2
    reads = [(i, i % 2) for i in range(M)]  # (state, landmark) of each range at a state
    l_tau = 1

    # --- the oracle: Section II written out -------------------------------------------------------------
    all_times = np.sort(np.r_[times, tau])
    k_tau = int(np.flatnonzero(all_times == tau)[0])
    at = [i for i in range(M + 1) if i != k_tau]
    Kall = kernel(all_times, np.diag(s0**2))
    rows = lambda ii: np.concatenate([np.arange(i * n, (i + 1) * n) for i in ii])
    K = Kall[np.ix_(rows(at), rows(at))]
    gain = Kall[np.ix_(rows([k_tau]), rows(at))] @ np.linalg.inv(K)  # K(τ) K⁻¹  (Eq. 12)
    mu = np.concatenate([phi(t - times[0]) @ m0 for t in times])  # zero input: μ(t) = Φ(t, t₀) m₀
    mu_tau = phi(tau - times[0]) @ m0
    eta = np.r_[mu, d.ravel()]  # Eq. 5
    P = scipy.linalg.block_diag(K, w**2 * np.eye(4))

    truth_x = mu + np.linalg.cholesky(K) @ rng.normal(size=M * n)
    truth_l = d.ravel() + w * rng.normal(size=4)

    def h(theta):  # Eq. 7 with each hᵢ a range (Eq. 33); the last one at x(τ) of Eq. 12
        x, ell = theta[: M * n].reshape(M, n), theta[M * n :].reshape(2, 2)
        x_tau = mu_tau + gain @ (theta[: M * n] - mu)
        return np.array([np.hypot(*(x[i, :2] - ell[j])) for i, j in reads] + [np.hypot(*(x_tau[:2] - ell[l_tau]))])

    y = h(np.r_[truth_x, truth_l]) + sigma_r * rng.normal(size=M + 1)
    theta_bar = np.r_[truth_x, truth_l] + 0.3 * rng.normal(size=M * n + 4)
    eps = 1e-6
    H = np.stack([(h(theta_bar + eps * e) - h(theta_bar - eps * e)) / (2 * eps) for e in np.eye(len(theta_bar))], 1)
    Rinv = np.eye(M + 1) / sigma_r**2  # Eq. 8
    Pinv = np.linalg.inv(P)
    info = Pinv + H.T @ Rinv @ H  # 𝓘 of Eq. 11
    step = np.linalg.solve(info, Pinv @ (eta - theta_bar) + H.T @ Rinv @ (y - h(theta_bar)))
    printed = np.linalg.solve(info, (eta - theta_bar) + H.T @ Rinv @ (y - h(theta_bar)))  # Eq. 11 as printed

    # --- steam_ref: the same problem as factors ---------------------------------------------------------
    X, L = [sr.X(i) for i in range(M)], [sr.L(j) for j in range(2)]
    graph = sr.FactorGraph(sr.gp_prior_factors(X, times, QC))
    graph.add(sr.PriorFactor.create(X[0], m0, s0))
    for j in range(2):
        graph.add(sr.PriorFactor.create(L[j], d[j], [w, w]))
    for k, (i, j) in enumerate(reads):
        graph.add(sr.RangeFactor.create(X[i], L[j], y[k], sigma_r))
    inner = sr.RangeFactor.create(sr.X(-1), L[l_tau], y[-1], sigma_r)
    graph.add(sr.InterpolatedFactor.create(inner, X[left], X[left + 1], times[left], times[left + 1], tau, QC))
    start = {X[i]: theta_bar[i * n : (i + 1) * n] for i in range(M)}
    start.update({L[j]: theta_bar[M * n + 2 * j : M * n + 2 * j + 2] for j in range(2)})
    moved = sr.gauss_newton(graph, sr.Values(start), max_iterations=1).values
    ours = np.concatenate([moved[k] for k in X + L]) - theta_bar

    scale = np.abs(step).max()
    np.testing.assert_allclose(ours, step, rtol=0, atol=1e-8 * scale)
    assert np.abs(printed - step).max() > 1e-2 * scale  # the print's rhs is a different step, not rounding
