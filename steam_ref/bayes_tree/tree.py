"""The numeric Bayes tree: multifrontal elimination into cliques, and back-substitution.

Each clique is a Gaussian conditional P(F | S) ∝ exp(-½ ‖R δ_F + S δ_S - d‖²), eliminated from the factors adjacent
to its frontal variables by one dense QR (:func:`~steam_ref.linear.conditional.eliminate_clique`, [YIB Eq. 24-25]),
which also leaves the factor f(S) on its separator: it is passed to the parent clique and cached, so an incremental
update can reuse it when this clique's subtree is orphaned [K12 Sec. 4]. Stacking the conditionals' rows in
elimination order gives the upper-triangular R of A = QR, with RᵀR = AᵀA = 𝓘 [YIB Eq. 11, 21]. The solution is
found from the root down: δ_F = R⁻¹(d - S δ_S). Covariances from the tree are computed in :mod:`steam_ref.covariance`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from ..errors import SteamError, UnderdeterminedError
from ..linear.conditional import Clique, assemble_sqrt_information, eliminate_clique
from ..linear.ordering import Ordering
from ..linear.system import GaussianFactor
from ..variables import Key, key_list
from .symbolic import CliqueTree, build_cliques

__all__ = ["Clique", "BayesTree", "eliminate", "eliminate_clique"]


def eliminate(
    order: Sequence[Key],
    factors: Sequence[GaussianFactor],
    dims: Mapping[Key, int] | None = None,
    factor_ids: Sequence[int | None] | None = None,
    amalgamation_zeros: float = 0.0,
) -> tuple[list[Clique], list[int | None], list[int]]:
    """Multifrontal elimination of linear factors in ``order``.  [YIB Eq. 24-25, K12 Alg. 1-2]

    Returns ``(cliques, parents, owner)``: the cliques children first, each one's parent index
    (None for a root), and for each input factor the index of the clique that eliminated it.
    ``factor_ids`` (None entries for cached marginal factors) label the factors stored in each
    clique's ``factors``. ``amalgamation_zeros`` > 0 merges cliques (:func:`~.symbolic.build_cliques`).
    """
    if dims is None:  # each variable's size, read off the factors' blocks
        dims = {k: block.shape[1] for f in factors for k, block in zip(f.keys, f.blocks, strict=True)}
    symbolic = build_cliques(order, [f.keys for f in factors], dims, amalgamation_zeros)
    incoming: list[list[GaussianFactor]] = [[] for _ in symbolic]  # marginal factors from children
    cliques, owner = [], [0] * len(factors)
    for i, sc in enumerate(symbolic):
        for j in sc.factors:
            owner[j] = i
        ids = () if factor_ids is None else tuple([f for f in map(factor_ids.__getitem__, sc.factors) if f is not None])
        clique = eliminate_clique(sc.frontals, sc.separator, dims, [factors[j] for j in sc.factors] + incoming[i], ids)
        if sc.parent is not None:
            incoming[sc.parent].append(clique.marginal)
        cliques.append(clique)
    return cliques, [sc.parent for sc in symbolic], owner


class BayesTree(CliqueTree[Clique]):
    """A Bayes tree of Gaussian conditionals.  [YIB Sec. III-A, K11]"""

    @classmethod
    def from_factors(cls, factors: Sequence[GaussianFactor], ordering: Ordering | Sequence[Key]) -> BayesTree:
        """Eliminate linear factors in the given order (an Ordering or a list of keys) into a new tree."""
        order = ordering.keys if isinstance(ordering, Ordering) else tuple(key_list("ordering", ordering))
        factors = list(factors)
        for i, f in enumerate(factors):
            if not isinstance(f, GaussianFactor):
                raise SteamError(
                    f"factors[{i}] is a {type(f).__name__}, not a GaussianFactor (linearize a factor first)"
                )
        named = {k for f in factors for k in f.keys}
        free = next((k for k in order if k not in named), None)
        if free is not None:
            raise UnderdeterminedError(
                f"variable {free!r} of the ordering is named by no factor, so nothing constrains it"
            )
        tree = cls()
        cliques, parents, _ = eliminate(order, factors)
        tree.insert_eliminated(cliques, parents)
        return tree

    def dims(self) -> dict[Key, int]:
        """Size of every variable (visits the whole tree)."""
        return {k: d for c in self.cliques.values() for k, d in zip(c.frontals, c.frontal_dims, strict=True)}

    def solve(self) -> dict[Key, NDArray]:
        """Full back-substitution from the roots: δ for every variable.  [YIB Sec. III-A]"""
        delta: dict[Key, NDArray] = {}
        stack = list(self.roots)
        while stack:
            c = stack.pop()
            clique = self.cliques[c]
            sep = np.concatenate([delta[k] for k in clique.separator]) if clique.separator else np.zeros(0)
            for k, x in zip(clique.frontals, clique.split_frontals(clique.solve(sep)), strict=True):
                delta[k] = x
            stack.extend(self.children[c])
        return delta

    def to_sparse(self) -> tuple[sp.csr_matrix, NDArray, Ordering]:
        """The assembled square-root information matrix: ``(R, d, ordering)``, R sparse.

        R (n, n) is upper triangular in ``ordering`` (cliques in postorder, frontals in order);
        RᵀR equals AᵀA = 𝓘 with rows and columns in that order, and R δ = d gives the solution.
        """
        order = self.elimination_order()
        dims = self.dims()
        ordering = Ordering(tuple(order), tuple(dims[k] for k in order))
        R, d = assemble_sqrt_information(ordering, list(self.cliques.values())), np.zeros(ordering.total_dim)
        for clique in self.cliques.values():
            r0 = ordering.offset_of[clique.frontals[0]]
            d[r0 : r0 + clique.R.shape[0]] = clique.d
        return R, d, ordering

    def to_dense(self) -> tuple[NDArray, NDArray, Ordering]:
        """:meth:`to_sparse` with R as a dense (n, n) array (for tests and figures of small trees)."""
        R, d, ordering = self.to_sparse()
        return R.toarray(), d, ordering
