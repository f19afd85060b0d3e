"""Every variable ordering of steam_ref: natural, XL (the paper's PB), AMD (PBVR) and the
constrained minimum degree of iSAM2.  [YIB Sec. III, IV, K12 Sec. 4.2]

An ordering is the order in which variables are eliminated, i.e. the order of the column blocks
of A and of the rows/columns of 𝓘. Natural keeps the order given; XL puts every trajectory state
before every landmark (footnote 1 of [YIB]); AMD (approximate minimum degree) permutes the
variables to keep the Cholesky factor sparse; :func:`constrained_min_degree` is exact greedy
minimum degree with a chosen group forced last (the Bayes tree's re-elimination). Orderings act on
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

import heapq
import os
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

from ..arguments import is_integer, number
from ..errors import ShapeError, SteamError, UnknownVariableError
from ..variables import Key, key_list

__all__ = [
    "KeysBelow",
    "Ordering",
    "check_constrained",
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
    """Which sparse Cholesky/AMD runs, 'cholmod' or 'superlu': ``backend``, otherwise ``STEAM_REF_SPARSE_BACKEND``,
    otherwise CHOLMOD if installed."""
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
    offsets: NDArray = field(init=False, repr=False)  # first column of each variable, (n,)
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


def _sizes(keys: Sequence[Key], dims: Mapping[Key, int]) -> tuple[int, ...]:
    """The size of each key, read from ``dims``; UnknownVariableError naming a key it lacks."""
    try:
        return tuple(dims[k] for k in keys)
    except KeyError as exc:
        raise UnknownVariableError(f"dims gives no size for variable {exc.args[0]!r}") from None


def natural_ordering(keys: Iterable[Key], dims: Mapping[Key, int]) -> Ordering:
    """The variables in the order given (for a graph: first-seen order)."""
    keys = tuple(key_list("keys", keys))
    return Ordering(keys, _sizes(keys, dims))


def xl_ordering(keys: Iterable[Key], dims: Mapping[Key, int]) -> Ordering:
    """Trajectory states first (by index), then landmarks (by index): the paper's PB.  [YIB Eq. 15]"""
    keys = key_list("keys", keys)
    states = sorted((k for k in keys if k.symbol == "x"), key=lambda k: k.index)
    others = sorted((k for k in keys if k.symbol != "x"), key=lambda k: (k.symbol, k.index))
    return Ordering(tuple(states + others), _sizes(states + others, dims))


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


def _places(index: Mapping[Key, int], factor_keys: Iterable[Sequence[Key]], among: str) -> list[list[int]]:
    """Each factor's variables as their places in ``index``; UnknownVariableError names one ``index`` lacks."""
    factor_keys, place = list(factor_keys), index.__getitem__
    try:
        return [list(map(place, keys)) for keys in factor_keys]  # one pass in C: a list per factor, no generator
    except KeyError as exc:
        missing = exc.args[0]
    i, keys = next(((i, keys) for i, keys in enumerate(factor_keys) if missing in keys), ("?", "a key"))
    raise UnknownVariableError(
        f"factor_keys[{i}] = {keys!r} names {missing!r}, which is not among the {among} to order"
    )


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
    :class:`Ordering` (:func:`min_degree_keys` gives the keys alone, as an incremental update needs them)."""
    order = min_degree_keys(variables, dims, factor_keys, last)
    return Ordering(tuple(order), tuple(dims[k] for k in order))


def min_degree_keys(
    variables: Sequence[Key],
    dims: Mapping[Key, int],
    factor_keys: Iterable[Sequence[Key]],
    last: Iterable[Key] = (),
    first: Mapping[Key, float] | None = None,
) -> list[Key]:
    """A greedy minimum-degree elimination order with the variables in ``last`` eliminated last.

    ``dims``: the size of each variable (the :class:`Ordering` carries them); ``factor_keys``: the
    variables of each factor.

    The degree of a variable is its number of neighbours in the current elimination graph (the
    variable graph after the eliminations so far, fill included), so this is exact minimum degree,
    not AMD's approximation. Ties go to the variable listed first in ``variables``. Variables in
    ``last`` are ordered among themselves by minimum degree too, after all others: this is the
    constrained ordering iSAM2 obtains from CCOLAMD, which keeps the variables touched by new
    factors near the root so the next update removes little of the tree.  [K12 Sec. 4.2]

    ``first`` (after GTSAM's ``constrainedKeys``): the variables it names (and ``last`` does not) are eliminated
    before all others, in increasing order of the number it maps each to (ties in the order of ``variables``), the
    rest by minimum degree on the graph their elimination leaves: a fixed-lag smoother puts the variables next to
    leave its window there, to sit in leaf cliques, cut off with no re-elimination. GTSAM's numbers are CCOLAMD
    groups (each ordered by fill, a key left out in group 0) that replace iSAM2's new keys last; ``last`` holds here.
    """
    if first is not None:
        return _first_then_min_degree(list(variables), dims, factor_keys, list(last), first)
    variables = list(variables)
    index = {v: i for i, v in enumerate(variables)}
    if len(index) != len(variables):
        twice = next(v for i, v in enumerate(variables) if index[v] != i)
        raise SteamError(f"variables lists {twice!r} twice")
    _sizes(variables, dims)  # names a variable dims lacks, before any work
    n = len(variables)
    adj: list[set[int]] = [set() for _ in range(n)]  # by place in ``variables``: integers hash faster than keys
    for places in _places(index, factor_keys, "variables"):
        for j in places:
            adj[j].update(places)
    if isinstance(last, Key):
        raise SteamError(f"last must be a collection of variables, got the single key {last!r}: write [{last!r}]")
    last_set = set(last)
    unknown = [v for v in last_set if v not in index]
    if unknown:
        raise UnknownVariableError(f"last names {unknown[0]!r}, which is not among the variables to order")
    # A heap entry is one integer, (group · n + degree) · n + place: compared as the tuple (group, degree, place),
    # with group 1 for the variables of ``last``. ``current`` holds each variable's valid entry (-1 once eliminated).
    group = [n * n if v in last_set else 0 for v in variables] if last_set else [0] * n
    current = []
    for i, a in enumerate(adj):
        a.discard(i)
        current.append(group[i] + len(a) * n + i)
    heap = current.copy()
    heapq.heapify(heap)
    pop, push, order = heapq.heappop, heapq.heappush, []
    while heap:
        entry = pop(heap)
        i = entry % n
        if current[i] != entry:  # already eliminated, or a stale degree
            continue
        current[i] = -1
        order.append(variables[i])
        a = adj[i]
        for u in a:  # eliminating v joins its neighbours into a clique (fill)
            au = adj[u]
            au.discard(i)
            au |= a
            au.discard(u)
            entry = group[u] + len(au) * n + u
            if entry != current[u]:  # an unchanged degree's entry is in the heap already
                current[u] = entry
                push(heap, entry)
    return order


def check_constrained(constrained: object) -> Mapping[Key, float] | None:
    """``constrained`` (GTSAM's ``constrainedKeys``: :func:`min_degree_keys`'s ``first``) of an update or a
    marginalization, SteamError unless a mapping key -> number (every rank, its key ordered now or not) or None; a
    :class:`KeysBelow` (a smoother's timestamps, floats, read at the cost of the keys looked up) is not walked."""
    if constrained is not None and not isinstance(constrained, Mapping):
        raise SteamError(f"constrained must be a mapping key -> number or None, got {constrained!r:.80}")
    for k, r in () if constrained is None or isinstance(constrained, KeysBelow) else constrained.items():
        _rank(k, r)
    return constrained


def _rank(key: Key, r: object) -> float:
    """A rank of ``first``: a float as it is (the smoother's timestamps), anything else checked to be a number."""
    return r if type(r) is float else number(f"the rank of {key!r} among the keys eliminated first", r)


def _first_then_min_degree(
    variables: list[Key], dims: Mapping[Key, int], factor_keys: Iterable[Sequence[Key]], last: list[Key], first: Mapping
) -> list[Key]:
    """:func:`min_degree_keys` with ``first`` (its docstring)."""
    rank = {k: _rank(k, r) for k in variables if (r := first.get(k)) is not None}  # one look-up a variable
    early = sorted((k for k in rank if k not in last), key=rank.__getitem__)
    if not early:
        return min_degree_keys(variables, dims, factor_keys, last)
    groups = [set(keys) for keys in factor_keys]  # a group merged away is left empty in its place
    holding: dict[Key, list[int]] = {v: [] for v in early}  # an early key → the groups naming it, found in one pass
    for i, g in enumerate(groups):
        if not holding.keys().isdisjoint(g):  # most groups name no early key: one test each, no per-key loop
            for k in holding.keys() & g:
                holding[k].append(i)
    for v in early:  # the elimination game on the keys [K12 Alg. 1]: v's factors become one on its neighbours
        touching = [i for i in holding.pop(v) if groups[i]]
        merged = set().union(*(groups[i] for i in touching)) - {v}
        for i in touching:
            groups[i] = set()
        for k in holding.keys() & merged:
            holding[k].append(len(groups))
        groups.append(merged)
    gone = set(early)
    rest = [k for k in variables if k not in gone]
    return early + min_degree_keys(rest, dims, [tuple(g) for g in groups if g], last)


class KeysBelow(Mapping):
    """The entries of ``numbers`` below ``bound``, read in place, never copied: a fixed-lag smoother's timestamps
    older than the newest, the keys it has its solver eliminate first (``min_degree_keys(first=...)``), at the cost
    of the keys looked up rather than of its whole window."""

    def __init__(self, numbers: Mapping[Key, float], bound: float) -> None:
        self.numbers, self.bound = numbers, bound

    def get(self, key: Key, default: float | None = None) -> float | None:  # type: ignore[override]
        t = self.numbers.get(key)
        return t if t is not None and t < self.bound else default

    def __contains__(self, key: object) -> bool:
        return self.get(key) is not None  # type: ignore[arg-type]

    def __getitem__(self, key: Key) -> float:
        t = self.get(key)
        if t is None:
            raise KeyError(key)
        return t

    def __iter__(self) -> Iterator[Key]:
        return (k for k, t in self.numbers.items() if t < self.bound)

    def __len__(self) -> int:
        return sum(1 for _ in self)


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
