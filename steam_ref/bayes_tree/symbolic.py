"""The structure of a Bayes tree: orderings → cliques, and clique surgery.  [K11, K12 Alg. 1-4]

Nothing here knows a number: variables are any hashable names, a factor the tuple of variables it
touches; the elimination order comes from :mod:`steam_ref.linear.ordering`.

- :func:`symbolic_elimination` plays the elimination game [K12 Alg. 1]: eliminating θᵢ joins all
  factors adjacent to it into one on its separator sᵢ  [YIB Eq. 24-25].
- :func:`build_cliques` groups the conditionals P(θᵢ | sᵢ) into cliques [K12 Alg. 2].
- :class:`CliqueTree` links cliques into a forest and edits it: remove the cliques on the paths
  from some variables to the root, leaving orphaned subtrees, and reattach them [K12 Alg. 3-4]; cut
  leaves off. Every edit is recorded in an undo log (:mod:`.undo`), the solver's own when it has one.
"""

from __future__ import annotations

from collections.abc import Hashable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Generic, Protocol, TypeVar

from ..errors import SteamError, UnknownVariableError
from ..linear.amalgamation import amalgamate
from .dot import tree_dot
from .undo import UndoLog

__all__ = ["SymbolicClique", "CliqueTree", "symbolic_elimination", "build_cliques"]

V = Hashable


@dataclass(frozen=True)
class SymbolicClique:
    """One clique of an elimination: P(frontals | separator), structure only."""

    frontals: tuple  # variables eliminated here, in elimination order
    separator: tuple  # variables shared with the parent clique, in elimination order
    parent: int | None  # index of the parent in the clique list; None for a root
    factors: tuple[int, ...]  # indices of the input factors eliminated here (first variable frontal here)


def symbolic_elimination(order: Sequence[V], factor_keys: Sequence[Sequence[V]]) -> tuple[dict, list]:
    """The separator sᵢ of every variable, and which variable eliminates each factor.  [K12 Alg. 1]

    Eliminating θᵢ takes every factor adjacent to it, the original ones and those left by earlier
    eliminations, and leaves one new factor on sᵢ = (their variables) − {θᵢ}  [YIB Eq. 24]. The new
    factor is in turn adjacent to the first-eliminated variable of sᵢ, θᵢ's parent.
    Returns ``(separators, owner)``: variable → sᵢ (in elimination order), and for each factor the
    first of its variables in ``order``."""
    separators, owner = _elimination_game(order := list(order), factor_keys)
    named = {v: tuple(map(order.__getitem__, s)) for v, s in zip(order, separators, strict=True)}
    return named, [order[i] for i in owner]


def _elimination_game(order: list, factor_keys: Sequence[Sequence[V]]) -> tuple[list[list[int]], list[int]]:
    """:func:`symbolic_elimination` on places in ``order`` (ints hash and sort faster than keys): sᵢ sorted, owners."""
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
    return separators, owner


def build_cliques(
    order: Sequence[V], factor_keys: Sequence[Sequence[V]], dims: Mapping | None = None, zeros: float = 0.0
) -> list[SymbolicClique]:
    """Cliques of the Bayes tree of ``order``, children before parents.  [K12 Alg. 2]

    Conditionals are visited in reverse elimination order. P(θᵢ | sᵢ) joins the clique C of its
    parent (the clique holding sᵢ's first variable as a frontal) when sᵢ equals all of C's
    variables; otherwise it starts a new child clique of C (or a new root when sᵢ is empty).
    ``zeros`` > 0: cliques then merge into their parents (``dims``: :mod:`steam_ref.linear.amalgamation`)."""
    separators, owner = _elimination_game(order := list(order), factor_keys)
    clique_of = [0] * len(order)  # place → the clique where it is frontal
    frontals: list[list[int]] = []  # per clique, the places of its frontals in reverse elimination order
    seps: list[list[int]] = []  # per clique, the places of its separator
    parents: list[int | None] = []
    for i in reversed(range(len(order))):
        sep = separators[i]
        parent = clique_of[sep[0]] if sep else None
        # sᵢ lies within {sᵢ's first variable} ∪ its separator, so within the parent's variables: equal sizes, equal sets
        if parent is not None and len(sep) == len(frontals[parent]) + len(seps[parent]):
            frontals[parent].append(i)  # [K12 Alg. 2]: sᵢ = F_p ∪ S_p, θᵢ joins the parent clique
            clique_of[i] = parent
            continue
        clique_of[i] = len(frontals)
        frontals.append([i])
        seps.append(sep)
        parents.append(parent)
    sizes = [1] * len(order) if dims is None or not zeros else [dims[v] for v in order]  # read once, by place
    home = amalgamate(frontals, seps, parents, sizes, zeros) if zeros else range(len(frontals))  # merged [AG89]
    kept = [c for c, h in enumerate(home) if h == c]  # made parents first; numbered so children come first
    index = {c: len(kept) - 1 - i for i, c in enumerate(kept)}
    owned: list[list[int]] = [[] for _ in home]  # by clique: the factors it eliminates
    for j, i in enumerate(owner):
        owned[home[clique_of[i]]].append(j)
    name, up = order.__getitem__, [None if p is None else index[home[p]] for p in parents]  # a kept clique's parent
    return [
        SymbolicClique(tuple(map(name, reversed(frontals[c]))), tuple(map(name, seps[c])), up[c], tuple(owned[c]))
        for c in reversed(kept)
    ]


class _HasVariables(Protocol):
    # read-only members, so that a frozen dataclass (the Bayes tree's Clique) is one
    @property
    def frontals(self) -> tuple: ...
    @property
    def separator(self) -> tuple: ...


C = TypeVar("C", bound=_HasVariables)


class CliqueTree(Generic[C]):
    """A forest of cliques with integer ids, and the edits iSAM2 makes to it.  [K12 Alg. 3-4]

    Holds any clique objects with ``frontals`` and ``separator`` (symbolic or numeric). Each edit
    costs time proportional to the cliques it touches, never to the size of the tree."""

    def __init__(self, log: UndoLog | None = None) -> None:
        self.cliques: dict[int, C] = {}  # id → clique
        self.parent: dict[int, int | None] = {}  # id → parent id (None for a root)
        self.children: dict[int, list[int]] = {}  # id → child ids (a list is replaced, never edited in place)
        self.frontal_of: dict = {}  # variable → id of the clique that eliminates it
        self.roots: dict[int, None] = {}  # ids of the roots (an ordered set)
        self._next_id = 0
        self.log = UndoLog() if log is None else log  # where every edit is recorded (a solver's: :mod:`.undo`)

    def __len__(self) -> int:
        return len(self.cliques)

    def dot(self) -> str:
        """The tree as GTSAM's ``ISAM2.dot()`` prints it: "frontals : separator" labels (:mod:`.dot`)."""
        return tree_dot(self)

    def add(self, clique: C, parent: int | None) -> int:
        """Insert a clique under ``parent`` (None: as a root); returns its id."""
        cid = self._next_id
        for v in clique.frontals:
            if v in self.frontal_of:
                raise SteamError(f"variable {v!r} is already frontal in clique {self.frontal_of[v]}")
        self.log.record(self._unadd, cid, clique.frontals)  # one record undoes it all but the parent's new child
        self._next_id = cid + 1
        self.cliques[cid], self.children[cid], self.parent[cid] = clique, [], None
        for v in clique.frontals:
            self.frontal_of[v] = cid
        self.attach(cid, parent)
        return cid

    def _unadd(self, cid: int, frontals: tuple) -> None:
        """Undo :meth:`add` of clique ``cid`` (idempotent; its parent's list of children is recorded apart)."""
        self._next_id = cid
        for store in (self.cliques, self.children, self.parent, self.roots):
            store.pop(cid, None)
        for v in frontals:
            if self.frontal_of.get(v) == cid:
                del self.frontal_of[v]

    def attach(self, cid: int, parent: int | None) -> None:
        """Hang clique ``cid`` (a detached subtree) under ``parent`` (None: make it a root)."""
        self.log.set(self.parent, cid, parent)
        if parent is None:
            self.log.keep(self.roots)
            self.roots[cid] = None
        else:
            self.log.set(self.children, parent, [*self.children[parent], cid])

    def replace(self, cid: int, clique: C) -> None:
        """Put ``clique`` in the place of clique ``cid``, with the same variables (e.g. one more factor id)."""
        self.log.set(self.cliques, cid, clique)

    def insert_eliminated(
        self,
        cliques: Sequence[C],
        parents: Sequence[int | None],
        orphans: Sequence[int] = (),
        owners: Sequence[int] = (),
    ) -> list[int]:
        """Add the cliques of one elimination (children first; ``parents`` index into the list) and hang each
        orphan under ``cliques[owner]``, the new clique that eliminated its cached f(S) ([K12 Alg. 6], its last step);
        returns the new ids."""
        ids: list[int | None] = [None] * len(cliques)
        for i in reversed(range(len(cliques))):  # parents before children
            p = parents[i]
            ids[i] = self.add(cliques[i], None if p is None else ids[p])
        for o, owner in zip(orphans, owners, strict=True):
            self.attach(o, ids[owner])
        return ids  # type: ignore[return-value]

    def clique_containing(self, variable: V) -> int:
        """Id of the clique where ``variable`` is frontal."""
        try:
            return self.frontal_of[variable]
        except KeyError:
            raise UnknownVariableError(f"variable {variable!r} is not in the Bayes tree") from None

    def cliques_involving(self, variable: V) -> list[int]:
        """Every clique holding ``variable``, frontal or in its separator.  [K12 Alg. 5]

        They form a subtree rooted at the clique where it is frontal (running intersection), so
        a walk down from there that stops at cliques without it finds them all."""
        top = self.clique_containing(variable)
        found, stack = [], [top]
        while stack:
            c = stack.pop()
            found.append(c)
            stack.extend(ch for ch in self.children[c] if variable in self.cliques[ch].separator)
        return found

    def _put_back(self, cid: int, clique: C, parent: int | None, children: list[int]) -> None:
        """Undo the removal of clique ``cid`` (its links to its children are theirs to restore)."""
        self.cliques[cid], self.parent[cid], self.children[cid] = clique, parent, children
        for v in clique.frontals:
            self.frontal_of[v] = cid

    def _remove(self, cid: int) -> int | None:
        """Take clique ``cid`` out (recorded); returns its parent. Its children keep pointing at it."""
        clique, parent = self.cliques[cid], self.parent[cid]
        self.log.record(self._put_back, cid, clique, parent, self.children[cid])
        del self.cliques[cid], self.parent[cid], self.children[cid]
        self.roots.pop(cid, None)
        for v in clique.frontals:
            del self.frontal_of[v]
        return parent

    def remove_top(self, start: Iterable[int]) -> tuple[dict[int, C], list[int]]:
        """Remove the cliques ``start`` and all their ascendants up to the root.  [K12 Alg. 3-4]

        Returns ``(removed, orphans)``: id → clique of each removed clique (in the order found),
        and the ids of the children of removed cliques that were not removed. Orphans stay in the
        tree, detached (parent None, not roots), until :meth:`attach` hangs them back."""
        removed: dict[int, C] = {}
        for first in start:
            c: int | None = first
            while c is not None and c not in removed:
                removed[c] = self.cliques[c]
                c = self.parent[c]
        orphans = [ch for c in removed for ch in self.children[c] if ch not in removed]
        self.log.keep(self.roots)
        for c in removed:
            self._remove(c)
        for o in orphans:
            self.log.set(self.parent, o, None)
        return removed, orphans

    def cut(self, cids: Iterable[int]) -> dict[int, int | None]:
        """Delete the cliques ``cids``; each child of one that is not deleted hangs under the nearest ancestor
        that is not (a root when there is none). Returns child → its new parent.

        Marginalizing leaves (:mod:`.marginalization`): the caller vouches that every such child's separator lies
        within its new parent's variables (it holds none of the deleted frontals)."""
        gone = set(cids)
        moved: dict[int, int | None] = {}
        for c in gone:
            keep = [ch for ch in self.children[c] if ch not in gone]
            if keep:
                up = self.parent[c]
                while up is not None and up in gone:
                    up = self.parent[up]
                moved.update(dict.fromkeys(keep, up))
        self.log.keep(self.roots)
        for c in gone:
            p = self._remove(c)
            if p is not None and p not in gone:
                self.log.set(self.children, p, [ch for ch in self.children[p] if ch != c])
        for ch, up in moved.items():
            self.attach(ch, up)
        return moved

    def snapshot(self) -> CliqueTree[C]:
        """A structural copy (cliques shared, links copied), e.g. the tree "before" an update to draw.

        Later edits of this tree leave the copy as it was; the copy is a plain :class:`CliqueTree`."""
        out: CliqueTree[C] = CliqueTree()
        out.cliques, out.parent, out.roots = dict(self.cliques), dict(self.parent), dict(self.roots)
        out.children = {c: list(ch) for c, ch in self.children.items()}
        out.frontal_of = dict(self.frontal_of)
        out._next_id = self._next_id
        return out

    def path_to_root(self, cid: int) -> list[int]:
        """Ids from ``cid`` up to its root, inclusive."""
        path = []
        c: int | None = cid
        while c is not None:
            path.append(c)
            c = self.parent[c]
        return path

    def postorder(self) -> list[int]:
        """All clique ids, every child before its parent (a valid elimination order of the cliques)."""
        out: list[int] = []
        stack = [(r, False) for r in reversed(list(self.roots))]
        while stack:
            c, expanded = stack.pop()
            if expanded:
                out.append(c)
                continue
            stack.append((c, True))
            stack.extend((ch, False) for ch in reversed(self.children[c]))
        return out

    def elimination_order(self) -> list:
        """Variables in an order that eliminates into this tree: cliques in postorder, frontals in order."""
        return [v for c in self.postorder() for v in self.cliques[c].frontals]

    def problems(self) -> list[str]:
        """What is wrong with the structure (empty when valid).  Visits the whole tree: for tests.

        Checks: links are consistent; each variable is frontal in exactly one clique; each
        separator lies within the parent clique's variables; the cliques holding any one
        variable form a connected subtree (running intersection); roots have empty separators."""
        out: list[str] = []
        frontal_count: dict = {}
        for cid, clique in self.cliques.items():
            for v in clique.frontals:
                frontal_count[v] = frontal_count.get(v, 0) + 1
                if self.frontal_of.get(v) != cid:
                    out.append(f"frontal_of[{v!r}] is {self.frontal_of.get(v)}, but {v!r} is frontal in clique {cid}")
            if set(clique.frontals) & set(clique.separator):
                out.append(f"clique {cid} has a variable both frontal and in its separator")
            p = self.parent.get(cid)
            if p is None:
                if cid not in self.roots:
                    out.append(f"clique {cid} has no parent but is not a root (an unattached orphan?)")
                if clique.separator:
                    out.append(f"root clique {cid} has a non-empty separator {clique.separator}")
                continue
            if cid not in self.children.get(p, []):
                out.append(f"clique {cid} is not among the children of its parent {p}")
            pvars = set(self.cliques[p].frontals) | set(self.cliques[p].separator)
            if not set(clique.separator) <= pvars:
                out.append(f"separator {clique.separator} of clique {cid} is not within its parent {p}'s variables")
        out.extend(f"variable {v!r} is frontal in {n} cliques" for v, n in frontal_count.items() if n != 1)
        if len(self.frontal_of) != len(frontal_count):
            out.append("frontal_of names variables that are in no clique")
        out.extend(self._running_intersection_problems())
        return out

    def _running_intersection_problems(self) -> list[str]:
        """Each variable's cliques are connected: exactly one of them has no parent holding the variable."""
        tops: dict = {}
        for cid, clique in self.cliques.items():
            p = self.parent.get(cid)
            pvars = set() if p is None else set(self.cliques[p].frontals) | set(self.cliques[p].separator)
            for v in tuple(clique.frontals) + tuple(clique.separator):
                if v not in pvars:
                    tops.setdefault(v, []).append(cid)
        return [f"the cliques holding {v!r} are not connected (tops {t})" for v, t in tops.items() if len(t) != 1]
