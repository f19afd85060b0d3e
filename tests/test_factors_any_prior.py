"""Measurement and GP factors on the states of every prior: WNOA (6 numbers), WNOJ and Singer (9).

Jacobians against central differences; the interpolated state of Eq. 29 against the dense GP's
conditional mean, with and without an exogenous input (Eq. 23), from the quadrature oracles.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from finite_differences import numerical_jacobians
from oracles import gp_kernel, gp_mean

import steam_ref as sr
from steam_ref.gp import LinearSDE

QC = np.diag([0.3, 0.5, 0.7])
X1, X2, LM = sr.X(1), sr.X(2), sr.L(1)
PRIORS = {
    "wnoa": LinearSDE.wnoa(QC),
    "wnoj": LinearSDE.wnoj(QC),
    "singer": LinearSDE.singer(QC, alpha=0.8),
    "singer+input": LinearSDE.singer(QC, alpha=0.8, v=np.r_[np.zeros(6), 0.3, -0.2, 0.1]),
    "wnoa+input": LinearSDE.wnoa(QC, v=np.r_[0.0, 0.0, 0.0, 0.5, -1.0, 0.2]),
}


def measurements(n: int):
    return [
        sr.VelocityFactor.create(X1, [1.0, 0.1, -0.2], [0.5, 0.2, 0.1], state_dim=n),
        sr.OdometryFactor.create(X1, [1.0, 0.1], [0.1, 0.2], state_dim=n),
        sr.RangeFactor.create(X1, LM, 3.0, 0.5, state_dim=n),
        sr.BearingFactor.create(X1, LM, 0.4, 0.1, state_dim=n),
        sr.BearingRangeFactor.create(X1, LM, 0.4, 3.0, [0.1, 0.5], state_dim=n),
    ]


@pytest.mark.parametrize("index", range(5))
def test_a_measurement_reads_pose_and_velocity_from_the_front_of_any_state(rng, index):
    six, nine = measurements(6)[index], measurements(9)[index]
    assert nine.key_dims[0] == 9 and six.key_dims[0] == 6
    for _ in range(3):
        x9 = rng.normal(size=9)
        rest = [rng.normal(size=d) * 3 for d in nine.key_dims[1:]]
        np.testing.assert_array_equal(nine.error(x9, *rest), six.error(x9[:6], *rest))
        analytic = nine.jacobians(x9, *rest)
        for a, n in zip(analytic, numerical_jacobians(nine.error, x9, *rest), strict=True):
            np.testing.assert_allclose(a, n, rtol=1e-6, atol=1e-8)
        np.testing.assert_array_equal(analytic[0][..., 6:], 0.0)  # acceleration is not measured


def test_factors_of_different_state_sizes_are_never_stacked_together(rng):
    factors = [sr.RangeFactor.create(X1, LM, 3.0, 0.5, state_dim=n) for n in (6, 9)]
    assert factors[0].batch_signature() != factors[1].batch_signature()
    batch = sr.RangeFactor.stack([measurements(9)[2], measurements(9)[2]])
    assert batch.key_dims == (9, 2)


@pytest.mark.parametrize("state_dim", [5, 7, 0, 6.0, True])
def test_state_dim_is_checked(state_dim):
    with pytest.raises(sr.SteamError, match="state_dim must be a multiple of 3"):
        sr.RangeFactor.create(X1, LM, 3.0, 0.5, state_dim=state_dim)


@pytest.mark.parametrize("name", sorted(PRIORS))
def test_interpolated_state_is_the_dense_gp_conditional_mean(rng, name):
    sde = PRIORS[name]
    n = sde.n
    t1, tau, t2 = 1.0, 1.7, 2.5
    times = np.array([t1, tau, t2])
    mu0 = rng.normal(size=n)
    P0 = np.eye(n) * 2.0
    K, mu = gp_kernel(times, sde, P0), gp_mean(times, sde, mu0)  # order: x1, x(τ), x2
    x1, x2 = rng.normal(size=n), rng.normal(size=n)
    ends = np.r_[0:n, 2 * n : 3 * n]
    mid = np.arange(n, 2 * n)
    gain = K[np.ix_(mid, ends)] @ np.linalg.inv(K[np.ix_(ends, ends)])
    expected = mu[mid] + gain @ (np.r_[x1, x2] - mu[ends])
    inner = sr.RangeFactor.create(sr.X(-1), LM, 3.0, 0.5, state_dim=n)
    factor = sr.InterpolatedFactor.create(inner, X1, X2, t1, t2, tau, sde)
    np.testing.assert_allclose(factor.interpolated_state(x1, x2), expected, rtol=1e-8, atol=1e-9)
    lm = rng.normal(size=2) * 4
    np.testing.assert_allclose(factor.error(x1, x2, lm), inner.error(expected, lm), rtol=1e-8, atol=1e-9)
    for a, num in zip(factor.jacobians(x1, x2, lm), numerical_jacobians(factor.error, x1, x2, lm), strict=True):
        np.testing.assert_allclose(a, num, rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("name", sorted(PRIORS))
def test_gp_prior_factor_of_any_sde_whitens_by_q(rng, name):
    sde = PRIORS[name]
    dt = 0.6
    K = gp_kernel(np.array([0.0, dt]), sde, np.zeros((sde.n, sde.n)) + 1e-300 * np.eye(sde.n))
    Q = K[sde.n :, sde.n :]  # Cov x(dt) from a known x(0): Q(dt) by quadrature
    mu = gp_mean(np.array([0.0, dt]), sde, np.zeros(sde.n))
    (factor,) = sr.gp_prior_factors([X1, X2], [0.0, dt], sde)
    W = factor.sqrt_information
    np.testing.assert_allclose(W.T @ W, np.linalg.inv(Q), rtol=1e-7)
    x1 = rng.normal(size=sde.n)
    np.testing.assert_allclose(
        factor.error(x1, np.zeros(sde.n)),
        -(scipy.linalg.expm(np.asarray(sde.A) * dt) @ x1) - mu[sde.n :],
        rtol=1e-9,
        atol=1e-12,
    )


def test_the_papers_prior_from_qc_is_one_factor_whichever_way_it_is_asked():
    """Qc, ``LinearSDE.wnoa(Qc)`` through ``from_sde`` and ``gp_prior_factors`` of either give ``GPPriorFactor.wnoa``'s
    factor bit for bit: the SDE hands over W only where its model has it in closed form (memoised, the very array),
    and that W is Q(dt)⁻¹'s square root (Q by Van Loan's expm, independent of the closed forms). WNOJ, and WNOA with an
    input, have none: their factor factors Q(dt) itself."""
    dt = 0.37
    ref = sr.GPPriorFactor.wnoa(X1, X2, dt, QC)
    asked = [
        sr.GPPriorFactor.from_sde(X1, X2, dt, LinearSDE.wnoa(QC)),
        *sr.gp_prior_factors([X1, X2], [0.0, dt], QC),
        *sr.gp_prior_factors([X1, X2], [0.0, dt], LinearSDE.wnoa(QC)),
    ]
    for factor in asked:
        for name in ("sqrt_information", "phi", "v"):
            np.testing.assert_array_equal(getattr(factor, name), getattr(ref, name))
        assert factor.sqrt_information is ref.sqrt_information  # the memoised closed form, not a recomputation
    W, Q = ref.sqrt_information, LinearSDE.wnoa(QC).general().process_noise(dt)
    np.testing.assert_allclose(W.T @ W @ Q, np.eye(6), atol=1e-9)
    assert LinearSDE.wnoj(QC).sqrt_information(dt) is None and PRIORS["wnoa+input"].sqrt_information(dt) is None
