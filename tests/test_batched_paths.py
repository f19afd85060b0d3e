"""The batched paths of a stream agree with the scalar ones they replace: the divergence check's residuals
(:func:`steam_ref.linear.system.whitened_norms`) with each factor's own ``whitened_error``, the solver's
estimates formed in one call per kind (``IncrementalSolver.estimates_of``) with each state's own retraction,
and the front end's memoised Φ and W with the closed forms built anew. Small tasks: seconds."""

from __future__ import annotations

import numpy as np
import pytest

from steam_ref.bayes_tree import IncrementalSolver
from steam_ref.datasets import generate_synthetic
from steam_ref.errors import SteamError, UnknownVariableError
from steam_ref.factors import RangeFactor
from steam_ref.factors.base import sqrt_information
from steam_ref.factors.lie_prior import LiePriorFactor
from steam_ref.factors.lie_readings import BodyVelocityFactor, LieInterpolatedFactor, PoseReading
from steam_ref.gp.interpolate import interpolation_matrices
from steam_ref.gp.prior import process_noise_sqrt_information, transition
from steam_ref.lie import SE2
from steam_ref.linear.system import whitened_norms
from steam_ref.manifold import VECTOR
from steam_ref.motion import motion_prior
from steam_ref.paper.divergence import DivergenceCheck, fits
from steam_ref.paper.frontend import Layout
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.problem import build_problem
from steam_ref.paper.readings import Readings
from steam_ref.variables import L, Values, X

PRIORS = ["wnoa", "se2"]


@pytest.fixture(scope="module")
def data():
    return generate_synthetic(n_steps=40, n_landmarks=8, seed=5, range_sigma=0.3)


def _problem(data, prior: str):
    setup = PaperSetup.synthetic().replace(prior=prior)
    return build_problem(Readings.from_dataset(data, setup), setup, Layout(skip=3))


def _moved(problem, seed: int) -> Values:
    """The initial values moved by a random step in each variable's tangent (so no residual is zero)."""
    rng = np.random.default_rng(seed)
    v = problem.initial
    return v.retract({k: 0.05 * rng.standard_normal(v.dim(k)) for k in v})


def _one_by_one(factors, values) -> np.ndarray:
    """The scalar path: ‖W e‖ of each factor evaluated alone (its own whitened_error, its own arrays)."""
    return np.array([np.linalg.norm(f.whitened_error(*[values[k] for k in f.keys])) for f in factors])


@pytest.mark.parametrize("prior", PRIORS)
def test_the_batched_residuals_equal_each_factor_evaluated_alone(data, prior):
    problem = _problem(data, prior)
    factors = list(problem.graph)
    kinds = {type(f).__name__ for f in factors}
    if prior == "se2":  # every factor type a stream on SE(2) states makes, in one list
        assert {
            "LieStatePrior",
            "LiePriorFactor",
            "BodyVelocityFactor",
            "PoseReading",
            "LieInterpolatedFactor",
        } <= kinds
    values = _moved(problem, 1)
    want = _one_by_one(factors, values)
    assert want.min() > 0
    got = whitened_norms(factors, values)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)
    # in the order given, whatever the order: reversed in, reversed out
    np.testing.assert_allclose(whitened_norms(factors[::-1], values), want[::-1], rtol=1e-12, atol=0)
    asked: list[list] = []

    def estimates(keys):
        asked.append(keys)
        return {k: values[k] for k in keys}

    np.testing.assert_allclose(fits(factors, estimates), want, rtol=1e-12, atol=0)
    assert len(asked) == 1 and sorted(asked[0]) == sorted({k for f in factors for k in f.keys})  # one ask


def test_a_residual_that_overflows_is_infinite_not_an_error():
    far = RangeFactor.create(X(0), L(1), 1.0, 1e-10)
    near = RangeFactor.create(X(1), L(1), 5.0, 0.1)
    values = Values({X(0): np.r_[1e300, 0, 0, 0, 0, 0], X(1): np.zeros(6), L(1): np.array([3.0, 4.0])})
    np.testing.assert_array_equal(whitened_norms([far, near], values), [np.inf, 0.0])
    assert whitened_norms([], values).shape == (0,)


def test_the_divergence_gate_reads_the_batched_residuals():
    """The gate names the reading whose batched residual is beyond any noise, and only it."""
    check = DivergenceCheck()
    good = RangeFactor.create(X(0), L(1), 5.0, 0.1)
    bad = RangeFactor.create(X(0), L(2), 500.0, 0.1)
    values = {X(0): np.zeros(6), L(1): np.array([3.0, 4.0]), L(2): np.array([0.0, 1.0])}
    with pytest.warns(Warning, match=r"RangeFactor on x0, l2 reading \[500.0\] is 4.99e\+03 sigmas"):
        check.gate([good, bad], lambda keys: {k: values[k] for k in keys}, 3)
    assert check.count == 1


@pytest.mark.parametrize("prior", PRIORS)
def test_estimates_formed_in_one_call_equal_each_state_retracted_alone(data, prior):
    problem = _problem(data, prior)
    solver = IncrementalSolver(relinearize_threshold=1e9)  # never relinearized: δ stays, so x = θ̄ ⊕ δ is formed
    solver.update(list(problem.graph), problem.initial)
    theta, delta, keys = solver.linearization_point, solver.delta(), list(problem.initial)
    assert any(np.any(delta[k] != 0) for k in keys)
    got = solver.estimates_of(keys[::-1])
    for k in keys:
        kind = theta.kind(k)
        alone = kind.retract(theta[k], delta[k])  # the scalar path: one state's own retraction (SE(2): its own exp)
        if kind is VECTOR:
            np.testing.assert_array_equal(got[k], alone)  # + bit for bit
        else:
            np.testing.assert_allclose(got[k], alone, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(solver.estimate_of(k), got[k])
        assert not got[k].flags.writeable
    with pytest.raises(UnknownVariableError, match=r"variable l99 is not in the solver"):
        solver.estimates_of([keys[0], L(99)])


def test_the_memoised_transition_and_weights_equal_the_closed_forms_and_are_read_only():
    for dt, d in [(1.0, 3), (0.25, 3), (1.0, 2)]:
        I, O = np.eye(d), np.zeros((d, d))
        phi = transition(dt, d)
        np.testing.assert_array_equal(phi, np.block([[I, dt * I], [O, I]]))
        assert transition(dt, d) is phi and not phi.flags.writeable
    sigmas = np.array([0.3, 0.2, 0.05])
    W = sqrt_information(sigmas, 3)
    np.testing.assert_array_equal(W, np.diag(1.0 / sigmas))
    assert sqrt_information(sigmas.copy(), 3) is W and not W.flags.writeable
    assert sqrt_information(0.5, 1) is sqrt_information(np.array([0.5]), 1)
    # a user's bad noise is still refused, memoised good ones or not
    with pytest.raises(SteamError, match=r"noise \(standard deviations\) must be positive"):
        sqrt_information(np.array([0.3, -0.2, 0.05]), 3)
    with pytest.raises(SteamError, match=r"noise must be finite"):
        sqrt_information(np.array([0.3, np.nan, 0.05]), 3)


def test_the_se2_prior_makes_the_factors_create_makes_without_checking_again():
    qc = np.diag([0.5, 0.2, 0.1])
    prior = motion_prior("se2", qc)
    made, want = prior.prior_factor(X(1), X(2), 0.7), LiePriorFactor.create(X(1), X(2), 0.7, qc, group=SE2)
    np.testing.assert_array_equal(made.sqrt_information, process_noise_sqrt_information(0.7, qc))
    for name in ("sqrt_information", "phi"):
        np.testing.assert_array_equal(getattr(made, name), getattr(want, name))
    assert (made.keys, made.model, made.group) == (want.keys, want.model, want.group)
    inner = PoseReading.range(X(-1), L(3), 4.0, 0.1, group=SE2)
    made = prior.interpolated_factor(inner, X(1), X(2), 0.0, 1.0, 0.3)
    lam, psi = interpolation_matrices(0.0, 1.0, 0.3, qc)
    np.testing.assert_array_equal(made.lam, lam)
    np.testing.assert_array_equal(made.psi, psi)
    assert made.keys == (X(1), X(2), L(3)) and made.inner is inner
    # the public boundary still checks: a user's factor, a time outside the gap, a reading of another kind
    with pytest.raises(SteamError, match=r"qc"):
        LiePriorFactor.create(X(1), X(2), 0.7, np.eye(2), group=SE2)
    with pytest.raises(SteamError, match=r"time step must be positive"):
        prior.prior_factor(X(1), X(2), 0.0)
    with pytest.raises(SteamError, match=r"t1 < tau < t2"):
        prior.interpolated_factor(inner, X(1), X(2), 0.0, 1.0, 1.5)
    with pytest.raises(SteamError, match=r"inner must read a state of kind SE2_STATE"):
        prior.interpolated_factor(RangeFactor.create(X(-1), L(3), 4.0, 0.1), X(1), X(2), 0.0, 1.0, 0.3)
    assert isinstance(prior.velocity_reading(X(1), np.ones(3), np.ones(3)), BodyVelocityFactor)
    assert isinstance(
        LieInterpolatedFactor.create(inner, X(1), X(2), 0.0, 1.0, 0.3, qc, group=SE2), LieInterpolatedFactor
    )


def test_one_factor_is_its_batch_bit_for_bit(rng):
    """One number or one factor (Tukey's weight and ρ; a robust range's and a velocity reading's linearization, alone:
    a batch of one, read through views) against the same in a batch: equal bit for bit, NaN, inf, zero and the
    threshold among the residuals."""
    from steam_ref.factors import VelocityFactor
    from steam_ref.linear.system import linearize
    from steam_ref.robust import Tukey

    tukey = Tukey(2.5)
    s = np.array([0.0, -0.0, 2.5, -2.5, 1e-300, 3.0, np.inf, -np.inf, np.nan, *rng.standard_normal(40) * 3])
    w, rho = tukey.weight_and_rho(s)
    for i in range(len(s)):
        w1, rho1 = tukey.weight_and_rho(s[i : i + 1])
        assert np.array_equal(w1, w[i : i + 1], equal_nan=True) and np.array_equal(rho1, rho[i : i + 1], equal_nan=True)
    ranges = [RangeFactor.create(X(i), L(1), 1.0 + i, 0.2, loss=tukey) for i in range(5)]
    velocities = [VelocityFactor.create(X(i), rng.standard_normal(3), [0.1, 0.2, 0.05]) for i in range(5)]
    values = {X(i): rng.standard_normal(6) * 4 for i in range(5)} | {L(1): rng.standard_normal(2)}
    for factors in (ranges, velocities):
        (batch,) = linearize(factors, values)
        for i, f in enumerate(factors):
            (alone,) = linearize([f], values)
            assert np.array_equal(alone.rhs[0], batch.rhs[i]) and np.array_equal(alone.costs[0], batch.costs[i])
            for A_alone, A_batch in zip(alone.jacobians, batch.jacobians, strict=True):
                assert np.array_equal(A_alone[0], A_batch[i])
    stacked = VelocityFactor.stack(velocities)
    errors = stacked.error(np.array([values[f.keys[0]] for f in velocities]))
    for i, f in enumerate(velocities):  # one state as a vector (the divergence check's path): its row of the batch
        assert np.array_equal(f.error(values[f.keys[0]]), errors[i])
