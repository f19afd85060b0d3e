"""What every figure function shares: new axes or the given ones, saving, and the checks of its arrays.

matplotlib is imported inside the functions, so importing steam_ref never needs it. Used by
:mod:`steam_ref.plot.figures` and :mod:`steam_ref.plot.tree`.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ShapeError, SteamError

__all__: list[str] = []  # private helpers of the plot modules


def axes(ax: Any, path: str | None = None, **subplots: Any) -> Any:
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


def save(axes: Any, path: str | None) -> Any:
    """Save the figure holding ``axes`` to ``path`` (if given) and close it; returns ``axes``."""
    if path is not None:
        import matplotlib.pyplot as plt

        fig = np.ravel(axes)[0].figure
        name = os.path.basename(os.fspath(path))
        kind = name.rpartition(".")[2] if "." in name else None  # a dotfile ".png" is a PNG, not ".png.png"
        fig.savefig(path, dpi=120, bbox_inches="tight", format=kind)
        plt.close(fig)
    return axes


def plain_log_ticks(ax: Any) -> None:
    """Label the log y axis of ``ax`` with plain numbers (0.6, 2, 3, 10), not matplotlib's default 2×10⁰, nor
    the 6e-01 its LogFormatter writes below 1 and above 10,000."""
    from matplotlib.ticker import LogFormatter

    class Plain(LogFormatter):
        def _num_to_string(self, x: float, *_range: float) -> str:  # vmin, vmax unused
            return f"{x:g}"

    ax.yaxis.set_major_formatter(Plain(labelOnlyBase=False))
    ax.yaxis.set_minor_formatter(Plain(labelOnlyBase=False, minor_thresholds=(2, 0.5)))


def array(name: str, a: ArrayLike, ndim: int, columns: int | None = None) -> np.ndarray:
    """``a`` as a non-empty float array of ``ndim`` dimensions (and ``columns`` columns); ShapeError naming it."""
    try:
        out = np.asarray(a, dtype=float)
    except (TypeError, ValueError):
        raise ShapeError(f"{name} must be an array of numbers, got {a!r:.80}") from None
    if out.ndim != ndim or out.size == 0 or (columns is not None and out.shape[-1] != columns):
        want = f"(n, {columns})" if columns else f"{ndim}-d"
        raise ShapeError(f"{name} must be a non-empty {want} array, got shape {out.shape}")
    return out


def attributes(name: str, obj: Any, *attributes: str) -> None:
    """Raise naming ``name`` when ``obj`` lacks one of ``attributes`` (a duck-typed run, say)."""
    missing = [a for a in attributes if not hasattr(obj, a)]
    if missing:
        raise SteamError(
            f"{name} has no {missing[0]!r}: it must have {', '.join(attributes)} (e.g. a RunResult), got {obj!r:.80}"
        )


def block_grid(ax: Any, shape: tuple[int, int], block: int | None) -> None:
    if not block:
        return
    for k in range(block, shape[0], block):
        ax.axhline(k - 0.5, color="0.6", lw=0.4)
    for k in range(block, shape[1], block):
        ax.axvline(k - 0.5, color="0.6", lw=0.4)
