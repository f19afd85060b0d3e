"""Gaussian conditionals P(F | S) ∝ exp(-½ ‖R δ_F + S δ_S - d‖²) stacked into one square-root
information matrix R, with RᵀR = AᵀA = 𝓘.  [YIB Eq. 11, 21, 25]

A Bayes tree's cliques are such conditionals; stacking their rows in elimination order gives the
upper-triangular R of A = QR, sparse: only the conditionals' blocks are stored. A clique's elimination
starts from the dense block of its adjacent factors (:func:`gather`) and, when a pivot vanishes, names the
variable left free (:func:`underdetermined`). Used by the tree's
``to_sparse`` and ``to_dense`` (covariances come from the cliques themselves, :mod:`steam_ref.covariance`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Protocol

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from ..errors import UnderdeterminedError
from ..variables import Key
from .ordering import Ordering
from .system import GaussianFactor

__all__ = ["Conditional", "assemble_sqrt_information", "gather", "underdetermined"]


class Conditional(Protocol):
    """What a conditional P(F | S) offers (a Bayes tree clique is one). Read-only members, so that a
    frozen dataclass is one."""

    @property
    def frontals(self) -> tuple[Key, ...]: ...  # F, in elimination order
    @property
    def separator(self) -> tuple[Key, ...]: ...  # S, in elimination order
    @property
    def frontal_dims(self) -> tuple[int, ...]: ...  # size of each frontal variable
    @property
    def separator_dims(self) -> tuple[int, ...]: ...  # size of each separator variable
    @property
    def R(self) -> NDArray: ...  # (n_f, n_f) upper triangular
    @property
    def S(self) -> NDArray: ...  # (n_f, n_s)


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
    offset, n = {}, 0
    for k in keys:
        offset[k] = n
        n += dims[k]
    rows = sum(f.rhs.shape[0] for f in factors)
    M = np.zeros((rows, n + 1), order="F")
    r = 0
    for f in factors:
        end = r + f.rhs.shape[0]
        for k, block in zip(f.keys, f.blocks, strict=True):  # a factor names each variable once
            o = offset[k]
            M[r:end, o : o + block.shape[1]] = block
        M[r:end, n] = f.rhs  # ‖a θ + A_s s - b‖², the clique's terms stacked  [YIB Eq. 24]
        r = end
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
