"""Gauss-Newton and Levenberg-Marquardt reach a stationary point of Eq. 6, whatever the ordering."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from problems import small_problem

import steam_ref as sr
from steam_ref.linear import LinearSystem
from steam_ref.linear.ordering import make_ordering


def gradient_norm(problem, values):
    """‖Aᵀb‖ at ``values``: zero at a stationary point of the (IRLS-weighted) cost."""
    order = make_ordering("xl", problem.graph.keys(), values.dims(), [f.keys for f in problem.graph])
    A, b = LinearSystem.build(problem.graph.factors, values, order).to_dense()
    return np.linalg.norm(A.T @ b), np.linalg.norm(A.T @ A, 2)


@pytest.mark.parametrize("method", [sr.gauss_newton, sr.levenberg_marquardt])
@pytest.mark.parametrize("ordering", ["xl", "amd"])
def test_converges_to_stationary_point(rng, method, ordering):
    p = small_problem(rng, n_states=15, n_landmarks=4, interpolated=6, robust=False)
    result = method(p.graph, p.initial, ordering=ordering, relative_tolerance=1e-14, step_tolerance=1e-12)
    assert result.converged, result.reason
    g, scale = gradient_norm(p, result.values)
    assert g < 1e-8 * scale
    assert result.cost < result.initial_cost
    assert all(it.cost <= result.initial_cost for it in result.iterations if it.accepted)


def test_gn_and_lm_agree(rng):
    p = small_problem(rng, n_states=10, n_landmarks=3, interpolated=3, robust=False)
    gn = sr.gauss_newton(p.graph, p.initial, relative_tolerance=1e-14, step_tolerance=1e-12).values
    lm = sr.levenberg_marquardt(p.graph, p.initial, relative_tolerance=1e-14, step_tolerance=1e-12).values
    for k in gn:
        np.testing.assert_allclose(lm[k], gn[k], rtol=1e-7, atol=1e-9)


def test_first_gn_step_is_the_dense_newton_step(rng):
    p = small_problem(rng, n_states=6, n_landmarks=2)
    result = sr.gauss_newton(p.graph, p.initial, max_iterations=1)
    order = make_ordering("xl", p.graph.keys(), p.initial.dims(), [f.keys for f in p.graph])
    system = LinearSystem.build(p.graph.factors, p.initial, order)
    A, b = system.to_dense()
    step = system.split(np.linalg.solve(A.T @ A, A.T @ b))
    for k in step:
        np.testing.assert_allclose(result.values[k], p.initial[k] + step[k], rtol=1e-10, atol=1e-12)
    assert result.reason.startswith("max_iterations: one more Gauss-Newton step would lower the cost by")
    assert not result.converged


def test_perturbed_start_reaches_the_optimum_found_from_the_truth(rng):
    p = small_problem(rng, n_states=20, n_landmarks=4, noise=0.3, robust=False)
    tight = dict(relative_tolerance=1e-14, step_tolerance=1e-12)
    from_start = sr.levenberg_marquardt(p.graph, p.initial, **tight).values
    from_truth = sr.levenberg_marquardt(p.graph, sr.Values(p.truth), **tight).values
    for k in p.truth:
        np.testing.assert_allclose(from_start[k], from_truth[k], rtol=1e-6, atol=1e-8)


def _heading_problem(theta0: float) -> tuple[sr.FactorGraph, sr.Values]:
    """One state whose velocity is pinned to (1, 0) by a tight prior, and a projected-velocity
    reading of (3, 0): the cost in θ is ½|R(θ)ᵀv - z|² = 5 - 3 cos θ (plus tiny priors), minimal
    at θ = 0 with cost 2. Its Gauss-Newton step is δθ = -3 sin θ, so from θ = 1 it jumps to
    θ ≈ -1.52, where cos θ is smaller: the undamped step raises the cost."""
    graph = sr.FactorGraph([])
    graph.add(sr.PriorFactor.create(sr.X(0), [0, 0, 0, 1, 0, 0], [1e-3, 1e-3, 1e3, 1e-3, 1e-3, 1e-3]))
    graph.add(sr.VelocityFactor.create(sr.X(0), [3.0, 0.0, 0.0], [1.0, 1.0, 1.0]))
    return graph, sr.Values({sr.X(0): np.array([0, 0, theta0, 1, 0, 0.0])})


def test_lm_rejects_an_overshooting_step_and_raises_the_damping():
    graph, initial = _heading_problem(theta0=1.0)
    gn_step = sr.gauss_newton(graph, initial, max_iterations=1)
    assert gn_step.cost > gn_step.initial_cost  # the premise: the undamped step overshoots
    factor, lam0 = 10.0, 1e-9
    result = sr.levenberg_marquardt(graph, initial, initial_damping=lam0, damping_factor=factor)
    its = result.iterations
    assert not its[0].accepted and its[0].damping == lam0 and its[0].cost == result.initial_cost
    assert any(it.accepted for it in its)
    for before, after in itertools.pairwise(its):
        if before.accepted:
            assert after.damping == pytest.approx(max(before.damping / factor, 1e-12), rel=1e-12)
        else:
            assert after.damping == pytest.approx(before.damping * factor, rel=1e-12)
    kept = [result.initial_cost] + [it.cost for it in its]
    assert all(b <= a for a, b in itertools.pairwise(kept))  # the kept cost never increases
    # an accepted step lowers it (not strict: kept has one more entry, the initial cost)
    assert all(it.cost < prev for prev, it in zip(kept, its, strict=False) if it.accepted)
    assert result.converged, result.reason
    assert abs(result.values[sr.X(0)][2]) < 1e-3 and result.cost == pytest.approx(2.0, abs=1e-4)


def test_batch_solve_rejects_unknown_method(rng):
    p = small_problem(rng, n_states=3, n_landmarks=1)
    with pytest.raises(sr.SteamError, match="newton"):
        sr.batch_solve(p.graph, p.initial, method="newton")
