"""Gaussian conditionals P(F | S) ∝ exp(-½ ‖R δ_F + S δ_S - d‖²) stacked into one square-root
information matrix R, with RᵀR = AᵀA = 𝓘.  [YIB Eq. 11, 21, 25]

A Bayes tree's cliques are such conditionals; stacking their rows in elimination order gives the
upper-triangular R of A = QR. Used by the tree's ``to_dense`` and by covariance recovery.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from ..variables import Key
from .ordering import Ordering

__all__ = ["Conditional", "assemble_sqrt_information"]


class Conditional(Protocol):
    """What a conditional P(F | S) offers (a Bayes tree clique is one)."""

    frontals: tuple[Key, ...]  # F, in elimination order
    separator: tuple[Key, ...]  # S, in elimination order
    frontal_dims: tuple[int, ...]  # size of each frontal variable
    separator_dims: tuple[int, ...]  # size of each separator variable
    R: NDArray  # (n_f, n_f) upper triangular
    S: NDArray  # (n_f, n_s)


def assemble_sqrt_information(ordering: Ordering, conditionals: Sequence[Conditional]) -> NDArray:
    """Dense upper-triangular R (n, n) of the conditionals, rows and columns in ``ordering``.

    Every frontal and separator variable must be in ``ordering``, frontals in the order the
    conditional lists them, so each conditional's rows start at the column of its first frontal.
    """
    n = ordering.total_dim
    R = np.zeros((n, n))
    for c in conditionals:
        r0 = ordering.offset_of[c.frontals[0]]
        nf = c.R.shape[0]
        R[r0 : r0 + nf, r0 : r0 + nf] = c.R
        o = 0
        for k, dim in zip(c.separator, c.separator_dims):
            c0 = ordering.offset_of[k]
            R[r0 : r0 + nf, c0 : c0 + dim] = c.S[:, o : o + dim]
            o += dim
    return R
