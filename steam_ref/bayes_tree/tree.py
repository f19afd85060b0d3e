"""The numeric Bayes tree: cliques of Gaussian conditionals, elimination and back-substitution.

Eliminating the frontal variables F of a clique from the factors adjacent to them [YIB Eq. 24],

    f(F, S) ∝ exp(-½ ‖A_F δ_F + A_S δ_S - b‖²),

is one dense QR of the small gathered block [A_F A_S | b] = Q [[R, S, d], [0, A', b']]. The top
rows give the conditional P(F | S) ∝ exp(-½ ‖R δ_F + S δ_S - d‖²) (Eq. 25 for several variables at
once: R⁻¹S is the paper's rᵀ, R⁻¹d its d), and the rows below give the new factor on the
separator, f(S) ∝ exp(-½ ‖A' δ_S - b'‖²), which is passed to the parent clique and cached, so an
incremental update can reuse it when this clique's subtree is orphaned [K12 Sec. 4]. Stacking the
conditionals' rows in elimination order gives the upper-triangular R of A = QR, with RᵀR = AᵀA = 𝓘
[YIB Eq. 11, 21]. The solution is found from the root down: δ_F = R⁻¹(d - S δ_S). Covariances
from the tree are computed in :mod:`steam_ref.covariance`.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.linalg import lapack

from ..errors import SteamError, UnderdeterminedError
from ..linear.conditional import assemble_sqrt_information, gather, underdetermined
from ..linear.ordering import Ordering
from ..linear.system import GaussianFactor
from ..variables import Key, key_list
from .params import zero_fraction
from .symbolic import CliqueTree, build_cliques

__all__ = ["Clique", "BayesTree", "eliminate", "eliminate_clique", "factor_dims"]

RANK_TOLERANCE = 1e-12  # a pivot |Rᵢᵢ| below this times the largest |entry| means a free direction


@dataclass(frozen=True, eq=False)
class Clique:
    """P(F | S) ∝ exp(-½ ‖R δ_F + S δ_S - d‖²), and the factor on S its elimination left.  [YIB Eq. 25]"""

    frontals: tuple[Key, ...]  # F, eliminated here, in elimination order
    separator: tuple[Key, ...]  # S, shared with the parent clique, in elimination order
    frontal_dims: tuple[int, ...]  # size of each frontal variable
    separator_dims: tuple[int, ...]  # size of each separator variable
    R: NDArray  # (n_f, n_f) upper triangular
    S: NDArray  # (n_f, n_s)
    d: NDArray  # (n_f,)
    marginal: GaussianFactor  # f(S) = ‖A' δ_S - b'‖², A' (k, n_s) with k ≤ n_s  [YIB Eq. 24]
    factors: tuple[int, ...] = ()  # ids of the original (nonlinear) factors eliminated here

    def solve(self, separator_values: NDArray) -> NDArray:
        """δ_F = R⁻¹(d - S δ_S) for the stacked separator values (n_s,); returns (n_f,).  [YIB Eq. 25]"""
        rhs = self.d - self.S.dot(separator_values) if self.S.shape[1] else self.d  # .dot: @'s call costs more
        x, info = lapack.dtrtrs(self.R, rhs)
        if info != 0:
            raise SteamError(f"singular conditional in the clique of {self.frontals}")
        return x

    def split_frontals(self, x: NDArray) -> list[NDArray]:
        """A stacked frontal vector (n_f,) as one array per frontal variable."""
        out, o = [], 0
        for dim in self.frontal_dims:
            out.append(x[o : o + dim])
            o += dim
        return out


def factor_dims(factors: Sequence[GaussianFactor]) -> dict[Key, int]:
    """Size of each variable, read off the factors' blocks."""
    return {k: block.shape[1] for f in factors for k, block in zip(f.keys, f.blocks, strict=True)}


@functools.cache
def _below_diagonal(rows: int, cols: int) -> NDArray:
    """(rows, cols) bool, True below the diagonal (read-only: one per shape, shared)."""
    mask = np.tri(rows, cols, -1, dtype=bool)
    mask.flags.writeable = False
    return mask


def eliminate_clique(
    frontals: tuple[Key, ...],
    separator: tuple[Key, ...],
    dims: Mapping[Key, int],
    factors: Sequence[GaussianFactor],
    factor_ids: tuple[int, ...] = (),
) -> Clique:
    """Eliminate ``frontals`` from the adjacent ``factors`` by one dense QR.  [YIB Eq. 24-25]"""
    M = gather(frontals + separator, dims, factors)
    nf, ncol = sum(dims[k] for k in frontals), M.shape[1]
    free = M.shape[0] if M.shape[0] < nf else None  # fewer rows than frontal unknowns
    if free is None:
        qr, _, _, _ = lapack.dgeqrf(M)  # Q R = [A_F A_S | b]: Gram-Schmidt on the columns
        R = qr[: min(M.shape[0], ncol)]
        R[_below_diagonal(*R.shape)] = 0.0  # np.triu in place, its mask made once per shape
        small = np.abs(R.diagonal()[:nf]) <= RANK_TOLERANCE * max(np.abs(M).max(), 1.0)
        free = int(small.argmax()) if small.any() else None  # the first vanishing pivot
    if free is not None:  # a vanishing pivot: name the variable and why
        raise underdetermined(M, frontals, dims, free)
    ns = ncol - 1 - nf
    below = R[nf : nf + ns, nf:].copy()  # f(S): the rows left after eliminating F  [YIB Eq. 24]
    blocks, o = [], 0
    for k in separator:
        blocks.append(below[:, o : o + dims[k]])
        o += dims[k]
    marginal = GaussianFactor(separator, tuple(blocks), below[:, ns])
    return Clique(
        frontals,
        separator,
        tuple(dims[k] for k in frontals),
        tuple(dims[k] for k in separator),
        np.asfortranarray(R[:nf, :nf]),
        np.ascontiguousarray(R[:nf, nf : ncol - 1]),
        R[:nf, ncol - 1].copy(),
        marginal,
        tuple(factor_ids),
    )


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
    dims = factor_dims(factors) if dims is None else dims
    symbolic = build_cliques(order, [f.keys for f in factors], dims, amalgamation_zeros)
    incoming: list[list[GaussianFactor]] = [[] for _ in symbolic]  # marginal factors from children
    cliques, owner = [], [0] * len(factors)
    for i, sc in enumerate(symbolic):
        for j in sc.factors:
            owner[j] = i
        ids = () if factor_ids is None else tuple(i for i in (factor_ids[j] for j in sc.factors) if i is not None)
        gathered = [factors[j] for j in sc.factors] + incoming[i]
        clique = eliminate_clique(sc.frontals, sc.separator, dims, gathered, ids)
        if sc.parent is not None:
            incoming[sc.parent].append(clique.marginal)
        cliques.append(clique)
    return cliques, [sc.parent for sc in symbolic], owner


class BayesTree(CliqueTree[Clique]):
    """A Bayes tree of Gaussian conditionals.  [YIB Sec. III-A, K11]"""

    @classmethod
    def from_factors(
        cls, factors: Sequence[GaussianFactor], ordering: Ordering | Sequence[Key], amalgamation_zeros: float = 0.0
    ) -> BayesTree:
        """Eliminate linear factors in the given order (an Ordering or a list of keys) into a new tree, its cliques
        merged up to ``amalgamation_zeros`` (:class:`~.params.ISAM2Params`)."""
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
        zeros = zero_fraction(amalgamation_zeros)
        tree = cls()
        cliques, parents, _ = eliminate(order, factors, amalgamation_zeros=zeros)
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
