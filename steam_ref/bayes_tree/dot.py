"""The Bayes tree in GTSAM's words: its ``dot()`` text and its fill, as GTSAM 4.3 reports them.

:func:`tree_dot` writes a tree as GTSAM's ``BayesTree::dot`` (``ISAM2.dot()`` in Python) does: a Graphviz
digraph, a node per clique named by the integer key of its first frontal (GTSAM's ``Symbol``: the character in
the top byte, the index below) and labelled ``"frontals : separator"`` (frontals in elimination order, the
separator sorted by integer key, a root without ``" : "``), each edge ``parent->child`` just before the child,
depth first. GTSAM's child order comes from its junction tree, so where a clique has several children the set of
lines agrees, their order may not (tests/test_bayes_tree_dot.py compares both ways)::

    digraph G{
    8646911284551352322[label="x1, x2"];
    8646911284551352322->8646911284551352320
    8646911284551352320[label="x0 : x1"];
    }

:func:`clique_nnz` and :func:`tree_nnz` count the nonzeros of R as ``ISAM2::treeNnz()`` does: per clique the
upper triangle of its frontal block and its whole separator block, n_f(n_f + 1)/2 + n_f·n_s (structurally:
entries that happen to be 0 count).  [YIB Eq. 21, 25]
"""

from __future__ import annotations

from collections.abc import Iterable

from ..variables import Key

__all__ = ["gtsam_key", "tree_dot", "clique_nnz", "tree_nnz"]


def gtsam_key(key: Key) -> int:
    """The integer GTSAM's ``Symbol(c, j)`` stands for: ord(c) << 56 | j (for 0 ≤ j < 2⁵⁶, GTSAM's range; a
    negative index, which GTSAM has no Symbol for, still gives each key its own integer)."""
    return (ord(key.symbol) << 56) + int(key.index)


def _label(keys: Iterable[Key]) -> str:
    return ", ".join(f"{k.symbol}{k.index}" for k in keys)


def tree_dot(tree) -> str:
    """The tree (a :class:`~steam_ref.bayes_tree.symbolic.CliqueTree`) as GTSAM's ``BayesTree::dot`` text."""
    lines = ["digraph G{\n"]
    stack: list[tuple[int, int | None]] = [(r, None) for r in reversed(list(tree.roots))]
    while stack:
        cid, parent = stack.pop()
        clique = tree.cliques[cid]
        node = gtsam_key(clique.frontals[0])
        label = _label(clique.frontals)
        if parent is not None:
            lines.append(f"{parent}->{node}\n")
            label += " : " + _label(sorted(clique.separator, key=gtsam_key))
        lines.append(f'{node}[label="{label}"];\n')
        stack.extend((c, node) for c in reversed(tree.children[cid]))
    lines.append("}")
    return "".join(lines)


def clique_nnz(clique) -> int:
    """Nonzeros of a clique's rows of R: n_f(n_f + 1)/2 + n_f·n_s (GTSAM's count)."""
    nf, ns = sum(clique.frontal_dims), sum(clique.separator_dims)
    return nf * (nf + 1) // 2 + nf * ns


def tree_nnz(cliques: Iterable) -> int:
    """Nonzeros of R over ``cliques`` (e.g. ``tree.cliques.values()``), as GTSAM's ``ISAM2::treeNnz()``."""
    return sum(clique_nnz(c) for c in cliques)
