"""Bookkeeping of one incremental update, kept out of the algorithm's steps: timing and undo."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

from numpy.typing import NDArray

from ..linear.system import GaussianFactor
from ..variables import Key

__all__ = ["PhaseTimer", "Journal", "UndoDict", "until_done"]


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


_ABSENT = object()  # a key the dict did not have


def until_done(undo: Callable[[], None]) -> None:
    """Run ``undo`` (idempotent) to its end: a second Ctrl-C during it starts it again, rather than
    leaving it half done; an error in it (a bug) propagates."""
    while True:
        try:
            undo()
            return
        except Exception:
            raise
        except BaseException:
            continue


class UndoDict(dict):
    """A dict that, while ``record`` is a dict, keeps there each key's value before its first change.

    The increments δ live in one, so an update's journal learns what back-substitution changed
    without back-substitution knowing about journals.
    """

    __slots__ = ("record",)

    def __init__(self) -> None:
        super().__init__()
        self.record: dict | None = None  # key → value before the update (``_ABSENT``: a new key)

    def __setitem__(self, key: object, value: object) -> None:
        record = self.record
        if record is not None and key not in record:
            record[key] = dict.get(self, key, _ABSENT)
        dict.__setitem__(self, key, value)

    def update(self, *args: object, **kwargs: object) -> None:
        """Every write goes through :meth:`__setitem__`, so the record sees it (the batched back-substitution
        writes δ with ``update``)."""
        for key, value in dict(*args, **kwargs).items():
            self[key] = value

    def undo(self, record: dict) -> None:
        """Put back the values ``record`` kept (idempotent)."""
        for key, old in record.items():
            if old is _ABSENT:
                dict.pop(self, key, None)
            else:
                dict.__setitem__(self, key, old)


@dataclass
class Journal:
    """What a running update changed, so that any failure or interruption can put it back (mutable:
    filled as it runs, each change recorded before it is made).

    Valid until the update returns: a ``KeyboardInterrupt`` between any two steps is undone as an
    error is.
    """

    n_factors: int  # number of factors before the update
    new_keys: list[Key]  # variables the update adds
    steps: int  # the solver's update count before the update
    over: dict[Key, None]  # the relinearization candidates before the update (a copy)
    tree: tuple[int, dict[int, None]]  # the tree's checkpoint (CliqueTree.checkpoint)
    old_points: dict[Key, tuple[NDArray, NDArray]] = field(default_factory=dict)  # relinearized key → old (θ̄, δ)
    old_linear: dict[int, GaussianFactor] = field(default_factory=dict)  # factor id → old cached linearization
    old_delta: dict = field(default_factory=dict)  # key → δ before the update (UndoDict.record)

    def moved(self, key: Key, theta_bar: NDArray, delta: NDArray) -> None:
        """``key``'s θ̄ and δ are about to change from these."""
        self.old_points[key] = (theta_bar, delta)

    def relinearized(self, fid: int, old: GaussianFactor | None) -> None:
        """Factor ``fid``'s cached linearization is about to be replaced (None: it had none)."""
        if old is not None:
            self.old_linear[fid] = old
