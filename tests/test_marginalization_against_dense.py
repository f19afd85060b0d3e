"""Marginalization of a linearized nonlinear problem against the dense Schur complement, and its history smoothed.

A stream of WNOA states reading 2-D landmarks by range (nonlinear) goes to an :class:`IncrementalSolver` that never
relinearizes (``relinearize_threshold=inf``): every factor, the marginal factors too, stays linearized at the first
guesses θ̄, far from the optimum, so δ is large. Then the linear problem ‖A δ - b‖² the solver holds is known densely:
A the whitened Jacobians of every factor ever given at θ̄, b = -W e(θ̄), H = AᵀA, g = Aᵀb. After each
``marginalize_leaves`` of drawn states and landmarks (both paths: leaves cut off, and re-elimination with D first):

- the tree's information over the window, RᵀR and Rᵀd, is the dense Schur complement of everything forgotten so far
  in (H, g) [derivations Eq. 10.1-10.3], to 1e-10 of H's largest entry;
- δ of the window is the full problem's H⁻¹g there (a marginal keeps its mean), θ̄ untouched;
- the window's joint covariance is the block of H⁻¹ (to 1e-10 of its largest entry);

and at the end the forgotten conditionals (``keep_conditionals=True``), smoothed by :class:`History` from the final
window [derivations Eq. 10.5], give every forgotten variable θ̄ + H⁻¹g, the batch solution of the whole linearized
problem. On SE(2) states the same holds in the right tangent: θ̄ ⊕ H⁻¹g (the second test). The linear streams of
tests/test_fixed_lag.py and tests/test_fixed_lag_history.py have δ = the estimate's
own offset from a linearization point that moves; here θ̄ stays where the marginal factors froze it.
"""

from __future__ import annotations

import numpy as np
import pytest

from steam_ref.bayes_tree import IncrementalSolver
from steam_ref.bayes_tree.history import History
from steam_ref.factors import Factor, GPPriorFactor, PriorFactor, RangeFactor
from steam_ref.gp import process_noise, transition
from steam_ref.variables import Key, L, X

QC = np.diag([0.3, 0.2, 0.1])
FROZEN = dict(relinearize_threshold=np.inf, wildfire_threshold=0.0)  # θ̄ never moves; δ solved in full


def dense_system(factors: list[Factor], theta: dict[Key, np.ndarray], keys: list[Key]):
    """H = AᵀA and g = Aᵀb over ``keys`` (stacked in that order) of every factor linearized at ``theta``."""
    offset = dict(zip(keys, np.cumsum([0] + [theta[k].shape[0] for k in keys])[:-1], strict=True))
    n = sum(theta[k].shape[0] for k in keys)
    H, g = np.zeros((n, n)), np.zeros(n)
    for f in factors:
        xs = [theta[k] for k in f.keys]
        A = f.sqrt_information @ np.hstack(f.jacobians(*xs))
        b = -f.sqrt_information @ f.error(*xs)
        idx = np.concatenate([np.arange(offset[k], offset[k] + theta[k].shape[0]) for k in f.keys])
        H[np.ix_(idx, idx)] += A.T @ A
        g[idx] += A.T @ b
    return H, g, offset


def span(offset: dict, theta: dict, keys: list[Key]) -> np.ndarray:
    return np.concatenate([np.arange(offset[k], offset[k] + theta[k].shape[0]) for k in keys])


def stream_step(rng, i: int, x: np.ndarray, landmarks: np.ndarray, held: set, entered: set):
    """State X(i) after X(i-1): its GP prior, and ranges to two landmarks, each held or new (one that entered and was
    marginalized is not read again); a new one enters with a weak prior, so that one range leaves nothing free."""
    dt = float(rng.uniform(0.5, 1.5))
    x = transition(dt, 3) @ x + np.linalg.cholesky(process_noise(dt, QC)) @ rng.normal(size=6)
    factors: list[Factor] = [GPPriorFactor.wnoa(X(i - 1), X(i), dt, QC)]
    values = {X(i): x + rng.normal(size=6) * 0.5}
    for j in rng.choice(len(landmarks), size=2, replace=False):
        key = L(int(j))
        if key not in held and key in entered:
            continue
        if key not in held:
            values[key] = landmarks[j] + rng.normal(size=2)
            factors.append(PriorFactor.create(key, landmarks[j] + rng.normal(size=2), 3.0))
            entered.add(key)
        r = np.linalg.norm(landmarks[j] - x[:2]) + rng.normal() * 0.1
        factors.append(RangeFactor.create(X(i), key, abs(r), 0.1))
    return factors, values, x


def check_marginal(solver: IncrementalSolver, everything: list[Factor], theta: dict, gone: list[Key]) -> None:
    """The window against the dense Schur complement of ``gone`` in the whole linearized problem."""
    held = list(solver.state.dims)
    keys = held + gone
    H, g, offset = dense_system(everything, theta, keys)
    k, d = span(offset, theta, held), span(offset, theta, gone) if gone else np.zeros(0, dtype=int)
    solve = np.linalg.solve(H[np.ix_(d, d)], np.column_stack([H[np.ix_(d, k)], g[d]])) if gone else np.zeros((0, 0))
    schur = H[np.ix_(k, k)] - (H[np.ix_(k, d)] @ solve[:, :-1] if gone else 0)
    vec = g[k] - (H[np.ix_(k, d)] @ solve[:, -1] if gone else 0)
    R, rhs, ordering = solver.tree.to_dense()
    mine = span(offset, theta, list(ordering.keys))  # the tree's order, as indices into the dense system
    where = {i: p for p, i in enumerate(k)}
    perm = np.array([where[i] for i in mine])
    scale = np.abs(H).max()
    np.testing.assert_allclose(R.T @ R, schur[np.ix_(perm, perm)], rtol=0, atol=1e-10 * scale)
    np.testing.assert_allclose(R.T @ rhs, vec[perm], rtol=0, atol=1e-10 * scale)
    full = np.linalg.solve(H, g)
    cov = np.linalg.inv(H)
    delta = solver.delta()
    for key in held:
        np.testing.assert_array_equal(solver.linearization_point[key], theta[key], err_msg=f"θ̄ of {key} moved")
        s = span(offset, theta, [key])
        np.testing.assert_allclose(delta[key], full[s], rtol=0, atol=1e-9, err_msg=f"δ of {key}")
    want = cov[np.ix_(k, k)]
    np.testing.assert_allclose(solver.joint_covariance(held), want, rtol=0, atol=1e-10 * np.abs(want).max())


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_marginalizing_a_linearized_problem_leaves_the_dense_schur_complement_and_its_history_the_batch_solution(seed):
    rng = np.random.default_rng(seed)
    landmarks = rng.uniform(-6, 6, size=(5, 2))
    x = np.array([0.0, 0.0, 0.0, 1.0, 0.5, -0.2])
    solver, history = IncrementalSolver(**FROZEN), History()
    everything: list[Factor] = [PriorFactor.create(X(0), x + rng.normal(size=6) * 0.1, 0.1)]
    theta: dict[Key, np.ndarray] = {X(0): x + rng.normal(size=6)}
    solver.update(everything, dict(theta))
    gone: list[Key] = []
    entered: set[Key] = set()
    paths, kinds = set(), set()
    for i in range(1, 16):
        factors, values, x = stream_step(rng, i, x, landmarks, set(solver.state.dims), entered)
        solver.update(factors, values)
        everything += factors
        theta |= {k: np.asarray(v, dtype=float) for k, v in values.items()}
        candidates = [k for k in solver.state.dims if k != X(i)]  # the newest state stays: the next prior names it
        tree = solver.tree
        leaves = [tree.cliques[c].frontals for c in tree.cliques if not tree.children[c]]
        leaves = [list(f) for f in leaves if X(i) not in f and len(f) < len(candidates)]
        if len(candidates) > 2 and rng.uniform() < 0.6:
            if leaves and i % 2:  # the frontals of a leaf clique: cut off
                drop = leaves[int(rng.integers(len(leaves)))]
            else:  # any of them: mostly re-eliminated with D first
                drop = [candidates[j] for j in rng.choice(len(candidates), size=rng.integers(1, 4), replace=False)]
            report = solver.marginalize_leaves(drop, keep_conditionals=True)
            assert set(report.keys) == set(drop) and len(report.conditionals) == len(drop)
            assert report.leaves or not i % 2 or not leaves
            history.conditionals.extend(report.conditionals)
            gone += list(report.keys)
            paths.add(report.leaves)
            kinds |= {k.symbol for k in drop}
            check_marginal(solver, everything, theta, gone)
    assert paths == {True, False} and kinds == {"x", "l"}, (paths, kinds)
    every = list(solver.state.dims) + gone
    H, g, offset = dense_system(everything, theta, every)
    full = np.linalg.solve(H, g)
    smoothed = history.smooth(solver.estimate_of)
    assert set(smoothed) == set(gone)
    for key, value in smoothed.items():
        want = theta[key] + full[span(offset, theta, [key])]
        np.testing.assert_allclose(value, want, rtol=0, atol=1e-9, err_msg=f"smoothed {key}")
    assert np.abs(full).max() > 0.1  # δ far from zero: θ̄ is not the answer


def test_the_history_of_se2_states_smooths_to_the_batch_step_in_their_tangent():
    """The same on SE(2) states turning ~1.1 rad a step (tests/test_se2_solvers.py's problem, its Jacobians by central
    differences through the retraction): θ̄ never moves, so every forgotten state's smoothed value and every held
    one's estimate is θ̄ ⊕ δ, δ = H⁻¹g of the whole problem in the right tangent at θ̄ [derivations Eq. 10.5], to the
    differences' error; θ̄ + δ (a history that adds) lands measurably elsewhere."""
    from test_se2_solvers import dense_jacobian, kind, new_values, problem

    steps, guesses, _ = problem(3, 9)
    solver, history = IncrementalSolver(**FROZEN), History()
    drops = {3: [X(0)], 5: [X(2)], 6: [X(1), X(4)], 8: [X(3), X(6)]}  # leaves and middle states
    paths = set()
    for i, factors in enumerate(steps):
        solver.update(factors, new_values(i, guesses))
        if i in drops:
            report = solver.marginalize_leaves(drops[i], keep_conditionals=True)
            history.conditionals.extend(report.conditionals)
            paths.add(report.leaves)
    assert paths == {True, False}
    keys = list(guesses)
    r, J = dense_jacobian([f for fs in steps for f in fs], guesses, keys)
    delta = np.linalg.solve(J.T @ J, -J.T @ r)
    offset = dict(zip(keys, np.cumsum([0] + [len(guesses[k]) for k in keys])[:-1], strict=True))
    step = {k: delta[offset[k] : offset[k] + len(guesses[k])] for k in keys}
    want = {k: kind(k).retract(guesses[k], step[k]) for k in keys}
    got = history.smooth(solver.estimate_of) | dict(solver.estimate())
    assert set(got) == set(keys)
    for k in keys:
        assert np.abs(kind(k).local(want[k], got[k])).max() < 1e-6, (k, got[k], want[k])
    forgotten = [k for group in drops.values() for k in group]
    assert max(np.abs(guesses[k] + step[k] - want[k]).max() for k in forgotten) > 1e-2
