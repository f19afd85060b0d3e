"""The Bayes tree's figures: its cliques, an update before and after [K12 Fig. 3-4], its R factor.

Like :mod:`steam_ref.plot.figures`, nothing from steam_ref but its exceptions is imported at run time; each
function takes the tree (or anything with the attributes it reads), draws on the axes given (or new
ones) and returns them, saving to ``path`` if given. :mod:`steam_ref.plot.figures` re-exports them.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import UnknownVariableError
from .base import axes as _axes
from .base import save as _save

if TYPE_CHECKING:
    from ..bayes_tree.isam import UpdateReport
    from ..bayes_tree.symbolic import CliqueTree
    from ..bayes_tree.tree import BayesTree

__all__ = ["tree_layout", "draw_tree", "draw_update", "draw_spy"]

# clique colours of a Bayes tree update [K12 Fig. 3-4]
_REMOVED, _NEW, _ORPHAN, _PLAIN = "#e45756", "#f58518", "#4c78a8", "#eeeeee"


# --- The Bayes tree  [K12 Fig. 3-4] -------------------------------------------------------------


def tree_layout(tree: CliqueTree) -> dict[int, tuple[float, float]]:
    """(x, y) of every clique: leaves spread evenly left to right, a parent above its children's
    middle; y = -depth, so the roots are at y = 0."""
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


def _clique_label(clique: Any) -> str:
    """ "frontals : separator", or just the frontals for a root."""
    front = " ".join(map(str, clique.frontals))
    return f"{front} : {' '.join(map(str, clique.separator))}" if clique.separator else front


def draw_tree(
    tree: CliqueTree,
    ax: Any = None,
    *,
    fill: Mapping[int, str] | None = None,
    edge: Mapping[int, str] | None = None,
    title: str = "",
    path: str | None = None,
) -> Any:
    """Each clique a box "frontals : separator" linked to its parent, the roots on top.

    tree: a :class:`~steam_ref.bayes_tree.symbolic.CliqueTree` (a BayesTree, or a snapshot of one);
    fill, edge: clique id → colour of its box and of its outline.
    """
    ax = _axes(ax, path, figsize=(8, 4))
    fill, edge = fill or {}, edge or {}
    pos = tree_layout(tree)
    for c, (x, y) in pos.items():
        p = tree.parent[c]
        if p is not None:
            ax.plot([x, pos[p][0]], [y, pos[p][1]], color="0.6", lw=1, zorder=1)
    for c, (x, y) in pos.items():
        box = dict(
            boxstyle="round,pad=0.3", fc=fill.get(c, _PLAIN), ec=edge.get(c, "0.3"), lw=2.5 if c in edge else 0.8
        )
        ax.text(x, y, _clique_label(tree.cliques[c]), ha="center", va="center", fontsize=8, bbox=box, zorder=2)
    xs = [x for x, _ in pos.values()] or [0.0]
    ys = [y for _, y in pos.values()] or [0.0]
    ax.set_xlim(min(xs) - 0.8, max(xs) + 0.8)
    ax.set_ylim(min(ys) - 0.6, 0.6)
    ax.set_axis_off()
    ax.set_title(title, fontsize=10)
    return _save(ax, path)


def draw_update(
    before: CliqueTree, after: CliqueTree, report: UpdateReport, axes: Any = None, path: str | None = None
) -> Any:
    """Two panels: the tree before an update (removed cliques red) and after it (re-made cliques
    orange, orphans outlined blue).  [K12 Fig. 3-4]

    before: ``tree.snapshot()`` taken before the update; report: any object with ``step``,
    ``removed_cliques``, ``orphans`` and ``new_cliques`` (clique ids), e.g. an UpdateReport.
    """
    axes = _axes(axes, path, ncols=2, figsize=(12, 4))
    removed, orphans = set(report.removed_cliques), set(report.orphans)
    outline = dict.fromkeys(orphans, _ORPHAN)
    draw_tree(
        before,
        axes[0],
        fill=dict.fromkeys(removed, _REMOVED),
        edge=outline,
        title=f"before update {report.step}: removed in red",
    )
    draw_tree(
        after,
        axes[1],
        fill=dict.fromkeys(report.new_cliques, _NEW),
        edge=outline,
        title="after: re-made in orange, orphans outlined blue",
    )
    return _save(axes, path)


def draw_spy(
    tree: BayesTree, ax: Any = None, *, highlight: Collection = (), title: str = "R", path: str | None = None
) -> Any:
    """Spy plot of the tree's assembled R (cliques in postorder), the rows of the ``highlight``
    variables in orange. tree: anything with ``to_dense() -> (R, _, ordering)``, e.g. a BayesTree."""
    R, _, ordering = tree.to_dense()
    unknown = [k for k in highlight if k not in ordering.offset_of]
    if unknown:
        raise UnknownVariableError(f"highlight names {unknown[0]!r}, which is not in the tree")
    ax = _axes(ax, path, figsize=(4, 4))
    ax.spy(np.abs(R) > 1e-12, markersize=2, color="0.3")
    for k in highlight:
        o, d = ordering.offset_of[k], ordering.dims[ordering.position[k]]
        ax.axhspan(o - 0.5, o + d - 0.5, color=_NEW, alpha=0.3, lw=0)
    ticks = ordering.offsets + np.asarray(ordering.dims) / 2 - 0.5
    ax.set_xticks(ticks, [str(k) for k in ordering.keys], rotation=90, fontsize=6)
    ax.set_yticks(ticks, [str(k) for k in ordering.keys], fontsize=6)
    ax.set_title(title, fontsize=10)
    return _save(ax, path)
