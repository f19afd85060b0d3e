"""Gaussian conditionals P(F | S) ∝ exp(-½ ‖R δ_F + S δ_S - d‖²): a clique's elimination, and the
conditionals stacked into one square-root information matrix R, with RᵀR = AᵀA = 𝓘.  [YIB Eq. 11, 21, 24-25]

Eliminating the frontal variables F of a clique from the factors adjacent to them [YIB Eq. 24],

    f(F, S) ∝ exp(-½ ‖A_F δ_F + A_S δ_S - b‖²),

is one dense QR of the small gathered block (:func:`gather`) [A_F A_S | b] = Q [[R, S, d], [0, A', b']]
(:func:`eliminate_clique`). The top rows give the conditional P(F | S) (Eq. 25 for several variables at once: R⁻¹S
is the paper's rᵀ, R⁻¹d its d: ``Clique.solved`` keeps both, so that solving is one product), the rows below the
new factor on the separator, f(S) ∝ exp(-½ ‖A' δ_S - b'‖²); when a pivot vanishes, the variable left free is
named (:func:`underdetermined`). A Bayes tree's cliques are such conditionals (:mod:`steam_ref.bayes_tree.tree`);
stacking their rows in elimination order gives the upper-triangular R of A = QR, sparse: only the conditionals'
blocks are stored (:func:`assemble_sqrt_information`, behind the tree's ``to_sparse`` and ``to_dense``; covariances
come from the cliques themselves, :mod:`steam_ref.covariance`).
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from copy import copy
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.linalg import lapack

from ..errors import SteamError, UnderdeterminedError
from ..variables import Key
from .ordering import Ordering
from .system import GaussianFactor

__all__ = ["Clique", "Conditional", "assemble_sqrt_information", "eliminate_clique", "gather", "underdetermined"]


class Conditional(Protocol):
    """What a conditional P(F | S) offers (a Bayes tree clique is one). Read-only members, so that a
    frozen dataclass is one."""

    @property
    def frontals(self) -> tuple[Key, ...]: ...  # F, in elimination order
    @property
    def separator(self) -> tuple[Key, ...]: ...  # S, in the order of the elimination that made it
    @property
    def frontal_dims(self) -> tuple[int, ...]: ...  # size of each frontal variable
    @property
    def separator_dims(self) -> tuple[int, ...]: ...  # size of each separator variable
    @property
    def R(self) -> NDArray: ...  # (n_f, n_f) upper triangular
    @property
    def S(self) -> NDArray: ...  # (n_f, n_s)


RANK_TOLERANCE = 1e-12  # a pivot abs(Rᵢᵢ) ≤ this times max(1, largest abs entry of [A | b]) means a free direction
_below_diagonal = functools.cache(functools.partial(np.tri, k=-1, dtype=bool))  # (rows, cols): np.triu's mask
_largest = np.maximum.reduce  # the ufunc itself: ndarray.max's Python wrapper costs more than the reduction


@dataclass(frozen=True, eq=False)
class Clique:
    """P(F | S) ∝ exp(-½ ‖R δ_F + S δ_S - d‖²), and the factor on S its elimination left.  [YIB Eq. 25]"""

    frontals: tuple[Key, ...]  # F, eliminated here, in elimination order
    separator: tuple[Key, ...]  # S, shared with the parent, in its elimination's order (an orphan keeps its own)
    frontal_dims: tuple[int, ...]  # size of each frontal variable
    separator_dims: tuple[int, ...]  # size of each separator variable
    R: NDArray  # (n_f, n_f) upper triangular
    S: NDArray  # (n_f, n_s)
    d: NDArray  # (n_f,)
    marginal: GaussianFactor  # f(S) = ‖A' δ_S - b'‖², A' (k, n_s) with k ≤ n_s  [YIB Eq. 24]
    factors: tuple[int, ...] = ()  # ids of the original (nonlinear) factors eliminated here

    solved: tuple[NDArray, NDArray] = field(init=False, repr=False)  # (g, G) = (R⁻¹d, R⁻¹S), made with the clique

    def __post_init__(self) -> None:
        """(g, G) = (R⁻¹d, R⁻¹S), the conditional solved for its frontals: δ_F = g - G δ_S.  [YIB Eq. 25]

        G is the paper's rᵀ, g its d, made once with the clique (not lazily: an interrupted update must leave no
        trace), so that a back-substitution visit is one product, no LAPACK call. R⁻¹ by ``dtrtri`` and two products,
        not ``dtrtrs`` with n_s + 1 right-hand sides, which OpenBLAS threads (~100× slower outside the solvers' thread
        limit; the same choice as ``covariance._extend``). Against a solve per visit the estimates move at rounding
        level (whole Plaza runs: ≤ 1e-11, docs/experiments.md).
        """
        Rinv, info = lapack.dtrtri(self.R)
        if info != 0:
            raise SteamError(f"singular conditional in the clique of {self.frontals}")
        object.__setattr__(self, "solved", (Rinv.dot(self.d), Rinv.dot(self.S)))

    def solve(self, separator_values: NDArray) -> NDArray:
        """δ_F = R⁻¹(d - S δ_S) = g - G δ_S for the stacked separator values (n_s,); returns (n_f,).  [YIB Eq. 25]"""
        g, G = self.solved
        return g - G.dot(separator_values)  # .dot: @'s call costs more

    def with_factors(self, extra: tuple[int, ...]) -> Clique:
        """This clique naming ``extra`` original factors too (a marginal factor its next re-elimination gathers), its
        arrays and solved form shared, not made again: a new clique, for the tree to put in this one's place."""
        out = copy(self)
        object.__setattr__(out, "factors", self.factors + extra)  # frozen from here on
        return out

    def split_frontals(self, x: NDArray) -> list[NDArray]:
        """A stacked frontal vector (n_f,) as one array per frontal variable."""
        out, o = [], 0
        for dim in self.frontal_dims:
            out.append(x[o : o + dim])
            o += dim
        return out


def assemble_sqrt_information(ordering: Ordering, conditionals: Sequence[Conditional]) -> sp.csr_matrix:
    """Sparse upper-triangular R (n, n) of the conditionals, rows and columns in ``ordering``.

    Every frontal and separator variable must be in ``ordering``, frontals in the order the
    conditional lists them, so each conditional's rows start at the column of its first frontal.
    Memory is that of the conditionals' blocks [R S], never n × n.
    """
    rows, cols, vals = [], [], []
    for c in conditionals:
        r0 = ordering.offset_of[c.frontals[0]]
        nf = c.R.shape[0]
        col = [r0 + np.arange(nf)] + [
            ordering.offset_of[k] + np.arange(dim) for k, dim in zip(c.separator, c.separator_dims, strict=True)
        ]
        block = np.hstack([np.triu(c.R), c.S])  # the rows [R S] of P(F | S): RᵀR = 𝓘  [YIB Eq. 25]
        r, j = np.nonzero(block)
        rows.append(r0 + r)
        cols.append(np.concatenate(col)[j])
        vals.append(block[r, j])
    n = ordering.total_dim
    if not rows:
        return sp.csr_matrix((n, n))
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))


def gather(keys: tuple[Key, ...], dims: Mapping[Key, int], factors: Sequence[GaussianFactor]) -> NDArray:
    """The dense block [A_F A_S | b] of the factors adjacent to a clique: (rows, n + 1).  [YIB Eq. 24]"""
    columns, n = {}, 0
    for k in keys:
        d = dims[k]
        columns[k] = slice(n, n + d)
        n += d
    if not factors:
        return np.zeros((0, n + 1), order="F")
    rhs = np.concatenate([f.rhs for f in factors])  # ‖a θ + A_s s - b‖², the clique's terms stacked  [YIB Eq. 24]
    M = np.zeros((len(rhs), n + 1), order="F")
    M[:, n] = rhs
    r = 0
    for f in factors:
        rows = slice(r, r + len(f.rhs))  # the factor's rows, one slice for all its blocks
        for k, block in zip(f.keys, f.blocks, strict=True):  # a factor names each variable once, one block each
            M[rows, columns[k]] = block
        r = rows.stop
    return M


def underdetermined(M: NDArray, frontals: tuple[Key, ...], dims: Mapping[Key, int], free: int) -> UnderdeterminedError:
    """The error of a gathered block [A_F A_S | b] whose pivot ``free`` vanished: the frontal variable the factors
    leave free and why (no factor reaches it, too few directions, or float64 cannot resolve the scales)."""
    bad = _free_variable(M, frontals, dims, free)
    diag = (M[:, :-1] ** 2).sum(axis=0)  # the diagonal of the clique's information
    own = M[:, _columns_of(bad, frontals, dims)]
    if not diag[diag > 0].size or not own.any():
        return UnderdeterminedError(f"variable {bad!r} is not constrained by the factors (no factor reaches it)")
    span = float(diag.max() / diag[diag > 0].min())
    rank = int(np.linalg.matrix_rank(own))
    if span < 1 / np.finfo(float).eps and rank < own.shape[1]:  # well scaled, yet short of directions
        return UnderdeterminedError(
            f"variable {bad!r} is not constrained by the factors (they fix {rank} of its {own.shape[1]} directions)"
        )
    return UnderdeterminedError(
        f"elimination breaks down at variable {bad!r} (pivot {free} of its clique vanishes): the factors leave "
        f"it free, or the information matrix is too ill-conditioned for float64 (its diagonal spans "
        f"{float(diag.max() / diag[diag > 0].min()):.1e} in this clique)"
    )


def eliminate_clique(
    frontals: tuple[Key, ...],
    separator: tuple[Key, ...],
    dims: Mapping[Key, int],
    factors: Sequence[GaussianFactor],
    factor_ids: tuple[int, ...] = (),
) -> Clique:
    """Eliminate ``frontals`` from the adjacent ``factors`` by one dense QR.  [YIB Eq. 24-25]"""
    frontal_dims, separator_dims = tuple(map(dims.__getitem__, frontals)), tuple(map(dims.__getitem__, separator))
    M = gather(frontals + separator, dims, factors)
    (rows, ncol), nf = M.shape, sum(frontal_dims)
    if rows < nf:  # fewer rows than frontal unknowns
        raise underdetermined(M, frontals, dims, rows)
    tolerance = RANK_TOLERANCE * max(_largest(np.abs(M), axis=None), 1.0)  # read before the QR overwrites M
    qr, _, _, _ = lapack.dgeqrf(M, overwrite_a=True)  # Q R = M, Householder, in place (Gram-Schmidt's R, to signs)
    R = qr if rows <= ncol else qr[:ncol]
    R[_below_diagonal(*R.shape)] = 0.0  # np.triu in place, its mask made once per shape
    pivots = R.diagonal()[:nf].tolist()  # Python's min over a few numbers costs less than NumPy's calls
    if min(map(abs, pivots), default=np.inf) <= tolerance:  # a vanishing pivot: name the first one's variable and why
        free = next(i for i, p in enumerate(pivots) if abs(p) <= tolerance)
        raise underdetermined(gather(frontals + separator, dims, factors), frontals, dims, free)
    ns = ncol - 1 - nf
    below = R[nf : nf + ns, nf:].copy()  # f(S): the rows left after eliminating F  [YIB Eq. 24]
    blocks, o = [], 0
    for d in separator_dims:
        blocks.append(below[:, o : o + d])
        o += d
    marginal = GaussianFactor(separator, tuple(blocks), below[:, ns])
    return Clique(
        frontals,
        separator,
        frontal_dims,
        separator_dims,
        np.asfortranarray(R[:nf, :nf]),
        np.ascontiguousarray(R[:nf, nf : ncol - 1]),
        R[:nf, ncol - 1].copy(),
        marginal,
        tuple(factor_ids),
    )


def _columns_of(key: Key, frontals: tuple[Key, ...], dims: Mapping[Key, int]) -> slice:
    """The columns of frontal ``key`` in a gathered clique matrix."""
    o = 0
    for k in frontals:
        if k == key:
            return slice(o, o + dims[k])
        o += dims[k]
    raise KeyError(key)


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
