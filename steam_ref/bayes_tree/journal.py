"""Bookkeeping of one incremental update, kept out of the algorithm's steps: timing and undo."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from numpy.typing import NDArray

from ..linear.system import GaussianFactor
from ..variables import Key

__all__ = ["PhaseTimer", "Journal"]


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


@dataclass
class Journal:
    """What a running update changed, so that a failure can put it back (mutable: filled as it runs).

    Valid until the new cliques go into the tree (:meth:`close`); a failure after that is a bug.
    """

    n_factors: int  # number of factors before the update
    new_keys: list[Key]  # variables the update adds
    old_points: dict[Key, tuple[NDArray, NDArray]] = field(default_factory=dict)  # relinearized key → old (θ̄, δ)
    old_linear: dict[int, GaussianFactor] = field(default_factory=dict)  # factor id → old cached linearization
    top_removed: bool = False  # the top of the tree was removed (the tree can restore it)
    closed: bool = False  # the new cliques are in: nothing to undo any more

    def moved(self, key: Key, theta_bar: NDArray, delta: NDArray) -> None:
        """``key``'s θ̄ and δ are about to change from these."""
        self.old_points[key] = (theta_bar, delta)

    def relinearized(self, fid: int, old: GaussianFactor | None) -> None:
        """Factor ``fid``'s cached linearization is about to be replaced (None: it had none)."""
        if old is not None:
            self.old_linear[fid] = old

    def removed_top(self) -> None:
        """The tree's top was removed (``BayesTree.restore_top`` puts it back)."""
        self.top_removed = True

    def close(self) -> None:
        """The new cliques are going in: from here on nothing is undone."""
        self.closed = True
