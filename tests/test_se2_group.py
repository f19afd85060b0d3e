"""SE(2) itself (steam_ref.lie.SE2) and the SE(2) state kind, against three oracles: a 50-digit
evaluation of the closed forms (mpmath), high-order finite differences, and GTSAM 4.3's ``Pose2``."""

from __future__ import annotations

import numpy as np
import pytest
from requirements import optional_import

from steam_ref.errors import ShapeError, SteamError
from steam_ref.lie import SE2, SE2_STATE, world_position_covariance
from steam_ref.lie.se2 import wrap
from steam_ref.lie.se2_series import _ROOT_HI, _ROOT_LO, _ROOT_NEAR, SERIES_BELOW, Coefficients
from steam_ref.manifold import VECTOR, Manifold

mp = optional_import("mpmath", "test")
mp.mp.dps = 50

EDGE = SERIES_BELOW
# both sides of the series switch, tiny angles, and the ends of (-π, π]
ANGLES = [0.0, 1e-300, 1e-12, 1e-6, 0.05, 0.5, np.nextafter(EDGE, 0), EDGE, np.nextafter(EDGE, 2), 1.7, 2.9,
          np.nextafter(np.pi, 0), np.pi]  # fmt: skip
ANGLES += [-a for a in ANGLES if a > 0]


def _mp_coefficients(phi: float) -> dict[str, float]:
    """The closed forms of every coefficient and its derivative, with twice the digits 1 - cos φ loses at φ
    (φ = 0: their limits, taken at φ = 1e-30, within 1e-59 of them)."""
    phi = phi if phi != 0 else 1e-30
    with mp.workdps(100 + 2 * max(0, int(-np.log10(abs(phi))))):
        return _mp_forms(mp.mpf(phi))


def _mp_forms(f):
    forms = {
        "A": lambda p: mp.sin(p) / p,
        "B": lambda p: (1 - mp.cos(p)) / p,
        "C": lambda p: (p - mp.sin(p)) / p**2,
        "D": lambda p: (1 - mp.cos(p)) / p**2,
        "alpha": lambda p: (p / 2) * mp.cot(p / 2),
        "gamma": lambda p: (1 - (p / 2) * mp.cot(p / 2)) / p,
    }
    out = {name: float(g(f)) for name, g in forms.items()}
    for name in ("A", "B", "C", "D", "alpha", "gamma"):
        out[name + "1"] = float(mp.diff(forms[name], f, h=abs(f) * mp.mpf("1e-25")))
    return out


@pytest.mark.parametrize("phi", ANGLES)
def test_every_coefficient_and_its_derivative_is_exact_on_both_sides_of_the_series_switch(phi):
    ours = Coefficients(phi)
    want = _mp_coefficients(phi)
    for name, value in want.items():
        got = float(ours[name])
        # relative in the series' range; the closed forms above it carry an absolute rounding of a few ulp of 1
        tol = 2e-15 * abs(value) + (4e-16 if abs(phi) >= EDGE else 1e-29 if phi == 0 else 0.0)
        assert abs(got - value) <= tol, (name, phi, got, value)


ROOT = 2 * _ROOT_HI  # B' = 0 here: tan(φ/2) = φ, where B = (1 - cos φ)/φ peaks
NEAR_ZEROS = [ROOT, np.nextafter(ROOT, 0), np.nextafter(ROOT, 4), -ROOT, np.pi, np.nextafter(np.pi, 0)]
NEAR_ZEROS += [
    ROOT + s * d for s in (1, -1) for d in (1e-12, 1e-9, 1e-6, 1e-3, 2 * _ROOT_NEAR * 0.99, 2 * _ROOT_NEAR * 1.01)
]
NEAR_ZEROS += [np.pi - d for d in (1e-12, 1e-8, 1e-4, 1e-2)]


def test_the_root_of_b_prime_is_known_to_32_digits():
    with mp.workdps(60):
        root = mp.findroot(lambda h: mp.tan(h) - 2 * h, mp.mpf("1.1655611852"))
        assert abs(mp.mpf(_ROOT_HI) + mp.mpf(_ROOT_LO) - root) < mp.mpf("1e-32")


@pytest.mark.parametrize("phi", NEAR_ZEROS)
def test_b_prime_and_c_prime_keep_their_relative_precision_where_they_vanish(phi):
    """B' vanishes at φ ≈ ±2.331 and C' at ±π: a difference of two O(1) terms there would be all rounding."""
    with mp.workdps(60):
        p = mp.mpf(phi)
        want = {"B1": (p * mp.sin(p) - 1 + mp.cos(p)) / p**2, "C1": (2 * mp.sin(p) - p - p * mp.cos(p)) / p**3}
        ours = Coefficients(phi)
        for name, value in want.items():
            assert abs(mp.mpf(float(ours[name])) - value) <= 1e-13 * abs(value), (name, phi)


def _mp_exp(xi):
    r1, r2, p = (mp.mpf(v) for v in xi)
    if p == 0:
        return [r1, r2, p]
    a, b = mp.sin(p) / p, (1 - mp.cos(p)) / p
    return [a * r1 - b * r2, b * r1 + a * r2, p]


@pytest.mark.parametrize("phi", ANGLES)
def test_exp_and_log_match_50_digits_and_invert_each_other(phi):
    xi = np.array([0.7, -1.3, phi])
    T = SE2.exp(xi)
    want = [float(v) for v in _mp_exp(xi)]
    want[2] = phi if phi != -np.pi else np.pi  # Exp's heading in (-π, π]
    np.testing.assert_allclose(T, want, rtol=4e-16, atol=4e-16)
    if phi == -np.pi:  # Log answers with φ = π, another ρ for the same pose
        np.testing.assert_allclose(SE2.exp(SE2.log(T)), T, rtol=1e-15, atol=4e-16)
        assert SE2.log(T)[2] == np.pi
    else:
        np.testing.assert_allclose(SE2.log(T), xi, rtol=1e-15, atol=2e-16)


def test_log_returns_the_angle_in_minus_pi_to_pi_inclusive_of_pi():
    assert SE2.log(np.array([0.0, 0.0, -np.pi]))[2] == np.pi
    assert SE2.log(np.array([0.0, 0.0, np.pi]))[2] == np.pi
    np.testing.assert_allclose(SE2.log(np.array([0.0, 0.0, 1.5 * np.pi]))[2], -0.5 * np.pi, rtol=1e-15)
    assert SE2.log(np.array([1.0, 2.0, 1e-300]))[2] == 1e-300  # a tiny angle is returned bit for bit
    assert wrap(np.nextafter(np.pi, 4)) < -np.pi + 1e-15
    inside = np.array([np.nextafter(-np.pi, 0), -3.0, 0.5, np.pi])
    np.testing.assert_array_equal(wrap(inside), inside)  # rounding never pushes an angle out of (-π, π]
    outside = np.array([-np.pi, 7.0, -7.0, 3 * np.pi, np.nextafter(np.pi, 4), 1e6])
    w = wrap(outside)
    assert np.all((w > -np.pi) & (w <= np.pi))
    np.testing.assert_allclose(np.cos(w), np.cos(outside), atol=1e-9)
    np.testing.assert_allclose(np.sin(w), np.sin(outside), atol=1e-9)


def _jac(f, x, h=1e-3):
    """8th-order central differences (truncation ~h⁸, rounding ~1e-13): the derivative of f at x."""
    c = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])
    cols = []
    for e in np.eye(len(x)):
        cols.append(sum(ck * np.asarray(f(x + (k - 4) * h * e)) for k, ck in enumerate(c) if ck) / h)
    return np.stack(cols, axis=-1)


XIS = [np.array([0.7, -1.3, p]) for p in (0.0, 1e-7, 0.4, np.nextafter(EDGE, 0), np.nextafter(EDGE, 2), 2.2, 3.0)]


@pytest.mark.parametrize("xi", XIS, ids=lambda x: f"phi={x[2]:.3g}")
def test_right_jacobian_and_its_inverse_against_finite_differences_of_exp_and_log(xi):
    T = SE2.exp(xi)
    jr = _jac(lambda z: SE2.log(SE2.between(T, SE2.exp(z))), xi)  # Exp(ξ + dξ) = Exp(ξ) Exp(J_r dξ)
    np.testing.assert_allclose(SE2.right_jacobian(xi), jr, atol=1e-11)
    jinv = _jac(lambda d: SE2.log(SE2.compose(T, SE2.exp(d))), np.zeros(3))  # Log(T Exp δ) = ξ + J_r⁻¹ δ
    np.testing.assert_allclose(SE2.right_jacobian_inverse(xi), jinv, atol=1e-11)
    np.testing.assert_allclose(SE2.right_jacobian_inverse(xi) @ SE2.right_jacobian(xi), np.eye(3), atol=1e-15)


@pytest.mark.parametrize("xi", XIS, ids=lambda x: f"phi={x[2]:.3g}")
def test_the_derivatives_of_jr_v_and_jr_inverse_v_are_exact(xi):
    v = np.array([0.4, -0.9, 1.3])
    np.testing.assert_allclose(
        SE2.jr_inverse_times_jacobian(xi, v), _jac(lambda z: SE2.right_jacobian_inverse(z) @ v, xi), atol=1e-11
    )
    np.testing.assert_allclose(SE2.jr_times_jacobian(xi, v), _jac(lambda z: SE2.right_jacobian(z) @ v, xi), atol=1e-11)


def test_adjoint_moves_a_twist_through_a_pose():
    T, xi = np.array([1.2, -0.4, 2.6]), np.array([0.3, 0.8, -0.5])
    lhs = SE2.compose(SE2.compose(T, SE2.exp(xi)), SE2.inverse(T))
    np.testing.assert_allclose(lhs, SE2.exp(SE2.adjoint(T) @ xi), atol=1e-15)


POSES = [np.array([1.2, -0.4, 2.6]), np.array([-3.0, 0.5, -3.1]), np.array([0.2, 0.1, 0.3])]


def _right(f, a):
    """The derivative of f(a ⊕ δ) in the right tangent of f's value: Log(f(a)⁻¹ f(a Exp δ))."""
    fa = f(a)
    return _jac(lambda d: SE2.log(SE2.between(fa, f(SE2.compose(a, SE2.exp(d))))), np.zeros(3))


def test_compose_inverse_between_jacobians_against_finite_differences():
    a, b = POSES[0], POSES[1]
    _, Ha, Hb = SE2.compose(a, b, jacobians=True)
    np.testing.assert_allclose(Ha, _right(lambda z: SE2.compose(z, b), a), atol=1e-11)
    np.testing.assert_allclose(Hb, _right(lambda z: SE2.compose(a, z), b), atol=1e-11)
    np.testing.assert_allclose(SE2.inverse(a, jacobians=True)[1], _right(SE2.inverse, a), atol=1e-11)
    _, Ha, Hb = SE2.between(a, b, jacobians=True)
    np.testing.assert_allclose(Ha, _right(lambda z: SE2.between(z, b), a), atol=1e-11)
    np.testing.assert_allclose(Hb, _right(lambda z: SE2.between(a, z), b), atol=1e-11)


def test_functions_broadcast_over_leading_axes():
    xis = np.stack(XIS)
    np.testing.assert_array_equal(SE2.right_jacobian(xis)[3], SE2.right_jacobian(XIS[3]))
    np.testing.assert_array_equal(
        SE2.jr_inverse_times_jacobian(xis, np.ones(3))[5], SE2.jr_inverse_times_jacobian(XIS[5], np.ones(3))
    )
    np.testing.assert_array_equal(SE2.exp(xis)[1], SE2.exp(XIS[1]))


# --- GTSAM 4.3's Pose2 -----------------------------------------------------------------------------


# GTSAM's own closed forms lose precision at small angles (its Logmap at φ = 1e-9 is off by 6e-8), so the
# comparison uses angles where both are exact; the 50-digit tests above cover the small ones.
def _gt(P):
    """A gtsam.Pose2 as [x, y, θ], θ in (-π, π] (GTSAM's atan2 gives -π for the half turn)."""
    return [P.x(), P.y(), np.pi if P.theta() == -np.pi else P.theta()]


GT_XIS = [np.array([0.7, -1.3, p]) for p in (0.1, 0.9, 1.1, 2.5, -3.0, np.pi)]


@pytest.mark.parametrize("xi", GT_XIS, ids=lambda x: f"phi={x[2]:.3g}")
def test_against_gtsam_pose2(xi):
    gtsam = optional_import("gtsam", "gtsam")
    P = gtsam.Pose2.Expmap(xi)
    T = SE2.exp(xi)
    np.testing.assert_allclose(T, _gt(P), atol=1e-15)
    np.testing.assert_allclose(SE2.log(T), gtsam.Pose2.Logmap(P), atol=1e-14)
    np.testing.assert_allclose(SE2.right_jacobian(xi), gtsam.Pose2.ExpmapDerivative(xi), atol=1e-15)
    np.testing.assert_allclose(SE2.right_jacobian_inverse(xi), gtsam.Pose2.LogmapDerivative(P), atol=1e-14)
    np.testing.assert_allclose(SE2.adjoint(T), P.AdjointMap(), atol=1e-15)
    Q = gtsam.Pose2(*POSES[1])
    for name, ours in (("compose", SE2.compose), ("between", SE2.between)):
        H1, H2 = np.zeros((3, 3), order="F"), np.zeros((3, 3), order="F")
        R = getattr(P, name)(Q, H1, H2)
        value, J1, J2 = ours(T, POSES[1], jacobians=True)
        np.testing.assert_allclose(value, _gt(R), atol=1e-14, err_msg=name)
        np.testing.assert_allclose(J1, H1, atol=1e-14, err_msg=name)
        np.testing.assert_allclose(J2, H2, atol=1e-14, err_msg=name)
    R = P.inverse()  # (GTSAM's Python binding gives no Jacobian of inverse: finite differences check ours)
    np.testing.assert_allclose(SE2.inverse(T), _gt(R), atol=1e-14)


def _mp_pose2_exp(xi):
    """Exp(ξ) of SE(2) at 50 digits: (V(φ) ρ, φ), V = [[A, -B], [B, A]], A = sin φ/φ, B = (1 - cos φ)/φ."""
    r1, r2, p = xi
    a, b = (mp.sin(p) / p, (1 - mp.cos(p)) / p) if p else (mp.mpf(1), mp.mpf(0))
    return [a * r1 - b * r2, b * r1 + a * r2, p]


def _mp_pose2_log(pose):
    """Log(T) of SE(2) at 50 digits for abs(θ) < π: [V(θ)⁻¹ t; θ]."""
    x, y, p = pose
    if not p:
        return [x, y, p]
    a, b = mp.sin(p) / p, (1 - mp.cos(p)) / p
    return [(a * x + b * y) / (a * a + b * b), (-b * x + a * y) / (a * a + b * b), p]


def _mp_pose2_jr(xi):
    """J_r(ξ) by its definition, d/dε Log(Exp(ξ)⁻¹ Exp(ξ + ε)) at ε = 0 (mpmath's differences at 50 digits)."""
    t = _mp_pose2_exp(xi)

    def entry(i, j, e):
        x = list(xi)
        x[j] += e
        u = _mp_pose2_exp(x)
        c, s = mp.cos(t[2]), mp.sin(t[2])
        dx, dy = u[0] - t[0], u[1] - t[1]
        return _mp_pose2_log([c * dx + s * dy, -s * dx + c * dy, u[2] - t[2]])[i]

    return mp.matrix([[mp.diff(lambda e, i=i, j=j: entry(i, j, e), 0) for j in range(3)] for i in range(3)])


def _worst(got, want) -> float:
    return float(max(abs(mp.mpf(float(g)) - w) for g, w in zip(np.ravel(got), want, strict=True)))


def test_gtsams_pose2_near_zero_loses_what_the_docs_record():
    """docs/conformance.md and examples/conformance_gtsam.py leave the se2 kit's cases near φ = 0 out of GTSAM's
    check because Pose2's closed forms lose digits there: Expmap 7e-10 at φ = -1e-7, Logmap 1.7e-8 at θ = 1e-10,
    ExpmapDerivative 1.3e-9 and LogmapDerivative 2.6e-5 at φ = 1e-4 (the kit's inputs, largest absolute error). Each
    measured against 50 digits, to the figures quoted, and each past the kit's 1e-12: a wheel that fixes them fails
    here, and the script's reason is then stale."""
    gtsam = optional_import("gtsam", "gtsam")
    exp_xi, log_pose, jac_xi = [1.5, 0.4, -1e-7], [0.1, 0.2, 1e-10], [0.5, -0.3, 1e-4]
    p = gtsam.Pose2.Expmap(np.array(exp_xi))
    jr = _mp_pose2_jr([mp.mpf(v) for v in jac_xi])
    jr_inv = jr**-1
    measured = {
        "Expmap": _worst([p.x(), p.y(), p.theta()], _mp_pose2_exp([mp.mpf(v) for v in exp_xi])),
        "Logmap": _worst(gtsam.Pose2.Logmap(gtsam.Pose2(*log_pose)), _mp_pose2_log([mp.mpf(v) for v in log_pose])),
        "ExpmapDerivative": _worst(gtsam.Pose2.ExpmapDerivative(np.array(jac_xi)), list(jr)),
        "LogmapDerivative": _worst(
            gtsam.Pose2.LogmapDerivative(gtsam.Pose2.Expmap(np.array(jac_xi))),
            [jr_inv[i, j] for i in range(3) for j in range(3)],
        ),
    }
    quoted = {"Expmap": "7e-10", "Logmap": "1.7e-08", "ExpmapDerivative": "1.3e-09", "LogmapDerivative": "2.6e-05"}
    shown = {name: f"{err:.{len(quoted[name].split('e')[0].replace('.', '')) - 1}e}" for name, err in measured.items()}
    assert shown == quoted, measured
    assert min(measured.values()) > 1e-12


# --- the state kind -----------------------------------------------------------------------------------


def test_the_se2_state_kind_retracts_on_the_right_and_local_inverts_it(rng):
    assert isinstance(SE2_STATE, Manifold) and SE2_STATE.name == "se2" and VECTOR.name == "vector"
    x = np.array([1.0, -2.0, 3.0, 0.4, 0.1, -0.7])
    for _ in range(20):
        d = rng.standard_normal(6)
        d[2] = rng.uniform(-3.1, 3.1)
        y = SE2_STATE.retract(x, d)
        assert -np.pi < y[2] <= np.pi
        np.testing.assert_allclose(SE2_STATE.local(x, y), d, atol=1e-13)
        np.testing.assert_allclose(SE2_STATE.retract(x, SE2_STATE.local(x, y)), y, atol=1e-13)
        # right retraction: the position moves along the body axes at x (R(θ) δρ to first order)
        small = SE2_STATE.retract(x, 1e-7 * d)
        c, s = np.cos(x[2]), np.sin(x[2])
        np.testing.assert_allclose((small[:2] - x[:2]) / 1e-7, [c * d[0] - s * d[1], s * d[0] + c * d[1]], atol=1e-6)
    np.testing.assert_array_equal(VECTOR.retract(x, x), 2 * x)
    np.testing.assert_array_equal(VECTOR.local(x, 2 * x), x)
    with pytest.raises(ShapeError, match=r"SE2_STATE state"):
        SE2_STATE.retract(np.zeros(3), np.zeros(3))


def test_world_position_covariance_refuses_a_nan_or_asymmetric_covariance():
    """It used to rotate either without a word."""
    x, P = np.array([1.0, 2.0, 0.5, 0.3, 0.0, 0.1]), np.diag([0.4, 0.1, 0.2, 1.0, 1.0, 1.0])
    c, s = np.cos(0.5), np.sin(0.5)
    R = np.array([[c, -s], [s, c]])
    np.testing.assert_allclose(world_position_covariance(x, P), R @ P[:2, :2] @ R.T, rtol=1e-15)
    np.testing.assert_allclose(world_position_covariance(x[:3], P[:3, :3]), R @ P[:2, :2] @ R.T, rtol=1e-15)
    bad = P.copy()
    bad[1, 1] = np.nan
    with pytest.raises(SteamError, match=r"cov .*nan"):
        world_position_covariance(x, bad)
    bad = P.copy()
    bad[0, 1] = 0.05
    with pytest.raises(SteamError, match=r"cov must be symmetric.*cov\[0, 1\] = 0\.05"):
        world_position_covariance(x, bad)
    with pytest.raises(ShapeError, match="square covariance"):
        world_position_covariance(x, np.eye(1))
