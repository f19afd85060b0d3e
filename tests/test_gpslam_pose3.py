"""gpslam's SE(3) fixtures against our 'se3' prior (``LieGroupWnoa(SE3V, ...)``, states [t; φ; ϖ]).

gpslam (Yan & Dong, Georgia Tech; ``gtrll/gpslam``, the version stored at commit 2c56dba) tests its Pose3 GP in
``gpslam/gp/tests/``: ``testGaussianProcessPriorPose3.cpp`` (``GaussianProcessPriorPose3Test``: ``Factor``,
``Optimization``), ``testGaussianProcessInterpolatorPose3.cpp`` (``GaussianProcessInterpolatorPose3``:
``interpolatePose``) and ``testPose3Utils.cpp`` (``testPose3Utils``: ``getBodyCentricVelocity``, ``SE3Jacobian``,
``SE3velocity``). Their states, times, Qc and asserted values are carried over below, each test naming its source.

Conventions, mapped:

- **Order.** gpslam's poses are GTSAM's ``Pose3``, tangent [ω; v] rotation first, its velocity variable too; ours
  [ρ; φ] translation first: ``_ours`` permutes each 6-vector (the permutation is its own inverse), and an error or
  Jacobian of gpslam's has each 6-block permuted so.
- **Velocity.** gpslam's velocity is the body twist (``getBodyCentricVb`` = Log(T₁⁻¹T₂)/Δt, ``Pose3utils.cpp``),
  ours too (Ṫ = T ϖ^); both perturb a pose on the right (GTSAM's retraction, our ``GroupState``) and a twist by +.
- **Prior.** ``GaussianProcessPriorPose3.h``: e = [Log(T₁⁻¹T₂) - Δt ϖ₁; J_r(ξ)⁻¹ ϖ₂ - ϖ₁], noise Q(Δt) of the
  vector WNOA (``calcQ``, ``GPutils.h``): our "local-variable" residual, the table's 'se3' (gpslam's Pose2 prior
  is the "simplified" one, ``steam_ref.lie.gp``). Its ∂(J_r(ξ)⁻¹ϖ₂)/∂ξ is central differences of step 1e-6
  (``jacobianMethodNumercialDiff``); ours is exact, so ours is held to 8th-order differences at 1e-12 where
  gpslam holds its own to 1e-6 and 1e-5 against central differences of step 1e-6.
- **Interpolator.** ``GaussianProcessInterpolatorPose3.h``: T(τ) = T₁ Exp(ξ(τ)), ξ(τ) the pose rows of
  Λ [0; ϖ₁] + Ψ [ξ; J_r(ξ)⁻¹ϖ₂], Λ and Ψ of the vector WNOA (``calcLambda``, ``calcPsi``): our interpolated pose.
  gpslam declares ``interpolateVelocity`` without writing it, so its fixtures check the pose and its four 6 × 6
  Jacobians alone; ours give the twist too, checked here beside them.
- **Not translated.** ``GaussianProcessPriorPose3VW`` / ``InterpolatorPose3VW`` and ``convertVbtoVW`` hold the
  linear velocity in the world frame, a state we do not have; the ``Rot3`` prior and interpolator hold a
  rotation alone (our priors hold a pose). ``testPose3Utils.SO3Jacobian``'s two rotations are checked on our SO(3)
  beside the SE(3) fixtures.

``Rot3::Ypr(y, p, r)`` is Rz(y) Ry(p) Rx(r) (GTSAM's ``Rot3.h``; equal to GTSAM 4.3's to 2e-16 where measured).
"""

from __future__ import annotations

import numpy as np
import pytest
from finite_differences import jacobian8_stacked

from steam_ref.batch import gauss_newton
from steam_ref.factors.point_readings import PosePrior
from steam_ref.gp import interpolation_matrices
from steam_ref.graph import FactorGraph
from steam_ref.lie import SE3V, SO3
from steam_ref.lie import gp as lie_gp
from steam_ref.motion import motion_prior
from steam_ref.variables import X

PERM = np.r_[3:6, 0:3]  # [ω; v] <-> [ρ; φ], either way
QC = 0.01 * np.eye(6)  # every Pose3 fixture's Qc
PI = np.pi


def _ours(v) -> np.ndarray:
    """A 6-vector of gpslam's ([ω; v]) in our order ([ρ; φ])."""
    return np.asarray(v, dtype=float)[PERM]


def _rot(axis: int, angle: float) -> np.ndarray:
    phi = np.zeros(3)
    phi[axis] = angle
    return SO3.exp(phi).reshape(3, 3)


def _pose(ypr=(0.0, 0.0, 0.0), t=(0.0, 0.0, 0.0)) -> np.ndarray:
    """GTSAM's ``Pose3(Rot3::Ypr(y, p, r), Point3(t))`` as an SE3V pose [t; φ]."""
    R = _rot(2, ypr[0]) @ _rot(1, ypr[1]) @ _rot(0, ypr[2])
    return np.r_[np.asarray(t, dtype=float), SO3.log_matrix(R)]


def _matrix_off(a: np.ndarray, b: np.ndarray) -> float:
    """The largest difference of two SE3V poses' 4 × 4 matrices."""
    return float(np.max(np.abs(SE3V.matrix(a) - SE3V.matrix(b))))


def assert_close(analytic: np.ndarray, numeric: np.ndarray, tol: float) -> None:
    scale = max(1.0, float(np.max(np.abs(numeric))))
    np.testing.assert_allclose(analytic, numeric, rtol=0, atol=tol * scale)


# --- testGaussianProcessPriorPose3.cpp --------------------------------------------------------------------------

PRIOR = motion_prior("se3", QC)
STATE = PRIOR.kind

# (p1, v1, p2, v2) of ``GaussianProcessPriorPose3Test.Factor``, Δt = 0.1; gpslam asserts e = 0 on the first three
PRIOR_FIXTURES = {
    "origin": ((), [0] * 6, (), [0] * 6),
    "forward": ((), [0, 0, 0, 1, 0, 0], ((0, 0, 0), (0.1, 0, 0)), [0, 0, 0, 1, 0, 0]),
    "rotate": ((), [0, 0, 1, 0, 0, 0], ((0.1, 0, 0),), [0, 0, 1, 0, 0, 0]),
    "random": (
        ((-0.1, 1.2, 0.3), (-4.0, 2.0, 14.0)),
        [2, 3, 1, 5, 4, 9],
        ((2.4, -2.5, 3.7), (9.0, -8.0, -7.0)),
        [1, 3, 8, 0, 6, 4],
    ),
}


def _states(fixture) -> tuple[np.ndarray, np.ndarray]:
    p1, v1, p2, v2 = fixture
    return np.r_[_pose(*p1), _ours(v1)], np.r_[_pose(*p2), _ours(v2)]


@pytest.mark.parametrize("name", sorted(PRIOR_FIXTURES))
def test_prior_factor_fixture(name):
    """``GaussianProcessPriorPose3Test.Factor``: e = 0 at rest and at a constant twist (gpslam: 1e-6; ours 1e-15);
    H₁..H₄ against central differences of step 1e-6 (gpslam: 1e-6, H₁ 1e-5 at the random states): ours within 1e-12
    of 8th-order differences at every fixture (measured ≤ 1.1e-13), and H₂ = [-Δt I; -I], H₄ = [0; J_r(ξ)⁻¹] as
    gpslam writes them."""
    dt = 0.1
    x1, x2 = _states(PRIOR_FIXTURES[name])
    factor = PRIOR.prior_factor(X(1), X(2), dt)
    e = factor.error(x1, x2)
    if name != "random":  # gpslam asserts no value at its random states
        assert np.max(np.abs(e)) < 1e-15
    A, B = factor.jacobians(x1, x2)
    assert_close(A, jacobian8_stacked(lambda d: factor.error(STATE.retract(x1, d), x2), 12), 1e-12)
    assert_close(B, jacobian8_stacked(lambda d: factor.error(x1, STATE.retract(x2, d)), 12), 1e-12)
    eye = np.eye(6)
    np.testing.assert_array_equal(A[:, 6:], np.vstack([-dt * eye, -eye]))  # ∂e/∂ϖ₁
    xi = SE3V.log(SE3V.between(x1[:6], x2[:6]))
    np.testing.assert_array_equal(B[:, 6:], np.vstack([0 * eye, SE3V.right_jacobian_inverse(xi)]))  # ∂e/∂ϖ₂


def test_prior_noise_is_q_of_dt():
    """The factor's noise: Q(Δt) = [[Δt³/3 Qc, Δt²/2 Qc], [Δt²/2 Qc, Δt Qc]] (``calcQ``), so WᵀW = Q(Δt)⁻¹."""
    for dt in (0.1, 1.0):
        W = PRIOR.prior_factor(X(1), X(2), dt).sqrt_information
        Q = np.block([[dt**3 / 3 * QC, dt**2 / 2 * QC], [dt**2 / 2 * QC, dt * QC]])
        assert_close(W.T @ W, np.linalg.inv(Q), 1e-12)


def test_prior_optimization_fixture():
    """``GaussianProcessPriorPose3Test.Optimization``: both poses held by priors (σ = 0.001) at the origin and at
    x = 1, the GP factor between them (Δt = 1, Qc = 0.01 I), no prior on a twist; started at ϖ₁ = [1 m/s forward],
    ϖ₂ = gpslam's "rnd value". Gauss-Newton ends at zero cost with both twists [1 m/s forward] and the poses
    unmoved (gpslam: 1e-6 each; ours 1e-12)."""
    pose1, pose2 = _pose(), _pose(t=(1.0, 0.0, 0.0))
    forward = _ours([0, 0, 0, 1, 0, 0])
    graph = FactorGraph(
        [
            PosePrior.create(X(1), pose1, 0.001, group=SE3V),
            PosePrior.create(X(2), pose2, 0.001, group=SE3V),
            PRIOR.prior_factor(X(1), X(2), 1.0),
        ]
    )
    initial = {X(1): np.r_[pose1, forward], X(2): np.r_[pose2, _ours([0.1, 0.2, -0.3, 2.0, -0.5, 0.6])]}
    result = gauss_newton(graph, initial)
    assert result.converged
    assert graph.error(result.values) < 1e-24
    for key, pose in ((X(1), pose1), (X(2), pose2)):
        x = result.values[key]
        assert _matrix_off(x[:6], pose) < 1e-12
        np.testing.assert_allclose(x[6:], forward, rtol=0, atol=1e-12)


# --- testGaussianProcessInterpolatorPose3.cpp --------------------------------------------------------------------

DT, TAU = 0.1, 0.03  # ``GaussianProcessInterpolatorPose3.interpolatePose``: states at 0 and 0.1, the query at 0.03

# (p1, v1, p2, v2, the pose gpslam expects at τ or None); gpslam holds the pose to 1e-6, its Jacobians to 1e-8 of
# central differences of step 1e-6 (1e-6 of step 1e-4 at "forward")
INTERP_FIXTURES = {
    "origin": ((), [0] * 6, (), [0] * 6, ()),
    "forward": ((), [0, 0, 0, 1, 0, 0], ((0, 0, 0), (0.1, 0, 0)), [0, 0, 0, 1, 0, 0], ((0, 0, 0), (0.03, 0, 0))),
    "rotate": ((), [0, 0, 1, 0, 0, 0], ((0.1, 0, 0),), [0, 0, 1, 0, 0, 0], ((0.03, 0, 0),)),
    "random": (
        ((0.4, -0.8, 0.2), (3.0, -8.0, 2.0)),
        [0.1, -0.2, -1.4, 0.5, 0.9, 0.7],
        ((0.1, 0.3, -0.5), (-9.0, 3.0, 4.0)),
        [0.6, 0.3, -0.9, 0.4, -0.2, 0.8],
        None,
    ),
}


LAM, PSI = interpolation_matrices(0.0, DT, TAU, QC)


def _interpolate(x1: np.ndarray, x2: np.ndarray) -> np.ndarray:
    """The mean at τ alone (broadcasting over leading axes, for the stacked differences)."""
    return lie_gp.interpolate(x1, x2, LAM, PSI, group=SE3V, jacobians=False)


@pytest.mark.parametrize("name", sorted(INTERP_FIXTURES))
def test_interpolator_fixture(name):
    """The pose at τ gpslam expects (1e-6; ours 1e-15: at a constant twist Λ, Ψ carry the local GP along it
    exactly), the twist there unchanged at a constant twist (gpslam has no interpolated twist); the Jacobians,
    pose and twist rows, within 1e-12 of 8th-order differences (measured ≤ 7.4e-14; gpslam: the pose rows)."""
    p1, v1, p2, v2, expected = INTERP_FIXTURES[name]
    x1, x2 = _states((p1, v1, p2, v2))
    x = PRIOR.interpolate(0.0, x1, DT, x2, TAU)  # the table's 'se3' prior
    if expected is not None:
        assert _matrix_off(x[:6], _pose(*expected)) < 1e-15
        assert np.max(np.abs(x[6:] - x1[6:])) < 1e-15 and np.array_equal(x1[6:], x2[6:])
    y, J1, J2 = lie_gp.interpolate(x1, x2, LAM, PSI, group=SE3V)
    np.testing.assert_array_equal(y, x)
    assert_close(J1, jacobian8_stacked(lambda d: STATE.local(x, _interpolate(STATE.retract(x1, d), x2)), 12), 1e-12)
    assert_close(J2, jacobian8_stacked(lambda d: STATE.local(x, _interpolate(x1, STATE.retract(x2, d))), 12), 1e-12)


# --- testPose3Utils.cpp -------------------------------------------------------------------------------------------

# ``testPose3Utils.getBodyCentricVelocity``, Δt = 0.1: (pose1, pose2, Vb, Vs) as gpslam writes them ([ω; v])
VELOCITY_FIXTURES = {
    "origin": ((), (), [0] * 6, [0] * 6),
    "forward x": ((), ((0, 0, 0), (0.1, 0, 0)), [0, 0, 0, 1, 0, 0], [0, 0, 0, 1, 0, 0]),
    "rotate y": ((), ((0.1, 0, 0),), [0, 0, 1, 0, 0, 0], [0, 0, 1, 0, 0, 0]),
    "forward x at yaw 90": (((PI / 2, 0, 0),), ((PI / 2, 0, 0), (0.1, 0, 0)), [0, 0, 0, 0, -1, 0], [0, 0, 0, 1, 0, 0]),
    "rotate body z at yaw 90": (((PI / 2, 0, 0),), ((PI / 2 + 0.1, 0, 0),), [0, 0, 1, 0, 0, 0], [0, 0, 1, 0, 0, 0]),
    "rotate body x at yaw 90": (
        ((PI / 2, 0, 0), (1, 0, 0)),
        ((PI / 2, 0, 0.1), (1, 0, 0)),
        [1, 0, 0, 0, 0, 0],
        [0, 1, 0, 0, 0, 1],
    ),
    "circle": (
        ((0, 0, 0), (0, -1, 0)),
        ((PI / 2, 0, 0), (1, 0, 0)),
        [0, 0, 5 * PI, 5 * PI, 0, 0],
        [0, 0, 5 * PI, 0, 0, 0],
    ),
}


@pytest.mark.parametrize("name", list(VELOCITY_FIXTURES))
def test_body_centric_velocity_fixture(name):
    """Vb = Log(T₁⁻¹T₂)/Δt and Vs = Log(T₂T₁⁻¹)/Δt = Ad(T₁) Vb, gpslam's numbers (its tolerance 1e-6; ours 1e-13
    of the largest); and Vb is the constant twist our prior reads as no motion noise: e(T₁, Vb, T₂, Vb) = 0."""
    dt = 0.1
    p1, p2, vb, vs = VELOCITY_FIXTURES[name]
    T1, T2 = _pose(*p1), _pose(*p2)
    body = SE3V.log(SE3V.between(T1, T2)) / dt
    tol = 1e-13 * max(1.0, float(np.max(np.abs(vb))))
    np.testing.assert_allclose(body, _ours(vb), rtol=0, atol=tol)
    np.testing.assert_allclose(SE3V.log(SE3V.compose(T2, SE3V.inverse(T1))) / dt, _ours(vs), rtol=0, atol=tol)
    np.testing.assert_allclose(SE3V.adjoint(T1) @ body, _ours(vs), rtol=0, atol=tol)
    e = PRIOR.prior_factor(X(1), X(2), dt).error(np.r_[T1, body], np.r_[T2, body])
    assert np.max(np.abs(e)) < tol


# ``testPose3Utils.SE3Jacobian`` and ``SE3velocity``: the poses at whose Log gpslam checks J_r, J_l and inverses
JACOBIAN_POSES = {
    "origin": (),
    "small": ((1e-5, 0.0, 1e-5), (0.0, 2e-5, 0.0)),
    "Ypr(1, 2, 3)": ((1.0, 2.0, 3.0), (4.0, 5.0, 6.0)),
    "Ypr(2.4, 1.2, 3.9)": ((2.4, 1.2, 3.9), (43.0, -5.0, 12.0)),
}


@pytest.mark.parametrize("name", list(JACOBIAN_POSES))
def test_se3_jacobian_fixture(name):
    """At ξ = Log(T) of gpslam's poses: J_r(ξ) u = d/ds Log(Exp(ξ)⁻¹ Exp(ξ + s u)) and J_l(ξ) = J_r(-ξ) u =
    d/ds Log(Exp(ξ + s u) Exp(ξ)⁻¹), within 1e-12 of 8th-order differences (measured ≤ 1.7e-13; gpslam: 1e-6 to
    1e-5 of one-sided differences of step 1e-6, and ``SE3velocity`` Anderson & Barfoot's Vb ≈ J_r(ξ) ξ̇ to 1e-4 at
    the last pose); J_r⁻¹ J_r = I to 1e-13. ``SO3Jacobian``'s rotations (the identity, Ypr(1, 2, 3)) the same on
    our SO(3)."""
    xi = SE3V.log(_pose(*JACOBIAN_POSES[name]))
    right = jacobian8_stacked(lambda u: SE3V.log(SE3V.between(SE3V.exp(xi), SE3V.exp(xi + u))), 6)
    left = jacobian8_stacked(lambda u: SE3V.log(SE3V.compose(SE3V.exp(xi + u), SE3V.inverse(SE3V.exp(xi)))), 6)
    assert_close(SE3V.right_jacobian(xi), right, 1e-12)
    assert_close(SE3V.right_jacobian(-xi), left, 1e-12)
    for x in (xi, -xi):
        assert_close(SE3V.right_jacobian_inverse(x) @ SE3V.right_jacobian(x), np.eye(6), 1e-13)
    if name in ("origin", "Ypr(1, 2, 3)"):
        phi = xi[3:]
        right = jacobian8_stacked(lambda u: SO3.log(SO3.between(SO3.exp(phi), SO3.exp(phi + u))), 3)
        left = jacobian8_stacked(lambda u: SO3.log(SO3.compose(SO3.exp(phi + u), SO3.inverse(SO3.exp(phi)))), 3)
        assert_close(SO3.right_jacobian(phi), right, 1e-12)
        assert_close(SO3.right_jacobian(-phi), left, 1e-12)
        assert_close(SO3.right_jacobian_inverse(phi) @ SO3.right_jacobian(phi), np.eye(3), 1e-13)
