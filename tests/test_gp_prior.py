"""The GP prior: closed forms, the general LTI SDE, the kernel and its sparse inverse.  [YIB Sec. II-B]"""

import numpy as np
import pytest
import scipy.integrate
from hypothesis import given, settings
from hypothesis import strategies as st
from oracles import gp_kernel, gp_mean, random_lti, random_spd, sde_input_integral, sde_process_noise

from steam_ref.errors import ShapeError, SteamError
from steam_ref.gp import LinearSDE, dense_kernel, process_noise, process_noise_inverse, transition


def random_times(rng, M, t0=0.3):
    return t0 + np.concatenate([[0.0], np.cumsum(rng.uniform(0.2, 1.0, size=M - 1))])


def random_problem(rng, kind):
    """A LinearSDE with a nonzero input v, its initial covariance and mean."""
    if kind == "wnoa":
        d = 2
        sde = LinearSDE.wnoa(random_spd(rng, d), v=rng.normal(size=2 * d))
    else:
        sde = LinearSDE(**random_lti(rng, n=4, m=2))
    return sde, random_spd(rng, sde.n), rng.normal(size=sde.n)


# --- closed forms versus matrix exponentials ------------------------------------------------


@pytest.mark.parametrize("d", [1, 2, 3])
def test_closed_forms_equal_wnoa_sde(rng, d):
    qc = random_spd(rng, d)
    sde = LinearSDE.wnoa(qc)
    for dt in rng.uniform(0.05, 4.0, size=3):
        np.testing.assert_allclose(transition(dt, d), sde.transition_expm(dt), rtol=1e-12, atol=1e-12)
        Q = sde.process_noise_van_loan(dt)
        np.testing.assert_array_equal(sde.process_noise(dt), process_noise(dt, qc))  # the SDE uses the closed form
        np.testing.assert_allclose(process_noise(dt, qc), Q, rtol=1e-10, atol=1e-12 * np.abs(Q).max())
        Qi = process_noise_inverse(dt, qc)
        np.testing.assert_allclose(Qi, np.linalg.inv(Q), rtol=1e-7, atol=1e-9 * np.abs(Qi).max())


def test_wnoa_constructor_is_eq_31(rng):
    d = 3
    sde = LinearSDE.wnoa(random_spd(rng, d))
    I, O = np.eye(d), np.zeros((d, d))
    np.testing.assert_array_equal(sde.A, np.block([[O, I], [O, O]]))
    np.testing.assert_array_equal(sde.F, np.vstack([O, I]))
    np.testing.assert_array_equal(sde.v, np.zeros(2 * d))
    assert not sde.A.flags.writeable


@pytest.mark.parametrize("d", [1, 3])
def test_q_times_q_inverse_is_identity(rng, d):
    qc = random_spd(rng, d)
    for dt in (0.01, 0.37, 5.0):
        np.testing.assert_allclose(
            process_noise(dt, qc) @ process_noise_inverse(dt, qc), np.eye(2 * d), rtol=0, atol=1e-9
        )


def test_van_loan_equals_quadrature(rng):
    sde = LinearSDE(**random_lti(rng, n=4, m=2))
    for dt in (0.13, 0.83, 2.1):
        reference = sde_process_noise(sde, dt)  # [YIB Eq. 17] by quad_vec
        np.testing.assert_allclose(sde.process_noise(dt), reference, rtol=1e-9, atol=1e-12 * np.abs(reference).max())


def test_wnoa_closed_form_q_equals_quadrature(rng):
    qc = random_spd(rng, 2)
    reference = sde_process_noise(LinearSDE.wnoa(qc), 0.71)
    np.testing.assert_allclose(process_noise(0.71, qc), reference, rtol=1e-10, atol=1e-13)


def test_transition_semigroup(rng):
    sde = LinearSDE(**random_lti(rng, n=4, m=2))
    t1, t2, t3 = np.sort(rng.uniform(0.5, 3.0, size=3))
    np.testing.assert_allclose(
        sde.transition(t3 - t1), sde.transition(t3 - t2) @ sde.transition(t2 - t1), rtol=1e-11, atol=1e-12
    )
    np.testing.assert_allclose(sde.transition(t2 - t1) @ sde.transition(t1 - t2), np.eye(4), rtol=0, atol=1e-12)


@settings(max_examples=30, deadline=None)
@given(
    dt1=st.floats(0.01, 3.0),
    dt2=st.floats(0.01, 3.0),
    seed=st.integers(0, 2**32 - 1),
)
def test_discretisation_composes_over_two_steps(dt1, dt2, seed):
    """Φ(t₃,t₁) = Φ(t₃,t₂)Φ(t₂,t₁), Q₃₁ = Φ₃₂ Q₂₁ Φ₃₂ᵀ + Q₃₂, v₃₁ = Φ₃₂ v₂₁ + v₃₂."""
    sde = LinearSDE(**random_lti(np.random.default_rng(seed), n=3, m=2))
    P32, P21 = sde.transition(dt2), sde.transition(dt1)
    np.testing.assert_allclose(sde.transition(dt1 + dt2), P32 @ P21, rtol=1e-10, atol=1e-12)
    Q = sde.process_noise(dt1 + dt2)
    composed = P32 @ sde.process_noise(dt1) @ P32.T + sde.process_noise(dt2)
    np.testing.assert_allclose(Q, composed, rtol=1e-9, atol=1e-12 * np.abs(Q).max())
    vi = sde.input_integral(dt1 + dt2)
    composed_v = P32 @ sde.input_integral(dt1) + sde.input_integral(dt2)
    np.testing.assert_allclose(vi, composed_v, rtol=1e-9, atol=1e-12 * np.abs(vi).max())


@settings(max_examples=30, deadline=None)
@given(dt=st.floats(1e-3, 20.0), d=st.integers(1, 3))
def test_closed_form_q_is_symmetric_positive_definite(dt, d):
    qc = np.diag(np.arange(1.0, d + 1))
    Q = process_noise(dt, qc)
    np.testing.assert_array_equal(Q, Q.T)
    assert np.all(np.linalg.eigvalsh(Q) > 0)


# --- mean: v_i and μ(t) against ODE integration ------------------------------------------------


def _integrate_mean(sde, t0, mu0, t_eval):
    sol = scipy.integrate.solve_ivp(
        lambda t, m: sde.A @ m + sde.v, (t0, t_eval.max()), mu0, t_eval=t_eval, rtol=1e-12, atol=1e-12, method="DOP853"
    )
    assert sol.success
    return sol.y.T


def test_input_integral_matches_ode_and_quadrature(rng):
    sde = LinearSDE(**random_lti(rng, n=4, m=2))
    dt = 1.37
    ode = _integrate_mean(sde, 0.0, np.zeros(4), np.array([dt]))[0]  # μ(dt) from μ(0) = 0 is v_i
    np.testing.assert_allclose(sde.input_integral(dt), ode, rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(sde.input_integral(dt), sde_input_integral(sde, dt), rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("kind", ["wnoa", "random"])
def test_mean_matches_ode(rng, kind):
    sde, _, mu0 = random_problem(rng, kind)
    t0 = 0.4
    times = np.array([2.9, 0.4, 1.1, 3.5, 1.1, 0.75])  # unsorted, repeated, one at t0
    unique, where = np.unique(times, return_inverse=True)
    expected = _integrate_mean(sde, t0, mu0, unique)[where]
    np.testing.assert_allclose(sde.mean(times, t0, mu0), expected, rtol=1e-9, atol=1e-10)


# --- the kernel K and its block-tridiagonal inverse  [YIB Eq. 3, 15, 22] ------------------------


@pytest.mark.parametrize("kind", ["wnoa", "random"])
def test_dense_kernel_equals_oracle(rng, kind):
    sde, P0, _ = random_problem(rng, kind)
    times = random_times(rng, 5)
    K = gp_kernel(times, sde, P0)
    np.testing.assert_allclose(dense_kernel(sde, times, P0), K, rtol=1e-9, atol=1e-11 * np.abs(K).max())


@pytest.mark.parametrize("kind", ["wnoa", "random"])
def test_kernel_inverse_is_block_tridiagonal(rng, kind):
    for _ in range(3):
        sde, P0, _ = random_problem(rng, kind)
        M, n = 7, sde.n
        K = gp_kernel(random_times(rng, M), sde, P0)
        K_inv = np.linalg.inv(K)
        scale = np.abs(K_inv).max()
        tol = 1e-13 * np.linalg.cond(K) * scale  # inv is accurate to about cond(K)·eps
        band = 0.0
        for j in range(M):
            for k in range(M):
                block = K_inv[j * n : (j + 1) * n, k * n : (k + 1) * n]
                if abs(j - k) > 1:
                    np.testing.assert_allclose(block, 0.0, rtol=0, atol=tol)
                elif abs(j - k) == 1:
                    band = max(band, np.abs(block).max())
        assert band > 1e-2 * scale  # the off-diagonal band itself is not empty


def prior_factor_system(sde, times, P0, mu0):
    """Σ Jᵀ Q⁻¹ J and Σ Jᵀ Q⁻¹ b from x₀ ~ N(μ₀, P0) and the [YIB Eq. 22] factors, in plain numpy."""
    n, M = sde.n, len(times)
    info, rhs = np.zeros((M * n, M * n)), np.zeros(M * n)
    J0 = np.zeros((n, M * n))
    J0[:, :n] = np.eye(n)
    terms = [(J0, mu0, P0)]
    for i in range(1, M):
        dt = times[i] - times[i - 1]
        J = np.zeros((n, M * n))  # residual x_i - Φ x_{i-1} - v_i  [YIB Eq. 22]
        J[:, (i - 1) * n : i * n] = -sde.transition(dt)
        J[:, i * n : (i + 1) * n] = np.eye(n)
        terms.append((J, sde.input_integral(dt), sde.process_noise(dt)))
    for J, b, cov in terms:
        info += J.T @ np.linalg.solve(cov, J)
        rhs += J.T @ np.linalg.solve(cov, b)
    return info, rhs


@pytest.mark.parametrize("kind", ["wnoa", "random"])
def test_prior_factor_information_equals_kernel_inverse(rng, kind):
    sde, P0, mu0 = random_problem(rng, kind)
    times = random_times(rng, 6)
    info, rhs = prior_factor_system(sde, times, P0, mu0)
    K = gp_kernel(times, sde, P0)
    K_inv = np.linalg.inv(K)
    tol = 1e-13 * np.linalg.cond(K) * np.abs(K_inv).max()  # inv is accurate to about cond(K)·eps
    np.testing.assert_allclose(info, K_inv, rtol=1e-9, atol=tol)
    # the factors' least-squares minimiser is the prior mean μ  [YIB Eq. 3, 22-23]
    mu = gp_mean(times, sde, mu0)
    np.testing.assert_allclose(
        np.linalg.solve(info, rhs), mu, rtol=1e-9, atol=1e-13 * np.linalg.cond(info) * np.abs(mu).max()
    )


# --- errors ---------------------------------------------------------------------------------


@pytest.mark.parametrize("qc", [np.diag([1.0, -1.0]), np.array([[1.0, 2.0], [0.0, 1.0]]), np.zeros((2, 2))])
def test_non_spd_qc_raises(qc):
    with pytest.raises(SteamError, match="positive definite"):
        process_noise(0.5, qc)
    with pytest.raises(SteamError, match="positive definite"):
        process_noise_inverse(0.5, qc)
    with pytest.raises(SteamError, match="positive definite"):
        LinearSDE.wnoa(qc)


@pytest.mark.parametrize("dt", [0.0, -0.3, np.inf, np.nan])
def test_non_positive_dt_raises(rng, dt):
    qc = random_spd(rng, 2)
    sde = LinearSDE(**random_lti(rng))
    for call in (
        lambda: process_noise(dt, qc),
        lambda: process_noise_inverse(dt, qc),
        lambda: sde.process_noise(dt),
        lambda: sde.input_integral(dt),
    ):
        with pytest.raises(SteamError, match="time step"):
            call()


def test_wrong_shapes_raise(rng):
    good = random_lti(rng, n=4, m=2)
    bad = [
        (dict(good, A=np.ones((4, 3))), r"A.*\(4, 3\)"),
        (dict(good, F=np.ones((3, 2))), r"F.*\(3, 2\)"),
        (dict(good, qc=np.eye(3)), r"Qc.*\(3, 3\)"),
        (dict(good, v=np.ones(3)), r"v.*\(3,\)"),
        (dict(good, A=np.full((4, 4), np.nan)), r"A\[0, 0\] = nan"),
    ]
    for kwargs, pattern in bad:
        with pytest.raises(ShapeError, match=pattern):
            LinearSDE(**kwargs)
    with pytest.raises(ShapeError, match=r"\(1, 2\)"):
        process_noise(0.5, np.ones((1, 2)))
    sde = LinearSDE(**good)
    with pytest.raises(ShapeError, match=r"mu0.*\(3,\)"):
        sde.mean([1.0], 0.0, np.zeros(3))
    with pytest.raises(ShapeError, match=r"P0.*\(2, 2\)"):
        dense_kernel(sde, [0.0, 1.0], np.eye(2))


def test_bad_times_raise(rng):
    sde = LinearSDE(**random_lti(rng))
    with pytest.raises(SteamError, match="t >= t0"):
        sde.mean([0.5, 1.0], 0.7, np.zeros(4))
    with pytest.raises(SteamError, match="strictly increasing"):
        dense_kernel(sde, [0.0, 1.0, 1.0], np.eye(4))


# --- memoisation by value ---------------------------------------------------------------------


def test_sqrt_information_is_memoised_by_value_and_read_only(rng):
    from steam_ref.gp import process_noise_sqrt_information

    qc = random_spd(rng, 3)
    W = process_noise_sqrt_information(0.7, qc)
    np.testing.assert_allclose(W.T @ W, process_noise_inverse(0.7, qc), rtol=1e-10)
    assert np.allclose(np.triu(W), W)
    with pytest.raises(ValueError, match="read-only"):
        W[0, 0] = 1.0  # shared between factors: must not be writable
    # a different Qc (or gap) with the same shape gets its own matrix, not the memoised one
    W2 = process_noise_sqrt_information(0.7, 2.0 * qc)
    np.testing.assert_allclose(W2.T @ W2, process_noise_inverse(0.7, 2.0 * qc), rtol=1e-10)
    W3 = process_noise_sqrt_information(0.8, qc)
    np.testing.assert_allclose(W3.T @ W3, process_noise_inverse(0.8, qc), rtol=1e-10)


def test_bad_qc_raises_every_time_not_once():
    bad = np.diag([1.0, -1.0])
    for _ in range(2):  # a failed check must not be memoised as a success
        with pytest.raises(SteamError, match="positive definite"):
            process_noise(0.5, bad)
    with pytest.raises(ShapeError, match="finite"):
        process_noise(0.5, np.array([[1.0, np.nan], [np.nan, 1.0]]))


def test_qc_inverse_is_the_inverse_by_a_cholesky_solve_symmetric_and_read_only(rng):
    from steam_ref.gp.prior import qc_inverse

    a = rng.normal(size=(3, 3))
    qc = a @ a.T + 0.3 * np.eye(3)
    inverse = qc_inverse(qc)
    np.testing.assert_allclose(inverse @ qc, np.eye(3), rtol=0, atol=1e-12)  # oracle: the definition
    np.testing.assert_allclose(inverse, np.linalg.inv(qc), rtol=1e-12, atol=1e-14)
    assert np.array_equal(inverse, inverse.T) and not inverse.flags.writeable


@pytest.mark.parametrize("scale", [1e-9, 1.0, 1e6])
def test_qc_not_symmetric_at_any_scale_raises(scale):
    """An asymmetry of 5 % is refused whatever the units: with an absolute tolerance a Qc of 1e-9 passed, and
    Q(dt) = Q-pattern ⊗ Qc came out not symmetric (Q[0, 1] = 5 Q[1, 0] by hand)."""
    qc = scale * np.array([[1.0, 0.05], [0.0, 1.0]])
    with pytest.raises(SteamError, match="symmetric"):
        process_noise(1.0, qc)
