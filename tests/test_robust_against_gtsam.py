"""Robust losses and robust pose readings against GTSAM 4.3's ``noiseModel::Robust`` (an independent oracle).

GTSAM's mEstimator Huber and Tukey give the weight w(e) and loss ρ(e) of a whitened error norm e, including at the
threshold itself; a ``RangeFactor2D``, ``BearingFactor2D`` or ``BearingRangeFactor2D`` on a ``Pose2`` with a
``Robust`` noise model linearizes to A = √w W H, b = -√w W e (block reweighting, the Jacobian in the pose's body
tangent [x, y, θ], the SE(2) state's pose block; W of a full covariance the upper-triangular R with RᵀR = Σ⁻¹)
and its error is ρ of the whitened error norm.
"""

from __future__ import annotations

import numpy as np
import pytest
from requirements import optional_import

gtsam = optional_import("gtsam", "gtsam")  # skips here, fails in CI (STEAM_REF_REQUIRE_OPTIONAL=1)

import steam_ref as sr  # noqa: E402
from steam_ref.factors.lie_readings import PoseReading  # noqa: E402
from steam_ref.graph import FactorGraph  # noqa: E402
from steam_ref.lie import SE2  # noqa: E402
from steam_ref.linear.system import linearize  # noqa: E402
from steam_ref.variables import L, Values, X  # noqa: E402

# whitened error norms around and exactly at each threshold, both signs
NORMS = np.array([0.0, 1e-9, 0.3, 1.0, 1.3, 1.3 + 1e-12, 2.0, 2.5 - 1e-12, 2.5, 2.5 + 1e-12, 3.0, 40.0, 1e6])


@pytest.mark.parametrize(
    ("ours", "theirs"),
    [
        (sr.Huber(1.3), lambda: gtsam.noiseModel.mEstimator.Huber.Create(1.3)),
        (sr.Tukey(2.5), lambda: gtsam.noiseModel.mEstimator.Tukey.Create(2.5)),
        (sr.Tukey(15.0), lambda: gtsam.noiseModel.mEstimator.Tukey.Create(15.0)),
    ],
    ids=["huber", "tukey", "tukey15"],
)
def test_weight_and_rho_equal_gtsam_mestimators_at_and_around_the_threshold(ours, theirs):
    m = theirs()
    s = np.concatenate([NORMS, -NORMS])
    w, rho = ours.weight_and_rho(s)
    np.testing.assert_allclose(w, [m.weight(float(e)) for e in s], rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(rho, [m.loss(float(e)) for e in s], rtol=1e-13, atol=1e-15)
    np.testing.assert_array_equal(ours.weight(s), w)
    np.testing.assert_array_equal(ours.rho(s), rho)


def _pose2(x):
    return gtsam.Pose2(float(x[0]), float(x[1]), float(x[2]))


def _gtsam_robust(loss, noise):
    estimator = (
        gtsam.noiseModel.mEstimator.Huber.Create(loss.k)
        if isinstance(loss, sr.Huber)
        else gtsam.noiseModel.mEstimator.Tukey.Create(loss.c)
    )
    return gtsam.noiseModel.Robust.Create(estimator, noise)


# (pose, landmark, bearing, range): one near the ±π seam of the bearing, one an outlier past every threshold
CASES = [
    (np.array([0.3, -0.2, 0.4]), np.array([2.0, 1.5]), 0.61, 2.3),
    (np.array([0.0, 0.0, 0.0]), np.array([-3.0, -0.01]), np.pi - 0.02, 3.1),  # true bearing just below -π
    (np.array([1.0, 2.0, -2.9]), np.array([-1.0, 2.2]), -0.3, 1.5),  # heading near -π
    (np.array([0.5, 0.5, 1.0]), np.array([4.0, -1.0]), 2.0, 9.0),  # an outlier
]
LOSSES = [sr.Huber(1.3), sr.Tukey(2.5)]


def _ours(factor, pose, landmark):
    state = np.concatenate([pose, [0.4, -0.1, 0.2]])  # the twist: read by no pose reading
    values = FactorGraph([factor]).with_kinds(Values({X(0): state, L(0): landmark}))
    (group,) = linearize([factor], values)
    return group.jacobians[0][0][:, :3], group.jacobians[1][0], group.rhs[0], group.costs[0]


def _theirs(factor, pose, landmark):
    values = gtsam.Values()
    values.insert(0, _pose2(pose))
    values.insert(1, gtsam.Point2(*landmark))
    linear = factor.linearize(values)
    A, b = linear.jacobian()
    return A[:, :3], A[:, 3:], b, factor.error(values)


@pytest.mark.parametrize("loss", LOSSES, ids=["huber", "tukey"])
@pytest.mark.parametrize("case", range(len(CASES)))
@pytest.mark.parametrize("reading", ["range", "bearing", "bearing_range", "bearing_range_correlated"])
def test_robust_se2_pose_readings_linearize_as_gtsam_robust_factors(reading, case, loss):
    pose, landmark, bearing, rng = CASES[case]
    sigma_b, sigma_r = 0.05, 0.2
    if reading == "range":
        ours = PoseReading.range(X(0), L(0), rng, sigma_r, loss=loss, group=SE2)
        noise = _gtsam_robust(loss, gtsam.noiseModel.Isotropic.Sigma(1, sigma_r))
        theirs = gtsam.RangeFactor2D(0, 1, rng, noise)
    elif reading == "bearing":
        ours = PoseReading.bearing(X(0), L(0), bearing, sigma_b, loss=loss, group=SE2)
        noise = _gtsam_robust(loss, gtsam.noiseModel.Isotropic.Sigma(1, sigma_b))
        theirs = gtsam.BearingFactor2D(0, 1, gtsam.Rot2(bearing), noise)
    elif reading == "bearing_range_correlated":  # a full covariance: W = R with RᵀR = Σ⁻¹, R upper, as GTSAM's
        cov = np.array([[sigma_b**2, 0.6 * sigma_b * sigma_r], [0.6 * sigma_b * sigma_r, sigma_r**2]])
        ours = PoseReading.bearing_range(X(0), L(0), bearing, rng, cov, loss=loss, group=SE2)
        noise = _gtsam_robust(loss, gtsam.noiseModel.Gaussian.Covariance(cov))
        theirs = gtsam.BearingRangeFactor2D(0, 1, gtsam.Rot2(bearing), rng, noise)
    else:
        sigmas = np.array([sigma_b, sigma_r])
        ours = PoseReading.bearing_range(X(0), L(0), bearing, rng, sigmas, loss=loss, group=SE2)
        noise = _gtsam_robust(loss, gtsam.noiseModel.Diagonal.Sigmas(sigmas))
        theirs = gtsam.BearingRangeFactor2D(0, 1, gtsam.Rot2(bearing), rng, noise)
    Ax, Al, b, cost = _ours(ours, pose, landmark)
    Gx, Gl, gb, gcost = _theirs(theirs, pose, landmark)
    scale = max(1.0, float(np.abs(Gx).max()), float(np.abs(Gl).max()))
    np.testing.assert_allclose(Ax, Gx, rtol=1e-9, atol=1e-12 * scale)
    np.testing.assert_allclose(Al, Gl, rtol=1e-9, atol=1e-12 * scale)
    np.testing.assert_allclose(b, gb, rtol=1e-9, atol=1e-12 * max(1.0, float(np.abs(gb).max())))
    np.testing.assert_allclose(cost, gcost, rtol=1e-11)
