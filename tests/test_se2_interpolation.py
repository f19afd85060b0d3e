"""The local GP on SE(2) (steam_ref.lie.gp): the interpolated mean against brute force (the states at
the ends, a constant-twist path, the dense local GP's conditional mean), its Jacobians against central differences, its covariance and the
extrapolation's against Monte Carlo through the exact nonlinear maps."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from oracles import gp_kernel

from steam_ref.errors import SteamError
from steam_ref.gp import LinearSDE, interpolate_covariance, interpolation_matrices, process_noise
from steam_ref.lie import SE2, SE2_STATE
from steam_ref.lie.gp import (
    extrapolate,
    extrapolate_covariance,
    interpolate,
    local_variables,
)
from steam_ref.lie.gp import interpolate_covariance as lie_interpolate_covariance
from steam_ref.motion.lie_group import LieGroupWnoa

QC = np.diag([0.3, 0.2, 0.5])
X1 = np.array([1.0, 2.0, 2.9, 0.8, 0.1, 0.9])
X2 = np.array([1.7, 2.9, -2.6, 0.7, -0.1, 1.1])
MODELS = ["local-variable", "simplified"]


def tangent_jacobian(f, x, eps=1e-6):
    """∂ local(f(x), f(x ⊕ δ)) / ∂δ at δ = 0, by central differences."""
    fx = f(x)
    cols = [
        (SE2_STATE.local(fx, f(SE2_STATE.retract(x, eps * e))) - SE2_STATE.local(fx, f(SE2_STATE.retract(x, -eps * e))))
        / (2 * eps)
        for e in np.eye(6)
    ]
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize("model", MODELS)
def test_the_mean_reproduces_the_states_at_the_ends(model):
    I, O = np.eye(6), np.zeros((6, 6))  # Λ(t₁) = I, Ψ(t₁) = 0; Λ(t₂) = 0, Ψ(t₂) = I  [YIB Eq. 16]
    np.testing.assert_allclose(interpolate(X1, X2, I, O, model, group=SE2)[0], X1, atol=1e-15)
    np.testing.assert_allclose(interpolate(X1, X2, O, I, model, group=SE2)[0], X2, atol=1e-14)
    # and the Λ(τ), Ψ(τ) of the prior approach them as τ → t₁, t₂
    for tau, end in ((1e-9, X1), (1 - 1e-9, X2)):
        lam, psi = interpolation_matrices(0.0, 1.0, tau, QC)
        np.testing.assert_allclose(
            SE2_STATE.local(end, interpolate(X1, X2, lam, psi, model, group=SE2)[0]), 0.0, atol=1e-7
        )


@pytest.mark.parametrize("model", MODELS)
def test_on_a_constant_twist_the_mean_lies_on_the_path(model):
    """T(t) = T₁ Exp((t - t₁) ϖ), ϖ constant (2.4 rad of turn over the gap): every τ lands on it."""
    twist = np.array([1.5, 0.3, 1.2])
    x1 = np.r_[X1[:3], twist]
    x2 = np.r_[SE2.compose(x1[:3], SE2.exp(2.0 * twist)), twist]
    for tau in (0.1, 0.7, 1.0, 1.9):
        lam, psi = interpolation_matrices(0.0, 2.0, tau, QC)
        x = interpolate(x1, x2, lam, psi, model, group=SE2)[0]
        path = SE2.compose(x1[:3], SE2.exp(tau * twist))
        np.testing.assert_allclose(x[:3], path, atol=1e-14)
        np.testing.assert_allclose(x[3:], twist, atol=1e-14)
        pred = extrapolate(x1, 0.0, tau, group=SE2)[0]
        np.testing.assert_allclose(pred, np.r_[path, twist], atol=1e-14)


def _matrix(pose):
    """The 3 × 3 matrix of a planar pose [x, y, θ], written out."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return np.array([[c, -s, pose[0]], [s, c, pose[1]], [0.0, 0.0, 1.0]])


def _hat(xi):
    return np.array([[0.0, -xi[2], xi[0]], [xi[2], 0.0, xi[1]], [0.0, 0.0, 0.0]])


def _log(T):
    L = np.real(scipy.linalg.logm(T))
    return np.array([L[0, 2], L[1, 2], L[1, 0]])


def _jr(xi, h=1e-5):
    """J_r(ξ) by central differences of Exp(ξ + δ) = Exp(ξ) Exp(J_r(ξ) δ), matrices by expm and logm."""
    E_inv = np.linalg.inv(scipy.linalg.expm(_hat(xi)))
    return np.stack(
        [(_log(E_inv @ scipy.linalg.expm(_hat(xi + h * e))) - _log(E_inv @ scipy.linalg.expm(_hat(xi - h * e)))) / (2 * h)
         for e in np.eye(3)],
        axis=-1,
    )  # fmt: skip


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("tau", [0.35, 1.0, 1.6])
def test_the_motion_priors_mean_is_the_dense_local_gps_conditional_mean(model, tau):
    """``LieGroupWnoa(SE2).interpolate`` = (T₁ Exp(ξ(τ)), J_r(ξ(τ)) ξ̇(τ)) (simplified: ξ̇(τ)) with γ(τ) the posterior
    mean [YIB Eq. 12] of the local WNOA GP given γ₁ = [0; ϖ₁] and γ₂ = [ξ₂₁; J_r(ξ₂₁)⁻¹ ϖ₂] (simplified: ϖ₂)
    [DER 11.10, 11.15]. Oracles: the dense kernel by quadrature over t₁, τ, t₂; Exp and Log by expm and logm of
    3 × 3 matrices; J_r by central differences."""
    t1, t2 = 0.0, 2.0
    xi21 = _log(np.linalg.inv(_matrix(X1)) @ _matrix(X2))
    rate2 = np.linalg.solve(_jr(xi21), X2[3:]) if model == "local-variable" else X2[3:]
    gamma_ends = np.concatenate([np.zeros(3), X1[3:], xi21, rate2])  # [γ₁; γ₂]
    K = gp_kernel(np.array([t1, tau, t2]), LinearSDE.wnoa(QC).general(), np.eye(6))
    ends, mid = np.r_[0:6, 12:18], np.r_[6:12]
    gamma = K[np.ix_(mid, ends)] @ np.linalg.solve(K[np.ix_(ends, ends)], gamma_ends)  # [YIB Eq. 12], μ = 0
    T = _matrix(X1) @ scipy.linalg.expm(_hat(gamma[:3]))
    twist = _jr(gamma[:3]) @ gamma[3:] if model == "local-variable" else gamma[3:]
    got = LieGroupWnoa(SE2, QC, model).interpolate(t1, X1, t2, X2, tau)
    np.testing.assert_allclose(got[:2], T[:2, 2], rtol=0, atol=1e-9)
    np.testing.assert_allclose(got[2], np.arctan2(T[1, 0], T[0, 0]), rtol=0, atol=1e-9)
    np.testing.assert_allclose(got[3:], twist, rtol=0, atol=1e-8)


@pytest.mark.parametrize("model", MODELS)
@pytest.mark.parametrize("tau", [0.15, 0.5, 0.93])
def test_the_interpolation_jacobians_are_exact(model, tau):
    lam, psi = interpolation_matrices(0.0, 1.0, tau, QC)
    _, J1, J2 = interpolate(X1, X2, lam, psi, model, group=SE2)
    np.testing.assert_allclose(
        J1, tangent_jacobian(lambda z: interpolate(z, X2, lam, psi, model, group=SE2)[0], X1), atol=2e-8
    )
    np.testing.assert_allclose(
        J2, tangent_jacobian(lambda z: interpolate(X1, z, lam, psi, model, group=SE2)[0], X2), atol=2e-8
    )


def test_the_extrapolation_jacobian_is_exact():
    _, J = extrapolate(X1, 0.0, 1.7, group=SE2)
    np.testing.assert_allclose(J, tangent_jacobian(lambda z: extrapolate(z, 0.0, 1.7, group=SE2)[0], X1), atol=2e-8)


def _sample_covariance(draws, mean):
    d = SE2_STATE.local(mean, draws)
    return d.T @ d / len(d)


@pytest.mark.parametrize("model", MODELS)
def test_the_interpolated_covariance_against_monte_carlo(model):
    """Draw [δ₁; δ₂] ~ N(0, P) and the local GP's conditional noise at τ, push both through the exact
    nonlinear maps, and compare the sample covariance of x(τ) ⊖ x̄(τ) with the first-order formula."""
    rng = np.random.default_rng(7)
    t1, t2, tau, n = 0.0, 1.0, 0.35, 40000
    A = rng.standard_normal((12, 12)) * 1e-3
    P = A @ A.T + 1e-6 * np.eye(12)
    mean, cov = lie_interpolate_covariance(t1, t2, tau, QC * 1e-3, X1, X2, P, model, group=SE2)
    lam, psi = interpolation_matrices(t1, t2, tau, QC * 1e-3)
    cond = interpolate_covariance(t1, t2, tau, QC * 1e-3, np.zeros((12, 12)))
    d = rng.multivariate_normal(np.zeros(12), P, n)
    w = rng.multivariate_normal(np.zeros(6), cond, n)
    x1, x2 = SE2_STATE.retract(X1, d[:, :6]), SE2_STATE.retract(X2, d[:, 6:])  # every map broadcasts over draws
    gamma1 = np.concatenate([np.zeros((n, 3)), x1[:, 3:]], axis=1)
    gamma = gamma1 @ lam.T + local_variables(x1, x2, model, group=SE2)[0] @ psi.T + w  # γ(τ) + its conditional noise
    pose = SE2.compose(x1[:, :3], SE2.exp(gamma[:, :3]))
    jr = SE2.right_jacobian(gamma[:, :3])
    twist = np.einsum("nij,nj->ni", jr, gamma[:, 3:]) if model == "local-variable" else gamma[:, 3:]
    draws = np.concatenate([pose, twist], axis=1)
    sample = _sample_covariance(draws, mean)
    scale = np.sqrt(np.outer(np.diag(cov), np.diag(cov)))
    assert np.abs(sample - cov).max() / scale.max() < 0.03  # Monte Carlo error ~ 1/√n ≈ 0.5 %
    assert np.abs((sample - cov) / scale).max() < 0.05


def test_the_extrapolated_covariance_against_monte_carlo():
    rng = np.random.default_rng(8)
    n, s = 40000, 1.3
    A = rng.standard_normal((6, 6)) * 1e-3
    P = A @ A.T + 1e-6 * np.eye(6)
    mean, cov = extrapolate_covariance(X1, 0.0, s, QC * 1e-3, P, group=SE2)
    d = rng.multivariate_normal(np.zeros(6), P, n)
    w = rng.multivariate_normal(np.zeros(6), process_noise(s, QC * 1e-3), n)
    x1 = SE2_STATE.retract(X1, d)
    gamma = np.concatenate([s * x1[:, 3:], x1[:, 3:]], axis=1) + w  # Φ(s) γ₁ + w  [YIB Eq. 22]
    jr = SE2.right_jacobian(gamma[:, :3])
    draws = np.concatenate(
        [SE2.compose(x1[:, :3], SE2.exp(gamma[:, :3])), np.einsum("nij,nj->ni", jr, gamma[:, 3:])], 1
    )
    sample = _sample_covariance(draws, mean)
    scale = np.sqrt(np.outer(np.diag(cov), np.diag(cov)))
    assert np.abs((sample - cov) / scale).max() < 0.05


def test_bad_times_are_refused():
    with pytest.raises(SteamError, match="extrapolation needs a finite t > t1"):
        extrapolate(X1, 1.0, 1.0, group=SE2)
    with pytest.raises(SteamError, match="t1 < tau < t2"):
        lie_interpolate_covariance(0.0, 1.0, 1.0, QC, X1, X2, np.eye(12), group=SE2)
    with pytest.raises(SteamError, match="model must be one of"):
        lie_interpolate_covariance(0.0, 1.0, 0.5, QC, X1, X2, np.eye(12), "exact", group=SE2)
