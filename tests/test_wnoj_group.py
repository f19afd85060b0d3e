"""White noise on jerk (and Singer's model) on a Lie group: ``LieGroupAccelPrior`` on SE(2) and SE(3).

Oracles: 8th-order central differences in the right tangents (tests/finite_differences.py) for the second
derivatives the groups give (``jr_times_hessian``, ``jr_inverse_times_hessian``), the prior factor's Jacobians, the
interpolated and extrapolated means' Jacobians, at rotation angles from 1e-8 to 3.0; the exact kinematics (a state
drawn by the model's own noise leaves that noise as the residual, so the local variables and their map back are
inverses); a constant-twist trajectory (zero acceleration) has zero residual and interpolates onto itself.
"""

from __future__ import annotations

import numpy as np
import pytest
from finite_differences import jacobian8_stacked

from steam_ref.errors import ShapeError
from steam_ref.gp.interpolate import interpolation_terms
from steam_ref.lie import SE2, SE3, SE3V, GroupState, gp_accel
from steam_ref.motion import LieGroupAccelPrior, motion_prior
from steam_ref.variables import X

ANGLES = (1e-8, 0.3, 1.0, 3.0)
GROUPS = {"se2": SE2, "se3": SE3}


def _qc(g):
    return np.diag(np.linspace(0.1, 0.5, g.dim))


def assert_close(analytic, numeric, tol=1e-9):
    np.testing.assert_allclose(analytic, numeric, rtol=0, atol=tol * max(1.0, float(np.max(np.abs(numeric)))))


def _states(rng, g, angle):
    xi = rng.standard_normal(g.dim)
    xi *= angle / float(g.angle(xi))
    T1 = g.exp(rng.standard_normal(g.dim))
    return np.r_[T1, rng.standard_normal(2 * g.dim)], np.r_[g.compose(T1, g.exp(xi)), rng.standard_normal(2 * g.dim)]


@pytest.mark.parametrize("group", GROUPS)
@pytest.mark.parametrize("angle", ANGLES)
def test_the_second_derivatives_of_jr_and_its_inverse_are_exact(group, angle, rng):
    g = GROUPS[group]
    xi, v, u = rng.standard_normal((3, g.dim))
    xi *= angle / float(g.angle(xi))
    assert_close(g.jr_times_hessian(xi, v, u), jacobian8_stacked(lambda d: g.jr_times_jacobian(xi + d, v) @ u, g.dim))
    assert_close(
        g.jr_inverse_times_hessian(xi, v, u),
        jacobian8_stacked(lambda d: g.jr_inverse_times_jacobian(xi + d, v) @ u, g.dim),
    )
    dj, _ = g.jr_derivatives(xi, u)
    assert_close(dj @ v, g.jr_times_jacobian(xi, v) @ u, 1e-12)
    batch = np.stack([xi, 0.5 * xi])  # broadcasting over a leading axis
    np.testing.assert_allclose(g.jr_times_hessian(batch, v, u)[1], g.jr_times_hessian(0.5 * xi, v, u), atol=1e-14)


@pytest.mark.parametrize("group", GROUPS)
@pytest.mark.parametrize("angle", ANGLES)
def test_the_prior_factor_and_the_interpolated_and_extrapolated_jacobians_are_exact(group, angle, rng):
    g = GROUPS[group]
    kind, n = GroupState(g, 2), 3 * g.dim
    prior = LieGroupAccelPrior.wnoj(g, _qc(g))
    x1, x2 = _states(rng, g, angle)
    f = prior.prior_factor(X(0), X(1), 0.8)
    A, B = f.jacobians(x1, x2)
    assert_close(A, jacobian8_stacked(lambda d: f.error(kind.retract(x1, d), x2), n))
    assert_close(B, jacobian8_stacked(lambda d: f.error(x1, kind.retract(x2, d)), n))
    lam, psi, c = interpolation_terms(prior.sde, 0.0, 0.8, 0.3)
    x, J1, J2 = gp_accel.interpolate(x1, x2, lam, psi, c, group=g)

    def at(a, b):
        return kind.local(x, gp_accel.interpolate(a, b, lam, psi, c, group=g, jacobians=False))

    assert_close(J1, jacobian8_stacked(lambda d: at(kind.retract(x1, d), x2), n))
    assert_close(J2, jacobian8_stacked(lambda d: at(x1, kind.retract(x2, d)), n))
    phi = prior.sde.transition(0.6)
    xe, Je = gp_accel.extrapolate(x1, phi, 0.0, group=g)
    assert_close(
        Je,
        jacobian8_stacked(lambda d: kind.local(xe, gp_accel.extrapolate(kind.retract(x1, d), phi, 0.0, group=g)[0]), n),
    )


@pytest.mark.parametrize("name", ["se2-wnoj", "se3-wnoj", "se2-singer", "se3-singer"])
def test_a_drawn_step_leaves_its_own_noise_and_the_mean_leaves_none(name):
    """The local variables and their map back are inverses (the kinematics are exact, not truncated): a state
    drawn as γ₂ = Φ γ₁ + v + w leaves e = w; the prediction leaves 0; a constant twist interpolates onto itself."""
    prior = motion_prior(name, _qc(GROUPS[name[:3]]))
    g = prior.group  # SE3V for the table's SE(3) priors: poses [t; φ]
    rng = np.random.default_rng(7)
    x1 = np.r_[g.exp(rng.standard_normal(g.dim)), rng.standard_normal(g.dim), 0.3 * rng.standard_normal(g.dim)]
    w = 0.2 * rng.standard_normal(3 * g.dim)
    sde, dt = prior.sde, 0.7
    gamma = sde.transition(dt) @ gp_accel.local_start(x1, g) + sde.input_integral(dt) + w
    x2 = gp_accel.from_local(x1, gamma, g, jacobians=False)
    f = prior.prior_factor(X(0), X(1), dt)
    np.testing.assert_allclose(f.error(x1, x2), w, atol=1e-13)
    np.testing.assert_allclose(f.error(x1, prior.predict(x1, dt)), 0.0, atol=1e-13)
    steady = np.r_[x1[: g.size + g.dim], np.zeros(g.dim)]  # a constant twist, no acceleration
    later = lambda s: np.r_[g.compose(steady[: g.size], g.exp(s * steady[g.size : g.size + g.dim])), steady[g.size :]]
    if name.endswith("wnoj"):  # Singer's mean decays the acceleration, WNOJ's keeps a constant twist
        np.testing.assert_allclose(prior.interpolate(0.0, steady, 1.0, later(1.0), 0.4), later(0.4), atol=1e-13)


def test_the_table_refuses_a_qc_of_the_wrong_shape():
    for name, d in (("se2-wnoj", 3), ("se3-wnoj", 6), ("se3-singer", 6)):
        wrong = np.eye(9 - d)
        with pytest.raises(ShapeError, match=rf"qc must be \({d}, {d}\) on the body jerk"):
            motion_prior(name, wrong)
    prior = motion_prior("se3-wnoj", np.eye(6))
    assert prior.kind is GroupState(SE3V, 2) and prior.state_dim == 18 and len(prior.state_names) == 18
    assert motion_prior("se2-singer", np.eye(3), singer_time_constant=2.0).sde.A[6, 6] == -0.5
