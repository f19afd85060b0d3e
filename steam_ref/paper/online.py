"""A streamed run: the front end feeds a solver on the paper's schedule.  [YIB Alg. 1, Sec. IV]

:class:`StreamingEstimator` is the run loop of Algorithm 1: each pose, the front end
(:mod:`steam_ref.paper.frontend`, step 1) releases new variables and factors; when the schedule says so
they go to the solver (:mod:`steam_ref.paper.solvers`: PB, PBVR or BTGP, steps 2-7), and the front end
then predicts from the solver's latest estimate.

The schedule (:class:`Schedule`, the paper's '/1' and '/10'): the new factors go to the solver at an
estimated state once ``every`` landmark readings (ranges, bearings, bearing-ranges) have been released
since the last update, and at the last pose. On Plaza nothing is solved until ``start_after_ranges`` (50) ranges have arrived; then one
batch Levenberg-Marquardt solve of everything so far seeds the solver, as in the paper's scripts.
Time queries between states use Eq. 18 (:mod:`steam_ref.trajectory`).
"""

from __future__ import annotations

import numbers
import time
import warnings
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..arguments import integer
from ..batch import BatchResult, levenberg_marquardt
from ..bayes_tree import ISAM2Params
from ..errors import ConvergenceWarning, SteamError
from ..graph import FactorGraph
from ..trajectory import Trajectory
from ..variables import L, Values, X
from .converge import converge
from .divergence import DivergenceCheck
from .frontend import FrontEnd, Layout, NewStep
from .presets import PaperSetup
from .readings import Readings
from .results import RunResult, peak_rss_mb
from .solvers import METHODS, PB_MAX_ITERATIONS, PB_RELATIVE_TOLERANCE, OnlineSolver, make_solver

__all__ = ["StreamOptions", "Schedule", "StreamingEstimator", "run_online", "INITIAL_SOLVE"]

# The first batch solve on Plaza: GTSAM's LevenbergMarquardtParams defaults, which the scripts use.
INITIAL_SOLVE: dict[str, Any] = dict(ordering="amd", relative_tolerance=1e-5, absolute_tolerance=1e-5)


@dataclass(frozen=True)
class StreamOptions:
    """How a run is streamed and solved; every field can be overridden."""

    method: str = "btgp"  # 'btgp', 'pb' or 'pbvr'
    every: int | None = None  # update after this many landmark readings ('/1', '/10'); None: the set-up's
    skip: int = Layout.skip  # a state at most skip poses after the previous one (see frontend.Layout)
    interpolate: bool = Layout.interpolate  # readings between states: interpolated (Eq. 29) or dropped
    range_states: bool = Layout.range_states  # also estimate every pose that has a range reading
    start_after_ranges: int | None = None  # None: the set-up's (Plaza 50, synthetic 0)
    final_updates: int | None = None  # extra solver updates after the last pose; None: the set-up's (synthetic 10)
    converge_at_end: bool = False  # after the last pose, iterate everything to the batch optimum (converge.py)
    isam2: ISAM2Params | None = None  # BTGP's iSAM2 settings; None: the set-up's (PaperSetup.isam2_params)
    pb_relative_tolerance: float = PB_RELATIVE_TOLERANCE  # PB/PBVR Gauss-Newton stopping rule
    pb_max_iterations: int = PB_MAX_ITERATIONS  # PB/PBVR iterations per update
    max_poses: int | None = None  # process only this prefix of the poses
    time_budget_s: float | None = None  # stop when the run has taken this long (reported)
    progress: bool = False  # tqdm progress bar

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise SteamError(f"unknown method {self.method!r}; use one of {', '.join(METHODS)}")
        _check_count("every", self.every, 1)
        for name in ("interpolate", "range_states", "progress", "converge_at_end"):
            if not isinstance(getattr(self, name), bool):
                raise SteamError(f"{name} must be True or False, got {getattr(self, name)!r}")
        Layout(self.skip, self.range_states, self.interpolate)  # checks skip
        _check_count("max_poses", self.max_poses, 2)
        _check_count("start_after_ranges", self.start_after_ranges, 0)
        _check_count("final_updates", self.final_updates, 0)
        _check_count("pb_max_iterations", self.pb_max_iterations, 1)
        if self.time_budget_s is not None and not (_is_real(self.time_budget_s) and self.time_budget_s > 0):
            raise SteamError(f"time_budget_s must be a number > 0 (or None), got {self.time_budget_s!r}")
        if not (_is_real(self.pb_relative_tolerance) and 0 <= self.pb_relative_tolerance < np.inf):
            raise SteamError(f"pb_relative_tolerance must be a finite number >= 0, got {self.pb_relative_tolerance!r}")
        if self.isam2 is not None and not isinstance(self.isam2, ISAM2Params):
            raise SteamError(f"isam2 must be an ISAM2Params (or None for the set-up's), got {self.isam2!r}")

    @property
    def layout(self) -> Layout:
        """The state layout these options ask for."""
        return Layout(self.skip, self.range_states, self.interpolate)

    def replace(self, **changes) -> StreamOptions:
        """A copy with some fields changed; SteamError names an unknown field."""
        unknown = sorted(set(changes) - {f.name for f in fields(self)})
        if unknown:
            raise SteamError(f"StreamOptions has no field {unknown[0]!r}")
        return replace(self, **changes)


def _is_real(value: object) -> bool:
    """A real number (NaN included: callers compare it), never a bool."""
    return not isinstance(value, bool) and isinstance(value, numbers.Real)


def _check_count(name: str, value: object, lowest: int) -> None:
    """None (the set-up's, or no limit), or an integer >= ``lowest``: :func:`~steam_ref.arguments.integer`."""
    if value is not None:
        integer(name, value, lowest)


class Schedule:
    """When the new factors go to the solver.  [YIB Sec. IV: '/1', '/10']"""

    def __init__(self, every: int, start_after: int, last_pose: int):
        self.every, self.start_after, self.last_pose = every, start_after, last_pose
        self.released = 0  # landmark readings (ranges, bearings, bearing-ranges) released so far
        self.since_update = 0  # landmark readings released since the last update
        self.started = False  # the solver has had its first update

    def due(self, step: NewStep) -> bool:
        """Count the step's ranges; True when the solver should update now."""
        self.released += step.n_landmark_readings
        self.since_update += step.n_landmark_readings
        if step.pose == self.last_pose:
            return True
        if step.pose == 0 or not step.is_state or (not self.started and self.released < self.start_after):
            return False  # the scripts loop over odometry rows: pose 0's factors go with pose 1's update
        return self.since_update >= self.every

    def updated(self) -> None:
        """The solver has just been updated."""
        self.started, self.since_update = True, 0


class StreamingEstimator:
    """Algorithm 1 on a :class:`Readings` stream: the front end feeding an :class:`OnlineSolver`.

    Call :meth:`step` once per pose (or :meth:`run`); query :meth:`estimate_at`,
    :meth:`trajectory` and :meth:`landmark_estimates` at any moment.
    """

    def __init__(
        self, readings: Readings, setup: PaperSetup, options: StreamOptions, solver: OnlineSolver | None = None
    ):
        if solver is not None and options.converge_at_end:
            raise SteamError(
                "converge_at_end rebuilds steam_ref's own solver at the optimum: it cannot finish a solver passed in"
            )
        every = setup.every if options.every is None else options.every
        options = options.replace(every=every)  # the result reports the schedule that ran
        self.readings, self.setup, self.options = readings, setup, options
        self.front = FrontEnd(readings, setup, options.layout, options.max_poses)
        start = setup.start_after_ranges if options.start_after_ranges is None else options.start_after_ranges
        self.schedule = Schedule(every, start, self.front.n_poses - 1)
        self.final_updates = setup.final_updates if options.final_updates is None else options.final_updates
        self.solver = solver if solver is not None else self._new_solver()
        self.factors: list = []  # every factor given to the solver so far
        self.convergence: BatchResult | None = None  # what converge_at_end found
        self.convergence_seconds = 0.0  # its wall time (within the last update's)
        self.n_solved = 0  # how many of ``states`` the solver holds
        self._pending: list = []  # new factors not yet given to the solver
        self._pending_values = Values()  # initial estimates of new variables not yet given
        self.step_seconds: list[float] = []  # wall time of each processed pose
        self.update_steps: list[int] = []  # pose at which each solver update ran
        self.update_seconds: list[float] = []  # wall time of each solver update
        self.divergence = DivergenceCheck()  # readings beyond any noise, a diverging estimate (paper.divergence)

    def _new_solver(self) -> OnlineSolver:
        o = self.options
        isam2 = self.setup.isam2_params() if o.isam2 is None else o.isam2
        return make_solver(
            o.method, isam2=isam2, pb_relative_tolerance=o.pb_relative_tolerance, pb_max_iterations=o.pb_max_iterations
        )

    @property
    def n_poses(self) -> int:
        """Poses this run processes."""
        return self.front.n_poses

    @property
    def states(self) -> list[int]:
        """Poses with an estimated state so far, increasing."""
        return self.front.states

    @property
    def done(self) -> bool:
        """True when every pose has been processed."""
        return self.front.done

    def step(self) -> None:
        """Process the readings of the next pose; update the solver when the schedule says so."""
        start = time.perf_counter()
        new = self.front.step()
        self._pending.extend(new.factors)
        for k, v in new.values.items():
            self._pending_values.insert(k, v)
        if self.schedule.due(new):
            self._update(new.pose)
        self.step_seconds.append(time.perf_counter() - start)

    def _update(self, pose: int) -> None:
        """Give the new factors to the solver (after a first batch LM solve on Plaza)."""
        start = time.perf_counter()
        values = self._pending_values
        if not self.schedule.started and self.schedule.start_after > 0:
            values = levenberg_marquardt(FactorGraph(self._pending), values, **INITIAL_SOLVE).values
        prediction = values  # the gate: new readings at the prediction; the fit: at the new estimate
        self.divergence.gate(
            self._pending, lambda k: prediction[k] if k in prediction else self.solver.estimate_of(k), pose
        )
        self.solver.update(self._pending, values)
        self.divergence.fit(self._pending, self.solver.estimate_of, pose)
        self.factors.extend(self._pending)
        if pose == self.schedule.last_pose:
            for _ in range(self.final_updates):
                self.solver.update([], Values())
            if self.options.converge_at_end:
                self._converge()
        self.schedule.updated()
        self._pending, self._pending_values = [], Values()
        self.n_solved = len(self.states)
        self.front.rebase(self.solver.estimate_of(X(pose)))  # predict from the estimate
        self.update_steps.append(pose)
        self.update_seconds.append(time.perf_counter() - start)

    def _converge(self) -> None:
        """Iterate the whole problem from the solver's estimate to the batch optimum
        (:func:`~steam_ref.paper.converge.converge`), then hand it to a new solver: one update with every
        factor, linearized there (for BTGP a Bayes tree eliminated from scratch), so that its
        estimate and covariances are those of the optimum. Warns when the optimum's check fails."""
        start = time.perf_counter()
        self.convergence = converge(FactorGraph(self.factors), self.solver.estimate())
        if not self.convergence.converged:
            warnings.warn(f"converge_at_end: {self.convergence.reason}", ConvergenceWarning, stacklevel=4)
        self.solver = self._new_solver()
        self.solver.update(self.factors, self.convergence.values)
        self.convergence_seconds = time.perf_counter() - start

    # -- queries --

    def landmark_estimates(self) -> dict[int, NDArray]:
        """Current estimate of every landmark the solver holds: id → (2,)."""
        if not self.schedule.started:
            return {}
        held = (lid for lid in sorted(self.front.landmarks) if L(lid) not in self._pending_values)
        return {lid: self.solver.estimate_of(L(lid)).copy() for lid in held}

    def solved(self) -> Trajectory:
        """The trajectory the solver holds: its states, queried at any time (Eq. 18)."""
        return Trajectory(self.solver, self.states[: self.n_solved], self.readings.times, self.setup.motion_prior())

    def estimate_at(self, t: float, *, covariance: bool = False) -> NDArray | tuple[NDArray, NDArray]:
        """The state x(t) (n,) at any time from the first solved state on, with its covariance (n, n) if asked:
        [YIB Eq. 18] between states, the prior's prediction after the last one (``Trajectory.at``)."""
        return self.solved().at(t, covariance=covariance)

    def trajectory(self) -> tuple[NDArray, NDArray]:
        """Times (n_poses,) and states (n_poses, n) at every pose of the solved span (Eq. 18 between states)."""
        return self.solved().at_every_pose()

    # -- a whole run --

    def run(self, ground_truth: NDArray | None = None, *, covariances: bool = False) -> RunResult:
        """Process the stream to its end (or the time budget); ``ground_truth`` (n_poses, ≥3) with x,
        y in columns 1-2 (the CMU GT layout) gives the RMSE; ``covariances`` adds the final marginals."""
        from tqdm import tqdm

        budget, completed = self.options.time_budget_s, True
        with tqdm(
            total=self.n_poses, disable=not self.options.progress, desc=self.options.method, mininterval=0.5
        ) as bar:
            while not self.done:
                self.step()
                bar.update(1)
                if budget is not None and sum(self.step_seconds) > budget and not self.done:
                    completed = False
                    break
        return self.result(ground_truth, completed and self.n_poses == self.readings.n_poses, covariances=covariances)

    def result(
        self, ground_truth: NDArray | None = None, completed: bool = True, *, covariances: bool = False
    ) -> RunResult:
        """A :class:`RunResult` of what has been processed so far."""
        solved = self.solved()
        times, states = solved.at_every_pose()
        marks = self.landmark_estimates()
        return RunResult.of(
            self.options,
            times,
            states,
            np.array(solved.states, dtype=int),
            marks,
            np.array(self.step_seconds),
            np.array(self.update_steps, dtype=int),
            np.array(self.update_seconds),
            self.readings.n_poses,
            self.front.n_processed,
            completed,
            ground_truth,
            solved.covariances([L(i) for i in marks]) if covariances else None,
            peak_rss_mb(),
            self.convergence_seconds if self.convergence is not None else None,
            self.convergence.converged if self.convergence is not None else None,
            self.divergence.findings,
        )


def run_online(
    data, setup: PaperSetup, options: StreamOptions | None = None, *, covariances: bool = False, **changes
) -> RunResult:
    """Stream ``data`` (a :class:`~steam_ref.datasets.RangeDataset` or
    :class:`~steam_ref.datasets.LandmarkDataset`, or the :class:`Readings` made from one) through the chosen solver.

    ``options`` default to :class:`StreamOptions`'s defaults; keyword ``changes`` override fields. A data
    set's ground truth, when it has one, gives the RMSE; :class:`Readings` carry none.
    """
    options = StreamOptions() if options is None else options
    options = options.replace(**changes) if changes else options
    if isinstance(data, Readings):
        readings, truth = data, None
    else:
        readings, truth = Readings.from_dataset(data, setup), data.ground_truth
    return StreamingEstimator(readings, setup, options).run(truth, covariances=covariances)
