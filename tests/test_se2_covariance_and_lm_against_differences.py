"""Covariances and Levenberg-Marquardt on SE(2) states with landmarks, against oracles built without our Jacobians.

The oracle of every covariance is the dense inverse of AᵀA with A = W ∂e(θ̄ ⊕ δ)/∂δ by the 8th-order central stencil
(``jacobian8``) through each variable's retraction, so it shares only the factors' errors with the code under test:
the batch result's sparse queries and the Bayes tree's walk down must both give its blocks. Levenberg-Marquardt is
started far enough away that steps are rejected: a rejected step must leave the estimate and its cost where they
were, and ``converged`` must agree with the stationarity check at the estimate returned.
"""

from __future__ import annotations

import numpy as np
import pytest
from finite_differences import jacobian8

import steam_ref as sr
from steam_ref.batch import check_stationarity, gauss_newton, levenberg_marquardt
from steam_ref.bayes_tree import IncrementalSolver
from steam_ref.factors.lie_prior import LieStatePrior, lie_prior_factors
from steam_ref.factors.lie_readings import PoseReading
from steam_ref.graph import FactorGraph
from steam_ref.lie import SE2, SE2_STATE
from steam_ref.variables import L, Values, X


def _problem(seed: int, n: int = 6, n_landmarks: int = 3):
    """SE(2) states under the WNOA prior, every state reading every landmark's bearing and range, a prior on the first
    state and on each landmark; (factors, the states and landmarks near which the readings were made)."""
    rng = np.random.default_rng(seed)
    keys = [X(i) for i in range(n)]
    factors: list = list(lie_prior_factors(keys, np.arange(n) * 0.7, np.diag([0.1, 0.2, 0.3]), group=SE2))
    states = {
        k: np.array([0.5 * i, 0.2 * i, 0.3 * i, 0.7, 0.0, 0.3]) + rng.normal(size=6) * 0.05 for i, k in enumerate(keys)
    }
    landmarks = {L(j): rng.normal(size=2) * 4 for j in range(n_landmarks)}
    factors.append(LieStatePrior.create(keys[0], states[keys[0]], 0.1, group=SE2))
    factors += [sr.PriorFactor.create(k, l, 1.0) for k, l in landmarks.items()]
    for k, x in states.items():
        for lk, l in landmarks.items():
            d = l - x[:2]
            bearing = np.arctan2(d[1], d[0]) - x[2] + rng.normal() * 0.05
            rng_ = np.hypot(*d) + rng.normal() * 0.1
            factors.append(PoseReading.bearing_range(k, lk, bearing, rng_, np.array([0.05, 0.1]), group=SE2))
    return factors, {**states, **landmarks}


def _dense_covariance(factors, values: Values, order: list) -> tuple[np.ndarray, dict]:
    """(AᵀA)⁻¹ with A by differences of the whitened errors along each variable's retraction, and each key's slice."""
    dims = [values.dim(k) for k in order]
    offsets = np.concatenate([[0], np.cumsum(dims)])
    at = {k: slice(int(offsets[i]), int(offsets[i + 1])) for i, k in enumerate(order)}
    rows = []
    for f in factors:
        row = np.zeros((f.dim, int(offsets[-1])))
        for k in f.keys:
            whitened = lambda d, k=k, f=f: f.sqrt_information @ f.error(*[values.retract({k: d})[j] for j in f.keys])
            row[:, at[k]] = jacobian8(whitened, values.dim(k))
        rows.append(row)
    A = np.vstack(rows)
    return np.linalg.inv(A.T @ A), at


@pytest.mark.parametrize("seed", [3, 11])
def test_se2_covariances_with_landmarks_equal_the_dense_inverse_from_differences(seed):
    factors, near = _problem(seed)
    rng = np.random.default_rng(seed + 100)
    start = Values({k: v + (np.r_[rng.normal(size=3) * 0.05, 0, 0, 0] if len(v) == 6 else 0) for k, v in near.items()})
    result = gauss_newton(factors, start)
    assert result.converged, result.reason
    order = list(near)
    dense, at = _dense_covariance(factors, result.values, order)
    query = [X(2), L(1), X(5), L(0)]
    idx = np.concatenate([np.arange(at[k].start, at[k].stop) for k in query])
    expected = dense[np.ix_(idx, idx)]
    tol = 1e-9 * np.abs(expected).max()
    np.testing.assert_allclose(result.joint_covariance(query), expected, rtol=0, atol=tol)
    for k, block in result.marginal_covariances(order).items():
        np.testing.assert_allclose(block, dense[at[k], at[k]], rtol=0, atol=tol)
    solver = IncrementalSolver()  # linearized at the batch's estimate: its tree's 𝓘 is the same
    solver.update(factors, result.values)
    np.testing.assert_allclose(solver.joint_covariance(query), expected, rtol=0, atol=tol)
    for k, block in solver.marginal_covariances(order).items():
        np.testing.assert_allclose(block, dense[at[k], at[k]], rtol=0, atol=tol)


def test_levenberg_marquardt_after_rejected_steps_keeps_its_estimate_and_certifies_only_a_stationary_point():
    factors, near = _problem(3)
    rng = np.random.default_rng(4)  # headings off by up to ~3 rad, landmarks by metres: LM rejects steps
    start = {
        k: SE2_STATE.retract(v, np.r_[rng.normal(size=2) * 2, rng.normal() * 1.5, 0, 0, 0])
        if len(v) == 6
        else v + rng.normal(size=2) * 2
        for k, v in near.items()
    }
    result = levenberg_marquardt(factors, start, initial_damping=1e-8, max_iterations=60)
    rejected = [i for i, it in enumerate(result.iterations) if not it.accepted]
    assert rejected, "the start was meant to make LM reject a step"
    before = [result.initial_cost] + [it.cost for it in result.iterations[:-1]]
    for i in rejected:
        assert result.iterations[i].cost == before[i]  # a rejected step reports the cost it kept
    for i, it in enumerate(result.iterations):
        if it.accepted:
            assert it.cost < before[i]
        if i and not result.iterations[i - 1].accepted:
            assert it.damping == pytest.approx(result.iterations[i - 1].damping * 10)  # λ raised after a rejection
    graph = FactorGraph(factors)
    assert result.cost == graph.error(result.values)  # the cost reported is the estimate's
    found = check_stationarity(graph, result.values, result.ordering)
    assert result.converged == found.holds(1e-8, 1e-12)
    assert result.converged, result.reason
