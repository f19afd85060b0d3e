"""WNOJ and Singer priors: closed forms against expm / Van Loan, quadrature, hand-derived series and
the dense GP kernel.  [YIB Eq. 14, 16, 17, 22]"""

import numpy as np
import pytest
import scipy.integrate
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st
from oracles import gp_kernel, random_spd, sde_process_noise, sde_transition

from steam_ref.errors import ShapeError, SteamError
from steam_ref.gp import (
    ClosedForm,
    LinearSDE,
    dense_kernel,
    singer_process_noise,
    singer_transition,
    wnoj_process_noise,
    wnoj_process_noise_inverse,
    wnoj_transition,
)
from steam_ref.gp.models import SINGER_LARGEST_ALPHA_DT

# Hand-derived, independent of the code's series table (docs/derivations.md, section 6):
# Q_rc = Δt^(k_r + k_c + 1) S_rc(x) ⊗ Qc, k = (2, 1, 0), S(x) = S0 - x S1 + O(x²)
S0 = np.array([[1 / 20, 1 / 8, 1 / 6], [1 / 8, 1 / 3, 1 / 2], [1 / 6, 1 / 2, 1.0]])
S1 = np.array([[1 / 36, 1 / 12, 1 / 6], [1 / 12, 1 / 4, 1 / 2], [1 / 6, 1 / 2, 1.0]])


def scale_of(dt, d):
    """D ⊗ 1 with D = (Δt², Δt, 1): Q = Δt (D S D) ⊗ Qc."""
    D = np.repeat([dt**2, dt, 1.0], d)
    return dt * np.outer(D, D)


def normalised(Q, ref):
    """Q in units of √(diag ref ⊗ diag ref): entries of very different sizes compared alike."""
    s = np.sqrt(np.diag(ref))
    return Q / np.outer(s, s)


def sdes(rng, d):
    qc = random_spd(rng, d)
    return [LinearSDE.wnoj(qc)] + [LinearSDE.singer(qc, alpha) for alpha in (0.3, 2.0, 15.0)]


# --- the SDEs themselves ---------------------------------------------------------------------------


def test_constructors_build_the_sde_by_hand(rng):
    d, alpha = 2, 0.7
    qc = random_spd(rng, d)
    I, O = np.eye(d), np.zeros((d, d))
    F = np.vstack([O, O, I])
    wnoj, singer = LinearSDE.wnoj(qc), LinearSDE.singer(qc, alpha)
    np.testing.assert_array_equal(wnoj.A, np.block([[O, I, O], [O, O, I], [O, O, O]]))
    np.testing.assert_array_equal(singer.A, np.block([[O, I, O], [O, O, I], [O, O, -alpha * I]]))
    for sde in (wnoj, singer):
        np.testing.assert_array_equal(sde.F, F)
        np.testing.assert_array_equal(sde.qc, qc)
        np.testing.assert_array_equal(sde.v, np.zeros(3 * d))
        assert sde.n == 3 * d and not sde.A.flags.writeable
    assert singer.model == ClosedForm("singer", alpha) and wnoj.model == ClosedForm("wnoj")
    by_tau = LinearSDE.singer(qc, time_constant=1 / alpha)
    np.testing.assert_allclose(by_tau.A, singer.A, rtol=1e-15)
    assert LinearSDE.singer(qc, 0.5, v=np.ones(6)).v.tolist() == [1.0] * 6


# --- closed forms against the matrix exponential route ---------------------------------------------


@pytest.mark.parametrize("d", [1, 2, 3])
def test_closed_forms_equal_expm_and_van_loan(rng, d):
    for sde in sdes(rng, d):
        alpha = 0.0 if sde.model.alpha is None else sde.model.alpha
        for dt in (0.05, 0.37, 1.3, 4.0):  # with α = 0.3 ... 15: αΔt from 0.015 to 60, both branches
            np.testing.assert_allclose(sde.transition(dt), sde.transition_expm(dt), rtol=1e-12, atol=1e-13)
            general = sde.general()
            assert general.model is None
            np.testing.assert_array_equal(general.transition(dt), sde.transition_expm(dt))
            np.testing.assert_array_equal(general.process_noise(dt), sde.process_noise_van_loan(dt))
            if alpha * dt > 6:
                continue  # Van Loan's exp([[-A, ·], [0, Aᵀ]]) mixes e^{±αΔt}: see the quadrature test below
            Q = sde.process_noise_van_loan(dt)
            np.testing.assert_allclose(normalised(sde.process_noise(dt), Q), normalised(Q, Q), rtol=0, atol=1e-12)


@pytest.mark.parametrize("x", [8.0, 20.0, 60.0])
def test_singer_q_at_large_alpha_dt_equals_quadrature(rng, x):
    """Where Van Loan loses digits (≈ e^{αΔt}·eps relative), the closed form still equals Eq. 17."""
    sde, dt = LinearSDE.singer(random_spd(rng, 2), x / 1.1), 1.1
    reference = sde_process_noise(sde, dt)  # [YIB Eq. 17] by quad_vec
    np.testing.assert_allclose(
        normalised(sde.process_noise(dt), reference), normalised(reference, reference), rtol=0, atol=1e-12
    )


def test_singers_stiffness_beside_wnoj_is_largest_in_the_twist_and_sqrt_of_one_over_eps_at_the_limit():
    """Per axis over Δt = 1 at x = αΔt ≫ 1, WNOJ's variances over Singer's are 3x²/20 (pose), x²/3 (twist) and 2x
    (acceleration), to O(1/x): the twist's is the largest, the one ``SINGER_LARGEST_ALPHA_DT`` holds to sqrt(1/eps)
    (the comment above it). Oracles: Singer's Q by quadrature of [YIB Eq. 17] with Φ from expm, WNOJ's the
    hand-derived S(0); the code's closed form must equal the quadrature there too."""
    x = SINGER_LARGEST_ALPHA_DT
    A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -x]])  # α = x, Δt = 1, one axis, Qc = 1

    def integrand(s: float) -> np.ndarray:
        g = scipy.linalg.expm(A * s)[:, 2]  # Φ(s) F, the noise's column after s
        return np.outer(g, g)

    singer, _ = scipy.integrate.quad_vec(integrand, 0.0, 1.0, epsrel=1e-11, epsabs=0.0, points=[1 / x, 10 / x, 100 / x])
    np.testing.assert_allclose(singer_process_noise(1.0, x, np.eye(1)), singer, rtol=1e-9, atol=0)
    ratios = np.diag(S0) / np.diag(singer)
    np.testing.assert_allclose(ratios, [3 * x * x / 20, x * x / 3, 2 * x], rtol=5 / x)
    assert int(np.argmax(ratios)) == 1
    assert abs(ratios.max() * np.sqrt(np.finfo(float).eps) - 1) < 5 / x


def test_transition_closed_form_for_negative_and_zero_dt(rng):
    for sde in sdes(rng, 2):
        for dt in (-2.5, -0.4, 0.0):
            np.testing.assert_allclose(sde.transition(dt), sde.transition_expm(dt), rtol=1e-12, atol=1e-12)


def test_closed_form_q_equals_quadrature(rng):
    for sde in sdes(rng, 2):
        for dt in (0.21, 1.7):
            reference = sde_process_noise(sde, dt)  # [YIB Eq. 17] by quad_vec
            np.testing.assert_allclose(
                normalised(sde.process_noise(dt), reference), normalised(reference, reference), rtol=0, atol=1e-10
            )
            np.testing.assert_allclose(sde.transition(dt), sde_transition(sde, dt), rtol=1e-12, atol=1e-13)


def test_wnoj_closed_forms_by_hand(rng):
    qc, dt = random_spd(rng, 2), 0.8
    I = np.eye(2)
    expected_phi = np.block([[I, dt * I, dt**2 / 2 * I], [0 * I, I, dt * I], [0 * I, 0 * I, I]])
    np.testing.assert_allclose(wnoj_transition(dt, 2), expected_phi, rtol=1e-15)
    np.testing.assert_allclose(wnoj_process_noise(dt, qc), np.kron(S0, qc) * scale_of(dt, 2), rtol=1e-14)
    for dt in (0.01, 0.6, 7.0):
        Qi = wnoj_process_noise_inverse(dt, qc)
        np.testing.assert_allclose(wnoj_process_noise(dt, qc) @ Qi, np.eye(6), rtol=0, atol=1e-9)


@pytest.mark.parametrize("x", [1e-6, 1e-4])
def test_singer_small_alpha_dt_is_stable(rng, x):
    """αΔt = 1e-6: the naive closed forms would lose ~1/x⁵ to cancellation; ours must equal the expm
    route and the first-order series S0 - x S1 (hand-derived) to near machine precision."""
    d, dt = 2, 0.9
    qc = random_spd(rng, d)
    sde = LinearSDE.singer(qc, x / dt)
    Q, V = sde.process_noise(dt), sde.process_noise_van_loan(dt)
    np.testing.assert_allclose(normalised(Q, V), normalised(V, V), rtol=0, atol=1e-12)
    series = np.kron(S0 - x * S1, qc) * scale_of(dt, d)  # + O(x²) ≈ 1e-12 relative at most
    np.testing.assert_allclose(normalised(Q, series), normalised(series, series), rtol=0, atol=5 * x**2 + 1e-14)
    Phi = sde.transition(dt)
    np.testing.assert_allclose(Phi, sde.transition_expm(dt), rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(
        Phi[:d, 2 * d :], dt**2 * (1 / 2 - x / 6 + x**2 / 24 - x**3 / 120) * np.eye(d), rtol=1e-14
    )
    np.testing.assert_allclose(Phi[d : 2 * d, 2 * d :], dt * (1 - x / 2 + x**2 / 6 - x**3 / 24) * np.eye(d), rtol=1e-14)


@pytest.mark.parametrize("x", [0.999, 1.0, 1.001, 1.5])
def test_singer_series_and_closed_form_meet(rng, x):
    """Either side of the switch at αΔt = 1 both branches equal Van Loan."""
    sde = LinearSDE.singer(random_spd(rng, 2), x / 1.3)
    Q, V = sde.process_noise(1.3), sde.process_noise_van_loan(1.3)
    np.testing.assert_allclose(normalised(Q, V), normalised(V, V), rtol=0, atol=1e-12)
    np.testing.assert_allclose(sde.transition(1.3), sde.transition_expm(1.3), rtol=1e-14, atol=1e-15)


def test_singer_tends_to_wnoj_linearly_in_alpha(rng):
    """α → 0: Φ, Q → WNOJ's, and Q_singer - Q_wnoj ≈ -αΔt Δt (D S1 D) ⊗ Qc."""
    d, dt = 3, 1.4
    qc = random_spd(rng, d)
    np.testing.assert_allclose(singer_transition(dt, 1e-12, d), wnoj_transition(dt, d), rtol=0, atol=1e-11)
    wnoj = wnoj_process_noise(dt, qc)
    np.testing.assert_allclose(
        normalised(singer_process_noise(dt, 1e-12, qc), wnoj), normalised(wnoj, wnoj), rtol=0, atol=1e-11
    )
    for alpha in (1e-3, 1e-5):
        diff = singer_process_noise(dt, alpha, qc) - wnoj
        first_order = -alpha * dt * np.kron(S1, qc) * scale_of(dt, d)
        np.testing.assert_allclose(diff, first_order, rtol=1e-2 * alpha / 1e-3 + 1e-6, atol=1e-15)


@settings(max_examples=40, deadline=None)
@given(dt1=st.floats(1e-3, 3.0), dt2=st.floats(1e-3, 3.0), log_alpha=st.floats(-4, 2), seed=st.integers(0, 2**32 - 1))
def test_singer_discretisation_composes(dt1, dt2, log_alpha, seed):
    """Φ(Δ₁+Δ₂) = Φ(Δ₂)Φ(Δ₁) and Q(Δ₁+Δ₂) = Φ(Δ₂) Q(Δ₁) Φ(Δ₂)ᵀ + Q(Δ₂), across the series/closed-form switch."""
    alpha, qc = 10.0**log_alpha, random_spd(np.random.default_rng(seed), 2)
    P1, P2 = singer_transition(dt1, alpha, 2), singer_transition(dt2, alpha, 2)
    np.testing.assert_allclose(singer_transition(dt1 + dt2, alpha, 2), P2 @ P1, rtol=1e-12, atol=1e-13)
    Q = singer_process_noise(dt1 + dt2, alpha, qc)
    composed = P2 @ singer_process_noise(dt1, alpha, qc) @ P2.T + singer_process_noise(dt2, alpha, qc)
    np.testing.assert_allclose(normalised(composed, Q), normalised(Q, Q), rtol=0, atol=1e-11)
    assert np.all(np.linalg.eigvalsh(normalised(Q, Q)) > 0)


# --- the kernel's sparse inverse from the closed forms  [YIB Eq. 3, 15, 22] -------------------------


@pytest.mark.parametrize("model", ["wnoj", "singer"])
def test_inverse_kernel_from_closed_forms_equals_dense_kernel_inverse(rng, model):
    """K⁻¹ = P0⁻¹ (on x₀) + Σ Jᵢᵀ Qᵢ⁻¹ Jᵢ, Jᵢ = [.. -Φᵢ I ..], with Φ, Q closed-form; K dense by expm and quadrature."""
    d, M = 2, 5
    qc = random_spd(rng, d)
    sde = LinearSDE.wnoj(qc) if model == "wnoj" else LinearSDE.singer(qc, 1.7)
    n = sde.n
    times = 0.4 + np.concatenate([[0.0], np.cumsum(rng.uniform(0.3, 1.2, size=M - 1))])
    P0 = random_spd(rng, n)
    K = gp_kernel(times, sde, P0)  # oracle: expm + quad_vec
    info = np.zeros((M * n, M * n))
    info[:n, :n] = np.linalg.inv(P0)
    for i in range(1, M):
        dt = times[i] - times[i - 1]
        J = np.zeros((n, M * n))
        J[:, (i - 1) * n : i * n], J[:, i * n : (i + 1) * n] = -sde.transition(dt), np.eye(n)  # [YIB Eq. 22]
        Qi = wnoj_process_noise_inverse(dt, qc) if model == "wnoj" else np.linalg.inv(sde.process_noise(dt))
        info += J.T @ Qi @ J
    K_inv = np.linalg.inv(K)
    tol = 1e-13 * np.linalg.cond(K) * np.abs(K_inv).max()
    np.testing.assert_allclose(info, K_inv, rtol=1e-8, atol=tol)
    np.testing.assert_allclose(dense_kernel(sde, times, P0), K, rtol=1e-9, atol=1e-11 * np.abs(K).max())


# --- errors ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("alpha", [0.0, -1.0, np.inf, np.nan, "fast"])
def test_bad_alpha_raises_naming_it(alpha):
    with pytest.raises(SteamError, match="alpha="):
        LinearSDE.singer(np.eye(2), alpha)
    with pytest.raises(SteamError, match="alpha="):
        singer_process_noise(1.0, alpha, np.eye(2))
    with pytest.raises(SteamError, match="time_constant="):
        LinearSDE.singer(np.eye(2), time_constant=alpha)


def test_alpha_and_time_constant_exactly_one():
    for kwargs in ({}, dict(alpha=1.0, time_constant=1.0)):
        with pytest.raises(SteamError, match="exactly one of alpha and time_constant"):
            LinearSDE.singer(np.eye(2), **kwargs)


@pytest.mark.parametrize("qc", [np.diag([1.0, -1.0]), np.array([[1.0, 2.0], [0.0, 1.0]])])
def test_non_spd_qc_raises(qc):
    for call in (
        lambda: LinearSDE.wnoj(qc),
        lambda: LinearSDE.singer(qc, 1.0),
        lambda: wnoj_process_noise(0.5, qc),
        lambda: singer_process_noise(0.5, 1.0, qc),
    ):
        with pytest.raises(SteamError, match="positive definite"):
            call()


@pytest.mark.parametrize("dt", [0.0, -0.3, np.inf, np.nan])
def test_bad_dt_raises(dt):
    for call in (
        lambda: wnoj_process_noise(dt, np.eye(2)),
        lambda: singer_process_noise(dt, 1.0, np.eye(2)),
        lambda: LinearSDE.singer(np.eye(2), 1.0).process_noise(dt),
        lambda: wnoj_process_noise_inverse(dt, np.eye(2)),
    ):
        with pytest.raises(SteamError, match="time step"):
            call()
    if not np.isfinite(dt):
        with pytest.raises(SteamError, match="time step"):
            singer_transition(dt, 1.0, 2)


def test_model_must_match_a_and_f(rng):
    sde = LinearSDE.singer(random_spd(rng, 2), 0.5)
    with pytest.raises(SteamError, match="not those of model"):
        LinearSDE(sde.A, sde.F, sde.qc, model=ClosedForm("singer", 0.6))
    with pytest.raises(SteamError, match="not those of model"):
        LinearSDE(sde.A, sde.F, sde.qc, model=ClosedForm("wnoj"))
    with pytest.raises(SteamError, match="model="):
        LinearSDE(sde.A, sde.F, sde.qc, model="singer")
    with pytest.raises(SteamError, match="name='cv'"):
        ClosedForm("cv")
    with pytest.raises(SteamError, match=r"alpha=1\.0"):
        ClosedForm("wnoj", 1.0)
    with pytest.raises(ShapeError, match=r"Qc.*\(3, 3\)"):
        LinearSDE(sde.A, sde.F, np.eye(3), model=ClosedForm("singer", 0.5))
