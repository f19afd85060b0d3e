"""The numeric Bayes tree: cliques of Gaussian conditionals, elimination and back-substitution.

Eliminating the frontal variables F of a clique from the factors adjacent to them [YIB Eq. 24],

    f(F, S) ∝ exp(-½ ‖A_F δ_F + A_S δ_S - b‖²),

is one dense QR of the small gathered block [A_F A_S | b] = Q [[R, S, d], [0, A', b']]. The top
rows give the conditional P(F | S) ∝ exp(-½ ‖R δ_F + S δ_S - d‖²) (Eq. 25 for several variables at
once: R⁻¹S is the paper's rᵀ, R⁻¹d its d), and the rows below give the new factor on the
separator, f(S) ∝ exp(-½ ‖A' δ_S - b'‖²), which is passed to the parent clique and cached, so an
incremental update can reuse it when this clique's subtree is orphaned [K12 Sec. 4]. Stacking the
conditionals' rows in elimination order gives the upper-triangular R of A = QR, with RᵀR = AᵀA = 𝓘
[YIB Eq. 11, 21]. The solution is found from the root down: δ_F = R⁻¹(d - S δ_S).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray
from scipy.linalg import lapack

from ..errors import SteamError, UnderdeterminedError
from ..variables import Key
from ..linear.ordering import Ordering
from ..linear.system import GaussianFactor
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
        rhs = self.d - self.S @ separator_values if self.S.shape[1] else self.d
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
    dims: dict[Key, int] = {}
    for f in factors:
        for k, block in zip(f.keys, f.blocks):
            dims[k] = block.shape[1]
    return dims


def _gather(keys: tuple[Key, ...], dims: Mapping[Key, int], factors: Sequence[GaussianFactor]) -> NDArray:
    """The dense block [A_F A_S | b] of the factors adjacent to a clique: (rows, n + 1).  [YIB Eq. 24]"""
    offset, n = {}, 0
    for k in keys:
        offset[k] = n
        n += dims[k]
    rows = sum(f.rhs.shape[0] for f in factors)
    M = np.zeros((rows, n + 1), order="F")
    r = 0
    for f in factors:
        end = r + f.rhs.shape[0]
        for k, block in zip(f.keys, f.blocks):  # a factor names each variable once
            o = offset[k]
            M[r:end, o : o + block.shape[1]] = block
        M[r:end, n] = f.rhs
        r = end
    return M


def eliminate_clique(
    frontals: tuple[Key, ...],
    separator: tuple[Key, ...],
    dims: Mapping[Key, int],
    factors: Sequence[GaussianFactor],
    factor_ids: tuple[int, ...] = (),
) -> Clique:
    """Eliminate ``frontals`` from the adjacent ``factors`` by one dense QR.  [YIB Eq. 24-25]"""
    M = _gather(frontals + separator, dims, factors)
    nf, ncol = sum(dims[k] for k in frontals), M.shape[1]
    free = M.shape[0] if M.shape[0] < nf else None  # fewer rows than frontal unknowns
    if free is None:
        qr, _, _, _ = lapack.dgeqrf(M)  # Q R = [A_F A_S | b]: Gram-Schmidt on the columns
        R = np.triu(qr[: min(M.shape[0], ncol)])
        small = np.flatnonzero(np.abs(np.diagonal(R[:nf, :nf])) <= RANK_TOLERANCE * max(np.abs(M).max(), 1.0))
        free = int(small[0]) if len(small) else None
    if free is not None:
        bad = _free_variable(M, frontals, dims, free)
        raise UnderdeterminedError(f"variable {bad!r} is not constrained by the factors (pivot {free} of its clique vanishes)")
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


def _free_variable(M: NDArray, frontals: tuple[Key, ...], dims: Mapping[Key, int], col: int) -> Key:
    """Name a frontal variable left free: one whose own columns have rank below its size, else the pivot's."""
    o, at_pivot = 0, frontals[-1]
    for k in frontals:
        block = M[:, o : o + dims[k]]
        if np.linalg.matrix_rank(block) < dims[k]:
            return k
        if o <= col < o + dims[k]:
            at_pivot = k
        o += dims[k]
    return at_pivot


def eliminate(
    order: Sequence[Key],
    factors: Sequence[GaussianFactor],
    dims: Mapping[Key, int] | None = None,
    factor_ids: Sequence[int | None] | None = None,
) -> tuple[list[Clique], list[int | None], list[int]]:
    """Multifrontal elimination of linear factors in ``order``.  [YIB Eq. 24-25, K12 Alg. 1-2]

    Returns ``(cliques, parents, owner)``: the cliques children first, each one's parent index
    (None for a root), and for each input factor the index of the clique that eliminated it.
    ``factor_ids`` (None entries for cached marginal factors) label the factors stored in each
    clique's ``factors``.
    """
    dims = factor_dims(factors) if dims is None else dims
    symbolic = build_cliques(order, [f.keys for f in factors])
    incoming: list[list[GaussianFactor]] = [[] for _ in symbolic]  # marginal factors from children
    cliques, owner = [], [0] * len(factors)
    for i, sc in enumerate(symbolic):
        for j in sc.factors:
            owner[j] = i
        ids = () if factor_ids is None else tuple(factor_ids[j] for j in sc.factors if factor_ids[j] is not None)
        gathered = [factors[j] for j in sc.factors] + incoming[i]
        clique = eliminate_clique(sc.frontals, sc.separator, dims, gathered, ids)
        if sc.parent is not None:
            incoming[sc.parent].append(clique.marginal)
        cliques.append(clique)
    return cliques, [sc.parent for sc in symbolic], owner


class BayesTree(CliqueTree[Clique]):
    """A Bayes tree of Gaussian conditionals.  [YIB Sec. III-A, K11]"""

    @classmethod
    def from_factors(cls, factors: Sequence[GaussianFactor], ordering: Ordering | Sequence[Key]) -> BayesTree:
        """Eliminate linear factors in the given order into a new tree."""
        order = ordering.keys if isinstance(ordering, Ordering) else tuple(ordering)
        tree = cls()
        cliques, parents, _ = eliminate(order, factors)
        tree.insert_eliminated(cliques, parents)
        return tree

    def dims(self) -> dict[Key, int]:
        """Size of every variable (visits the whole tree)."""
        return {k: d for c in self.cliques.values() for k, d in zip(c.frontals, c.frontal_dims)}

    def solve(self) -> dict[Key, NDArray]:
        """Full back-substitution from the roots: δ for every variable.  [YIB Sec. III-A]"""
        delta: dict[Key, NDArray] = {}
        stack = list(self.roots)
        while stack:
            c = stack.pop()
            clique = self.cliques[c]
            sep = np.concatenate([delta[k] for k in clique.separator]) if clique.separator else np.zeros(0)
            for k, x in zip(clique.frontals, clique.split_frontals(clique.solve(sep))):
                delta[k] = x
            stack.extend(self.children[c])
        return delta

    def to_dense(self) -> tuple[NDArray, NDArray, Ordering]:
        """The assembled square-root information matrix: ``(R, d, ordering)``.

        R (n, n) is upper triangular in ``ordering`` (cliques in postorder, frontals in order);
        RᵀR equals AᵀA = 𝓘 with rows and columns in that order, and R δ = d gives the solution.
        """
        order = self.elimination_order()
        dims = self.dims()
        ordering = Ordering(tuple(order), tuple(dims[k] for k in order))
        R, d = self._assemble(ordering, list(self.cliques.values())), np.zeros(ordering.total_dim)
        for clique in self.cliques.values():
            r0 = ordering.offset_of[clique.frontals[0]]
            d[r0 : r0 + clique.R.shape[0]] = clique.d
        return R, d, ordering

    def joint_marginal_covariance(self, keys: Sequence[Key]) -> NDArray:
        """Joint covariance of several variables, stacked in the order given: (Σdₖ, Σdₖ).

        When one clique holds them all, its joint covariance from the root walk is used.
        Otherwise: the cliques on the paths from the variables to the root are closed under
        taking parents, so their conditionals alone are the joint density of their variables
        [K11 Sec. 3], and the covariance is (R_Uᵀ R_U)⁻¹ restricted to ``keys``, found by two sparse
        triangular solves.
        """
        keys = list(keys)
        for k in keys:
            clique = self.cliques[self.clique_containing(k)]
            if set(keys) <= set(clique.frontals) | set(clique.separator):
                joint, index = self._path_covariance(self.frontal_of[k])
                idx = np.concatenate([np.arange(index[j][0], index[j][0] + index[j][1]) for j in keys])
                block = joint[np.ix_(idx, idx)]
                return 0.5 * (block + block.T)
        return self._upper_closed_covariance(keys)

    def _path_covariance(self, cid: int) -> tuple[NDArray, dict[Key, tuple[int, int]]]:
        """Joint covariance of clique ``cid``'s variables (F then S), walking from the root."""
        joint, index = np.zeros((0, 0)), {}
        for c in self.path_to_root(cid)[::-1]:
            joint, index = _clique_covariance(self.cliques[c], joint, index)
        return joint, index

    def _upper_closed_covariance(self, keys: list[Key]) -> NDArray:
        """Cov of ``keys`` from R_U of the cliques on their root paths (sparse solves)."""
        depth: dict[int, int] = {}
        for k in keys:
            path = self.path_to_root(self.clique_containing(k))
            for i, c in enumerate(path):
                depth[c] = len(path) - 1 - i
        cids = sorted(depth, key=lambda c: -depth[c])  # children before parents
        order = [v for c in cids for v in self.cliques[c].frontals]
        dims = {v: d for c in cids for v, d in zip(self.cliques[c].frontals, self.cliques[c].frontal_dims)}
        ordering = Ordering(tuple(order), tuple(dims[v] for v in order))
        R = self._assemble(ordering, [self.cliques[c] for c in cids])
        cols = np.concatenate([np.arange(ordering.offset_of[k], ordering.offset_of[k] + dims[k]) for k in keys])
        E = np.zeros((ordering.total_dim, len(cols)))
        E[cols, np.arange(len(cols))] = 1.0
        Rs = sp.csr_matrix(R)
        Y = spla.spsolve_triangular(Rs.T.tocsr(), E, lower=True)  # Rᵀ Y = E
        X = spla.spsolve_triangular(Rs, Y, lower=False)  # R X = Y: X = (RᵀR)⁻¹ E
        block = X[cols]
        return 0.5 * (block + block.T)

    @staticmethod
    def _assemble(ordering: Ordering, cliques: Sequence[Clique]) -> NDArray:
        """Dense upper-triangular R of the given cliques, rows and columns in ``ordering``."""
        n = ordering.total_dim
        R = np.zeros((n, n))
        for clique in cliques:
            r0 = ordering.offset_of[clique.frontals[0]]
            nf = clique.R.shape[0]
            R[r0 : r0 + nf, r0 : r0 + nf] = clique.R
            o = 0
            for k, dim in zip(clique.separator, clique.separator_dims):
                c0 = ordering.offset_of[k]
                R[r0 : r0 + nf, c0 : c0 + dim] = clique.S[:, o : o + dim]
                o += dim
        return R

    def marginal_covariance(self, key: Key) -> NDArray:
        """Cov(δθ_key) = (𝓘⁻¹)_key,key from the tree, walking down from the root.  [K11 Sec. 3]

        Each clique gives P(F | S); with Σ_SS from the parent's joint covariance,
        Cov(F, S) = -R⁻¹S Σ_SS and Cov(F, F) = R⁻¹R⁻ᵀ + R⁻¹S Σ_SS (R⁻¹S)ᵀ. Costs one small dense
        step per clique on the path from the root to the variable's clique.
        """
        joint, index = self._path_covariance(self.clique_containing(key))
        o, dim = index[key]
        block = joint[o : o + dim, o : o + dim]
        return 0.5 * (block + block.T)


def _clique_covariance(
    clique: Clique, parent_joint: NDArray, parent_index: dict[Key, tuple[int, int]]
) -> tuple[NDArray, dict[Key, tuple[int, int]]]:
    """Joint covariance of the clique's variables (F then S) from its parent's.  [K11 Sec. 3]"""
    sel = np.concatenate([np.arange(o, o + dim) for o, dim in (parent_index[k] for k in clique.separator)]) if clique.separator else np.zeros(0, int)
    Sigma_SS = parent_joint[np.ix_(sel, sel)]
    nf = clique.R.shape[0]
    Rinv = lapack.dtrtrs(clique.R, np.eye(nf))[0]  # R⁻¹ by triangular solves
    RinvS = Rinv @ clique.S
    cov_FS = -RinvS @ Sigma_SS
    cov_FF = Rinv @ Rinv.T - cov_FS @ RinvS.T
    joint = np.block([[cov_FF, cov_FS], [cov_FS.T, Sigma_SS]])
    index, o = {}, 0
    for k, dim in zip(clique.frontals + clique.separator, clique.frontal_dims + clique.separator_dims):
        index[k] = (o, dim)
        o += dim
    return joint, index
