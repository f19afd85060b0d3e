"""Relaxed clique amalgamation [AG89] (``ISAM2Params.amalgamation_zeros``) against brute force and dense algebra.

Oracles: the merged cliques' explicit zeros counted entry by entry from the unmerged elimination's separators;
numpy.linalg.solve and the dense inverse of AᵀA for the merged tree's solution and covariances; the unmerged run of
the same stream (wildfire threshold 0: the same δ to rounding). With the fraction 0 nothing merges: the cliques are
those of [K12 Alg. 2], variable by variable.
"""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
from cli_runs import run_module, runner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_bayes_tree import dense_system, random_sparse_factors
from test_isam import ACTIONS, Stream, assert_matches_dense, natural_system

import steam_ref as sr
from steam_ref import covariance
from steam_ref.bayes_tree import BayesTree, IncrementalSolver, eliminate
from steam_ref.bayes_tree.dot import tree_nnz
from steam_ref.bayes_tree.symbolic import CliqueTree, build_cliques, symbolic_elimination
from steam_ref.errors import SteamError
from steam_ref.linear import Ordering

# --- the parameter --------------------------------------------------------------------------


@pytest.mark.parametrize("bad", [-0.1, 1, 1.5, math.nan, math.inf, "0.3", True, None, [0.1]])
def test_a_zero_fraction_outside_0_to_1_is_refused_by_name(bad):
    with pytest.raises(SteamError, match=re.escape(f"amalgamation_zeros must be a fraction in [0, 1), got {bad!r}")):
        sr.ISAM2Params(amalgamation_zeros=bad)
    with pytest.raises(SteamError, match="amalgamation_zeros"):
        IncrementalSolver(amalgamation_zeros=bad)


def test_the_default_is_off_and_a_fraction_is_kept_as_a_float():
    assert sr.ISAM2Params().amalgamation_zeros == 0.0
    params = sr.ISAM2Params(amalgamation_zeros=np.float32(0.25))
    assert type(params.amalgamation_zeros) is float and params.amalgamation_zeros == 0.25


# --- structure --------------------------------------------------------------------------------


def random_graph(rng: np.random.Generator, n: int = 14) -> tuple[list[int], list[tuple[int, ...]], dict[int, int]]:
    """A random elimination order, factors on 1-3 variables (each variable in at least one), sizes 1-6."""
    factors = [tuple(int(v) for v in rng.choice(n, size=int(rng.integers(1, 4)), replace=False)) for _ in range(n)]
    factors += [(v,) for v in range(n)]
    return [int(v) for v in rng.permutation(n)], factors, {v: int(rng.integers(1, 7)) for v in range(n)}


def tree_of(cliques) -> CliqueTree:
    tree: CliqueTree = CliqueTree()
    tree.insert_eliminated(cliques, [c.parent for c in cliques])
    return tree


def zeros_by_hand(frontals: tuple, separator: tuple, separators: dict, dims: dict) -> tuple[int, int]:
    """(explicit zeros, entries) of a clique's dense rows of R, entry by entry: the row block of a frontal v is
    nonzero in the unmerged R only at v itself and at its separator sᵢ [K12 Alg. 1]."""
    columns = [(v, i) for v in frontals + separator for i in range(dims[v])]
    zeros = entries = 0
    for r, (v, i) in enumerate(columns[: sum(dims[v] for v in frontals)]):
        for w, j in columns[r:]:
            entries += 1
            zeros += not (w == v and j >= i) and w not in separators[v]
    return zeros, entries


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), z=st.sampled_from([0.05, 0.2, 0.3, 0.5, 0.9]))
def test_merged_cliques_are_unions_along_tree_edges_with_at_most_z_zeros(seed, z):
    order, factors, dims = random_graph(np.random.default_rng(seed))
    separators, _ = symbolic_elimination(order, factors)
    plain, merged = tree_of(build_cliques(order, factors, dims)), tree_of(build_cliques(order, factors, dims, z))
    assert merged.problems() == []
    for c in merged.cliques.values():  # each merged clique is a connected set of unmerged cliques, whole
        parts = {plain.frontal_of[v] for v in c.frontals}
        assert sorted(v for p in parts for v in plain.cliques[p].frontals) == sorted(c.frontals)
        tops = [p for p in parts if plain.parent[p] not in parts]
        assert len(tops) == 1 and plain.cliques[tops[0]].separator == c.separator
        zeros, entries = zeros_by_hand(c.frontals, c.separator, separators, dims)
        assert zeros <= z * entries
        # the clique's frontals in an order that eliminates: no frontal in the separator of a later one
        assert all(v not in separators[w] for i, v in enumerate(c.frontals) for w in c.frontals[i + 1 :])
    # every input factor is eliminated in the clique that holds its first variable as a frontal
    for clique in build_cliques(order, factors, dims, z):
        for j in clique.factors:
            assert min(factors[j], key=order.index) in clique.frontals


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_with_zero_fraction_the_cliques_are_k12s(seed):
    """The cliques of [K12 Alg. 2]: each dense (no explicit zero), and no child whose separator is all of its parent's
    variables (a merge that would add no zero is already made)."""
    order, factors, dims = random_graph(np.random.default_rng(seed))
    separators, _ = symbolic_elimination(order, factors)
    cliques = build_cliques(order, factors, dims, 0.0)
    assert cliques == build_cliques(order, factors)
    tree = tree_of(cliques)
    for cid, c in tree.cliques.items():
        assert zeros_by_hand(c.frontals, c.separator, separators, dims)[0] == 0
        p = tree.parent[cid]
        if p is not None:
            assert set(c.separator) != set(tree.cliques[p].frontals + tree.cliques[p].separator)


def test_the_toy_merges_as_counted_by_hand():
    """The toy of tests/test_bayes_tree_symbolic.py, sizes 1: [a : c] (2 entries), [b : c] (2), [c : d] (2), [d e f]
    (6). a into c: 5 entries, 1 zero (0.2); then b: 9 entries, 3 zeros (1/3); the root: 15 entries, 5 or 9 zeros."""
    toy, order = [("a", "c"), ("b", "c"), ("c", "d"), ("d", "e"), ("d", "f"), ("e", "f")], list("abcdef")
    shapes = {
        0.19: [("a",), ("b",), ("c",), ("d", "e", "f")],
        0.2: [("b",), ("a", "c"), ("d", "e", "f")],
        0.4: [("b", "a", "c"), ("d", "e", "f")],
        0.6: [("b", "a", "c", "d", "e", "f")],
    }
    for z, frontals in shapes.items():
        assert [c.frontals for c in build_cliques(order, toy, None, z)] == frontals, z


# --- numbers: the merged tree against dense algebra ------------------------------------------


@pytest.mark.parametrize("trial", range(6))
def test_a_merged_tree_solves_and_recovers_covariances_as_the_dense_inverse(rng, trial):
    factors, dims = random_sparse_factors(rng, n_vars=12, n_factors=20)
    keys = list(dims)
    order = [keys[i] for i in rng.permutation(len(keys))]
    plain, tree = BayesTree.from_factors(factors, order), BayesTree()
    cliques, parents, _ = eliminate(order, factors, amalgamation_zeros=0.6)
    tree.insert_eliminated(cliques, parents)
    assert tree.problems() == [] and len(tree) < len(plain)  # something merged
    natural = Ordering(tuple(keys), tuple(dims[k] for k in keys))
    A, b = dense_system(factors, natural)
    info = A.T @ A
    reference, cov = np.linalg.solve(info, A.T @ b), np.linalg.inv(info)
    delta = tree.solve()
    np.testing.assert_allclose(np.concatenate([delta[k] for k in keys]), reference, rtol=1e-9, atol=1e-12)
    R, _, ordering = tree.to_dense()
    p = ordering.scalar_permutation(natural)
    np.testing.assert_allclose(R.T @ R, info[np.ix_(p, p)], rtol=1e-9, atol=1e-9 * np.abs(info).max())

    def block(group):
        idx = np.concatenate([natural.offset_of[k] + np.arange(dims[k]) for k in group])
        return cov[np.ix_(idx, idx)]

    marginals = covariance.tree_marginal_covariances(tree)
    for k in keys:
        np.testing.assert_allclose(marginals[k], block([k]), rtol=1e-9, atol=1e-12)
    big = max(tree.cliques.values(), key=lambda c: len(c.frontals))  # within one merged clique, and across cliques
    for group in (list(big.frontals), [big.frontals[0], *big.separator], [keys[0], keys[-1], keys[5]]):
        np.testing.assert_allclose(covariance.tree_joint_covariance(tree, group), block(group), rtol=1e-9, atol=1e-12)


# --- iSAM2 with merged cliques -----------------------------------------------------------------


def tree_cliques_nnz(solver: IncrementalSolver) -> int:
    """R's entries counted from the stored arrays: each clique's upper triangle of R and all of S."""
    return sum(c.R.shape[0] * (c.R.shape[0] + 1) // 2 + c.S.size for c in solver.tree.cliques.values())


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), actions=ACTIONS, z=st.sampled_from([0.3, 0.5, 0.8]))
def test_merged_updates_match_the_dense_solve_and_the_unmerged_run(seed, actions, z):
    """Wildfire threshold 0: after every update δ is the dense solve's and the unmerged solver's, to rounding; the
    running fill counts the merged cliques' entries."""
    streams = [Stream(np.random.default_rng(seed), n_states=20, n_landmarks=2) for _ in range(2)]
    plain, merged = (
        IncrementalSolver(relinearize_skip=1, wildfire_threshold=0.0, amalgamation_zeros=a) for a in (0, z)
    )
    for action in ["state"] + actions:
        reports = [s.update(*stream.step(action)) for s, stream in zip((plain, merged), streams, strict=True)]
        assert_matches_dense(merged, exact_delta=True)
        a, b = plain.delta(), merged.delta()
        assert a.keys() == b.keys()
        for k in a:
            np.testing.assert_allclose(b[k], a[k], rtol=1e-9, atol=1e-12, err_msg=str(k))
        assert reports[1].tree_nnz == tree_cliques_nnz(merged) == tree_nnz(merged.tree.cliques.values())
        assert len(merged.tree) <= len(plain.tree)
    assert len(merged.tree) < len(plain.tree) or len(plain.tree) == 1


def test_merged_isam2_covariances_equal_the_dense_inverse(rng):
    stream = Stream(rng, n_states=14)
    solver = IncrementalSolver(relinearize_threshold=0.05, relinearize_skip=1, amalgamation_zeros=0.5)
    for action in ["state"] * 14 + ["extra"] * 3:
        solver.update(*stream.step(action))
    assert any(len(c.frontals) > 1 and c.separator for c in solver.tree.cliques.values())
    system, ordering = natural_system(solver)
    J, _ = system.to_dense()
    cov = np.linalg.inv(J.T @ J)
    marginals = solver.marginal_covariances()
    for k in ordering.keys:
        o, d = ordering.offset_of[k], ordering.dims[ordering.position[k]]
        np.testing.assert_allclose(marginals[k], cov[o : o + d, o : o + d], rtol=1e-9, atol=1e-12)
    for c in solver.tree.cliques.values():  # the joint of each merged clique's frontals and separator
        group = list(c.frontals + c.separator)
        idx = np.concatenate([ordering.offset_of[k] + np.arange(solver.state.dims[k]) for k in group])
        np.testing.assert_allclose(solver.joint_covariance(group), cov[np.ix_(idx, idx)], rtol=1e-9, atol=1e-12)


def test_the_dot_text_labels_each_merged_clique_with_all_its_frontals(rng):
    stream = Stream(rng, n_states=10)
    solver = IncrementalSolver(amalgamation_zeros=0.5)
    for _ in range(10):
        solver.update(*stream.step("state"))
    labels = re.findall(r'\[label="([^"]*)"\]', solver.tree.dot())
    expected = []
    for c in solver.tree.cliques.values():
        frontals = ", ".join(f"{k.symbol}{k.index}" for k in c.frontals)
        sep = ", ".join(f"{k.symbol}{k.index}" for k in sorted(c.separator, key=lambda k: (ord(k.symbol), k.index)))
        expected.append(frontals + (f" : {sep}" if c.separator else ""))
    assert sorted(labels) == sorted(expected)
    assert any(len(c.frontals) > 1 and c.separator for c in solver.tree.cliques.values())


# --- the command line ---------------------------------------------------------------------------


run = runner("run")


def test_the_run_option_gives_the_librarys_merged_run(tmp_path, capsys):
    """(in this process, through the command's entry point: the claim is the run's, not the process's)"""
    from steam_ref.datasets import generate_synthetic
    from steam_ref.paper.online import run_online
    from steam_ref.paper.options import StreamOptions
    from steam_ref.paper.presets import PaperSetup

    rmse, dots = {}, {}
    for z in ("0.4", "0"):
        dot = tmp_path / f"z{z}.dot"
        code, out, err = run(capsys, "--steps", "60", "--amalgamation-zeros", z, "--json", "--tree-dot", dot)
        assert code == 0, err
        rmse[z], dots[z] = json.loads(out)["rmse_m"], dot.read_text()
    setup, data = PaperSetup.synthetic(), generate_synthetic(n_steps=60, n_landmarks=12, seed=0)  # --steps 60's task
    merged = run_online(data, setup.with_isam2(amalgamation_zeros=0.4), StreamOptions())
    assert rmse["0.4"] == round(merged.rmse_m, 6)
    assert abs(rmse["0.4"] - rmse["0"]) < 1e-3  # within what the wildfire threshold lets through
    # the flag reaches the tree: fewer cliques, some holding several states over a separator
    assert dots["0.4"].count("[label=") < dots["0"].count("[label=")
    assert re.search(r'label="x\d+, x\d+[^"]* : ', dots["0.4"])


@pytest.mark.parametrize("bad", ["1", "-0.1", "nan", "abc"])
def test_the_run_option_refuses_a_bad_fraction_in_one_line(bad):
    out = run_module("run", "--amalgamation-zeros", bad)  # a real process: its exit code
    assert out.returncode == 2
    assert f"--amalgamation-zeros: expected a fraction >= 0 and < 1, got {bad!r}" in out.stderr
