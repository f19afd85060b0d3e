"""The sparse system and its solution against numpy.linalg, under each ordering and backend."""

from __future__ import annotations

import numpy as np
import pytest
from problems import small_problem

import steam_ref as sr
import steam_ref.batch
from steam_ref.factors import gp as gp_factors
from steam_ref.linear import LinearSystem, SparseCholesky, solve
from steam_ref.linear import ordering as orderings
from steam_ref.linear.ordering import make_ordering
from steam_ref.linear.system import linearize

BACKENDS = ["superlu", pytest.param("cholmod", marks=pytest.mark.needs_cholmod)]


@pytest.fixture
def problem(rng):
    return small_problem(rng, n_states=12, n_landmarks=4, interpolated=5)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("ordering", ["natural", "xl", "amd"])
def test_sparse_step_equals_dense(problem, ordering, backend):
    order = make_ordering(
        ordering, problem.graph.keys(), problem.initial.dims(), [f.keys for f in problem.graph], backend
    )
    system = LinearSystem.build(problem.graph.factors, problem.initial, order)
    A, b = system.to_dense()
    reference = np.linalg.solve(A.T @ A, A.T @ b)
    step, chol = solve(system, backend)
    assert chol.backend == backend
    np.testing.assert_allclose(step, reference, rtol=1e-9, atol=1e-12 * np.abs(reference).max())


def test_step_is_ordering_independent(problem):
    steps = {}
    for name in ["xl", "amd"]:
        order = make_ordering(name, problem.graph.keys(), problem.initial.dims(), [f.keys for f in problem.graph])
        steps[name] = LinearSystem.build(problem.graph.factors, problem.initial, order).split(
            solve(LinearSystem.build(problem.graph.factors, problem.initial, order))[0]
        )
    for k in steps["xl"]:
        np.testing.assert_allclose(steps["amd"][k], steps["xl"][k], rtol=1e-9, atol=1e-12)


def test_dense_A_rows_are_whitened_factors(rng):
    """A and b built by hand from each factor's own Jacobians and whitening, for one small graph."""
    p = small_problem(rng, n_states=3, n_landmarks=1, robust=False)
    order = make_ordering("xl", p.graph.keys(), p.initial.dims(), [f.keys for f in p.graph])
    A, b = LinearSystem.build(p.graph.factors, p.initial, order).to_dense()
    rows, rhs = [], []
    for f in p.graph.factors:
        xs = [p.initial[k] for k in f.keys]
        block = np.zeros((f.dim, order.total_dim))
        for k, J in zip(f.keys, f.jacobians(*xs), strict=True):
            o = order.offset_of[k]
            block[:, o : o + J.shape[1]] = f.sqrt_information @ J
        rows.append(block)
        rhs.append(-f.sqrt_information @ f.error(*xs))
    np.testing.assert_allclose(np.sort(A, axis=0), np.sort(np.vstack(rows), axis=0), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(A.T @ b, np.vstack(rows).T @ np.concatenate(rhs), rtol=1e-12, atol=1e-12)


def test_gp_prior_blocks_made_once_are_what_each_linearization_makes(rng, monkeypatch):
    """A GP prior alone, linearized with the blocks it makes once (W (-Φ), W I), against the same prior in a group of
    two, which makes them anew: equal bit for bit, to the dense product within rounding, and read-only."""
    # an empty memo: earlier tests in this process may have filled it
    monkeypatch.setattr(gp_factors, "_WHITENED", gp_factors.Memo())
    qc = np.diag([0.5, 0.4, 0.1])
    f = sr.GPPriorFactor.wnoa(sr.X(0), sr.X(1), 0.7, qc)
    g = sr.GPPriorFactor.wnoa(sr.X(1), sr.X(2), 0.7, qc)  # the same gap: the same W and Φ
    values = {sr.X(i): rng.standard_normal(6) for i in range(3)}
    (alone,) = linearize([f], values)
    (pair,) = linearize([f, g], values)
    assert f.whitened_jacobians() is f.whitened_jacobians() is g.whitened_jacobians()
    for A_alone, A_pair, H in zip(alone.jacobians, pair.jacobians, (-f.phi, np.eye(6)), strict=True):
        assert np.array_equal(A_alone[0], A_pair[0]) and not A_alone.flags.writeable
        np.testing.assert_allclose(A_alone[0], f.sqrt_information @ H, rtol=1e-14, atol=1e-14)
    assert np.array_equal(alone.rhs[0], pair.rhs[0]) and np.array_equal(alone.costs[0], pair.costs[0])


def test_past_its_memo_a_gp_prior_is_linearized_the_usual_way_and_nothing_more_is_kept(rng, monkeypatch):
    """A full memo makes no blocks and keeps none: the prior's blocks are made by the linearization, equal to the
    dense product, and the memo holds what it held."""
    memo = gp_factors.Memo(size=1)
    monkeypatch.setattr(gp_factors, "_WHITENED", memo)
    qc = np.diag([0.5, 0.4, 0.1])
    first, second = (sr.GPPriorFactor.wnoa(sr.X(0), sr.X(1), dt, qc) for dt in (0.7, 0.9))
    assert first.whitened_jacobians() is not None and memo.full
    assert second.whitened_jacobians() is None and len(memo) == 1
    values = {sr.X(i): rng.standard_normal(6) for i in range(2)}
    (alone,) = linearize([second], values)
    for A, H in zip(alone.jacobians, (-second.phi, np.eye(6)), strict=True):
        np.testing.assert_allclose(A[0], second.sqrt_information @ H, rtol=1e-14, atol=1e-14)


def test_a_memo_keeps_the_first_values_it_is_given_up_to_its_size():
    memo = gp_factors.Memo(size=2)
    assert [memo.keep(k, k * 10) for k in (1, 2, 3)] == [10, 20, 30]  # each value is returned, kept or not
    assert memo == {1: 10, 2: 20} and memo.full


def test_a_gp_prior_whose_matrices_may_change_in_place_is_linearized_from_them_as_they_are_now(rng):
    """Φ given by the caller stays writeable: a change in place must reach the next linearization (no memo of the
    blocks made from the old Φ), alone as in a group."""
    f = sr.GPPriorFactor.from_matrices(sr.X(0), sr.X(1), np.eye(6), np.eye(6))
    values = {sr.X(i): rng.standard_normal(6) for i in range(2)}
    (before,) = linearize([f], values)
    f.phi[0, 0] = 5.0
    (alone,) = linearize([f], values)
    (pair,) = linearize([f, f], values)
    assert before.jacobians[0][0, 0, 0] == -1.0 and alone.jacobians[0][0, 0, 0] == pair.jacobians[0][0, 0, 0] == -5.0


def test_an_unknown_key_in_a_factor_given_as_an_iterator_is_named():
    with pytest.raises(sr.UnknownVariableError, match="not among"):
        orderings.min_degree_keys([sr.X(0)], {sr.X(0): 6}, [iter((sr.X(0), sr.X(9)))], [])


def test_xl_information_has_eq15_structure(rng):
    """Eq. 15: 𝓘ₓₓ block-tridiagonal, 𝓘ₗₗ block-diagonal, under XL ordering."""
    p = small_problem(rng, n_states=10, n_landmarks=3)
    order = make_ordering("xl", p.graph.keys(), p.initial.dims(), [f.keys for f in p.graph])
    info = LinearSystem.build(p.graph.factors, p.initial, order).information()[0].toarray()
    n_x = 10 * 6
    for i in range(10):
        for j in range(10):
            block = info[6 * i : 6 * i + 6, 6 * j : 6 * j + 6]
            assert (np.abs(block).max() > 0) == (abs(i - j) <= 1), (i, j)
    ll = info[n_x:, n_x:]
    for i in range(3):
        for j in range(3):
            assert (np.abs(ll[2 * i : 2 * i + 2, 2 * j : 2 * j + 2]).max() > 0) == (i == j)
    assert order.keys[:10] == tuple(sr.X(i) for i in range(10))


def _many_landmark_problem(rng, n_states=60, n_landmarks=30):
    """Each landmark seen from several distant states: XL ordering fills the landmark block."""
    p = small_problem(rng, n_states=n_states, n_landmarks=n_landmarks, robust=False)
    for i in range(n_states):
        lk = sr.L(int(rng.integers(0, n_landmarks)))
        p.graph.add(sr.RangeFactor.create(sr.X(i), lk, 4.0, 0.5))
    return p


@pytest.mark.parametrize("backend", BACKENDS)
def test_amd_is_a_permutation_with_less_fill_than_xl(rng, backend):
    p = _many_landmark_problem(rng)
    nnz = {}
    for name in ["xl", "amd"]:
        order = make_ordering(name, p.graph.keys(), p.initial.dims(), [f.keys for f in p.graph], backend)
        assert sorted(order.keys) == sorted(p.graph.keys())
        info = LinearSystem.build(p.graph.factors, p.initial, order).information()[0]
        nnz[name] = SparseCholesky.factor(info, order, backend).nnz
        dense_L = np.linalg.cholesky(info.toarray())
        assert nnz[name] >= np.count_nonzero(np.abs(dense_L) > 1e-300)  # the factor holds at least L's nonzeros
    assert nnz["amd"] < nnz["xl"]


@pytest.mark.needs_cholmod
def test_superlu_minimum_degree_fill_close_to_cholmod_amd(rng):
    p = _many_landmark_problem(rng, n_states=150, n_landmarks=60)
    nnz = {}
    for backend in ["cholmod", "superlu"]:
        order = make_ordering("amd", p.graph.keys(), p.initial.dims(), [f.keys for f in p.graph], backend)
        info = LinearSystem.build(p.graph.factors, p.initial, order).information()[0]
        nnz[backend] = SparseCholesky.factor(info, order, "cholmod").nnz
    assert nnz["superlu"] <= 1.15 * nnz["cholmod"]


@pytest.mark.parametrize("backend", BACKENDS)
def test_unconstrained_variable_is_named(rng, backend):
    qc = np.diag([0.1, 0.1, 0.1])
    graph = sr.FactorGraph(sr.gp_prior_factors([sr.X(0), sr.X(1)], [0.0, 1.0], qc))
    graph.add(sr.PriorFactor.create(sr.X(0), np.zeros(6), np.ones(6)))
    graph.add(sr.RangeFactor.create(sr.X(1), sr.L(5), 3.0, 0.5))  # one range cannot fix a 2-D landmark
    values = sr.Values({sr.X(0): rng.normal(size=6), sr.X(1): rng.normal(size=6), sr.L(5): np.array([3.0, 1.0])})
    with pytest.raises(sr.UnderdeterminedError):
        sr.gauss_newton(graph, values, backend=backend)
    graph2 = sr.FactorGraph([sr.VelocityFactor.create(sr.X(3), [1, 0, 0], 1.0)])  # positions free
    with pytest.raises(sr.UnderdeterminedError, match="x3"):
        sr.gauss_newton(graph2, sr.Values({sr.X(3): rng.normal(size=6)}), backend=backend)


def test_bad_values_raise(rng):
    graph = sr.FactorGraph([sr.RangeFactor.create(sr.X(0), sr.L(1), 3.0, 0.5)])
    with pytest.raises(sr.UnknownVariableError, match="l1"):
        sr.gauss_newton(graph, sr.Values({sr.X(0): rng.normal(size=6)}))
    with pytest.raises(sr.ShapeError, match="l1"):
        sr.gauss_newton(graph, sr.Values({sr.X(0): rng.normal(size=6), sr.L(1): np.zeros(3)}))
    with pytest.raises(sr.ShapeError, match="not finite"):
        sr.Values({sr.X(0): np.array([np.nan] * 6)})
    with pytest.raises(sr.SteamError, match="unknown ordering"):
        sr.gauss_newton(graph, sr.Values({sr.X(0): rng.normal(size=6), sr.L(1): np.zeros(2)}), ordering="colamd")


@pytest.mark.parametrize("name", ["natural", "xl", "amd"])
def test_make_ordering_by_name_is_a_permutation_with_the_right_sizes(problem, name):
    keys = problem.graph.keys()
    dims = {k: problem.initial.dim(k) for k in keys}
    order = orderings.make_ordering(name, keys, dims, [f.keys for f in problem.graph])
    assert sorted(order.keys) == sorted(keys) and len(order.keys) == len(keys)
    assert order.dims == tuple(dims[k] for k in order.keys)
    if name == "natural":
        assert list(order.keys) == keys
    if name == "xl":
        kinds = [k.symbol for k in order.keys]
        assert kinds == sorted(kinds, key=lambda kind: kind != "x")  # every state before every landmark
    # the batch solvers order through the same function: their result records it
    used = sr.gauss_newton(problem.graph, problem.initial, ordering=name, max_iterations=0, check=False).ordering
    assert used is not None and (used.keys, used.dims) == (order.keys, order.dims)
    assert steam_ref.batch.make_ordering is orderings.make_ordering  # one make_ordering: linear/ordering.py
    assert "make_ordering" not in steam_ref.batch.__all__


def test_every_ordering_function_returns_an_ordering(problem):
    keys = problem.graph.keys()
    dims = problem.initial.dims()
    factor_keys = [f.keys for f in problem.graph]
    made = [
        orderings.natural_ordering(keys, dims),
        orderings.xl_ordering(keys, dims),
        orderings.amd_ordering(keys, dims, factor_keys),
        orderings.constrained_min_degree(keys, dims, factor_keys, last=keys[-2:]),
    ]
    for order in made:
        assert isinstance(order, orderings.Ordering)
        assert sorted(order.keys) == sorted(keys) and order.dims == tuple(dims[k] for k in order.keys)
        assert list(order) == list(order.keys) and order[0] == order.keys[0]  # it reads as its keys
    assert set(made[-1].keys[-2:]) == set(keys[-2:])


def test_make_ordering_passes_an_ordering_through_and_names_unknown_ones(problem):
    keys = problem.graph.keys()
    dims = {k: problem.initial.dim(k) for k in keys}
    given = orderings.natural_ordering(keys[::-1], dims)
    assert orderings.make_ordering(given, keys, dims, []) is given
    with pytest.raises(sr.SteamError, match="'colamd'"):
        orderings.make_ordering("colamd", keys, dims, [])
