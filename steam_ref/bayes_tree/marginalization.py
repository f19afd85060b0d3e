"""Marginalizing variables out of the Bayes tree, exactly.  [K11 Sec. 3, K12 Sec. 4; derivations §10]

To forget a set of variables D (the states older than a lag) is to replace the posterior p(D, Θ) by
its marginal p(Θ) = ∫ p(D, Θ) dD. In the linearized problem ‖A δ - b‖² that is one more use of
[YIB Eq. 24]: eliminating D from the factors adjacent to it,

    [A_D A_S | b] = Q [[R_D, S_D, d_D], [0, A_m, b_m]],

leaves the conditional P(D | S), which a smoother keeps only to smooth its past afterwards (:mod:`.history`), and the
rows ‖A_m δ_S - b_m‖² on D's separator S: the Schur complement of D in the information matrix (derivations §10,
Eq. 10.1-10.3). Every other factor is untouched, so the marginal over Θ is the old factors not touching D plus this
one. :meth:`IncrementalSolver.marginalize_leaves <.isam.IncrementalSolver.marginalize_leaves>` does it in the
tree, in the update's style:

1. *The cliques of D.* Every clique holding a variable of D (frontal or in a separator) is found by
   walking down from the clique where it is frontal [K12 Alg. 5].
2. *Leaves: nothing to re-eliminate.* When each of those cliques is frontal only in D, the tree minus
   them is already the Bayes tree of p(Θ): the cliques above are conditionals of Θ only, computed with
   the cut cliques' cached factor f(S) [YIB Eq. 24], the marginal (Eq. 10.3). They are cut off; a child
   holding no variable of D hangs under the nearest clique left, with its own f(S); the Schur complement
   of D's own factors (Eq. 10.1-10.2) becomes a :class:`MarginalFactor` of the clique that eliminates the
   first-eliminated of its variables, for that clique's next re-elimination. (When the cut cliques are whole
   subtrees it equals their tops' f(S), which ``reuse_marginals`` takes as it is, with no elimination.)
3. *Otherwise: re-eliminate the affected part with D first.* (GTSAM's ``marginalizeLeaves`` needs D in
   leaves; an ordering with D first puts it there.) The cliques of D and their ascendants are removed,
   as an update removes its top [K12 Alg. 6]. D is eliminated first from the factors adjacent to it
   (Eq. 10.1-10.2, one variable at a time), its conditionals are dropped, and the rest of the removed
   part is eliminated as an update would, from its remaining factors, the marginal factors and the
   orphans' cached f(S), with the old root's variables kept last (and the caller's ``constrained`` first);
   the orphans are hung back.

The marginal factor (:class:`~steam_ref.factors.MarginalFactor`) is frozen at θ̄_S of the moment: its
right-hand side at θ̄' is b_m - A_m (θ̄' ⊖ θ̄_S) (Eq. 10.4). Every change goes through the solver's
:class:`~.state.SolverState`, in one transaction: a failure or a Ctrl-C leaves the solver as it was.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

from numpy.typing import NDArray

from ..arguments import flag
from ..errors import SteamError, UnknownVariableError
from ..factors.marginal import MarginalFactor
from ..linear.ordering import check_constrained, min_degree_keys
from ..linear.system import GaussianFactor
from ..variables import Key, key_list
from .backsolve import backsubstitute
from .history import ForgottenConditional
from .state import SolverState
from .tree import BayesTree, Clique, eliminate, eliminate_clique

__all__ = ["MarginalFactor", "MarginalizationReport", "cuttable", "eliminate_variables", "marginalize_keys"]


@dataclass(frozen=True)
class MarginalizationReport:
    """What one marginalization did."""

    keys: tuple[Key, ...]  # the variables marginalized, in elimination order
    leaves: bool  # True: they were whole subtrees, cut off with no re-elimination
    removed_cliques: tuple[int, ...]  # ids of the cliques taken out (tree before)
    new_cliques: tuple[int, ...]  # ids of the cliques made by re-elimination (none for leaves)
    dropped_factors: tuple[int, ...]  # ids of the factors that touched the keys, now gone
    marginal_factors: tuple[int, ...]  # ids of the MarginalFactors added on the separators
    estimates: dict[Key, NDArray]  # each key's estimate θ̄ ⊕ δ at the moment it was marginalized
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
    pool, end = dict(enumerate(factors)), len(factors)  # position → factor, in order: a new marginal goes last
    on: dict[Key, list[int]] = {}  # variable → the positions naming it, increasing (a used one stays, skipped)
    for i, f in pool.items():
        for k in f.keys:
            on.setdefault(k, []).append(i)
    for v in drop:
        adjacent = [pool.pop(i) for i in on.pop(v, ()) if i in pool]  # in the pool's order, no scan of it
        if not adjacent:
            raise UnknownVariableError(f"no factor names {v!r}: nothing to marginalize it from")
        separator = tuple(dict.fromkeys(k for f in adjacent for k in f.keys if k != v))
        clique = eliminate_clique((v,), separator, dims, adjacent)
        if conditionals is not None:
            conditionals.append(clique)
        marginal = clique.marginal
        if separator and marginal.rhs.shape[0]:
            for k in separator:
                on.setdefault(k, []).append(end)
            pool[end], end = marginal, end + 1
    return list(pool.values())


def _home(state: SolverState, keys: tuple[Key, ...], tops: list[int]) -> int:
    """The clique that eliminates a factor on ``keys``: the deepest holding one of them as frontal (walking up
    from the parent of a cut top whose variables hold them, the first clique with one of them frontal)."""
    tree, wanted = state.tree, set(keys)
    for t in tops:
        c = tree.parent[t]
        if c is None or not wanted <= set(tree.cliques[c].frontals) | set(tree.cliques[c].separator):
            continue
        while c is not None and wanted.isdisjoint(tree.cliques[c].frontals):
            c = tree.parent[c]  # a root holds its variables as frontals: the walk ends there at the latest
        if c is not None:
            return c
    raise SteamError(f"no clique holds the marginal factor's variables {keys}")


def marginalize_keys(
    state: SolverState,
    keys: Iterable[Key],
    alpha: float,
    constrained: Mapping[Key, float] | None = None,
    keep_conditionals: bool = False,
    reuse_marginals: bool = False,
) -> MarginalizationReport:
    """Marginalize ``keys`` out of ``state``'s Bayes tree and factors (module docstring, steps 1-3): what
    :meth:`~.isam.IncrementalSolver.marginalize_leaves` runs. ``alpha``: the wildfire threshold of the
    back-substitution after a re-elimination; ``constrained``: the keys its ordering eliminates first
    (:func:`~steam_ref.linear.ordering.min_degree_keys`); ``reuse_marginals``: whole subtrees are cut with the f(S)
    the tree cached (step 2, the same marginal to rounding, with no elimination). One transaction: on any failure
    or interruption (Ctrl-C) the state is left as it was."""
    drop_list = list(dict.fromkeys(key_list("keys", keys)))  # a key named twice is marginalized once (as GTSAM)
    check_constrained(constrained)
    flag("keep_conditionals", keep_conditionals)
    for k in drop_list:
        if k not in state.dims:
            raise UnknownVariableError(f"cannot marginalize {k!r}: the solver does not hold it")
    if not drop_list:
        return MarginalizationReport((), True, (), (), (), (), {})
    with state.transaction():
        return _marginalize(state, drop_list, alpha, constrained, keep_conditionals, reuse_marginals)


def _marginalize(
    state: SolverState, keys: list[Key], alpha: float, constrained: Mapping[Key, float] | None, keep: bool, reuse: bool
) -> MarginalizationReport:
    """Steps 1-3 of the module docstring, inside a transaction; ``keys`` in their order (a set's is PYTHONHASHSEED's)."""
    tree, drop = state.tree, set(keys)
    whole = cuttable(tree, drop) if reuse else []
    whole = whole if sum(len(tree.cliques[c].frontals) for c in whole) == len(drop) else []  # only if they are all of D
    cids = whole or list(dict.fromkeys(c for v in keys for c in tree.cliques_involving(v)))  # step 1
    dropped = [j for c in cids for j in tree.cliques[c].factors if not drop.isdisjoint(state.factors[j].keys)]
    inside = set(cids)
    tops = [c for c in cids if tree.parent[c] not in inside]
    if whole:  # whole subtrees: the f(S) of their tops is the marginal (Eq. 10.3), their conditionals P(D | S)
        order_drop = [k for c in reversed(whole) for k in tree.cliques[c].frontals]  # children first
        schur = [m for t in tops if tree.cliques[t].separator and (m := tree.cliques[t].marginal).rhs.shape[0]]
        split = [(tree.cliques[c], i) for c in reversed(whole) for i in range(len(tree.cliques[c].frontals))]
    else:
        adjacent = [state.cached(j) for j in dropped]
        variables = list(dict.fromkeys(k for f in adjacent for k in f.keys))
        last = [k for k in variables if k not in drop]  # D first, the rest last: a lone key is first with no ordering
        order = keys if len(keys) == 1 else min_degree_keys(variables, state.dims, [f.keys for f in adjacent], last)
        order_drop = order[: len(drop)]
        conditionals: list[Clique] | None = [] if keep else None
        schur = eliminate_variables(order_drop, adjacent, state.dims, conditionals)  # (Eq. 10.1-10.3)
        split = [(c, 0) for c in conditionals or ()]
    estimates = {k: e.copy() for k, e in state.estimates_of(order_drop).items()}
    forgotten = tuple(ForgottenConditional.of(c, state.theta_bar, state.kinds, i) for c, i in split) if keep else ()
    leaves = all(drop.issuperset(tree.cliques[c].frontals) for c in cids)
    if leaves:
        # Step 2, leaves: cut the cliques of D off; the Schur complement of D's factors goes to their parents.
        homes = [_home(state, gf.keys, tops) for gf in schur]
        removed, new_cids, factor_ids = list(cids), [], _add_marginal_factors(state, schur)
        for home, j in zip(homes, factor_ids, strict=True):  # its next re-elimination gathers j
            tree.replace(home, tree.cliques[home].with_factors((j,)))  # the solved form not made again
        tree.cut(removed)  # a child holding no variable of D hangs under the nearest clique left, its f(S) kept
    else:  # step 3: re-eliminate the affected part with D first
        roots, (removed_top, orphans) = set(tree.roots), tree.remove_top(cids)  # the roots before
        removed = list(removed_top)
        kept = [j for c in removed_top.values() for j in c.factors if drop.isdisjoint(state.factors[j].keys)]
        linear = [state.cached(j) for j in kept] + schur + [tree.cliques[o].marginal for o in orphans]
        rest = [k for c in removed_top.values() for k in c.frontals if k not in drop]
        last = [k for c, cl in removed_top.items() if c in roots for k in cl.frontals if k not in drop]
        order_rest = min_degree_keys(rest, state.dims, [f.keys for f in linear], last, constrained)
        factor_ids = _add_marginal_factors(state, schur)  # the solver's ids, so each clique is labelled as it is made
        labels, n_own = kept + factor_ids + [None] * len(orphans), len(kept) + len(schur)
        cliques, parents, owner = eliminate(order_rest, linear, state.dims, labels)
        new_cids = tree.insert_eliminated(cliques, parents, orphans, owner[n_own:])
    state.drop_factors(dropped)  # (their ids are never given again)
    state.drop_variables(keys)
    if new_cids:
        backsubstitute(state, set(new_cids), alpha)
    return MarginalizationReport(
        tuple(order_drop), leaves, tuple(removed), tuple(new_cids),
        tuple(dropped), tuple(factor_ids), estimates, forgotten,
    )  # fmt: skip


def cuttable(tree: BayesTree, keys: Iterable[Key]) -> list[int]:
    """The whole subtrees among the cliques of ``keys`` (frontal only in them, as all below), parents first."""
    wanted = set(keys)
    inside = {tree.frontal_of[k] for k in wanted if k in tree.frontal_of}
    found = [c for c in inside if tree.parent[c] not in inside]  # the tops, then breadth first
    for c in found:
        found.extend(ch for ch in tree.children[c] if ch in inside)
    whole: dict[int, bool] = {}
    for c in reversed(found):  # children first
        whole[c] = wanted.issuperset(tree.cliques[c].frontals) and all(whole.get(h, 0) for h in tree.children[c])
    return [c for c in found if whole[c]]


def _add_marginal_factors(state: SolverState, schur: list[GaussianFactor]) -> list[int]:
    """Append each Schur factor as a :class:`MarginalFactor` frozen at θ̄, cached as it is; returns ids."""
    if any(not gf.keys for gf in schur):
        raise SteamError("a marginal factor with no variables")  # a root's f(∅) is never made one
    frozen = [MarginalFactor.frozen_at(gf, state.theta_bar, state.kinds) for gf in schur]
    return state.append_factors(frozen, list(schur))  # its linearization at θ̄ is itself [Eq. 10.4 at θ̄' = θ̄_S]
