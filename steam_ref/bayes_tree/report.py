"""What one update of the Bayes tree did: :class:`UpdateReport`, returned by every
:meth:`~steam_ref.bayes_tree.IncrementalSolver.update`, so a notebook can show the affected top of the tree
[K12 Fig. 3-4] and a benchmark its phases and fill; and :class:`PhaseTimer`, which times them."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from ..variables import Key

__all__ = ["UpdateReport", "PhaseTimer"]


class PhaseTimer:
    """Wall time of each phase of one update: ``with timer("remove"): ...``."""

    def __init__(self) -> None:
        self.start = time.perf_counter()  # when the update began
        self.seconds: dict[str, float] = {}  # phase → seconds
        self._phase, self._t = "", 0.0

    def __call__(self, phase: str) -> PhaseTimer:
        self._phase = phase
        return self

    def __enter__(self) -> None:
        self._t = time.perf_counter()

    def __exit__(self, *exc: object) -> None:
        self.seconds[self._phase] = time.perf_counter() - self._t

    def total(self) -> float:
        """Seconds since the update began."""
        return time.perf_counter() - self.start


@dataclass(frozen=True, kw_only=True)
class UpdateReport:
    """What one update did, so a notebook can show the affected top of the tree (built by keyword only)."""

    step: int  # number of this update, from 1
    removed_cliques: tuple[int, ...]  # ids of the cliques taken off the top (ids of the tree before)
    new_cliques: tuple[int, ...]  # ids of the cliques made by re-elimination
    orphans: tuple[int, ...]  # ids of the subtrees kept and reattached
    relinearized: tuple[Key, ...]  # θ_rl: variables whose linearization point moved
    reeliminated: tuple[Key, ...]  # variables eliminated anew, in elimination order (frontals of the new cliques)
    updated: tuple[Key, ...]  # variables whose increment δ (hence estimate) was recomputed
    linearized_factors: int  # factors linearized in this update (the new ones included)
    backsubstituted_cliques: int  # cliques whose conditional was solved
    time_s: float  # wall time of the whole update
    timings: dict[str, float] = field(default_factory=dict)  # seconds per phase (check, add, ..., backsubstitute)
    tree_nnz: int = 0  # nonzeros of R after the update, counted as GTSAM's ISAM2::treeNnz (bayes_tree/dot.py)
