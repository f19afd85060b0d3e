"""Marginalizing variables out of the Bayes tree, exactly.  [K11 Sec. 3, K12 Sec. 4; derivations §10]

To forget a set of variables D (the states older than a lag) is to replace the posterior p(D, Θ) by
its marginal p(Θ) = ∫ p(D, Θ) dD. In the linearized problem ‖A δ - b‖² that is one more use of
[YIB Eq. 24]: eliminating D from the factors adjacent to it,

    [A_D A_S | b] = Q [[R_D, S_D, d_D], [0, A_m, b_m]],

leaves the conditional P(D | S), which a smoother keeps only to smooth its past afterwards
(:mod:`.history`), and the rows ‖A_m δ_S - b_m‖²
on D's separator S: the Schur complement of D in the information matrix (derivations §10, Eq. 10.1-10.3).
Every other factor is untouched, so the marginal over Θ is the old factors not touching D plus this
one. :func:`marginalize` does it in the tree, in the update's style:

1. *The cliques of D.* Every clique holding a variable of D (frontal or in a separator) is found by
   walking down from the clique where it is frontal [K12 Alg. 5].
2. *Leaves: nothing to re-eliminate.* When each of those cliques is frontal only in D, the tree minus
   them is already the Bayes tree of p(Θ): the cliques above are conditionals of Θ only, computed with
   the cut cliques' cached factor f(S) [YIB Eq. 24], the marginal (Eq. 10.3). They are cut off; a child
   holding no variable of D hangs under the nearest clique left, with its own f(S); the Schur complement
   of D's own factors (Eq. 10.1-10.2) becomes a :class:`MarginalFactor` of the clique that eliminates its
   first variable, for that clique's next re-elimination. (When the cut cliques are whole subtrees it
   equals their f(S).)
3. *Otherwise: re-eliminate the affected part with D first.* (GTSAM's ``marginalizeLeaves`` needs D in
   leaves; an ordering with D first puts it there.) The cliques of D and their ascendants are removed,
   as an update removes its top [K12 Alg. 4]. D is eliminated first from the factors adjacent to it
   (Eq. 10.1-10.2, one variable at a time), its conditionals are dropped, and the rest of the removed
   part is eliminated as an update would, from its remaining factors, the marginal factors and the
   orphans' cached f(S), with the old root's variables kept last; the orphans are hung back.

The marginal factor is linear, frozen at the linearization point θ̄_S of the moment (first-estimate
Jacobians): its Jacobian never changes, and when S is relinearized at θ̄' its right-hand side becomes
b_m - A_m (θ̄' - θ̄_S) (Eq. 10.4), GTSAM's ``LinearContainerFactor``.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..errors import SteamError, UnknownVariableError
from ..factors import Factor
from ..linear.ordering import constrained_min_degree
from ..linear.system import GaussianFactor
from ..variables import Key, Values, key_list
from .history import ForgottenConditional
from .isam import IncrementalSolver
from .journal import until_done
from .tree import Clique, eliminate, eliminate_clique

__all__ = ["MarginalFactor", "MarginalizationReport", "eliminate_variables", "marginalize"]


@dataclass(frozen=True, eq=False)
class MarginalFactor(Factor):
    """A linear factor frozen at a linearization point: e(θ) = A (θ - θ₀) - b.  [derivations Eq. 10.4]

    Made from a Schur complement ‖A δ_S - b‖² computed at θ̄_S = θ₀. Its whitened Jacobian is A at every
    θ (first-estimate Jacobians) and its right-hand side at θ̄' is b - A (θ̄' - θ₀). ``keys`` lists
    the separator variables, ``dims`` their sizes; A is (m, Σ dims), already whitened.
    """

    A: NDArray  # (m, n), whitened: sqrt_information is the identity
    b: NDArray  # (m,)
    theta0: NDArray  # (n,) the frozen linearization point, the keys' θ̄ stacked
    dims: tuple[int, ...] = ()  # size of each key

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "A", "b", "theta0")
    _shared: ClassVar[tuple[str, ...]] = ("dims",)  # equal within a batch: batch_signature holds it

    @classmethod
    def frozen_at(cls, gf: GaussianFactor, theta_bar: Mapping[Key, NDArray]) -> MarginalFactor:
        """The linear factor ``gf`` = ‖A δ - b‖², δ about ``theta_bar`` of its keys, as a factor of θ."""
        A = np.hstack(gf.blocks) if gf.blocks else np.zeros((len(gf.rhs), 0))
        theta0 = np.concatenate([np.asarray(theta_bar[k], dtype=float) for k in gf.keys])
        dims = tuple(block.shape[1] for block in gf.blocks)
        return cls(gf.keys, np.eye(len(gf.rhs)), A=A, b=gf.rhs.copy(), theta0=theta0, dims=dims)

    @property
    def key_dims(self) -> tuple[int, ...]:  # type: ignore[override]
        return self.dims

    def batch_signature(self) -> tuple:
        return super().batch_signature() + (self.dims,)

    def error(self, *xs: NDArray) -> NDArray:
        x = np.concatenate(xs, axis=-1)
        return np.einsum("...ij,...j->...i", self.A, x - self.theta0) - self.b  # [derivations Eq. 10.4]

    def jacobians(self, *xs: NDArray) -> tuple[NDArray, ...]:
        bounds = np.cumsum((0, *self.dims))
        shape = xs[0].shape[:-1] + self.A.shape[-2:]
        A = np.broadcast_to(self.A, shape)
        return tuple(A[..., :, a:z] for a, z in itertools.pairwise(bounds))


@dataclass(frozen=True)
class MarginalizationReport:
    """What one :func:`marginalize` did."""

    keys: tuple[Key, ...]  # the variables marginalized, in elimination order
    leaves: bool  # True: they were whole subtrees, cut off with no re-elimination
    removed_cliques: tuple[int, ...]  # ids of the cliques taken out (tree before)
    new_cliques: tuple[int, ...]  # ids of the cliques made by re-elimination (none for leaves)
    dropped_factors: tuple[int, ...]  # ids of the factors that touched the keys, now gone
    marginal_factors: tuple[int, ...]  # ids of the MarginalFactors added on the separators
    estimates: dict[Key, NDArray]  # each key's estimate θ̄ + δ at the moment it was marginalized
    conditionals: tuple[ForgottenConditional, ...] = ()  # P(v | S) of each key, if asked for (``keep_conditionals``)


def eliminate_variables(
    drop: Sequence[Key],
    factors: Sequence[GaussianFactor],
    dims: Mapping[Key, int],
    conditionals: list[Clique] | None = None,
) -> list[GaussianFactor]:
    """Eliminate ``drop`` from linear ``factors``, in that order: the factors left on the other variables.

    Each elimination is [YIB Eq. 24] for one variable: the factors adjacent to it are stacked and one QR
    splits them into the conditional (dropped, or appended to ``conditionals`` if a list is given) and the
    Schur complement on its separator (kept) [derivations Eq. 10.1-10.3]. Factors not adjacent to ``drop``
    come back unchanged, first.
    """
    pool = list(factors)
    for v in drop:
        adjacent = [f for f in pool if v in f.keys]
        if not adjacent:
            raise UnknownVariableError(f"no factor names {v!r}: nothing to marginalize it from")
        pool = [f for f in pool if v not in f.keys]
        separator = tuple(dict.fromkeys(k for f in adjacent for k in f.keys if k != v))
        clique = eliminate_clique((v,), separator, dims, adjacent)
        if conditionals is not None:
            conditionals.append(clique)
        marginal = clique.marginal
        if separator and marginal.rhs.shape[0]:
            pool.append(marginal)
    return pool


def _cliques_of(solver: IncrementalSolver, drop: set[Key]) -> list[int]:
    """Every clique holding a variable of ``drop``, frontal or in its separator (step 1)."""
    found: dict[int, None] = {}
    for v in drop:
        found.update(dict.fromkeys(solver.tree.cliques_involving(v)))
    return list(found)


def _are_leaves(solver: IncrementalSolver, cids: list[int], drop: set[Key]) -> bool:
    """True when every clique holding ``drop`` is frontal only in ``drop`` (step 2 applies)."""
    return all(drop.issuperset(solver.tree.cliques[c].frontals) for c in cids)


def _home(solver: IncrementalSolver, keys: tuple[Key, ...], tops: list[int]) -> int:
    """The clique that eliminates a factor on ``keys``: the deepest holding one of them as frontal.

    The keys lie within the variables of the parent of one of the cut cliques' tops; walking up from
    there, the first clique with one of them frontal holds them all.
    """
    tree, wanted = solver.tree, set(keys)
    for t in tops:
        c = tree.parent[t]
        if c is None or not wanted <= set(tree.cliques[c].frontals) | set(tree.cliques[c].separator):
            continue
        while c is not None and wanted.isdisjoint(tree.cliques[c].frontals):
            c = tree.parent[c]  # a root holds its variables as frontals: the walk ends there at the latest
        if c is not None:
            return c
    raise SteamError(f"no clique holds the marginal factor's variables {keys}")


def marginalize(
    solver: IncrementalSolver, keys: Iterable[Key], *, keep_conditionals: bool = False
) -> MarginalizationReport:
    """Marginalize ``keys`` out of ``solver``'s Bayes tree and factors (module docstring, steps 1-3).

    Afterwards the solver holds the marginal over the other variables: for a linear problem its
    estimate and covariances of every other variable are those of the whole problem, to rounding.
    ``keep_conditionals``: the report also carries each key's conditional P(v | S) at the linearization
    point of the moment (:class:`~.history.ForgottenConditional`), for a smoothing pass later.
    Raises :class:`UnknownVariableError` for a key the solver does not hold, and :class:`SteamError` for a
    :class:`~.fixed_lag.FixedLagSmoother`, which marginalizes by its timestamps and keeps its own record of
    what it forgot; on any failure or interruption (Ctrl-C) the solver is left as it was.
    """
    if not isinstance(solver, IncrementalSolver):
        raise SteamError(f"marginalize: solver must be an IncrementalSolver, got {type(solver).__name__}")
    if solver.forgets_by_time:
        raise SteamError(
            "marginalize: a FixedLagSmoother forgets by its timestamps (and records what it forgot); give the "
            "variables an old timestamp in its next update instead"
        )
    return _marginalize(solver, keys, keep_conditionals=keep_conditionals)


def _marginalize(
    solver: IncrementalSolver, keys: Iterable[Key], *, keep_conditionals: bool = False
) -> MarginalizationReport:
    """:func:`marginalize` without its check: what a :class:`~.fixed_lag.FixedLagSmoother` calls on itself."""
    drop_list = list(dict.fromkeys(key_list("keys", keys)))
    for k in drop_list:
        if k not in solver._dims:
            raise UnknownVariableError(f"cannot marginalize {k!r}: the solver does not hold it")
    if not drop_list:
        return MarginalizationReport((), True, (), (), (), (), {})
    drop = set(drop_list)
    tree = solver.tree
    cids = _cliques_of(solver, drop)
    fids = [j for c in cids for j in tree.cliques[c].factors]
    dropped = [j for j in fids if not drop.isdisjoint(solver._factors[j].keys)]
    adjacent = [solver._cached(j) for j in dropped]
    variables = list(dict.fromkeys(k for f in adjacent for k in f.keys))
    last = [k for k in variables if k not in drop]
    order = constrained_min_degree(variables, solver._dims, [f.keys for f in adjacent], last=last).keys
    order_drop = order[: len(drop)]
    estimates = {k: solver.estimate_of(k).copy() for k in order_drop}
    conditionals: list[Clique] | None = [] if keep_conditionals else None
    schur_factors = eliminate_variables(order_drop, adjacent, solver._dims, conditionals)  # (Eq. 10.1-10.3)
    theta = solver._theta_bar  # nothing is changed yet: a failure up to here leaves the solver as it was
    forgotten = () if conditionals is None else tuple(ForgottenConditional.of(c, theta) for c in conditionals)
    leaves = _are_leaves(solver, cids, drop)
    inside = set(cids)
    tops = [c for c in cids if tree.parent[c] not in inside]
    homes = [_home(solver, gf.keys, tops) for gf in schur_factors] if leaves else []
    undo = _Undo.of(solver, dropped, [*cids, *(tree.parent[c] for c in cids), *homes] if leaves else [])
    try:
        return _commit(solver, drop, cids, dropped, schur_factors, leaves, homes, order_drop, estimates, forgotten)
    except BaseException:  # an error, or Ctrl-C at any point: the solver as it was, then propagate
        until_done(lambda: undo.apply(solver))
        raise


@dataclass
class _Undo:
    """What :func:`_commit` may change, kept before it starts: any failure or interruption is undone. The per-variable
    stores are copied whole (their order is part of "as it was"; a fixed-lag window bounds them); the tree keeps its
    checkpoint (re-elimination) and the links of the cliques a cut or a recorded factor touches."""

    n_factors: int  # number of factors before
    dropped: dict[int, tuple[Factor, GaussianFactor | None]]  # factor id → (factor, cached linearization)
    theta_bar: dict[Key, NDArray]  # a copy of θ̄
    stores: tuple[dict, ...]  # copies of :func:`_stores`
    tree: tuple[int, dict[int, None]]  # the tree's checkpoint
    links: dict[int, tuple[Clique, int | None, list[int]]]  # clique id → (clique, parent, children)

    @classmethod
    def of(cls, solver: IncrementalSolver, dropped: list[int], touched: Iterable[int | None]) -> _Undo:
        tree = solver.tree
        links = {c: (tree.cliques[c], tree.parent[c], list(tree.children[c])) for c in touched if c is not None}
        return cls(
            len(solver._factors),
            {j: (solver._factors[j], solver._linear[j]) for j in dropped},
            dict(solver._theta_bar),
            tuple(dict(store) for store in _stores(solver)),
            tree.checkpoint(),
            links,
        )

    def apply(self, solver: IncrementalSolver) -> None:
        """Put it all back (idempotent, for :func:`~.journal.until_done`)."""
        tree = solver.tree
        tree.rollback(self.tree)  # re-elimination: its new cliques go, the removed top comes back
        for c, (clique, parent, children) in self.links.items():  # a cut: the cliques and links it changed
            tree.cliques[c], tree.parent[c], tree.children[c] = clique, parent, list(children)
            tree.frontal_of.update(dict.fromkeys(clique.frontals, c))
            for ch in children:
                tree.parent[ch] = c
        del solver._factors[self.n_factors :], solver._linear[self.n_factors :]
        for j, (factor, gf) in self.dropped.items():
            solver._factors[j], solver._linear[j] = factor, gf
        solver._theta_bar = Values.adopt(self.theta_bar)
        for store, saved in zip(_stores(solver), self.stores, strict=True):
            dict.clear(store)
            dict.update(store, saved)  # not the UndoDict's own update: nothing is recorded


def _stores(solver: IncrementalSolver) -> tuple[dict, ...]:
    """The solver's per-variable dicts besides θ̄: sizes, β, δ, the estimates, the stale and relinearization sets."""
    return (solver._dims, solver._beta, solver._delta, solver._estimate, solver._stale, solver._over)


def _commit(
    solver: IncrementalSolver,
    drop: set[Key],
    cids: list[int],
    dropped: list[int],
    schur_factors: list[GaussianFactor],
    leaves: bool,
    homes: list[int],
    order_drop: Sequence[Key],
    estimates: dict[Key, NDArray],
    forgotten: tuple[ForgottenConditional, ...],
) -> MarginalizationReport:
    """Steps 2-3 of :func:`marginalize`: every change to the solver, from what ``_marginalize`` computed."""
    tree = solver.tree
    if leaves:  # step 2: cut the cliques of D off; the Schur complement of D's factors goes to their parents
        removed = list(cids)
        new_cids: list[int] = []
        factor_ids = _add_marginal_factors(solver, schur_factors)
        for home, j in zip(homes, factor_ids, strict=True):
            _record_factor(solver, home, j)
        tree.cut(removed)  # a child holding no variable of D hangs under the nearest clique left, its f(S) kept
    else:  # step 3: re-eliminate the affected part with D first
        removed_cliques, orphans, cliques, parents, owner, kept = _reeliminate(solver, cids, drop, schur_factors)
        removed = list(removed_cliques)
        factor_ids = _add_marginal_factors(solver, schur_factors)
        labels = kept + factor_ids + [None] * len(orphans)
        cliques = [_relabel(c, labels) for c in cliques]
        new_cids = tree.insert_eliminated(cliques, parents)
        for o, own in zip(orphans, owner, strict=True):
            tree.attach(o, new_cids[own])
    for j in dropped:
        solver._factors[j] = None  # type: ignore[call-overload]  # ids are positions: keep the slot
        solver._linear[j] = None
    for k in drop:
        solver._theta_bar.remove(k)
        for store in (solver._dims, solver._beta, solver._delta, solver._estimate):
            del store[k]
        solver._stale.pop(k, None)
        solver._over.pop(k, None)
    if new_cids:
        solver._backsubstitute(set(new_cids))
    return MarginalizationReport(
        tuple(order_drop),
        leaves,
        tuple(removed),
        tuple(new_cids),
        tuple(dropped),
        tuple(factor_ids),
        estimates,
        forgotten,
    )


def _reeliminate(
    solver: IncrementalSolver, cids: list[int], drop: set[Key], schur: list[GaussianFactor]
) -> tuple[dict[int, Clique], list[int], list[Clique], list[int | None], list[int], list[int]]:
    """Step 3: remove the cliques of D and their ascendants, eliminate the rest of them anew.

    Returns ``(removed, orphans, cliques, parents, owner of each orphan, kept factor ids)``; the new
    cliques' ``factors`` index into ``kept + marginal factor ids + orphans``, relabelled by the caller.
    On failure or interruption the tree is put back.
    """
    tree = solver.tree
    roots = set(tree.roots)
    removed, orphans = tree.remove_top(cids)
    try:
        kept = [j for c in removed.values() for j in c.factors if drop.isdisjoint(solver._factors[j].keys)]
        linear = [solver._cached(j) for j in kept] + schur + [tree.cliques[o].marginal for o in orphans]
        rest = [k for c in removed.values() for k in c.frontals if k not in drop]
        last = [k for c, cl in removed.items() if c in roots for k in cl.frontals if k not in drop]
        order = solver._elimination_order(rest, [f.keys for f in linear], last)
        n_own = len(kept) + len(schur)
        cliques, parents, owner = eliminate(order, linear, solver._dims, list(range(n_own)) + [None] * len(orphans))
    except BaseException:  # an error, or Ctrl-C (KeyboardInterrupt) while eliminating: the tree as it was
        tree.restore_top()
        raise
    return removed, orphans, cliques, parents, owner[n_own:], kept


def _relabel(clique: Clique, labels: list[int | None]) -> Clique:
    """``clique`` with its factor positions replaced by the solver's factor ids."""
    ids = tuple(labels[i] for i in clique.factors)
    return Clique(
        clique.frontals,
        clique.separator,
        clique.frontal_dims,
        clique.separator_dims,
        clique.R,
        clique.S,
        clique.d,
        clique.marginal,
        tuple(i for i in ids if i is not None),
    )


def _add_marginal_factors(solver: IncrementalSolver, schur: list[GaussianFactor]) -> list[int]:
    """Append each Schur factor as a :class:`MarginalFactor` frozen at θ̄, cached as it is; returns ids."""
    ids = []
    for gf in schur:
        if not gf.keys:
            raise SteamError("a marginal factor with no variables")  # a root's f(∅) is never made one
        ids.append(len(solver._factors))
        solver._factors.append(MarginalFactor.frozen_at(gf, solver._theta_bar))
        solver._linear.append(gf)  # its linearization at θ̄ is itself  [Eq. 10.4 at θ̄' = θ̄_S]
    return ids


def _record_factor(solver: IncrementalSolver, cid: int, fid: int) -> None:
    """Clique ``cid`` now also eliminates factor ``fid`` (its next re-elimination must gather it)."""
    c = solver.tree.cliques[cid]
    solver.tree.cliques[cid] = Clique(
        c.frontals, c.separator, c.frontal_dims, c.separator_dims, c.R, c.S, c.d, c.marginal, c.factors + (fid,)
    )
