"""The WNOA prior on SE(3) (``motion_prior('se3')``, ``'se3-simplified'``), and every group prior's covariance at a
time between two states or after the last one in STEAM's failing case.

Oracles: 8th-order central differences in the right tangents (tests/finite_differences.py) for every Jacobian, at
rotation angles from 1e-8 to 3.0; GTSAM's SE(3) fixtures (testWnoaInterpFactor.cpp and the Python
test_WnoaFactor.py of GTSAM 4.3: a pose turned 0.5 rad about x moving with the twist [1, 0, 0.5] rad/s, [0.1, 0, 0]
m/s, states 0.1 s apart; their numbers, rotation-first, carried over to our translation-first order); and for the
covariance, the dense joint Gaussian: J by differences of the mean, the local GP's conditional covariance from the
dense kernel of its LTI model (``gp.sde.dense_kernel``), in a joint covariance where one direction (the vertical
translation) no reading observes (utiasASRL/steam clipped the negative eigenvalues its interpolation gave there).
"""

from __future__ import annotations

import numpy as np
import pytest
from finite_differences import jacobian8_stacked

from steam_ref.errors import ShapeError, SteamError
from steam_ref.gp import LinearSDE
from steam_ref.gp.interpolate import interpolation_matrices, interpolation_terms
from steam_ref.gp.sde import dense_kernel
from steam_ref.lie import SE2, SE3, SE3V, GroupState, gp_accel
from steam_ref.lie import gp as lie_gp
from steam_ref.motion import LieGroupAccelPrior, LieGroupWnoa, motion_prior
from steam_ref.variables import X

ANGLES = (1e-8, 1e-4, 0.3, 1.0, 2.0, 3.0)
QC6 = np.diag([0.4, 0.3, 0.2, 0.05, 0.08, 0.1])
SE3_STATE = GroupState(SE3)


def _states(rng, angle: float, kind=SE3_STATE):
    """Two states whose relative pose turns by ``angle`` (random axis and translation), random twists."""
    g, d = kind.group, kind.group.dim
    xi = rng.standard_normal(d)
    xi *= angle / float(g.angle(xi))
    T1 = g.exp(rng.standard_normal(d))
    x1 = np.r_[T1, rng.standard_normal(kind.size - g.size)]
    x2 = np.r_[g.compose(T1, g.exp(xi)), rng.standard_normal(kind.size - g.size)]
    return x1, x2


def _close(analytic, numeric, tol=1e-9):
    scale = max(1.0, float(np.max(np.abs(numeric))))
    np.testing.assert_allclose(analytic, numeric, rtol=0, atol=tol * scale)


def test_the_table_builds_both_residuals_and_refuses_a_planar_qc():
    prior = motion_prior("se3", QC6)  # on SE3V: poses [t; φ], so a state has as many numbers as its tangent
    assert isinstance(prior, LieGroupWnoa) and prior.group is SE3V and prior.residual == "local-variable"
    assert prior.kind is GroupState(SE3V) and prior.state_dim == 12 and len(prior.state_names) == 12
    assert motion_prior("se3-simplified", QC6).residual == "simplified"
    for name in ("se3", "se3-simplified"):
        with pytest.raises(
            ShapeError, match=r"qc must be \(6, 6\) on the body twist of a state on SE3V, got shape \(3, 3\)"
        ):
            motion_prior(name, np.eye(3))
    with pytest.raises(SteamError, match="'se3' takes no option 'se2_residual'"):
        motion_prior("se3", QC6, se2_residual="simplified")
    with pytest.raises(SteamError, match="holds no planar pose"):
        prior.initial_state(np.zeros(3), np.zeros(3), 1.0)


@pytest.mark.parametrize("residual", ["local-variable", "simplified"])
@pytest.mark.parametrize("angle", ANGLES)
def test_the_prior_factors_jacobians_are_exact_at_every_angle(residual, angle, rng):
    prior = LieGroupWnoa(SE3, QC6, residual)
    x1, x2 = _states(rng, angle)
    f = prior.prior_factor(X(0), X(1), 0.7)
    A, B = f.jacobians(x1, x2)
    _close(A, jacobian8_stacked(lambda d: f.error(SE3_STATE.retract(x1, d), x2), 12))
    _close(B, jacobian8_stacked(lambda d: f.error(x1, SE3_STATE.retract(x2, d)), 12))
    np.testing.assert_allclose(f.error(x1, prior.predict(x1, 0.7)), 0.0, atol=1e-13)  # the mean: zero error


@pytest.mark.parametrize("residual", ["local-variable", "simplified"])
@pytest.mark.parametrize("angle", ANGLES)
def test_interpolation_and_extrapolation_jacobians_are_exact_at_every_angle(residual, angle, rng):
    x1, x2 = _states(rng, angle)
    lam, psi = interpolation_matrices(0.0, 0.8, 0.3, QC6)
    x, J1, J2 = lie_gp.interpolate(x1, x2, lam, psi, residual, group=SE3)

    def at(a, b):
        return SE3_STATE.local(x, lie_gp.interpolate(a, b, lam, psi, residual, group=SE3, jacobians=False))

    _close(J1, jacobian8_stacked(lambda d: at(SE3_STATE.retract(x1, d), x2), 12))
    _close(J2, jacobian8_stacked(lambda d: at(x1, SE3_STATE.retract(x2, d)), 12))
    xe, Je = lie_gp.extrapolate(x1, 0.0, 0.9, group=SE3)
    _close(
        Je,
        jacobian8_stacked(
            lambda d: SE3_STATE.local(xe, lie_gp.extrapolate(SE3_STATE.retract(x1, d), 0.0, 0.9, group=SE3)[0]), 12
        ),
    )
    near = lie_gp.interpolate(
        x1, x2, *interpolation_matrices(0.0, 0.8, 1e-9, QC6), residual, group=SE3, jacobians=False
    )
    np.testing.assert_allclose(SE3_STATE.local(x1, near), 0.0, atol=1e-7)  # x(τ) → x₁ as τ → t₁


# --- GTSAM 4.3's SE(3) fixtures (testWnoaInterpFactor.cpp, python/gtsam/tests/test_WnoaFactor.py) ---------------

DT = 0.1
P0 = SE3.exp([0.0, 0.0, 0.0, 0.5, 0.0, 0.0])  # Pose3::Expmap([0.5, 0, 0, 0, 0, 0]): 0.5 rad about x
V0 = np.array([0.1, 0.0, 0.0, 1.0, 0.0, 0.5])  # GTSAM's [1, 0, 0.5, 0.1, 0, 0] (rotation first), ours translation first


RESIDUAL = {"se3": "local-variable", "se3-simplified": "simplified"}


def _along(k: float) -> np.ndarray:
    return np.r_[SE3.compose(P0, SE3.exp(k * DT * V0)), V0]  # p0.expmap(k · timestep · v0), the same velocity


@pytest.mark.parametrize("name", ["se3", "se3-simplified"])
def test_gtsams_constant_velocity_fixture_has_zero_prior_error_and_interpolates_onto_its_own_poses(name):
    """GTSAM: the factors' error is 0 to 1e-9 at the fixture, its interpolated p1, p3 match to 1e-6 and v1, v3 to
    1e-12 (``testSe3UpdateInterpValues``); both residuals hold all of it to 1e-14 here."""
    prior = LieGroupWnoa(SE3, np.eye(6), RESIDUAL[name])  # Q_se3 = Vector6::Ones()
    for a, b in ((0, 2), (2, 4)):
        np.testing.assert_allclose(prior.prior_factor(X(0), X(1), 2 * DT).error(_along(a), _along(b)), 0.0, atol=1e-14)
    for k, (a, b) in ((1, (0, 2)), (3, (2, 4))):
        x = prior.interpolate(a * DT, _along(a), b * DT, _along(b), k * DT)
        np.testing.assert_allclose(SE3_STATE.local(_along(k), x), 0.0, atol=1e-14)


def test_gtsams_doubled_velocity_fixture_leaves_the_velocity_as_residual():
    """test_WnoaFactor.py ``testEvaluateError``: p1 = p0.retract(0.1 v0), v1 = 2 v0, Δt = 0.1: the local-variable
    residual is [0; v0] (J_r(ξ)⁻¹ ξ = ξ); GTSAM checks it to rtol 1e-4, ours holds 1e-15."""
    p0 = SE3.exp([1.0, 0.0, 0.0, 0.5, 0.0, 0.2])  # Pose3::Expmap([0.5, 0, 0.2, 1, 0, 0])
    v0 = np.array([1.0, 0.0, 2.0, 0.1, 0.0, 0.0])  # [0.1, 0, 0, 1, 0, 2]
    x1, x2 = np.r_[p0, v0], np.r_[SE3.compose(p0, SE3.exp(0.1 * v0)), 2 * v0]
    e = LieGroupWnoa(SE3, np.eye(6)).prior_factor(X(0), X(1), 0.1).error(x1, x2)
    np.testing.assert_allclose(e, np.r_[np.zeros(6), v0], rtol=0, atol=1e-15)


# --- the covariance between two states and after the last, where one direction is unobserved ------------------


def _unobserved_joint(kind, rng):
    """A joint covariance of two states' tangents from a prior-like coupling and readings of every direction but the
    tangent's third direction of both poses (SE(3): the vertical translation δρ_z; SE(2): the heading), fixed only
    by 1e-10 of information: variance ~1e10 there."""
    n = kind.dim
    A = rng.standard_normal((2 * n, 2 * n))
    info = A.T @ A
    info[[2, n + 2], :] = 0.0
    info[:, [2, n + 2]] = 0.0
    info[2, 2] = info[n + 2, n + 2] = 1e-10
    info[2, n + 2] = info[n + 2, 2] = -0.99e-10  # the two nearly tied, as the prior ties them
    return np.linalg.inv(info)


PRIORS = {
    "se3": lambda: LieGroupWnoa(SE3, QC6),
    "se3-simplified": lambda: LieGroupWnoa(SE3, QC6, "simplified"),
    "se3-wnoj": lambda: LieGroupAccelPrior.wnoj(SE3, QC6),
    "se2-wnoj": lambda: LieGroupAccelPrior.wnoj(SE2, np.diag([0.3, 0.2, 0.1])),
    "se3-singer": lambda: LieGroupAccelPrior.singer(SE3, QC6, 2.0),
}


def _sde(prior):
    return getattr(prior, "sde", None) or LinearSDE.wnoa(prior.qc)


@pytest.mark.parametrize("name", sorted(PRIORS))
def test_the_interpolated_covariance_is_the_dense_one_and_psd_where_a_direction_is_unobserved(name, rng):
    prior = PRIORS[name]()
    kind = prior.kind
    x1, x2 = _states(rng, 1.3, kind)
    x2[kind.group.size :] *= 0.5
    t1, t2, tau = 0.0, 0.8, 0.35
    P = _unobserved_joint(kind, rng)
    cov = prior.interpolate_covariance(t1, x1, t2, x2, tau, P)
    x = prior.interpolate(t1, x1, t2, x2, tau)
    n = kind.dim
    J = np.hstack(
        [
            jacobian8_stacked(lambda d: kind.local(x, prior.interpolate(t1, kind.retract(x1, d), t2, x2, tau)), n),
            jacobian8_stacked(lambda d: kind.local(x, prior.interpolate(t1, x1, t2, kind.retract(x2, d), tau)), n),
        ]
    )
    K = dense_kernel(_sde(prior), [t1, tau, t2], np.eye(n))  # the local GP: γ(t₁), γ(τ), γ(t₂)
    ends = np.r_[0:n, 2 * n : 3 * n]
    q_cond = K[n : 2 * n, n : 2 * n] - K[n : 2 * n, ends] @ np.linalg.solve(K[np.ix_(ends, ends)], K[ends, n : 2 * n])
    # N = ∂x(τ)/∂γ(τ): the mean as a function of the local state, by differences through the end state's twist
    # (the local state at τ moves with x₂'s local variables by Ψ, invertible here).
    lam_psi = _terms(prior, t1, t2, tau)
    N = J[:, n:] @ np.linalg.inv(lam_psi @ _dgamma2(prior, x1, x2))
    dense = J @ P @ J.T + N @ q_cond @ N.T
    big = np.max(np.abs(dense))
    np.testing.assert_allclose(cov, dense, rtol=0, atol=1e-9 * big)
    assert np.min(np.linalg.eigvalsh(cov)) >= -1e-12 * np.max(np.linalg.eigvalsh(cov))
    assert big > 1e8  # the unobserved direction is there


def _from_local(prior, x1, gamma):
    """The state at the local state γ (the map back of the prior's local GP)."""
    if prior.kind.derivatives == 2:
        return gp_accel.from_local(x1, gamma, prior.group, jacobians=False)
    return lie_gp._from_local(x1, gamma, prior.residual, prior.group, jacobians=False)


def _terms(prior, t1, t2, tau):
    return interpolation_terms(_sde(prior), t1, t2, tau)[1]


def _dgamma2(prior, x1, x2):
    """∂γ₂/∂δ₂ (the end state's local variables against its tangent) by differences of the local variables."""
    kind = prior.kind
    g = kind.group

    def gamma2(d):
        y = kind.retract(x2, d)
        if kind.derivatives == 2:
            return gp_accel.local_variables(x1, y, group=g, jacobians=False)
        return lie_gp.local_variables(x1, y, prior.residual, group=g, jacobians=False)

    return jacobian8_stacked(gamma2, kind.dim)


@pytest.mark.parametrize("name", sorted(PRIORS))
def test_the_extrapolated_covariance_is_the_dense_one_and_psd_where_a_direction_is_unobserved(name, rng):
    prior = PRIORS[name]()
    kind = prior.kind
    x1, _ = _states(rng, 0.0 + 1e-3, kind)
    n = kind.dim
    P = _unobserved_joint(kind, rng)[:n, :n]
    cov = prior.extrapolate_covariance(0.0, x1, 0.6, P)
    x = prior.extrapolate(0.0, x1, 0.6)
    J = jacobian8_stacked(lambda d: kind.local(x, prior.extrapolate(0.0, kind.retract(x1, d), 0.6)), n)
    sde = _sde(prior)
    gamma = sde.transition(0.6) @ np.r_[np.zeros(kind.group.dim), x1[kind.group.size :]] + sde.input_integral(0.6)
    N = jacobian8_stacked(lambda dg: kind.local(x, _from_local(prior, x1, gamma + dg)), n)  # ∂x(t)/∂γ(t)
    dense = J @ P @ J.T + N @ sde.process_noise(0.6) @ N.T
    big = np.max(np.abs(dense))
    np.testing.assert_allclose(cov, dense, rtol=0, atol=1e-9 * big)
    assert np.min(np.linalg.eigvalsh(cov)) >= -1e-12 * np.max(np.linalg.eigvalsh(cov))
