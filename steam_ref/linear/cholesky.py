"""Sparse Cholesky solution of 𝓘 δθ = Aᵀb (Eq. 11) and fill-in counts (covariances: :mod:`steam_ref.covariance`).

The matrix is factored *in the order the LinearSystem's columns already have* (the ordering was
chosen before assembly), so the fill of 𝓛 is the fill of that ordering. Backends:

- ``cholmod``: scikit-sparse's CHOLMOD (supernodal), told to keep our order (``natural``);
- ``superlu``: SciPy's SuperLU in natural column order with no pivoting (``diag_pivot_thresh=0``,
  symmetric mode), which on a symmetric positive definite matrix is exactly the LDLᵀ/Cholesky
  elimination: L's pattern is the Cholesky factor's.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

from ..errors import NumericalError, ShapeError, SteamError, UnderdeterminedError
from .ordering import Ordering, sparse_backend
from .system import LinearSystem

__all__ = ["SparseCholesky", "Symbolic", "solve", "check_system"]

# A pivot (the LDLᵀ d_i = L_ii²) at most this times its own column's diagonal entry 𝓘_ii is what rounding
# left of a zero one: the matrix is singular, or its scaled condition exceeds ~10¹³ (d_i / 𝓘_ii ≥ 1/cond of
# D^-½ 𝓘 D^-½ for a positive definite 𝓘). Both backends apply it; CHOLMOD by itself takes any pivot > 0.
PIVOT_TOLERANCE = 1e-13


def _unconstrained_variable(info: sp.csc_matrix, ordering: Ordering, column: int | None = None) -> str:
    """Name the variable a singular information matrix leaves free (its first zero diagonal, if any)."""
    diag = info.diagonal()
    zero = np.flatnonzero(diag <= 0)
    col = int(zero[0]) if len(zero) else column
    if col is None:
        return (
            "the information matrix is not positive definite in float64: the factors leave some combination of "
            f"variables free, or it is too ill-conditioned (its diagonal spans {float(diag.max() / diag.min()):.1e})"
        )
    pos = int(np.searchsorted(ordering.offsets, col, side="right") - 1)
    if len(zero):
        return f"variable {ordering.keys[pos]!r} (column {col}) is not constrained by the factors"
    spread = float(diag.max() / diag.min())
    return (
        f"elimination breaks down at variable {ordering.keys[pos]!r} (column {col}): the factors leave it free, "
        f"or the information matrix is too ill-conditioned for float64 (its diagonal spans {spread:.1e})"
    )


def _superlu(info: sp.csc_matrix) -> tuple[spla.SuperLU | None, int | None]:
    """SuperLU in natural order without pivoting: (the factor, None), or (None, first failing column or None)."""
    options = dict(permc_spec="NATURAL", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    try:
        lu = spla.splu(info, **options)
    except RuntimeError:  # "Factor is exactly singular": find where, on 𝓘 + 10⁻¹² diag 𝓘
        try:
            nudged = spla.splu(sp.csc_matrix(info + 1e-12 * sp.diags(info.diagonal())), **options)
        except RuntimeError:
            return None, None
        small = np.flatnonzero(nudged.U.diagonal() < 1e-9 * info.diagonal())
        return None, int(small[0]) if len(small) else None
    # A pivot is judged against its own column's diagonal entry, which it can only lose to cancellation:
    # scale-invariant, as CHOLMOD's test (pivot > 0) is. Against the largest pivot instead, a positive
    # definite 𝓘 whose diagonal merely spans many decades (tiny time gaps) was refused.
    u = lu.U.diagonal()
    tiny = np.flatnonzero(~(u > PIVOT_TOLERANCE * info.diagonal()))
    if len(tiny) or np.any(lu.perm_r != np.arange(len(u))):
        return None, int(tiny[0]) if len(tiny) else None
    return lu, None


def _checked_information(info: sp.spmatrix | NDArray, ordering: Ordering, symmetry: bool) -> sp.csc_matrix:
    """``info`` as a CSC matrix, if it is square, of the ordering's size, finite and (if ``symmetry``) symmetric.

    Symmetry is judged entry by entry against √(𝓘ᵢᵢ 𝓘ⱼⱼ), which bounds |𝓘ᵢⱼ| in a positive definite
    matrix: a relative test whatever the units. It needs a transpose, about 6% of a factorization.
    """
    info = sp.csc_matrix(info)
    n = ordering.total_dim
    if info.shape != (n, n):
        raise ShapeError(
            f"the information matrix must be square ({n}, {n}) to match the ordering, got shape {info.shape}"
        )
    if not np.isfinite(info.data).all():
        col = int(info.tocoo().col[~np.isfinite(info.tocoo().data)][0])
        key = ordering.keys[int(np.searchsorted(ordering.offsets, col, side="right") - 1)]
        raise NumericalError(f"the information matrix holds NaN or inf in column {col}, of variable {key!r}")
    diff = (info - info.T).tocoo() if symmetry else sp.coo_matrix(info.shape)
    if diff.nnz:
        scale = np.sqrt(np.abs(info.diagonal()))
        bad = np.abs(diff.data) > 1e-10 * scale[diff.row] * scale[diff.col]
        if bad.any():
            i, j = int(diff.row[bad][0]), int(diff.col[bad][0])
            raise SteamError(
                f"the information matrix is not symmetric: entry ({i}, {j}) = {float(info[i, j])!r} "
                f"but ({j}, {i}) = {float(info[j, i])!r}"
            )
    return info


class Symbolic:
    """CHOLMOD's symbolic analysis of the last pattern factored, reused while the pattern holds.

    Gauss-Newton and Levenberg-Marquardt factor matrices of one sparsity pattern in one ordering at
    every iteration: analysing it once and refactoring numerically (``Factor.cholesky``) gives the
    same factor as a fresh ``cholesky`` (the analysis depends on the pattern only). A new pattern is
    analysed anew. SuperLU has no such split; it ignores this.
    """

    def __init__(self) -> None:
        self._pattern: tuple[NDArray, NDArray] | None = None  # (indptr, indices) analysed
        self._factor: Any = None  # CHOLMOD's analysed Factor
        self.analyses = 0  # how many patterns were analysed (for tests and profiles)

    def factor(self, info: sp.csc_matrix) -> Any:
        """CHOLMOD's numeric factor of ``info``, in natural order, reusing the analysis when the pattern holds."""
        from sksparse.cholmod import analyze

        pattern = self._pattern
        if pattern is None or not (
            np.array_equal(pattern[0], info.indptr) and np.array_equal(pattern[1], info.indices)
        ):
            self._factor = analyze(info, ordering_method="natural")
            self._pattern = (info.indptr.copy(), info.indices.copy())
            self.analyses += 1
        return self._factor.cholesky(info)


@dataclass
class SparseCholesky:
    """𝓛𝓛ᵀ = 𝓘 in the given order, with solves.  [YIB Eq. 11]"""

    backend: str  # 'cholmod' or 'superlu'
    nnz: int  # nonzeros of the lower-triangular factor 𝓛 (diagonal included)
    _factor: Any  # the backend's factor: CHOLMOD's Factor (called) or SciPy's SuperLU (.solve)
    n: int = 0  # size of 𝓘

    @classmethod
    def factor(
        cls,
        info: sp.csc_matrix,
        ordering: Ordering,
        backend: str | None = None,
        *,
        check_symmetry: bool = True,
        symbolic: Symbolic | None = None,
    ) -> SparseCholesky:
        """Factor 𝓘 (sparse or dense, symmetric positive definite, of the size of ``ordering``) without reordering it.

        ``check_symmetry=False`` skips the symmetry check, for a caller whose 𝓘 is AᵀA by construction;
        ``symbolic`` keeps CHOLMOD's analysis for the next matrix of the same pattern.
        """
        backend = sparse_backend(backend)
        info = _checked_information(info, ordering, check_symmetry)
        if np.any(info.diagonal() <= 0):
            raise UnderdeterminedError(_unconstrained_variable(info, ordering))
        if backend == "cholmod":
            from sksparse.cholmod import CholmodNotPositiveDefiniteError, cholesky

            try:
                f = (
                    cholesky(info, ordering_method="natural") if symbolic is None else symbolic.factor(info)
                )  # 𝓛𝓛ᵀ = 𝓘  [YIB Eq. 11]
                L = f.L()  # CHOLMOD may find the failure only here, when it converts the factor
            except CholmodNotPositiveDefiniteError as exc:
                column = getattr(exc, "column", None)
                if column is None:  # simplicial CHOLMOD does not say where: find it by SuperLU
                    column = _superlu(info)[1]
                raise UnderdeterminedError(
                    _unconstrained_variable(info, ordering, column) + f" (CHOLMOD: {exc})"
                ) from None
            tiny = np.flatnonzero(~(L.diagonal() ** 2 > PIVOT_TOLERANCE * info.diagonal()))  # natural order: no P
            if len(tiny):
                raise UnderdeterminedError(_unconstrained_variable(info, ordering, int(tiny[0])))
            return cls(backend, int(L.nnz), f, info.shape[0])
        lu, column = _superlu(info)
        if lu is None:
            raise UnderdeterminedError(_unconstrained_variable(info, ordering, column))
        return cls(backend, int(lu.L.nnz), lu, info.shape[0])

    def solve(self, rhs: NDArray) -> NDArray:
        """𝓘⁻¹ rhs for a vector (n,) or a matrix (n, k)."""
        if np.ndim(rhs) not in (1, 2) or np.shape(rhs)[0] != self.n:
            raise ShapeError(
                f"rhs must be a vector ({self.n},) or a matrix ({self.n}, k) to match 𝓘, got shape {np.shape(rhs)}"
            )
        if self.backend == "cholmod":
            return self._factor(rhs)  # 𝓛𝓛ᵀ x = rhs by two triangular solves  [YIB Eq. 11]
        return self._factor.solve(np.asarray(rhs, dtype=float))  # the same by SuperLU's LU of 𝓘  [YIB Eq. 11]


def check_system(system: object) -> None:
    """SteamError unless ``system`` is a :class:`LinearSystem` (what a solve or a covariance of one reads)."""
    if not isinstance(system, LinearSystem):
        raise SteamError(f"system must be a LinearSystem (LinearSystem.build), got system={system!r:.80}")


def solve(system: LinearSystem, backend: str | None = None) -> tuple[NDArray, SparseCholesky]:
    """The Gauss-Newton step δθ* of Eq. 11 (in the system's column order) and the factor used."""
    check_system(system)
    info, rhs = system.information()
    chol = SparseCholesky.factor(info, system.ordering, backend, check_symmetry=False)  # AᵀA
    return chol.solve(rhs), chol
