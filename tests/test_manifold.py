"""The manifold seam (steam_ref/manifold.py): a variable whose retraction is not addition is honoured by batch
Gauss-Newton, the Bayes tree (incremental updates with relinearization), marginalization and the fixed-lag
smoother's kept history, each against a dense Gauss-Newton written here for that kind.

The kind is defined in this file only: a positive scale, x ⊕ δ = x·exp(δ), x ⊖ x₀ = log(x/x₀) (elementwise),
and its factors declare it (``key_kinds``), so the estimates may be plain dicts: a solver takes each variable's
kind from its factors. The factors read log-ratios, so the problem is linear in the tangent coordinates u = log x:
every solver that moves the estimate through the kind reaches the optimum exactly (to rounding), and one that adds
δ to x does not. The oracle's Jacobians are central differences through the retraction, not the factors' own.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest

from steam_ref.batch import gauss_newton
from steam_ref.bayes_tree import FixedLagSmoother, IncrementalSolver, marginalize
from steam_ref.errors import KindError
from steam_ref.factors import Factor
from steam_ref.manifold import VECTOR, Manifold, VectorSpace, by_kind
from steam_ref.variables import Values, X

D = 2  # size of each variable


class Scale(Manifold):
    """A positive scale per entry: x ⊕ δ = x·exp(δ)."""

    name = "scale"

    def retract(self, x, delta):
        return x * np.exp(delta)

    def local(self, x0, x):
        return np.log(x / x0)


SCALE = Scale()


@dataclass(frozen=True, eq=False)
class LogPrior(Factor):
    """e = log x - z: a reading of the scale itself. Jacobian with respect to the tangent δ at x: I."""

    z: np.ndarray
    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "z")
    key_dims: ClassVar[tuple[int, ...]] = (D,)
    key_kinds: ClassVar[tuple[Manifold, ...]] = (SCALE,)  # type: ignore[misc]

    def error(self, x):
        return np.log(x) - self.z

    def jacobians(self, x):
        return (np.broadcast_to(np.eye(D), x.shape[:-1] + (D, D)).copy(),)


@dataclass(frozen=True, eq=False)
class LogRatio(Factor):
    """e = log(b / a) - z: a relative scale between two variables. Jacobians in the tangent: -I, I."""

    z: np.ndarray
    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "z")
    key_dims: ClassVar[tuple[int, ...]] = (D, D)
    key_kinds: ClassVar[tuple[Manifold, ...]] = (SCALE, SCALE)  # type: ignore[misc]

    def error(self, a, b):
        return np.log(b / a) - self.z

    def jacobians(self, a, b):
        eye = np.broadcast_to(np.eye(D), a.shape[:-1] + (D, D))
        return -eye.copy(), eye.copy()


def problem(seed: int, n: int):
    """A chain of n scales with a prior, odometry-like ratios, loop closures and absolute readings; per-state batches."""
    rng = np.random.default_rng(seed)
    truth = np.exp(np.cumsum(rng.normal(0, 0.3, size=(n, D)), axis=0))
    steps = [[LogPrior((X(0),), np.eye(D) / 0.1, z=np.log(truth[0]) + rng.normal(0, 0.1, D))]]
    guesses = [truth[0] * np.exp(rng.normal(0, 0.3, D))]
    for i in range(1, n):
        fs = [LogRatio((X(i - 1), X(i)), np.eye(D) / 0.05, z=np.log(truth[i] / truth[i - 1]) + rng.normal(0, 0.05, D))]
        if i >= 3 and i % 3 == 0:
            j = i - 3
            fs.append(LogRatio((X(j), X(i)), np.eye(D) / 0.1, z=np.log(truth[i] / truth[j]) + rng.normal(0, 0.1, D)))
        if i % 4 == 0:  # an absolute reading now and then: later data moves the past (smoothing has work to do)
            fs.append(LogPrior((X(i),), np.eye(D) / 0.05, z=np.log(truth[i]) + rng.normal(0, 0.05, D)))
        steps.append(fs)
        guesses.append(truth[i] * np.exp(rng.normal(0, 0.5, D)))  # far from the truth: relinearization must work
    return steps, guesses


def dense_gauss_newton(factors, initial: dict) -> dict:
    """Gauss-Newton for the scale kind: x ← x ⊕ δ, Jacobians by central differences through ⊕."""
    keys = list(initial)
    x = {k: np.array(v, float) for k, v in initial.items()}

    def residual(values):
        return np.concatenate([f.whitened_error(*[values[k] for k in f.keys]) for f in factors])

    for _ in range(50):
        r, h = residual(x), 1e-6
        J = np.zeros((len(r), D * len(keys)))
        for i, k in enumerate(keys):
            for a in range(D):
                step = np.zeros(D)
                step[a] = h
                up, down = dict(x), dict(x)
                up[k], down[k] = SCALE.retract(x[k], step), SCALE.retract(x[k], -step)
                J[:, D * i + a] = (residual(up) - residual(down)) / (2 * h)
        delta = np.linalg.lstsq(J, -r, rcond=None)[0]
        x = {k: SCALE.retract(x[k], delta[D * i : D * i + D]) for i, k in enumerate(keys)}
        if np.abs(delta).max() < 1e-13:
            break
    return x


def assert_close(got, want, keys, tol=1e-8):
    for k in keys:
        np.testing.assert_allclose(got[k], want[k], rtol=tol, atol=0, err_msg=str(k))


def test_the_seam_is_bit_for_bit_addition_for_a_vector():
    rng = np.random.default_rng(0)
    x, d = rng.normal(size=6), rng.normal(size=6)
    assert VECTOR.retract(x, d).tobytes() == (x + d).tobytes() and VECTOR.local(x, d).tobytes() == (d - x).tobytes()
    v = Values({X(0): x})
    assert v.retract({X(0): d})[X(0)].tobytes() == (x + d).tobytes() and v.kind(X(0)) is VECTOR


def test_the_batched_moves_are_the_one_variable_moves():
    """retract_many / local_many / rebase_many of many variables (sizes 6 and 2 mixed for a vector) equal the
    one-variable maps: bit for bit for a vector (x + δ, x - x₀, the marked blocks moved alone), to rounding for a
    kind that moves by its broadcast map."""
    rng = np.random.default_rng(1)
    xs = [rng.normal(size=6 if i % 3 else 2) for i in range(7)]
    ds = [rng.normal(size=len(x)) for x in xs]
    moves = [rng.random(len(x)) < 0.5 for x in xs]
    assert [a.tobytes() for a in VECTOR.retract_many(xs, ds)] == [
        (x + d).tobytes() for x, d in zip(xs, ds, strict=True)
    ]
    assert [a.tobytes() for a in VECTOR.local_many(xs, ds)] == [(d - x).tobytes() for x, d in zip(xs, ds, strict=True)]
    theta, delta = VECTOR.rebase_many(xs, ds, moves)
    for x, d, m, t, e in zip(xs, ds, moves, theta, delta, strict=True):
        np.testing.assert_array_equal(t, np.where(m, x + d, x))
        np.testing.assert_array_equal(e, np.where(m, 0.0, d))
    assert VECTOR.retract_sum(xs[0], ds[0], xs[0]).tobytes() == ((xs[0] + ds[0]) + xs[0]).tobytes()
    pos = [np.exp(rng.normal(size=D)) for _ in range(5)]
    steps = [rng.normal(size=D) for _ in range(5)]
    for got, x, d in zip(SCALE.retract_many(pos, steps), pos, steps, strict=True):
        np.testing.assert_allclose(got, x * np.exp(d), rtol=1e-15)
    theta, delta = SCALE.rebase_many(pos, steps, [np.array([True, False])] * 5)  # a kind that moves whole
    for t, e, x, d in zip(theta, delta, pos, steps, strict=True):
        np.testing.assert_allclose(t, x * np.exp(d), rtol=1e-15)
        assert not e.any()
    assert SCALE.retract_many([], []) == [] and isinstance(VECTOR, VectorSpace)
    groups = by_kind([X(0), X(1), X(2), X(3)], {X(1): SCALE, X(3): SCALE, X(2): VECTOR})
    assert groups == [(VECTOR, [X(0), X(2)]), (SCALE, [X(1), X(3)])]


def test_a_kind_that_only_says_its_name_moves_nothing():
    """The base Manifold is no vector space: a kind that forgets its maps fails loudly, not with + silently."""
    with pytest.raises(NotImplementedError):
        Manifold().retract(np.zeros(2), np.ones(2))


def test_values_carry_kinds_through_copy_insert_and_remove():
    v = Values({X(0): [1.0, 2.0], X(1): [3.0, 4.0]}, kinds={X(0): SCALE})
    assert v.kind(X(0)) is SCALE and v.kind(X(1)) is VECTOR and v.copy().kind(X(0)) is SCALE
    assert v.kinds() == {X(0): SCALE}  # the kinds given; X(1) was given none
    v.insert(X(0), [2.0, 2.0])  # the kind stays
    assert v.kind(X(0)) is SCALE
    np.testing.assert_allclose(v.local({X(0): np.array([2.0, 2.0 * np.e])})[X(0)], [0.0, 1.0])
    v.remove(X(0))
    v.insert(X(0), [1.0, 1.0])
    assert v.kind(X(0)) is VECTOR


def test_batch_gauss_newton_follows_the_kind():
    steps, guesses = problem(1, 12)
    factors = [f for fs in steps for f in fs]
    initial = {X(i): g for i, g in enumerate(guesses)}
    want = dense_gauss_newton(factors, initial)
    told = gauss_newton(factors, Values(initial, kinds=dict.fromkeys(initial, SCALE))).values
    assert_close(told, want, initial)
    plain = gauss_newton(factors, initial)  # a plain dict: the factors say what each variable is
    assert plain.converged and all(plain.values[k].tobytes() == told[k].tobytes() for k in initial)
    assert plain.values.kind(X(3)) is SCALE
    added = dict.fromkeys(initial, VECTOR)  # x + δ: not the optimum, and refused for saying so
    with pytest.raises(KindError, match=r"the kind of x0 is given twice and differs: vector by its value.*scale by"):
        gauss_newton(factors, Values(initial, kinds=added))


@pytest.mark.parametrize("seed", [2, 3])
def test_the_bayes_tree_relinearizes_along_the_kind(seed):
    steps, guesses = problem(seed, 15)
    solver = IncrementalSolver(relinearize_threshold=0.01, relinearize_skip=1, wildfire_threshold=0.0)
    for i, fs in enumerate(steps):  # the kind told, or not: the factors say it
        solver.update(fs, Values({X(i): guesses[i]}, kinds={X(i): SCALE}) if i % 2 else {X(i): guesses[i]})
    for _ in range(30):  # updates with nothing new: fluid relinearization to the optimum
        solver.update()
    want = dense_gauss_newton([f for fs in steps for f in fs], {X(i): g for i, g in enumerate(guesses)})
    estimate = solver.estimate()
    assert_close(estimate, want, want)
    assert estimate.kind(X(0)) is SCALE and solver.linearization_point.kind(X(3)) is SCALE


def test_marginalization_and_the_kept_history_follow_the_kind():
    steps, guesses = problem(4, 24)
    lag = 4.0
    smoother = FixedLagSmoother(lag, keep_history=True, relinearize_threshold=0.0, relinearize_skip=1,
                                wildfire_threshold=0.0)  # fmt: skip
    for i, fs in enumerate(steps):
        smoother.update(fs, {X(i): guesses[i]}, timestamps={X(i): float(i)})
        for _ in range(2):
            smoother.update()  # relinearize the window (and the marginal factors' right-hand sides) as it slides
    assert smoother.n_marginalized > 10
    want = dense_gauss_newton([f for fs in steps for f in fs], {X(i): g for i, g in enumerate(guesses)})
    window = smoother.estimate()
    assert_close(window, want, window)  # linear in the tangent: the marginal factors are exact
    past = smoother.smoothed_history()
    assert_close(past, want, past)
    assert set(past) | set(window) == set(want)


def test_marginalize_follows_the_kind():
    steps, guesses = problem(5, 14)
    solver = IncrementalSolver(relinearize_threshold=0.0, relinearize_skip=1, wildfire_threshold=0.0)
    for i, fs in enumerate(steps):
        solver.update(fs, {X(i): guesses[i]})
    marginalize(solver, [X(0), X(1), X(5)])
    marginal = [f for f in solver.factors if f is not None and type(f).__name__ == "MarginalFactor"]
    assert marginal and all(k is SCALE for f in marginal for k in f.key_kinds)  # made with the kinds held
    for _ in range(5):
        solver.update()
    want = dense_gauss_newton([f for fs in steps for f in fs], {X(i): g for i, g in enumerate(guesses)})
    estimate = solver.estimate()
    assert X(5) not in estimate
    assert_close(estimate, want, estimate)
