"""Partial back-substitution, [K12 Alg. 7]: solve only where the solution changes.  [YIB Eq. 25, step 6]

[K12 Alg. 7], as :func:`backsubstitute` runs it:

1. Start at the roots of the re-eliminated top of the tree; its cliques are always solved.
2. For the current clique, compute the frontal variables from the separator's current solution,
   δ_F = R⁻¹(d - S δ_S) [YIB Eq. 25], as g - G δ_S: ``Clique.solved`` keeps g = R⁻¹d and G = R⁻¹S (the paper's rᵀ).
3. Enter each child whose separator holds a variable that changed by at least the wildfire threshold α, here or
   in an ascendant (α = 0: every child; a re-made clique in any case); skip the others, and so their subtrees.
   (A leaf has no children to decide on: its variables' changes are not measured.)

Changes are judged per variable (the newest state moving must not mark the landmarks of its clique changed).
Each new δ is checked against its variable's threshold β here, where every δ is solved (a relinearization moves δ
into θ̄ and clears the candidates): the candidates of the next fluid relinearization [K12 Alg. 5; YIB Alg. 1 step 7].
Both tests take max abs(·) of a variable's 2 to 18 numbers (and its change) in Python floats, at half NumPy's cost
(equal when finite). (A level-at-a-time variant in stacked NumPy calls was removed, slower: docs/experiments.md.)
"""

from __future__ import annotations

from collections.abc import Collection
from operator import sub

import numpy as np

from ..variables import Key
from .state import SolverState

__all__ = ["backsubstitute"]


def backsubstitute(state: SolverState, new_cliques: Collection[int], alpha: float) -> tuple[list[Key], int]:
    """δ_F = R⁻¹(d - S δ_S) from the roots of the new part down, a clique at a time, while it changes.  [K12 Alg. 7]

    Writes each solved variable's new δ into ``state`` (a new array), marks its estimate stale and keeps
    its relinearization candidacy [K12 Alg. 5]. Returns the updated variables, depth first, and the number of
    cliques solved.
    """
    tree, delta, beta, stale, candidates = state.tree, state.delta, state.beta, state.stale, state.candidates
    record = state.log.old_values(delta).append  # each δ it replaces, for the transaction's undo
    changed: set[Key] = set()
    updated: list[Key] = []
    cliques, children = tree.cliques, tree.children
    stack = [c for c in new_cliques if tree.parent[c] is None]
    visited = 0
    while stack:
        c = stack.pop()
        clique = cliques[c]
        visited += 1
        on, frontals, kids = clique.separator, clique.frontals, children[c]
        sep = delta[on[0]] if len(on) == 1 else np.concatenate([delta[k] for k in on] or [np.zeros(0)])  # a root: none
        x = clique.solve(sep)  # [YIB Eq. 25]
        watch = alpha != 0 and kids  # step 3's test decides only which children to enter: a leaf needs none
        parts = ((frontals[0], x),) if len(frontals) == 1 else zip(frontals, clique.split_frontals(x), strict=True)
        for k, xk in parts:  # the usual clique: one frontal, the whole x
            old, new = delta[k], xk.tolist()
            if watch and max(map(abs, map(sub, new, old.tolist()))) >= alpha:  # step 3: changed by at least α
                changed.add(k)
            record((k, old))
            delta[k] = xk
            stale[k] = None  # never undone: an extra mark only forms the same estimate again
            if max(map(abs, new)) >= beta[k]:  # a candidate for the next relinearization [K12 Alg. 5]
                candidates[k] = None  # the transaction keeps the candidates whole: no record needed
            elif k in candidates:
                del candidates[k]
        updated.extend(frontals)
        for ch in kids:
            if ch in new_cliques or alpha == 0 or not changed.isdisjoint(cliques[ch].separator):
                stack.append(ch)
    return updated, visited
