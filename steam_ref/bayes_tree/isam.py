"""Incremental updates of the Bayes tree: iSAM2, the paper's Algorithm 1 steps 2-7.  [YIB Alg. 1, K12]

One :meth:`IncrementalSolver.update` does, in the numbering of [YIB Alg. 1]:

1. add the new factors and the new variables (with their initial values);
7. (the previous round's step 7, done first as in [K12 Alg. 6]) fluid relinearization: variables
   whose increment δ moved them at least a threshold from their linearization point θ̄ get
   θ̄ ← θ̄ + δ [K12 Alg. 5];
2. remove the cliques holding an affected variable (one named by a new factor, or relinearized:
   every clique holding it) and all their ascendants up to the root [K12 Alg. 4];
3. re-linearize only the factors of the removed part that touch a relinearized variable; the
   others keep their cached linearization (θ̄ did not move for them);
4. add the cached marginal factors f(S) of the orphaned subtrees;
5. eliminate this small factor graph with a constrained minimum-degree ordering (variables touched
   by the new factors last) and reattach each orphan under the clique that eliminates the first
   variable of its separator [K12 Alg. 4];
6. back-substitute from the root, descending only while the increments change by at least the
   wildfire threshold [K12 Alg. 7].

Every step costs time in proportion to the removed part and the cliques back-substitution visits:
nothing walks the whole tree, and the estimate θ̄ + δ is kept up to date variable by variable.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..covariance import tree_joint_covariance, tree_marginal_covariance, tree_marginals
from ..errors import ShapeError, SteamError, UnderdeterminedError, UnknownVariableError
from ..factors import Factor
from ..variables import Key, Values
from ..linear.ordering import constrained_min_degree
from ..linear.system import GaussianFactor, linearize
from .params import ISAM2Params
from .tree import BayesTree, eliminate

__all__ = ["IncrementalSolver", "UpdateReport"]

@dataclass(frozen=True)
class UpdateReport:
    """What one update did, so a notebook can show the affected top of the tree."""

    step: int  # number of this update, from 1
    removed_cliques: tuple[int, ...]  # ids of the cliques taken off the top (ids of the tree before)
    new_cliques: tuple[int, ...]  # ids of the cliques made by re-elimination
    orphans: tuple[int, ...]  # ids of the subtrees kept and reattached
    relinearized: tuple[Key, ...]  # variables whose linearization point moved
    reeliminated: tuple[Key, ...]  # variables eliminated anew (frontals of the new cliques)
    updated: tuple[Key, ...]  # variables whose increment δ (hence estimate) was recomputed
    linearized_factors: int  # factors linearized in this update (the new ones included)
    backsubstituted_cliques: int  # cliques whose conditional was solved
    time_s: float  # wall time of the whole update
    timings: dict[str, float] = field(default_factory=dict)  # seconds per phase


@dataclass
class _Undo:
    """What an update changed before re-elimination succeeded, to put back if it fails."""

    n_factors: int  # number of factors before the update
    new_keys: list[Key]  # variables the update added
    relinearized: dict[Key, tuple[NDArray, NDArray]] = field(default_factory=dict)  # key → old (θ̄, δ)
    linear: dict[int, GaussianFactor] = field(default_factory=dict)  # factor id → old cached linearization
    removed: bool = False  # the top of the tree was removed
    committed: bool = False  # elimination succeeded: nothing to undo any more


class IncrementalSolver:
    """iSAM2 on the Bayes tree: BTGP's incremental solver.  [YIB Alg. 1, K12 Alg. 6]

    ``params`` (default :class:`ISAM2Params`, GTSAM's defaults) sets the relinearization and
    wildfire thresholds; keyword ``changes`` override its fields, so
    ``IncrementalSolver(relinearize_skip=1, wildfire_threshold=0)`` works as well.
    """

    def __init__(self, params: ISAM2Params | None = None, **changes: object) -> None:
        params = ISAM2Params() if params is None else params
        self.params = params.replace(**changes) if changes else params  # the settings, validated
        self.tree = BayesTree()  # the current Bayes tree
        self.factors: list[Factor] = []  # every factor so far; a factor's id is its position
        self._linear: list[GaussianFactor | None] = []  # cached linearization of each factor at θ̄
        self._theta_bar = Values()  # linearization point θ̄
        self._dims: dict[Key, int] = {}  # size of each variable
        self._threshold: dict[Key, float] = {}  # relinearization threshold of each variable (by kind)
        self._delta: dict[Key, NDArray] = {}  # current increment δ, relative to θ̄ (never written in place)
        self._estimate: dict[Key, NDArray] = {}  # θ̄ + δ, read-only arrays, refreshed for ``_stale`` keys
        self._stale: dict[Key, None] = {}  # variables whose δ or θ̄ moved since their estimate was formed
        self._over: dict[Key, None] = {}  # variables whose latest δ has max |δ| ≥ their threshold
        self._steps = 0

    # --- queries ----------------------------------------------------------------------------

    def estimate(self) -> Values:
        """The current estimate θ̄ + δ of every variable (a snapshot; the arrays are read-only).

        Only the variables whose δ changed since the last call are recomputed.
        """
        for k in self._stale:
            self._form_estimate(k)
        self._stale.clear()
        out = Values()
        out._data = dict(self._estimate)  # shallow: the solver never writes into these arrays
        return out

    def estimate_of(self, key: Key) -> NDArray:
        """The current estimate θ̄ + δ of one variable (read-only)."""
        if key in self._stale:
            del self._stale[key]
            self._form_estimate(key)
        try:
            return self._estimate[key]
        except KeyError:
            raise UnknownVariableError(f"variable {key!r} is not in the solver") from None

    def _form_estimate(self, key: Key) -> None:
        e = self._theta_bar[key] + self._delta[key]
        e.flags.writeable = False
        self._estimate[key] = e

    @property
    def linearization_point(self) -> Values:
        """θ̄: where each factor of the tree was linearized (a copy)."""
        return self._theta_bar.copy()

    def delta(self) -> dict[Key, NDArray]:
        """The current increments δ (a copy), relative to :attr:`linearization_point`."""
        return {k: v.copy() for k, v in self._delta.items()}

    def marginal_covariance(self, key: Key) -> NDArray:
        """Cov(δθ_key) (d, d) of the current linear system, from the Bayes tree.  [K11 Sec. 3]"""
        return tree_marginal_covariance(self.tree, key)

    def joint_marginal_covariance(self, keys: Iterable[Key]) -> NDArray:
        """Joint covariance (Σdₖ, Σdₖ) of several variables, stacked in the order given, from the tree."""
        return tree_joint_covariance(self.tree, list(keys))

    def marginals(self, keys: Iterable[Key] | None = None) -> dict[Key, NDArray]:
        """Marginal covariance (dₖ, dₖ) of each of ``keys`` (every variable when None), in one pass down the tree."""
        return tree_marginals(self.tree, keys)

    def __len__(self) -> int:
        return len(self._dims)

    # --- the update -------------------------------------------------------------------------

    def update(
        self,
        new_factors: Factor | Iterable[Factor] = (),
        new_values: Mapping[Key, NDArray] | None = None,
        *,
        relinearize: bool = True,
    ) -> UpdateReport:
        """Add factors and variables, and update the tree and the estimate.  [YIB Alg. 1, K12 Alg. 6]

        Raises :class:`SteamError` subclasses on bad input (a new value for an existing variable, a
        factor naming a variable with no value, a variable left unconstrained, ...); the solver is
        then as it was before the call.
        """
        t0 = time.perf_counter()
        new_factors = [new_factors] if isinstance(new_factors, Factor) else list(new_factors)
        new_values = self._checked_update(new_factors, {} if new_values is None else new_values)
        undo = _Undo(len(self.factors), list(new_values))
        try:
            return self._update(new_factors, new_values, relinearize, undo, t0)
        except Exception:
            if not undo.committed:
                self._rollback(undo)
            raise

    def _update(self, new_factors: list[Factor], new_values: dict[Key, NDArray], relinearize: bool, undo: _Undo, t0: float) -> UpdateReport:
        self._steps += 1
        # 1. Add the new factors and the new variables.                     [YIB Alg. 1 step 1]
        new_ids = self._add(new_factors, new_values)
        touched = list(dict.fromkeys(k for f in new_factors for k in f.keys))
        # 7. Fluid relinearization, from the previous round's δ.      [YIB Alg. 1 step 7, K12 Alg. 5]
        relin = self._fluid_relinearization(undo) if relinearize and self._steps % self.params.relinearize_skip == 0 else []
        t1 = time.perf_counter()
        # 2. Remove the cliques of the affected variables and their ascendants.   [K12 Alg. 4]
        start = [self.tree.frontal_of[k] for k in touched if k in self.tree.frontal_of]
        for k in relin:
            start.extend(self.tree.cliques_involving(k))
        removed, orphans = self.tree.remove_top(start)
        undo.removed = True
        variables = [k for c in removed.values() for k in c.frontals] + list(new_values)
        fids = [j for c in removed.values() for j in c.factors] + new_ids
        # 3. Re-linearize the factors of the removed part that touch a relinearized variable.
        t2 = time.perf_counter()
        n_linearized = self._relinearize(fids, set(relin), undo)
        t3 = time.perf_counter()
        # 4. Add the cached marginal factors f(S) of the orphaned subtrees.
        linear = [self._linear[j] for j in fids] + [self.tree.cliques[o].marginal for o in orphans]
        # 5. Eliminate with the touched variables last; reattach the orphans.  [YIB Eq. 24-25]
        order = constrained_min_degree(variables, [f.keys for f in linear], last=touched)
        t4 = time.perf_counter()
        cliques, parents, owner = eliminate(order, linear, self._dims, fids + [None] * len(orphans))
        undo.committed = True
        new_cids = self.tree.insert_eliminated(cliques, parents)
        for i, o in enumerate(orphans):  # under the clique eliminating its separator's first variable
            self.tree.attach(o, new_cids[owner[len(fids) + i]])
        t5 = time.perf_counter()
        # 6. Partial back-substitution from the root.                      [K12 Alg. 7]
        updated, visited = self._backsubstitute(set(new_cids))
        t6 = time.perf_counter()
        timings = dict(relinearize=t1 - t0, remove=t2 - t1, linearize=t3 - t2, order=t4 - t3, eliminate=t5 - t4, backsubstitute=t6 - t5)
        return UpdateReport(
            self._steps, tuple(removed), tuple(new_cids), tuple(orphans), tuple(relin), tuple(order),
            tuple(updated), n_linearized, visited, t6 - t0, timings,
        )

    def _rollback(self, undo: _Undo) -> None:
        """Put everything back as it was before a failed update (the failure came before re-insertion)."""
        if undo.removed:
            self.tree.restore_top()
        for j, gf in undo.linear.items():
            self._linear[j] = gf
        for k, (theta, delta) in undo.relinearized.items():
            self._theta_bar.insert(k, theta)
            self._delta[k] = delta
            self._stale[k] = None
            self._over[k] = None
        for k in undo.new_keys:
            for store in (self._theta_bar._data, self._dims, self._threshold, self._delta, self._estimate, self._stale):
                store.pop(k, None)
        del self.factors[undo.n_factors :], self._linear[undo.n_factors :]
        self._steps -= 1

    def _checked_update(self, new_factors: list[Factor], new_values: Mapping[Key, NDArray]) -> dict[Key, NDArray]:
        """Validate an update before anything changes; returns the new values as float vectors."""
        values: dict[Key, NDArray] = {}
        for k, v in new_values.items():
            if k in self._dims:
                raise SteamError(f"variable {k!r} already has a value; an update cannot give it a new one")
            x = np.array(v, dtype=float).reshape(-1)
            if not np.all(np.isfinite(x)):
                raise ShapeError(f"new value of {k!r} is not finite: {x}")
            self.params.threshold_for(k.kind)  # a dict of thresholds must name every kind
            values[k] = x
        for f in new_factors:
            if not isinstance(f, Factor):
                raise SteamError(f"update expects factors, got {type(f).__name__}")
            for k, dim in zip(f.keys, f.key_dims):
                have = values[k].shape[0] if k in values else self._dims.get(k)
                if have is None:
                    raise UnknownVariableError(f"{type(f).__name__} names {k!r}, which has no value: give it one in new_values")
                if have != dim:
                    raise ShapeError(f"{type(f).__name__} expects {k!r} of size {dim}, its value has size {have}")
        named = {k for f in new_factors for k in f.keys}
        for k in values:
            if k not in named:
                raise UnderdeterminedError(f"new variable {k!r} is named by no new factor, so nothing constrains it")
        return values

    def _add(self, new_factors: list[Factor], new_values: dict[Key, NDArray]) -> list[int]:
        """Store factors (uncached) and variables (θ̄ = initial value, δ = 0); returns the new factor ids."""
        first = len(self.factors)
        self.factors.extend(new_factors)
        self._linear.extend([None] * len(new_factors))
        for k, x in new_values.items():
            self._theta_bar.insert(k, x)
            self._dims[k] = x.shape[0]
            self._threshold[k] = self.params.threshold_for(k.kind)
            self._delta[k] = np.zeros_like(x)
            self._stale[k] = None
        return list(range(first, len(self.factors)))

    def _fluid_relinearization(self, undo: _Undo) -> list[Key]:
        """θ̄ ← θ̄ + δ where max |δ| ≥ threshold.  [K12 Alg. 5]

        The candidates are kept up to date by back-substitution, which is the only place δ changes.
        """
        relin = list(self._over)
        self._over.clear()
        for k in relin:
            undo.relinearized[k] = (self._theta_bar[k], self._delta[k])
            self._theta_bar.insert(k, self.estimate_of(k))  # the estimate is unchanged
            self._delta[k] = np.zeros(self._dims[k])
        return relin

    def _relinearize(self, fids: list[int], relin: set[Key], undo: _Undo) -> int:
        """Linearize, at θ̄, the factors among ``fids`` that are new or touch ``relin``.  [YIB Eq. 9]"""
        need = [j for j in fids if self._linear[j] is None or (relin and not relin.isdisjoint(self.factors[j].keys))]
        undo.linear.update((j, self._linear[j]) for j in need if self._linear[j] is not None)
        if need:
            for group in linearize([self.factors[j] for j in need], self._theta_bar):
                for i, gf in zip(group.factor_ids, group.gaussian_factors()):
                    self._linear[need[i]] = gf
        return len(need)

    def _backsubstitute(self, new_cliques: set[int]) -> tuple[list[Key], int]:
        """δ_F = R⁻¹(d - S δ_S) from the roots of the new part down, while it changes.  [K12 Alg. 7]

        A re-made clique is always solved; an old one only when a variable of its separator changed
        by at least the wildfire threshold (with threshold 0, always: full back-substitution).
        Changes are judged per variable: a root clique holding the newest state and the landmarks
        must not mark the landmarks changed because the newest state moved.
        """
        tree, delta, threshold = self.tree, self._delta, self.params.wildfire_threshold
        stale, over, limit = self._stale, self._over, self._threshold
        changed: set[Key] = set()
        updated: list[Key] = []
        stack = [c for c in new_cliques if tree.parent[c] is None]
        visited = 0
        while stack:
            c = stack.pop()
            clique = tree.cliques[c]
            visited += 1
            sep = np.concatenate([delta[k] for k in clique.separator]) if clique.separator else None
            x = clique.solve(sep)  # [YIB Eq. 25]
            frontals = clique.frontals
            for k, xk in zip(frontals, (x,) if len(frontals) == 1 else clique.split_frontals(x)):
                if threshold == 0 or abs(xk - delta[k]).max() >= threshold:
                    changed.add(k)
                delta[k] = xk
                stale[k] = None
                if abs(xk).max() >= limit[k]:  # a candidate for the next relinearization [K12 Alg. 5]
                    over[k] = None
                elif k in over:
                    del over[k]
            updated.extend(frontals)
            for ch in tree.children[c]:
                if ch in new_cliques or not changed.isdisjoint(tree.cliques[ch].separator):
                    stack.append(ch)
        return updated, visited
