"""Covariance recovery against dense inverses.  [YIB Eq. 11: cov δθ* = 𝓘⁻¹, K11 Sec. 3]

Oracles: numpy.linalg.inv of AᵀA (built from the factors) and of RᵀR (the tree's own square-root
information matrix, assembled densely). The one-pass :func:`tree_marginal_covariances` is also checked
against the per-variable root walk and counted: it visits each clique once. Joint covariances of
variables far apart in a few-hundred-state tree are checked against the dense inverse, and their
memory (tracemalloc) against what any n × n, or even n × k, dense array would take.
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
import scipy.sparse as sp
from problems import small_problem
from test_bayes_tree import dense_system, random_sparse_factors
from test_linear import BACKENDS

import steam_ref as sr
from steam_ref import covariance
from steam_ref.bayes_tree import BayesTree
from steam_ref.covariance import (
    marginal_covariances,
    sparse_joint_covariance,
    tree_joint_covariance,
    tree_marginal_covariance,
    tree_marginal_covariances,
)
from steam_ref.errors import UnknownVariableError
from steam_ref.linear import LinearSystem, Ordering, constrained_min_degree, make_ordering, natural_ordering
from steam_ref.linear.system import linearize


def block_of(cov: np.ndarray, ordering: Ordering, keys) -> np.ndarray:
    idx = np.concatenate([ordering.offset_of[k] + np.arange(ordering.dims[ordering.position[k]]) for k in keys])
    return cov[np.ix_(idx, idx)]


def random_tree(rng, trial: int) -> tuple[BayesTree, list, dict]:
    """A tree of random linear factors, eliminated in a random or a min-degree order."""
    factors, dims = random_sparse_factors(rng, n_vars=12, n_factors=18)
    keys = list(dims)
    order = (
        [keys[i] for i in rng.permutation(len(keys))]
        if trial % 2
        else constrained_min_degree(keys, dims, [f.keys for f in factors]).keys
    )
    return BayesTree.from_factors(factors, order), factors, dims


@pytest.mark.parametrize("trial", range(6))
def test_tree_marginal_covariances_equal_dense_inverse(rng, trial):
    tree, factors, dims = random_tree(rng, trial)
    R, _, tree_order = tree.to_dense()
    from_R = np.linalg.inv(R.T @ R)
    natural = natural_ordering(list(dims), dims)
    A, _ = dense_system(factors, natural)
    from_A = np.linalg.inv(A.T @ A)
    marginals = tree_marginal_covariances(tree)
    assert set(marginals) == set(dims)
    for k, got in marginals.items():
        for cov, ordering in [(from_R, tree_order), (from_A, natural)]:
            block = block_of(cov, ordering, [k])
            np.testing.assert_allclose(got, block, rtol=1e-9, atol=1e-12 * np.abs(block).max())
        np.testing.assert_allclose(got, tree_marginal_covariance(tree, k), rtol=1e-12, atol=0)


@pytest.mark.parametrize("trial", range(4))
def test_tree_joint_covariance_equals_dense_inverse(rng, trial):
    tree, factors, dims = random_tree(rng, trial)
    natural = natural_ordering(list(dims), dims)
    A, _ = dense_system(factors, natural)
    cov = np.linalg.inv(A.T @ A)
    keys = list(dims)
    root = tree.cliques[next(iter(tree.roots))]
    groups = [keys[:2], [keys[5], keys[0], keys[9]], list(root.frontals), keys]
    for group in groups:
        block = block_of(cov, natural, group)
        np.testing.assert_allclose(
            tree_joint_covariance(tree, group), block, rtol=1e-9, atol=1e-12 * np.abs(block).max()
        )


def test_tree_marginal_covariances_of_some_keys_visit_only_their_root_paths(rng, monkeypatch):
    """A chain of 300 states: all marginals cost one clique step per clique; a few keys, their paths."""
    problem = small_problem(rng, n_states=300, n_landmarks=2)
    keys = problem.graph.keys()
    order = constrained_min_degree(keys, problem.initial.dims(), [f.keys for f in problem.graph])
    gaussian = [gf for g in linearize(problem.graph.factors, problem.initial) for gf in g.gaussian_factors()]
    tree = BayesTree.from_factors(gaussian, order)
    calls = []
    step = covariance._clique_covariance
    monkeypatch.setattr(covariance, "_clique_covariance", lambda clique, S: calls.append(clique) or step(clique, S))
    everything = tree_marginal_covariances(tree)
    assert len(calls) == len(tree) and len(everything) == len(keys)
    calls.clear()
    some = [sr.X(150), sr.L(1), sr.X(3)]
    got = tree_marginal_covariances(tree, some)
    assert list(got) == some
    paths = {c for k in some for c in tree.path_to_root(tree.clique_containing(k))}
    assert len(calls) == len(paths) < len(tree)
    for k in some:
        np.testing.assert_array_equal(got[k], everything[k])


def test_unknown_keys_are_named(rng):
    tree, _factors, dims = random_tree(rng, 0)
    with pytest.raises(UnknownVariableError, match="x7"):
        tree_marginal_covariances(tree, [sr.X(7)])
    with pytest.raises(UnknownVariableError, match="x7"):
        tree_joint_covariance(tree, [next(iter(dims)), sr.X(7)])
    problem = small_problem(rng, n_states=4, n_landmarks=1)
    with pytest.raises(UnknownVariableError, match="x9"):
        sparse_joint_covariance(problem.graph.factors, problem.initial, [sr.X(9)])


@pytest.fixture
def problem(rng):
    return small_problem(rng, n_states=12, n_landmarks=4, interpolated=5)


@pytest.mark.parametrize("backend", BACKENDS)
def test_marginal_covariances_equal_dense_inverse(problem, backend):
    keys = problem.graph.keys()
    dims = {k: problem.initial.dim(k) for k in keys}
    order = make_ordering("amd", keys, dims, [f.keys for f in problem.graph], backend)
    system = LinearSystem.build(problem.graph.factors, problem.initial, order)
    chosen = [sr.X(0), sr.X(7), sr.L(2)]
    cov = marginal_covariances(system, chosen, backend)
    A, _ = system.to_dense()
    dense = np.linalg.inv(A.T @ A)
    for k in chosen:
        np.testing.assert_allclose(cov[k], block_of(dense, order, [k]), rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("backend", BACKENDS)
def test_sparse_joint_covariance_equals_dense_inverse(problem, backend):
    keys = problem.graph.keys()
    natural = natural_ordering(keys, {k: problem.initial.dim(k) for k in keys})
    A, _ = LinearSystem.build(problem.graph.factors, problem.initial, natural).to_dense()
    dense = np.linalg.inv(A.T @ A)
    for group in [[sr.X(3)], [sr.X(11), sr.X(0), sr.L(3)], keys]:
        got = sparse_joint_covariance(problem.graph.factors, problem.initial, group, backend)
        block = block_of(dense, natural, group)
        np.testing.assert_allclose(got, block, rtol=1e-9, atol=1e-12 * np.abs(block).max())


@pytest.mark.parametrize("max_entries", [1, 100, 10**9])
def test_sparse_marginal_covariances_in_chunks_equal_dense_inverse(problem, max_entries, monkeypatch):
    """Every key's block, whether the solves take one key at a time (tiny budget), a few, or all at once."""
    from steam_ref.covariance import _blocks_of_inverse, sparse_marginal_covariances

    monkeypatch.setattr(covariance, "_blocks_of_inverse", lambda c, o, k: _blocks_of_inverse(c, o, k, max_entries))
    keys = problem.graph.keys()
    natural = natural_ordering(keys, {k: problem.initial.dim(k) for k in keys})
    A, _ = LinearSystem.build(problem.graph.factors, problem.initial, natural).to_dense()
    dense = np.linalg.inv(A.T @ A)
    got = sparse_marginal_covariances(problem.graph.factors, problem.initial, keys)
    assert list(got) == keys
    for k in keys:
        np.testing.assert_allclose(got[k], block_of(dense, natural, [k]), rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("trial", range(4))
def test_tree_joint_covariances_equal_dense_inverse(rng, trial):
    """Groups a clique holds whole (a clique's frontal and a separator variable) and groups it does not."""
    from steam_ref.covariance import tree_joint_covariances

    tree, factors, dims = random_tree(rng, trial)
    natural = natural_ordering(list(dims), dims)
    A, _ = dense_system(factors, natural)
    cov = np.linalg.inv(A.T @ A)
    keys = list(dims)
    held = [[c.frontals[0], c.separator[-1]] for c in tree.cliques.values() if c.separator]
    groups = held + [keys[:3], [keys[7], keys[1]], [keys[4]]]
    got = tree_joint_covariances(tree, groups)
    assert len(got) == len(groups) and len(held) > 0
    for group, block in zip(groups, got, strict=True):
        expected = block_of(cov, natural, group)
        np.testing.assert_allclose(block, expected, rtol=1e-9, atol=1e-12 * np.abs(expected).max())


@pytest.mark.parametrize("backend", BACKENDS)
def test_sparse_joint_covariances_equal_dense_inverse(problem, backend):
    from steam_ref.covariance import sparse_joint_covariances

    keys = problem.graph.keys()
    natural = natural_ordering(keys, {k: problem.initial.dim(k) for k in keys})
    A, _ = LinearSystem.build(problem.graph.factors, problem.initial, natural).to_dense()
    dense = np.linalg.inv(A.T @ A)
    groups = [[sr.X(3), sr.X(4)], [sr.X(11), sr.X(0), sr.L(3)], [sr.L(1)]]
    for group, got in zip(
        groups, sparse_joint_covariances(problem.graph.factors, problem.initial, groups, backend), strict=True
    ):
        block = block_of(dense, natural, group)
        np.testing.assert_allclose(got, block, rtol=1e-9, atol=1e-12 * np.abs(block).max())


def trajectory_tree(rng, n_states: int, ordering: str) -> tuple[BayesTree, object]:
    """A GP trajectory with 3 landmarks, linearized at its initial guess and eliminated into a tree in
    constrained minimum-degree order (deep: the first state ~n/2 cliques below the root) or AMD's."""
    problem = small_problem(rng, n_states=n_states, n_landmarks=3)
    keys = problem.graph.keys()
    dims = {k: problem.initial.dim(k) for k in keys}
    if ordering == "amd":
        order = make_ordering("amd", keys, dims, [f.keys for f in problem.graph])
    else:
        order = constrained_min_degree(keys, dims, [f.keys for f in problem.graph])
    gaussian = [gf for g in linearize(problem.graph.factors, problem.initial) for gf in g.gaussian_factors()]
    return BayesTree.from_factors(gaussian, order), problem


def _held_together(tree: BayesTree, keys) -> bool:
    """True when one clique holds every one of ``keys`` (frontal or separator)."""
    return any(set(keys) <= set(c.frontals) | set(c.separator) for c in tree.cliques.values())


@pytest.mark.parametrize("ordering", ["min_degree", "amd"])
def test_joint_covariance_of_far_apart_variables_equals_dense_inverse(rng, ordering):
    """First and last of 300 states, a landmark with a state, three states in three cliques."""
    n = 300
    tree, problem = trajectory_tree(rng, n, ordering)
    keys = problem.graph.keys()
    natural = natural_ordering(keys, {k: problem.initial.dim(k) for k in keys})
    A, _ = LinearSystem.build(problem.graph.factors, problem.initial, natural).to_dense()
    dense = np.linalg.inv(A.T @ A)
    first, middle, last = sr.X(0), sr.X(n // 2), sr.X(n - 1)
    assert len(tree.path_to_root(tree.clique_containing(first))) > n // 4  # far below the root
    assert len({tree.clique_containing(k) for k in (first, middle, last)}) == 3
    groups = [[first, last], [sr.L(1), first], [last, middle, first], [sr.X(77), sr.L(0), last, sr.X(201), first]]
    for group in groups:
        assert not _held_together(tree, group)
        block = block_of(dense, natural, group)
        got = tree_joint_covariance(tree, group)
        np.testing.assert_allclose(got, block, rtol=1e-8, atol=1e-10 * np.abs(block).max())
    assert np.abs(block_of(dense, natural, [first, last])[:6, 6:]).max() > 1e-8  # the cross block is not trivially zero


def test_joint_covariance_memory_does_not_grow_with_distance(rng):
    """2,000 states: the joint of the first and the last state takes no more memory than that of the
    first and its neighbour, both a walk of ~1,000 cliques, and far less than one dense (n, 12) block
    (1.2 MB; an n × n matrix would take 1.2 GB, the former R of the ~1,000 cliques' variables 0.3 GB)."""
    n = 2000
    tree, problem = trajectory_tree(rng, n, "min_degree")
    first, last = sr.X(0), sr.X(n - 1)
    paths = [set(tree.path_to_root(tree.clique_containing(k))) for k in (first, last)]
    assert len(paths[0]) >= n // 3 and not (paths[0] <= paths[1] or paths[1] <= paths[0])  # deep, in two branches
    n_scalar = sum(problem.initial.dim(k) for k in problem.graph.keys())

    def peak_bytes(keys) -> int:
        tracemalloc.start()
        try:
            tree_joint_covariance(tree, keys)
            return tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()

    near, far = peak_bytes([first, sr.X(1)]), peak_bytes([first, last])
    bound = 8 * n_scalar * 12  # float64 (n, 12): the right-hand side of two triangular solves with R
    assert far < bound / 2 and near < bound / 2, (far, near, bound)
    assert far < 2 * near + 64_000, (far, near)  # ~ constant in the distance: not even O(n · distance)


def test_sqrt_information_is_sparse_and_squares_to_the_information(rng):
    """The tree's assembled R (scipy.sparse, upper triangular): RᵀR = AᵀA in the tree's order, and its
    nonzeros fit in the cliques' [R S] blocks."""
    tree, factors, _ = random_tree(rng, 1)
    R, _, tree_order = tree.to_sparse()
    assert sp.issparse(R) and sp.triu(R).nnz == R.nnz
    assert R.nnz <= sum(c.R.shape[0] * (c.R.shape[1] + c.S.shape[1]) for c in tree.cliques.values())
    A, _ = dense_system(factors, tree_order)
    dense = R.toarray()
    np.testing.assert_allclose(dense.T @ dense, A.T @ A, rtol=1e-9, atol=1e-12 * np.abs(A.T @ A).max())
    np.testing.assert_array_equal(tree.to_dense()[0], dense)


def test_batch_result_covariances_equal_the_dense_inverse_at_its_estimate(problem):
    """BatchResult answers the four queries from its factors linearized at its own estimate (not the start)."""
    result = sr.gauss_newton(problem.graph, problem.initial)
    keys = problem.graph.keys()
    natural = natural_ordering(keys, {k: result.values.dim(k) for k in keys})
    A, _ = LinearSystem.build(problem.graph.factors, result.values, natural).to_dense()
    dense = np.linalg.inv(A.T @ A)
    last = block_of(dense, natural, [sr.X(11)])
    np.testing.assert_allclose(result.marginal_covariance(sr.X(11)), last, rtol=1e-9, atol=1e-12 * abs(last).max())
    marginals = result.marginal_covariances([sr.L(0), sr.X(0)])
    assert list(marginals) == [sr.L(0), sr.X(0)]
    for k, got in marginals.items():
        np.testing.assert_allclose(got, block_of(dense, natural, [k]), rtol=1e-9, atol=1e-12)
    group = [sr.X(11), sr.L(3), sr.X(0)]
    block = block_of(dense, natural, group)
    np.testing.assert_allclose(result.joint_covariance(group), block, rtol=1e-9, atol=1e-12 * abs(block).max())
    (again,) = result.joint_covariances([group])
    np.testing.assert_allclose(again, block, rtol=1e-9, atol=1e-12 * abs(block).max())
    at_start = sparse_joint_covariance(problem.graph.factors, problem.initial, [sr.X(11)])
    assert not np.allclose(at_start, last, rtol=1e-6, atol=0)  # the start's linearization is another answer
    with pytest.raises(UnknownVariableError, match="x99"):
        result.marginal_covariance(sr.X(99))


def test_a_batch_result_without_factors_says_it_has_no_covariance(problem):
    result = sr.gauss_newton(problem.graph, problem.initial)
    bare = sr.BatchResult(result.values, result.initial_cost)
    with pytest.raises(sr.SteamError, match="BatchResult keeps no factors"):
        bare.marginal_covariance(sr.X(0))


def test_the_sparse_covariance_functions_are_exported():
    from steam_ref.covariance import sparse_marginal_covariances

    assert sr.sparse_marginal_covariances is sparse_marginal_covariances
    assert sr.sparse_joint_covariance is sparse_joint_covariance
