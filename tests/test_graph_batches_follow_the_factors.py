"""A FactorGraph groups and stacks its factors once (FactorGraph.batches) for every linearization and cost of a
batch solve; the grouping must follow the factors: made again when one is added or replaced, never stale.

Oracle: the cost summed factor by factor, ½‖W e‖² from each factor's own ``whitened_error`` (no grouping, no
stacking), and a Gauss-Newton step checked against the dense normal equations."""

from __future__ import annotations

import numpy as np
import pytest

import steam_ref as sr
from steam_ref.batch import gauss_newton
from steam_ref.linear import LinearSystem, make_ordering


def brute_cost(factors, values) -> float:
    """Σ ½‖W e‖², one factor at a time."""
    return sum(0.5 * float(np.sum(f.whitened_error(*[values[k] for k in f.keys]) ** 2)) for f in factors)


def graph_and_values(n_ranges: int = 4):
    rng = np.random.default_rng(3)
    graph = sr.FactorGraph([sr.PriorFactor.create(sr.X(0), [0, 0, 0, 1, 0, 0], 0.1)])
    for j in range(n_ranges):
        graph.add(sr.PriorFactor.create(sr.L(j), rng.normal(size=2) * 5, 0.5))
        graph.add(sr.RangeFactor.create(sr.X(0), sr.L(j), 3.0 + j, 0.2))
    values = sr.Values({sr.X(0): rng.normal(size=6), **{sr.L(j): rng.normal(size=2) * 5 for j in range(n_ranges)}})
    return graph, values


def test_the_cost_follows_an_added_factor():
    graph, values = graph_and_values()
    assert graph.error(values) == pytest.approx(brute_cost(graph.factors, values), rel=1e-13)
    made = graph.batches()
    assert graph.batches() is made  # the same factors: grouped once
    graph.add(sr.RangeFactor.create(sr.X(0), sr.L(1), 9.0, 0.1))
    assert graph.batches() is not made
    assert graph.error(values) == pytest.approx(brute_cost(graph.factors, values), rel=1e-13)


def test_the_cost_follows_a_factor_replaced_in_the_list():
    graph, values = graph_and_values()
    before = graph.error(values)
    graph.factors[2] = sr.RangeFactor.create(sr.X(0), sr.L(0), 30.0, 0.2)  # same type, same length, other reading
    after = graph.error(values)
    assert after != before
    assert after == pytest.approx(brute_cost(graph.factors, values), rel=1e-13)


def test_a_gauss_newton_step_after_an_add_solves_the_dense_normal_equations():
    graph, values = graph_and_values()
    gauss_newton(graph, values, max_iterations=1, check=False)  # groups the factors of the first graph
    graph.add(sr.PriorFactor.create(sr.X(0), [1, 2, 0.3, 0, 0, 0], 0.05))
    order = make_ordering("natural", graph.keys(), values.dims(), [f.keys for f in graph])
    A, b = LinearSystem.build(list(graph), values, order).to_dense()  # a fresh linearization
    expected = np.linalg.solve(A.T @ A, A.T @ b)
    result = gauss_newton(graph, values, ordering=order, max_iterations=1, check=False)
    step = np.concatenate([result.values[k] - values[k] for k in order.keys])  # vector spaces: θ ⊕ δ = θ + δ
    np.testing.assert_allclose(step, expected, rtol=1e-9, atol=1e-12)
