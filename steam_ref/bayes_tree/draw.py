"""Pictures of a Bayes tree and of its R factor (matplotlib, imported only when drawing).

Each clique is a box "frontals : separator", the root on top; an update is shown as two trees:
before (the removed cliques in red) and after (the re-made cliques in orange, the reattached
orphans outlined in blue) [K12 Fig. 3-4].
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from typing import TYPE_CHECKING

import numpy as np

from .symbolic import CliqueTree

if TYPE_CHECKING:
    from .isam import UpdateReport
    from .tree import BayesTree

__all__ = ["snapshot", "tree_layout", "draw_tree", "draw_update", "draw_spy"]

REMOVED, NEW, ORPHAN, PLAIN = "#e45756", "#f58518", "#4c78a8", "#eeeeee"


def snapshot(tree: CliqueTree) -> CliqueTree:
    """A structural copy of the tree (cliques shared, links copied): keep it to draw "before"."""
    out: CliqueTree = CliqueTree()
    out.cliques, out.parent, out.roots = dict(tree.cliques), dict(tree.parent), dict(tree.roots)
    out.children = {c: list(ch) for c, ch in tree.children.items()}
    out.frontal_of = dict(tree.frontal_of)
    return out


def tree_layout(tree: CliqueTree) -> dict[int, tuple[float, float]]:
    """(x, y) of every clique: leaves spread evenly left to right, a parent above its children's middle."""
    pos: dict[int, tuple[float, float]] = {}
    next_x = 0.0
    for c in tree.postorder():  # children first
        depth = len(tree.path_to_root(c)) - 1
        kids = tree.children[c]
        if kids:
            x = float(np.mean([pos[k][0] for k in kids]))
        else:
            x, next_x = next_x, next_x + 1.0
        pos[c] = (x, -float(depth))
    return pos


def _label(clique) -> str:
    front = " ".join(map(str, clique.frontals))
    return f"{front} : {' '.join(map(str, clique.separator))}" if clique.separator else front


def draw_tree(tree: CliqueTree, ax=None, *, fill: Mapping[int, str] | None = None, edge: Mapping[int, str] | None = None, title: str = ""):
    """Draw the cliques as boxes linked to their parents; ``fill``/``edge``: clique id → colour."""
    import matplotlib.pyplot as plt

    ax = ax if ax is not None else plt.gca()
    fill, edge = fill or {}, edge or {}
    pos = tree_layout(tree)
    for c, (x, y) in pos.items():
        p = tree.parent[c]
        if p is not None:
            ax.plot([x, pos[p][0]], [y, pos[p][1]], color="0.6", lw=1, zorder=1)
    for c, (x, y) in pos.items():
        box = dict(boxstyle="round,pad=0.3", fc=fill.get(c, PLAIN), ec=edge.get(c, "0.3"), lw=2.5 if c in edge else 0.8)
        ax.text(x, y, _label(tree.cliques[c]), ha="center", va="center", fontsize=8, bbox=box, zorder=2)
    xs = [x for x, _ in pos.values()] or [0.0]
    ys = [y for _, y in pos.values()] or [0.0]
    ax.set_xlim(min(xs) - 0.8, max(xs) + 0.8)
    ax.set_ylim(min(ys) - 0.6, 0.6)
    ax.set_axis_off()
    ax.set_title(title, fontsize=10)
    return ax


def draw_update(before: CliqueTree, after: CliqueTree, report: UpdateReport, axes=None):
    """Two panels: the tree before an update (removed cliques red) and after (new orange, orphans blue)."""
    import matplotlib.pyplot as plt

    if axes is None:
        _, axes = plt.subplots(1, 2, figsize=(12, 4))
    removed, orphans = set(report.removed_cliques), set(report.orphans)
    draw_tree(before, axes[0], fill={c: REMOVED for c in removed}, edge={c: ORPHAN for c in orphans}, title=f"before update {report.step}: removed in red")
    draw_tree(after, axes[1], fill={c: NEW for c in report.new_cliques}, edge={c: ORPHAN for c in orphans}, title="after: re-made in orange, orphans outlined blue")
    return axes


def draw_spy(tree: BayesTree, ax=None, *, highlight: Collection = (), title: str = "R"):
    """Spy plot of the assembled R (cliques in postorder), the rows of ``highlight`` variables in orange."""
    import matplotlib.pyplot as plt

    ax = ax if ax is not None else plt.gca()
    R, _, ordering = tree.to_dense()
    ax.spy(np.abs(R) > 1e-12, markersize=2, color="0.3")
    for k in highlight:
        o, d = ordering.offset_of[k], ordering.dims[ordering.position[k]]
        ax.axhspan(o - 0.5, o + d - 0.5, color=NEW, alpha=0.3, lw=0)
    ticks = ordering.offsets + np.asarray(ordering.dims) / 2 - 0.5
    ax.set_xticks(ticks, [str(k) for k in ordering.keys], rotation=90, fontsize=6)
    ax.set_yticks(ticks, [str(k) for k in ordering.keys], fontsize=6)
    ax.set_title(title, fontsize=10)
    return ax
