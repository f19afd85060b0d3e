"""Gaussian conditionals P(F | S) ∝ exp(-½ ‖R δ_F + S δ_S - d‖²) stacked into one square-root
information matrix R, with RᵀR = AᵀA = 𝓘.  [YIB Eq. 11, 21, 25]

A Bayes tree's cliques are such conditionals; stacking their rows in elimination order gives the
upper-triangular R of A = QR, sparse: only the conditionals' blocks are stored. Used by the tree's
``to_sparse`` and ``to_dense`` (covariances come from the cliques themselves, :mod:`steam_ref.covariance`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from ..variables import Key
from .ordering import Ordering

__all__ = ["Conditional", "assemble_sqrt_information"]


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
        block = np.hstack([np.triu(c.R), c.S])  # (n_f, n_f + n_s): its columns are ``col``
        r, j = np.nonzero(block)
        rows.append(r0 + r)
        cols.append(np.concatenate(col)[j])
        vals.append(block[r, j])
    n = ordering.total_dim
    if not rows:
        return sp.csr_matrix((n, n))
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
