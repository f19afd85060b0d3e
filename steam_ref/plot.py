"""Every figure of steam_ref: the tutorials', the experiments' (Fig. 2-4) and the Bayes tree's.

matplotlib is imported inside each function, so importing steam_ref never needs it, and nothing
from steam_ref is imported at run time: the functions take plain arrays, or objects described by
the attributes they read. Every function draws on the axes it is given (or on new ones) and returns
them; with ``path`` it also saves the figure there (PNG by the suffix) and closes it.

- the GP prior and its interpolation: :func:`plot_state_samples`, :func:`plot_matrix`,
  :func:`plot_sparsity`, :func:`plot_interpolation`;
- a run: :func:`plot_trajectory` (top view, as Fig. 2), :func:`plot_timing` (Fig. 3/4, left),
  :func:`plot_interpolation_tradeoff` (Fig. 3/4, right), :func:`plot_fidelity` (distance to the
  authors' estimate, pose by pose);
- the Bayes tree: :func:`tree_layout`, :func:`draw_tree`, :func:`draw_update` (an update as
  before/after [K12 Fig. 3-4]), :func:`draw_spy` (its R factor).
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

if TYPE_CHECKING:
    from .bayes_tree.isam import UpdateReport
    from .bayes_tree.symbolic import CliqueTree
    from .bayes_tree.tree import BayesTree

__all__ = [
    "plot_state_samples",
    "plot_matrix",
    "plot_sparsity",
    "plot_interpolation",
    "plot_trajectory",
    "plot_timing",
    "plot_interpolation_tradeoff",
    "plot_fidelity",
    "tree_layout",
    "draw_tree",
    "draw_update",
    "draw_spy",
]

# clique colours of a Bayes tree update [K12 Fig. 3-4]
_REMOVED, _NEW, _ORPHAN, _PLAIN = "#e45756", "#f58518", "#4c78a8", "#eeeeee"


def _axes(ax: Any, path: str | None = None, **subplots: Any) -> Any:
    """``ax`` if given; else new axes: a pyplot figure, or, when only saving to ``path``, a bare
    Figure (no GUI backend needed)."""
    if ax is not None:
        return ax
    if path is not None:
        from matplotlib.figure import Figure

        figsize = subplots.pop("figsize", None)
        layout = subplots.pop("layout", None)
        return Figure(figsize=figsize, layout=layout).subplots(**subplots)
    import matplotlib.pyplot as plt

    return plt.subplots(**subplots)[1]


def _save(axes: Any, path: str | None) -> Any:
    """Save the figure holding ``axes`` to ``path`` (if given) and close it; returns ``axes``."""
    if path is not None:
        import matplotlib.pyplot as plt

        fig = np.ravel(axes)[0].figure
        fig.savefig(path, dpi=120, bbox_inches="tight")
        plt.close(fig)
    return axes


def _block_grid(ax: Any, shape: tuple[int, int], block: int | None) -> None:
    if not block:
        return
    for k in range(block, shape[0], block):
        ax.axhline(k - 0.5, color="0.6", lw=0.4)
    for k in range(block, shape[1], block):
        ax.axvline(k - 0.5, color="0.6", lw=0.4)


def plot_state_samples(
    times: ArrayLike, samples: ArrayLike, labels: Sequence[str] | None = None, axes: Any = None, path: str | None = None
) -> Any:
    """Plot the first d = len(labels) state components of each sample against time.

    samples: (S, M, n) for S trajectories at M times. One subplot per component. Returns the axes.
    """
    samples = np.asarray(samples, dtype=float)
    labels = list(labels) if labels is not None else [f"x[{k}]" for k in range(samples.shape[2] // 2)]
    axes = _axes(axes, path, ncols=len(labels), figsize=(4 * len(labels), 3), sharex=True, layout="constrained")
    for k, (ax, label) in enumerate(zip(np.atleast_1d(axes), labels)):
        for s in samples:
            ax.plot(times, s[:, k], lw=1)
        ax.set_xlabel("t [s]")
        ax.set_ylabel(label)
    return _save(axes, path)


def plot_matrix(
    M: ArrayLike, ax: Any = None, block: int | None = None, title: str | None = None, path: str | None = None
) -> Any:
    """Image of log₁₀|M| (entries below 1e-16·max shown as the floor), grid lines every `block`."""
    M = np.abs(np.asarray(M, dtype=float))
    ax = _axes(ax, path, figsize=(4, 4))
    floor = 1e-16 * max(M.max(), np.finfo(float).tiny)
    im = ax.imshow(np.log10(np.maximum(M, floor)), cmap="viridis", interpolation="nearest")
    ax.figure.colorbar(im, ax=ax, shrink=0.8, label="log₁₀|entry|")
    _block_grid(ax, M.shape, block)
    if title:
        ax.set_title(title)
    return _save(ax, path)


def plot_sparsity(
    M: ArrayLike,
    ax: Any = None,
    block: int | None = None,
    rel_tol: float = 1e-9,
    title: str | None = None,
    path: str | None = None,
) -> Any:
    """Spy plot of the entries with |M_ij| > rel_tol·max|M|, grid lines every `block`."""
    M = np.abs(np.asarray(M, dtype=float))
    ax = _axes(ax, path, figsize=(4, 4))
    ax.spy(M > rel_tol * M.max(), markersize=2)
    _block_grid(ax, M.shape, block)
    if title:
        ax.set_title(title)
    return _save(ax, path)


def plot_interpolation(
    t_query: ArrayLike,
    mean: ArrayLike,
    std: ArrayLike,
    ax: Any = None,
    t_est: ArrayLike | None = None,
    x_est: ArrayLike | None = None,
    std_est: ArrayLike | None = None,
    label: str | None = None,
    color: str = "C0",
    path: str | None = None,
) -> Any:
    """One scalar component: interpolated mean with a ±2σ band, and the estimated states as dots
    with ±2σ error bars. All arrays are 1-d."""
    ax = _axes(ax, path, figsize=(6, 3))
    t_query, mean, std = (np.asarray(a, dtype=float) for a in (t_query, mean, std))
    ax.fill_between(t_query, mean - 2 * std, mean + 2 * std, color=color, alpha=0.25, lw=0, label="±2σ")
    ax.plot(t_query, mean, color=color, lw=1.2, label="interpolated mean")
    if t_est is not None and x_est is not None:
        yerr = None if std_est is None else 2 * np.asarray(std_est, dtype=float)
        ax.errorbar(t_est, x_est, yerr=yerr, fmt="o", color="k", ms=4, capsize=2, label="estimated states")
    ax.set_xlabel("t [s]")
    if label:
        ax.set_ylabel(label)
    return _save(ax, path)


# --- A run: trajectory, timing, interpolation trade-off  [YIB Fig. 2-4] -----------------------


def _xy(points: ArrayLike | Mapping[Any, ArrayLike] | None) -> np.ndarray | None:
    """(n, 2) float array of points given as an array or as a mapping id → (2,); None if empty."""
    if points is None:
        return None
    if isinstance(points, Mapping):
        points = list(points.values())
    xy = np.asarray(points, dtype=float).reshape(-1, 2)
    return xy if len(xy) else None


def plot_trajectory(
    truth_xy: ArrayLike | None,
    estimate_xy: ArrayLike,
    *,
    landmarks_true: ArrayLike | None = None,
    landmarks_estimated: ArrayLike | Mapping[Any, ArrayLike] | None = None,
    dead_reckoning: ArrayLike | None = None,
    estimate_label: str = "estimate",
    truth_label: str = "ground truth",
    title: str | None = None,
    ax: Any = None,
    path: str | None = None,
) -> Any:
    """Top view of a run, as Fig. 2: estimated positions against ground truth and dead reckoning,
    true and estimated landmarks.

    truth_xy, estimate_xy, dead_reckoning: (n, 2) positions (truth may be None, or another reference:
    ``truth_label`` names it, e.g. "batch optimum"); landmarks_true: (k, 2); landmarks_estimated:
    (k, 2), or a mapping landmark id → (2,).
    """
    ax = _axes(ax, path, figsize=(6, 6))
    if truth_xy is not None:
        ax.plot(*np.asarray(truth_xy, dtype=float).T, "g-", lw=1.5, label=truth_label)
    if dead_reckoning is not None:
        ax.plot(*np.asarray(dead_reckoning, dtype=float).T, "y-", lw=1, label="dead reckoning")
    ax.plot(*np.asarray(estimate_xy, dtype=float).T, "b-", lw=1, label=estimate_label)
    marks_true, marks_est = _xy(landmarks_true), _xy(landmarks_estimated)
    if marks_true is not None:
        ax.plot(*marks_true.T, "g*", ms=9, label="landmarks (true)")
    if marks_est is not None:
        ax.plot(*marks_est.T, "k+", ms=9, label="landmarks (estimated)")
    ax.set(aspect="equal", xlabel="x (m)", ylabel="y (m)")
    if title:
        ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
    return _save(ax, path)


def plot_timing(runs: Mapping[str, Any], ax: Any = None, *, title: str | None = None, path: str | None = None) -> Any:
    """Cumulative computation time against time step, one line per run (Fig. 3/4, left).

    runs: label → run, any object with ``cumulative_s`` ((n_steps,) seconds after each processed
    step) and ``completed`` (False: cut short by a time budget, marked "(budget)" in the legend),
    e.g. :class:`steam_ref.online.RunResult`.
    """
    ax = _axes(ax, path, figsize=(5, 4))
    for label, run in runs.items():
        cumulative = np.asarray(run.cumulative_s, dtype=float)
        ax.plot(np.arange(len(cumulative)), cumulative, label=label + ("" if run.completed else " (budget)"))
    ax.set(xlabel="time step", ylabel="cumulative time (s)", yscale="log")
    if title:
        ax.set_title(title)
    ax.legend(fontsize=8)
    return _save(ax, path)


def plot_interpolation_tradeoff(
    with_interpolation: Mapping[int, Any],
    without_interpolation: Mapping[int, Any] | None = None,
    axes: Any = None,
    *,
    name: str = "",
    path: str | None = None,
) -> Any:
    """RMSE and total time against the time-step difference between estimated states, with and
    without interpolation (Fig. 3/4, right). Two panels; returns both axes.

    with_interpolation, without_interpolation: skip (time steps between states) → run, any object
    with ``rmse_m`` (position RMSE, m) and ``total_s`` (computation time, s), e.g.
    :class:`steam_ref.online.RunResult`. ``name`` (the data set) heads the panel titles.
    """
    axes = _axes(axes, path, ncols=2, figsize=(9, 4))
    curves = ((without_interpolation or {}, "gs-", "without interpolation"), (with_interpolation, "rd--", "with interpolation"))
    for runs, style, label in curves:
        if not runs:
            continue
        skips = sorted(runs)
        axes[0].plot(skips, [runs[k].rmse_m for k in skips], style, label=label)
        axes[1].plot(skips, [runs[k].total_s for k in skips], style, label=label)
    head = f"{name}: " if name else ""
    axes[0].set(xlabel="time steps between estimated states", ylabel="RMSE (m)", title=f"{head}RMSE")
    axes[1].set(xlabel="time steps between estimated states", ylabel="time (s)", title=f"{head}computation time")
    for ax in axes:
        ax.legend(fontsize=8)
        ax.grid(True, alpha=0.3)
    return _save(axes, path)


def plot_fidelity(
    distances: Mapping[str, ArrayLike], ax: Any = None, *, tolerance_m: float | None = 0.02, reference: str = "the authors' estimate",
    log: bool = False, path: str | None = None,
) -> Any:
    """Distance from a run's estimate to the authors' saved estimate (or another ``reference``, e.g. "the
    batch optimum") at every pose, one line per data set or run (name → (n,) metres, pose by pose), with
    the tolerance drawn as a dashed line; ``log`` for a logarithmic axis."""
    ax = _axes(ax, path, figsize=(7, 3))
    for name, d in distances.items():
        d = 1000 * np.asarray(d, dtype=float)
        ax.plot(np.arange(len(d)), d, lw=0.8, label=name)
    if tolerance_m is not None:
        ax.axhline(1000 * tolerance_m, color="0.4", ls="--", lw=0.8, label=f"{1000 * tolerance_m:g} mm")
    ax.set(xlabel="pose", ylabel=f"distance to {reference} (mm)", yscale="log" if log else "linear")
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    return _save(ax, path)


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
        box = dict(boxstyle="round,pad=0.3", fc=fill.get(c, _PLAIN), ec=edge.get(c, "0.3"), lw=2.5 if c in edge else 0.8)
        ax.text(x, y, _clique_label(tree.cliques[c]), ha="center", va="center", fontsize=8, bbox=box, zorder=2)
    xs = [x for x, _ in pos.values()] or [0.0]
    ys = [y for _, y in pos.values()] or [0.0]
    ax.set_xlim(min(xs) - 0.8, max(xs) + 0.8)
    ax.set_ylim(min(ys) - 0.6, 0.6)
    ax.set_axis_off()
    ax.set_title(title, fontsize=10)
    return _save(ax, path)


def draw_update(before: CliqueTree, after: CliqueTree, report: UpdateReport, axes: Any = None, path: str | None = None) -> Any:
    """Two panels: the tree before an update (removed cliques red) and after it (re-made cliques
    orange, orphans outlined blue).  [K12 Fig. 3-4]

    before: ``tree.snapshot()`` taken before the update; report: any object with ``step``,
    ``removed_cliques``, ``orphans`` and ``new_cliques`` (clique ids), e.g. an UpdateReport.
    """
    axes = _axes(axes, path, ncols=2, figsize=(12, 4))
    removed, orphans = set(report.removed_cliques), set(report.orphans)
    outline = {c: _ORPHAN for c in orphans}
    draw_tree(before, axes[0], fill={c: _REMOVED for c in removed}, edge=outline, title=f"before update {report.step}: removed in red")
    draw_tree(after, axes[1], fill={c: _NEW for c in report.new_cliques}, edge=outline, title="after: re-made in orange, orphans outlined blue")
    return _save(axes, path)


def draw_spy(tree: BayesTree, ax: Any = None, *, highlight: Collection = (), title: str = "R", path: str | None = None) -> Any:
    """Spy plot of the tree's assembled R (cliques in postorder), the rows of the ``highlight``
    variables in orange. tree: anything with ``to_dense() -> (R, _, ordering)``, e.g. a BayesTree."""
    ax = _axes(ax, path, figsize=(4, 4))
    R, _, ordering = tree.to_dense()
    ax.spy(np.abs(R) > 1e-12, markersize=2, color="0.3")
    for k in highlight:
        o, d = ordering.offset_of[k], ordering.dims[ordering.position[k]]
        ax.axhspan(o - 0.5, o + d - 0.5, color=_NEW, alpha=0.3, lw=0)
    ticks = ordering.offsets + np.asarray(ordering.dims) / 2 - 0.5
    ax.set_xticks(ticks, [str(k) for k in ordering.keys], rotation=90, fontsize=6)
    ax.set_yticks(ticks, [str(k) for k in ordering.keys], fontsize=6)
    ax.set_title(title, fontsize=10)
    return _save(ax, path)
