"""Figures for the tutorials. matplotlib is imported inside each function, so importing steam_ref
never needs it. Every function draws on `ax` (or new axes) and returns what it drew on."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["plot_state_samples", "plot_matrix", "plot_sparsity", "plot_interpolation"]


def _axes(ax: Any, **subplots: Any) -> Any:
    import matplotlib.pyplot as plt

    return plt.subplots(**subplots)[1] if ax is None else ax


def _block_grid(ax: Any, shape: tuple[int, int], block: int | None) -> None:
    if not block:
        return
    for k in range(block, shape[0], block):
        ax.axhline(k - 0.5, color="0.6", lw=0.4)
    for k in range(block, shape[1], block):
        ax.axvline(k - 0.5, color="0.6", lw=0.4)


def plot_state_samples(
    times: ArrayLike, samples: ArrayLike, labels: Sequence[str] | None = None, axes: Any = None
) -> Any:
    """Plot the first d = len(labels) state components of each sample against time.

    samples: (S, M, n) for S trajectories at M times. One subplot per component. Returns the axes.
    """
    import matplotlib.pyplot as plt

    samples = np.asarray(samples, dtype=float)
    labels = list(labels) if labels is not None else [f"x[{k}]" for k in range(samples.shape[2] // 2)]
    if axes is None:
        _, axes = plt.subplots(1, len(labels), figsize=(4 * len(labels), 3), sharex=True, layout="constrained")
    for k, (ax, label) in enumerate(zip(np.atleast_1d(axes), labels)):
        for s in samples:
            ax.plot(times, s[:, k], lw=1)
        ax.set_xlabel("t [s]")
        ax.set_ylabel(label)
    return axes


def plot_matrix(M: ArrayLike, ax: Any = None, block: int | None = None, title: str | None = None) -> Any:
    """Image of log₁₀|M| (entries below 1e-16·max shown as the floor), grid lines every `block`."""
    M = np.abs(np.asarray(M, dtype=float))
    ax = _axes(ax, figsize=(4, 4))
    floor = 1e-16 * max(M.max(), np.finfo(float).tiny)
    im = ax.imshow(np.log10(np.maximum(M, floor)), cmap="viridis", interpolation="nearest")
    ax.figure.colorbar(im, ax=ax, shrink=0.8, label="log₁₀|entry|")
    _block_grid(ax, M.shape, block)
    if title:
        ax.set_title(title)
    return ax


def plot_sparsity(
    M: ArrayLike, ax: Any = None, block: int | None = None, rel_tol: float = 1e-9, title: str | None = None
) -> Any:
    """Spy plot of the entries with |M_ij| > rel_tol·max|M|, grid lines every `block`."""
    M = np.abs(np.asarray(M, dtype=float))
    ax = _axes(ax, figsize=(4, 4))
    ax.spy(M > rel_tol * M.max(), markersize=2)
    _block_grid(ax, M.shape, block)
    if title:
        ax.set_title(title)
    return ax


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
) -> Any:
    """One scalar component: interpolated mean with a ±2σ band, and the estimated states as dots
    with ±2σ error bars. All arrays are 1-d."""
    ax = _axes(ax, figsize=(6, 3))
    t_query, mean, std = (np.asarray(a, dtype=float) for a in (t_query, mean, std))
    ax.fill_between(t_query, mean - 2 * std, mean + 2 * std, color=color, alpha=0.25, lw=0, label="±2σ")
    ax.plot(t_query, mean, color=color, lw=1.2, label="interpolated mean")
    if t_est is not None and x_est is not None:
        yerr = None if std_est is None else 2 * np.asarray(std_est, dtype=float)
        ax.errorbar(t_est, x_est, yerr=yerr, fmt="o", color="k", ms=4, capsize=2, label="estimated states")
    ax.set_xlabel("t [s]")
    if label:
        ax.set_ylabel(label)
    return ax


def plot_estimate(
    path: str, truth: ArrayLike, estimate: ArrayLike, landmarks: ArrayLike | None = None, title: str | None = None
) -> None:
    """Save a top view of an estimated path (n, 2) against ground truth (n, 2), with landmarks (k, 2)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 6))
    ax.plot(*np.asarray(truth).T, "g-", lw=1, label="ground truth")
    ax.plot(*np.asarray(estimate).T, "b-", lw=0.8, label="estimate")
    if landmarks is not None:
        ax.plot(*np.asarray(landmarks).T, "g*", label="landmarks")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    if title:
        ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
