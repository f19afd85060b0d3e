"""Every Lie group through one battery (manif's ``common_tester.h`` is the model): a new group joins in one line, GROUPS.

Oracles, none of them the group's own code: the matrix form of the group (compose is the matrix product, inverse the
matrix inverse, Exp the matrix exponential of hat(ξ), Ad conjugation); 8th-order central differences; and mpmath at
50 digits, where Exp is ``mp.expm(hat(ξ))``, J_r(ξ) = Σₖ (-ad ξ)ᵏ/(k+1)! summed to 1e-60 with ad built from hat and
vee, and the derivatives of J_r(ξ) v and J_r(ξ)⁻¹ v are summed term by term from the same series. Only the
conventions of ``lie.group`` are assumed: tangent [ρ; φ], right Jacobians, flat arrays, broadcasting.

**Finite differences.** The 8th-order central stencil with step h = 2⁻⁷ has truncation error h⁸ |f⁽⁹⁾| / 630 ≈ 2e-20
|f⁽⁹⁾| and rounding error at most Σ|cₖ| · 2ε · max|f| / h ≈ 2.1 · 2.2e-16 · 128 · max|f| = 6e-14 max|f|; each
check allows 50 times that rounding bound, scaled by the largest |f| on the stencil (a wrong Jacobian is off by O(1)).

**The angle sweep.** For each angle φ from 1e-12 to π (log-spaced, both signs, just either side of the series switch,
near π) ξ = φ r + t with r a rotation direction (one per angle, each in turn where there are several: SO(3), SE(3)
turn about x, y, z) and t zero or a translation direction, and v each basis vector: then every entry of Exp, J_r,
J_r⁻¹ and the two derivatives is one coefficient of the group's closed forms (SE(2): A, B, C, D, α, γ and their
derivatives; SO(3), SE(3): those of ``lie.coefficients``, written in the frame of the axis for exactly this reason)
or an exact constant, so the entry-wise relative error ≤ 1e-13 bounds every coefficient's. An entry that is zero in
50 digits must be zero to 1e-13 of the largest entry of its matrix. A group that lists its coefficients
(``coefficients``, ``coefficient_definitions``) has each checked against its definition at 460 angles besides.

**Angles of any size and shapes.** Exp turns by any finite angle exactly (Log's angle is the exact reduction, from
mpmath), Exp(ξ) = Exp(ξ/2)², the state retraction agrees; an infinite or NaN angle and an input of the wrong size
are refused, naming them.
"""

from __future__ import annotations

import pickle

import numpy as np
import pytest
import scipy.linalg
from requirements import optional_import

from steam_ref.errors import ShapeError, SteamError
from steam_ref.lie import SE2, SE3, SE3V, SO3, GroupState, LieGroup

mp = optional_import("mpmath", "test")

GROUPS = [SE2, SO3, SE3, SE3V]  # a new group joins the battery here

H = 2.0**-7  # the stencil's step (exact, so x ± kh is exact for |x| ≥ 1/16)
STENCIL = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])
FD_SLACK = 50 * np.abs(STENCIL).sum() * np.finfo(float).eps / H  # 50 × the stencil's rounding bound per unit of |f|
EPS = np.finfo(float).eps
REL = 1e-13  # the angle sweep's bound on every coefficient's relative error
pytestmark = pytest.mark.parametrize("group", GROUPS, ids=lambda g: g.name)


def derivative(f, x, h=H):
    """∂f/∂x by the 8th-order central stencil, and the largest |f| it read (for the rounding bound)."""
    cols, scale = [], 0.0
    for e in np.eye(len(x)):
        values = [np.asarray(f(x + (k - 4) * h * e)) for k in range(9)]
        scale = max(scale, max(float(np.max(np.abs(v))) for v in values))
        cols.append(sum(c * v for c, v in zip(STENCIL, values, strict=True) if c) / h)
    return np.stack(cols, axis=-1), scale


def assert_derivative(ours, f, x):
    numeric, scale = derivative(f, x)
    np.testing.assert_allclose(ours, numeric, rtol=0, atol=FD_SLACK * max(scale, 1.0))


def rotation_directions(group):
    """The basis vectors of the tangent that turn (group.angle > 0), each scaled to angle 1."""
    return [e / group.angle(e) for e in np.eye(group.dim) if group.angle(e) > 0]


def translation_directions(group):
    return [e for e in np.eye(group.dim) if group.angle(e) == 0]


def tangent(group, rng, angle, spread=2.0):
    """A random twist whose rotation angle is ``angle`` (translation ~ N(0, spread²))."""
    t = sum(spread * rng.standard_normal() * e for e in translation_directions(group))
    r = sum(rng.standard_normal() * e for e in rotation_directions(group))
    return t + angle * r / group.angle(r)


def elements(group, rng, n=6, max_angle=np.pi - 0.3):
    return [group.exp(tangent(group, rng, rng.uniform(-max_angle, max_angle))) for _ in range(n)]


def right_derivative(group, f, a):
    """∂ Log(f(a)⁻¹ f(a Exp δ)) / ∂δ at δ = 0: the right Jacobian of f, by differences (on a small Log)."""
    fa = f(a)
    return lambda d: group.log(group.between(fa, f(group.compose(a, group.exp(d)))))


# --- the group's axioms on its matrices --------------------------------------------------------------


def test_shapes_identity_and_one_object_per_group(group):
    assert isinstance(group, LieGroup) and type(group)() is group and pickle.loads(pickle.dumps(group)) is group
    kind = GroupState(group)
    assert kind is GroupState(group) and pickle.loads(pickle.dumps(kind)) is kind
    assert (kind.size, kind.dim, kind.name) == (group.size + group.dim, 2 * group.dim, group.name)
    xi = np.ones(group.dim)
    n = group.matrix(group.identity()).shape[-1]
    assert group.exp(xi).shape == (group.size,) and group.log(group.exp(xi)).shape == (group.dim,)
    assert group.hat(xi).shape == (n, n) and group.right_jacobian(xi).shape == (group.dim, group.dim)
    np.testing.assert_array_equal(group.matrix(group.identity()), np.eye(n))
    with pytest.raises(SteamError, match="bad"):
        group.check("bad", np.zeros(group.size + 1))
    with pytest.raises(SteamError, match="bad"):
        group.check("bad", np.full(group.size, np.nan))


def test_hat_and_vee_invert_each_other_and_exp_is_the_matrix_exponential(group, rng):
    for _ in range(10):
        xi = tangent(group, rng, rng.uniform(-3.1, 3.1))
        np.testing.assert_array_equal(group.vee(group.hat(xi)), xi)
        M = scipy.linalg.expm(group.hat(xi))
        np.testing.assert_allclose(group.matrix(group.exp(xi)), M, rtol=0, atol=50 * EPS * np.abs(M).max())


def test_compose_inverse_between_are_the_matrix_product_and_inverse(group, rng):
    a, b, c = elements(group, rng, 3)
    A, B = group.matrix(a), group.matrix(b)
    tol = {"rtol": 0, "atol": 20 * EPS * (1 + np.abs(A).max() * np.abs(B).max())}
    np.testing.assert_allclose(group.matrix(group.compose(a, b)), A @ B, **tol)
    np.testing.assert_allclose(group.matrix(group.inverse(a)), np.linalg.inv(A), **tol)
    np.testing.assert_allclose(group.matrix(group.between(a, b)), np.linalg.inv(A) @ B, **tol)
    np.testing.assert_allclose(
        group.matrix(group.compose(group.compose(a, b), c)), group.matrix(group.compose(a, group.compose(b, c))), **tol
    )
    np.testing.assert_allclose(group.matrix(group.compose(a, group.inverse(a))), np.eye(len(A)), **tol)
    np.testing.assert_allclose(group.matrix(group.compose(a, group.identity())), A, **tol)
    np.testing.assert_allclose(group.log(group.between(a, a)), np.zeros(group.dim), atol=tol["atol"])


def test_exp_and_log_invert_each_other(group, rng):
    for angle in (0.0, 1e-9, 0.3, group.series_below, 2.0, np.pi - 1e-3):
        xi = tangent(group, rng, angle)
        np.testing.assert_allclose(group.log(group.exp(xi)), xi, rtol=0, atol=20 * EPS * (1 + np.abs(xi).max()))
    for a in elements(group, rng, max_angle=np.pi):
        back = group.exp(group.log(a))
        np.testing.assert_allclose(group.matrix(back), group.matrix(a), rtol=0, atol=20 * EPS * (1 + np.abs(a).max()))


def test_the_adjoint_moves_a_twist_through_an_element(group, rng):
    for a in elements(group, rng, 4):
        xi = tangent(group, rng, 0.7)
        A = group.matrix(a)
        np.testing.assert_allclose(
            group.hat(group.adjoint(a) @ xi), A @ group.hat(xi) @ np.linalg.inv(A), atol=1e-13 * (1 + np.abs(A).max())
        )
        lhs = group.compose(group.compose(a, group.exp(xi)), group.inverse(a))
        np.testing.assert_allclose(group.matrix(lhs), group.matrix(group.exp(group.adjoint(a) @ xi)), atol=1e-13)


# --- Jacobians against 8th-order central differences -------------------------------------------------


def test_compose_inverse_between_jacobians_and_values_from_one_call(group, rng):
    for a, b in zip(elements(group, rng, 4), elements(group, rng, 4), strict=True):
        value, Ja, Jb = group.compose(a, b, jacobians=True)
        np.testing.assert_array_equal(value, group.compose(a, b))
        assert_derivative(Ja, right_derivative(group, lambda z, b=b: group.compose(z, b), a), np.zeros(group.dim))
        assert_derivative(Jb, right_derivative(group, lambda z, a=a: group.compose(a, z), b), np.zeros(group.dim))
        value, J = group.inverse(a, jacobians=True)
        np.testing.assert_array_equal(value, group.inverse(a))
        assert_derivative(J, right_derivative(group, group.inverse, a), np.zeros(group.dim))
        value, Ja, Jb = group.between(a, b, jacobians=True)
        np.testing.assert_array_equal(value, group.between(a, b))
        assert_derivative(Ja, right_derivative(group, lambda z, b=b: group.between(z, b), a), np.zeros(group.dim))
        assert_derivative(Jb, right_derivative(group, lambda z, a=a: group.between(a, z), b), np.zeros(group.dim))


ANGLES = (0.0, 1e-7, 0.4, 2.2, 3.0, np.pi)


def _switch(group):
    return (np.nextafter(group.series_below, 0), group.series_below, np.nextafter(group.series_below, 9))


def test_the_right_jacobian_and_its_inverse_are_what_they_define(group, rng):
    """Exp(ξ + dξ) = Exp(ξ) Exp(J_r(ξ) dξ) and Log(Exp(ξ) Exp(δ)) = ξ + J_r(ξ)⁻¹ δ, to first order."""
    for angle in ANGLES + _switch(group):
        xi = tangent(group, rng, angle)
        E = group.exp(xi)
        jr = group.right_jacobian(xi)
        assert_derivative(jr, lambda z, E=E: group.log(group.between(E, group.exp(z))), xi)
        jinv = group.right_jacobian_inverse(xi)
        if group.angle(xi) < np.pi - 0.1:  # (the stencil reaches 4h = 0.03 rad: Log must not wrap at ±π inside it)
            assert_derivative(jinv, lambda d, E=E: group.log(group.compose(E, group.exp(d))), 0 * xi)
        np.testing.assert_allclose(jinv @ jr, np.eye(group.dim), rtol=0, atol=50 * EPS * np.abs(jr).max() ** 2)


def test_the_derivatives_of_jr_v_and_jr_inverse_v_against_differences(group, rng):
    for angle in ANGLES + _switch(group):
        xi, v = tangent(group, rng, angle), rng.standard_normal(group.dim)
        assert_derivative(group.jr_times_jacobian(xi, v), lambda z, v=v: group.right_jacobian(z) @ v, xi)
        assert_derivative(
            group.jr_inverse_times_jacobian(xi, v), lambda z, v=v: group.right_jacobian_inverse(z) @ v, xi
        )


def test_the_generic_forms_of_the_base_class_agree_with_the_groups_own(group, rng):
    """What LieGroup derives for any group (J_r⁻¹ by inversion, ∂(J_r⁻¹v)/∂ξ from ∂(J_r v)/∂ξ, between by compose
    and inverse) against the group's closed forms."""
    for angle in ANGLES + _switch(group):
        xi, v = tangent(group, rng, angle), rng.standard_normal(group.dim)
        scale = 1 + np.abs(group.right_jacobian_inverse(xi)).max() ** 3 * (1 + np.abs(v).max())
        np.testing.assert_allclose(
            LieGroup.right_jacobian_inverse(group, xi), group.right_jacobian_inverse(xi), atol=20 * EPS * scale
        )
        np.testing.assert_allclose(
            LieGroup.jr_inverse_times_jacobian(group, xi, v),
            group.jr_inverse_times_jacobian(xi, v),
            atol=50 * EPS * scale,
        )
    for a, b in zip(elements(group, rng, 4), elements(group, rng, 4), strict=True):
        np.testing.assert_allclose(
            group.matrix(LieGroup._between(group, a, b)),
            group.matrix(group.between(a, b)),
            atol=50 * EPS * (1 + np.abs(a).max() + np.abs(b).max()),
        )


def test_a_local_variable_and_its_jacobians_from_one_call(group, rng):
    """log_between(a, b, v): ξ = Log(a⁻¹b), J_r(ξ)⁻¹ v and their Jacobians against the group's methods one at a time,
    the base class's generic form and differences; compose_exp(a, ξ) against compose(a, exp(ξ))."""
    zero = np.zeros(group.dim)
    for angle in ANGLES + _switch(group):
        a, v = elements(group, rng, 1)[0], rng.standard_normal(group.dim)
        b = group.compose(a, group.exp(tangent(group, rng, angle)))
        xi, u, da, db, du = group.log_between(a, b, v, jacobians=True)
        np.testing.assert_array_equal(np.concatenate([xi, u]), np.concatenate(group.log_between(a, b, v)))
        scale = 1 + np.abs(xi).max() ** 2 + np.abs(v).max() * (1 + np.abs(xi).max()) ** 2
        for ours, generic in zip(
            (xi, u, da, db, du), LieGroup.log_between(group, a, b, v, jacobians=True), strict=True
        ):
            np.testing.assert_allclose(ours, generic, rtol=0, atol=100 * EPS * scale)
        np.testing.assert_allclose(xi, group.log(group.between(a, b)), rtol=0, atol=20 * EPS * scale)
        if group.angle(xi) < np.pi - 0.1:  # (the stencil must not carry Log across ±π)
            assert_derivative(da, lambda d, b=b, a=a: group.log(group.between(group.compose(a, group.exp(d)), b)), zero)
            assert_derivative(db, lambda d, b=b, a=a: group.log(group.between(a, group.compose(b, group.exp(d)))), zero)
            assert_derivative(du, lambda z, v=v: group.right_jacobian_inverse(z) @ v, xi)
        step = tangent(group, rng, angle)
        np.testing.assert_allclose(
            group.compose_exp(a, step),
            group.compose(a, group.exp(step)),
            rtol=0,
            atol=20 * EPS * (1 + np.abs(step).max()),
        )


def test_every_method_broadcasts_over_leading_axes(group, rng):
    xis = np.stack([tangent(group, rng, a) for a in (0.0, 0.3, 1.5, 3.0, 1e-8, 2.5)]).reshape(2, 3, group.dim)
    vs = rng.standard_normal((2, 3, group.dim))
    a = group.exp(xis)
    b = group.exp(xis[::-1])
    one_at_a_time = {
        "exp": (group.exp, (xis,)),
        "log": (group.log, (a,)),
        "hat": (group.hat, (xis,)),
        "matrix": (group.matrix, (a,)),
        "right_jacobian": (group.right_jacobian, (xis,)),
        "right_jacobian_inverse": (group.right_jacobian_inverse, (xis,)),
        "adjoint": (group.adjoint, (a,)),
        "jr_times_jacobian": (group.jr_times_jacobian, (xis, vs)),
        "jr_inverse_times_jacobian": (group.jr_inverse_times_jacobian, (xis, vs)),
        "compose": (lambda x, y: group.compose(x, y, jacobians=True), (a, b)),
        "inverse": (lambda x: group.inverse(x, jacobians=True), (a,)),
        "between": (lambda x, y: group.between(x, y, jacobians=True), (a, b)),
        "log_between": (lambda x, y, z: group.log_between(x, y, z, jacobians=True), (a, b, vs)),
        "compose_exp": (group.compose_exp, (a, xis)),
    }
    for name, (f, args) in one_at_a_time.items():
        batch = f(*args)
        batch = batch if isinstance(batch, tuple) else (batch,)
        for i, j in np.ndindex(2, 3):
            single = f(*(arg[i, j] for arg in args))
            for got, want in zip(batch, single if isinstance(single, tuple) else (single,), strict=True):
                np.testing.assert_array_equal(got[i, j], want, err_msg=name)


def test_the_series_switch_is_continuous(group, rng):
    """Each coefficient is its series just below series_below and its closed form at it and above: the two agree
    to the rounding of either (the functions themselves move by about an ulp across the switch)."""
    r = rotation_directions(group)[0]
    t = sum(translation_directions(group)) + 0 * r
    below, at, above = ((s * r + t) for s in _switch(group))
    v = np.linspace(0.5, -0.7, group.dim)
    for f in (
        group.exp,
        group.right_jacobian,
        group.right_jacobian_inverse,
        lambda z: group.jr_times_jacobian(z, v),
        lambda z: group.jr_inverse_times_jacobian(z, v),
    ):
        for x, y in ((below, at), (at, above)):
            np.testing.assert_allclose(f(x), f(y), rtol=0, atol=20 * EPS * np.abs(f(y)).max())
    np.testing.assert_allclose(group.log(group.exp(below)), below, atol=20 * EPS)


def test_the_state_kind_retracts_on_the_right_and_local_inverts_it(group, rng):
    kind = GroupState(group)
    n = group.size
    for _ in range(10):
        x = np.concatenate([elements(group, rng, 1)[0], rng.standard_normal(group.dim)])
        d = np.concatenate([tangent(group, rng, rng.uniform(-3, 3)), rng.standard_normal(group.dim)])
        y = kind.retract(x, d)
        np.testing.assert_allclose(y[:n], group.compose(x[:n], group.exp(d[: group.dim])))
        np.testing.assert_allclose(kind.local(x, y), d, atol=1e-12)
        np.testing.assert_allclose(kind.retract(x, kind.local(x, y)), y, atol=1e-12)
    xs = [np.concatenate([e, rng.standard_normal(group.dim)]) for e in elements(group, rng, 5)]
    ds = [np.concatenate([tangent(group, rng, rng.uniform(-3, 3)), rng.standard_normal(group.dim)]) for _ in xs]
    for got, x, d in zip(kind.retract_many(xs, ds), xs, ds, strict=True):  # the solver's batched retraction
        np.testing.assert_array_equal(got, kind.retract(x, d))


# --- a planar robot's pose and velocity -----------------------------------------------------------------

PLANAR = ("from_planar", "to_planar", "body_twist", "world_velocity")


def _planar_calls(group):
    pose, velocity = np.array([1.5, -0.4, 2.2]), np.array([0.7, -0.2, 0.9])
    return {
        "from_planar": lambda: group.from_planar(pose),
        "to_planar": lambda: group.to_planar(group.identity()),
        "body_twist": lambda: group.body_twist(group.identity(), velocity),
        "world_velocity": lambda: group.world_velocity(group.identity(), np.ones(group.dim)),
        "turned": lambda: GroupState(group).turned(np.concatenate([group.identity(), np.zeros(group.dim)]), 0.3),
    }


def test_the_base_class_refuses_a_planar_pose_by_the_groups_name(group):
    """What a group does not write is refused, naming the group: never a silent SE(2) assumption."""
    for name in PLANAR:
        with pytest.raises(SteamError, match=rf"{group!r} holds no planar pose"):
            getattr(LieGroup, name)(group, *([np.zeros(3)] * (2 if name in ("body_twist", "world_velocity") else 1)))
    names = group.state_names()
    assert len(names) == group.size + group.dim and len(set(names)) == len(names)


def test_a_planar_pose_and_velocity_through_the_group(group, rng):
    """A group that holds a planar pose: the pose round-trips (heading wrapped to (-π, π]); the world velocity is
    the derivative of the planar pose as the element moves by its body twist, T Exp(h ϖ) (8th-order differences),
    and body_twist inverts it; a state turned about the world's origin is the left action of the turn, its twist
    kept. A group that holds none refuses every one of these, naming itself."""
    if type(group).from_planar is LieGroup.from_planar:  # the group writes no planar pose
        for call in _planar_calls(group).values():
            with pytest.raises(SteamError, match=rf"{group!r} holds no planar pose"):
                call()
        return
    for _ in range(6):
        pose = np.array([*rng.normal(0, 3, 2), rng.uniform(-3.0, 3.0)])
        np.testing.assert_allclose(group.to_planar(group.from_planar(pose)), pose, rtol=0, atol=1e-15)
        turned = group.to_planar(group.from_planar(pose + [0.0, 0.0, 4 * np.pi]))
        np.testing.assert_allclose(turned, pose, rtol=0, atol=1e-14)  # the heading wrapped back
        assert -np.pi < group.to_planar(group.from_planar([0.0, 0.0, 3 * np.pi / 2]))[2] <= np.pi
        a = elements(group, rng, 1, max_angle=2.5)[0]
        w = rng.normal(0, 1, group.dim)
        velocity = group.world_velocity(a, w)
        np.testing.assert_allclose(group.body_twist(a, velocity), w, rtol=0, atol=1e-14)
        moved = lambda h, a=a, w=w: group.to_planar(group.compose(a, group.exp(h[0] * w)))
        assert_derivative(velocity[:, None], moved, np.zeros(1))
        kind, angle = GroupState(group), rng.uniform(-3, 3)
        x = np.concatenate([a, w])
        y = kind.turned(x, angle)
        left = group.compose(group.from_planar([0.0, 0.0, angle]), a)  # the world turned: Rz(angle) T
        np.testing.assert_allclose(group.log(group.between(left, y[: group.size])), 0.0, atol=1e-13)
        np.testing.assert_array_equal(y[group.size :], w)


# --- angles of any size, inputs of the wrong shape -------------------------------------------------------

HUGE = (7.0, -40.0, 1e6, 2.1097e15, 1e16, -3e17, 1e20, 1e300)


def _reduced(theta):
    """θ reduced to (-π, π] exactly (mpmath with the digits |θ| needs), as a float."""
    with mp.workdps(360):
        t = mp.mpf(float(theta))
        r = t - 2 * mp.pi * mp.nint(t / (2 * mp.pi))
        return float(r if r > -mp.pi else r + 2 * mp.pi)


def test_angles_of_any_size_are_reduced_exactly_and_exp_log_and_the_retraction_agree(group, rng):
    """Exp of a twist turning by any finite angle is the rotation by that angle reduced exactly: its Log turns by
    the reduced angle, Exp(ξ) = Exp(ξ/2)² (heading and translation agree), and the state retraction turns by it
    too. (SE(2) subtracted a rounded 2π, losing |θ|·2.4e-17 in the heading but not in the translation.)"""
    kind = GroupState(group)
    x = np.concatenate([elements(group, rng, 1)[0], np.zeros(group.dim)])
    for theta in HUGE:
        for r in rotation_directions(group):
            want = abs(_reduced(theta))
            E = group.exp(theta * r)
            assert abs(float(group.angle(group.log(E))) - want) <= 4 * EPS * max(want, 1.0), (theta, r)
            xi = theta * r + sum(translation_directions(group)) + 0 * r
            half = group.exp(xi / 2)
            M = group.matrix(group.exp(xi))
            np.testing.assert_allclose(
                M, group.matrix(group.compose(half, half)), rtol=0, atol=20 * EPS * np.abs(M).max()
            )
            moved = kind.retract(x, np.concatenate([theta * r, np.zeros(group.dim)]))
            turn = group.log(group.between(x[: group.size], moved[: group.size]))
            assert abs(float(group.angle(turn)) - want) <= 8 * EPS * max(want, 1.0), (theta, r)


def test_an_angle_that_cannot_be_reduced_is_refused(group):
    turn = rotation_directions(group)[0]
    for bad in (np.inf, -np.inf, np.nan):
        with pytest.raises(ShapeError, match="angle"):
            group.exp(np.where(turn != 0, bad, 0.0))


def test_every_kernel_checks_its_inputs_shapes(group):
    """A twist or an element with one number too many (a 4-vector for an SE(2) pose) is refused, naming it."""
    xi, a = np.zeros(group.dim), group.identity()
    long_xi, long_a = np.zeros(group.dim + 1), np.zeros(group.size + 1)
    n = group.hat(xi).shape[-1]
    calls = {
        "xi": [group.exp, group.hat, group.angle, group.right_jacobian, group.right_jacobian_inverse],
        "a": [group.log, group.matrix, group.adjoint, group.inverse],
    }
    for name, fs in calls.items():
        for f in fs:
            with pytest.raises(ShapeError, match=rf"^{name} must be"):
                f(long_xi if name == "xi" else long_a)
    for f in (group.jr_times_jacobian, group.jr_inverse_times_jacobian):
        with pytest.raises(ShapeError, match=r"^xi must be"):
            f(long_xi, xi)
        with pytest.raises(ShapeError, match=r"^v must be"):
            f(xi, long_xi)
    for f in (group.compose, group.between):
        with pytest.raises(ShapeError, match=r"^a must be"):
            f(long_a, a)
        with pytest.raises(ShapeError, match=r"^b must be"):
            f(a, long_a)
    with pytest.raises(ShapeError, match=r"^X must be"):
        group.vee(np.zeros((n + 1, n + 1)))
    with pytest.raises(ShapeError, match=r"^xi must be an array of numbers"):
        group.exp("1, 2, 3")


def test_the_planar_calls_check_their_inputs_shapes(group):
    """The planar calls (a group that writes them: SE(2)) refuse a 4-vector pose, element or twist and a 2-number
    velocity, naming it, as the kernels do (they took the 4-vector and handed it on, or failed with IndexError), and a
    pose that is no number or is NaN (from_planar is how a pose enters a state)."""
    if type(group).from_planar is LieGroup.from_planar:  # the group writes no planar pose (the test above)
        return
    a, long_a, long_xi = group.identity(), np.zeros(group.size + 1), np.zeros(group.dim + 1)
    with pytest.raises(ShapeError, match=r"^pose must be a planar pose \[x, y, θ\] of .* got shape \(4,\)"):
        group.from_planar(np.zeros(4))
    with pytest.raises(ShapeError, match=r"^pose must be an array of numbers, got pose='abc'"):
        group.from_planar("abc")
    with pytest.raises(ShapeError, match=r"^pose must be finite, but pose\[2\] = nan"):
        group.from_planar([0.0, 0.0, np.nan])
    with pytest.raises(ShapeError, match=r"^a must be an element of"):
        group.to_planar(long_a)
    with pytest.raises(ShapeError, match=r"^velocity must be a planar velocity .* got shape \(2,\)"):
        group.body_twist(a, [1.0, 0.0])
    with pytest.raises(ShapeError, match=r"^a must be an element of"):
        group.body_twist(long_a, [1.0, 0.0, 0.0])
    with pytest.raises(ShapeError, match=r"^twist must be a twist of"):
        group.world_velocity(a, long_xi)
    poses = np.array([[1.0, 2.0, 3.5], [0.0, 0.0, -0.5]])  # stacks still pass, θ wrapped
    np.testing.assert_allclose(group.to_planar(group.from_planar(poses)), [[1.0, 2.0, 3.5 - 2 * np.pi], poses[1]])


# --- the angle sweep against 50 digits -----------------------------------------------------------------


def _hat_vee(group):
    """hat's generators and vee's coefficients (both maps are linear, so the group's own on basis vectors and
    elementary matrices give them exactly)."""
    gens = np.array([group.hat(e) for e in np.eye(group.dim)])  # (dim, n, n), entries 0 and ±1
    n = gens.shape[-1]
    coeffs = np.zeros((group.dim, n, n))  # vee(M)ₖ = Σᵢⱼ coeffs[k, i, j] Mᵢⱼ
    for i, j in np.ndindex(n, n):
        E = np.zeros((n, n))
        E[i, j] = 1.0
        coeffs[:, i, j] = group.vee(E)
    return gens, coeffs


def _mp_tools(gens, coeffs):
    """hat and ad(ξ) = [ξ^, ·]ᵛ in mpf, from hat's generators and vee's coefficients."""
    G, V = _mp_array(gens), _mp_array(coeffs)

    def hat(xi):
        return np.einsum("k,kij->ij", xi, G)

    def ad(xi):
        X = hat(xi)
        return np.stack([np.einsum("kij,ij->k", V, X @ G[j] - G[j] @ X) for j in range(len(gens))], axis=1)

    return hat, ad


def _mp_array(a):
    return np.vectorize(lambda v: mp.mpf(float(v)), otypes=[object])(np.asarray(a, dtype=float))


def _left_multiplier(A):
    """X ↦ A X for object arrays, summing over A's nonzero entries only (on the sweep's axis-aligned twists ad(ξ) and
    ad(eⱼ) are sparse, and a product of 50-digit numbers costs a microsecond)."""
    terms = [[(k, A[i, k]) for k in range(A.shape[1]) if A[i, k] != 0] for i in range(A.shape[0])]
    zero = mp.mpf(0)

    def times(X):
        out = np.full(X.shape, zero, dtype=object)
        for i, row in enumerate(terms):
            for k, a in row:  # (ad(eⱼ)'s entries are ±1: no product)
                out[i] = out[i] + X[k] if a == 1 else out[i] - X[k] if a == -1 else out[i] + X[k] * a
        return out

    return times


_MP_REFERENCES: dict[tuple, dict[str, np.ndarray]] = {}
_MP_BASES: dict[tuple, tuple] = {}


def _mp_basis(gens, coeffs):
    """``_mp_tools``' hat and ad, and X ↦ ad(eⱼ) X for each basis vector eⱼ: the same for every ξ of the sweep, so
    made once per hat, vee and digits (their entries are small integers, exact in any precision). Read-only."""
    key = (gens.tobytes(), coeffs.tobytes(), gens.shape, mp.mp.dps)
    if key not in _MP_BASES:
        hat, ad = _mp_tools(gens, coeffs)
        _MP_BASES[key] = hat, ad, [_left_multiplier(ad(_mp_array(e))) for e in np.eye(len(gens))]
    return _MP_BASES[key]


def _mp_reference(group, xi, vs):
    """``_mp_series`` for the group's hat and vee, computed once per hat, vee, ξ, v's and digits (a pure function of
    them: SE3 and SE3V, the same group with the same hat, vee and sweep, share each reference). Read-only."""
    gens, coeffs = _hat_vee(group)
    key = (gens.tobytes(), coeffs.tobytes(), np.asarray(xi, float).tobytes(), np.asarray(vs, float).tobytes())
    key += (gens.shape, len(vs), mp.mp.dps)
    if key not in _MP_REFERENCES:
        _MP_REFERENCES[key] = _mp_series(gens, coeffs, xi, vs)
    return _MP_REFERENCES[key]


def _mp_series(gens, coeffs, xi, vs):
    """Exp(ξ)'s matrix, J_r(ξ), J_r(ξ)⁻¹ and, for each v, ∂(J_r v)/∂ξ and ∂(J_r⁻¹ v)/∂ξ, in mpmath.

    J_r = Σₖ (-1)ᵏ adᵏ / (k+1)!, with ∂(adᵏ)/∂ξⱼ = ad ∂(adᵏ⁻¹)/∂ξⱼ + ad(eⱼ) adᵏ⁻¹ summed alongside; then
    ∂(J_r v)/∂ξⱼ = (∂J_r/∂ξⱼ) v and ∂(J_r⁻¹ v)/∂ξⱼ = -J_r⁻¹ (∂J_r/∂ξⱼ) J_r⁻¹ v (d(J⁻¹) = -J⁻¹ dJ J⁻¹).
    """
    d = len(gens)
    hat, ad, basis = _mp_basis(gens, coeffs)
    x = _mp_array(xi)
    A = _left_multiplier(ad(x))
    eye = _mp_array(np.eye(d))
    power, dpower = eye, [_mp_array(np.zeros((d, d))) for _ in range(d)]
    J, dJ = eye.copy(), [m.copy() for m in dpower]
    tiny, c, k = mp.mpf(10) ** -(mp.mp.dps + 10), mp.mpf(1), 0
    while True:
        k += 1
        dpower = [A(dpower[j]) + basis[j](power) for j in range(d)]
        power = A(power)
        c = -c / (k + 1)
        J = J + power * c  # (array first: mpf * array would try to convert the array)
        dJ = [dJ[j] + dpower[j] * c for j in range(d)]
        if k > 5 and k % 3 == 0 and abs(c) * max(abs(v) for m in [power, *dpower] for v in m.ravel()) < tiny:
            break
    Jinv = np.array(mp.inverse(mp.matrix(J.tolist())).tolist(), dtype=object)
    out = {"exp": np.array(mp.expm(mp.matrix(hat(x).tolist())).tolist(), dtype=object)}
    out |= {"right_jacobian": J, "right_jacobian_inverse": Jinv}
    for m, v in enumerate(vs):
        vm = _mp_array(v)
        out[f"jr_times_jacobian v{m}"] = np.stack([dJ[j] @ vm for j in range(d)], axis=1)
        u = Jinv @ vm
        out[f"jr_inverse_times_jacobian v{m}"] = -np.stack([Jinv @ (dJ[j] @ u) for j in range(d)], axis=1)
    return out


def _sweep(group):
    magnitudes = np.r_[np.logspace(-12, np.log10(np.pi), 25)[:-1], _switch(group), np.pi - 1e-3, np.pi - 1e-8]
    return np.r_[magnitudes, np.nextafter(np.pi, 0), np.pi, -magnitudes[::3]]


def test_every_coefficient_against_50_digits_from_1e_12_to_pi(group):
    vs = list(np.eye(group.dim))
    worst, failures = 0.0, []
    with mp.workdps(50):
        turns = rotation_directions(group)
        for n, phi in enumerate(_sweep(group)):
            r = turns[n % len(turns)]  # one rotation axis per angle, each in turn (SO(3), SE(3): x, y, z)
            for t in [np.zeros(group.dim)] + translation_directions(group):
                xi = phi * r + t
                ref = _mp_reference(group, xi, vs)
                ours = {
                    "exp": group.matrix(group.exp(xi)),
                    "right_jacobian": group.right_jacobian(xi),
                    "right_jacobian_inverse": group.right_jacobian_inverse(xi),
                }
                for m, v in enumerate(vs):
                    ours[f"jr_times_jacobian v{m}"] = group.jr_times_jacobian(xi, v)
                    ours[f"jr_inverse_times_jacobian v{m}"] = group.jr_inverse_times_jacobian(xi, v)
                for name, want in ref.items():
                    # 50 digits rounded to doubles: that rounding (1.1e-16 relative) is 1/900 of REL
                    want = np.vectorize(float, otypes=[float])(want)
                    got, scale = ours[name], np.abs(want).max()
                    zero = np.abs(want) <= scale * 1e-40  # zero in 50 digits: zero to REL of the matrix
                    with np.errstate(divide="ignore", invalid="ignore"):
                        err = np.where(zero, np.abs(got) / (scale or 1.0), np.abs(got - want) / np.abs(want))
                    worst = max(worst, float(err.max()))
                    for i, j in zip(*np.nonzero(err > REL), strict=True):
                        failures.append(f"{name}[{i}, {j}] at ξ={xi.tolist()}: relative error {err[i, j]:.2e}")
    assert not failures, f"{len(failures)} entries off by more than {REL}:\n" + "\n".join(failures[:20])
    assert worst <= REL


def _dense_angles(group):
    """1e-12 to 1 log-spaced, then every 0.0066 rad from 0.5 to π, and 1 ulp either side of the series switch."""
    return np.r_[np.logspace(-12, 0, 49), np.linspace(0.5, np.pi, 400), _switch(group), np.nextafter(np.pi, 0), np.pi]
