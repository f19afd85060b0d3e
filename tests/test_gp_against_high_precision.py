"""The GP priors' covariances and the local variables of the Lie groups against oracles the other files do not use.

Oracles, none of them steam_ref's code:

- **the conditional covariance at τ at 50 digits**: Q(s) and Φ(s) of each prior from mpmath's matrix exponential of
  Van Loan's block, then Q_τ - Q_τ Φ(t₂, τ)ᵀ Q₂⁻¹ Φ(t₂, τ) Q_τ with no cancellation left at 50 digits; float64 must
  keep each entry's relative precision at every τ, also within 1e-6 of either state, where the difference of two
  covariances loses it (and gave negative variances next to t₂);
- **the interpolation matrices Λ(τ), Ψ(τ) at 100 digits** [YIB Eq. 16] from the same Φ and Q: each entry's relative
  precision at every τ, from 1e-12 (t₂ - t₁) after t₁ to 1e-12 (t₂ - t₁) before t₂, where Φ(τ, t₁) - Ψ Φ(t₂, t₁)
  and Q_τ Φ(t₂, τ)ᵀ Q₂⁻¹ cancel;
- **Singer's Q at 30 digits from its definition** ∫ g gᵀ, g the last column of Φ(s), up to αΔt = 1e100;
- **the kinematics of the local variables** from their definition: a trajectory T(t) = Exp(ξ(t)) with ξ(t) a cubic,
  its body twist ϖ = (T⁻¹ Ṫ)^∨ and ϖ̇ by differences of mpmath's matrix exponential at 60 digits; the local
  variables of the state (T, ϖ, ϖ̇) must be ξ, ξ̇, ξ̈ of the cubic (and the map back the state), at angles up to 3.1.
"""

from __future__ import annotations

import numpy as np
import pytest
from requirements import optional_import

from steam_ref.errors import NumericalError, SteamError
from steam_ref.gp import (
    LinearSDE,
    interpolate_covariance,
    interpolate_covariance_sde,
    interpolation_matrices,
    interpolation_matrices_many,
    interpolation_matrices_sde,
    singer_process_noise,
)
from steam_ref.gp.interpolate import interpolation_terms
from steam_ref.lie import SE2, SE3, gp_accel
from steam_ref.lie import gp as lie_gp

mp = optional_import("mpmath", "test")

QC = np.array([[0.7]])  # one axis: every prior here is the same scalar SDE on each axis, Q ⊗ Qc


def _mp_phi_q(sde, s):
    """Φ(s) and Q(s) of ``sde`` in mpmath (Van Loan's block at the working precision)."""
    n = sde.n
    A, G, s = mp.matrix(sde.A.tolist()), mp.matrix((sde.F @ sde.qc @ sde.F.T).tolist()), mp.mpf(s)
    C = mp.zeros(2 * n)
    for i in range(n):
        for j in range(n):
            C[i, j], C[i, n + j], C[n + i, n + j] = -A[i, j] * s, G[i, j] * s, A[j, i] * s
    E = mp.expm(C)
    return mp.expm(A * s), E[n:, n:].T * E[:n, n:]


def _mp_conditional(sde, t2, tau):
    """Cov(x(τ) | x(0), x(t₂)) at 50 digits, rounded to doubles."""
    with mp.workdps(50):
        _, q_tau = _mp_phi_q(sde, tau)
        phi_b, _ = _mp_phi_q(sde, mp.mpf(t2) - mp.mpf(tau))
        _, q2 = _mp_phi_q(sde, t2)
        cond = q_tau - q_tau * phi_b.T * mp.inverse(q2) * phi_b * q_tau
        return np.array(cond.tolist(), dtype=float)


def _assert_entrywise(ours, want, rel):
    scale = np.abs(want).max()
    zero = np.abs(want) <= 1e-30 * scale  # an entry zero in 50 digits: zero to ``rel`` of the matrix
    err = np.where(zero, np.abs(ours) / scale, np.abs(ours - want) / np.where(zero, 1.0, np.abs(want)))
    assert err.max() <= rel, f"relative error {err.max():.2e} at {np.unravel_index(err.argmax(), err.shape)}"


SDES = {"wnoa": LinearSDE.wnoa(QC), "wnoj": LinearSDE.wnoj(QC), "singer": LinearSDE.singer(QC, 1.7)}


@pytest.mark.parametrize("name", sorted(SDES))
@pytest.mark.parametrize("fraction", [1e-7, 0.37, 0.999, 1 - 1e-6])
def test_the_interpolated_covariance_keeps_its_relative_precision_next_to_either_state(name, fraction):
    """With the states known exactly (joint covariance 0) the covariance at τ is the conditional one; every entry to
    1e-12 of its 50-digit value at every τ, positive definite next to t₂ as next to t₁ (the closed forms; Van Loan's
    Q of ``sde.general()`` has its own limits, ``LinearSDE.process_noise_van_loan``)."""
    sde, t2 = SDES[name], 0.8
    tau = fraction * t2
    want = _mp_conditional(sde, t2, tau)
    zero = np.zeros((2 * sde.n, 2 * sde.n))
    got = [interpolate_covariance_sde(sde, 0.0, t2, tau, zero)]
    if name == "wnoa":  # the paper's memoised closed forms, from Qc
        got.append(interpolate_covariance(0.0, t2, tau, QC, zero))
    for cov in got:
        _assert_entrywise(cov, want, 1e-12)
        np.linalg.cholesky(cov)  # positive definite (Cholesky, not eigvalsh: the entries span s⁵ to s, s = τ - t₁)


def _mp_lambda_psi(sde, t2, tau):
    """Λ(τ), Ψ(τ) with t₁ = 0 at 100 digits, rounded to doubles: Ψ = Q_τ Φ(t₂, τ)ᵀ Q₂⁻¹, Λ = Φ(τ, 0) - Ψ Φ(t₂, 0)
    [YIB Eq. 16]. Next to t₂ Λ's entries fall to ~(t₂ - τ)³ of Φ's (1e-36 at 1e-12 (t₂ - t₁)) and Van Loan's block
    loses e^{αΔt} more: 50 digits left Singer's at αΔt = 16 off by 4e-11."""
    with mp.workdps(100):
        phi_tau, q_tau = _mp_phi_q(sde, tau)
        phi_rest, _ = _mp_phi_q(sde, mp.mpf(t2) - mp.mpf(tau))
        phi_2, q_2 = _mp_phi_q(sde, t2)
        psi = q_tau * phi_rest.T * mp.inverse(q_2)
        lam = phi_tau - psi * phi_2
        return np.array(lam.tolist(), dtype=float), np.array(psi.tolist(), dtype=float)


# τ / (t₂ - t₁) log-spaced toward both states, and the middle.
TAU_FRACTIONS = sorted({*np.logspace(-12, -1, 12), 0.5, *(1 - np.logspace(-12, -1, 12))})

# Every route to Λ, Ψ: the paper's memoised closed forms, the batched ones, any LinearSDE's (WNOJ, Singer, the
# acceleration priors on a group through ``interpolation_terms``), each with its relative tolerance: a few ulps times
# a condition factor, for each entry of Λ, Ψ is a sum of products whose terms exceed it by up to the integer
# coefficients of Q₂⁻¹ (Q_pp⁻¹ = 12/Δt³ for WNOA; 720/Δt⁵ for WNOJ, and Singer at small αΔt). Measured worst:
# 2.4e-15 for WNOA, 6e-14 for WNOJ and Singer at α = 1.7 (at mid-interval; 1.5e-15 and 2.5e-14 at 1e-12 of either
# state), 1.7e-13 for Singer at αΔt = 16 (at τ = 0.9 Δt, where α (t₂ - τ) = 1.6 and Φ(τ, t₂) would amplify by e^1.6, so
# Ψ is a product as before the fix, which gave the same there). The priors on a group (lie.gp, lie.gp_accel,
# motion.lie_group, motion.lie_accel) interpolate their local variables with exactly these matrices.
FAST_SINGER = LinearSDE.singer(QC, 20.0)
LAMBDA_PSI_ROUTES = {
    "wnoa-memoised": (SDES["wnoa"], lambda sde, t2, tau: interpolation_matrices(0.0, t2, tau, QC), 1e-14),
    "wnoa-batched": (
        SDES["wnoa"],
        lambda sde, t2, tau: tuple(m[0] for m in interpolation_matrices_many(0.0, t2, [tau], QC)),
        1e-14,
    ),
    "wnoa-sde": (SDES["wnoa"], lambda sde, t2, tau: interpolation_matrices_sde(sde, 0.0, t2, tau), 1e-14),
    "wnoj-sde": (SDES["wnoj"], lambda sde, t2, tau: interpolation_matrices_sde(sde, 0.0, t2, tau), 1e-13),
    "singer-terms": (SDES["singer"], lambda sde, t2, tau: interpolation_terms(sde, 0.0, t2, tau)[:2], 1e-13),
    "singer-fast-sde": (FAST_SINGER, lambda sde, t2, tau: interpolation_matrices_sde(sde, 0.0, t2, tau), 3e-13),
}


def _entrywise_error(ours, want):
    """max over entries of abs(ours - want) / abs(want); an entry zero at 50 digits against the matrix's largest."""
    scale = np.abs(want).max()
    zero = np.abs(want) <= 1e-30 * scale
    return float(np.where(zero, np.abs(ours) / scale, np.abs(ours - want) / np.where(zero, 1.0, np.abs(want))).max())


@pytest.mark.parametrize("route", sorted(LAMBDA_PSI_ROUTES))
def test_every_entry_of_lambda_and_psi_keeps_its_relative_precision_next_to_either_state(route):
    """Λ(τ) → 0 and Ψ(τ) → I next to t₂ (Ψ → 0, Λ → Φ(τ, t₁) next to t₁): every entry of each, small ones included,
    to its route's tolerance of its 100-digit value at every τ. Φ(τ, t₁) - Ψ Φ(t₂, t₁) lost Λ's digits next to t₂ (5.8e-4
    of each entry of the paper's WNOA at 1e-12 (t₂ - t₁), all of them for WNOJ and Singer), and Q_τ Φ(t₂, τ)ᵀ Q₂⁻¹ Ψ's
    small entries there (2.3e-4)."""
    sde, matrices, rtol = LAMBDA_PSI_ROUTES[route]
    t2 = 0.8
    bad = []
    for fraction in TAU_FRACTIONS:
        tau = fraction * t2
        lam, psi = matrices(sde, t2, tau)
        want_lam, want_psi = _mp_lambda_psi(sde, t2, tau)
        errors = _entrywise_error(lam, want_lam), _entrywise_error(psi, want_psi)
        if max(errors) > rtol:
            bad.append(f"τ/(t₂ - t₁) = {fraction:.12g}: Λ {errors[0]:.1e}, Ψ {errors[1]:.1e}")
    assert not bad, f"relative error above {rtol:g} at " + "; ".join(bad)


@pytest.mark.parametrize("group", [SE2, SE3], ids=lambda g: g.name)
def test_the_lie_interpolated_covariance_of_exact_states_is_n_times_the_50_digit_conditional(group, rng):
    """The WNOA prior on a group: with P = 0 its covariance at τ is N Cov(γ(τ) | γ₁, γ₂) Nᵀ, N = ∂x(τ)/∂γ(τ); next
    to t₂ it must keep the conditional's relative precision (it is positive definite, and tiny)."""
    d = group.dim
    qc = np.diag(np.linspace(0.2, 0.6, d))
    x1 = np.r_[group.exp(rng.standard_normal(d)), rng.standard_normal(d)]
    x2 = np.r_[group.compose(x1[: group.size], group.exp(0.5 * rng.standard_normal(d))), rng.standard_normal(d)]
    t2, tau = 0.8, 0.8 * (1 - 1e-6)
    _, cov = lie_gp.interpolate_covariance(0.0, t2, tau, qc, x1, x2, np.zeros((4 * d, 4 * d)), group=group)
    lam, psi = interpolation_matrices(0.0, t2, tau, qc)
    gamma = lam @ np.r_[np.zeros(d), x1[group.size :]] + psi @ lie_gp.local_variables(
        x1, x2, "local-variable", group=group, jacobians=False
    )
    _, N, _ = lie_gp._from_local(x1, gamma, "local-variable", group)
    want = N @ np.kron(_mp_conditional(LinearSDE.wnoa(np.eye(1)), t2, tau), qc) @ N.T  # one axis's, ⊗ Qc
    scale = np.sqrt(np.outer(np.diag(want), np.diag(want)))  # each entry against its row's and column's variances
    np.testing.assert_allclose(cov / scale, want / scale, rtol=0, atol=1e-11)
    np.linalg.cholesky(cov)


def _mp_singer_q(dt, alpha):
    """Singer's Q(Δt) (Qc = 1) at 30 digits from its definition ∫₀^Δt g gᵀ ds, g the last column of Φ(s): with u = αs,
    Q_rc = α^-(k_r + k_c + 1) ∫₀^{αΔt} h_r h_c du, h = [u - 1 + e⁻ᵘ, 1 - e⁻ᵘ, e⁻ᵘ], k = (2, 1, 0); by quadrature up to
    u = 80 and beyond, where e⁻ᵘ < 1e-34, as the integrals of the polynomials (u - 1)², u - 1 and 1 that remain."""
    with mp.workdps(30):
        a, X = mp.mpf(alpha), mp.mpf(alpha) * mp.mpf(dt)
        h = (lambda u: u + mp.expm1(-u), lambda u: -mp.expm1(-u), lambda u: mp.exp(-u))
        near = min(X, mp.mpf(80))
        cuts = [mp.mpf(0)] + [mp.mpf(m) for m in (1, 10) if m < near] + [near]
        tail = {
            (0, 0): ((X - 1) ** 3 - (near - 1) ** 3) / 3,
            (0, 1): ((X - 1) ** 2 - (near - 1) ** 2) / 2,
            (1, 1): X - near,
        }
        q = np.zeros((3, 3))
        for r in range(3):
            for c in range(r, 3):
                whole = mp.quad(lambda u, r=r, c=c: h[r](u) * h[c](u), cuts) + tail.get((r, c), 0)
                q[r, c] = q[c, r] = float(whole / a ** ((2, 1, 0)[r] + (2, 1, 0)[c] + 1))
        return q


@pytest.mark.parametrize(("dt", "alpha"), [(1.0, 1e62), (1e30, 1e40), (2.0, 1e100)])
def test_singers_q_is_exact_at_any_alpha_dt_float64_holds(dt, alpha):
    """Every entry of Q to 1e-13 of its definition, also where (αΔt)⁵ or (αΔt)³ overflow float64 while Q does not
    (Q_pp came out 0 there, with no error). (tests/test_gp_models.py holds αΔt up to 60 to quadrature.)"""
    _assert_entrywise(singer_process_noise(dt, alpha, np.eye(1)), _mp_singer_q(dt, alpha), 1e-13)


def test_singers_q_that_float64_cannot_hold_is_refused():
    """Q_pp = Δt³/(3α²) below float64's range (α = 1e200, Δt = 1: 3e-401) is a NumericalError, not a Q with a zero
    variance."""
    with pytest.raises(NumericalError, match="alpha=1e\\+200"):
        singer_process_noise(1.0, 1e200, np.eye(1))


def test_a_time_constant_whose_alpha_overflows_is_named():
    with pytest.raises(SteamError, match="time_constant=1e-320"):
        LinearSDE.singer(np.eye(1), time_constant=1e-320)


# --- the local variables are the time derivatives of Log(T₁⁻¹ T(t)) -----------------------------------------------


def _mp_hat(group, x):
    if group is SE2:
        r1, r2, p = x
        return mp.matrix([[0, -p, r1], [p, 0, r2], [0, 0, 0]])
    r1, r2, r3, a, b, c = x
    return mp.matrix([[0, -c, b, r1], [c, 0, -a, r2], [-b, a, 0, r3], [0, 0, 0, 0]])


def _mp_vee(group, X):
    return [X[0, 2], X[1, 2], X[1, 0]] if group is SE2 else [X[0, 3], X[1, 3], X[2, 3], X[2, 1], X[0, 2], X[1, 0]]


def _on_a_cubic(group, c):
    """At t = 1 on T(t) = Exp(ξ(t)), ξ(t) = c₀t + c₁t² + c₂t³: T's matrix, ϖ and ϖ̇ (4th-order differences of
    mpmath's expm at 60 digits, h = 1e-16: error ~1e-32), and ξ, ξ̇, ξ̈ of the cubic."""
    with mp.workdps(60):
        T = lambda s: mp.expm(_mp_hat(group, [c[0][i] * s + c[1][i] * s**2 + c[2][i] * s**3 for i in range(group.dim)]))
        t, h = mp.mpf(1), mp.mpf("1e-16")
        m2, m1, m0, p1, p2 = (T(t + k * h) for k in (-2, -1, 0, 1, 2))
        d1 = (-p2 + 8 * p1 - 8 * m1 + m2) / (12 * h)
        d2 = (-p2 + 16 * p1 - 30 * m0 + 16 * m1 - m2) / (12 * h**2)
        Ti = mp.inverse(m0)
        twist, rate = _mp_vee(group, Ti * d1), _mp_vee(group, -Ti * d1 * Ti * d1 + Ti * d2)
        as_float = lambda v: np.array([float(a) for a in v])
        return np.array(m0.tolist(), dtype=float), as_float(twist), as_float(rate)


def _element(group, M):
    if group is SE2:
        return np.array([M[0, 2], M[1, 2], np.arctan2(M[1, 0], M[0, 0])])
    return np.r_[M[:3, 3], M[:3, :3].ravel()]


@pytest.mark.parametrize("group", [SE2, SE3], ids=lambda g: g.name)
@pytest.mark.parametrize("angle", [1e-6, 1.5, 3.1])
def test_the_local_variables_are_the_time_derivatives_of_the_log(group, angle, rng):
    """γ₂ = [ξ; ξ̇; ξ̈] of ``gp_accel`` (and [ξ; ξ̇] of the WNOA's local-variable model) at a state (T, ϖ, ϖ̇) on a
    known curve ξ(t) are the curve's, and the map back gives the state: the kinematics ξ̇ = J_r⁻¹ ϖ and
    ξ̈ = d/dt(J_r⁻¹ ϖ), signs and side included, not only a pair of maps that invert each other."""
    d = group.dim
    c = rng.standard_normal((3, d))
    turn = slice(2, 3) if group is SE2 else slice(3, 6)
    c[:, turn] *= angle / np.linalg.norm(c.sum(axis=0)[turn])  # ξ(1) turns by ``angle``
    M, twist, rate = _on_a_cubic(group, c)
    xi = c.sum(axis=0)
    want = np.r_[xi, c[0] + 2 * c[1] + 3 * c[2], 2 * c[1] + 6 * c[2]]  # ξ, ξ̇, ξ̈ at t = 1
    x1 = np.r_[group.identity(), rng.standard_normal(2 * d)]
    x2 = np.r_[_element(group, M), twist, rate]
    tol = {"rtol": 0, "atol": 1e-13 * max(1.0, np.abs(want).max())}
    np.testing.assert_allclose(gp_accel.local_variables(x1, x2, group=group, jacobians=False), want, **tol)
    np.testing.assert_allclose(
        lie_gp.local_variables(x1[:-d], x2[:-d], "local-variable", group=group, jacobians=False), want[: 2 * d], **tol
    )
    back = gp_accel.from_local(x1, want, group, jacobians=False)
    np.testing.assert_allclose(group.matrix(back[: group.size]), M, rtol=0, atol=1e-14)
    np.testing.assert_allclose(back[group.size :], x2[group.size :], rtol=0, atol=1e-13 * max(1.0, np.abs(x2).max()))
