"""The linear least-squares layer: linearization, orderings, sparse Cholesky, conditionals.  [YIB Eq. 9-11, 15, 21]"""

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
