"""lgmath's SE(2) and SO(2) cases, and its SO(3) ``Rotation`` cases, ported as facts onto steam_ref's SE2 and SO3.

The source is lgmath (Anderson, Barfoot, Lisus et al., BSD licence), repository ``utiasASRL/lgmath``:
``tests/SE2Tests.cpp`` at commit be0e03bb, ``tests/SO2Tests.cpp`` at 3619a877, ``tests/RotationTests.cpp`` at
07601434, and the closed forms of ``src/se2/Operations.cpp`` (``vec2Gamma1``, ``vec2Gamma2``, ``vec2jac``,
``vec2jacinv``, ``tranAd``) at 100f02f3. Each test names its file and its test. Only inputs, expected outputs and
the property checked carry over. (lgmath's SE(3), SO(3) and Transform cases are in ``test_se3_against_lgmath_cases``.)

**Conventions, and the conversion.** lgmath's SE(2) tangent is ξ = [ρ₁, ρ₂, θ] (translation first), ours too;
``hat(ξ)`` = [[0, -θ, ρ₁], [θ, 0, ρ₂], [0, 0, 0]] and ``curlyhat(ξ)`` = [[0, -θ, ρ₂], [θ, 0, -ρ₁], [0, 0, 0]] are
our ``hat`` and ``ad``; ``vec2tran`` = Exp, ``tran2vec`` = Log, ``tranAd`` = Ad. Like its SE(3), lgmath perturbs on
the left: its ``vec2jac(ξ)`` = [[Γ₁(θ), -S Γ₂(θ) ρ], [0, 1]], S = [[0, -1], [1, 0]], Γ₁ = (sin θ/θ) I + ((1 -
cos θ)/θ) S, Γ₂ = ((1 - cos θ)/θ²) I + ((θ - sin θ)/θ²) S, is the left Jacobian J_l(ξ) = J_r(-ξ), ours at -ξ
(written here from ``Operations.cpp``: :func:`lgmath_vec2jac`). A Log at θ = ±π: lgmath compares angles wrapped
to [-π, π]; ours is in (-π, π], so (0, 0, -π) reads back as π, the same rotation (asserted as such).

Random vectors (lgmath's ``Random()``, uniform in [-1, 1]) come from the suite's seeded generator; lgmath's
tolerance is 1e-6 throughout, ours 1e-14 against closed forms and matrix exponentials (``scipy.linalg.expm``).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from requirements import optional_import

from steam_ref.lie import SE2, SO3
from steam_ref.lie.se2 import wrap

mp = optional_import("mpmath", "test")

PI = np.pi
S = np.array([[0.0, -1.0], [1.0, 0.0]])


def gamma1(t):
    return np.eye(2) if abs(t) < 1e-12 else np.sin(t) / t * np.eye(2) + (1 - np.cos(t)) / t * S


def gamma2(t):
    return 0.5 * np.eye(2) if abs(t) < 1e-12 else (1 - np.cos(t)) / t**2 * np.eye(2) + (t - np.sin(t)) / t**2 * S


def lgmath_vec2jac(xi):
    """lgmath's ``se2::vec2jac`` (src/se2/Operations.cpp), written from its closed form."""
    J = np.eye(3)
    J[:2, :2], J[:2, 2] = gamma1(xi[2]), -S @ gamma2(xi[2]) @ xi[:2]
    return J


def lgmath_vec2jacinv(xi):
    """lgmath's ``se2::vec2jacinv``: [[Γ₁⁻¹, Γ₁⁻¹ S Γ₂ ρ], [0, 1]]."""
    J, g = np.eye(3), np.linalg.inv(gamma1(xi[2]))
    J[:2, :2], J[:2, 2] = g, g @ S @ gamma2(xi[2]) @ xi[:2]
    return J


def special_twists():
    """SE2Tests.cpp's special cases: zero, a unit step along x and along y, turns by π, -π and π/2."""
    return [
        np.array(v, dtype=float) for v in ([0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, PI], [0, 0, -PI], [0, 0, PI / 2])
    ]


def twists(rng):
    return special_twists() + list(rng.uniform(-1, 1, (20, 3)))


# --- SE2Tests.cpp ------------------------------------------------------------------------------------------------------


def test_se2_hat_and_curlyhat(rng):
    """SE2Tests.cpp, TestHatFunction, TestHatFunctionInputs and TestCurlyHatFunction: at 20 random ξ, hat(ξ) =
    [[0, -θ, ρ₁], [θ, 0, ρ₂], [0, 0, 0]] and curlyhat(ξ) = [[0, -θ, ρ₂], [θ, 0, -ρ₁], [0, 0, 0]]: our ``hat`` and
    ``ad``, exactly."""
    for r1, r2, t in rng.uniform(-1, 1, (20, 3)):
        xi = np.array([r1, r2, t])
        np.testing.assert_array_equal(SE2.hat(xi), [[0, -t, r1], [t, 0, r2], [0, 0, 0]])
        np.testing.assert_array_equal(SE2.ad(xi), [[0, -t, r2], [t, 0, -r1], [0, 0, 0]])


def test_se2_point_operators(rng):
    """SE2Tests.cpp, TestPointToCircleDotOperatorFunction (ξ^ p = p⊙ ξ, p⊙ = [[s I, S p], [0, 0]] for p = [p; s])
    and TestPointToDoubleCircleOperatorFunction (pᵀ ξ^ = ξᵀ p⊚, p⊚ = [[0, p], [-(S p)ᵀ, 0]]), at 20 random ξ and
    homogeneous points, with our ``hat``, to 1e-15."""
    for xi, p in zip(rng.uniform(-1, 1, (20, 3)), rng.uniform(-1, 1, (20, 3)), strict=True):
        fs = np.zeros((3, 3))
        fs[:2, :2], fs[:2, 2] = p[2] * np.eye(2), S @ p[:2]
        sf = np.zeros((3, 3))
        sf[:2, 2], sf[2, :2] = p[:2], -(S @ p[:2])
        np.testing.assert_allclose(SE2.hat(xi) @ p, fs @ xi, rtol=0, atol=1e-15)
        np.testing.assert_allclose(p @ SE2.hat(xi), xi @ sf, rtol=0, atol=1e-15)


def test_se2_vec2tran_and_tran2vec(rng):
    """SE2Tests.cpp, TestVec2TranFunction, TestTran2VecFunction and Vec2Tran2VecTest: Exp(ξ) = [[C(θ), Γ₁(θ) ρ],
    [0, 1]] (lgmath's closed form) and Log of it is ξ, at the special cases and 20 random ξ. Ours: the matrix of Exp
    against that closed form and against ``expm`` of the hat, to 1e-14; Log(Exp(ξ)) = ξ to 1e-14, except
    (0, 0, -π), which reads back (0, 0, π) (module docstring)."""
    for xi in twists(rng):
        M = SE2.matrix(SE2.exp(xi))
        c, s = np.cos(xi[2]), np.sin(xi[2])
        closed = np.eye(3)
        closed[:2, :2], closed[:2, 2] = [[c, -s], [s, c]], gamma1(xi[2]) @ xi[:2]
        np.testing.assert_allclose(M, closed, rtol=0, atol=1e-14)
        np.testing.assert_allclose(M, scipy.linalg.expm(SE2.hat(xi)), rtol=0, atol=1e-14)
        back = SE2.log(SE2.exp(xi))
        expected = np.array([xi[0], xi[1], PI]) if xi[2] == -PI else xi
        np.testing.assert_allclose(back, expected, rtol=0, atol=1e-14)
        assert abs(wrap(back[2] - xi[2])) < 1e-14  # lgmath's comparison, the angles wrapped


def mp_right_jacobian(xi):
    """J_r(ξ) = Σₙ (-ad ξ)ⁿ/(n+1)! at 40 digits, summed to 60 terms (the terms at abs(ξ) < 4 fall below 1e-45)."""
    with mp.workdps(40):
        A = mp.matrix([[mp.mpf(float(v)) for v in row] for row in SE2.ad(xi)])
        term, total = mp.eye(3), mp.eye(3)
        for n in range(1, 60):
            term = term * (-A) / (n + 1)
            total += term
        return np.array(total.tolist(), dtype=float)


def test_se2_jacobians_are_ours_at_minus_xi(rng):
    """SE2Tests.cpp, JacAndInvJacTest: vec2jac(ξ) vec2jacinv(ξ) = I at the special cases and 20 random ξ. Ours:
    J_r(-ξ) against the 40-digit series (:func:`mp_right_jacobian`) to 1e-15, J_r(-ξ)⁻¹ its inverse to 1e-14;
    lgmath's closed forms (module docstring) equal them to 1e-12 only: its (θ - sin θ)/θ² and (1 - cos θ)/θ² cancel
    at small turns, 3.7e-13 off the series at the random θ = -0.010 (recorded; within lgmath's 1e-6)."""
    worst = 0.0
    for xi in twists(rng):
        oracle = mp_right_jacobian(-xi)
        np.testing.assert_allclose(SE2.right_jacobian(-xi), oracle, rtol=0, atol=1e-15)
        np.testing.assert_allclose(SE2.right_jacobian_inverse(-xi) @ oracle, np.eye(3), rtol=0, atol=1e-14)
        np.testing.assert_allclose(lgmath_vec2jac(xi), oracle, rtol=0, atol=1e-12)
        np.testing.assert_allclose(lgmath_vec2jacinv(xi), SE2.right_jacobian_inverse(-xi), rtol=0, atol=1e-12)
        worst = max(worst, float(np.max(np.abs(lgmath_vec2jac(xi) - oracle))))
    assert 3.6e-13 < worst < 3.7e-13, worst  # recorded in the docstring


def test_se2_adjoint_identity(rng):
    """SE2Tests.cpp, TestIdentityAdTvEqualIPlusHatvTimesJv: Ad(Exp(v)) = I + curlyhat(v) J(v), J lgmath's left
    Jacobian: ours Ad(Exp(v)) = I + ad(v) J_r(-v), at the special cases and 20 random v, to 1e-14; and ``tranAd``'s
    form [[C, -S r], [0, 1]] for Exp(v) = (C, r)."""
    for v in twists(rng):
        T = SE2.exp(v)
        np.testing.assert_allclose(SE2.adjoint(T), np.eye(3) + SE2.ad(v) @ SE2.right_jacobian(-v), rtol=0, atol=1e-14)
        M = SE2.matrix(T)
        ad = np.eye(3)
        ad[:2, :2], ad[:2, 2] = M[:2, :2], -S @ M[:2, 2]
        np.testing.assert_allclose(SE2.adjoint(T), ad, rtol=0, atol=1e-15)


# --- SO2Tests.cpp: SO(2) as our SE(2) with zero translation -----------------------------------------------------------

SO2_ANGLES = [0.0, PI, PI / 2, PI / 4, 3 * PI / 4, 1e-4]


def test_so2_hat_and_vec2rot(rng):
    """SO2Tests.cpp, testHatFunction: hat(θ) = [[0, -θ], [θ, 0]], skew, linear (hat(2.5θ) = 2.5 hat(θ)), at 0, ±1,
    ±π, ±π/2 and 5 random angles in [-2π, 2π]: the rotation block of our SE(2) hat, exactly. testVec2Rot2Vec:
    vec2rot at 0, π, π/2, π/4, 3π/4, 1e-4 is [[cos, -sin], [sin, cos]] (written out for the first five), its angle
    reads back (wrapped) and it is a rotation (det 1, CᵀC = I): the rotation block of our Exp, to 1e-15."""
    angles = [0.0, 1.0, -1.0, PI, -PI, PI / 2, -PI / 2, *rng.uniform(-2 * PI, 2 * PI, 5)]
    for t in angles:
        H = SE2.hat([0.0, 0.0, t])[:2, :2]
        np.testing.assert_array_equal(H, [[0.0, -t], [t, 0.0]])
        np.testing.assert_array_equal(H.T, -H)
        np.testing.assert_allclose(SE2.hat([0.0, 0.0, 2.5 * t])[:2, :2], 2.5 * H, rtol=1e-15, atol=0)
    r = np.sqrt(2.0) / 2
    written = [np.eye(2), -np.eye(2), [[0, -1], [1, 0]], [[r, -r], [r, r]], [[-r, -r], [r, -r]]]
    for t, C in zip(SO2_ANGLES, [*written, None], strict=True):
        R = SE2.matrix(SE2.exp([0.0, 0.0, t]))[:2, :2]
        expected = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]]) if C is None else np.asarray(C)
        np.testing.assert_allclose(R, expected, rtol=0, atol=1e-15)
        assert abs(wrap(SE2.log(SE2.exp([0.0, 0.0, t]))[2] - t)) < 1e-15
        assert abs(np.linalg.det(R) - 1.0) < 1e-15
        np.testing.assert_allclose(R.T @ R, np.eye(2), rtol=0, atol=1e-15)


def test_so2_group_jacobians_are_one():
    """SO2Tests.cpp, testGroupJacobians: SO(2)'s vec2jac and vec2jacinv are 1: the (θ, θ) entry of our SE(2) J_r and
    J_r⁻¹ at any turn (with t = 0 the SE(2) Jacobians are block triangular), exactly."""
    for t in (0.0, 0.3, -2.0, PI):
        xi = np.array([0.0, 0.0, t])
        assert SE2.right_jacobian(xi)[2, 2] == 1.0
        assert SE2.right_jacobian_inverse(xi)[2, 2] == 1.0


def test_so2_rotation_constructor_angles():
    """SO2Tests.cpp, testSO2RotationAngleConstructor: a rotation from each of 0, ±π/4, ±π/2, ±π, ±2π holds
    vec2rot(angle), reads back the angle wrapped to [-π, π], and is a rotation. Ours stores the angle wrapped (from
    ``Exp``): its matrix is vec2rot's, to 1e-15; its stored angle the wrapped one, in (-π, π]."""
    for t in (0.0, PI / 4, PI / 2, PI, -PI / 4, -PI / 2, -PI, 2 * PI, -2 * PI):
        T = SE2.exp([0.0, 0.0, t])
        np.testing.assert_allclose(SE2.matrix(T)[:2, :2], [[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]], atol=1e-15)
        assert -PI < T[2] <= PI and abs(wrap(T[2] - t)) < 1e-15


# --- RotationTests.cpp: SO(3) ---------------------------------------------------------------------------------------


def rotation_vectors(rng):
    """RotationTests.cpp's cases: zero, ±π and π/2 about each axis, and 20 random vectors."""
    vs = [np.zeros(3)]
    for scale in (PI, -PI, 0.5 * PI):
        vs += [scale * e for e in np.eye(3)]
    return vs + list(rng.uniform(-1, 1, (20, 3)))


def test_rotation_to_and_from_the_algebra(rng):
    """RotationTests.cpp, "Test Rotation to/from SE(3) algebra.": a rotation made from φ holds vec2rot(φ), and its
    vec() is φ as an axis-angle (``nearEqualAxisAngle``: at π, φ or -φ). Ours: the matrix of Exp(φ) is ``expm`` of
    φ^ to 1e-14; Log(Exp(φ)) is φ to 1e-14 below π, at π φ or its antipode; the default rotation is I, exactly."""
    np.testing.assert_array_equal(SO3.matrix(SO3.identity()), np.eye(3))
    for phi in rotation_vectors(rng):
        R = SO3.matrix(SO3.exp(phi))
        np.testing.assert_allclose(R, scipy.linalg.expm(SO3.hat(phi)), rtol=0, atol=1e-14)
        back = SO3.log(SO3.exp(phi))
        if np.linalg.norm(phi) < PI - 1e-9:
            np.testing.assert_allclose(back, phi, rtol=0, atol=1e-14)
        else:
            assert min(np.max(np.abs(back - phi)), np.max(np.abs(back + phi))) < 1e-14, (phi, back)


def test_rotation_inverse_products_and_landmarks(rng):
    """RotationTests.cpp, "Test Rotation inverse.": at the cases above, C⁻¹ is the matrix inverse, C C⁻¹ = I, the
    product C_i C_{i+1} (``*=`` and ``*``) and C_i C_{i+1}⁻¹ (``/=`` and ``/``) are the matrix products, and C p is the
    matrix times a random landmark. Ours: ``inverse``, ``compose``, ``between`` of the swapped pair (C_i C_{i+1}⁻¹ =
    (C_{i+1} C_i⁻¹)⁻¹) against the matrices, to 1e-14."""
    vs = rotation_vectors(rng)
    Cs = [SO3.exp(v) for v in vs]
    Ms = [SO3.matrix(C) for C in Cs]
    for C, M in zip(Cs, Ms, strict=True):
        np.testing.assert_allclose(SO3.matrix(SO3.inverse(C)), np.linalg.inv(M), rtol=0, atol=1e-14)
        np.testing.assert_allclose(SO3.matrix(SO3.compose(C, SO3.inverse(C))), np.eye(3), rtol=0, atol=1e-14)
        p = rng.uniform(-1, 1, 3)
        np.testing.assert_allclose(SO3.matrix(C) @ p, M @ p, rtol=0, atol=1e-15)
    for i in range(len(Cs) - 1):
        np.testing.assert_allclose(SO3.matrix(SO3.compose(Cs[i], Cs[i + 1])), Ms[i] @ Ms[i + 1], atol=1e-14)
        divided = SO3.compose(Cs[i], SO3.inverse(Cs[i + 1]))
        np.testing.assert_allclose(SO3.matrix(divided), Ms[i] @ np.linalg.inv(Ms[i + 1]), rtol=0, atol=1e-14)


@pytest.mark.parametrize("scale", [1.0, 3.0])
def test_rotation_exponential_series(rng, scale):
    """RotationTests.cpp, "Rotation Constructors.", section "exponential map": Exp(φ) analytically equals the series
    Σ (φ^)ⁿ/n! to 15 terms (lgmath: 1e-6). Ours against that series summed here to 40 terms (converged: the terms at
    abs(φ) ≤ 3√3 fall below 1e-16), to 1e-13."""
    phi = scale * rng.uniform(-1, 1, 3)
    term, total = np.eye(3), np.eye(3)
    for n in range(1, 40):
        term = term @ SO3.hat(phi) / n
        total = total + term
    np.testing.assert_allclose(SO3.matrix(SO3.exp(phi)), total, rtol=0, atol=1e-13)
