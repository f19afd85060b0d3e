"""Exact minimum degree, the ordering of iSAM2, and the elimination game it plays.  [K12 Alg. 1, Sec. 5]

Eliminating a variable θᵢ joins every factor adjacent to it into one on its separator sᵢ [YIB Eq. 24]; on the
variable graph, it joins θᵢ's neighbours into a clique (the fill). Playing that game with the variable of least
degree eliminated next gives a minimum-degree order (:func:`min_degree_elimination`, :func:`min_degree_keys`, the keys
alone); the separators it meets on the way are the ones the Bayes tree's cliques are made of, so it hands them on
(:class:`Game`) and :func:`steam_ref.bayes_tree.symbolic.build_cliques` does not play it again. For an order made
elsewhere, :func:`elimination_game` plays it alone. Variables are worked on as integer places (ints hash and sort
faster than keys). :mod:`steam_ref.linear.ordering` names every ordering, these included.
"""

from __future__ import annotations

import heapq
from collections.abc import Hashable, Iterable, Iterator, Mapping, Sequence
from typing import NamedTuple

from ..arguments import number
from ..errors import SteamError, UnknownVariableError
from ..variables import Key

__all__ = ["Game", "KeysBelow", "elimination_game", "min_degree_elimination", "min_degree_keys"]


def _sizes(keys: Sequence[Key], dims: Mapping[Key, int]) -> tuple[int, ...]:
    """The size of each key, read from ``dims``; UnknownVariableError naming a key it lacks."""
    try:
        return tuple(dims[k] for k in keys)
    except KeyError as exc:
        raise UnknownVariableError(f"dims gives no size for variable {exc.args[0]!r}") from None


def _places(index: Mapping[Key, int], factor_keys: Iterable[Sequence[Key]], among: str) -> list[list[int]]:
    """Each factor's variables as their places in ``index``; UnknownVariableError names one ``index`` lacks."""
    factor_keys, place = list(factor_keys), index.__getitem__
    try:
        return [list(map(place, keys)) for keys in factor_keys]  # one pass in C: a list per factor, no generator
    except KeyError as exc:
        missing = exc.args[0]
    i, keys = next(
        ((i, keys) for i, keys in enumerate(factor_keys) if missing in keys), ("?", "a key")
    )  # an iterator is spent
    raise UnknownVariableError(
        f"factor_keys[{i}] = {keys!r} names {missing!r}, which is not among the {among} to order"
    )


class Game(NamedTuple):
    """What the elimination game of an order found, by place in the order: what the cliques are built from.  [K12 Alg. 1]"""

    separators: list[list[int]]  # sᵢ of each place, the neighbours it had when eliminated, as places, increasing
    owner: list[int]  # for each factor, the place of its variable eliminated first


def elimination_game(order: Sequence[Hashable], factor_keys: Iterable[Sequence[Hashable]]) -> Game:
    """The game of ``order`` on factors given by their variables (any hashable names), played alone.  [K12 Alg. 1]

    Eliminating θᵢ takes every factor adjacent to it, the original ones and those left by earlier eliminations, and
    leaves one on sᵢ = (their variables) − {θᵢ} [YIB Eq. 24], adjacent in turn to sᵢ's first-eliminated variable.
    """
    pos = {v: i for i, v in enumerate(order)}
    if len(pos) != len(order):
        raise SteamError("an elimination order lists a variable twice")
    place, owner = pos.__getitem__, []
    pending: list[set[int]] = [set() for _ in order]  # by place: the places of the factors waiting for it
    try:
        for keys in factor_keys:
            owner.append(first := min(places := list(map(place, keys))))
            pending[first].update(places)
    except KeyError as exc:
        raise UnknownVariableError(f"a factor names {exc.args[0]!r}, which is not in the elimination order") from None
    separators = []
    for i, s in enumerate(pending):
        s.discard(i)
        separators.append(sep := sorted(s))
        if sep:  # the new factor f(sᵢ) waits for the first variable of sᵢ  [YIB Eq. 24]
            pending[sep[0]].update(sep)
    return Game(separators, owner)


def min_degree_keys(
    variables: Sequence[Key],
    dims: Mapping[Key, int],
    factor_keys: Iterable[Sequence[Key]],
    last: Iterable[Key] = (),
    first: Mapping[Key, float] | None = None,
) -> list[Key]:
    """A greedy minimum-degree elimination order with the variables in ``last`` eliminated last: the keys of
    :func:`min_degree_elimination` (its docstring)."""
    return min_degree_elimination(variables, dims, factor_keys, last, first, game=False)[0]


def min_degree_elimination(
    variables: Sequence[Key],
    dims: Mapping[Key, int],
    factor_keys: Iterable[Sequence[Key]],
    last: Iterable[Key] = (),
    first: Mapping[Key, float] | None = None,
    *,
    game: bool = True,
) -> tuple[list[Key], Game | None]:
    """A greedy minimum-degree elimination order with the variables in ``last`` eliminated last, and the
    :class:`Game` it played (None with ``first``, or a factor of no variable: :func:`elimination_game` plays it;
    or when ``game`` is False).

    ``dims``: the size of each variable (an :class:`~.ordering.Ordering` carries them); ``factor_keys``: the
    variables of each factor.

    The degree of a variable is its number of neighbours in the current elimination graph (the
    variable graph after the eliminations so far, fill included), so this is exact minimum degree,
    not AMD's approximation. Ties go to the variable listed first in ``variables``. Variables in
    ``last`` are ordered among themselves by minimum degree too, after all others: this is the
    constrained ordering iSAM2 obtains from CCOLAMD, which keeps the variables touched by new
    factors near the root so the next update removes little of the tree.  [K12 Sec. 5]

    ``first`` (GTSAM's ``constrainedKeys``): the variables it names (and ``last`` does not) are eliminated before
    all others, in increasing order of the number it maps each to (ties in the order of ``variables``), and the
    rest by minimum degree on the graph their elimination leaves: a fixed-lag smoother puts the variables next to
    leave its window there, so that they sit in leaf cliques and are cut off with no re-elimination.

    Eliminating a variable joins its neighbours into a clique: its neighbours then are its separator sᵢ, the
    variables of the factor its elimination leaves [YIB Eq. 24], so the order comes with the elimination game
    played (:func:`steam_ref.bayes_tree.symbolic.build_cliques` takes it).
    """
    if first is not None:
        return _first_then_min_degree(list(variables), dims, factor_keys, list(last), first), None
    variables = list(variables)
    index = {v: i for i, v in enumerate(variables)}
    if len(index) != len(variables):
        twice = next(v for i, v in enumerate(variables) if index[v] != i)
        raise SteamError(f"variables lists {twice!r} twice")
    _sizes(variables, dims)  # names a variable dims lacks, before any work
    n = len(variables)
    adj: list[set[int]] = [set() for _ in range(n)]  # by place in ``variables``: integers hash faster than keys
    for places in (placed := _places(index, factor_keys, "variables")):
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
    pop, push, eliminated = heapq.heappop, heapq.heappush, []
    while heap:
        entry = pop(heap)
        i = entry % n
        if current[i] != entry:  # already eliminated, or a stale degree
            continue
        current[i] = -1
        eliminated.append(i)
        a = adj[i]  # sᵢ: left as it is from here on (no other set holds i any more)
        for u in a:  # eliminating v joins its neighbours into a clique (fill)
            au = adj[u]
            au.discard(i)
            au |= a
            au.discard(u)
            entry = group[u] + len(au) * n + u
            if entry != current[u]:  # an unchanged degree's entry is in the heap already
                current[u] = entry
                push(heap, entry)
    order = list(map(variables.__getitem__, eliminated))
    if not game or not all(placed):  # not asked for, or a factor of no variable, which no variable owns
        return order, None
    at = [0] * n  # each variable's place in the order
    for p, i in enumerate(eliminated):
        at[i] = p
    place = at.__getitem__
    owner = [min(map(place, p)) for p in placed]  # each factor's variable eliminated first
    return order, Game([sorted(map(place, adj[i])) for i in eliminated], owner)


def _first_then_min_degree(
    variables: list[Key], dims: Mapping[Key, int], factor_keys: Iterable[Sequence[Key]], last: list[Key], first: Mapping
) -> list[Key]:
    """:func:`min_degree_keys` with ``first`` (its docstring)."""
    rank = {k: r for k in variables if (r := first.get(k)) is not None}  # one look-up a variable
    for k, r in rank.items():
        if type(r) is not float:  # a float passes as it is (the smoother's timestamps); anything else is checked
            rank[k] = number(f"the rank of {k!r} among the keys eliminated first", r)
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
