"""The forgotten past, smoothed afterwards: the kept conditionals against the dense posterior.

On linear Gaussian streams, a fixed-lag smoother that keeps its history gives, after any number of
updates and marginalizations, every variable ever held (the window's and the forgotten ones, by one
backward pass, derivations Eq. 10.5) the dense batch optimum of every factor ever given, to 1e-10.
The dense side is tests/test_fixed_lag.py's, built from the factors' error functions alone.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest
from test_fixed_lag import EXACT, LinearStream, Offset, dense_posterior, fed, over_lagged_streams

from steam_ref.bayes_tree import FixedLagSmoother, IncrementalSolver, marginalize
from steam_ref.errors import SteamError
from steam_ref.factors import Factor, PriorFactor
from steam_ref.variables import L, X


def optimum(everything: list[Factor]) -> dict:
    """The dense batch optimum of every factor given."""
    return dense_posterior(everything, list(dict.fromkeys(k for f in everything for k in f.keys)))[0]


@over_lagged_streams(most_steps=24)
def test_smoothed_history_is_the_batch_optimum(seed, n, lag, landmarks, threshold):
    stream = LinearStream(seed, landmarks)
    smoother = stream.smoother = FixedLagSmoother(lag, relinearize_threshold=threshold, keep_history=True, **EXACT)
    mean = optimum(fed(stream, smoother, n))
    past = smoother.smoothed_history()
    assert len(smoother.history) == smoother.n_marginalized
    states = [X(i) for i in range(n + 1)]
    assert set(past) | {k for k in states if k in smoother.solver.state.dims} >= set(states)  # every state, once
    for k, v in past.items():  # a landmark forgotten and seen again: the latest incarnation forgotten
        held = k in smoother.linearization_point
        name = L(1000 * (stream.generation[k.index] - held) + k.index) if k.symbol == "l" else k
        np.testing.assert_allclose(v, mean[name], rtol=0, atol=1e-10, err_msg=f"forgotten {k}")
    for k in smoother.solver.state.dims:
        name = L(1000 * stream.generation[k.index] + k.index) if k.symbol == "l" else k
        np.testing.assert_allclose(smoother.estimate_of(k), mean[name], rtol=0, atol=1e-10, err_msg=f"window {k}")


def test_the_lagged_estimate_is_not_the_smoothed_one():
    """The check can fail: the estimates frozen at marginalization differ from the batch optimum."""
    stream = LinearStream(7, 2)
    smoother = stream.smoother = FixedLagSmoother(1.0, keep_history=True, **EXACT)
    frozen: dict = {}

    def keep_frozen(_everything):
        done = smoother.last_marginalization
        frozen.update({} if done is None else {k: v for k, v in done.estimates.items() if k.symbol == "x"})

    mean = optimum(fed(stream, smoother, 15, keep_frozen))
    past = smoother.smoothed_history()
    gap = max(np.abs(frozen[k] - mean[k]).max() for k in frozen)
    assert gap > 1e-3  # later readings moved the past: a lagged estimate is not the optimum
    assert max(np.abs(past[k] - mean[k]).max() for k in frozen) < 1e-10


def test_without_history_the_past_is_refused():
    smoother = FixedLagSmoother(1.0)
    with pytest.raises(SteamError, match="keep_history=True"):
        smoother.smoothed_history()
    assert smoother.history is None


@dataclass(frozen=True, eq=False)
class Distance(Factor):
    """A nonlinear reading: e = ‖l - x[:3]‖ - z (test-local)."""

    z: np.ndarray
    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "z")
    key_dims: ClassVar[tuple[int, ...]] = (6, 3)

    def error(self, x, l):
        return np.linalg.norm(l - x[..., :3], axis=-1, keepdims=True) - self.z

    def jacobians(self, x, l):
        u = (l - x[..., :3]) / np.linalg.norm(l - x[..., :3], axis=-1, keepdims=True)
        Jx = np.zeros(x.shape[:-1] + (1, 6))
        Jx[..., 0, :3] = -u
        return Jx, u[..., None, :]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_nonlinear_past_frozen_where_the_full_smoother_never_moved_equals_it(seed):
    """Nonlinear distances, no relinearization anywhere: each factor stays linearized at its first value, as the
    frozen conditionals and marginal factors are, so the smoothed past and the window are the full iSAM2's
    estimate (landmarks, with a weak prior where they enter, are never forgotten here: none enters twice)."""
    stream = LinearStream(seed, 3, fix_every=4)
    never = dict(EXACT, relinearize_threshold=np.inf)
    lagged, full = FixedLagSmoother(2.5, keep_history=True, **never), IncrementalSolver(**never)
    factors, values, stamps = stream.initial()
    for solver in (lagged, full):
        solver.update(factors, values, **({"timestamps": stamps} if solver is lagged else {}))
    for _ in range(30):
        factors, values, stamps = stream.step()
        factors = [
            Distance(f.keys, np.eye(1) / 0.1, z=np.linalg.norm(f.z) + stream.rng.normal(size=1) * 0.1)
            if isinstance(f, Offset)
            else f
            for f in factors
        ]
        factors += [
            PriorFactor.create(k, v, 1.0) for k, v in values.items() if k.symbol == "l"
        ]  # one distance fixes 1 of 3
        lagged.update(factors, values, timestamps={k: t for k, t in stamps.items() if k.symbol == "x"})
        full.update(factors, values)
    past = lagged.smoothed_history()
    assert len(past) >= 20
    for k in full.estimate():
        got = past[k] if k in past else lagged.estimate_of(k)
        np.testing.assert_allclose(got, full.estimate_of(k), rtol=0, atol=1e-9, err_msg=str(k))


def test_marginalize_refuses_a_fixed_lag_smoother_and_leaves_it_as_it_was():
    stream = LinearStream(4, 1)
    smoother = stream.smoother = FixedLagSmoother(2.0, keep_history=True, **EXACT)
    fed(stream, smoother, 6)
    held, before, kept = sorted(smoother.timestamps, key=str), smoother.estimate(), len(smoother.history)
    with pytest.raises(SteamError, match="must be an IncrementalSolver, got FixedLagSmoother"):
        marginalize(smoother, [held[0]])  # it forgets by its timestamps, and records what it forgot
    assert sorted(smoother.timestamps, key=str) == held and len(smoother.history) == kept
    for k in before:
        np.testing.assert_array_equal(smoother.estimate_of(k), before[k])
    factors, values, stamps = stream.step()
    smoother.update(factors, values, timestamps=stamps)  # and it goes on
    assert smoother.tree.problems() == []


def test_marginalize_names_what_it_was_given_when_it_is_no_solver():
    for wrong in (None, {"x0": 1}, "solver"):
        with pytest.raises(SteamError, match=f"solver must be an IncrementalSolver, got {type(wrong).__name__}"):
            marginalize(wrong, [X(0)])
