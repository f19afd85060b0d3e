"""manif's own fixed-value cases of SE(2), SO(2), SO(3) and SE(3), ported as facts onto steam_ref's groups.

The source is manif (Deray & Solà, MIT licence), repository ``artivis/manif`` at commit de52f8b8; each test names
its file and its test. Only the inputs, the expected outputs and the property checked carry over; the code is ours.

**Conventions.** manif's and ours agree: tangent [ρ; φ] translation first (SE(2) [x, y, θ], SE(3) [v; ω]), right
Jacobians, ``rplus(τ)`` = X Exp(τ), ``lplus(τ)`` = Exp(τ) X, ``rminus(Y)`` of X = Log(Y⁻¹ X), ``lminus`` = Log(X Y⁻¹),
``between(Y)`` = X⁻¹ Y. What differs, converted in each test:

- an SE(2) angle: manif reads θ = atan2(sin, cos) of its stored unit complex, so the inverse of a turn by π reads -π;
  ours is stored in (-π, π], so it reads π (the same rotation: the test asserts the rotation and our range);
- ``act(p)`` = R p + t: steam_ref has the inverse map (a world point in the body frame,
  ``lie.points.to_body(T, p)`` = Rᵀ(p - t)), so T acts as ``to_body(T⁻¹, p)``: with T⁻¹ = (Rᵀ, -Rᵀt),
  (Rᵀ)ᵀ(p + Rᵀt) = R p + t;
- manif's SO(2) is the rotation of our SE(2) with zero translation: an SO(2) Jacobian (1 × 1) is the (θ, θ) entry
  of the SE(2) Jacobian at the same angles, since with t = 0 every SE(2) Jacobian is block triangular with that entry
  the SO(2) one (the rotation of a product never depends on a translation);
- manif's SO3(roll, pitch, yaw) is Rz(yaw) Ry(pitch) Rx(roll), built here from our SO(3) Exp of each axis.

Tolerances are manif's or tighter: its ``EXPECT_DOUBLE_EQ`` (4 units in the last place) is ``rtol=4ε``; where it
checks a zero with ``EXPECT_NEAR(0, ·, 1e-15)`` so do we. Properties manif checks on a random element run here on
seeded random elements.
"""

from __future__ import annotations

import numpy as np
import pytest

from steam_ref.lie import SE2, SE3, SO3
from steam_ref.lie.points import to_body

EPS = np.finfo(float).eps
PI, PI_2 = np.pi, np.pi / 2


def assert_double_eq(actual, expected):
    """gtest's EXPECT_DOUBLE_EQ: within 4 units in the last place (``rtol=4ε``)."""
    np.testing.assert_allclose(actual, expected, rtol=4 * EPS, atol=0)


def act(group, a, p):
    """manif's ``act``: R p + t, as our ``to_body`` of the inverse (module docstring)."""
    return to_body(group, group.inverse(a), np.asarray(p, dtype=float))[0]


def same_angle(a, b):
    """The signed difference of two angles, reduced to [-π, π]: zero when they are one rotation."""
    return float(np.angle(np.exp(1j * (a - b))))


# --- SE(2): manif test/se2/gtest_se2.cpp, test/se2/gtest_se2_tangent.cpp -------------------------------------------


def test_se2_inverse_of_identity_of_a_half_turn_and_of_a_generic_pose():
    """manif test/se2/gtest_se2.cpp, TEST_SE2_INVERSE: Identity⁻¹ = (0, 0, 0); (1, 1, π)⁻¹ = (1, 1, -π) in manif,
    ours (1, 1, π): θ in (-π, π] (module docstring); (0.7, 2.3, π/3)⁻¹ = (-2.341858428704209, -0.543782217350893,
    -1.04719755119660), x and y to 4 ulps, θ to 3e-15 (manif's bounds)."""
    np.testing.assert_array_equal(SE2.inverse(SE2.identity()), np.zeros(3))
    half = SE2.inverse([1.0, 1.0, PI])
    np.testing.assert_allclose(half[:2], [1.0, 1.0], rtol=4 * EPS, atol=4 * EPS)
    assert abs(same_angle(half[2], -PI)) <= 4 * EPS  # manif's -π, the same rotation
    assert -PI < half[2] <= PI  # ours in the stored range
    inv = SE2.inverse([0.7, 2.3, PI / 3])
    assert_double_eq(inv[:2], [-2.341858428704209, -0.543782217350893])
    assert abs(inv[2] - -1.04719755119660) <= 3e-15


@pytest.mark.parametrize("tau", [[0.0, 0.0, 0.0], [1.0, 1.0, PI_2]], ids=["zero", "quarter"])
def test_se2_rplus_and_lplus(tau):
    """manif test/se2/gtest_se2.cpp, TEST_SE2_RPLUS_ZERO, TEST_SE2_RPLUS, TEST_SE2_LPLUS_ZERO, TEST_SE2_LPLUS (and
    PLUS, OP_PLUS, OP_PLUS_EQ, which are rplus): (1, 1, π/2) ⊕ 0 = (1, 1, π/2) on either side; ⊕ (1, 1, π/2) turns to
    θ = π on either side (manif checks θ only; ``rplus`` is our ``compose_exp``, ``lplus`` Exp(τ) X)."""
    X = np.array([1.0, 1.0, PI_2])
    right, left = SE2.compose_exp(X, tau), SE2.compose(SE2.exp(tau), X)
    if not np.any(tau):
        assert_double_eq(right, X)
        assert_double_eq(left, X)
    else:
        assert_double_eq([right[2], left[2]], [PI, PI])


def test_se2_rminus_lminus_lift():
    """manif test/se2/gtest_se2.cpp, TEST_SE2_RMINUS_ZERO, TEST_SE2_RMINUS_I, TEST_SE2_RMINUS, TEST_SE2_LMINUS_IDENTITY,
    TEST_SE2_LMINUS, TEST_SE2_MINUS, TEST_SE2_LIFT: 0 ⊖ 0 = 0 (x, y to 1e-15); (1, 1, π) ⊖ (1, 1, π) has θ = 0;
    (1, 1, π) ⊖ (2, 2, π/2) has θ = π/2 on the right (Log(Y⁻¹X)) and on the left (Log(XY⁻¹)); Log(1, 1, π) has θ = π."""
    zero = SE2.log(SE2.between([0.0, 0.0, 0.0], [0.0, 0.0, 0.0]))
    np.testing.assert_allclose(zero, 0.0, rtol=0, atol=1e-15)
    X, Y = np.array([1.0, 1.0, PI]), np.array([2.0, 2.0, PI_2])
    assert SE2.log(SE2.between(X, X))[2] == 0.0
    assert_double_eq(SE2.log(SE2.between(Y, X))[2], PI_2)  # rminus
    assert_double_eq(SE2.log(SE2.compose(X, SE2.inverse(Y)))[2], PI_2)  # lminus
    assert_double_eq(SE2.log(X)[2], PI)


def test_se2_compose_and_between():
    """manif test/se2/gtest_se2.cpp, TEST_SE2_COMPOSE (and OP_COMPOSE, OP_COMPOSE_EQ), TEST_SE2_BETWEEN_I,
    TEST_SE2_BETWEEN: (1, 1, π/2)(2, 2, π/2) = (-1, 3, π); (1, 1, π)⁻¹(1, 1, π) = (0, 0, 0);
    (1, 1, π)⁻¹(2, 2, π/2) = (-1, -1, -π/2); each to 4 ulps."""
    assert_double_eq(SE2.compose([1.0, 1.0, PI_2], [2.0, 2.0, PI_2]), [-1.0, 3.0, PI])
    np.testing.assert_array_equal(SE2.between([1.0, 1.0, PI], [1.0, 1.0, PI]), np.zeros(3))
    assert_double_eq(SE2.between([1.0, 1.0, PI], [2.0, 2.0, PI_2]), [-1.0, -1.0, -PI_2])


@pytest.mark.parametrize(
    ("pose", "expected"),
    [([1.0, 1.0, PI_2], [0.0, 2.0]), ([1.0, 1.0, -PI_2], [2.0, 0.0]), ([0.0, 0.0, 0.0], [1.0, 1.0])],
    ids=["quarter", "minus-quarter", "identity"],
)
def test_se2_act(pose, expected):
    """manif test/se2/gtest_se2.cpp, TEST_SE2_ACT: (1, 1, π/2) moves (1, 1) to (0, 2), (1, 1, -π/2) to (2, 0),
    the identity leaves it; each to 1e-15 (manif's)."""
    np.testing.assert_allclose(act(SE2, pose, [1.0, 1.0]), expected, rtol=0, atol=1e-15)


def test_se2_exp_of_a_half_turn_tangent():
    """manif test/se2/gtest_se2_tangent.cpp, TEST_SE2_TANGENT_RETRACT and TEST_SE2_TANGENT_RETRACT_JAC: Exp(4, 2, π) has
    cos θ = cos π, sin θ = sin π and θ = π, each to 4 ulps (sin π to 4 ulps of sin(π) = 1.2e-16, so the stored angle
    must be π itself, not -π); its right Jacobian is 3 × 3 (manif checks its size only: ours is checked below against
    J_r(ξ) = Exp(ξ)⁻¹ ∂Exp/∂ξ by the matrix form)."""
    xi = np.array([4.0, 2.0, PI])
    T = SE2.exp(xi)
    assert T[2] == PI
    assert_double_eq([np.cos(T[2]), np.sin(T[2])], [np.cos(PI), np.sin(PI)])
    J = SE2.right_jacobian(xi)
    assert J.shape == (3, 3)
    h = 1e-6
    numeric = np.stack(
        [
            SE2.log(SE2.between(SE2.exp(xi - h * e), SE2.exp(xi + h * e))) / (2 * h)  # ≈ J_r e for small h
            for e in np.eye(3)
        ],
        axis=-1,
    )
    np.testing.assert_allclose(J, numeric, rtol=0, atol=1e-8)


# --- SO(2) as our SE(2) with zero translation: manif test/so2/gtest_so2.cpp ------------------------------------------


def rot(theta):
    return np.array([0.0, 0.0, theta])


def test_so2_values():
    """manif test/so2/gtest_so2.cpp, TEST_SO2_INVERSE, TEST_SO2_RPLUS, TEST_SO2_LPLUS, TEST_SO2_RMINUS, TEST_SO2_RMINUS2,
    TEST_SO2_LMINUS, TEST_SO2_LIFT, TEST_SO2_COMPOSE, TEST_SO2_BETWEEN: π⁻¹ reads -π in manif (the same rotation as our
    π); π/2 ⊕ π/2 = π on either side; π ⊖ π/2 = π/2 on either side; 3π/8 ⊖ 0 = 3π/8; Log(π) = π; π/2 · π/2 = π;
    π⁻¹ · π/2 = -π/2; each to 4 ulps."""
    assert abs(same_angle(SE2.inverse(rot(PI))[2], -PI)) <= 4 * EPS
    values = [
        SE2.compose_exp(rot(PI_2), rot(PI_2))[2],
        SE2.compose(SE2.exp(rot(PI_2)), rot(PI_2))[2],
        SE2.log(SE2.between(rot(PI_2), rot(PI)))[2],
        SE2.log(SE2.compose(rot(PI), SE2.inverse(rot(PI_2))))[2],
        SE2.log(SE2.between(rot(0.0), rot(3 * PI / 8)))[2],
        SE2.log(rot(PI))[2],
        SE2.compose(rot(PI_2), rot(PI_2))[2],
        SE2.between(rot(PI), rot(PI_2))[2],
    ]
    expected = [PI, PI, PI_2, PI_2, 3 * PI / 8, PI, PI, -PI_2]
    assert_double_eq(values, expected)


def test_so2_jacobians_are_the_angle_entries_of_se2s():
    """manif test/so2/gtest_so2.cpp, TEST_SO2_INVERSE_JAC (-1 at 0 and at π), TEST_SO2_LIFT_JAC (1 at π),
    TEST_SO2_COMPOSE_JAC (1 and 1 at π/2, π/2), TEST_SO2_RPLUS_JAC, TEST_SO2_LPLUS_JAC, TEST_SO2_PLUS_JAC (1 and 1),
    TEST_SO2_RMINUS_JAC, TEST_SO2_LMINUS_JAC, TEST_SO2_MINUS_JAC (1 and -1 at π, π/2), TEST_SO2_BETWEEN_JAC (-1 and 1
    at π, π/2): each the (θ, θ) entry of our SE(2) Jacobian at zero translation (module docstring), to 4 ulps.
    rplus's Jacobians are Ad(Exp(τ))⁻¹ (for X) and J_r(τ) (for τ); lplus's J_l(τ) = J_r(-τ) (for τ) and I (for X);
    rminus X ⊖ Y = Log(Y⁻¹X) is our log_between(Y, X), whose Jacobians are for Y then X."""
    _, J_inv0 = SE2.inverse(rot(0.0), jacobians=True)
    _, J_invpi = SE2.inverse(rot(PI), jacobians=True)
    _, Ja, Jb = SE2.compose(rot(PI_2), rot(PI_2), jacobians=True)
    tau = rot(PI_2)
    J_rplus_m = SE2.adjoint(SE2.inverse(SE2.exp(tau)))
    J_rplus_t = SE2.right_jacobian(tau)
    J_lplus_t = SE2.right_jacobian(-tau)
    log_pi = SE2.log(rot(PI))
    J_lift = SE2.right_jacobian_inverse(log_pi)
    _, _, J_rminus_b, J_rminus_a, _ = SE2.log_between(rot(PI_2), rot(PI), np.zeros(3), jacobians=True)
    _, J_between_a, J_between_b = SE2.between(rot(PI), rot(PI_2), jacobians=True)
    ours = [J_inv0, J_invpi, J_lift, Ja, Jb, J_rplus_m, J_rplus_t, J_lplus_t, J_rminus_a, J_rminus_b, J_between_a]
    ours.append(J_between_b)
    manif = [-1.0, -1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, -1.0, -1.0, 1.0]
    assert_double_eq([J[2, 2] for J in ours], manif)


@pytest.mark.parametrize(
    ("theta", "expected"), [(PI_2, [-1.0, 1.0]), (-PI_2, [1.0, -1.0]), (0.0, [1.0, 1.0])], ids=["+", "-", "0"]
)
def test_so2_act(theta, expected):
    """manif test/so2/gtest_so2.cpp, TEST_SO2_ACT: a turn by π/2 moves (1, 1) to (-1, 1), by -π/2 to (1, -1), by 0
    leaves it; to 1e-15."""
    np.testing.assert_allclose(act(SE2, rot(theta), [1.0, 1.0]), expected, rtol=0, atol=1e-15)


# --- SO(3): manif test/so3/gtest_so3.cpp -------------------------------------------------------------------------------


def rpy(roll, pitch, yaw):
    """manif's SO3(roll, pitch, yaw) = Rz(yaw) Ry(pitch) Rx(roll), as our stored rotation (9 numbers)."""
    return SO3.compose(SO3.compose(SO3.exp([0.0, 0.0, yaw]), SO3.exp([0.0, pitch, 0.0])), SO3.exp([roll, 0.0, 0.0]))


def test_so3_hat():
    """manif test/so3/gtest_so3.cpp, TEST_SO3_TANGENT_SKEW: hat(1, 2, 3) = [[0, -3, 2], [3, 0, -1], [-2, 1, 0]],
    exactly."""
    np.testing.assert_array_equal(SO3.hat([1.0, 2.0, 3.0]), [[0.0, -3.0, 2.0], [3.0, 0.0, -1.0], [-2.0, 1.0, 0.0]])


@pytest.mark.parametrize(
    ("angles", "expected"),
    [
        ((0.0, 0.0, 0.0), [1.0, 1.0, 1.0]),
        ((PI, PI_2, PI / 4), [0.0, -1.414213562373, -1.0]),
        ((PI / 4, -PI_2, -PI), [1.414213562373, 0.0, 1.0]),
    ],
    ids=["identity", "a", "b"],
)
def test_so3_act(angles, expected):
    """manif test/so3/gtest_so3.cpp, TEST_SO3_ACT: SO3(roll, pitch, yaw) moves (1, 1, 1) to the given point; the
    entries ±√2 to 1e-12 (manif's, its figures printed to 12 places), the rest to 1e-15."""
    R = SO3.matrix(rpy(*angles))
    moved = R @ np.ones(3)
    atol = np.where(np.abs(np.abs(expected) - np.sqrt(2)) < 1e-9, 1e-12, 1e-15)
    assert np.all(np.abs(moved - expected) <= atol), moved


def test_so3_inverse_jacobian_is_minus_the_rotation(rng):
    """manif test/so3/gtest_so3.cpp, TEST_SO3_INVERSE_JAC: J of X⁻¹ is -I at the identity and -R at a random X,
    each entry exactly (manif's ``EXPECT_EQ``); also TEST_SO3_INVERSE: X⁻¹ is the conjugate, here the transpose."""
    _, J = SO3.inverse(SO3.identity(), jacobians=True)
    np.testing.assert_array_equal(J, -np.eye(3))
    X = SO3.exp(rng.uniform(-1, 1, 3) * 2)
    inv, J = SO3.inverse(X, jacobians=True)
    np.testing.assert_array_equal(J, -SO3.matrix(X))
    np.testing.assert_array_equal(SO3.matrix(inv), SO3.matrix(X).T)


def test_so3_left_and_right_jacobians(rng):
    """manif test/so3/gtest_so3.cpp, TEST_SO3_RIGHT_LEFT_JAC_ADJ (J_l(τ) = Exp(τ) J_r(τ)) and TEST_SO3_RIGHT_LEFT_JAC
    (J_l = J_rᵀ, J_r = J_lᵀ), at 0 and at a random τ, to manif's EXPECT_EIGEN_NEAR (1e-8) or tighter. Ours has the right
    Jacobian alone; J_l(τ) = J_r(-τ) (Exp(τ + dτ) = Exp(J_l dτ) Exp(τ) = Exp(τ) Exp(Ad(Exp(-τ)) J_l dτ))."""
    for tau in (np.zeros(3), rng.uniform(-1, 1, 3)):
        Jr, Jl = SO3.right_jacobian(tau), SO3.right_jacobian(-tau)
        np.testing.assert_allclose(Jl, SO3.matrix(SO3.exp(tau)) @ Jr, rtol=0, atol=1e-14)
        np.testing.assert_allclose(Jl, Jr.T, rtol=0, atol=1e-15)


def test_so3_exp_log_rplus_rminus_properties(rng):
    """manif test/so3/gtest_so3.cpp, TEST_SO3_RETRACT (Exp(0) = I; Exp(-τ) = Exp(τ)⁻¹), TEST_SO3_LIFT (Log(I) = 0;
    Log(X⁻¹) = -Log(X)), TEST_SO3_RPLUS / TEST_SO3_LPLUS (X ⊕ 0 = X on either side), TEST_SO3_RMINUS /
    TEST_SO3_LMINUS (X ⊖ X = 0, to 1e-15), at seeded random X and τ, to manif's 4 ulps or 1e-15 for a zero."""
    np.testing.assert_array_equal(SO3.exp(np.zeros(3)), np.eye(3).ravel())
    np.testing.assert_array_equal(SO3.log(SO3.identity()), np.zeros(3))
    tau = rng.uniform(-1, 1, 3)
    np.testing.assert_allclose(SO3.exp(-tau), SO3.inverse(SO3.exp(tau)), rtol=0, atol=4 * EPS)
    X = SO3.exp(rng.uniform(-1, 1, 3))
    np.testing.assert_allclose(SO3.log(SO3.inverse(X)), -SO3.log(X), rtol=4 * EPS, atol=4 * EPS)
    assert_double_eq(SO3.compose_exp(X, np.zeros(3)), X)
    assert_double_eq(SO3.compose(SO3.exp(np.zeros(3)), X), X)
    np.testing.assert_allclose(SO3.log(SO3.between(X, X)), 0.0, rtol=0, atol=1e-15)


# --- SE(3): manif test/se3/gtest_se3.cpp --------------------------------------------------------------------------------


def se3(x, y, z, roll, pitch, yaw):
    """manif's SE3(x, y, z, roll, pitch, yaw): translation (x, y, z), rotation SO3(roll, pitch, yaw); ours [t; R]."""
    return np.concatenate([[x, y, z], rpy(roll, pitch, yaw)])


@pytest.mark.parametrize(
    ("pose", "expected"),
    [
        ((0.0, 0.0, 0.0, 0.0, 0.0, 0.0), [1.0, 1.0, 1.0]),
        ((1.0, 1.0, 1.0, PI, PI_2, PI / 4), [1.0, -0.414213562373, 0.0]),
        ((-1.0, -1.0, -1.0, PI / 4, -PI_2, -PI), [0.414213562373, -1.0, 0.0]),
    ],
    ids=["identity", "a", "b"],
)
def test_se3_act(pose, expected):
    """manif test/se3/gtest_se3.cpp, TEST_SE3_ACT: SE3(x, y, z, roll, pitch, yaw) moves (1, 1, 1) to the given point;
    the entries ±(√2 - 1) to 1e-12 (manif's), the rest to 1e-15."""
    moved = act(SE3, se3(*pose), np.ones(3))
    atol = np.where(np.abs(np.abs(expected) - (np.sqrt(2) - 1)) < 1e-9, 1e-12, 1e-15)
    assert np.all(np.abs(moved - expected) <= atol), moved


def test_se3_matrix_of_a_translation():
    """manif test/se3/gtest_se3.cpp, TEST_SE3_TRANSFORM and TEST_SE3_ISOMETRY: the pose translated by (1, 2, 3), not
    turned, has the matrix [[I, (1, 2, 3)], [0, 1]], each entry exactly."""
    T = np.concatenate([[1.0, 2.0, 3.0], np.eye(3).ravel()])
    expected = np.eye(4)
    expected[:3, 3] = [1.0, 2.0, 3.0]
    np.testing.assert_array_equal(SE3.matrix(T), expected)


def test_se3_tangent_is_linear_then_angular():
    """manif test/se3/gtest_se3.cpp, TEST_SE3TAN_LINANGVEL: the tangent (1, 2, 3, 4, 5, 6) has linear part (1, 2, 3),
    angular (4, 5, 6): hat puts the first three in the translation column and the last three in the skew block."""
    X = SE3.hat(np.arange(1.0, 7.0))
    np.testing.assert_array_equal(X[:3, 3], [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(SO3.vee(X[:3, :3]), [4.0, 5.0, 6.0])


def test_se3_identity_inverse_compose(rng):
    """manif test/se3/gtest_se3.cpp, TEST_SE3_INVERSE (Identity⁻¹ = Identity, exactly; X⁻¹ is the matrix inverse;
    X⁻¹X = XX⁻¹ = Identity, at a random X) and TEST_SE3_COMPOSE (Identity · Identity = Identity, exactly); random
    entries to 1e-14 (manif's EXPECT_EIGEN_NEAR is 1e-8)."""
    identity = SE3.identity()
    np.testing.assert_array_equal(SE3.inverse(identity), identity)
    np.testing.assert_array_equal(SE3.compose(identity, identity), identity)
    X = SE3.exp(rng.uniform(-1, 1, 6) * 2)
    np.testing.assert_allclose(SE3.matrix(SE3.inverse(X)), np.linalg.inv(SE3.matrix(X)), rtol=0, atol=1e-14)
    for product in (SE3.compose(SE3.inverse(X), X), SE3.compose(X, SE3.inverse(X))):
        np.testing.assert_allclose(SE3.matrix(product), np.eye(4), rtol=0, atol=1e-14)
