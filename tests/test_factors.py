"""Every factor's Jacobians against central differences, batching against single evaluation,
whitening against the Mahalanobis norm, and the interpolated factor (Eq. 29) against dense
marginalisation of an explicit state at τ."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import pytest
from finite_differences import numerical_jacobians

import steam_ref as sr
from steam_ref.gp import interpolation_matrices
from steam_ref.linear import LinearSystem, Ordering, linearize

QC = np.diag([0.3, 0.5, 0.7])
X1, X2, LM = sr.X(1), sr.X(2), sr.L(1)


def make_factors(rng):
    """One factor of each kind, with generic (random, non-zero) parameters."""
    cov = rng.normal(size=(3, 3))
    cov = cov @ cov.T + np.eye(3)
    inner_range = sr.RangeFactor.create(sr.X(-1), LM, 4.0, 0.3)
    inner_vel = sr.VelocityFactor.create(sr.X(-1), rng.normal(size=3), [0.5, 0.2, 0.1])
    return [
        sr.GPPriorFactor.wnoa(X1, X2, 0.7, QC),
        sr.PriorFactor.create(X1, rng.normal(size=6), rng.uniform(0.5, 2, 6)),
        sr.PriorFactor.create(LM, rng.normal(size=2), [1.0, 2.0]),
        sr.OdometryFactor.create(X1, rng.normal(size=2), [0.1, 0.2]),
        sr.VelocityFactor.create(X1, rng.normal(size=3), cov),
        sr.RangeFactor.create(X1, LM, 3.0, 0.5),
        sr.BearingFactor.create(X1, LM, 0.4, 0.1),
        sr.BearingRangeFactor.create(X1, LM, 0.4, 3.0, [0.1, 0.5]),
        sr.InterpolatedFactor.create(inner_range, X1, X2, 1.0, 2.5, 1.6, QC),
        sr.InterpolatedFactor.create(inner_vel, X1, X2, 1.0, 2.5, 2.2, QC),
    ]


def random_point(rng, factor):
    return [rng.normal(size=d) * (3.0 if i > 0 else 1.0) for i, d in enumerate(factor.key_dims)]


@pytest.mark.parametrize("index", range(10))
def test_jacobians_match_central_differences(rng, index):
    factor = make_factors(rng)[index]
    for _ in range(3):
        xs = random_point(rng, factor)
        analytic = factor.jacobians(*xs)
        numeric = numerical_jacobians(factor.error, *xs)
        assert len(analytic) == len(factor.keys)
        for a, n in zip(analytic, numeric, strict=True):
            np.testing.assert_allclose(a, n, rtol=1e-6, atol=1e-8)


@pytest.mark.parametrize("index", range(10))
def test_stacked_batch_equals_one_by_one(rng, index):
    proto = make_factors(rng)[index]
    factors = [make_factors(np.random.default_rng(s))[index] for s in range(4)]
    points = [random_point(rng, proto) for _ in factors]
    batch = type(proto).stack(factors)
    xs = [np.stack([p[k] for p in points]) for k in range(len(proto.key_dims))]
    errors, jacs = batch.error(*xs), batch.jacobians(*xs)
    for i, (f, p) in enumerate(zip(factors, points, strict=True)):
        np.testing.assert_allclose(errors[i], f.error(*p), rtol=1e-13, atol=1e-13)
        for J, Ji in zip(jacs, f.jacobians(*p), strict=True):
            np.testing.assert_allclose(J[i], Ji, rtol=1e-13, atol=1e-13)


def test_whitened_norm_is_mahalanobis(rng):
    cov = rng.normal(size=(3, 3))
    cov = cov @ cov.T + 0.5 * np.eye(3)
    f = sr.VelocityFactor.create(X1, rng.normal(size=3), cov)
    x = rng.normal(size=6)
    e = f.error(x)
    np.testing.assert_allclose(np.sum(f.whitened_error(x) ** 2), e @ np.linalg.solve(cov, e), rtol=1e-12)
    assert np.allclose(np.tril(f.sqrt_information, -1), 0.0)


def test_gp_prior_error_is_eq22(rng):
    dt = 0.8
    f = sr.GPPriorFactor.wnoa(X1, X2, dt, QC)
    x1, x2 = rng.normal(size=6), rng.normal(size=6)
    phi = np.eye(6) + np.diag(np.full(3, dt), 3)  # written out: p' = p + dt v, v' = v
    e = x2 - phi @ x1
    q = np.block([[dt**3 / 3 * QC, dt**2 / 2 * QC], [dt**2 / 2 * QC, dt * QC]])
    np.testing.assert_allclose(f.error(x1, x2), e, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(np.sum(f.whitened_error(x1, x2) ** 2), e @ np.linalg.solve(q, e), rtol=1e-10)


def _wnoa_information(dt: float, qc: np.ndarray) -> np.ndarray:
    """Q(Δt)⁻¹ of the WNOA prior, Q written out  [YIB Eq. 17; derivations §1]."""
    return np.linalg.inv(np.block([[dt**3 / 3 * qc, dt**2 / 2 * qc], [dt**2 / 2 * qc, dt * qc]]))


@pytest.mark.parametrize("how", ["a read-only view of a writeable array", "made writeable, changed, read-only again"])
def test_a_wnoa_prior_factor_whitens_by_the_values_qc_holds_now(how):
    """A read-only Qc met before whose values changed since (through the writeable array it views, or made
    writeable again): the factor whitens by Q(Δt) of its values now, not the first ones (the memo keyed by Qc's
    identity gave the old W back)."""
    dt, base = 0.37, np.diag([0.5, 0.25, 2.0])
    if how.startswith("a read-only view"):
        qc = base.view()
        qc.flags.writeable = False
    else:
        qc = base
        qc.flags.writeable = False
    before = sr.GPPriorFactor.wnoa(X1, X2, dt, qc).sqrt_information
    np.testing.assert_allclose(before.T @ before, _wnoa_information(dt, np.array(qc)), rtol=1e-10)
    base.flags.writeable = True
    base[:] = np.diag([3.0, 0.1, 0.7])
    qc.flags.writeable = False
    W = sr.GPPriorFactor.wnoa(X1, X2, dt, qc).sqrt_information
    np.testing.assert_allclose(W.T @ W, _wnoa_information(dt, np.array(qc)), rtol=1e-10)


def test_measurement_models_by_hand():
    x = np.array([1.0, 2.0, np.pi / 6, 0.4, -0.2, 0.05])
    c, s = np.cos(np.pi / 6), np.sin(np.pi / 6)
    v = sr.VelocityFactor.create(X1, [0, 0, 0], 1.0).error(x)
    np.testing.assert_allclose(v, [c * 0.4 - s * 0.2, -s * 0.4 - c * 0.2, 0.05], rtol=1e-14)
    o = sr.OdometryFactor.create(X1, [0, 0], 1.0).error(x)
    np.testing.assert_allclose(o, [c * 0.4 - s * 0.2, 0.05], rtol=1e-14)
    r = sr.RangeFactor.create(X1, LM, 0.0, 1.0).error(x, np.array([4.0, 6.0]))
    np.testing.assert_allclose(r, [5.0], rtol=1e-14)
    b = sr.BearingFactor.create(X1, LM, 0.0, 1.0).error(x, np.array([1.0, 5.0]))
    np.testing.assert_allclose(b, [np.pi / 2 - np.pi / 6], rtol=1e-14)


def test_bearing_error_wraps():
    x = np.array([0.0, 0.0, 0.0, 0, 0, 0])
    f = sr.BearingFactor.create(X1, LM, np.pi - 0.01, 1.0)
    e = f.error(x, np.array([-1.0, -0.01]))  # true bearing just below -π
    assert abs(e[0]) < 0.05


@pytest.mark.parametrize("loss", [sr.Huber(1.3), sr.Tukey(2.5)])
def test_robust_weight_is_rho_prime_over_s(loss):
    s = np.array([0.3, 1.0, 1.9, 2.4, 4.0])
    eps = 1e-6
    rho_prime = (loss.rho(s + eps) - loss.rho(s - eps)) / (2 * eps)
    np.testing.assert_allclose(loss.weight(s), rho_prime / s, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(loss.rho(np.array([1e-4])), [0.5e-8], rtol=1e-6)


def test_robust_linearization_scales_by_sqrt_weight(rng):
    values = sr.Values({X1: rng.normal(size=6), LM: np.array([3.0, 4.0])})
    plain = sr.RangeFactor.create(X1, LM, 1.0, 0.5)
    robust = sr.RangeFactor.create(X1, LM, 1.0, 0.5, loss=sr.Tukey(15.0))
    (gp,), (gr,) = linearize([plain], values), linearize([robust], values)
    s = abs(gp.rhs[0, 0])
    w = (1 - (s / 15.0) ** 2) ** 2
    np.testing.assert_allclose(gr.rhs, np.sqrt(w) * gp.rhs, rtol=1e-12)
    np.testing.assert_allclose(gr.jacobians[0], np.sqrt(w) * gp.jacobians[0], rtol=1e-12)
    assert gr.costs[0] < gp.costs[0]


def _information(factors, values, keys):
    order = Ordering(tuple(keys), tuple(values.dim(k) for k in keys))
    info, eta = LinearSystem.build(factors, values, order).information()
    return info.toarray(), eta


@pytest.mark.parametrize("measurement", ["prior", "range"])
def test_interpolated_factor_equals_dense_marginalisation(rng, measurement):
    """Eq. 29 against the explicit state x(τ), marginalised by a dense Schur complement.

    Marginalising x(τ) out of [GP prior t₁→τ→t₂, measurement on x(τ)] leaves the GP prior t₁→t₂ and
    the measurement on Λx₁ + Ψx₂ with covariance R + H P_τ Hᵀ, where P_τ is the conditional
    covariance of x(τ) given x₁, x₂. Eq. 29 is that factor with P_τ dropped.
    """
    t1, tau, t2 = 0.4, 1.1, 1.9
    XT = sr.X(99)
    x1, x2 = rng.normal(size=6), rng.normal(size=6)
    lam, psi = interpolation_matrices(t1, t2, tau, QC)
    xt = lam @ x1 + psi @ x2
    landmark = xt[:2] + np.array([3.0, -2.0])
    values = sr.Values({X1: x1, X2: x2, XT: xt, LM: landmark})
    anchor = [
        sr.PriorFactor.create(X1, rng.normal(size=6), np.ones(6)),
        sr.PriorFactor.create(LM, landmark, [2.0, 2.0]),
    ]

    # P_τ from the GP prior alone: the inverse of x(τ)'s block in the information of the two GP factors.
    gp3 = [sr.GPPriorFactor.wnoa(X1, XT, tau - t1, QC), sr.GPPriorFactor.wnoa(XT, X2, t2 - tau, QC)]
    p_tau = np.linalg.inv(_information(gp3, values, [X1, XT, X2])[0][6:12, 6:12])

    if measurement == "prior":
        R = np.diag([0.3, 0.2, 0.1, 0.4, 0.5, 0.6]) ** 2
        y = rng.normal(size=6)
        explicit = sr.PriorFactor.create(XT, y, R)
        H = np.eye(6)
        keys3, keys2 = [XT, X1, X2, LM], [X1, X2, LM]
    else:
        R = np.array([[0.3**2]])
        explicit = sr.RangeFactor.create(XT, LM, 3.2, 0.3)
        H = explicit.jacobians(xt, landmark)[0]
        keys3, keys2 = [XT, X1, X2, LM], [X1, X2, LM]
    info3, eta3 = _information(gp3 + [explicit] + anchor, values, keys3)
    a, b = slice(6, None), slice(0, 6)
    marg_info = info3[a, a] - info3[a, b] @ np.linalg.solve(info3[b, b], info3[b, a])
    marg_eta = eta3[a] - info3[a, b] @ np.linalg.solve(info3[b, b], eta3[b])

    R_eff = R + H @ p_tau @ H.T
    if measurement == "prior":
        inner = sr.PriorFactor.create(sr.X(-1), y, R_eff)
    else:
        inner = sr.RangeFactor.create(sr.X(-1), LM, 3.2, float(np.sqrt(R_eff[0, 0])))
    interp = sr.InterpolatedFactor.create(inner, X1, X2, t1, t2, tau, QC)
    gp2 = sr.GPPriorFactor.wnoa(X1, X2, t2 - t1, QC)
    info2, eta2 = _information([gp2, interp] + anchor, values, keys2)
    np.testing.assert_allclose(info2, marg_info, rtol=1e-9, atol=1e-9 * np.abs(marg_info).max())
    np.testing.assert_allclose(eta2, marg_eta, rtol=1e-9, atol=1e-9 * np.abs(marg_eta).max())


def test_bad_factor_input_raises():
    with pytest.raises(sr.ShapeError, match="measured"):
        sr.RangeFactor.create(X1, LM, np.nan, 1.0)
    with pytest.raises(sr.SteamError, match=r"noise \(standard deviations\) must be positive"):
        sr.VelocityFactor.create(X1, [0, 0, 0], [1.0, 0.0, 1.0])
    with pytest.raises(sr.ShapeError, match=r"\(3,\)"):
        sr.VelocityFactor.create(X1, [0, 0, 0], [1.0, 1.0])
    with pytest.raises(sr.SteamError, match="positive definite"):
        sr.VelocityFactor.create(X1, [0, 0, 0], -np.eye(3))
    with pytest.raises(sr.SteamError, match="t1 < tau < t2"):
        sr.InterpolatedFactor.create(sr.RangeFactor.create(X1, LM, 1.0, 1.0), X1, X2, 1.0, 2.0, 2.0, QC)
    with pytest.raises(sr.SteamError, match="increase strictly"):
        sr.gp_prior_factors([X1, X2], [1.0, 1.0], QC)
    with pytest.raises(sr.SteamError, match="dt=-1"):
        sr.GPPriorFactor.wnoa(X1, X2, -1.0, QC)


def test_landmark_on_the_robot_is_an_error_for_a_bearing():
    with pytest.raises(sr.SteamError, match="coincides"):
        sr.BearingRangeFactor.create(X1, LM, 0.0, 1.0, [0.1, 0.1]).jacobians(np.ones(6), np.ones(2))
    with pytest.raises(sr.SteamError, match="a bearing has no value there"):
        sr.BearingFactor.create(X1, LM, 0.3, 0.1).error(np.ones(6), np.ones(2))


@pytest.mark.parametrize("measured", [0.0, 2.5])
def test_a_range_at_the_landmark_is_zero_minus_the_reading_with_zero_jacobian_rows_and_a_warning(measured):
    # The convention of gpslam's and STEAM's tests: the distance is 0 (a value, not an error), its derivative does
    # not exist (|d| has a one-sided slope 1 in every direction), the Jacobian rows are zero.
    x = np.array([1.5, -0.5, 0.3, 0.8, 0.1, 0.0])
    factor = sr.RangeFactor.create(X1, LM, measured, 0.2)
    with pytest.warns(sr.DegenerateMeasurementWarning, match="exactly at the landmark"):
        e = factor.error(x, x[:2].copy())
    with pytest.warns(sr.DegenerateMeasurementWarning):
        Hx, Hl = factor.jacobians(x, x[:2].copy())
    assert e.tolist() == [-measured] and not Hx.any() and not Hl.any() and Hx.shape == (1, 6) and Hl.shape == (1, 2)
    # one step away the usual derivative is back, and unchanged by the convention
    l = x[:2] + [1e-3, 0.0]
    Hx, Hl = factor.jacobians(x, l)
    assert np.allclose(Hl, [[1.0, 0.0]]) and np.allclose(Hx[0, :2], [-1.0, 0.0])
    # a batch with one degenerate row keeps the others' Jacobians
    xs = np.stack([x, x])
    ls = np.stack([x[:2], x[:2] + [0.0, 2.0]])
    with pytest.warns(sr.DegenerateMeasurementWarning):
        Hx, Hl = factor.jacobians(xs, ls)
    assert not Hl[0].any() and np.allclose(Hl[1], [[0.0, 1.0]])


def test_the_degenerate_range_warning_names_the_line_that_asked_for_the_jacobians():
    x = np.array([1.5, -0.5, 0.3, 0.8, 0.1, 0.0])
    with pytest.warns(sr.DegenerateMeasurementWarning) as record:
        sr.RangeFactor.create(X1, LM, 1.0, 0.2).jacobians(x, x[:2].copy())
    assert record[0].filename == __file__


# --- what a factor class declares for Factor.stack -------------------------------------------------


def _prior(mean: float) -> sr.PriorFactor:
    return sr.PriorFactor.create(sr.X(0), np.full(6, mean), 0.5)


def test_a_field_declared_nowhere_is_caught_at_the_first_construction():
    """Before: stack copied an undeclared field from the first factor for every factor, silently."""

    @dataclass(frozen=True, eq=False)
    class Scaled(sr.PriorFactor):
        scale: float = field(default=1.0, kw_only=True)  # per factor, but listed in no tuple

    p = _prior(0.0)
    with pytest.raises(sr.SteamError, match=r"Scaled does not say how to stack its field 'scale'"):
        Scaled(p.keys, p.sqrt_information, mean=p.mean, scale=2.0)
    with pytest.raises(sr.SteamError, match=r"'scale'"):  # and stack refuses it too, however it was built
        Scaled.stack([p, p])


def test_a_shared_field_that_differs_is_named_with_the_factor():
    @dataclass(frozen=True, eq=False)
    class Scaled(sr.PriorFactor):
        scale: float = field(default=1.0, kw_only=True)
        _shared: ClassVar[tuple[str, ...]] = ("scale",)

    p = _prior(0.0)
    same = [Scaled(p.keys, p.sqrt_information, mean=p.mean + i, scale=2.0) for i in range(3)]
    batch = Scaled.stack(same)
    assert batch.scale == 2.0 and batch.mean.shape == (3, 6)
    np.testing.assert_array_equal(batch.mean[:, 0], [0.0, 1.0, 2.0])  # batched: one row per factor
    mixed = same + [Scaled(p.keys, p.sqrt_information, mean=p.mean, scale=3.0)]
    with pytest.raises(sr.SteamError, match=r"factor 3 has scale=3.0, factor 0 scale=2.0"):
        Scaled.stack(mixed)


def test_a_declared_name_that_is_no_field_and_a_field_declared_twice_are_caught():
    @dataclass(frozen=True, eq=False)
    class Typo(sr.PriorFactor):
        _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "maen")

    @dataclass(frozen=True, eq=False)
    class Twice(sr.PriorFactor):
        _shared: ClassVar[tuple[str, ...]] = ("mean",)

    p = _prior(0.0)
    with pytest.raises(sr.SteamError, match=r"'mean'"):  # mean is a field no tuple lists now
        Typo(p.keys, p.sqrt_information, mean=p.mean)
    with pytest.raises(sr.SteamError, match=r"Twice declares field 'mean' twice"):
        Twice(p.keys, p.sqrt_information, mean=p.mean)


def test_every_factor_class_of_steam_ref_declares_every_field():
    def subclasses(cls):
        for sub in cls.__subclasses__():
            yield sub
            yield from subclasses(sub)

    shipped = [c for c in subclasses(sr.Factor) if c.__module__.startswith("steam_ref.")]
    assert len(shipped) >= 9
    for cls in shipped:
        cls._check_declared()  # raises on a field declared nowhere


def test_a_new_factor_family_declaring_its_states_has_its_keys_roles_checked_without_calling_the_check():
    """``n_states`` alone, no ``__post_init__`` of its own: the base refuses keys in the wrong roles, with the message
    of the shipped factors (tests/test_bad_api_inputs_refused.py); ``roles_of_states_only`` checks the states alone
    (the wrapped reading's keys after them are its own to check); a factor declaring none takes any keys."""

    @dataclass(frozen=True, eq=False)
    class Sighting(sr.Factor):
        n_states: ClassVar[int | None] = 1

    @dataclass(frozen=True, eq=False)
    class Between(sr.Factor):
        n_states: ClassVar[int | None] = 2
        roles_of_states_only: ClassVar[bool] = True

    @dataclass(frozen=True, eq=False)
    class Anything(sr.Factor):
        pass

    w = np.eye(1)
    Sighting((sr.X(0), sr.L(0), sr.L(1)), w)
    with pytest.raises(
        sr.SteamError,
        match=r"^Sighting takes keys \(state X\(i\), landmark L\(j\)\), got \(l0, x0\): "
        r"l0 is not a state key, x0 is not a landmark key$",
    ):
        Sighting((sr.L(0), sr.X(0)), w)
    Between((sr.X(0), sr.X(1), sr.X(2), sr.L(0)), w)  # after the two states: any keys
    with pytest.raises(
        sr.SteamError, match=r"^Between takes keys \(state X\(i\), state X\(i\)\), got \(x0, l0\): l0 is"
    ):
        Between((sr.X(0), sr.L(0), sr.L(1)), w)
    Anything((sr.L(0), sr.X(0)), w)


def test_stacking_factors_with_different_losses_is_refused():
    a = sr.RangeFactor.create(sr.X(0), sr.L(0), 5.0, 0.1)
    b = sr.RangeFactor.create(sr.X(1), sr.L(0), 5.0, 0.1, loss=sr.Huber(1.0))
    with pytest.raises(sr.SteamError, match=r"factor 1 has loss=Huber"):
        sr.RangeFactor.stack([a, b])


HELPED = [
    "PriorFactor",
    "OdometryFactor",
    "VelocityFactor",
    "RangeFactor",
    "BearingFactor",
    "BearingRangeFactor",
    "InterpolatedFactor",
    "GPPriorFactor",
]


@pytest.mark.parametrize("name", HELPED)
def test_help_on_a_factor_leads_with_its_purpose_how_to_make_it_and_its_error(name):
    """help(sr.RangeFactor) opens with the purpose, the call that makes one (with the argument names of the real
    method) and the error formula, in at most 25 lines before pydoc's listing of members and machinery."""
    import inspect
    import pydoc
    import re

    cls = getattr(sr, name)
    rendered = pydoc.plain(pydoc.render_doc(cls)).splitlines()
    top = rendered[: next(i for i, line in enumerate(rendered) if "Method resolution order" in line)]
    assert len(top) <= 25, f"help({name}) takes {len(top)} lines before its members"
    text = "\n".join(top)
    assert cls.__doc__.strip().splitlines()[0] in text
    assert "Error:  e =" in text
    for machinery in ("__dataclass_fields__", "_batched", "batch_signature", "stack("):
        assert machinery not in text, f"{machinery} in the opening of help({name})"
    makers = re.findall(rf"{name}\.(\w+)\(([^)]*)\)", text)
    assert makers, f"help({name}) does not show how to make one"
    for method, shown in makers:
        real = [p for p in inspect.signature(getattr(cls, method)).parameters if p != "cls"]
        names = [a.split("=")[0].strip() for a in shown.split(",") if a.strip() not in ("", "*")]
        assert names == real, f"help({name}) shows {method}({shown}), the method takes {real}"
