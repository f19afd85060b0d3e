"""The consistency figure: ANEES pose by pose against its χ² band, one panel per kind of state."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .base import array as _array
from .base import axes as _axes
from .base import save as _save

__all__ = ["plot_anees"]


def plot_anees(
    per_pose: Mapping[str, Mapping[str, ArrayLike]],
    bands: Mapping[str, tuple[float, float]],
    *,
    n_runs: int | None = None,
    path: str | None = None,
) -> Any:
    """ANEES at every pose of each estimator (name → kind → (n,)), one panel per kind ('pose',
    'velocity'), on a log axis, with the kind's two-sided band (kind → (low, high)) shaded."""
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
        row.grid(True, alpha=0.3)
    ax[0, 0].legend(fontsize=7, ncol=2)
    ax[-1, 0].set_xlabel("pose")
    return _save(ax, path)
