"""Structure of the Bayes tree on six-variable toys: orderings, cliques, and clique surgery.  [K12 Alg. 1-4]

The toy used throughout has factors (a,c) (b,c) (c,d) (d,e) (d,f) (e,f). Eliminated in the order
a b c d e f, the separators are a:{c} b:{c} c:{d} d:{e,f} e:{f} f:{}, and the tree is

            [d e f]            root: d, e, f frontal
               |
            [c : d]
            /     \\
       [a : c]   [b : c]
"""

from __future__ import annotations

import itertools
from collections import defaultdict

import numpy as np
import pytest

from steam_ref.bayes_tree.symbolic import (
    CliqueTree,
    SymbolicClique,
    build_cliques,
    symbolic_elimination,
)
from steam_ref.errors import SteamError, UnknownVariableError
from steam_ref.linear.ordering import constrained_min_degree

TOY = [("a", "c"), ("b", "c"), ("c", "d"), ("d", "e"), ("d", "f"), ("e", "f")]
ORDER = list("abcdef")
UNIT: defaultdict = defaultdict(lambda: 1)  # every variable of size 1: these orderings are symbolic


def toy_tree(order=ORDER, factors=TOY) -> tuple[CliqueTree, dict[str, int]]:
    """The toy's tree, and the id of the clique where each variable is frontal."""
    tree: CliqueTree = CliqueTree()
    cliques = build_cliques(order, factors)
    tree.insert_eliminated(cliques, [c.parent for c in cliques])
    return tree, dict(tree.frontal_of)


def fill(order, factors) -> int:
    """Number of (variable, separator-variable) pairs: the off-diagonal blocks of R."""
    seps, _ = symbolic_elimination(order, factors)
    return sum(len(s) for s in seps.values())


# --- orderings ------------------------------------------------------------------------------


def test_symbolic_elimination_separators_by_hand():
    seps, owner = symbolic_elimination(ORDER, TOY)
    assert seps == {"a": ("c",), "b": ("c",), "c": ("d",), "d": ("e", "f"), "e": ("f",), "f": ()}
    assert owner == ["a", "b", "c", "d", "d", "e"]  # first variable of each factor in the order


def test_symbolic_elimination_matches_dense_cholesky_pattern(rng):
    """The separators are the off-diagonal pattern of the Cholesky factor of a random SPD matrix."""
    n = 9
    factors = [tuple(sorted(rng.choice(n, size=rng.integers(1, 4), replace=False).tolist())) for _ in range(12)]
    factors += [(i,) for i in range(n)]
    order = rng.permutation(n).tolist()
    A = np.zeros((len(factors), n))
    for r, f in enumerate(factors):
        A[r, list(f)] = rng.normal(size=len(f))
    P = A[:, order]
    L = np.linalg.cholesky(P.T @ P + np.eye(n))
    seps, _ = symbolic_elimination(order, factors)
    for j, v in enumerate(order):
        pattern = {order[i] for i in range(j + 1, n) if abs(L[i, j]) > 1e-12}
        assert set(seps[v]) == pattern


def test_min_degree_is_a_permutation_with_constrained_variables_last(rng):
    variables = list(range(12))
    factors = [tuple(rng.choice(12, size=2, replace=False).tolist()) for _ in range(20)] + [(i,) for i in range(12)]
    last = [3, 7, 0]
    order = constrained_min_degree(variables, UNIT, factors, last=last)
    assert sorted(order) == variables
    assert set(order[-3:]) == set(last)


def test_min_degree_eliminates_a_path_without_fill():
    # a - b - c - d - e - f - g, given in a scrambled order: eliminating from the ends costs no fill.
    variables = list("dgbfaec")
    factors = [(x, y) for x, y in zip("abcdef", "bcdefg", strict=True)]
    order = constrained_min_degree(variables, UNIT, factors)
    assert fill(order, factors) == len(factors)


def test_min_degree_no_worse_than_natural_on_a_loop_closure():
    """A chain x0..x9 with a loop closure x0-x9 and two landmarks seen from many states."""
    xs = [f"x{i}" for i in range(10)]
    factors = [(a, b) for a, b in itertools.pairwise(xs)] + [("x0", "x9")]
    factors += [(x, "l0") for x in xs[::2]] + [(x, "l1") for x in xs[1::3]]
    variables = xs + ["l0", "l1"]
    natural = fill(variables, factors)
    md = fill(constrained_min_degree(variables, UNIT, factors), factors)
    assert md <= natural
    constrained = constrained_min_degree(variables, UNIT, factors, last=["x9"])
    assert constrained[-1] == "x9" and sorted(constrained) == sorted(variables)


def test_unknown_variable_in_factor_is_named():
    with pytest.raises(UnknownVariableError, match="'z'"):
        constrained_min_degree(list("ab"), UNIT, [("a", "z")])
    with pytest.raises(UnknownVariableError, match="'z'"):
        symbolic_elimination(list("ab"), [("a", "z")])
    with pytest.raises(SteamError, match="twice"):
        symbolic_elimination(list("aba"), [("a", "b")])


# --- cliques --------------------------------------------------------------------------------


def test_build_cliques_by_hand():
    cliques = build_cliques(ORDER, TOY)
    by_frontals = {c.frontals: c for c in cliques}
    assert set(by_frontals) == {("a",), ("b",), ("c",), ("d", "e", "f")}
    root, c, a, b = by_frontals[("d", "e", "f")], by_frontals[("c",)], by_frontals[("a",)], by_frontals[("b",)]
    assert root.separator == () and root.parent is None
    assert c.separator == ("d",) and cliques[c.parent] is root
    assert a.separator == ("c",) and cliques[a.parent] is c
    assert b.separator == ("c",) and cliques[b.parent] is c
    # each factor is eliminated in the clique of its first variable
    assert a.factors == (0,) and b.factors == (1,) and c.factors == (2,) and root.factors == (3, 4, 5)
    # children are listed before parents
    for i, cl in enumerate(cliques):
        assert cl.parent is None or cl.parent > i


@pytest.mark.parametrize("order", [list(p) for p in itertools.islice(itertools.permutations("abcdef"), 0, 720, 37)])
def test_every_order_gives_a_valid_tree(order):
    tree, _ = toy_tree(order)
    assert tree.problems() == []
    # the tree's own elimination order reproduces it: same frontal/separator sets
    again, _ = toy_tree(tree.elimination_order())
    sets = lambda t: sorted((tuple(sorted(c.frontals)), tuple(sorted(c.separator))) for c in t.cliques.values())
    assert sets(again) == sets(tree)


def test_problems_reports_broken_structure():
    tree, ids = toy_tree()
    assert tree.problems() == []
    c = ids["c"]
    tree.cliques[c] = SymbolicClique(("c",), ("x",), None, ())  # separator not in the parent
    assert any("not within its parent" in p for p in tree.problems())
    tree, ids = toy_tree()
    tree.cliques[ids["a"]] = SymbolicClique(("a", "c"), (), None, ())  # c frontal twice
    assert any("frontal in 2 cliques" in p for p in tree.problems())


# --- clique surgery -------------------------------------------------------------------------


def test_cliques_involving_follows_the_separators():
    tree, ids = toy_tree()
    assert sorted(tree.cliques_involving("c")) == sorted([ids["c"], ids["a"], ids["b"]])
    assert sorted(tree.cliques_involving("d")) == sorted([ids["d"], ids["c"]])
    assert tree.cliques_involving("e") == [ids["e"]]


def test_remove_top_for_a_root_variable():
    # A new factor on e removes only the root [d e f]; the orphan is [c : d] (with a, b below it).
    tree, ids = toy_tree()
    removed, orphans = tree.remove_top([ids["e"]])
    assert list(removed) == [ids["e"]]
    assert orphans == [ids["c"]]
    assert set(tree.cliques) == {ids["a"], ids["b"], ids["c"]}


def test_remove_top_for_a_leaf_variable():
    # A new factor on a removes [a : c], [c : d] and the root; the orphan is [b : c].
    tree, ids = toy_tree()
    removed, orphans = tree.remove_top([ids["a"]])
    assert set(removed) == {ids["a"], ids["c"], ids["d"]}
    assert orphans == [ids["b"]]
    assert set(tree.frontal_of) == {"b"}


def test_reeliminate_and_reattach_orphan():
    """Add a factor (a, e): re-eliminate a c d e f with a, e last; [b : c] hangs under c's clique."""
    tree, ids = toy_tree()
    removed, orphans = tree.remove_top([ids["a"], ids["e"]])
    variables = [v for c in removed.values() for v in c.frontals]
    assert sorted(variables) == list("acdef")
    owned = [TOY[j] for c in removed.values() for j in c.factors]
    factors = owned + [("a", "e")] + [tree.cliques[o].separator for o in orphans]
    order = constrained_min_degree(variables, UNIT, factors, last=["a", "e"])
    assert set(order[-2:]) == {"a", "e"}
    cliques = build_cliques(order, factors)
    new_ids = tree.insert_eliminated(cliques, [c.parent for c in cliques])
    owner = cliques.index(next(c for c in cliques if len(factors) - 1 in c.factors))
    tree.attach(orphans[0], new_ids[owner])
    assert tree.parent[ids["b"]] == tree.frontal_of["c"]
    assert tree.problems() == []
    assert sorted(tree.frontal_of) == list("abcdef")


def test_unattached_orphan_is_a_problem():
    tree, ids = toy_tree()
    tree.remove_top([ids["e"]])
    assert any("unattached" in p for p in tree.problems())


def test_postorder_puts_children_first():
    tree, _ = toy_tree()
    order = tree.postorder()
    seen = set()
    for c in order:
        assert all(ch in seen for ch in tree.children[c])
        seen.add(c)
    assert sorted(order) == sorted(tree.cliques)
