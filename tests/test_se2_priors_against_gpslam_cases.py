"""gpslam's planar GP cases (Pose2 and the 3-dim linear prior), ported as facts onto steam_ref's priors.

The source is gpslam (Dong & Yan, Georgia Tech), repository ``gtrll/gpslam`` at commit 2c56dbac: its tests
``gpslam/gp/tests/testGaussianProcessPriorPose2.cpp`` (``GaussianProcessPriorPose2``: ``Factor``,
``Optimization``), ``testGaussianProcessInterpolatorPose2.cpp`` (``GaussianProcessInterpolatorPose2``:
``interpolatePose``), ``testGaussianProcessPriorLinear.cpp`` (``GaussianProcessPriorLinear``: ``Factor``,
``Optimization``), ``testGaussianProcessInterpolatorLinear.cpp`` (``GaussianProcessInterpolatorLinear``:
``interpolatePose``), and the closed forms of ``gpslam/gp/GPutils.h`` (``calcQ``, ``calcQ_inv``, ``calcPhi``,
``calcLambda``, ``calcPsi``) and of the factors' headers (``GaussianProcessPriorPose2.h``,
``GaussianProcessInterpolatorPose2.h``, ``GaussianProcessPriorLinear.h``). The Pose3 fixtures are in
``tests/test_gpslam_pose3.py``. Only inputs, expected outputs and the properties checked carry over.

**Conventions, and the conversion.**

- *Pose2.* gpslam's poses are GTSAM's ``Pose2``, tangent [x, y, θ] as ours, perturbed on the right (GTSAM's
  retraction, our ``GroupState``); its velocity variable is the body twist (ours), perturbed by +. A pose written
  ``Pose2(x, y, θ)`` is ours [x, y, wrap(θ)]: GTSAM stores the angle as (cos θ, sin θ), ours in (-π, π] (the
  fixture Pose2(2.4, -2.5, 3.7) is the same rotation as θ = 3.7 - 2π).
- *The Pose2 prior* (``GaussianProcessPriorPose2.h``): e = [Log(T₁⁻¹T₂) - Δt ϖ₁; ϖ₂ - ϖ₁], noise ``calcQ``(Qc, Δt):
  our ``residual="simplified"`` (``LieGroupWnoa(SE2, qc, "simplified")``), the same e, keys in the same order.
- *The Pose2 interpolator* (``GaussianProcessInterpolatorPose2.h``): T(τ) = T₁ Exp(Λ₀ [0; ϖ₁] + Ψ₀ [ξ; ϖ₂]) with
  Λ₀, Ψ₀ the pose rows of ``calcLambda``, ``calcPsi``: ours with the simplified residual (γ₂ = [ξ; ϖ₂]).
  gpslam declares ``interpolateVelocity`` without writing it; ours gives the twist too, checked beside.
- *The linear prior* (``GaussianProcessPriorLinear.h``): e = Φ(Δt) x₁ - x₂ for x = [p; v]: ours
  (``GPPriorFactor.wnoa``) is e = x₂ - Φ x₁, minus gpslam's; so its Jacobians are minus ours (the cost is the same).
- *GPutils.* ``calcLambda`` = Φ(τ) - Q(τ) Φ(Δt - τ)ᵀ Q(Δt)⁻¹ Φ(Δt), ``calcPsi`` = Q(τ) Φ(Δt - τ)ᵀ Q(Δt)⁻¹, each
  written here from that definition; a second, independent oracle is the cubic Hermite basis of s = τ/Δt that the
  WNOA mean follows (pose rows [h₀₀ I, Δt h₁₀ I] and [h₀₁ I, Δt h₁₁ I]).

**Tolerances.** gpslam holds values to 1e-6 and its Jacobians to 1e-6 or 1e-8 of central differences of step 1e-6
(1e-4 at its "forward" cases). Ours are held tighter: values where the closed form is exact to 1e-14, Jacobians to
1e-9 of the 8th-order stencil (``finite_differences.jacobian8``).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from finite_differences import jacobian8

from steam_ref import X
from steam_ref.batch import gauss_newton
from steam_ref.factors.gp import GPPriorFactor
from steam_ref.factors.point_readings import PosePrior
from steam_ref.gp import interpolate_state, interpolation_matrices, process_noise, process_noise_inverse, transition
from steam_ref.graph import FactorGraph
from steam_ref.lie import SE2, GroupState
from steam_ref.lie import gp as lie_gp
from steam_ref.lie.se2 import wrap
from steam_ref.motion.lie_group import LieGroupWnoa
from steam_ref.variables import Values

QC = 0.01 * np.eye(3)  # every fixture's Qc
D = 3
STATE = GroupState(SE2)
PRIOR = LieGroupWnoa(SE2, QC, residual="simplified")  # gpslam's GaussianProcessPriorPose2


def pose2(x, y, theta):
    """GTSAM's ``Pose2(x, y, θ)`` as ours: the angle wrapped to (-π, π] (module docstring)."""
    return np.array([x, y, float(wrap(theta))])


def state(p, v):
    return np.concatenate([pose2(*p), np.asarray(v, dtype=float)])


def right_jacobians(f, x1, x2, n=2 * D, kind=STATE):
    """∂f/∂δ₁, ∂f/∂δ₂ by the 8th-order stencil, each state stepped on the right (``kind.retract``)."""
    return (
        jacobian8(lambda d: f(kind.retract(x1, d), x2), n),
        jacobian8(lambda d: f(x1, kind.retract(x2, d)), n),
    )


def log_matrix(T):
    """Log of an SE(2) pose through the principal matrix logarithm (scipy), none of our SE(2) code."""
    c, s = np.cos(T[2]), np.sin(T[2])
    L = np.real(scipy.linalg.logm(np.array([[c, -s, T[0]], [s, c, T[1]], [0.0, 0.0, 1.0]])))
    return np.array([L[0, 2], L[1, 2], L[1, 0]])


# --- GPutils.h: calcQ, calcQ_inv, calcPhi, calcLambda, calcPsi ---------------------------------------------------------


def gpslam_q(qc, t):
    return np.block([[t**3 / 3 * qc, t**2 / 2 * qc], [t**2 / 2 * qc, t * qc]])


def gpslam_q_inv(qc, t):
    qi = np.linalg.inv(qc)
    return np.block([[12 / t**3 * qi, -6 / t**2 * qi], [-6 / t**2 * qi, 4 / t * qi]])


def gpslam_phi(t, d=D):
    return np.block([[np.eye(d), t * np.eye(d)], [np.zeros((d, d)), np.eye(d)]])


@pytest.mark.parametrize(("dt", "tau"), [(0.1, 0.03), (0.1, 0.06), (1.0, 0.5), (2.5, 0.1)])
def test_gputils_closed_forms(dt, tau):
    """GPutils.h: calcQ = [[τ³/3 Qc, τ²/2 Qc], [τ²/2 Qc, τ Qc]], calcQ_inv = [[12/τ³, -6/τ²], [-6/τ², 4/τ]] ⊗ Qc⁻¹,
    calcPhi = [[I, τ I], [0, I]], calcLambda and calcPsi from their definitions (module docstring), at the fixtures'
    Δt = 0.1, τ = 0.03 (and ``GaussianProcessInterpolatorLinear.equals``' τ = 0.06, and two more): ours
    (``gp.process_noise``, ``process_noise_inverse``, ``transition``, ``interpolation_matrices``) to 1e-13 relative;
    the pose rows of Λ and Ψ also against the cubic Hermite basis, s = τ/Δt: h₀₀ = 1 - 3s² + 2s³,
    h₁₀ = s - 2s² + s³, h₀₁ = 3s² - 2s³, h₁₁ = s³ - s²."""
    qc = np.diag([0.01, 0.02, 0.05])  # a Qc with unequal entries, so a swapped block shows
    np.testing.assert_allclose(process_noise(dt, qc), gpslam_q(qc, dt), rtol=1e-14, atol=0)
    np.testing.assert_allclose(process_noise_inverse(dt, qc), gpslam_q_inv(qc, dt), rtol=1e-13, atol=0)
    np.testing.assert_array_equal(transition(dt, D), gpslam_phi(dt))
    psi = gpslam_q(qc, tau) @ gpslam_phi(dt - tau).T @ gpslam_q_inv(qc, dt)
    lam = gpslam_phi(tau) - psi @ gpslam_phi(dt)
    ours_lam, ours_psi = interpolation_matrices(0.0, dt, tau, qc)
    np.testing.assert_allclose(ours_lam, lam, rtol=0, atol=1e-13 * np.max(np.abs(lam)))
    np.testing.assert_allclose(ours_psi, psi, rtol=0, atol=1e-13 * np.max(np.abs(psi)))
    s, eye = tau / dt, np.eye(D)
    h00, h10, h01, h11 = 1 - 3 * s**2 + 2 * s**3, s - 2 * s**2 + s**3, 3 * s**2 - 2 * s**3, s**3 - s**2
    np.testing.assert_allclose(ours_lam[:D], np.hstack([h00 * eye, dt * h10 * eye]), rtol=0, atol=1e-14)
    np.testing.assert_allclose(ours_psi[:D], np.hstack([h01 * eye, dt * h11 * eye]), rtol=0, atol=1e-14)


# --- testGaussianProcessPriorPose2.cpp ---------------------------------------------------------------------------------

# (p1, v1, p2, v2) of ``GaussianProcessPriorPose2.Factor``, Δt = 0.1; gpslam asserts e = 0 on the first three
POSE2_PRIOR_FIXTURES = {
    "origin": ((0, 0, 0), (0, 0, 0), (0, 0, 0), (0, 0, 0)),
    "forward": ((0, 0, 0), (1, 0, 0), (0.1, 0, 0), (1, 0, 0)),
    "rotate": ((0, 0, 0), (0, 0, 1), (0, 0, 0.1), (0, 0, 1)),
    "random": ((-0.1, 1.2, 0.3), (5, 4, 9), (2.4, -2.5, 3.7), (0, 6, 4)),
}


@pytest.mark.parametrize("name", list(POSE2_PRIOR_FIXTURES))
def test_pose2_prior_factor_fixture(name):
    """``GaussianProcessPriorPose2.Factor``: e = 0 at rest, moving forward at 1 m/s and turning at 1 rad/s (gpslam:
    1e-6; ours 1e-15); at the "random" states (where gpslam asserts no value) e = [Log(T₁⁻¹T₂) - Δt ϖ₁; ϖ₂ - ϖ₁]
    with the Log from scipy's matrix logarithm, to 1e-12. H₁..H₄ against differences (gpslam: 1e-6 of central
    differences): ours to 1e-9 of the 8th-order stencil; and gpslam's own closed forms, H₂ = [-Δt I; -I],
    H₄ = [0; I], H₃ = [J_r(ξ)⁻¹; 0] (its Hlogmap · Hcomp2), exactly as written."""
    dt = 0.1
    p1, v1, p2, v2 = POSE2_PRIOR_FIXTURES[name]
    x1, x2 = state(p1, v1), state(p2, v2)
    factor = PRIOR.prior_factor(X(1), X(2), dt)
    e = factor.error(x1, x2)
    if name == "random":
        xi = log_matrix(SE2.between(x1[:3], x2[:3]))
        np.testing.assert_allclose(e, np.r_[xi - dt * x1[3:], x2[3:] - x1[3:]], rtol=0, atol=1e-12)
    else:
        assert np.max(np.abs(e)) < 1e-15, e
    A, B = factor.jacobians(x1, x2)
    n1, n2 = right_jacobians(factor.error, x1, x2)
    np.testing.assert_allclose(A, n1, rtol=0, atol=1e-9)
    np.testing.assert_allclose(B, n2, rtol=0, atol=1e-9)
    eye, zero = np.eye(D), np.zeros((D, D))
    np.testing.assert_array_equal(A[:, D:], np.vstack([-dt * eye, -eye]))
    np.testing.assert_array_equal(B[:, D:], np.vstack([zero, eye]))
    xi = SE2.log(SE2.between(x1[:3], x2[:3]))
    np.testing.assert_allclose(B[:, :D], np.vstack([SE2.right_jacobian_inverse(xi), zero]), rtol=0, atol=1e-15)


@pytest.mark.parametrize("dt", [0.1, 1.0])
def test_pose2_prior_noise_is_calc_q(dt):
    """``GaussianProcessPriorPose2``'s noise model is ``calcQ<3>``(Qc, Δt): the factor's WᵀW = calcQ_inv, to 1e-12
    relative of its largest entry."""
    W = PRIOR.prior_factor(X(1), X(2), dt).sqrt_information
    expected = gpslam_q_inv(QC, dt)
    np.testing.assert_allclose(W.T @ W, expected, rtol=0, atol=1e-12 * np.max(np.abs(expected)))


def test_pose2_prior_optimization_fixture():
    """``GaussianProcessPriorPose2.Optimization``: poses held by priors (σ = 0.001) at the origin and at x = 1, the GP
    factor between them (Δt = 1, Qc = 0.01 I), no prior on a twist; started at ϖ₁ = (1, 0, 0) and gpslam's
    "rnd value" ϖ₂ = (2, -0.5, 0.6). Gauss-Newton ends at zero cost, the poses unmoved and both twists (1, 0, 0)
    (gpslam: 1e-6 each; ours 1e-12)."""
    pose1, pose2_, forward = pose2(0, 0, 0), pose2(1, 0, 0), np.array([1.0, 0.0, 0.0])
    graph = FactorGraph(
        [
            PosePrior.create(X(1), pose1, 0.001, group=SE2),
            PosePrior.create(X(2), pose2_, 0.001, group=SE2),
            PRIOR.prior_factor(X(1), X(2), 1.0),
        ]
    )
    initial = Values({X(1): np.r_[pose1, forward], X(2): np.r_[pose2_, 2.0, -0.5, 0.6]})
    result = gauss_newton(graph, initial)
    assert result.converged
    assert graph.error(result.values) < 1e-24
    for key, pose in ((X(1), pose1), (X(2), pose2_)):
        x = result.values[key]
        np.testing.assert_allclose(x[:3], pose, rtol=0, atol=1e-12)
        np.testing.assert_allclose(x[3:], forward, rtol=0, atol=1e-12)


# --- testGaussianProcessInterpolatorPose2.cpp --------------------------------------------------------------------------

DT, TAU = 0.1, 0.03  # ``GaussianProcessInterpolatorPose2.interpolatePose``: states at 0 and 0.1, the query at 0.03
LAM, PSI = interpolation_matrices(0.0, DT, TAU, QC)

# (p1, v1, p2, v2, the pose gpslam expects at τ or None)
POSE2_INTERP_FIXTURES = {
    "origin": ((0, 0, 0), (0, 0, 0), (0, 0, 0), (0, 0, 0), (0, 0, 0)),
    "forward": ((0, 0, 0), (1, 0, 0), (0.1, 0, 0), (1, 0, 0), (0.03, 0, 0)),
    "rotate": ((0, 0, 0), (0, 0, 1), (0, 0, 0.1), (0, 0, 1), (0, 0, 0.03)),
    "random": ((3, -8, 2), (0.5, 0.9, 0.7), (-9, 3, 4), (0.6, -0.2, 0.8), None),
}


def gpslam_interpolated_pose(x1, x2):
    """gpslam's interpolated pose, from its header's formula: T₁ Exp(Λ₀ [0; ϖ₁] + Ψ₀ [ξ; ϖ₂]), Λ₀ and Ψ₀ the pose
    rows of calcLambda and calcPsi at (Qc, Δt, τ) (written here from GPutils.h), ξ = Log(T₁⁻¹T₂) from scipy."""
    psi = gpslam_q(QC, TAU) @ gpslam_phi(DT - TAU).T @ gpslam_q_inv(QC, DT)
    lam = gpslam_phi(TAU) - psi @ gpslam_phi(DT)
    xi = log_matrix(SE2.between(x1[:3], x2[:3]))
    local = lam[:D] @ np.r_[np.zeros(D), x1[3:]] + psi[:D] @ np.r_[xi, x2[3:]]
    return SE2.compose(x1[:3], SE2.exp(local))


@pytest.mark.parametrize("name", list(POSE2_INTERP_FIXTURES))
def test_pose2_interpolator_fixture(name):
    """``GaussianProcessInterpolatorPose2.interpolatePose``: the pose at τ = 0.03 is (0, 0, 0) at rest, (0.03, 0, 0)
    forward at 1 m/s, (0, 0, 0.03) turning at 1 rad/s (gpslam: 1e-6; ours 1e-15), and at every fixture the pose of
    gpslam's formula (:func:`gpslam_interpolated_pose`) to 1e-13; the twist at τ is the common twist where the two
    are equal (ours only: gpslam has no interpolated twist). Jacobians, pose rows (gpslam's) and twist rows, within
    1e-9 of the 8th-order stencil (gpslam: 1e-8 of central differences, 1e-6 at "forward")."""
    p1, v1, p2, v2, expected = POSE2_INTERP_FIXTURES[name]
    x1, x2 = state(p1, v1), state(p2, v2)
    x = PRIOR.interpolate(0.0, x1, DT, x2, TAU)
    if expected is not None:
        np.testing.assert_allclose(x[:3], pose2(*expected), rtol=0, atol=1e-15)
        np.testing.assert_allclose(x[3:], x1[3:], rtol=0, atol=1e-15)
    np.testing.assert_allclose(x[:3], gpslam_interpolated_pose(x1, x2), rtol=0, atol=1e-13)
    y, J1, J2 = lie_gp.interpolate(x1, x2, LAM, PSI, "simplified", group=SE2)
    np.testing.assert_array_equal(y, x)

    def at(a, b):
        return STATE.local(x, lie_gp.interpolate(a, b, LAM, PSI, "simplified", group=SE2, jacobians=False))

    n1, n2 = right_jacobians(at, x1, x2)
    np.testing.assert_allclose(J1, n1, rtol=0, atol=1e-9)
    np.testing.assert_allclose(J2, n2, rtol=0, atol=1e-9)


# --- testGaussianProcessPriorLinear.cpp, testGaussianProcessInterpolatorLinear.cpp ---------------------------------

# (p1, v1, p2, v2) of ``GaussianProcessPriorLinear.Factor`` (GaussianProcessPriorLinear<3>), Δt = 0.1
LINEAR_PRIOR_FIXTURES = {
    "origin": ((0, 0, 0), (0, 0, 0), (0, 0, 0), (0, 0, 0)),
    "forward": ((0, 0, 0), (1, 0, 0), (0.1, 0, 0), (1, 0, 0)),
    "rotate": ((0, 0, 0), (0, 0, 1), (0, 0, 0.1), (0, 0, 1)),
    "random": ((2, -5, 7), (-1, 2, -9), (-8, 4, -8), (3, -4, 7)),
}


@pytest.mark.parametrize("name", list(LINEAR_PRIOR_FIXTURES))
def test_linear_prior_factor_fixture(name):
    """``GaussianProcessPriorLinear.Factor``: e = 0 at the three constant-velocity fixtures (gpslam: 1e-6; ours
    1e-15); everywhere ours is minus gpslam's Φ(Δt)x₁ - x₂ (module docstring), to 1e-14, and its Jacobians minus
    gpslam's written ones (H₁ = [I; 0], H₂ = [Δt I; I], H₃ = [-I; 0], H₄ = [0; -I]), exactly."""
    dt = 0.1
    p1, v1, p2, v2 = LINEAR_PRIOR_FIXTURES[name]
    x1, x2 = np.r_[p1, v1].astype(float), np.r_[p2, v2].astype(float)
    factor = GPPriorFactor.wnoa(X(1), X(2), dt, QC)
    e = factor.error(x1, x2)
    gpslam_e = gpslam_phi(dt) @ x1 - x2
    np.testing.assert_allclose(e, -gpslam_e, rtol=0, atol=1e-14)
    if name != "random":
        assert np.max(np.abs(e)) < 1e-15, e
    eye, zero = np.eye(D), np.zeros((D, D))
    H1, H2 = np.vstack([eye, zero]), np.vstack([dt * eye, eye])
    H3, H4 = np.vstack([-eye, zero]), np.vstack([zero, -eye])
    A, B = factor.jacobians(x1, x2)
    np.testing.assert_array_equal(A, -np.hstack([H1, H2]))
    np.testing.assert_array_equal(B, -np.hstack([H3, H4]))


def test_linear_prior_optimization_fixture():
    """``GaussianProcessPriorLinear.Optimization``: positions held by priors (σ = 0.001) at (1, 0, 0) and
    (1.1, 0, 0), the GP factor between them (Δt = 0.1, Qc = 0.01 I), no prior on a velocity; gpslam starts at noisy
    values and ends (Gauss-Newton) at zero cost with both velocities (1, 0, 0). The problem is linear: ours is its
    least-squares solution from our factor's whitened error and Jacobians (steam_ref holds no prior on part of a
    vector state), solved densely: the positions (1, 0, 0), (1.1, 0, 0) and velocities (1, 0, 0), to 1e-12; the
    cost at it 0 (gpslam: 1e-6)."""
    factor = GPPriorFactor.wnoa(X(1), X(2), 0.1, QC)
    W = factor.sqrt_information
    x0 = np.r_[1.1, 0.3, 0.5, 1, 0.1, 0.2, 1.2, 0.4, -0.2, 2.1, -1.2, 0.9]  # gpslam's noisy start (x1, x2)
    A, B = factor.jacobians(x0[:6], x0[6:])
    select = np.hstack([np.eye(D), np.zeros((D, D))])
    rows = [
        (np.hstack([select, np.zeros((D, 6))]) / 0.001, (np.r_[1.0, 0, 0] - x0[:3]) / 0.001),
        (np.hstack([np.zeros((D, 6)), select]) / 0.001, (np.r_[1.1, 0, 0] - x0[6:9]) / 0.001),
        (W @ np.hstack([A, B]), -W @ factor.error(x0[:6], x0[6:])),
    ]
    J, r = np.vstack([j for j, _ in rows]), np.concatenate([b for _, b in rows])
    x = x0 + np.linalg.lstsq(J, r, rcond=None)[0]
    np.testing.assert_allclose(x, np.r_[1, 0, 0, 1, 0, 0, 1.1, 0, 0, 1, 0, 0], rtol=0, atol=1e-12)
    assert np.linalg.norm(W @ factor.error(x[:6], x[6:])) < 1e-12


# (p1, v1, p2, v2, the position gpslam expects at τ or None), Δt = 0.1, τ = 0.03
LINEAR_INTERP_FIXTURES = {
    "origin": ((0, 0, 0), (0, 0, 0), (0, 0, 0), (0, 0, 0), (0, 0, 0)),
    "forward": ((0, 0, 0), (10, 0, 0), (1, 0, 0), (10, 0, 0), (0.3, 0, 0)),
    "rotate": ((0, 0, 0), (0, 0, 3), (0, 0, 0.3), (0, 0, 3), (0, 0, 0.09)),
    "random": ((2, -5, 7), (-1, 2, -9), (-8, 4, -8), (3, -4, 7), None),
}


@pytest.mark.parametrize("name", list(LINEAR_INTERP_FIXTURES))
def test_linear_interpolator_fixture(name):
    """``GaussianProcessInterpolatorLinear.interpolatePose``: the position at τ = 0.03 is 0 at rest, (0.3, 0, 0) at
    10 m/s, (0, 0, 0.09) at 3 rad/s (gpslam: 1e-6; ours 1e-14), and at every fixture Λ₀x₁ + Ψ₀x₂ of gpslam's calcLambda,
    calcPsi (to 1e-12); its Jacobians are Λ₀ and Ψ₀ (the interpolation is linear: ours ``gp.interpolate_state``
    against the same differences gpslam takes, here the 8th-order stencil, to 1e-9)."""
    p1, v1, p2, v2, expected = LINEAR_INTERP_FIXTURES[name]
    x1, x2 = np.r_[p1, v1].astype(float), np.r_[p2, v2].astype(float)
    x = interpolate_state(0.0, x1, DT, x2, TAU, QC)
    if expected is not None:
        np.testing.assert_allclose(x[:3], expected, rtol=0, atol=1e-14)
        np.testing.assert_allclose(x[3:], v1, rtol=0, atol=1e-13)
    psi = gpslam_q(QC, TAU) @ gpslam_phi(DT - TAU).T @ gpslam_q_inv(QC, DT)
    lam = gpslam_phi(TAU) - psi @ gpslam_phi(DT)
    np.testing.assert_allclose(x[:3], lam[:D] @ x1 + psi[:D] @ x2, rtol=0, atol=1e-12)
    n1 = jacobian8(lambda d: interpolate_state(0.0, x1 + d, DT, x2, TAU, QC), 6)
    n2 = jacobian8(lambda d: interpolate_state(0.0, x1, DT, x2 + d, TAU, QC), 6)
    np.testing.assert_allclose(n1[:D], lam[:D], rtol=0, atol=1e-9)
    np.testing.assert_allclose(n2[:D], psi[:D], rtol=0, atol=1e-9)
