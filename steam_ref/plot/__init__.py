"""Every figure of steam_ref: the GP's, a run's (Fig. 2-4 of the paper) and the Bayes tree's.

A leaf of the package: the functions take plain arrays (or objects described by the attributes they
read), import nothing from steam_ref but its exceptions, and import matplotlib only when they draw, so
any layer may call them and importing steam_ref never loads matplotlib.

- :mod:`~steam_ref.plot.figures`: the GP prior and its interpolation, a run's trajectory, timing,
  the interpolation trade-off, the distance to the authors' run, ANEES against its χ² band;
- :mod:`~steam_ref.plot.tree`: the Bayes tree, an update before and after [K12 Fig. 3-4], its R factor;
- :mod:`~steam_ref.plot.base`: what they share (axes, saving, array checks).
"""

from .figures import (
    plot_anees,
    plot_fidelity,
    plot_interpolation,
    plot_interpolation_tradeoff,
    plot_matrix,
    plot_sparsity,
    plot_state_samples,
    plot_timing,
    plot_timing_and_tradeoff,
    plot_trajectory,
)
from .tree import draw_spy, draw_tree, draw_update, tree_layout

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
    "tree_layout",
    "draw_tree",
    "draw_update",
    "draw_spy",
    "plot_anees",
]
