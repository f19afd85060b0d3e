"""What a streamed run produced, and the figures it reports.  [YIB Sec. IV, Table I]"""

from __future__ import annotations

import resource
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..arguments import finite, floats
from ..errors import ShapeError
from ..evaluate.metrics import Statistics
from ..trajectory import Covariances
from .options import StreamOptions
from .presets import Schedule

__all__ = ["RunResult", "position_rmse", "peak_rss_mb", "scored"]


def position_rmse(positions: NDArray, truth: NDArray) -> float:
    """Root-mean-square distance between estimated and true positions, both (n, 2), n ≥ 1, finite."""
    positions, truth = floats("positions", positions), floats("truth", truth)  # read: a float64 array not copied
    for name, a in (("positions", positions), ("truth", truth)):
        if a.ndim != 2 or a.shape[1] != 2 or a.shape[0] == 0:
            raise ShapeError(f"{name} must be (n, 2) positions, n >= 1, got shape {a.shape}")
        finite(name, a)
    if positions.shape != truth.shape:
        raise ShapeError(f"positions and truth must have the same shape, got {positions.shape} and {truth.shape}")
    errors = np.hypot(positions[:, 0] - truth[:, 0], positions[:, 1] - truth[:, 1])  # no square: no overflow
    return Statistics.rmse_of(errors)


def scored(trajectory: NDArray, truth: NDArray | None, rows: NDArray | None = None) -> float:
    """The position RMSE of ``trajectory`` (n, ≥2; x, y first) against ``truth`` (n, 2), over ``rows`` if given
    (all of them if not); NaN without a truth or without any pose."""
    if truth is None or not len(truth):
        return float("nan")
    if rows is not None:
        trajectory, truth = trajectory[rows, :2], truth[rows]  # the positions only copied
    return position_rmse(trajectory[:, :2], truth)


def peak_rss_mb() -> float:
    """Peak resident set size of this process in MB (Linux reports KB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _json_float(x: float) -> float | None:
    return None if not np.isfinite(x) else round(float(x), 6)


@dataclass(frozen=True, kw_only=True)
class RunResult:
    """What one streamed run did and produced: built by :meth:`StreamingEstimator.result
    <steam_ref.paper.online.StreamingEstimator.result>`, each field filled where it is measured."""

    options: StreamOptions  # what the run chose
    schedule: Schedule  # when its solver updated (the set-up's)
    times: NDArray  # (n,) time of every pose covered by the estimate, in the data set's seconds
    # (n, d) the state at every covered pose (Eq. 18 between states): [x, y, θ, ẋ, ẏ, θ̇] (d = 6), and then
    # [ẍ, ÿ, θ̈] with a WNOJ or Singer prior (d = 9)
    trajectory: NDArray
    state_poses: NDArray  # (M,) pose indices that have an estimated state
    landmarks: dict[int, NDArray]  # landmark id → estimate (2,)
    step_seconds: NDArray  # (n_steps,) wall time of each processed step (front end + solver)
    update_steps: NDArray  # (U,) pose index at which each solver update ran
    update_seconds: NDArray  # (U,) wall time of each solver update
    n_poses_total: int  # poses in the data set
    n_steps_processed: int  # poses the stream reached (all of them unless cut short)
    completed: bool  # False when the time budget or max_poses cut the run short
    rmse_m: float  # position RMSE over every covered pose against ground truth (NaN without it)
    rmse_states_m: float  # the same over the poses with a state only
    covariances: Covariances | None  # final marginals, when asked for
    peak_rss_mb: float  # peak resident memory of the process so far
    convergence_s: float | None = None  # converge_at_end: its wall time (within total_s); None: not run
    converged_at_end: bool | None = (
        None  # converge_at_end: whether the optimum passed its check; None: not run (not asked, or cut short)
    )
    n_marginalized: int | None = None  # with a lag: variables marginalized (states and landmarks)
    peak_window: int | None = None  # with a lag: most variables the solver held at once
    rmse_lagged_m: float | None = None  # with a lag and its history: the RMSE of the estimates as they left the window
    history_smoothing_s: float | None = (
        None  # with a lag and its history: wall time of the backward pass (not in total_s)
    )
    divergence: tuple[str, ...] = ()  # readings beyond any plausible noise, a diverging estimate (paper.divergence)

    @property
    def method(self) -> str:
        """'btgp', 'pb' or 'pbvr' (the options')."""
        return self.options.method

    @property
    def n_states(self) -> int:
        """Number of estimated states M."""
        return len(self.state_poses)

    @property
    def cumulative_s(self) -> NDArray:
        """(n_steps,) cumulative computation time against time step (Fig. 3/4, left)."""
        return np.cumsum(self.step_seconds)

    @property
    def total_s(self) -> float:
        """Total computation time of the streamed run."""
        return float(np.sum(self.step_seconds))

    def summary(self, dataset: str = "") -> dict:
        """The figures the CLI's ``--json`` prints."""
        u, o = self.update_seconds, self.options
        return {
            "dataset": dataset,
            "method": self.method,
            "every": self.schedule.every,
            "skip": o.skip,
            "interpolate": o.interpolate,
            "range_states": o.range_states,
            "n_estimated_states": self.n_states,
            "n_poses": len(self.times),
            "n_updates": len(u),
            "rmse_m": _json_float(self.rmse_m),
            "rmse_estimated_m": _json_float(self.rmse_states_m),
            "total_s": round(self.total_s, 4),
            "update_s_median": round(float(np.median(u)), 6) if len(u) else None,
            "update_s_p95": round(float(np.percentile(u, 95)), 6) if len(u) else None,
            "peak_rss_mb": round(self.peak_rss_mb, 1),
            "completed": self.completed,
            "divergence": list(self.divergence),
        } | (
            {
                "convergence_s": None if self.convergence_s is None else round(self.convergence_s, 4),
                "converged_at_end": self.converged_at_end,
            }
            if o.converge_at_end
            else {}
        )

    def lag_summary(self) -> dict:
        """With a lag, the figures of fixed-lag smoothing the CLI's ``--json`` adds; else nothing."""
        if self.options.lag is None:
            return {}
        out = {"lag_s": self.options.lag, "n_marginalized": self.n_marginalized, "peak_window": self.peak_window}
        if self.options.lag_history:  # rmse_m is then the smoothed past's; this, the estimates as they left the window
            lagged = self.rmse_lagged_m
            out |= {"lag_history": True, "rmse_lagged_m": None if lagged is None else _json_float(lagged)}
            out["history_smoothing_s"] = (
                None if self.history_smoothing_s is None else round(self.history_smoothing_s, 4)
            )
        return out
