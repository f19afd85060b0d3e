"""The linear least-squares layer: linearization, orderings, sparse Cholesky.  [YIB Eq. 9-11, 15, 21]"""

from .ordering import Ordering, amd_ordering, have_cholmod, sparse_backend, xl_ordering
from .solve import SparseCholesky, marginal_covariances, solve
from .system import GaussianFactor, LinearizedGroup, LinearSystem, linearize

__all__ = [
    "Ordering",
    "xl_ordering",
    "amd_ordering",
    "have_cholmod",
    "sparse_backend",
    "SparseCholesky",
    "solve",
    "marginal_covariances",
    "GaussianFactor",
    "LinearizedGroup",
    "LinearSystem",
    "linearize",
]
