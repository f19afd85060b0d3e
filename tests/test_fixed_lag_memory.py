"""A fixed-lag smoother's memory stays flat over a long run: after 20,000 cheap updates every store of its state
object, its tree and its window hold what they held after the first thousand (objects counted, not RSS), and the
memory it holds after 5,000 updates is what it held after 500, but for 8 bytes a forgotten index.

What does grow, by design, is counted too: the ids (a factor's id counts every factor ever given; the stores hold the
live ones only), and the update that forgot each variable (to name it in an error): 8 bytes an index, in an array.
"""

from __future__ import annotations

import tracemalloc
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest

from steam_ref.bayes_tree import FixedLagSmoother
from steam_ref.bayes_tree.state import SolverState
from steam_ref.factors import Factor
from steam_ref.variables import X


@dataclass(frozen=True, eq=False)
class Step(Factor):
    """e = b - a - z, scalars (test-local: the cheapest factor a stream can have)."""

    z: np.ndarray
    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "z")
    key_dims: ClassVar[tuple[int, ...]] = (1, 1)

    def error(self, a, b):
        return b - a - self.z

    def jacobians(self, a, b):
        one = np.ones(a.shape[:-1] + (1, 1))
        return -one, one


@dataclass(frozen=True, eq=False)
class Fix(Factor):
    """e = a - z."""

    z: np.ndarray
    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "z")
    key_dims: ClassVar[tuple[int, ...]] = (1,)

    def error(self, a):
        return a - self.z

    def jacobians(self, a):
        return (np.ones(a.shape[:-1] + (1, 1)),)


def held(smoother: FixedLagSmoother) -> dict[str, int]:
    """The size of everything the smoother holds that should not grow with the run."""
    state = smoother.solver.state
    sizes = {name: len(getattr(state, name)) for name in SolverState.VARIABLE_STORES}
    sizes["live factors"] = sum(f is not None for f in state.factors)
    sizes["cached linearizations"] = sum(g is not None for g in state.linear)
    tree = state.tree
    sizes |= {"cliques": len(tree.cliques), "parents": len(tree.parent), "children": len(tree.children)}
    sizes |= {"frontals": len(tree.frontal_of), "roots": len(tree.roots), "timestamps": len(smoother.timestamps)}
    sizes["undo entries"] = len(state.log.entries)
    return sizes


@pytest.mark.slow
def test_twenty_thousand_updates_hold_what_a_thousand_held():
    rng = np.random.default_rng(0)
    smoother = FixedLagSmoother(4.0)
    smoother.update([Fix((X(0),), np.eye(1), z=np.zeros(1))], {X(0): np.zeros(1)}, timestamps={X(0): 0.0})
    most: dict[int, dict[str, int]] = {1: {}, 19: {}}  # the most of each, over updates 1,000-1,999 and 19,000-19,999
    for i in range(1, 20_001):
        factors = [Step((X(i - 1), X(i)), np.eye(1), z=rng.normal(size=1))]
        if i % 7 == 0:
            factors.append(Fix((X(i),), np.eye(1), z=rng.normal(size=1)))
        smoother.update(factors, {X(i): np.zeros(1)}, timestamps={X(i): float(i)})
        if i // 1000 in most:
            for name, n in held(smoother).items():
                most[i // 1000][name] = max(most[i // 1000].get(name, 0), n)
    # (an update that grows the record of forgotten indices, doubling its array, logs one entry more)
    assert most[19]["undo entries"] <= most[1]["undo entries"] <= most[19]["undo entries"] + 1
    assert {k: n for k, n in most[19].items() if k != "undo entries"} == {
        k: n for k, n in most[1].items() if k != "undo entries"
    }
    assert smoother.n_marginalized == 20_001 - len(smoother)
    assert most[19]["dims"] <= 8 and most[19]["cliques"] <= 8, most[19]
    # What grows by design, and only by that: a slot per factor ever held (given, or made by a marginalization).
    assert len(smoother.factors) <= 3 * 20_001


def test_the_memory_a_smoother_holds_does_not_grow_by_an_object_a_step():
    """500 and then 5,000 updates: each store holds as many entries, and the bytes held (tracemalloc) grow by at most
    32 a step: the record of the forgotten indices, 8 bytes each in an array doubled as it grows (up to 16), and
    slack. Before the factor stores held the live factors only and that record was an array, the stores grew by an
    entry a factor and the record by a dict entry and a key a variable (~250 bytes a step)."""
    rng = np.random.default_rng(1)
    smoother = FixedLagSmoother(4.0)
    smoother.update([Fix((X(0),), np.eye(1), z=np.zeros(1))], {X(0): np.zeros(1)}, timestamps={X(0): 0.0})
    seen: dict[int, tuple[dict[str, int], int]] = {}
    tracemalloc.start()
    try:
        for i in range(1, 5_001):
            factors = [Step((X(i - 1), X(i)), np.eye(1), z=rng.normal(size=1))]
            if i % 7 == 0:
                factors.append(Fix((X(i),), np.eye(1), z=rng.normal(size=1)))
            smoother.update(factors, {X(i): np.zeros(1)}, timestamps={X(i): float(i)})
            if i in (497, 4_998):  # the same phase of the every-7th prior
                sizes = held(smoother) | {"factor stores": len(smoother.solver.state.factors)}
                seen[i] = (sizes, tracemalloc.get_traced_memory()[0])
    finally:
        tracemalloc.stop()
    (early, early_bytes), (late, late_bytes) = seen[497], seen[4_998]
    assert late == early, {k: (early[k], late[k]) for k in early if early[k] != late[k]}  # (grown: early, late)
    assert (late_bytes - early_bytes) / 4_501 <= 32, f"{(late_bytes - early_bytes) / 4_501:.0f} bytes a step"
