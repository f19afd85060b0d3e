"""Finishing an incremental solve at the batch optimum, against batch Gauss-Newton on the same factors.

The solver is fed a toy run as a user would (each new state started at the prior's prediction from the
last estimate, GTSAM's default thresholds), so its estimate rests away from the optimum; the finished
estimate must be what :func:`steam_ref.gauss_newton` reaches from the solver's estimate, under the same rules
and check; with tight tolerances, the optimum to 1e-9.
"""

from __future__ import annotations

import numpy as np
import pytest
from problems import sample_trajectory

import steam_ref as sr

QC = 0.01 * np.diag([1.0, 1.0, 25.0])


def fed_solver(rng, n_states=30, **params):
    """An IncrementalSolver fed state by state: the GP prior, a projected velocity and a range to one of three
    landmarks (priors on them) each step; returns (solver, every factor, the truth)."""
    times = np.arange(n_states) * 0.5
    xs = sample_trajectory(rng, times, QC, [0.0, 0.0, 0.2, 1.0, 0.3, 0.2])
    marks = {sr.L(j): np.array(p) for j, p in enumerate([[5.0, 5.0], [-3.0, 6.0], [8.0, -2.0]])}
    solver = sr.IncrementalSolver(**params)
    first = [sr.PriorFactor.create(sr.X(0), xs[0], 0.1)] + [sr.PriorFactor.create(k, p, 0.5) for k, p in marks.items()]
    everything = list(first)
    solver.update(first, {sr.X(0): xs[0] + 0.05, **marks})
    for i in range(1, n_states):
        key, x = sr.X(i), xs[i]
        th = x[2]
        body = [np.cos(th) * x[3] + np.sin(th) * x[4], -np.sin(th) * x[3] + np.cos(th) * x[4], x[5]]
        mark = sr.L(i % 3)
        new = sr.gp_prior_factors([sr.X(i - 1), key], times[i - 1 : i + 1], QC) + [
            sr.VelocityFactor.create(key, np.array(body) + rng.normal(size=3) * 0.05, [0.1, 0.1, 0.1]),
            sr.RangeFactor.create(key, mark, np.hypot(*(x[:2] - marks[mark])) + rng.normal() * 0.1, 0.1),
        ]
        start = sr.predict_state(solver.estimate_of(sr.X(i - 1)), times[i] - times[i - 1], QC)
        solver.update(new, {key: start})
        everything += new
    return solver, everything


def optimum(factors, start):
    """The optimum to rounding: Gauss-Newton one step a call until a step is below 1e-11. The cost's own rules stop
    ~1e-7 away (it converges linearly), and even at tolerance 0 where the cost stops changing in float64 (at 33, a
    decrease below ~1e-14), which on some platforms is ~1e-9 short of the optimum; one step a call, no cost rule
    can stop it."""
    values = start
    for _ in range(60):
        one = sr.gauss_newton(
            factors, values, max_iterations=1, relative_tolerance=0, absolute_tolerance=0, step_tolerance=1e-11
        )
        values = one.values
        if one.iterations[-1].step_norm <= 1e-11:
            return one
    raise AssertionError("Gauss-Newton did not reach a step below 1e-11 in 60 steps")


def test_finish_certifies_the_optimum_the_batch_certifies(rng):
    """With the batch's defaults, the finished estimate is the batch's from the solver's estimate, bit for bit,
    and the check's numbers are in its reason; with tighter tolerances it reaches the optimum to rounding."""
    solver, factors = fed_solver(rng)
    before = solver.estimate()
    tight = optimum(factors, before)
    assert tight.stationarity is not None and tight.stationarity.predicted_decrease < 1e-20
    gap = max(np.abs(before[k] - tight.values[k]).max() for k in tight.values)
    assert gap > 1e-4, f"the defaults already reached the optimum ({gap:.2g}): the test shows nothing"

    finished = sr.finish_at_optimum(solver)
    batch = sr.gauss_newton(factors, before)

    assert finished.converged and batch.converged, finished.reason
    for k, x in batch.values.items():
        np.testing.assert_array_equal(finished.values[k], x, err_msg=str(k))
    found = finished.stationarity
    assert found is not None and found.predicted_decrease <= 1e-8 * finished.cost
    assert f"would lower the cost by {found.predicted_decrease:.3g}, within the tolerance" in finished.reason
    assert f"{1e-8 * found.cost:.3g}" in finished.reason and "condition ≈" in finished.reason
    assert finished.cost < finished.initial_cost
    assert len(finished.iterations) >= 2  # a Gauss-Newton step, then the one that found nothing left to move
    for k in before:  # the user's solver is not changed
        np.testing.assert_array_equal(solver.estimate_of(k), before[k])

    # tolerances lowered as the docstring says (relative 1e-15): it stops where the cost is flat to float64, and what
    # its certificate bounds is the distance to the optimum: the next step's predicted decrease is ½ ‖x - x*‖² in the
    # information 𝓘 (exactly, were the problem linear; here it converges linearly at a rate ρ ≈ 0.14, which scales that
    # by at most 1/(1 - ρ)² ≤ 2, the factor below)
    closer = sr.finish_at_optimum(solver, relative_tolerance=1e-15, absolute_tolerance=0, step_tolerance=1e-11)
    assert closer.converged, closer.reason
    keys = list(tight.values)
    gap = np.concatenate([closer.values[k] - tight.values[k] for k in keys])  # vector states: the tangent
    information = np.linalg.inv(tight.joint_covariance(keys))
    assert closer.stationarity is not None
    assert 0.5 * gap @ information @ gap <= 2 * closer.stationarity.predicted_decrease
    cov = closer.marginal_covariance(sr.X(29))
    np.testing.assert_allclose(cov, tight.marginal_covariance(sr.X(29)), rtol=1e-7)


def test_finish_says_how_far_it_is_when_its_iterations_run_out(rng):
    solver, _ = fed_solver(rng, n_states=12)
    result = sr.finish_at_optimum(solver, max_updates=2, relative_tolerance=0, step_tolerance=0)
    assert not result.converged
    assert len(result.iterations) == 2
    found = result.stationarity
    assert found is not None and found.predicted_decrease > 0
    assert result.reason.startswith(
        f"max_iterations: one more Gauss-Newton step would lower the cost by {found.predicted_decrease:.3g}, above"
    ), result.reason
    last, previous = result.iterations[-1].step_norm, result.iterations[-2].step_norm
    assert f"the last step's norm was {last:.2g}, {last / previous:.2f} times the one before" in result.reason


def test_finish_continues_as_a_solver_at_the_optimum(rng):
    """What the docstring says to do next: a solver with the user's settings, linearized at the optimum (its
    estimate moves by one more Gauss-Newton step, which back-substitution applies where the change reaches α)."""
    solver, _ = fed_solver(rng, n_states=12)
    result = sr.finish_at_optimum(solver)
    again = sr.IncrementalSolver(solver.params)
    again.update(list(result.factors), result.values)
    at = again.linearization_point
    for k, x in result.values.items():
        np.testing.assert_array_equal(at[k], x)
        np.testing.assert_allclose(again.estimate_of(k), x, rtol=0, atol=solver.params.wildfire_threshold)


def test_finish_refuses_what_it_cannot_finish(rng):
    with pytest.raises(sr.SteamError, match="solver must be an IncrementalSolver"):
        sr.finish_at_optimum(sr.FactorGraph())
    solver, _ = fed_solver(rng, n_states=4)
    with pytest.raises(sr.SteamError, match="step_tolerance must be a finite number"):
        sr.finish_at_optimum(solver, step_tolerance=-1.0)
    with pytest.raises(sr.SteamError, match="max_updates must be an integer"):
        sr.finish_at_optimum(solver, max_updates=2.5)
    with pytest.raises(sr.SteamError, match="the factor graph is empty"):
        sr.finish_at_optimum(sr.IncrementalSolver())
    lag = sr.FixedLagSmoother(1.0)
    with pytest.raises(sr.SteamError, match="FixedLagSmoother marginalizes what leaves its window"):
        sr.finish_at_optimum(lag)
    from steam_ref.bayes_tree import marginalize

    marginalize(solver, [sr.X(0)])
    with pytest.raises(sr.SteamError, match="IncrementalSolver has marginalized variables"):
        sr.finish_at_optimum(solver)
