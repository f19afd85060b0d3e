"""lgmath's fixed-value cases of SO(3) and SE(3), ported as facts onto steam_ref's SO3 and SE3.

The source is lgmath (Anderson, Barfoot et al., BSD licence), repository ``utiasASRL/lgmath`` at commit c1710ef9; each
test names its file and its test. Only the inputs, the expected outputs and the property checked carry over.

**Conventions, and the conversion.** lgmath and steam_ref share the tangent order ξ = [ρ; φ] (translation first),
Exp(ξ) = expm(ξ^) with ξ^ = [[φ^, ρ], [0, 0]], and Ad(T) = [[C, r^C], [0, C]] for T = [[C, r], [0, 1]]; its
``curlyhat`` ξ⋏ = [[φ^, ρ^], [0, φ^]] is our ``ad(ξ)``. They differ in the Jacobian: lgmath perturbs on the left,
T ← Exp(δ) T, so its ``vec2jac(ξ)`` is the left Jacobian J_l(ξ) = Σₙ (ξ⋏)ⁿ/(n+1)!, defined by
Exp(ξ + dξ) = Exp(J_l(ξ) dξ) Exp(ξ). Ours is the right one, Exp(ξ + dξ) = Exp(ξ) Exp(J_r(ξ) dξ), J_r(ξ) = Σₙ (-ξ⋏)ⁿ/(n+1)!,
so J_l(ξ) = J_r(-ξ) term by term (the same for SO(3) with φ^ in place of ξ⋏), and ``vec2jacinv(ξ)`` = J_r(-ξ)⁻¹, our
``right_jacobian_inverse(-ξ)``. Every test below reads lgmath's Jacobian as ours at -ξ.

**Oracles.** lgmath checks its closed forms against its own series summed to 20 terms, at 1e-6. Ours are independent
and tighter: mpmath at 40 digits (``mp.expm`` of the hat, Σ (±ad)ⁿ/(n+1)! summed to 1e-45, its inverse by ``mp.inverse``)
at 1e-13 of the largest entry; an exact matrix (a turn by π/2 or π about an axis) at 1e-15.

**Log at ±π.** lgmath compares a logarithm "as an axis-angle" (``nearEqualAxisAngle``, ``nearEqualLieAlg``): a turn
by π about u is the turn by π about -u, and Log's angle is in [0, π]. Ours is too: :func:`same_log` asserts Log(Exp(v))
is v itself below π and v or its antipode at π (the translation part follows from the rotation: V(φ)⁻¹ t).

Random vectors (lgmath's ``Random()``, uniform in [-1, 1]) are drawn from the suite's seeded generator.
"""

from __future__ import annotations

import numpy as np
import pytest
from requirements import optional_import

from steam_ref.lie import SE3, SO3
from steam_ref.lie.points import to_body

mp = optional_import("mpmath", "test")

PI = np.pi
REL = 1e-13  # entry-wise, relative to the largest entry of the matrix, against 40 digits


def special_rotation_vectors():
    """lgmath's special cases: zero, ±π and π/2 about each axis."""
    vs = [np.zeros(3)]
    for scale in (PI, -PI, 0.5 * PI):
        vs += [scale * e for e in np.eye(3)]
    return vs


def special_twists():
    """lgmath's special SE(3) cases: zero, a unit translation along each axis, ±π and π/2 about each axis."""
    vs = [np.zeros(6), *np.eye(6)[:3]]
    for scale in (PI, -PI, 0.5 * PI):
        vs += [scale * e for e in np.eye(6)[3:]]
    return vs


# --- 40-digit oracles --------------------------------------------------------------------------------------------------


def mp_matrix(a):
    return mp.matrix([[mp.mpf(float(x)) for x in row] for row in np.atleast_2d(a)])


def to_float(M):
    return np.array([[float(M[i, j]) for j in range(M.cols)] for i in range(M.rows)])


def mp_series(X, sign):
    """Σₙ (sign X)ⁿ/(n+1)! at 40 digits, summed until a term is below 1e-45."""
    total, term, n = mp.eye(X.rows), mp.eye(X.rows), 0
    while True:
        n += 1
        term = term * (sign * X) / (n + 1)
        total += term
        if mp.mnorm(term, 1) < mp.mpf("1e-45"):
            return total


def ad_matrix(xi):
    """lgmath's curlyhat ξ⋏ = [[φ^, ρ^], [0, φ^]], written out (the oracle does not call our ``ad``)."""
    rho, phi = SO3.hat(xi[:3]), SO3.hat(xi[3:])
    return np.block([[phi, rho], [np.zeros((3, 3)), phi]])


def assert_close_to(ours, oracle):
    np.testing.assert_allclose(ours, oracle, rtol=0, atol=REL * max(1.0, float(np.max(np.abs(oracle)))))


def same_log(ours, v):
    """Log(Exp(v)) read as an axis-angle (module docstring): v below π; v or its antipode at a turn by π."""
    theta = np.linalg.norm(v[-3:])
    if abs(theta - PI) > 1e-12:
        return np.allclose(ours, v, rtol=0, atol=1e-13)
    return np.allclose(ours[-3:], v[-3:], rtol=0, atol=1e-13) or np.allclose(ours[-3:], -v[-3:], rtol=0, atol=1e-13)


# --- SO(3): lgmath tests/SO3Tests.cpp -------------------------------------------------------------------------------------


def test_so3_hat(rng):
    """lgmath tests/SO3Tests.cpp, test3x3HatFunction: hat(v) = [[0, -v₃, v₂], [v₃, 0, -v₁], [-v₂, v₁, 0]] for v = 0,
    (1, 2, 3), (-1, -2, -3) and a random v, and hat(v)ᵀ = -hat(v); exactly (lgmath: 1e-6)."""
    for v in (np.zeros(3), np.array([1.0, 2.0, 3.0]), np.array([-1.0, -2.0, -3.0]), rng.uniform(-1, 1, 3)):
        H = SO3.hat(v)
        np.testing.assert_array_equal(H, [[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
        np.testing.assert_array_equal(H.T, -H)


@pytest.mark.parametrize("v", special_rotation_vectors(), ids=lambda v: str(np.round(v, 2)))
def test_so3_exp_and_log_of_the_special_cases(v):
    """lgmath tests/SO3Tests.cpp, testVec2RotSpecialCase: vec2rot of zero is I; of ±π about x, y, z is diag(1, -1, -1),
    diag(-1, 1, -1), diag(-1, -1, 1); of π/2 about x [[1, 0, 0], [0, 0, -1], [0, 1, 0]], about y [[0, 0, 1], [0, 1, 0],
    [-1, 0, 0]], about z [[0, -1, 0], [1, 0, 0], [0, 0, 1]] (lgmath's figures, each entry to 1e-15 here, 1e-6 there);
    rot2vec of each matrix gives v back as an axis-angle (module docstring)."""
    axis = int(np.argmax(np.abs(v)))
    angle = float(v[axis])
    expected = np.eye(3)
    if abs(angle) == PI:
        expected = -np.eye(3)
        expected[axis, axis] = 1.0
    elif angle:
        i, j = [k for k in range(3) if k != axis]
        sign = 1.0 if axis != 1 else -1.0  # about y the plane is (z, x): R[0, 2] = +1
        expected[i, i] = expected[j, j] = 0.0
        expected[i, j], expected[j, i] = -sign, sign
    R = SO3.matrix(SO3.exp(v))
    np.testing.assert_allclose(R, expected, rtol=0, atol=1e-15)
    assert same_log(SO3.log(expected.ravel()), v)


def test_so3_exp_against_the_series_and_log_inverts_it_with_the_near_pi_edge_case(rng):
    """lgmath tests/SO3Tests.cpp, CompareAnalyticalAndNumericVec2Rot: at the special cases, lgmath's edge case of
    rot2vec v = (3.141582282177315, 0.008064303485426312, 0) (an angle 2.1e-8 below π) and 50 random v: vec2rot(v)
    equals the exponential series (here ``mp.expm`` at 40 digits, to 1e-13), RᵀR = I (to 4e-15, lgmath's Rᵀ = R⁻¹ at
    1e-6), and rot2vec(vec2rot(v)) = v as an axis-angle, to 1e-13 (lgmath: 1e-6), the edge case too: near π the axis
    comes from the symmetric part of R and the angle from atan2, both well conditioned there."""
    edge = np.array([3.141582282177315, 0.008064303485426312, 0.0])
    vs = special_rotation_vectors() + [edge] + list(rng.uniform(-1, 1, (50, 3)))
    for v in vs:
        R = SO3.matrix(SO3.exp(v))
        assert_close_to(R, to_float(mp.expm(mp_matrix(SO3.hat(v)))))
        np.testing.assert_allclose(R.T @ R, np.eye(3), rtol=0, atol=4e-15)
        assert same_log(SO3.log(R.ravel()), v), (v, SO3.log(R.ravel()))


def test_so3_left_jacobian_its_inverse_and_exp_from_it(rng):
    """lgmath tests/SO3Tests.cpp, CompareAnalyticalJacobiansInversesAndNumericCounterparts: at the special cases and
    50 random φ, vec2jac(φ)⁻¹ = vec2jacinv(φ); vec2jac(φ) equals Σ (φ^)ⁿ/(n+1)!; vec2jacinv(φ) equals its series; and
    vec2rot(φ) = I + φ^ vec2jac(φ). Converted (module docstring): vec2jac(φ) = J_r(-φ), vec2jacinv(φ) = J_r(-φ)⁻¹;
    the series at 40 digits, to 1e-13 (lgmath: 1e-6)."""
    for phi in special_rotation_vectors() + list(rng.uniform(-1, 1, (50, 3))):
        Jl, Jl_inv = SO3.right_jacobian(-phi), SO3.right_jacobian_inverse(-phi)
        oracle = mp_series(mp_matrix(SO3.hat(phi)), +1)
        assert_close_to(Jl, to_float(oracle))
        assert_close_to(Jl_inv, to_float(mp.inverse(oracle)))
        assert_close_to(Jl @ Jl_inv, np.eye(3))
        assert_close_to(SO3.matrix(SO3.exp(phi)), np.eye(3) + SO3.hat(phi) @ Jl)


# --- SE(3): lgmath tests/SE3Tests.cpp, tests/TransformTests.cpp -------------------------------------------------------------


def test_se3_hat_and_curlyhat(rng):
    """lgmath tests/SE3Tests.cpp, Test4x4HatFunction and TestCurlyHatFunction: for 20 random ξ = [ρ; φ], ξ^ =
    [[φ^, ρ], [0, 0]] and ξ⋏ = [[φ^, ρ^], [0, φ^]] entry by entry, exactly (lgmath: 1e-6); ξ⋏ is our ``ad(ξ)``."""
    for xi in rng.uniform(-1, 1, (20, 6)):
        rho, phi = xi[:3], xi[3:]
        expected = np.zeros((4, 4))
        expected[:3, :3], expected[:3, 3] = SO3.hat(phi), rho
        np.testing.assert_array_equal(SE3.hat(xi), expected)
        np.testing.assert_allclose(SE3.ad(xi), ad_matrix(xi), rtol=0, atol=1e-15)


def test_se3_point_jacobian_is_minus_the_odot_of_the_body_point(rng):
    """lgmath tests/SE3Tests.cpp, TestPointTo4x6MatrixFunction: for p = [ε; η] (homogeneous), p^⊙ =
    [[η I, -ε^], [0, 0]] (``point2fs``), so ξ^ p = p^⊙ ξ. Ours has it as the Jacobian of a world point p seen from the
    body of T, q = Rᵀ(p - t): (T Exp δ)⁻¹ p ≈ (I - δ^) [q; 1], so ∂q/∂δ = -(top three rows of [q; 1]^⊙) =
    -[I, -q^] (η = 1, the only scale our points have); at 20 random poses and points, to 1e-15 (lgmath: 1e-6)."""
    for xi, p in zip(rng.uniform(-1, 1, (20, 6)), rng.uniform(-1, 1, (20, 3)), strict=True):
        q, dq_dpose, _ = to_body(SE3, SE3.exp(xi), p)
        odot = np.hstack([np.eye(3), -SO3.hat(q)])
        np.testing.assert_allclose(dq_dpose, -odot, rtol=0, atol=1e-15)
        np.testing.assert_allclose(SE3.hat(xi) @ np.append(q, 1.0), np.vstack([odot, np.zeros((1, 6))]) @ xi)


def test_se3_exp_against_the_series_and_log_inverts_it(rng):
    """lgmath tests/SE3Tests.cpp, CompareAnalyticalAndNumericVec2Tran, and tests/TransformTests.cpp,
    TransformationToFromSE3Algebra: at the 13 special twists and 20 random ones, vec2tran(ξ) equals the exponential
    series (here ``mp.expm`` of ξ^ at 40 digits, to 1e-13) and tran2vec(vec2tran(ξ)) = ξ as an axis-angle (module
    docstring; lgmath: 1e-6)."""
    for xi in special_twists() + list(rng.uniform(-1, 1, (20, 6))):
        T = SE3.exp(xi)
        assert_close_to(SE3.matrix(T), to_float(mp.expm(mp_matrix(SE3.hat(xi)))))
        assert same_log(SE3.log(T), xi), (xi, SE3.log(T))


def test_se3_left_jacobian_and_its_inverse(rng):
    """lgmath tests/SE3Tests.cpp, CompareAnalyticalJacobInvAndNumericCounterpartsInSE3: at the 13 special twists and 20
    random ones, vec2jac(ξ)⁻¹ = vec2jacinv(ξ), and vec2jac(ξ) = Σ (ξ⋏)ⁿ/(n+1)!, vec2jacinv(ξ) its inverse. Converted:
    vec2jac(ξ) = J_r(-ξ), vec2jacinv(ξ) = J_r(-ξ)⁻¹ (module docstring); against 40 digits, to 1e-13 (lgmath: 1e-6)."""
    for xi in special_twists() + list(rng.uniform(-1, 1, (20, 6))):
        Jl, Jl_inv = SE3.right_jacobian(-xi), SE3.right_jacobian_inverse(-xi)
        oracle = mp_series(mp_matrix(ad_matrix(xi)), +1)
        assert_close_to(Jl, to_float(oracle))
        assert_close_to(Jl_inv, to_float(mp.inverse(oracle)))


def test_se3_adjoint_of_exp_is_identity_plus_curlyhat_times_left_jacobian(rng):
    """lgmath tests/SE3Tests.cpp, TestIdentityAdTvEqualIPlusCurlyHatvTimesJv: Ad(Exp(ξ)) = I + ξ⋏ J_l(ξ) at the 13
    special twists and 20 random ones. Converted: J_l(ξ) = J_r(-ξ); here to 1e-13 of the largest entry (lgmath: 1e-6).
    The oracle of Ad is the matrix form: Ad(T) ξ = vee(T ξ^ T⁻¹), column by column."""
    for xi in special_twists() + list(rng.uniform(-1, 1, (20, 6))):
        T = SE3.exp(xi)
        M = SE3.matrix(T)
        Ad = np.stack([SE3.vee(M @ SE3.hat(e) @ np.linalg.inv(M)) for e in np.eye(6)], axis=-1)
        assert_close_to(SE3.adjoint(T), Ad)
        assert_close_to(SE3.adjoint(T), np.eye(6) + SE3.ad(xi) @ SE3.right_jacobian(-xi))


def test_se3_inverse_adjoint_and_products(rng):
    """lgmath tests/TransformTests.cpp, TransformationInverse: at the 13 special twists and 20 random ones, the inverse
    is the matrix inverse, T T⁻¹ = I, the adjoint is tranAd(matrix) = [[C, r^C], [0, C]], and the product (and the
    product with an inverse) of consecutive poses is the matrix product; to 1e-14 (lgmath: 1e-6)."""
    poses = [SE3.exp(xi) for xi in special_twists() + list(rng.uniform(-1, 1, (20, 6)))]
    for a, b in zip(poses, poses[1:] + poses[:1], strict=True):
        Ma, Mb = SE3.matrix(a), SE3.matrix(b)
        np.testing.assert_allclose(SE3.matrix(SE3.inverse(a)), np.linalg.inv(Ma), rtol=0, atol=1e-14)
        np.testing.assert_allclose(Ma @ SE3.matrix(SE3.inverse(a)), np.eye(4), rtol=0, atol=1e-14)
        C, r = Ma[:3, :3], Ma[:3, 3]
        tran_ad = np.block([[C, SO3.hat(r) @ C], [np.zeros((3, 3)), C]])
        np.testing.assert_allclose(SE3.adjoint(a), tran_ad, rtol=0, atol=1e-15)
        np.testing.assert_allclose(SE3.matrix(SE3.compose(a, b)), Ma @ Mb, rtol=0, atol=1e-14)
        np.testing.assert_allclose(
            SE3.matrix(SE3.compose(a, SE3.inverse(b))), Ma @ np.linalg.inv(Mb), rtol=0, atol=1e-14
        )
