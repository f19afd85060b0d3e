"""Partial back-substitution, two ways: a clique at a time, and in batches.  [K12 Alg. 7, YIB Eq. 25]

:func:`backsubstitute` states the algorithm a clique at a time: solve δ_F = R⁻¹(d - S δ_S), mark the
frontals whose δ moved by at least the wildfire threshold α, descend into the children whose separator
holds a marked variable. It is what :class:`~steam_ref.bayes_tree.IncrementalSolver` runs by default
(``ISAM2Params(backsubstitution="loop")``). On the paper's runs it visits hundreds of 6x6 conditionals
per update, and each visit costs a dozen NumPy calls of interpreter overhead for a few hundred flops.

:class:`BatchedBacksubstitution` does the same descent a tree level at a time. A visited clique's
ancestors are all visited (a clique is entered only from its parent), so the separator values a
level needs were all computed by the levels above it, in this same call. Every variable has a
fixed place in one flat workspace; each clique keeps, once, its conditional in solved form
G = R⁻¹S, g = R⁻¹d (so δ_F = g - G δ_S) flattened, with the workspace positions of its rows and
of its separator's entries; g rides along as the coefficient of a workspace entry fixed at 1, so
a row of the conditional is one dot product. A level is then a handful of stacked calls whatever
its cliques' shapes: gather the separator values, multiply, sum each row (``np.add.reduceat``);
the wildfire test abs(δ_new - δ_old) ≥ α is one stacked comparison per level, reduced per variable;
the relinearization test max abs(δ) ≥ β one per call. Only the choice of children to enter stays a
set test per child in Python, as in the loop (cheaper than any NumPy call at these sizes).

A level narrower than ``STACK_FROM`` is solved a clique at a time from the same solved form
(δ_F = [g | -G] [1; δ_S], two calls), where stacking would cost more calls than it saves.

The visited cliques, the variables marked and the candidates for relinearization are those of
the loop, in the loop's order; δ agrees with it to rounding (R⁻¹d - (R⁻¹S)δ_S against R⁻¹(d - Sδ_S)).

What it is worth: a level can only be solved once the one above it is, and the paper's trees are
narrow: on Plaza an update descends ~57 levels of ~6 cliques (~390 cliques), on paper-synthetic
~63 cliques. Each level still costs a dozen NumPy calls plus the Python that gathers it, so on
those runs this is no faster than the loop (0.75-1.0x, docs/experiments.md) and the loop stays the
default. It pays where levels are wide (bushy trees, many landmarks at the top).
"""

from __future__ import annotations

from collections.abc import Collection
from itertools import compress
from typing import NamedTuple, cast

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import lapack

from ..errors import SteamError
from ..variables import Key
from .tree import BayesTree, Clique

__all__ = ["backsubstitute", "BatchedBacksubstitution"]

_INT = np.intp
STACK_FROM = 4  # a level of this many cliques or more is solved in stacked calls, a narrower one clique by clique


class _Solved(NamedTuple):
    """One clique's conditional in solved form, laid out for stacking (indices into the workspace)."""

    clique: Clique  # the clique this was made from (a re-made clique gets a new entry)
    data: NDArray  # (n_f * (1 + n_s),) row by row: g_i, then -(R⁻¹S)_i
    columns: NDArray  # (n_f * (1 + n_s),) workspace position each entry multiplies (0: the constant 1)
    row_lengths: NDArray  # (n_f,) 1 + n_s for every row
    rows: NDArray  # (n_f,) workspace positions of the frontal entries
    matrix: NDArray  # (n_f, 1 + n_s) the same data as a matrix [g | -G], for a clique solved alone
    inputs: NDArray  # (1 + n_s,) the workspace positions it multiplies
    single: bool  # one frontal variable


def backsubstitute(
    tree: BayesTree,
    new_cliques: Collection[int],
    delta: dict[Key, NDArray],
    alpha: float,
    beta: dict[Key, float],
    stale: dict[Key, None],
    over: dict[Key, None],
) -> tuple[list[Key], int]:
    """δ_F = R⁻¹(d - S δ_S) from the roots of the new part down, a clique at a time, while it changes.  [K12 Alg. 7]

    A re-made clique (one of ``new_cliques``) is always solved; an old one only when a variable of its
    separator changed by at least the wildfire threshold α (with α = 0, always: full back-substitution).
    Changes are judged per variable: a root clique holding the newest state and the landmarks must not
    mark the landmarks changed because the newest state moved. Writes each solved variable's new δ into
    ``delta`` (a new array) and marks it in ``stale``; a variable whose new δ has max abs(δ) ≥ its
    relinearization threshold β (``beta``) joins ``over``, the candidates for the next relinearization
    [K12 Alg. 5], and leaves it otherwise. Returns the updated variables, depth first, and the number of
    cliques solved.
    """
    changed: set[Key] = set()
    updated: list[Key] = []
    stack = [c for c in new_cliques if tree.parent[c] is None]
    visited = 0
    while stack:
        c = stack.pop()
        clique = tree.cliques[c]
        visited += 1
        sep = np.concatenate([delta[k] for k in clique.separator]) if clique.separator else np.zeros(0)
        x = clique.solve(sep)  # [YIB Eq. 25]
        frontals = clique.frontals
        for k, xk in zip(frontals, (x,) if len(frontals) == 1 else clique.split_frontals(x), strict=True):
            if alpha == 0 or abs(xk - delta[k]).max() >= alpha:
                changed.add(k)
            delta[k] = xk
            stale[k] = None
            if abs(xk).max() >= beta[k]:  # a candidate for the next relinearization [K12 Alg. 5]
                over[k] = None
            elif k in over:
                del over[k]
        updated.extend(frontals)
        for ch in tree.children[c]:
            if ch in new_cliques or not changed.isdisjoint(tree.cliques[ch].separator):
                stack.append(ch)
    return updated, visited


class BatchedBacksubstitution:
    """[K12 Alg. 7] a tree level at a time with stacked NumPy calls (module docstring).

    One instance serves one solver: it remembers each variable's place in its workspace and each
    clique's solved form (dropped by :meth:`forget` when the clique leaves the tree).
    """

    def __init__(self) -> None:
        self._start: dict[Key, int] = {}  # variable → its first workspace position
        self._size = 1  # workspace entries in use; entry 0 is the constant 1
        self._work = np.ones(64)  # the new δ of the variables solved in the current call, by position
        self._solved: dict[int, _Solved] = {}  # clique id → its solved form
        self._lengths: dict[tuple[int, int], NDArray] = {}  # (n_f, n_s) → row lengths, shared

    def forget(self, clique_ids: Collection[int]) -> None:
        """Drop the solved forms of cliques that left the tree."""
        for c in clique_ids:
            self._solved.pop(c, None)

    def _positions(self, keys: tuple[Key, ...], dims: tuple[int, ...]) -> list[int]:
        """Workspace positions of the entries of ``keys``, giving a variable room on first sight."""
        out: list[int] = []
        for k, d in zip(keys, dims, strict=True):
            a = self._start.get(k)
            if a is None:
                a = self._start[k] = self._size
                self._size += d
                if self._size > len(self._work):
                    self._work = np.concatenate([self._work, np.zeros(max(self._size, len(self._work)))])
            out.extend(range(a, a + d))
        return out

    def _solved_form(self, cid: int, clique: Clique, solved: NDArray | None = None) -> _Solved:
        """[g | -G] with g = R⁻¹d, G = R⁻¹S (``solved`` when already computed), and the clique's workspace
        positions (once per clique).  [YIB Eq. 25]"""
        nf, ns = clique.R.shape[0], clique.S.shape[1]
        if solved is None:
            solved, info = lapack.dtrtrs(clique.R, np.column_stack([clique.d, -clique.S]))
            if info != 0:
                raise SteamError(f"singular conditional in the clique of {clique.frontals}")
        inputs = np.asarray([0, *self._positions(clique.separator, clique.separator_dims)], dtype=np.intp)
        lengths = self._lengths.get((nf, ns))
        if lengths is None:
            lengths = self._lengths[nf, ns] = np.full(nf, ns + 1, dtype=np.intp)
        entry = _Solved(
            clique,
            solved.ravel(),
            np.broadcast_to(inputs, (nf, ns + 1)).ravel(),
            lengths,
            np.asarray(self._positions(clique.frontals, clique.frontal_dims), dtype=np.intp),
            solved,
            inputs,
            len(clique.frontals) == 1,
        )
        self._solved[cid] = entry
        return entry

    def __call__(
        self,
        tree: BayesTree,
        new_cliques: Collection[int],
        delta: dict[Key, NDArray],
        alpha: float,
        beta: dict[Key, float],
        stale: dict[Key, None],
        over: dict[Key, None],
    ) -> tuple[list[Key], int]:
        """δ_F = g - G δ_S from the roots of the new part down, a level at a time.  [K12 Alg. 7]

        Same contract as the loop: writes ``delta`` (new arrays) and marks ``stale``; keeps ``over``
        (max abs(δ) ≥ β, the candidates of the next relinearization) in the loop's order; returns the
        updated variables in the loop's (depth-first) order and the number of cliques solved.
        """
        roots = [c for c in new_cliques if tree.parent[c] is None]
        children, cliques, solved = tree.children, tree.cliques, self._solved
        changed: set[Key] = set()  # variables whose δ moved by ≥ α in this call
        entered = set(roots)
        level = roots
        while level:
            ents = []
            for c in level:
                e = solved.get(c)
                ents.append(e if e is not None and e.clique is cliques[c] else self._solved_form(c, cliques[c]))
            if len(ents) < STACK_FROM and all(e.single for e in ents):  # narrow: a clique at a time is fewer calls
                keys = [e.clique.frontals[0] for e in ents]
                moved = [self._solve_alone(e, k, delta, alpha) for e, k in zip(ents, keys, strict=True)]
            else:
                keys, moved = self._solve_stacked(ents, delta, alpha)
            changed.update(keys if alpha == 0 else compress(keys, moved))
            level = [
                ch
                for c in level
                for ch in children[c]
                if ch in new_cliques or not changed.isdisjoint(cliques[ch].separator)
            ]
            entered.update(level)
        # The loop's depth-first order, so that ``over`` (hence the next θ_rl and ordering) and the
        # updated list come out as the loop's.
        updated: list[Key] = []
        stack = roots
        while stack:
            c = stack.pop()
            updated.extend(cliques[c].frontals)
            stack.extend(ch for ch in children[c] if ch in entered)
        self._relinearization_candidates(updated, delta, beta, over)
        stale.update(dict.fromkeys(updated))
        return updated, len(entered)

    def _solve_alone(self, e: _Solved, k: Key, delta: dict[Key, NDArray], alpha: float) -> bool:
        """One clique of a single frontal variable ``k``: δ_k = [g | -G] [1; δ_S]; whether it moved by ≥ α."""
        x = e.matrix @ self._work[e.inputs]  # [YIB Eq. 25]
        self._work[e.rows] = x
        moved = bool((np.abs(x - delta[k]) >= alpha).any())
        delta[k] = x
        return moved

    def _solve_stacked(
        self, ents: list[_Solved], delta: dict[Key, NDArray], alpha: float
    ) -> tuple[list[Key], list[bool]]:
        """A level in stacked calls: (its frontal variables, whether each moved by ≥ α)."""
        lengths = np.concatenate([e.row_lengths for e in ents])
        products = np.concatenate([e.data for e in ents]) * self._work[np.concatenate([e.columns for e in ents])]
        x = np.add.reduceat(products, np.cumsum(lengths) - lengths)  # [YIB Eq. 25]
        self._work[np.concatenate([e.rows for e in ents])] = x
        keys = [k for e in ents for k in e.clique.frontals]
        dims = [d for e in ents for d in e.clique.frontal_dims]
        moved = self._per_variable(np.abs(x - np.concatenate([delta[k] for k in keys])) >= alpha, dims)
        if len(set(dims)) == 1:  # the common case: rows of a (variables, size) array are their δ
            delta.update(zip(keys, x.reshape(len(keys), dims[0]), strict=True))
        else:
            starts = (np.cumsum(dims) - np.asarray(dims)).tolist()
            delta.update((k, x[a : a + d]) for k, a, d in zip(keys, starts, dims, strict=True))
        return keys, moved

    @staticmethod
    def _per_variable(flags: NDArray, dims: list[int]) -> list[bool]:
        """Any of each variable's entries set (entries stacked variable after variable)."""
        if len(set(dims)) == 1:
            return cast(list[bool], flags.reshape(len(dims), dims[0]).any(axis=1).tolist())
        starts = np.cumsum(dims) - np.asarray(dims)
        return cast(list[bool], np.logical_or.reduceat(flags, starts).tolist())

    def _relinearization_candidates(
        self, updated: list[Key], delta: dict[Key, NDArray], beta: dict[Key, float], over: dict[Key, None]
    ) -> None:
        """``over`` holds the updated variables whose max abs(δ) ≥ β, in the loop's order.  [K12 Alg. 5]"""
        if not updated:
            return
        dims = [len(delta[k]) for k in updated]
        limits = np.repeat([beta[k] for k in updated], dims)
        large = self._per_variable(np.abs(np.concatenate([delta[k] for k in updated])) >= limits, dims)
        for k, big in zip(updated, large, strict=True):
            if big:
                over[k] = None
            elif k in over:
                del over[k]
