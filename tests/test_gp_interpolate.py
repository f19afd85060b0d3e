"""GP interpolation between estimated states against the dense GP.  [YIB Eq. 12, 16, 18]"""

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st
from oracles import (
    condition_gaussian,
    gp_kernel,
    gp_mean,
    random_lti,
    random_spd,
    sde_input_integral,
    sde_transition,
)

from steam_ref.errors import ShapeError, SteamError
from steam_ref.factors import InterpolatedFactor, PriorFactor
from steam_ref.gp import (
    LinearSDE,
    extrapolate_covariance_sde,
    extrapolate_state_sde,
    interpolate_covariance,
    interpolate_covariance_sde,
    interpolate_state,
    interpolate_state_sde,
    interpolation_matrices,
    interpolation_matrices_many,
    interpolation_matrices_sde,
    process_noise,
    transition,
)
from steam_ref.motion import predict_state
from steam_ref.variables import X


def dense_problem(rng, kind, M=5):
    """Estimated times, one query τ in each of three intervals, and the dense prior over all of them.

    Returns (sde, qc, est_times, taus, intervals, all_times, K, mu) where intervals[k] = i means
    est_times[i-1] < taus[k] < est_times[i]; K and mu are over all_times (sorted union).
    """
    if kind == "wnoa":
        qc = random_spd(rng, 2)
        sde = LinearSDE.wnoa(qc, v=rng.normal(size=4))
    elif kind in ("wnoj", "singer"):  # the closed forms of Φ and Q, with an input v
        qc = random_spd(rng, 2)
        sde = (
            LinearSDE.wnoj(qc, v=rng.normal(size=6))
            if kind == "wnoj"
            else LinearSDE.singer(qc, 2.5, v=rng.normal(size=6))
        )
    else:
        qc, sde = None, LinearSDE(**random_lti(rng, n=4, m=2))
    est_times = 0.2 + np.concatenate([[0.0], np.cumsum(rng.uniform(0.3, 1.0, size=M - 1))])
    intervals = np.array([1, M // 2 + 1, M - 1])  # first, a middle one and the last
    lo, hi = est_times[intervals - 1], est_times[intervals]
    taus = lo + rng.uniform(0.1, 0.9, size=3) * (hi - lo)
    all_times = np.sort(np.concatenate([est_times, taus]))
    K = gp_kernel(all_times, sde, random_spd(rng, sde.n))
    mu = gp_mean(all_times, sde, rng.normal(size=sde.n))
    return sde, qc, est_times, taus, intervals, all_times, K, mu


def block_index(all_times, times, n):
    """Row indices into K of the states at `times`."""
    pos = np.searchsorted(all_times, times)
    return (pos[:, None] * n + np.arange(n)).ravel()


def matrices(kind, sde, qc, t1, t2, tau):
    if kind == "wnoa":  # the closed forms, which must equal the general ones (checked below)
        return interpolation_matrices(t1, t2, tau, qc)
    return interpolation_matrices_sde(sde, t1, t2, tau)


# --- Λ, Ψ: the only nonzero blocks of K(τ)K⁻¹  [YIB Eq. 12, 16] ---------------------------------


@pytest.mark.parametrize("kind", ["wnoa", "wnoj", "singer", "random"])
def test_lambda_psi_are_the_blocks_of_dense_k_tau_k_inv(rng, kind):
    sde, qc, est, taus, intervals, all_times, K, _ = dense_problem(rng, kind)
    n, M = sde.n, est.size
    E = block_index(all_times, est, n)
    K_EE = K[np.ix_(E, E)]
    for tau, i in zip(taus, intervals, strict=True):
        T = block_index(all_times, [tau], n)
        G = np.linalg.solve(K_EE, K[np.ix_(E, T)]).T  # K(τ) K⁻¹, (n, M n)  [YIB Eq. 12]
        lam, psi = matrices(kind, sde, qc, est[i - 1], est[i], tau)
        tol = 1e-13 * np.linalg.cond(K_EE) * np.abs(G).max()  # solve is accurate to about cond·eps
        expected = np.zeros((n, M * n))
        expected[:, (i - 1) * n : i * n], expected[:, i * n : (i + 1) * n] = lam, psi  # [YIB Eq. 16]
        np.testing.assert_allclose(G, expected, rtol=1e-8, atol=tol)


@pytest.mark.parametrize("u", [2.0**-20, 0.125, 1365 / 4096, 0.5, 0.875, 1 - 2.0**-20])  # 1365/4096 ≈ 1/3 - 8e-5
def test_wnoa_lambda_psi_are_the_hand_derived_polynomials(u):
    """With s = τ - t₁, r = t₂ - τ, Δt = s + r (derivations §3; Qc cancels):
    Λ = [[r²(r + 3s)/Δt³, r²s/Δt²], [-6rs/Δt³, r(r - 2s)/Δt²]] ⊗ I, Ψ = [[s²(s + 3r)/Δt³, -rs²/Δt²], [6rs/Δt³,
    s(s - 2r)/Δt²]] ⊗ I: Λ₂₂ = (1 - u)(1 - 3u), u = s/Δt, the sign change ``gp.interpolate._lambda_psi`` names.
    Each entry to its relative precision next to either state; Λ₂₂ near its root to the matrix's scale. Times are
    dyadic, so s, r and Δt are exact and the only rounding is the code's."""
    d, t1, dt = 2, 0.5, 2.0
    s, r = u * dt, (1 - u) * dt
    lam, psi = interpolation_matrices(t1, t1 + dt, t1 + s, np.diag([0.3, 7.0]))
    want_lam = np.array(
        [[r * r * (r + 3 * s) / dt**3, r * r * s / dt**2], [-6 * r * s / dt**3, r * (r - 2 * s) / dt**2]]
    )
    want_psi = np.array(
        [[s * s * (s + 3 * r) / dt**3, -r * s * s / dt**2], [6 * r * s / dt**3, s * (s - 2 * r) / dt**2]]
    )
    assert want_lam[1, 1] == pytest.approx((1 - u) * (1 - 3 * u), rel=1e-14)
    for got, want, root in ((lam, want_lam, (1, 1)), (psi, want_psi, None)):
        tol = 1e-13 * np.abs(want)
        if root is not None:
            tol[root] += 1e-15 * np.abs(want).max()  # a sign change inside the interval: to the matrix's scale
        np.testing.assert_array_less(np.abs(got - np.kron(want, np.eye(d))), np.kron(tol, np.eye(d)) + 1e-300)


@pytest.mark.parametrize("d", [1, 3])
def test_wnoa_closed_form_interpolation_equals_sde(rng, d):
    qc = random_spd(rng, d)
    sde = LinearSDE.wnoa(qc).general()  # Φ by expm, Q by Van Loan: independent of the closed forms
    t1, tau, t2 = np.sort(rng.uniform(0.5, 4.0, size=3))
    for closed, general in zip(
        interpolation_matrices(t1, t2, tau, qc), interpolation_matrices_sde(sde, t1, t2, tau), strict=True
    ):
        np.testing.assert_allclose(closed, general, rtol=1e-9, atol=1e-11)
    x1, x2 = rng.normal(size=2 * d), rng.normal(size=2 * d)
    np.testing.assert_allclose(
        interpolate_state(t1, x1, t2, x2, tau, qc),
        interpolate_state_sde(sde, t1, x1, t2, x2, tau),
        rtol=1e-9,
        atol=1e-11,
    )
    P = random_spd(rng, 4 * d)
    np.testing.assert_allclose(
        interpolate_covariance(t1, t2, tau, qc, P),
        interpolate_covariance_sde(sde, t1, t2, tau, P),
        rtol=1e-9,
        atol=1e-11,
    )


# --- the mean: Eq. 18 equals the dense Eq. 12 -----------------------------------------------------


@pytest.mark.parametrize("kind", ["wnoa", "wnoj", "singer", "random"])
def test_interpolate_state_sde_equals_dense_posterior_mean(rng, kind):
    """Nonzero μ (v ≠ 0, μ₀ ≠ 0): x̄(τ) = μ(τ) + K(τ)K⁻¹(x̄ - μ)  [YIB Eq. 12]."""
    sde, _, est, taus, intervals, all_times, K, mu = dense_problem(rng, kind)
    n = sde.n
    E = block_index(all_times, est, n)
    x_bar = rng.normal(size=(est.size, n)) * 3.0
    for tau, i in zip(taus, intervals, strict=True):
        T = block_index(all_times, [tau], n)
        dense = mu[T] + K[np.ix_(T, E)] @ np.linalg.solve(K[np.ix_(E, E)], x_bar.ravel() - mu[E])  # [YIB Eq. 12]
        got = interpolate_state_sde(sde, est[i - 1], x_bar[i - 1], est[i], x_bar[i], tau)
        np.testing.assert_allclose(got, dense, rtol=1e-7, atol=1e-8 * np.abs(dense).max())


def test_interpolate_state_equals_dense_zero_mean_wnoa(rng):
    qc = random_spd(rng, 3)
    sde = LinearSDE.wnoa(qc)
    est = np.array([0.3, 1.0, 1.4, 2.6])
    tau = 1.93
    all_times = np.sort(np.append(est, tau))
    K = gp_kernel(all_times, sde, random_spd(rng, 6))
    E, T = block_index(all_times, est, 6), block_index(all_times, [tau], 6)
    x_bar = rng.normal(size=(4, 6))
    dense = K[np.ix_(T, E)] @ np.linalg.solve(K[np.ix_(E, E)], x_bar.ravel())  # [YIB Eq. 12], μ = 0
    got = interpolate_state(1.4, x_bar[2], 2.6, x_bar[3], tau, qc)
    np.testing.assert_allclose(got, dense, rtol=1e-8, atol=1e-9 * np.abs(dense).max())


# --- the covariance at τ against dense marginalisation ------------------------------------------


@pytest.mark.parametrize("kind", ["wnoa", "wnoj", "singer", "random"])
def test_interpolate_covariance_equals_dense_posterior(rng, kind):
    """Random linear measurements of the estimated states only; condition the whole joint densely."""
    sde, qc, est, taus, intervals, all_times, K, mu = dense_problem(rng, kind)
    n = sde.n
    E = block_index(all_times, est, n)
    H = np.zeros((3 * est.size, all_times.size * n))
    H[:, E] = rng.normal(size=(3 * est.size, E.size))  # no column touches a query time
    R = random_spd(rng, H.shape[0], scale=0.1)
    y = rng.normal(size=H.shape[0])
    post_mean, post_cov = condition_gaussian(mu, K, H, R, y)
    for tau, i in zip(taus, intervals, strict=True):
        T = block_index(all_times, [tau], n)
        pair = block_index(all_times, est[[i - 1, i]], n)
        joint_cov = post_cov[np.ix_(pair, pair)]
        if kind == "wnoa":
            got = interpolate_covariance(est[i - 1], est[i], tau, qc, joint_cov)
        else:
            got = interpolate_covariance_sde(sde, est[i - 1], est[i], tau, joint_cov)
        expected = post_cov[np.ix_(T, T)]
        np.testing.assert_allclose(got, expected, rtol=1e-7, atol=1e-9 * np.abs(expected).max())
        x1, x2 = post_mean[pair[:n]], post_mean[pair[n:]]
        got_mean = interpolate_state_sde(sde, est[i - 1], x1, est[i], x2, tau)
        np.testing.assert_allclose(got_mean, post_mean[T], rtol=1e-7, atol=1e-9 * np.abs(post_mean).max())


def test_interpolate_covariance_of_exact_states_is_dense_conditional(rng):
    """joint_cov = 0: Cov(x(τ) | all states) = K_ττ - K_τE K_EE⁻¹ K_Eτ, and it is positive definite."""
    sde = LinearSDE(**random_lti(rng, n=4, m=4))
    est = np.array([0.1, 0.7, 1.5, 2.0])
    tau = 1.21
    all_times = np.sort(np.append(est, tau))
    K = gp_kernel(all_times, sde, random_spd(rng, 4))
    E, T = block_index(all_times, est, 4), block_index(all_times, [tau], 4)
    expected = K[np.ix_(T, T)] - K[np.ix_(T, E)] @ np.linalg.solve(K[np.ix_(E, E)], K[np.ix_(E, T)])
    got = interpolate_covariance_sde(sde, 0.7, 1.5, tau, np.zeros((8, 8)))
    np.testing.assert_allclose(got, expected, rtol=1e-7, atol=1e-10 * np.abs(expected).max())
    assert np.all(np.linalg.eigvalsh(got) > 0)


@settings(max_examples=40, deadline=None)
@given(
    t1=st.floats(-50.0, 50.0),
    length=st.floats(0.05, 10.0),
    frac=st.floats(0.01, 0.99),
    seed=st.integers(0, 2**32 - 1),
)
def test_wnoa_interpolation_properties(t1, length, frac, seed):
    """Constant-velocity motion is interpolated exactly; the conditional covariance is PSD and ≤ Q_τ."""
    rng = np.random.default_rng(seed)
    qc = random_spd(rng, 2)
    t2, tau = t1 + length, t1 + frac * length
    x1 = rng.normal(size=4)
    x2 = transition(length, 2) @ x1  # no acceleration between t₁ and t₂
    got = interpolate_state(t1, x1, t2, x2, tau, qc)
    np.testing.assert_allclose(
        got, transition(tau - t1, 2) @ x1, rtol=1e-8, atol=1e-8 * (1 + np.abs(x1).max() * length)
    )
    cond = interpolate_covariance(t1, t2, tau, qc, np.zeros((8, 8)))
    scale = np.abs(process_noise(tau - t1, qc)).max()
    np.testing.assert_allclose(cond, cond.T, rtol=0, atol=0)
    assert np.linalg.eigvalsh(cond).min() > -1e-9 * scale
    assert np.linalg.eigvalsh(process_noise(tau - t1, qc) - cond).min() > -1e-9 * scale


# --- after the last state: the prior's prediction against the dense GP posterior ---------------


def extrapolation_sde(rng, kind):
    """An SDE of each kind with a nonzero input v."""
    if kind == "random":
        return LinearSDE(**random_lti(rng, n=4, m=2))
    qc = random_spd(rng, 2)
    make = {"wnoa": LinearSDE.wnoa, "wnoj": LinearSDE.wnoj, "singer": lambda q, v: LinearSDE.singer(q, 0.8, v=v)}[kind]
    return make(qc, v=rng.normal(size=(2 if kind == "wnoa" else 3) * 2))


@pytest.mark.parametrize("kind", ["wnoa", "wnoj", "singer", "random"])
def test_extrapolation_equals_dense_posterior(rng, kind):
    """Linear measurements of the states only; the dense joint over states and two later times,
    conditioned on them, has at each later time the mean Φ x̄_N + v and covariance Φ P_N Φᵀ + Q."""
    sde = extrapolation_sde(rng, kind)
    n = sde.n
    est = 0.3 + np.concatenate([[0.0], np.cumsum(rng.uniform(0.3, 1.0, size=3))])
    later = est[-1] + np.array([0.4, 1.9])
    all_times = np.concatenate([est, later])
    K, mu = gp_kernel(all_times, sde, random_spd(rng, n)), gp_mean(all_times, sde, rng.normal(size=n))
    E = block_index(all_times, est, n)
    H = np.zeros((2 * est.size, all_times.size * n))
    H[:, E] = rng.normal(size=(2 * est.size, E.size))  # no column touches a later time
    post_mean, post_cov = condition_gaussian(
        mu, K, H, random_spd(rng, H.shape[0], scale=0.1), rng.normal(size=H.shape[0])
    )
    last = block_index(all_times, est[-1:], n)
    for t in later:
        T = block_index(all_times, [t], n)
        got = extrapolate_state_sde(sde, est[-1], post_mean[last], t)
        np.testing.assert_allclose(got, post_mean[T], rtol=1e-7, atol=1e-9 * np.abs(post_mean).max())
        got_cov = extrapolate_covariance_sde(sde, est[-1], t, post_cov[np.ix_(last, last)])
        expected = post_cov[np.ix_(T, T)]
        np.testing.assert_allclose(got_cov, expected, rtol=1e-7, atol=1e-9 * np.abs(expected).max())


def test_extrapolation_of_an_exact_state_is_the_dense_conditional(rng):
    """cov1 = 0: Cov(x(t) | all states) = K_tt - K_tE K_EE⁻¹ K_Et, which is Q(t - t_N) alone."""
    sde = LinearSDE.singer(random_spd(rng, 2), time_constant=0.6)
    est, t = np.array([0.1, 0.7, 1.5]), 2.35
    all_times = np.append(est, t)
    K = gp_kernel(all_times, sde, random_spd(rng, 6))
    E, T = block_index(all_times, est, 6), block_index(all_times, [t], 6)
    expected = K[np.ix_(T, T)] - K[np.ix_(T, E)] @ np.linalg.solve(K[np.ix_(E, E)], K[np.ix_(E, T)])
    got = extrapolate_covariance_sde(sde, 1.5, t, np.zeros((6, 6)))
    np.testing.assert_allclose(got, expected, rtol=1e-7, atol=1e-10 * np.abs(expected).max())


@pytest.mark.parametrize("t", [1.0, 0.5, np.nan, np.inf])
def test_extrapolation_needs_a_later_time(rng, t):
    sde = LinearSDE.wnoa(random_spd(rng, 2))
    with pytest.raises(SteamError, match=f"t={t}"):  # a finite t before t1, or a t that is not finite
        extrapolate_state_sde(sde, 1.0, np.ones(4), t)
    with pytest.raises(SteamError, match=f"t={t}"):
        extrapolate_covariance_sde(sde, 1.0, t, np.eye(4))


def test_extrapolation_shapes_are_checked(rng):
    sde = LinearSDE.wnoa(random_spd(rng, 2))
    with pytest.raises(ShapeError, match=r"x1.*\(3,\)"):
        extrapolate_state_sde(sde, 0.0, np.ones(3), 1.0)
    with pytest.raises(ShapeError, match=r"cov1.*\(4, 4\).*\(4, 3\)"):
        extrapolate_covariance_sde(sde, 0.0, 1.0, np.ones((4, 3)))


# --- errors ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("t1", "t2", "tau"), [(1.0, 2.0, 1.0), (1.0, 2.0, 2.0), (1.0, 2.0, 0.5), (1.0, 2.0, 2.5), (2.0, 1.0, 1.5)]
)
def test_tau_outside_interval_raises(rng, t1, t2, tau):
    qc = random_spd(rng, 2)
    sde = LinearSDE.wnoa(qc)
    x, P = np.ones(4), np.eye(8)
    for call in (
        lambda: interpolation_matrices(t1, t2, tau, qc),
        lambda: interpolate_state(t1, x, t2, x, tau, qc),
        lambda: interpolate_covariance(t1, t2, tau, qc, P),
        lambda: interpolation_matrices_sde(sde, t1, t2, tau),
        lambda: interpolate_state_sde(sde, t1, x, t2, x, tau),
        lambda: interpolate_covariance_sde(sde, t1, t2, tau, P),
    ):
        with pytest.raises(SteamError, match="t1 < tau < t2"):
            call()


def test_non_spd_qc_raises_in_interpolation():
    qc = np.array([[1.0, 0.0], [0.0, -2.0]])
    with pytest.raises(SteamError, match="positive definite"):
        interpolation_matrices(0.0, 1.0, 0.5, qc)
    with pytest.raises(SteamError, match="positive definite"):
        interpolate_covariance(0.0, 1.0, 0.5, qc, np.eye(8))


def test_wrong_shapes_raise_in_interpolation(rng):
    qc = random_spd(rng, 2)
    sde = LinearSDE.wnoa(qc)
    with pytest.raises(ShapeError, match=r"joint_cov.*\(8, 8\).*\(4, 4\)"):
        interpolate_covariance(0.0, 1.0, 0.5, qc, np.eye(4))
    with pytest.raises(ShapeError, match=r"joint_cov.*\(8, 8\).*\(8, 7\)"):
        interpolate_covariance_sde(sde, 0.0, 1.0, 0.5, np.ones((8, 7)))
    with pytest.raises(ShapeError, match=r"x1.*\(3,\)"):
        interpolate_state(0.0, np.ones(3), 1.0, np.ones(4), 0.5, qc)
    with pytest.raises(ShapeError, match=r"x2.*\(4, 1\)"):
        interpolate_state_sde(sde, 0.0, np.ones(4), 1.0, np.ones((4, 1)), 0.5)


def test_interpolation_matrices_depend_on_gaps_and_qc_only(rng):
    """Memoised on (τ - t₁, t₂ - t₁, Qc): a shifted interval gives the same Λ, Ψ; a Qc of another size
    gets its own (for the WNOA prior Λ and Ψ do not depend on Qc's values, only on its size)."""
    qc = random_spd(rng, 2)
    sde = LinearSDE.wnoa(qc).general()
    lam, psi = interpolation_matrices(10.0, 12.0, 10.5, qc)
    for closed, general in zip((lam, psi), interpolation_matrices_sde(sde, 3.0, 5.0, 3.5), strict=True):
        np.testing.assert_allclose(closed, general, rtol=1e-9, atol=1e-12)
    assert not lam.flags.writeable and not psi.flags.writeable
    qc3 = random_spd(rng, 3)
    lam3, psi3 = interpolation_matrices(10.0, 12.0, 10.5, qc3)
    assert lam3.shape == (6, 6)
    for closed, general in zip(
        (lam3, psi3), interpolation_matrices_sde(LinearSDE.wnoa(qc3).general(), 0.0, 2.0, 0.5), strict=True
    ):
        np.testing.assert_allclose(closed, general, rtol=1e-9, atol=1e-12)


def test_a_float32_time_is_read_as_float64_by_every_interpolation():
    """NumPy 2 keeps float32 - float in float32: τ - t₁ with τ = float32(1000) and t₁ = 999.9 lost ~1e-8 of Q(τ - t₁)
    (and a float32 τ far from t₁ overflowed); every function must give what the float64 time gives."""
    sde = LinearSDE.wnoj(np.diag([0.1, 0.2, 0.3]), v=np.arange(9.0) / 10)
    t1, t2, tau = 999.9, 1000.3, np.float32(1000.0)
    x1, x2, P = np.ones(sde.n), np.arange(sde.n, dtype=float), np.eye(2 * sde.n)
    inner = PriorFactor.create(X(9), np.zeros(sde.n), np.ones(sde.n))
    calls = [
        lambda tau: interpolate_covariance_sde(sde, t1, t2, tau, P),
        lambda tau: interpolate_state_sde(sde, t1, x1, t2, x2, tau),
        lambda tau: InterpolatedFactor.create(inner, X(0), X(1), t1, t2, tau, sde).offset,  # [YIB Eq. 23]
    ]
    for call in calls:
        np.testing.assert_array_equal(call(tau), call(float(tau)))


@pytest.mark.parametrize("kind", ["wnoa", "wnoj", "singer", "random"])
def test_predict_state_is_the_prior_mean_from_expm(rng, kind):
    """A new state's starting value is Φ(dt) x_prev + v(dt), with Φ = expm(A dt) and v by quadrature.  [YIB Eq. 14, 22]"""
    sde = extrapolation_sde(rng, kind)
    x_prev, dt = rng.normal(size=sde.n), 0.7
    expected = sde_transition(sde, dt) @ x_prev + sde_input_integral(sde, dt)
    np.testing.assert_allclose(predict_state(x_prev, dt, sde), expected, rtol=1e-10, atol=1e-12)


def test_predict_state_of_the_papers_prior_moves_the_pose_by_the_velocity(rng):
    """For Qc (the zero-mean WNOA prior), Φ = expm([[0, I], [0, 0]] dt): [x, y, θ] += dt [ẋ, ẏ, θ̇], velocity kept."""
    qc = 0.01 * np.diag([1.0, 1.0, 25.0])
    x_prev, dt = rng.normal(size=6), 0.3
    A = np.block([[np.zeros((3, 3)), np.eye(3)], [np.zeros((3, 3)), np.zeros((3, 3))]])
    got = predict_state(x_prev, dt, qc)
    np.testing.assert_allclose(got, scipy.linalg.expm(A * dt) @ x_prev, rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(got, np.concatenate([x_prev[:3] + dt * x_prev[3:], x_prev[3:]]), rtol=1e-14)
    assert not np.shares_memory(got, x_prev)  # a new array


@pytest.mark.parametrize(
    ("x_prev", "dt", "error", "match"),
    [
        (np.zeros(5), 1.0, ShapeError, r"x_prev must be a finite \(6,\) vector"),
        (np.zeros(6), 0.0, SteamError, "dt must be > 0"),
        (np.zeros(6), -1.0, SteamError, "dt must be > 0"),
        (np.zeros(6), True, SteamError, "dt must be a real number"),
        ([0, 0, 0, np.nan, 0, 0], 1.0, ShapeError, "x_prev"),
    ],
)
def test_predict_state_refuses_bad_input_naming_it(x_prev, dt, error, match):
    with pytest.raises(error, match=match):
        predict_state(x_prev, dt, np.eye(3))


@pytest.mark.parametrize("d", [1, 6])
def test_many_interpolation_matrices_at_once_equal_the_sde_and_each_one_alone(rng, d):
    """Λ(τ), Ψ(τ) of 40 times between two states in one call (the readings a gyro makes between two GPS fixes)
    against Van Loan's (an SDE of its own) and against the memoised one-at-a-time closed form."""
    qc = random_spd(rng, d)
    sde = LinearSDE.wnoa(qc).general()
    t1, t2 = 3.0, 3.0 + rng.uniform(0.5, 2.0)
    taus = np.sort(rng.uniform(t1, t2, size=40))
    lam, psi = interpolation_matrices_many(t1, t2, taus, qc)
    assert lam.shape == psi.shape == (40, 2 * d, 2 * d) and not lam.flags.writeable and not psi.flags.writeable
    for i, tau in enumerate(taus):
        for many, general, alone in zip(
            (lam[i], psi[i]), interpolation_matrices_sde(sde, t1, t2, tau), interpolation_matrices(t1, t2, tau, qc),
            strict=True,
        ):  # fmt: skip
            np.testing.assert_allclose(many, general, rtol=1e-9, atol=1e-11)
            np.testing.assert_allclose(many, alone, rtol=1e-13, atol=1e-14)


def test_many_interpolation_matrices_refuse_a_time_outside_naming_it():
    qc = np.eye(2)
    for taus, shown in (([0.5, 1.0, 0.7], "at 1: t1=0.0, tau=1.0, t2=1.0"), ([0.5, np.nan], "at 1: t1=0.0, tau=nan")):
        with pytest.raises(SteamError, match=f"interpolation needs t1 < tau < t2 .*{shown}"):
            interpolation_matrices_many(0.0, 1.0, taus, qc)
    with pytest.raises(SteamError, match="a vector of times"):
        interpolation_matrices_many(0.0, 1.0, [[0.5]], qc)
