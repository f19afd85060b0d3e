"""Every variable ordering of steam_ref: natural, XL (the paper's PB), AMD (PBVR) and the
constrained minimum degree of iSAM2.  [YIB Sec. III, IV, K12 Sec. 5]

An ordering is the order in which variables are eliminated, i.e. the order of the column blocks
of A and of the rows/columns of 𝓘. Natural keeps the order given; XL puts every trajectory state
before every landmark (footnote 1 of [YIB]); AMD (approximate minimum degree) permutes the
variables to keep the Cholesky factor sparse; :func:`constrained_min_degree` is exact greedy
minimum degree with a chosen group forced last (the Bayes tree's re-elimination: :mod:`.min_degree`). Orderings act on
*variables* (blocks), as in GTSAM, not on scalars. Every ordering function takes the variables and
their sizes (and, where the pattern matters, the variables of each factor) and returns an
:class:`Ordering`; :func:`make_ordering` is the one place that picks one by name, for the batch
solvers, the covariance queries and the benchmarks alike.

AMD backends: CHOLMOD's AMD when scikit-sparse is installed, otherwise SciPy's SuperLU
minimum-degree ordering on AᵀA (``MMD_AT_PLUS_A``), whose fill is within about 1% of AMD's on
these problems. Set the environment variable ``STEAM_REF_SPARSE_BACKEND=superlu`` to force the
fallback.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

from ..arguments import is_integer
from ..errors import ShapeError, SteamError, UnknownVariableError
from ..variables import Key, key_list
from .min_degree import KeysBelow, _places, _sizes, min_degree_keys

__all__ = [
    "KeysBelow",
    "Ordering",
    "natural_ordering",
    "xl_ordering",
    "amd_ordering",
    "constrained_min_degree",
    "min_degree_keys",
    "make_ordering",
    "variable_adjacency",
    "sparse_backend",
    "have_cholmod",
]

ORDERING_NAMES = ("natural", "xl", "amd")  # the names make_ordering knows


def have_cholmod() -> bool:
    """True when scikit-sparse's CHOLMOD imports."""
    try:
        import sksparse.cholmod  # noqa: F401
    except ImportError:
        return False
    return True


def sparse_backend(backend: str | None = None) -> str:
    """Which sparse Cholesky/AMD runs: 'cholmod' or 'superlu'.

    ``backend`` overrides; otherwise ``STEAM_REF_SPARSE_BACKEND``, otherwise CHOLMOD if installed.
    """
    choice = backend or os.environ.get("STEAM_REF_SPARSE_BACKEND", "") or ("cholmod" if have_cholmod() else "superlu")
    if choice not in ("cholmod", "superlu"):
        raise SteamError(f"unknown sparse backend {choice!r}; use 'cholmod' or 'superlu'")
    if choice == "cholmod" and not have_cholmod():
        raise SteamError(
            "sparse backend 'cholmod' asked for but scikit-sparse is not installed (pip install steam_ref[cholmod])"
        )
    return choice


def _positive_size(k: Key, d: object) -> int:
    """The size ``d`` of variable ``k`` as given (any object) as an int; ShapeError unless a positive integer."""
    if not is_integer(d) or d < 1:
        raise ShapeError(f"the size of variable {k!r} in an ordering must be a positive integer, got {d!r}")
    return int(d)


@dataclass(frozen=True)
class Ordering:
    """An elimination order of variables and where each one's columns start."""

    keys: tuple[Key, ...]  # variables in elimination order
    dims: tuple[int, ...]  # size of each
    offsets: NDArray = field(init=False)  # first column of each variable, (n,)
    offset_of: dict[Key, int] = field(init=False, repr=False)  # key → first column
    position: dict[Key, int] = field(init=False, repr=False)  # key → place in the order
    dim_array: NDArray = field(init=False, repr=False)  # ``dims`` as an int array, (n,)

    def __post_init__(self) -> None:
        keys, dims = tuple(self.keys), tuple(self.dims)
        if len(keys) != len(dims):
            raise ShapeError(f"an ordering needs one size per variable: {len(keys)} keys, {len(dims)} dims")
        seen: set[Key] = set()
        sizes = []
        for k, d in zip(keys, dims, strict=True):
            if k in seen:
                raise SteamError(f"an ordering lists variable {k!r} twice")
            seen.add(k)
            sizes.append(_positive_size(k, d))
        object.__setattr__(self, "keys", keys)
        object.__setattr__(self, "dims", tuple(sizes))
        offsets = np.concatenate([[0], np.cumsum(self.dims)[:-1]]).astype(int) if self.keys else np.zeros(0, int)
        object.__setattr__(self, "offsets", offsets)
        object.__setattr__(self, "offset_of", dict(zip(self.keys, offsets.tolist(), strict=True)))
        object.__setattr__(self, "position", {k: i for i, k in enumerate(self.keys)})
        object.__setattr__(self, "dim_array", np.array(self.dims, dtype=int))

    @property
    def total_dim(self) -> int:
        """Number of scalar unknowns."""
        return int(sum(self.dims))

    def scalar_permutation(self, other: Ordering) -> NDArray:
        """Indices p such that a vector in ``other``'s order, indexed by p, is in this order."""
        return np.concatenate([np.arange(d) + other.offset_of[k] for k, d in zip(self.keys, self.dims, strict=True)])

    def __len__(self) -> int:
        return len(self.keys)

    def __iter__(self) -> Iterator[Key]:
        """The variables in elimination order (an Ordering reads as the sequence of its keys)."""
        return iter(self.keys)

    def __getitem__(self, i: int) -> Key:
        return self.keys[i]


def natural_ordering(keys: Iterable[Key], dims: Mapping[Key, int]) -> Ordering:
    """The variables in the order given (for a graph: first-seen order)."""
    keys = tuple(key_list("keys", keys))
    return Ordering(keys, _sizes(keys, dims))


def xl_ordering(keys: Iterable[Key], dims: Mapping[Key, int]) -> Ordering:
    """Trajectory states first (by index), then landmarks (by index): the paper's PB.  [YIB Eq. 15]"""
    keys = key_list("keys", keys)
    states = sorted((k for k in keys if k.symbol == "x"), key=lambda k: k.index)
    others = sorted((k for k in keys if k.symbol != "x"), key=lambda k: (k.symbol, k.index))
    ordered = states + others
    return Ordering(tuple(ordered), _sizes(ordered, dims))


def variable_adjacency(keys: Sequence[Key], factor_keys: Iterable[tuple[Key, ...]]) -> sp.csc_matrix:
    """The symmetric variable-level pattern of 𝓘 (1 where two variables share a factor), (n, n)."""
    index = {k: i for i, k in enumerate(keys)}
    rows, cols = [np.arange(len(keys))], [np.arange(len(keys))]
    for ids in _places(index, factor_keys, "keys"):
        for a in ids:
            rows.append(np.full(len(ids), a))
            cols.append(np.array(ids))
    r, c = np.concatenate(rows), np.concatenate(cols)
    return sp.csc_matrix((np.ones(len(r)), (r, c)), shape=(len(keys), len(keys)))


def _amd_permutation(pattern: sp.csc_matrix, backend: str) -> NDArray:
    """Fill-reducing elimination order (a permutation of range(n)) of a symmetric pattern."""
    n = pattern.shape[0]
    # Diagonally dominant values with this pattern: any SPD matrix will do, only the pattern matters.
    M = (pattern + sp.identity(n, format="csc") * (2 * n + 1)).tocsc()
    if backend == "cholmod":
        from sksparse.cholmod import analyze

        return np.asarray(analyze(M, ordering_method="amd").P(), dtype=int)
    # SuperLU's perm_c maps an original column to its new position; the elimination order is its inverse.
    lu = spla.splu(M, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
    return np.argsort(lu.perm_c)


def amd_ordering(
    keys: Sequence[Key], dims: Mapping[Key, int], factor_keys: Iterable[tuple[Key, ...]], backend: str | None = None
) -> Ordering:
    """An approximate-minimum-degree elimination order of the variables: the paper's PBVR."""
    keys = key_list("keys", keys)
    sizes = _sizes(keys, dims)
    if not keys:
        return Ordering((), ())
    perm = _amd_permutation(variable_adjacency(keys, factor_keys), sparse_backend(backend))
    return Ordering(tuple(keys[i] for i in perm), tuple(sizes[i] for i in perm))


def constrained_min_degree(
    variables: Sequence[Key],
    dims: Mapping[Key, int],
    factor_keys: Iterable[Sequence[Key]],
    last: Iterable[Key] = (),
) -> Ordering:
    """A greedy minimum-degree elimination order with the variables in ``last`` eliminated last, as an
    :class:`Ordering` (:func:`~.min_degree.min_degree_keys` gives the keys alone, as an incremental update needs them).
    """
    order = min_degree_keys(variables, dims, factor_keys, last)
    return Ordering(tuple(order), tuple(dims[k] for k in order))


def make_ordering(
    name_or_ordering: str | Ordering,
    keys: Sequence[Key],
    dims: Mapping[Key, int],
    factor_keys: Iterable[tuple[Key, ...]],
    backend: str | None = None,
) -> Ordering:
    """'natural', 'xl', 'amd' or an explicit :class:`Ordering` (returned as it is) for ``keys``.

    ``dims``: size of each variable; ``factor_keys``: the variables of each factor (read by AMD
    only); ``backend``: AMD's sparse backend (see :func:`sparse_backend`). For a factor graph and
    its estimate: ``make_ordering(name, graph.keys(), values.dims(), [f.keys for f in graph])``.
    """
    if isinstance(name_or_ordering, Ordering):
        return _check_given(name_or_ordering, keys, dims)
    if name_or_ordering == "natural":
        return natural_ordering(keys, dims)
    if name_or_ordering == "xl":
        return xl_ordering(keys, dims)
    if name_or_ordering == "amd":
        return amd_ordering(keys, dims, factor_keys, backend)
    raise SteamError(f"unknown ordering {name_or_ordering!r}; use one of {ORDERING_NAMES} or an Ordering")


def _check_given(ordering: Ordering, keys: Sequence[Key], dims: Mapping[Key, int]) -> Ordering:
    """An explicit ordering, if it orders exactly ``keys`` with the sizes of ``dims``."""
    for k in keys:
        if k not in ordering.position:
            raise UnknownVariableError(f"the ordering given lacks variable {k!r}")
        size = ordering.dims[ordering.position[k]]
        if k in dims and dims[k] != size:
            raise ShapeError(f"the ordering given has variable {k!r} of size {size}, its estimate has size {dims[k]}")
    if len(ordering) != len(set(keys)):
        extra = next(k for k in ordering.keys if k not in set(keys))
        raise UnknownVariableError(
            f"the ordering given has variable {extra!r}, which is not among the variables to order"
        )
    return ordering
