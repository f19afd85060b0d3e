"""What one streamed run chooses on top of its set-up.  [YIB Sec. IV]

:class:`StreamOptions` holds the run-time choices only: which solver (PB, PBVR, BTGP) and its stopping
rule, which poses get a state (:class:`~steam_ref.paper.frontend.Layout`), a prefix of the poses, a time
budget, a progress bar, and whether to iterate to the batch optimum at the end. The model, the schedule
and iSAM2's settings belong to the set-up (:class:`~steam_ref.paper.presets.PaperSetup`).
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass

import numpy as np

from ..arguments import integer, replace_fields
from ..errors import SteamError
from .frontend import Layout
from .solvers import METHODS, PB_MAX_ITERATIONS, PB_RELATIVE_TOLERANCE

__all__ = ["StreamOptions"]


@dataclass(frozen=True)
class StreamOptions:
    """What one run chooses on top of its set-up: the method, the state layout, a prefix, a time budget.

    Run-time choices only: the model, the schedule and iSAM2's settings are the set-up's
    (:class:`~steam_ref.paper.presets.PaperSetup`: ``schedule``, ``isam2``), each with one owner.
    """

    method: str = "btgp"  # 'btgp', 'pb' or 'pbvr'
    skip: int = Layout.skip  # a state at most skip poses after the previous one (see frontend.Layout)
    interpolate: bool = Layout.interpolate  # readings between states: interpolated (Eq. 29) or dropped
    range_states: bool = Layout.range_states  # also estimate every pose that has a range reading
    converge_at_end: bool = False  # after the last pose, iterate everything to the batch optimum (converge.py)
    pb_relative_tolerance: float = PB_RELATIVE_TOLERANCE  # PB/PBVR Gauss-Newton stopping rule
    pb_max_iterations: int = PB_MAX_ITERATIONS  # PB/PBVR iterations per update
    max_poses: int | None = None  # process only this prefix of the poses
    time_budget_s: float | None = None  # stop when the run has taken this long (reported)
    progress: bool = False  # tqdm progress bar
    lag: float | None = None  # BTGP only: fixed-lag smoothing, forget states older than this (the data's seconds)
    lag_history: bool = False  # with a lag: keep the forgotten conditionals, smooth the past at the end (history.py)
    lag_batch: float = 0.0  # with a lag: seconds the window may grow past it, to marginalize in batches (fixed_lag.py)

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise SteamError(f"unknown method {self.method!r}; use one of {', '.join(METHODS)}")
        for name in ("interpolate", "range_states", "progress", "converge_at_end", "lag_history"):
            if not isinstance(getattr(self, name), bool):
                raise SteamError(f"{name} must be True or False, got {getattr(self, name)!r}")
        Layout(self.skip, self.range_states, self.interpolate)  # checks skip
        _check_count("max_poses", self.max_poses, 2)
        _check_count("pb_max_iterations", self.pb_max_iterations, 1)
        if self.time_budget_s is not None and not (_is_real(self.time_budget_s) and 0 < self.time_budget_s < np.inf):
            raise SteamError(
                f"time_budget_s must be a finite number of seconds > 0 (or None), got {self.time_budget_s!r}"
            )
        if not (_is_real(self.pb_relative_tolerance) and 0 <= self.pb_relative_tolerance < np.inf):
            raise SteamError(f"pb_relative_tolerance must be a finite number >= 0, got {self.pb_relative_tolerance!r}")
        _check_lag(self)

    @property
    def layout(self) -> Layout:
        """The state layout these options ask for."""
        return Layout(self.skip, self.range_states, self.interpolate)

    def replace(self, **changes) -> StreamOptions:
        """A copy with some fields changed; SteamError names an unknown field (:func:`~steam_ref.arguments.replace_fields`)."""
        return replace_fields(self, changes)


def _check_lag(o: StreamOptions) -> None:
    """A lag is a number of seconds > 0, for BTGP only, and not with converge_at_end (which needs every factor)."""
    if not (_is_real(o.lag_batch) and 0 <= o.lag_batch < np.inf):
        raise SteamError(f"lag_batch must be a finite number of seconds >= 0, got {o.lag_batch!r}")
    if o.lag is None:
        if o.lag_history:
            raise SteamError("lag_history keeps what a lag forgets: give a lag too")
        if o.lag_batch:
            raise SteamError(f"lag_batch={o.lag_batch!r} batches what a lag forgets: give a lag too")
        return
    if not (_is_real(o.lag) and 0 < o.lag < np.inf):
        raise SteamError(f"lag must be a finite number of seconds > 0 (or None), got {o.lag!r}")
    if o.method != "btgp":
        raise SteamError(
            f"lag (fixed-lag smoothing) is for BTGP only: {o.method.upper()} re-solves every state at every "
            "update and has no tree to marginalize from; use method 'btgp'"
        )
    if o.converge_at_end:
        raise SteamError("lag and converge_at_end cannot go together: converging at the end needs every factor kept")


def _is_real(value: object) -> bool:
    """A real number (NaN included: callers compare it), never a bool."""
    return not isinstance(value, bool) and isinstance(value, numbers.Real)


def _check_count(name: str, value: object, lowest: int) -> None:
    """None (no limit), or an integer >= ``lowest``: :func:`~steam_ref.arguments.integer`."""
    if value is not None:
        integer(name, value, lowest)
