"""The linear least-squares layer: linearization, orderings, sparse Cholesky, conditionals.  [YIB Eq. 9-11, 15, 21]

The names below load from their modules when first used (PEP 562), so that one light module of the layer
(``threads``, ``amalgamation``: what the command line reads before it solves) loads without SciPy's sparse matrices.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._package import lazy_names

# Each public name and the module it lives in (loaded when the name is first used).
_HOMES = {
    "Ordering": "ordering",
    "natural_ordering": "ordering",
    "xl_ordering": "ordering",
    "amd_ordering": "ordering",
    "constrained_min_degree": "ordering",
    "min_degree_keys": "ordering",
    "make_ordering": "ordering",
    "have_cholmod": "ordering",
    "sparse_backend": "ordering",
    "SparseCholesky": "cholesky",
    "solve": "cholesky",
    "GaussianFactor": "system",
    "LinearizedGroup": "system",
    "LinearSystem": "system",
    "linearize": "system",
    "blas_threads": "threads",
}
__all__ = [
    "Ordering",
    "natural_ordering",
    "xl_ordering",
    "amd_ordering",
    "constrained_min_degree",
    "min_degree_keys",
    "make_ordering",
    "have_cholmod",
    "sparse_backend",
    "SparseCholesky",
    "solve",
    "GaussianFactor",
    "LinearizedGroup",
    "LinearSystem",
    "linearize",
    "blas_threads",
]


__getattr__, __dir__ = lazy_names(globals(), _HOMES)


if TYPE_CHECKING:  # what a type checker and an IDE see: the same names, imported eagerly
    from .cholesky import SparseCholesky, solve
    from .ordering import (
        Ordering,
        amd_ordering,
        constrained_min_degree,
        have_cholmod,
        make_ordering,
        min_degree_keys,
        natural_ordering,
        sparse_backend,
        xl_ordering,
    )
    from .system import GaussianFactor, LinearizedGroup, LinearSystem, linearize
    from .threads import blas_threads
