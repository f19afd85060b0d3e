"""Factors on SE(2) states (steam_ref.factors.lie_prior, .lie_readings): residuals and costs against
GTSAM 4.3's ``WnoaMotionFactorPose2``, every Jacobian against central differences through the right
retraction, and where GTSAM's series pose Jacobians part from the exact ones."""

from __future__ import annotations

import numpy as np
import pytest
from requirements import optional_import

from steam_ref.errors import SteamError
from steam_ref.factors import Factor
from steam_ref.factors.lie_prior import LiePriorFactor, LieStatePrior, lie_prior_factors
from steam_ref.factors.lie_readings import BodyVelocityFactor, LieInterpolatedFactor, PoseReading
from steam_ref.lie import SE2, SE2_STATE
from steam_ref.linear.system import linearize
from steam_ref.variables import L, Values, X

QC = np.diag([0.3, 0.2, 0.1])
DT = 0.7


def tangent_jacobians(f, *xs, kinds, eps=1e-6):
    """∂f/∂δₖ of f(x₁ ⊕ δ₁, ...) at δ = 0 by central differences, ⊕ each argument's kind (SE2_STATE or +)."""
    out = []
    for k, x in enumerate(xs):
        cols = []
        for e in np.eye(len(x)):
            plus, minus = list(xs), list(xs)
            if kinds[k] == "se2":
                plus[k], minus[k] = SE2_STATE.retract(x, eps * e), SE2_STATE.retract(x, -eps * e)
            else:
                plus[k], minus[k] = x + eps * e, x - eps * e
            cols.append((np.asarray(f(*plus)) - np.asarray(f(*minus))) / (2 * eps))
        out.append(np.stack(cols, axis=-1))
    return out


def pair(rng, scale):
    """Two states whose relative pose has |ξ| = scale."""
    x1 = np.array([1.0, 2.0, 0.3, 0.5, 0.1, 0.6])
    d = rng.standard_normal(3)
    d *= scale / np.linalg.norm(d)
    return x1, SE2_STATE.retract(x1, np.concatenate([d, 0.3 * rng.standard_normal(3)]))


@pytest.mark.parametrize("model", ["local-variable", "simplified"])
@pytest.mark.parametrize("scale", [0.005, 0.71, 3.5])
def test_the_prior_jacobians_are_exact(rng, model, scale):
    f = LiePriorFactor.create(X(0), X(1), DT, QC, model, group=SE2)
    x1, x2 = pair(rng, scale)
    J1, J2 = f.jacobians(x1, x2)
    N1, N2 = tangent_jacobians(f.error, x1, x2, kinds=("se2", "se2"))
    np.testing.assert_allclose(J1, N1, atol=2e-8)
    np.testing.assert_allclose(J2, N2, atol=2e-8)


def test_the_two_models_are_the_formulas_they_name(rng):
    x1, x2 = pair(rng, 0.9)
    xi = SE2.log(SE2.between(x1[:3], x2[:3]))
    lv = LiePriorFactor.create(X(0), X(1), DT, QC, group=SE2).error(x1, x2)
    sm = LiePriorFactor.create(X(0), X(1), DT, QC, "simplified", group=SE2).error(x1, x2)
    np.testing.assert_allclose(lv, np.r_[xi - DT * x1[3:], np.linalg.solve(SE2.right_jacobian(xi), x2[3:]) - x1[3:]])
    np.testing.assert_allclose(sm, np.r_[xi - DT * x1[3:], x2[3:] - x1[3:]])
    assert np.abs(lv[3:] - sm[3:]).max() > 1e-2  # they differ at a turn of 0.9 rad


# --- GTSAM 4.3 -------------------------------------------------------------------------------------


def _gtsam_factor(gtsam):
    k = [gtsam.symbol(c, i) for c, i in (("x", 1), ("v", 1), ("x", 2), ("v", 2))]
    g = gtsam.WnoaMotionFactorPose2(gtsam.StateData(k[0], k[1], 0.0), gtsam.StateData(k[2], k[3], DT), np.diag(QC))
    return g, k


def _gtsam_eval(gtsam, g, k, x1, x2):
    H = [np.zeros((6, 3), order="F") for _ in range(4)]
    p1, p2 = gtsam.Pose2(*x1[:3]), gtsam.Pose2(*x2[:3])
    e = g.evaluateError(p1, x1[3:], p2, x2[3:], *H)
    v = gtsam.Values()
    for key, val in zip(k, (p1, x1[3:], p2, x2[3:]), strict=True):
        v.insert(key, val)
    return e, g.error(v), H


@pytest.mark.parametrize("seed", range(5))
def test_residual_cost_and_velocity_jacobians_match_gtsam_wnoa_motion_factor_pose2(seed):
    gtsam = optional_import("gtsam", "gtsam")
    rng = np.random.default_rng(seed)
    g, k = _gtsam_factor(gtsam)
    f = LiePriorFactor.create(X(0), X(1), DT, QC, group=SE2)
    # angles where GTSAM's own Logmap is exact (it loses digits below ~0.01 rad: 2.7e-11 at |ξ| = 0.005)
    x1 = np.r_[rng.uniform(-5, 5, 2), rng.uniform(-3, 3), rng.standard_normal(3)]
    x2 = SE2_STATE.retract(
        x1, np.r_[rng.uniform(-1, 1, 2), rng.choice([-1, 1]) * rng.uniform(0.1, 2.5), rng.standard_normal(3)]
    )
    e, cost, H = _gtsam_eval(gtsam, g, k, x1, x2)
    np.testing.assert_allclose(f.error(x1, x2), e, rtol=0, atol=1e-12)
    assert abs(0.5 * np.sum(f.whitened_error(x1, x2) ** 2) - cost) <= 1e-12 * max(1.0, cost)
    J1, J2 = f.jacobians(x1, x2)
    np.testing.assert_allclose(J1[:, 3:], H[1], atol=1e-12)  # GTSAM's velocity Jacobians are exact
    np.testing.assert_allclose(J2[:, 3:], H[3], atol=1e-12)


def test_where_gtsams_series_pose_jacobians_depart_from_the_exact_ones():
    """GTSAM truncates ∂(J_r(ξ)⁻¹ϖ₂)/∂ξ to a series: its pose Jacobians part from the exact ones (which
    central differences confirm to 1e-8) more and more as |ξ| grows."""
    gtsam = optional_import("gtsam", "gtsam")
    g, k = _gtsam_factor(gtsam)
    f = LiePriorFactor.create(X(0), X(1), DT, QC, group=SE2)
    rng = np.random.default_rng(3)
    departures = {}
    for scale in (0.005, 0.71, 3.5):
        x1, x2 = pair(rng, scale)
        _, _, H = _gtsam_eval(gtsam, g, k, x1, x2)
        J1, J2 = f.jacobians(x1, x2)
        N1, N2 = tangent_jacobians(f.error, x1, x2, kinds=("se2", "se2"))
        assert max(np.abs(J1 - N1).max(), np.abs(J2 - N2).max()) < 2e-8
        departures[scale] = max(np.abs(H[0] - J1[:, :3]).max(), np.abs(H[2] - J2[:, :3]).max())
        np.testing.assert_allclose(H[0][:3], J1[:3, :3], atol=1e-9)  # the ξ rows are exact in GTSAM too
    assert departures[0.005] < 1e-7
    assert departures[0.71] > 1e-6 and departures[3.5] > 1e-3
    assert departures[0.005] < departures[0.71] < departures[3.5]


# --- measurements -----------------------------------------------------------------------------------

STATE = np.array([1.0, -0.5, 2.4, 0.8, -0.2, 0.9])
LANDMARK = np.array([4.0, 3.0])


@pytest.mark.parametrize(
    "factor",
    [
        PoseReading.range(X(0), L(1), 4.0, 0.1, group=SE2),
        PoseReading.bearing(X(0), L(1), 0.3, 0.05, group=SE2),
        PoseReading.bearing_range(X(0), L(1), 0.3, 4.0, np.array([0.05, 0.1]), group=SE2),
    ],
    ids=["range", "bearing", "bearing-range"],
)
def test_landmark_readings_jacobians_in_the_right_tangent(factor):
    J = factor.jacobians(STATE, LANDMARK)
    N = tangent_jacobians(factor.error, STATE, LANDMARK, kinds=("se2", "vector"))
    np.testing.assert_allclose(J[0], N[0], atol=1e-8)
    np.testing.assert_allclose(J[1], N[1], atol=1e-8)
    assert factor.key_dims == (6, 2)


def test_velocity_reading_and_state_prior_jacobians(rng):
    v = BodyVelocityFactor.create(X(0), np.array([0.7, 0.0, 1.0]), 0.1, group=SE2)
    np.testing.assert_allclose(v.error(STATE), STATE[3:] - [0.7, 0.0, 1.0])
    np.testing.assert_allclose(v.jacobians(STATE)[0], tangent_jacobians(v.error, STATE, kinds=("se2",))[0], atol=1e-9)
    mean = SE2_STATE.retract(STATE, rng.standard_normal(6))
    p = LieStatePrior.create(X(0), mean, np.full(6, 0.1), group=SE2)
    np.testing.assert_allclose(p.error(mean), 0.0, atol=1e-15)
    np.testing.assert_allclose(SE2_STATE.retract(mean, p.error(STATE)), STATE, atol=1e-14)
    np.testing.assert_allclose(p.jacobians(STATE)[0], tangent_jacobians(p.error, STATE, kinds=("se2",))[0], atol=1e-8)
    with pytest.raises(SteamError, match=r"heading .* \(-π, π\]"):
        LieStatePrior.create(X(0), np.r_[0, 0, 4.0, 0, 0, 0], 0.1, group=SE2)


@pytest.mark.parametrize("model", ["local-variable", "simplified"])
@pytest.mark.parametrize(
    "inner",
    [
        PoseReading.range(X(9), L(1), 4.0, 0.1, group=SE2),
        PoseReading.bearing_range(X(9), L(1), 0.3, 4.0, np.array([0.05, 0.1]), group=SE2),
        BodyVelocityFactor.create(X(9), np.array([0.7, 0.0, 1.0]), 0.1, group=SE2),
    ],
    ids=["range", "bearing-range", "velocity"],
)
def test_interpolated_readings_jacobians(rng, model, inner):
    x1, x2 = pair(rng, 1.3)
    f = LieInterpolatedFactor.create(inner, X(0), X(1), 0.0, DT, 0.3, QC, model, group=SE2)
    rest = (LANDMARK,) if len(inner.keys) == 2 else ()
    kinds = ("se2", "se2") + ("vector",) * len(rest)
    J = f.jacobians(x1, x2, *rest)
    N = tangent_jacobians(f.error, x1, x2, *rest, kinds=kinds)
    for a, b in zip(J, N, strict=True):
        np.testing.assert_allclose(a, b, atol=2e-8)
    assert f.keys == (X(0), X(1)) + inner.keys[1:]


def test_a_batch_evaluates_as_its_factors_do(rng):
    """linearize stacks factors of one signature: the stacked error and Jacobians are each factor's own."""
    states = [SE2_STATE.retract(STATE, rng.standard_normal(6)) for _ in range(4)]
    values = Values({X(i): s for i, s in enumerate(states)} | {L(1): LANDMARK})
    factors: list[Factor] = lie_prior_factors([X(i) for i in range(4)], np.array([0.0, 0.5, 1.1, 2.0]), QC, group=SE2)
    factors += [PoseReading.range(X(i), L(1), 3.0, 0.2, group=SE2) for i in range(4)]
    inner = PoseReading.bearing(X(9), L(1), 0.2, 0.1, group=SE2)
    factors += [LieInterpolatedFactor.create(inner, X(i), X(i + 1), 0.0, 1.0, 0.4, QC, group=SE2) for i in range(3)]
    for group in linearize(factors, values):
        for row, i in enumerate(group.factor_ids):
            f = factors[i]
            xs = [values[k] for k in f.keys]
            np.testing.assert_allclose(-group.rhs[row], f.whitened_error(*xs), atol=1e-13)
            for J, Jf in zip(group.jacobians, f.jacobians(*xs), strict=True):
                np.testing.assert_allclose(J[row], f.sqrt_information @ Jf, atol=1e-13)


@pytest.mark.parametrize("model", ["local-variable", "simplified"])
@pytest.mark.parametrize("scale", [1e-6, 0.005, 0.71, 3.5])
def test_error_and_jacobians_from_one_evaluation_are_the_two_calls_bit_for_bit(rng, model, scale):
    """A linearization asks a Lie factor for both at once (one evaluation of the local variables or of x(τ)): the
    same numbers, to the last bit, as error() and jacobians() asked apart, for a stack and for one factor."""
    pairs = [pair(rng, scale) for _ in range(3)]
    x1, x2 = np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])
    priors = [LiePriorFactor.create(X(0), X(1), DT * (k + 1), QC, model, group=SE2) for k in range(3)]
    inner = PoseReading.bearing_range(X(9), L(1), 0.3, 4.0, np.array([0.05, 0.1]), group=SE2)
    readings = [
        LieInterpolatedFactor.create(inner, X(0), X(1), 0.0, DT, 0.1 + 0.2 * k, QC, model, group=SE2) for k in range(3)
    ]
    landmarks = np.tile(LANDMARK, (3, 1))
    for factors, rest in ((priors, ()), (readings, (landmarks,))):
        for f, xs in (
            (type(factors[0]).stack(factors), (x1, x2, *rest)),
            (factors[0], (x1[0], x2[0], *(r[0] for r in rest))),
        ):
            e, J = f.error_and_jacobians(*xs)
            assert np.array_equal(e, f.error(*xs))
            for a, b in zip(J, f.jacobians(*xs), strict=True):
                assert np.array_equal(a, b)


def test_bad_input_names_the_offending_value():
    with pytest.raises(SteamError, match="model must be one of 'local-variable', 'simplified', got model='lie'"):
        LiePriorFactor.create(X(0), X(1), DT, QC, "lie", group=SE2)
    with pytest.raises(SteamError, match=r"qc must be \(3, 3\)"):
        LiePriorFactor.create(X(0), X(1), DT, np.eye(2), group=SE2)
    with pytest.raises(SteamError, match=r"inner must read a state of kind SE2_STATE \(the reading at tau\)"):
        LieInterpolatedFactor.create(
            LieStatePrior.create(X(9), np.zeros(9), 1.0, group=SE2, derivatives=2), X(0), X(1), 0, 1, 0.5, QC, group=SE2
        )
    with pytest.raises(SteamError, match="times must increase strictly"):
        lie_prior_factors([X(0), X(1)], np.array([1.0, 1.0]), QC, group=SE2)
