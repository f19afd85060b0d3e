"""Marginalizing in batches, and whole subtrees cut with the marginal the tree cached, against the dense posterior.

``FixedLagSmoother(lag, batch=b)`` lets its window grow to ``lag + b`` seconds and then marginalizes what is older
than ``lag`` at once (the whole subtrees among it, or all of it when one older than ``lag + b`` would stay);
``marginalize_keys(..., reuse_marginals=True)``, what it runs, cuts whole subtrees with their tops' f(S) instead of
eliminating their factors again. Either way, on linear Gaussian streams the window is the marginal of the whole
problem over it, and the kept conditionals smooth the past to the batch optimum: the dense side is
tests/test_fixed_lag.py's, built from the factors' error functions alone.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_fixed_lag import EXACT, LinearStream, check_window, dense_posterior, fed, held_after_each_step

from steam_ref.bayes_tree import FixedLagSmoother, IncrementalSolver
from steam_ref.bayes_tree.marginalization import marginalize_keys
from steam_ref.errors import SteamError
from steam_ref.variables import L, X


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 10_000),
    n=st.integers(6, 20),
    lag=st.floats(0.6, 4.0),
    batch=st.floats(0.3, 4.0),
    landmarks=st.integers(0, 3),
    threshold=st.sampled_from([0.0, 0.1, np.inf]),
)
def test_a_batched_window_is_the_dense_marginal_and_keeps_its_contract(seed, n, lag, batch, landmarks, threshold):
    stream = LinearStream(seed, landmarks)
    smoother = FixedLagSmoother(lag, relinearize_threshold=threshold, keep_history=True, batch=batch, **EXACT)
    stream.smoother = smoother
    before: dict = {}

    def check(everything):
        check_window(smoother, everything, stream)
        newest, held = smoother.newest, smoother.timestamps
        assert all(t >= newest - lag - batch for t in held.values()), "older than lag + batch"
        done = smoother.last_marginalization
        if done is not None:  # it waited until something was older than lag + batch, and took only what was past lag
            when = stream.times | before  # each variable's stamp before this update
            assert all(when[k] < newest - lag for k in done.keys if k in when), "a variable within the lag went"
            assert min(when[k] for k in done.keys if k in when) < newest - lag - batch, "nothing was due"
        before.clear()
        before.update(held)

    everything = fed(stream, smoother, n, check)
    mean = dense_posterior(everything, list(dict.fromkeys(k for f in everything for k in f.keys)))[0]
    for k, v in smoother.smoothed_history().items():
        held = k in smoother.linearization_point
        name = L(1000 * (stream.generation[k.index] - held) + k.index) if k.symbol == "l" else k
        np.testing.assert_allclose(v, mean[name], rtol=0, atol=1e-10, err_msg=f"forgotten {k}")


def test_batches_marginalize_less_often_and_the_same_variables():
    def run(batch: float) -> tuple[int, int, FixedLagSmoother]:
        stream = LinearStream(3, 2)
        smoother = stream.smoother = FixedLagSmoother(2.0, batch=batch, **EXACT)
        calls = []
        fed(stream, smoother, 40, lambda _: calls.append(smoother.last_marginalization is not None))
        return sum(calls), smoother.n_marginalized, smoother

    every, n_every, _ = run(0.0)
    batched, n_batched, smoother = run(3.0)
    assert batched <= every / 2 and batched > 0
    assert n_every - 6 <= n_batched <= n_every  # the batched window holds up to 3 s (~3 states) more
    assert smoother.tree.problems() == []


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 10_000), n=st.integers(5, 14), data=st.data())
def test_whole_subtrees_cut_with_their_cached_marginal_leave_the_dense_marginal(seed, n, data):
    """Any subset: whole subtrees take the cached f(S), others the usual paths (leaves or re-elimination)."""
    solver = IncrementalSolver(**EXACT)
    for everything, held in held_after_each_step(LinearStream(seed, 3, fix_every=2), solver, n):
        if len(held) > 2 and data.draw(st.booleans()):
            oldest = data.draw(st.booleans())  # the oldest states: whole subtrees, mostly
            drop = (
                [k for k in held if k.symbol == "x"][: data.draw(st.integers(1, 3))]
                if oldest
                else data.draw(st.lists(st.sampled_from(held), min_size=1, max_size=len(held) - 1, unique=True))
            )
            if len(drop) >= len(held):
                continue
            report = marginalize_keys(solver.state, drop, 0.0, keep_conditionals=True, reuse_marginals=True)
            assert set(report.keys) == set(drop) and len(report.conditionals) == len(drop)
            check_window(solver, everything)


def test_a_whole_subtree_is_cut_with_no_elimination_and_each_frontal_keeps_its_conditional():
    stream = LinearStream(5, 1)
    solver = IncrementalSolver(**EXACT)
    factors, values, _ = stream.initial()
    solver.update(factors, values)
    for _ in range(8):
        factors, values, _ = stream.step()
        solver.update(factors, values, constrained={X(i): i for i in range(9)})  # time order: old states are leaves
    drop = [X(0), X(1), X(2)]
    cliques = {solver.tree.frontal_of[k] for k in drop}
    report = marginalize_keys(solver.state, drop, 0.0, keep_conditionals=True, reuse_marginals=True)
    assert report.leaves and report.new_cliques == () and set(report.removed_cliques) == cliques
    assert [c.key for c in report.conditionals] == list(report.keys)  # one each, eliminated first first
    for i, c in enumerate(report.conditionals):  # P(v | S_v): S_v the variables eliminated after v, or the window's
        assert set(c.separator) <= set(report.keys[i + 1 :]) | set(solver.state.dims), c.key


def test_a_bad_batch_is_refused():
    for bad in (-1.0, np.inf, np.nan, "1"):
        with pytest.raises(SteamError, match="batch"):
            FixedLagSmoother(1.0, batch=bad)
