"""The forgotten past, smoothed afterwards: the kept conditionals against the dense posterior.

On linear Gaussian streams, a fixed-lag smoother that keeps its history gives, after any number of
updates and marginalizations, every variable ever held (the window's and the forgotten ones, by one
backward pass, derivations Eq. 10.5) the dense batch optimum of every factor ever given, to 1e-10.
The dense side is tests/test_fixed_lag.py's, built from the factors' error functions alone.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from steam_ref.bayes_tree import FixedLagSmoother
from steam_ref.errors import SteamError
from steam_ref.variables import L, X

sys.path.insert(0, __file__.rsplit("/", 1)[0])
from test_fixed_lag import EXACT, LinearStream, dense_posterior, renamed  # noqa: E402


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 10_000),
    n=st.integers(4, 24),
    lag=st.floats(0.6, 6.0),
    landmarks=st.integers(0, 3),
    threshold=st.sampled_from([0.0, 0.1, np.inf]),
)
def test_smoothed_history_is_the_batch_optimum(seed, n, lag, landmarks, threshold):
    stream = LinearStream(seed, landmarks)
    smoother = stream.smoother = FixedLagSmoother(lag, relinearize_threshold=threshold, keep_history=True, **EXACT)
    factors, values, stamps = stream.initial()
    everything = list(factors)
    smoother.update(factors, values, timestamps=stamps)
    for _ in range(n):
        factors, values, stamps = stream.step()
        everything += renamed(stream, factors)
        smoother.update(factors, values, timestamps=stamps)
    all_keys = list(dict.fromkeys(k for f in everything for k in f.keys))
    mean, _ = dense_posterior(everything, all_keys)
    past = smoother.smoothed_history()
    assert len(smoother.history) == smoother.n_marginalized
    states = [X(i) for i in range(n + 1)]
    assert set(past) | {k for k in states if k in smoother._dims} >= set(states)  # every state, once
    for k, v in past.items():  # a landmark forgotten and seen again: its first incarnation (generation 0)
        np.testing.assert_allclose(v, mean[k], rtol=0, atol=1e-10, err_msg=f"forgotten {k}")
    for k in smoother._dims:
        name = L(1000 * stream.generation[k.index] + k.index) if k.kind == "l" else k
        np.testing.assert_allclose(smoother.estimate_of(k), mean[name], rtol=0, atol=1e-10, err_msg=f"window {k}")


def test_the_lagged_estimate_is_not_the_smoothed_one():
    """The check can fail: the estimates frozen at marginalization differ from the batch optimum."""
    stream = LinearStream(7, 2)
    smoother = stream.smoother = FixedLagSmoother(1.0, keep_history=True, **EXACT)
    factors, values, stamps = stream.initial()
    everything = list(factors)
    smoother.update(factors, values, timestamps=stamps)
    frozen = {}
    for _ in range(15):
        factors, values, stamps = stream.step()
        everything += renamed(stream, factors)
        smoother.update(factors, values, timestamps=stamps)
        done = smoother.last_marginalization
        frozen |= {} if done is None else {k: v for k, v in done.estimates.items() if k.kind == "x"}
    mean, _ = dense_posterior(everything, list(dict.fromkeys(k for f in everything for k in f.keys)))
    past = smoother.smoothed_history()
    gap = max(np.abs(frozen[k] - mean[k]).max() for k in frozen)
    assert gap > 1e-3  # later readings moved the past: a lagged estimate is not the optimum
    assert max(np.abs(past[k] - mean[k]).max() for k in frozen) < 1e-10


def test_without_history_the_past_is_refused():
    smoother = FixedLagSmoother(1.0)
    with pytest.raises(SteamError, match="keep_history=True"):
        smoother.smoothed_history()
    assert smoother.history is None
