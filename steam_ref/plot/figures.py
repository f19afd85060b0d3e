"""Every figure of steam_ref: the tutorials', the experiments' (Fig. 2-4) and the Bayes tree's.

matplotlib is imported inside each function, so importing steam_ref never needs it, and nothing
from steam_ref but its exceptions is imported at run time: the functions take plain arrays, or
objects described by the attributes they read, and a bad array raises a
:class:`~steam_ref.errors.ShapeError` naming the argument. Every function draws on the axes it is given (or on new ones) and returns
them; with ``path`` it also saves the figure there (PNG by the suffix) and closes it.

- the GP prior and its interpolation: :func:`plot_state_samples`, :func:`plot_matrix`,
  :func:`plot_sparsity`, :func:`plot_interpolation`;
- a run: :func:`plot_trajectory` (top view, as Fig. 2), :func:`plot_timing` (Fig. 3/4, left),
  :func:`plot_interpolation_tradeoff` (Fig. 3/4, right), :func:`plot_timing_and_tradeoff` (Fig. 3/4 whole), :func:`plot_fidelity` (distance to the
  authors' estimate, pose by pose);
- the Bayes tree: :func:`tree_layout`, :func:`draw_tree`, :func:`draw_update` (an update as
  before/after [K12 Fig. 3-4]), :func:`draw_spy` (its R factor), in :mod:`steam_ref.plot.tree`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ShapeError
from .base import array as _array
from .base import attributes as _attributes
from .base import axes as _axes
from .base import block_grid as _block_grid
from .base import plain_log_ticks as _plain_log_ticks
from .base import save as _save

__all__ = [
    "plot_state_samples",
    "plot_matrix",
    "plot_sparsity",
    "plot_interpolation",
    "plot_trajectory",
    "plot_timing",
    "plot_timing_and_tradeoff",
    "plot_interpolation_tradeoff",
    "plot_fidelity",
    "plot_anees",
]


def plot_state_samples(
    times: ArrayLike, samples: ArrayLike, labels: Sequence[str] | None = None, axes: Any = None, path: str | None = None
) -> Any:
    """Plot the first d = len(labels) state components of each sample against time.

    samples: (S, M, n) for S trajectories at M times. One subplot per component. Returns the axes.
    """
    samples = _array("samples", samples, 3)
    labels = list(labels) if labels is not None else [f"x[{k}]" for k in range(samples.shape[2] // 2)]
    axes = _axes(axes, path, ncols=len(labels), figsize=(4 * len(labels), 3), sharex=True, layout="constrained")
    for k, (ax, label) in enumerate(zip(np.atleast_1d(axes), labels, strict=True)):
        for s in samples:
            ax.plot(times, s[:, k], lw=1)
        ax.set_xlabel("t [s]")
        ax.set_ylabel(label)
    return _save(axes, path)


def plot_matrix(
    M: ArrayLike, ax: Any = None, block: int | None = None, title: str | None = None, path: str | None = None
) -> Any:
    """Image of log₁₀|M| (entries below 1e-16·max shown as the floor, NaN blank), grid lines every `block`."""
    magnitude = np.abs(_array("M", M, 2))
    ax = _axes(ax, path, figsize=(4, 4))
    floor = 1e-16 * max(magnitude.max(), np.finfo(float).tiny)
    im = ax.imshow(np.log10(np.maximum(magnitude, floor)), cmap="viridis", interpolation="nearest")
    ax.figure.colorbar(im, ax=ax, shrink=0.8, label="log₁₀|entry|")
    _block_grid(ax, magnitude.shape, block)
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
    """Spy plot of the entries with abs(M_ij) > rel_tol · max abs(M), grid lines every `block`."""
    magnitude = np.abs(_array("M", M, 2))
    ax = _axes(ax, path, figsize=(4, 4))
    ax.spy(rel_tol * magnitude.max() < magnitude, markersize=2)
    _block_grid(ax, magnitude.shape, block)
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
    t_query, mean, std = _array("t_query", t_query, 1), _array("mean", mean, 1), _array("std", std, 1)
    if not len(t_query) == len(mean) == len(std):
        raise ShapeError(
            f"t_query, mean and std must have one entry per time, got lengths {len(t_query)}, {len(mean)}, {len(std)}"
        )
    ax = _axes(ax, path, figsize=(6, 3))
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


def _xy(name: str, points: ArrayLike | Mapping[Any, ArrayLike] | None) -> np.ndarray | None:
    """(n, 2) float array of points given as an array or as a mapping id → (2,); None if empty."""
    if points is None:
        return None
    listed = np.asarray(list(points.values()) if isinstance(points, Mapping) else points, dtype=object)
    if listed.size == 0:
        return None
    return _array(name, listed.tolist(), 2, columns=2)


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

    estimate_xy, dead_reckoning: (n, 2) positions at the same n poses, those the run covered (a ShapeError
    otherwise: dead reckoning over the whole data set beside a run of its first poses would spread the figure over
    ground the run never reached); truth_xy: (n, 2) ground truth at those poses, or None, or another reference
    at poses of its own (``truth_label`` names it, e.g. "batch optimum"), which must not outnumber them;
    landmarks_true: (k, 2); landmarks_estimated: (k, 2), or a mapping landmark id → (2,).
    """
    estimate_xy = _array("estimate_xy", estimate_xy, 2, columns=2)
    truth_xy = None if truth_xy is None else _array("truth_xy", truth_xy, 2, columns=2)
    dead_reckoning = None if dead_reckoning is None else _array("dead_reckoning", dead_reckoning, 2, columns=2)
    n = len(estimate_xy)
    if dead_reckoning is not None and len(dead_reckoning) != n:
        raise ShapeError(f"dead_reckoning must have the estimate's {n} poses, got {len(dead_reckoning)}")
    if truth_xy is not None and len(truth_xy) > n:
        raise ShapeError(f"truth_xy must have at most the estimate's {n} poses, got {len(truth_xy)}")
    marks_true, marks_est = _xy("landmarks_true", landmarks_true), _xy("landmarks_estimated", landmarks_estimated)
    ax = _axes(ax, path, figsize=(6, 6))
    # The estimate is drawn first, the reference over it (thin, dashed, on top): where the two agree, both
    # stay visible. True landmarks are red stars, estimated ones black crosses over them.
    if dead_reckoning is not None:
        ax.plot(*dead_reckoning.T, "-", color="goldenrod", lw=1, label="dead reckoning", zorder=1)
    ax.plot(*estimate_xy.T, "b-", lw=1.5, alpha=0.8, label=estimate_label, zorder=2)
    if truth_xy is not None:
        ax.plot(*truth_xy.T, "--", color="limegreen", lw=1, label=truth_label, zorder=3)
    if marks_true is not None:
        ax.plot(*marks_true.T, "r*", ms=10, label="landmarks (true)", zorder=4)
    if marks_est is not None:
        ax.plot(*marks_est.T, "k+", ms=9, label="landmarks (estimated)", zorder=5)
    ax.set(aspect="equal", xlabel="x (m)", ylabel="y (m)")
    if title:
        ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
    return _save(ax, path)


def _ran_its_course(run: Any) -> bool:
    """Completed, or stopped at the prefix asked for (``options.max_poses``) rather than by a budget."""
    limit = getattr(getattr(run, "options", None), "max_poses", None)
    steps = getattr(run, "n_steps_processed", len(run.cumulative_s))
    return bool(run.completed) or (limit is not None and steps >= limit)


def plot_timing(
    runs: Mapping[str, Any],
    ax: Any = None,
    *,
    per_step: bool = False,
    title: str | None = None,
    path: str | None = None,
) -> Any:
    """Computation time against time step, one line per run (Fig. 3/4, left): cumulative, or with ``per_step``
    each step's own time (the paper's upper graph, whose 'gap' is a stretch without range readings).

    runs: label → run, any object with ``cumulative_s`` ((n_steps,) seconds after each processed
    step) and ``completed`` (False: cut short), e.g. :class:`steam_ref.paper.online.RunResult`. A run
    cut short by its time budget is marked "(budget)" in the legend; one that stopped at the prefix it
    was asked for (``options.max_poses``, as ``reproduce --quick`` runs) is not cut short by anything.
    A step's own time is the rise of the cumulative time over it; a step that took no measurable time is left
    out of the log axis (a gap), not drawn at an invented floor.
    """
    for label, run in runs.items():
        _attributes(f"runs[{label!r}]", run, "cumulative_s", "completed")
    ax = _axes(ax, path, figsize=(5, 4))
    for label, run in runs.items():
        cumulative = np.asarray(run.cumulative_s, dtype=float)
        seconds = np.diff(cumulative, prepend=0.0) if per_step else cumulative
        if per_step:
            seconds = np.where(seconds > 0, seconds, np.nan)  # no time measured: a gap on the log axis
        ax.plot(np.arange(len(seconds)), seconds, label=label + ("" if _ran_its_course(run) else " (budget)"))
    ax.set(xlabel="time step", ylabel="time per step (s)" if per_step else "cumulative time (s)", yscale="log")
    if title:
        ax.set_title(title)
    ax.legend(fontsize=8)
    return _save(ax, path)


def plot_timing_and_tradeoff(
    timing: Mapping[str, Any],
    with_interpolation: Mapping[int, Any],
    without_interpolation: Mapping[int, Any] | None = None,
    *,
    name: str = "",
    title: str | None = None,
    path: str | None = None,
) -> Any:
    """Fig. 3/4 whole, on a new figure: the paper's two left graphs, each step's own time above and the cumulative
    time below (:func:`plot_timing`, one legend for both: the same runs in the same colours), and the RMSE and
    total time against the skip on the right (:func:`plot_interpolation_tradeoff`). ``title`` heads the figure.
    Returns the four axes (upper, lower, RMSE, total time)."""
    if path is not None:  # only saving: a bare Figure, no GUI backend needed
        from matplotlib.figure import Figure

        fig = Figure(figsize=(15, 7))
    else:
        import matplotlib.pyplot as plt

        fig = plt.figure(figsize=(15, 7))
    grid = fig.add_gridspec(2, 3)
    upper, lower = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[1, 0])
    plot_timing(timing, upper, per_step=True, title=f"{name}: computation time per step")
    if (legend := upper.get_legend()) is not None:
        legend.remove()  # the graph below names the same runs
    plot_timing(timing, lower, title=f"{name}: cumulative computation time")
    right = [fig.add_subplot(grid[:, 1]), fig.add_subplot(grid[:, 2])]
    plot_interpolation_tradeoff(with_interpolation, without_interpolation, right, name=name)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return _save(np.array([upper, lower, *right], dtype=object), path)


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
    :class:`steam_ref.paper.online.RunResult`. ``name`` (the data set) heads the panel titles.
    """
    for skip, run in [*with_interpolation.items(), *(without_interpolation or {}).items()]:
        _attributes(f"the run at skip {skip!r}", run, "rmse_m", "total_s")
    axes = _axes(axes, path, ncols=2, figsize=(9, 4))
    curves = (
        (without_interpolation or {}, "gs-", "without interpolation"),
        (with_interpolation, "rd--", "with interpolation"),
    )
    for runs, style, label in curves:
        if not runs:
            continue
        skips = sorted(runs)
        axes[0].plot(skips, [runs[k].rmse_m for k in skips], style, label=label)
        axes[1].plot(skips, [runs[k].total_s for k in skips], style, label=label)
    head = f"{name}: " if name else ""
    axes[0].set(xlabel="time steps between estimated states", ylabel="position RMSE (m)", title=f"{head}RMSE")
    axes[1].set(
        xlabel="time steps between estimated states",
        ylabel="total computation time (s)",
        title=f"{head}total computation time",
    )
    skips = sorted({*with_interpolation, *(without_interpolation or {})})
    for ax in axes:
        ax.set_xticks(skips, [str(k) for k in skips])  # the skips run, not 2.5 or 7.5 time steps
        ax.legend(fontsize=8)
        ax.grid(True, alpha=0.3)
    return _save(axes, path)


def plot_fidelity(
    distances: Mapping[str, ArrayLike],
    ax: Any = None,
    *,
    tolerance_m: float | None = 0.02,
    reference: str = "the authors' estimate",
    log: bool = False,
    title: str | None = None,
    path: str | None = None,
) -> Any:
    """Distance from a run's estimate to the authors' saved estimate (or another ``reference``, e.g. "the
    batch optimum") at every pose, one line per data set or run (name → (n,) metres, pose by pose), with
    the tolerance drawn as a dashed line labelled as one; ``log`` for a logarithmic axis."""
    millimetres = {name: 1000 * _array(f"distances[{name!r}]", d, 1) for name, d in distances.items()}
    ax = _axes(ax, path, figsize=(7, 3))
    for name, d in millimetres.items():
        ax.plot(np.arange(len(d)), d, lw=0.8, label=name)
    if tolerance_m is not None:
        ax.axhline(1000 * tolerance_m, color="0.4", ls="--", lw=0.8, label=f"tolerance {1000 * tolerance_m:g} mm")
    ax.set(xlabel="pose", ylabel=f"distance to {reference} (mm)", yscale="log" if log else "linear")
    if title:
        ax.set_title(title)
    ax.legend(fontsize=8)
    ax.grid(True, alpha=0.3)
    return _save(ax, path)


def plot_anees(
    per_pose: Mapping[str, Mapping[str, ArrayLike]],
    bands: Mapping[str, tuple[float, float]],
    *,
    n_runs: int | None = None,
    title: str | None = None,
    path: str | None = None,
) -> Any:
    """ANEES at every pose of each estimator (name → kind → (n,)), one panel per kind ('pose',
    'velocity'), on a log axis, with the kind's two-sided band (kind → (low, high)) shaded; the legend
    beside the panels, where it hides no curve; ``title`` over them."""
    kinds = list(bands)
    ax = _axes(None, path, nrows=len(kinds), ncols=1, figsize=(8, 2.6 * len(kinds)), sharex=True, squeeze=False)
    for row, kind in zip(ax[:, 0], kinds, strict=True):
        lo, hi = bands[kind]
        row.axhspan(lo, hi, color="0.85", label=f"95 % band [{lo:.2f}, {hi:.2f}]")
        for name, kinds_of in per_pose.items():
            if kind in kinds_of:
                a = _array(f"per_pose[{name!r}][{kind!r}]", kinds_of[kind], 1)
                row.plot(np.arange(len(a)), a, lw=0.9, label=name)
        runs = f" over {n_runs} runs" if n_runs else ""
        row.set(yscale="log", ylabel=f"ANEES, {kind}{runs}")
        _plain_log_ticks(row)
        row.grid(True, alpha=0.3)
    ax[0, 0].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    ax[-1, 0].set_xlabel("pose")
    if title:
        ax[0, 0].set_title(title)
    return _save(ax, path)
