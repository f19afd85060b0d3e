"""What a user sees when they print what a solver returned. ``print(result)`` of a batch solve led with the
whole per-iteration list and the ordering's every column offset (thousands of characters on 120 states), burying
``converged`` and ``reason``; an iSAM2 ``UpdateReport`` printed every clique id and key of the update (all of them
on a first update); a ``Trajectory`` printed as ``<... object at 0x...>``. Now each repr has a size that does not
grow with the problem and says what matters first.
"""

from __future__ import annotations

import re

import numpy as np

import steam_ref as sr
from steam_ref import L, X

QC = np.diag([0.1, 0.1, 0.05])


def _problem(n: int) -> tuple[sr.FactorGraph, dict, np.ndarray]:
    """n states at irregular times with odometry, ranges to one surveyed beacon, and a prior on the first state."""
    times = np.concatenate([[0.0], np.cumsum(np.linspace(0.1, 0.4, n - 1))])
    keys = [X(i) for i in range(n)]
    graph = sr.FactorGraph(sr.gp_prior_factors(keys, times, QC))
    graph.add(sr.PriorFactor.create(keys[0], [0.0, 0.0, 0.0, 1.0, 0.0, 0.0], 0.1))
    graph.add(sr.PriorFactor.create(L(0), [5.0, 5.0], 0.01))
    for i, k in enumerate(keys):
        graph.add(sr.VelocityFactor.create(k, [1.0, 0.0, 0.0], [0.05, 0.05, 0.02]))
        graph.add(sr.RangeFactor.create(k, L(0), float(np.hypot(times[i] - 5.0, 5.0)), 0.1))
    values = {k: np.array([times[i], 0.0, 0.0, 1.0, 0.0, 0.0]) for i, k in enumerate(keys)} | {L(0): np.ones(2)}
    return graph, values, times


def test_a_batch_result_prints_its_verdict_not_its_iterations():
    lengths = []
    for n in (10, 200):
        graph, values, _ = _problem(n)
        result = sr.gauss_newton(graph, values)
        text = repr(result)
        assert text.startswith(f"BatchResult(values=Values({n + 1} variables), initial_cost=")
        assert f"converged={result.converged}" in text and f"reason={result.reason!r}" in text
        assert "Iteration(" not in text and "offsets" not in text and "ordering=" not in text
        lengths.append(len(text))
        assert len(result.iterations) >= 1 and result.ordering is not None  # still there, by name
    assert abs(lengths[1] - lengths[0]) < 40, lengths  # the numbers' digits differ, nothing else


def test_an_ordering_prints_its_keys_and_sizes_not_its_offsets():
    order = sr.xl_ordering([L(0), X(1), X(0)], {X(0): 6, X(1): 6, L(0): 2})
    assert repr(order) == "Ordering(keys=(x0, x1, l0), dims=(6, 6, 2))"
    np.testing.assert_array_equal(order.offsets, [0, 6, 12])


def test_an_update_report_prints_counts_and_times_not_every_id():
    lengths = []
    for n in (10, 200):
        graph, values, _ = _problem(n)
        report = sr.IncrementalSolver().update(graph.factors, values)
        text = repr(report)
        assert re.fullmatch(r"UpdateReport\(step=1, linearized_factors=\d+, backsubstituted_cliques=\d+, .*\)", text)
        assert "x0" not in text and "new_cliques" not in text
        assert len(report.reeliminated) == n + 1  # still there, by name
        lengths.append(len(text))
    assert abs(lengths[1] - lengths[0]) < 40, lengths


def test_a_trajectory_prints_its_states_span_and_prior():
    graph, values, times = _problem(10)
    t = sr.Trajectory(sr.gauss_newton(graph, values), list(range(10)), times, QC)
    assert repr(t) == (
        f"<Trajectory of 10 states, x0..x9 at 0..{times[-1]:.6g} s, wnoa prior of 6 numbers a state; "
        "at(t): the state at t s from the first state on>"
    )


def test_a_pose_error_prints_its_statistics_with_units_not_every_error():
    truth = np.column_stack([np.arange(50.0), np.zeros(50), np.zeros(50)])
    estimate = truth + [0.3, -0.4, 0.05]
    text = repr(sr.ape(truth, estimate))
    rmse = np.sqrt(np.mean(np.sum((estimate - truth)[:, :2] ** 2, axis=1)))  # brute force: 0.5 m at every pose
    assert text.startswith(f"PoseError(n=50, translation RMSE {rmse:.6g} m (mean {rmse:.6g}, median {rmse:.6g}, max")
    assert f"heading RMSE {0.05:.6g} rad (max {0.05:.6g})" in text
    assert "array([0.5" not in text and len(text) < 300


def test_the_incremental_solvers_print_what_they_hold():
    graph, values, times = _problem(10)
    solver = sr.IncrementalSolver()
    assert repr(solver) == "<IncrementalSolver after 0 updates: 0 variables, 0 factors, 0 cliques>"
    solver.update(graph.factors, values)
    n_cliques = len(solver.tree.cliques)
    assert repr(solver) == (
        f"<IncrementalSolver after 1 updates: 11 variables, {len(graph.factors)} factors, {n_cliques} cliques>"
    )
    window = sr.FixedLagSmoother(1.0)
    window.update(graph.factors, values, timestamps={X(i): float(times[i]) for i in range(10)})
    gone = sum(window.was_marginalized(X(i)) for i in range(10))  # the states older than the lag: counted one by one
    assert gone == sum(times < times[-1] - 1.0) > 0
    assert repr(window) == f"<FixedLagSmoother of lag 1 s, {gone} marginalized: {window.solver!r}>"
