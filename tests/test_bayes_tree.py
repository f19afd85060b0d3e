"""The numeric Bayes tree against dense linear algebra.  [YIB Eq. 11, 21, 24-25]

Oracles: numpy.linalg.solve on AᵀA, the dense inverse for covariances, and Eq. 25 written out
with a† = (aᵀa)⁻¹aᵀ for a single scalar variable.
"""

from __future__ import annotations

import numpy as np
import pytest
from problems import small_problem

import steam_ref as sr
from steam_ref.bayes_tree import BayesTree, eliminate_clique
from steam_ref.errors import UnderdeterminedError
from steam_ref.linear import LinearSystem, Ordering, amd_ordering, constrained_min_degree, xl_ordering
from steam_ref.linear.system import GaussianFactor, linearize
from steam_ref.variables import Key


def random_sparse_factors(
    rng: np.random.Generator, n_vars: int = 9, n_factors: int = 14
) -> tuple[list[GaussianFactor], dict]:
    """Random linear factors on variables of sizes 1-3, each variable with a full-rank prior."""
    dims = {Key("v", i): int(rng.integers(1, 4)) for i in range(n_vars)}
    keys = list(dims)
    factors = []
    for _ in range(n_factors):
        chosen = [keys[i] for i in rng.choice(n_vars, size=int(rng.integers(1, 4)), replace=False)]
        m = int(rng.integers(1, 5))
        factors.append(
            GaussianFactor(tuple(chosen), tuple(rng.normal(size=(m, dims[k])) for k in chosen), rng.normal(size=m))
        )
    for k in keys:  # keep the problem well posed
        factors.append(
            GaussianFactor((k,), (rng.normal(size=(dims[k], dims[k])) + 3 * np.eye(dims[k]),), rng.normal(size=dims[k]))
        )
    return factors, dims


def dense_system(factors: list[GaussianFactor], ordering: Ordering) -> tuple[np.ndarray, np.ndarray]:
    """Stack the factors into a dense A, b with columns in ``ordering``."""
    A = np.zeros((sum(f.rhs.shape[0] for f in factors), ordering.total_dim))
    b, r = np.zeros(A.shape[0]), 0
    for f in factors:
        m = f.rhs.shape[0]
        for k, block in zip(f.keys, f.blocks, strict=True):
            o = ordering.offset_of[k]
            A[r : r + m, o : o + block.shape[1]] += block
        b[r : r + m] = f.rhs
        r += m
    return A, b


def stacked(delta: dict, ordering: Ordering) -> np.ndarray:
    return np.concatenate([delta[k] for k in ordering.keys])


@pytest.mark.parametrize("trial", range(6))
def test_random_sparse_problem_matches_dense_solve(rng, trial):
    factors, dims = random_sparse_factors(rng)
    keys = list(dims)
    order = (
        [keys[i] for i in rng.permutation(len(keys))]
        if trial % 2
        else constrained_min_degree(keys, dims, [f.keys for f in factors]).keys
    )
    tree = BayesTree.from_factors(factors, order)
    assert tree.problems() == []
    natural = Ordering(tuple(keys), tuple(dims[k] for k in keys))
    A, b = dense_system(factors, natural)
    reference = np.linalg.solve(A.T @ A, A.T @ b)
    np.testing.assert_allclose(
        stacked(tree.solve(), natural), reference, rtol=1e-9, atol=1e-12 * np.abs(reference).max()
    )
    # RᵀR is AᵀA permuted into the tree's elimination order  [YIB Eq. 11, 21]
    R, d, ordering = tree.to_dense()
    assert np.allclose(R, np.triu(R), rtol=0, atol=0)
    p = ordering.scalar_permutation(natural)
    info = (A.T @ A)[np.ix_(p, p)]
    np.testing.assert_allclose(R.T @ R, info, rtol=1e-9, atol=1e-12 * np.abs(info).max())
    np.testing.assert_allclose(np.linalg.solve(R, d), reference[p], rtol=1e-9, atol=1e-12 * np.abs(reference).max())


@pytest.mark.parametrize("ordering_name", ["xl", "amd", "min_degree"])
def test_gp_trajectory_with_landmarks_matches_dense_solve(rng, ordering_name):
    problem = small_problem(rng, n_states=15, n_landmarks=3, interpolated=4)
    values = problem.initial
    keys = problem.graph.keys()
    dims = {k: values.dim(k) for k in keys}
    factor_keys = [f.keys for f in problem.graph]
    if ordering_name == "xl":
        ordering = xl_ordering(keys, dims)
    elif ordering_name == "amd":
        ordering = amd_ordering(keys, dims, factor_keys)
    else:
        ordering = constrained_min_degree(keys, dims, factor_keys)
    gaussian = [gf for group in linearize(problem.graph.factors, values) for gf in group.gaussian_factors()]
    tree = BayesTree.from_factors(gaussian, ordering)
    assert tree.problems() == []
    system = LinearSystem.build(problem.graph.factors, values, ordering)
    A, b = system.to_dense()
    reference = np.linalg.solve(A.T @ A, A.T @ b)
    np.testing.assert_allclose(
        stacked(tree.solve(), ordering), reference, rtol=1e-9, atol=1e-12 * np.abs(reference).max()
    )
    R, _, tree_order = tree.to_dense()
    p = tree_order.scalar_permutation(ordering)
    info = (A.T @ A)[np.ix_(p, p)]
    np.testing.assert_allclose(R.T @ R, info, rtol=1e-9, atol=1e-12 * np.abs(info).max())


def _root_frontals(tree: BayesTree) -> tuple[Key, ...]:
    (root,) = tree.roots
    return tree.cliques[root].frontals


def _min_degree_orderings(keys: list[Key], dims: dict, factor_keys: list) -> dict[str, Ordering | list[Key]]:
    return {
        "amd": amd_ordering(keys, dims, factor_keys),
        "constrained": constrained_min_degree(keys, dims, factor_keys),
    }


def test_landmarks_seen_all_along_the_path_end_in_the_root_under_any_ordering(rng):
    """small_problem ranges landmark i % 4 from state i, so each landmark is tied to states from
    one end of the path to the other: eliminating the states, in whatever order, joins all four
    landmarks, and XL and both minimum-degree orderings all put them in the root (of equal size)."""
    problem = small_problem(rng, n_states=20, n_landmarks=4)
    keys = problem.graph.keys()
    dims = {k: problem.initial.dim(k) for k in keys}
    factor_keys = [f.keys for f in problem.graph]
    gaussian = [gf for group in linearize(problem.graph.factors, problem.initial) for gf in group.gaussian_factors()]
    orderings = {"xl": xl_ordering(keys, dims), **_min_degree_orderings(keys, dims, factor_keys)}
    for name, ordering in orderings.items():
        frontals = _root_frontals(BayesTree.from_factors(gaussian, ordering))
        assert {k for k in frontals if k.symbol == "l"} == {sr.L(j) for j in range(4)}, name
        assert sum(dims[k] for k in frontals) == 4 * 2 + 2 * 6, name  # the landmarks and two states


def local_landmark_factors(
    rng: np.random.Generator, n_states: int = 40, per: int = 5
) -> tuple[list[GaussianFactor], dict]:
    """Random linear factors with the paper's exploration structure: a chain of 6-d states, each
    state ranged to the one 2-d landmark of its stretch (states per*j ... per*j + per - 1 see l_j)."""
    dims = {**{Key("x", i): 6 for i in range(n_states)}, **{Key("l", j): 2 for j in range(n_states // per)}}

    def factor(*keys: Key) -> GaussianFactor:
        m = sum(dims[k] for k in keys)
        return GaussianFactor(keys, tuple(rng.normal(size=(m, dims[k])) for k in keys), rng.normal(size=m))

    factors = [factor(Key("x", 0))] + [factor(Key("l", j)) for j in range(n_states // per)]
    factors += [factor(Key("x", i), Key("x", i + 1)) for i in range(n_states - 1)]
    factors += [factor(Key("x", i), Key("l", i // per)) for i in range(n_states)]
    return factors, dims


def test_min_degree_spreads_local_landmarks_that_xl_puts_in_the_root(rng):
    """When each landmark is seen from one stretch of the path only, minimum degree eliminates it
    with its stretch, so the root holds at most one landmark (and two states); XL eliminates every
    state first, which joins all landmarks along the chain, so its root holds all eight (28 columns)."""
    factors, dims = local_landmark_factors(rng)
    keys = list(dims)
    landmarks = {k for k in keys if k.symbol == "l"}
    factor_keys = [f.keys for f in factors]
    natural = Ordering(tuple(keys), tuple(dims[k] for k in keys))
    A, b = dense_system(factors, natural)
    reference = np.linalg.solve(A.T @ A, A.T @ b)
    xl = BayesTree.from_factors(factors, xl_ordering(keys, dims))
    assert {k for k in _root_frontals(xl) if k.symbol == "l"} == landmarks and len(landmarks) == 8
    xl_root = sum(dims[k] for k in _root_frontals(xl))
    for name, ordering in _min_degree_orderings(keys, dims, factor_keys).items():
        tree = BayesTree.from_factors(factors, ordering)
        assert tree.problems() == [], name
        np.testing.assert_allclose(
            stacked(tree.solve(), natural), reference, rtol=1e-9, atol=1e-12 * np.abs(reference).max()
        )
        frontals = _root_frontals(tree)
        assert len(landmarks & set(frontals)) <= 1, (name, frontals)
        assert sum(dims[k] for k in frontals) <= 2 * 6 + 2 < xl_root, (name, frontals)  # two states, one landmark


def test_one_scalar_elimination_is_eq_25(rng):
    """θ scalar, separator s (3 scalars): r = (a†A_s)ᵀ, d = a†b with a† = (aᵀa)⁻¹aᵀ.  [YIB Eq. 25]"""
    theta, s1, s2 = Key("t", 0), Key("s", 1), Key("s", 2)
    a, A1, A2, b = rng.normal(size=(5, 1)), rng.normal(size=(5, 1)), rng.normal(size=(5, 2)), rng.normal(size=5)
    clique = eliminate_clique(
        (theta,), (s1, s2), {theta: 1, s1: 1, s2: 2}, [GaussianFactor((theta, s1, s2), (a, A1, A2), b)]
    )
    a_dagger = np.linalg.solve(a.T @ a, a.T)
    r = (a_dagger @ np.hstack([A1, A2])).ravel()
    np.testing.assert_allclose(clique.S.ravel() / clique.R[0, 0], r, rtol=1e-12)
    np.testing.assert_allclose(clique.d / clique.R[0, 0], a_dagger @ b, rtol=1e-12)
    g, G = clique.solved  # the solved form back-substitution uses: G is the paper's rᵀ, g its d
    np.testing.assert_allclose(G.ravel(), r, rtol=1e-12)
    np.testing.assert_allclose(g, a_dagger @ b, rtol=1e-12)
    # the factor left on the separator: ‖A_s s - b‖² minimized over θ, i.e. projected off a  [YIB Eq. 24]
    P = np.eye(5) - a @ a_dagger
    As, bs = np.hstack(clique.marginal.blocks), clique.marginal.rhs
    np.testing.assert_allclose(As.T @ As, np.hstack([A1, A2]).T @ P @ np.hstack([A1, A2]), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(As.T @ bs, np.hstack([A1, A2]).T @ P @ b, rtol=1e-10, atol=1e-12)


def test_unconstrained_variable_is_named(rng):
    x, lm = Key("x", 0), Key("l", 7)
    factors = [
        GaussianFactor((x,), (np.eye(2),), rng.normal(size=2)),
        GaussianFactor(
            (x, lm), (rng.normal(size=(1, 2)), rng.normal(size=(1, 2))), rng.normal(size=1)
        ),  # one range: l7 free
    ]
    with pytest.raises(UnderdeterminedError, match="l7"):
        BayesTree.from_factors(factors, [lm, x])
