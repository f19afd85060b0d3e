"""Readings of a rigid body on SE(3) (and SE(2), the same code): position fix, range and body-frame point of a
landmark, gyro, pose prior; at a state and at a time between two states through the prior's one interpolation.

Oracles: the values against SciPy's rotation matrices of the same rotation vectors (independent of our group code);
every Jacobian against 8th-order central differences in the right tangent (tests/finite_differences.py) at
rotations of 1e-8 rad, 0.3, just below and above the series switch of the coefficients (θ = 2) and 3.0, at a state
and interpolated (WNOA with both residuals, WNOJ).
"""

from __future__ import annotations

import numpy as np
import pytest
from finite_differences import jacobian8_stacked
from scipy.spatial.transform import Rotation

from steam_ref.errors import ShapeError, SteamError
from steam_ref.factors.lie_prior import LieStatePrior
from steam_ref.factors.point_readings import (
    AngularVelocityReading,
    PointReading,
    PosePrior,
    PositionReading,
    RangeReading,
)
from steam_ref.lie import SE2, SE3, SO3, GroupState
from steam_ref.lie.points import point_dim
from steam_ref.motion import motion_prior
from steam_ref.variables import L, X

ANGLES = (1e-8, 0.3, 1.999, 2.001, 3.0)


def _close(analytic, numeric, tol=1e-9):
    np.testing.assert_allclose(analytic, numeric, rtol=0, atol=tol * max(1.0, float(np.max(np.abs(numeric)))))


def _state(rng, g, angle, derivatives=1):
    xi = rng.standard_normal(g.dim)
    xi *= angle / float(g.angle(xi))
    return np.r_[g.exp(xi), rng.standard_normal(derivatives * g.dim)]


def _readings(g, derivatives=1):
    k = point_dim(g)
    m = g.dim - k
    opts = {"group": g, "derivatives": derivatives}
    return {
        "position": PositionReading.create(X(0), np.arange(1.0, k + 1), 0.5, **opts),
        "range": RangeReading.create(X(0), L(1), 4.0, 0.2, **opts),
        "point": PointReading.create(X(0), L(1), np.linspace(1, 2, k), np.diag(np.linspace(0.1, 0.3, k)), **opts),
        "gyro": AngularVelocityReading.create(X(0), np.linspace(-0.2, 0.3, m), 0.01, **opts),
        "pose prior": PosePrior.create(X(0), g.exp(np.linspace(0.2, -0.4, g.dim)), 0.3, **opts),
    }


def test_the_values_are_those_of_scipys_rotation_of_the_same_rotation_vector(rng):
    rho, phi, l = rng.standard_normal((3, 3))
    x = np.r_[SE3.exp(np.r_[rho, phi]), rng.standard_normal(6)]
    R = Rotation.from_rotvec(phi).as_matrix()
    t = SE3.matrix(x[:12])[:3, 3]
    np.testing.assert_allclose(SE3.matrix(x[:12])[:3, :3], R, atol=1e-15)
    f = _readings(SE3)
    np.testing.assert_allclose(f["position"].error(x), t - [1, 2, 3], atol=1e-15)
    np.testing.assert_allclose(f["range"].error(x, l), [np.linalg.norm(l - t) - 4.0], atol=1e-14)
    np.testing.assert_allclose(f["point"].error(x, l), R.T @ (l - t) - np.linspace(1, 2, 3), atol=1e-14)
    np.testing.assert_allclose(f["gyro"].error(x), x[15:18] - np.linspace(-0.2, 0.3, 3), atol=0)
    mean = SE3.exp(np.linspace(0.2, -0.4, 6))
    np.testing.assert_allclose(f["pose prior"].error(np.r_[mean, x[12:]]), 0.0, atol=1e-15)
    # SE(2): the same code reads the planar pose's position, the yaw rate
    y = np.array([1.0, -2.0, 0.7, 0.3, 0.1, -0.25])
    f2 = _readings(SE2)
    np.testing.assert_allclose(f2["position"].error(y), [0.0, -4.0], atol=0)
    np.testing.assert_allclose(f2["gyro"].error(y), [-0.25 + 0.2], atol=1e-16)
    c, s = np.cos(0.7), np.sin(0.7)
    l2 = np.array([3.0, 1.0])
    np.testing.assert_allclose(f2["point"].error(y, l2), [[c, s], [-s, c]] @ (l2 - y[:2]) - [1, 2], atol=1e-15)


def _check_at_a_state(f, kind, x, l):
    if f.key_dims[1:]:
        Hx, Hl = f.jacobians(x, l)
        _close(Hx, jacobian8_stacked(lambda d: f.error(kind.retract(x, d), l), kind.dim))
        _close(Hl, jacobian8_stacked(lambda d: f.error(x, l + d), len(l)))
    else:
        (Hx,) = f.jacobians(x)
        _close(Hx, jacobian8_stacked(lambda d: f.error(kind.retract(x, d)), kind.dim))
    assert f.key_kinds[0] is kind and f.key_dims[0] == kind.dim


@pytest.mark.parametrize("group", ["se3", "se2"])
@pytest.mark.parametrize("angle", ANGLES)
def test_every_readings_jacobians_are_exact_at_a_state(group, angle, rng):
    g = {"se3": SE3, "se2": SE2}[group]
    for derivatives in (1, 2):
        x = _state(rng, g, angle, derivatives)
        l = rng.standard_normal(point_dim(g)) * 3
        for f in _readings(g, derivatives).values():
            _check_at_a_state(f, GroupState(g, derivatives), x, l)


PRIORS = {"se3": 1, "se3-simplified": 1, "se3-wnoj": 2}


@pytest.mark.parametrize("name", sorted(PRIORS))
@pytest.mark.parametrize("angle", [1e-8, 1.0, 2.5])
def test_every_reading_between_two_states_has_exact_jacobians(name, angle, rng):
    """Each reading at τ moved onto the states at t₁, t₂ by the prior's one interpolation (``interpolated_factor``):
    its error is the reading of the interpolated state, its Jacobians exact."""
    derivatives = PRIORS[name]
    prior = motion_prior(name, np.diag([0.4, 0.3, 0.2, 0.05, 0.08, 0.1]))
    kind = prior.kind
    g = prior.group  # SE3V: poses [t; φ]
    x1 = _state(rng, g, 0.5, derivatives)
    xi = rng.standard_normal(6)
    xi *= angle / float(g.angle(xi))
    x2 = np.r_[g.compose(x1[:6], g.exp(xi)), rng.standard_normal(6 * derivatives)]
    l = rng.standard_normal(3) * 3
    x = prior.interpolate(0.0, x1, 0.8, x2, 0.3)
    for f in _readings(g, derivatives).values():
        _check_between(prior.interpolated_factor(f, X(1), X(2), 0.0, 0.8, 0.3), f, kind, x, x1, x2, l)


def _check_between(g, f, kind, x, x1, x2, l):
    rest = (l,) if f.key_dims[1:] else ()
    np.testing.assert_allclose(g.error(x1, x2, *rest), f.error(x, *rest), atol=1e-14)
    J1, J2, *Jl = g.jacobians(x1, x2, *rest)
    _close(J1, jacobian8_stacked(lambda d: g.error(kind.retract(x1, d), x2, *rest), kind.dim))
    _close(J2, jacobian8_stacked(lambda d: g.error(x1, kind.retract(x2, d), *rest), kind.dim))
    if rest:
        _close(Jl[0], jacobian8_stacked(lambda d: g.error(x1, x2, l + d), 3))


def test_bad_readings_are_refused_by_name():
    with pytest.raises(SteamError, match="SO3 moves no points"):
        PositionReading.create(X(0), np.zeros(3), 1.0, group=SO3)
    with pytest.raises(ShapeError, match=r"measured must be 3 finite numbers"):
        PositionReading.create(X(0), np.zeros(2), 1.0, group=SE3)
    with pytest.raises(SteamError, match=r"a range cannot be negative, got measured=-1\.0"):
        RangeReading.create(X(0), L(0), -1.0, 1.0, group=SE3)
    with pytest.raises(ShapeError, match=r"measured must be 1 finite number"):
        AngularVelocityReading.create(X(0), np.zeros(3), 1.0, group=SE2)
    with pytest.raises(SteamError, match="derivatives"):
        PointReading.create(X(0), L(0), np.zeros(3), 1.0, group=SE3, derivatives=3)
    with pytest.raises(SteamError, match="names variable"):
        RangeReading.create(X(0), X(0), 1.0, 1.0, group=SE3)
    for bad in (0, 3):  # a reading made directly, not by create: its state's size names the derivatives too
        with pytest.raises(SteamError, match=rf"derivatives=1\) or also its acceleration \(2\), got {bad}"):
            _ = LieStatePrior((X(0),), np.eye(6), mean=np.zeros(6), group=SE2, derivatives=bad).key_dims
    with pytest.raises(SteamError, match="inner must read a state of kind"):
        motion_prior("se3", np.eye(6)).interpolated_factor(
            PositionReading.create(X(0), np.zeros(2), 1.0, group=SE2), X(1), X(2), 0, 1, 0.5
        )


@pytest.mark.parametrize("name", ["se3", "se3-wnoj"])
def test_readings_between_two_states_moved_at_once_are_the_factors_moved_one_by_one(rng, name):
    """MotionPrior.interpolated_factors (SE(3) WNOA: every Λ(τ), Ψ(τ) in one call; WNOJ: the protocol's default, one
    by one) gives each reading's interpolated factor: the same error and Jacobians at random states."""
    prior = motion_prior(name, np.diag([0.02, 0.005, 0.005, 0.001, 0.001, 0.002]))
    g, n = prior.kind.group, prior.kind.derivatives  # SE3V: the table's SE(3) priors hold [t; φ]
    taus = np.sort(rng.uniform(2.0, 3.0, size=7))
    inners = [AngularVelocityReading.create(X(1), rng.normal(size=3), 0.01, group=g, derivatives=n) for _ in taus]
    inners.append(PointReading.create(X(1), L(4), rng.normal(size=3), 0.05, group=g, derivatives=n))
    taus = np.r_[taus, 2.5]
    many = prior.interpolated_factors(inners, X(0), X(1), 2.0, 3.0, taus)
    size = prior.state_dim - g.size
    x1, x2 = (np.r_[g.exp(0.3 * rng.normal(size=6)), rng.normal(size=size)] for _ in range(2))
    landmark = rng.normal(size=3)
    for f, inner, tau in zip(many, inners, taus, strict=True):
        one = prior.interpolated_factor(inner, X(0), X(1), 2.0, 3.0, tau)
        args = (x1, x2, landmark)[: len(one.keys)]
        assert f.keys == one.keys and type(f) is type(one)
        np.testing.assert_allclose(f.error(*args), one.error(*args), rtol=1e-12, atol=1e-13)
        for a, b in zip(f.jacobians(*args), one.jacobians(*args), strict=True):
            np.testing.assert_allclose(a, b, rtol=1e-12, atol=1e-13)
