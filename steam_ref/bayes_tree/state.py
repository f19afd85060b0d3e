"""Everything an incremental solver holds, in one object with one undo log.  [K12 Alg. 4]

:class:`SolverState` owns the Bayes tree and every per-factor and per-variable store (listed once, in
:attr:`SolverState.STORES`), with the operations every step needs: add or drop a variable, append or drop
factors, cache a linearization, move a linearization point. Each writes through the :class:`~.undo.UndoLog`
the tree's surgery records into too, so one :meth:`SolverState.transaction` undoes an update, a
marginalization or both. An estimate is θ̄ ⊕ δ by the variable's kind (:mod:`steam_ref.manifold`).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager

import numpy as np
from numpy.typing import NDArray

from ..errors import SteamError
from ..factors import Factor
from ..linear.system import GaussianFactor
from ..manifold import Manifold, by_kind
from ..variables import Key, Values
from .tree import BayesTree
from .undo import UndoLog

__all__ = ["SolverState"]


class SolverState:
    """The stores of one incremental solver, its Bayes tree, and the undo log they all record into."""

    # Every store, per factor then per variable: what an undo restores and what a test compares.
    STORES = ("factors", "linear", "theta_bar", "kinds", "dims", "beta", "delta", "estimates", "stale", "candidates")
    VARIABLE_STORES = STORES[2:]

    def __init__(self) -> None:
        self.log = UndoLog()  # every change of every store below, and of the tree, while a transaction runs
        self.tree = BayesTree(self.log)  # the current Bayes tree
        self.factors: dict[int, Factor] = {}  # id → each factor held (ids count every factor given; a dropped one goes)
        self.linear: dict[int, GaussianFactor | None] = {}  # id → the cached linearization of each at θ̄ (None: not yet)
        self.n_factors = 0  # factors given so far: the next id
        self.theta_bar: dict[Key, NDArray] = {}  # θ̄: the linearization point
        self.kinds: dict[Key, Manifold] = {}  # the kind of each variable (how it moves), from its factors
        self.dims: dict[Key, int] = {}  # size of each variable (its tangent's too)
        self.beta: dict[Key, float] = {}  # β: each variable's relinearization threshold [K12 Alg. 5]
        self.delta: dict[Key, NDArray] = {}  # δ, relative to θ̄ (an array is replaced, never written in place)
        self.estimates: dict[Key, NDArray] = {}  # θ̄ ⊕ δ, read-only arrays, formed again for the stale keys
        self.stale: dict[Key, None] = {}  # variables whose θ̄ or δ moved since their estimate was formed
        self.candidates: dict[Key, None] = {}  # relinearization candidates: latest δ has max abs(δ) ≥ β
        self.steps = 0  # updates so far
        self.tree_nnz = 0  # nonzeros of R (GTSAM's treeNnz)

    @contextmanager
    def transaction(self) -> Iterator[UndoLog]:
        """Run a change of the solver: if it raises (Ctrl-C too), the stores, the tree and what the caller logged in
        the log it yields come back as they were; nested ones belong to the outermost."""
        with self.log.transaction():
            self.log.keep(self.candidates)  # an ordered set: the next θ̄ moves, and the next ordering, follow it
            for name in ("steps", "tree_nnz", "n_factors"):
                self.log.record(setattr, self, name, getattr(self, name))
            yield self.log

    def values(self) -> Values:
        """θ̄ as a Values (a view of the store, no copy: for reading only)."""
        return Values.view(self.theta_bar, self.kinds)

    # --- variables --------------------------------------------------------------------------

    def add_variable(self, key: Key, value: NDArray, kind: Manifold, beta: float) -> None:
        """A new variable: θ̄ = ``value``, δ = 0."""
        log = self.log
        log.set(self.theta_bar, key, value)
        log.set(self.kinds, key, kind)
        log.set(self.dims, key, value.shape[0])
        log.set(self.beta, key, beta)
        log.set(self.delta, key, np.zeros_like(value))
        log.set(self.stale, key, None)

    def drop_variables(self, keys: Sequence[Key]) -> None:
        """Forget variables from every per-variable store (their order comes back on undo)."""
        for name in self.VARIABLE_STORES:
            store = getattr(self, name)
            self.log.keep(store)
            for key in keys:
                store.pop(key, None)

    def move(self, key: Key, theta_bar: NDArray, delta: NDArray) -> None:
        """Set a variable's θ̄ and δ (fluid relinearization: θ̄ ⊕ δ unchanged, or as the caller moves it)."""
        self.log.set(self.theta_bar, key, theta_bar)
        self.log.set(self.delta, key, delta)
        self.log.set(self.stale, key, None)

    def _formed(self, keys: list[Key]) -> dict[Key, NDArray]:
        """θ̄ ⊕ δ of ``keys`` by their kinds, one call per kind, as read-only arrays in the order of ``keys``."""
        formed, groups = {}, by_kind(keys, self.kinds)
        for kind, group in groups:
            moved = kind.retract_many([self.theta_bar[k] for k in group], [self.delta[k] for k in group])
            for k, e in zip(group, moved, strict=True):
                e.setflags(write=False)
                formed[k] = e
        return formed if len(groups) < 2 else {k: formed[k] for k in keys}

    def estimates_of(self, keys: Sequence[Key]) -> dict[Key, NDArray]:
        """θ̄ ⊕ δ of held variables (read-only), the stale among them formed in one call per kind. KeyError: not held."""
        for k, e in self._formed([k for k in dict.fromkeys(keys) if k in self.stale]).items():
            self.log.set(self.estimates, k, e)
            self.log.delete(self.stale, k)
        return {k: self.estimates[k] for k in keys}

    def all_estimates(self) -> dict[Key, NDArray]:
        """θ̄ ⊕ δ of every variable (the store itself: the caller copies the dict, never the arrays).  [YIB Eq. 11]"""
        formed = self._formed(list(self.stale))  # in the order they went stale, as always
        if self.log.depth:  # in a transaction: recorded
            for k, e in formed.items():
                self.log.set(self.estimates, k, e)
            self.log.keep(self.stale)
        else:
            self.estimates.update(formed)
        self.stale.clear()
        return self.estimates

    # --- factors ----------------------------------------------------------------------------

    def append_factors(self, factors: Sequence[Factor], linear: list[GaussianFactor] | None = None) -> list[int]:
        """Store factors (with their linearization, else uncached); returns their ids."""
        ids = list(range(self.n_factors, self.n_factors + len(factors)))
        self.n_factors += len(factors)  # (the transaction recorded it)
        for j, f, gf in zip(ids, factors, [None] * len(factors) if linear is None else linear, strict=True):
            self.log.set(self.factors, j, f)
            self.log.set(self.linear, j, gf)
        return ids

    def factor_slots(self) -> tuple[Factor | None, ...]:
        """Every factor given so far, by id (None: dropped), built when asked: the stores hold the live ones only."""
        return tuple(self.factors.get(j) for j in range(self.n_factors))

    def cached(self, fid: int) -> GaussianFactor:
        """The linearization of factor ``fid`` at θ̄ (made when it entered, or when θ̄ of its variables moved)."""
        gf = self.linear[fid]
        if gf is None:
            raise SteamError(f"factor {fid} has not been linearized")
        return gf

    def set_linear(self, fid: int, gf: GaussianFactor | None) -> None:
        """Cache factor ``fid``'s linearization at θ̄."""
        self.log.set(self.linear, fid, gf)

    def drop_factors(self, fids: Sequence[int]) -> None:
        """Forget factors ``fids`` (their ids are never given again; the stores' order comes back on undo)."""
        for store in (self.factors, self.linear):
            self.log.keep(store)
            for fid in fids:
                del store[fid]
