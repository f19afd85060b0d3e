"""A streamed run: the front end feeds a solver on the paper's schedule.  [YIB Alg. 1, Sec. IV]

:class:`StreamingEstimator` is the run loop of Algorithm 1: each pose, the front end
(:mod:`steam_ref.paper.frontend`, step 1) releases new variables and factors; when the schedule says so
they go to the solver (:mod:`steam_ref.paper.solvers`: PB, PBVR or BTGP, steps 2-7), and the front end
then predicts from the solver's latest estimate. The loop asks every solver the same questions (what did the
last update forget?); the queries read a forgotten past as their ``past`` argument says (``"lagged"`` or
``"smoothed"``, :data:`~steam_ref.paper.online_solver.PASTS`).

When the solver updates is the set-up's :class:`~steam_ref.paper.presets.Schedule` (the paper's '/1' and
'/10', what starts the stream, Plaza's first batch solve); :class:`ScheduleClock` follows it as the
readings arrive. What a run chooses on top is :class:`~steam_ref.paper.options.StreamOptions`. Time
queries between states use Eq. 18 (:mod:`steam_ref.trajectory`).
"""

from __future__ import annotations

import time
import warnings
from array import array
from functools import partial

import numpy as np
from numpy.typing import NDArray

from ..arguments import flag, instance
from ..batch import BatchResult, levenberg_marquardt
from ..errors import ConvergenceWarning, SteamError
from ..graph import FactorGraph
from ..linear.threads import limited
from ..trajectory import Trajectory
from ..variables import Key, L, Values, X
from . import progress
from .converge import converge
from .divergence import DivergenceCheck
from .frontend import FrontEnd, NewStep
from .online_solver import OnlineSolver, SolverView
from .options import StreamOptions
from .presets import SETUP_HOW, PaperSetup, Schedule
from .readings import Readings
from .results import RunResult, peak_rss_mb, scored
from .solvers import forget_landmarks, make_solver

__all__ = ["ScheduleClock", "StreamingEstimator", "run_online"]

OPTIONS_HOW = "StreamOptions(method=..., ...): the run-time choices"  # how a stream's options are made


class ScheduleClock:
    """A :class:`~steam_ref.paper.presets.Schedule` followed as the readings arrive: is an update due now?
    [YIB Sec. IV: '/1', '/10']"""

    def __init__(self, schedule: Schedule, last_pose: int):
        self.schedule, self.last_pose = schedule, last_pose
        self.released = 0  # landmark readings (ranges, bearings, bearing-ranges) released so far
        self.since_update = 0  # landmark readings released since the last update
        self.started = False  # the solver has had its first update

    def due(self, step: NewStep) -> bool:
        """Count the step's landmark readings (ranges, bearings and bearing-ranges alike, as the '/1' and '/10'
        count them); True when the solver should update now."""
        self.released += step.n_landmark_readings
        self.since_update += step.n_landmark_readings
        if step.pose == self.last_pose:
            return True
        if (
            step.pose == 0
            or not step.is_state
            or (not self.started and self.released < self.schedule.start_after_ranges)
        ):
            return False  # the scripts loop over odometry rows: pose 0's factors go with pose 1's update
        return self.since_update >= self.schedule.every

    def updated(self) -> None:
        """The solver has just been updated."""
        self.started, self.since_update = True, 0


class EstimatesAfter:
    """The solver's estimates after an update, as the divergence fit asks for them (one call: the keys it names) and
    with the newest state's in the same query, kept in :attr:`answered` for the front end's next prediction."""

    def __init__(self, solver: OnlineSolver, newest: Key) -> None:
        self.solver, self.newest = solver, newest
        self.answered: dict[Key, NDArray] = {}  # empty when the fit asked nothing (no new factors)

    def __call__(self, keys: list[Key]) -> dict[Key, NDArray]:
        self.answered.update(self.solver.estimates_of(list(dict.fromkeys([*keys, self.newest]))))  # newest once
        return self.answered


class StreamingEstimator:
    """Algorithm 1 on a :class:`Readings` stream: the front end feeding an :class:`OnlineSolver`.

    Call :meth:`step` once per pose (or :meth:`run`); query :meth:`estimate_at`,
    :meth:`trajectory` and :meth:`landmark_estimates` at any moment.
    """

    def __init__(
        self,
        readings: Readings,
        setup: PaperSetup,
        options: StreamOptions,
        solver: OnlineSolver | None = None,
        *,
        name: str | None = None,  # the data set's, for the progress bar
    ):
        instance("readings", readings, Readings, "Readings.from_dataset(data, setup); run_online takes a data set")
        instance("setup", setup, PaperSetup, SETUP_HOW)
        instance("options", options, StreamOptions, OPTIONS_HOW)
        if solver is not None and options.converge_at_end:
            raise SteamError(
                "converge_at_end rebuilds steam_ref's own solver at the optimum: it cannot finish a solver passed in"
            )
        self.readings, self.setup, self.options, self.name = readings, setup, options, name
        self.front = FrontEnd(readings, setup, options.layout, options.max_poses)
        self.schedule = ScheduleClock(setup.schedule, self.front.n_poses - 1)
        self.solver = solver if solver is not None else self._new_solver()
        self.factors: list = []  # with converge_at_end, every factor given to the solver so far
        self.convergence: BatchResult | None = None  # what converge_at_end found
        self.convergence_seconds = 0.0  # its wall time (within the last update's)
        self.n_solved = 0  # how many of ``states`` the solver holds
        self._pending: list = []  # new factors not yet given to the solver
        self._pending_values = Values()  # initial estimates of new variables not yet given
        self.step_seconds = array("d")  # wall time of each processed pose (8 bytes each: a long run's records)
        self.update_steps = array("q")  # pose at which each solver update ran
        self.update_seconds = array("d")  # wall time of each solver update
        self.divergence = DivergenceCheck()  # readings beyond any noise, a diverging estimate (paper.divergence)
        self.broken: str | None = None  # a step that failed or was interrupted, and why: no step may follow

    def _new_solver(self) -> OnlineSolver:
        o = self.options
        return make_solver(
            o.method,
            isam2=self.setup.isam2_params(),
            pb_relative_tolerance=o.pb_relative_tolerance,
            pb_max_iterations=o.pb_max_iterations,
            lag=o.lag,
            times=self.readings.times,  # a lag stamps the states in the data's seconds, whatever the prior's clock
            keep_history=o.lag_history,
            lag_batch=o.lag_batch,
        )

    @property
    def n_poses(self) -> int:
        """Poses this run processes."""
        return self.front.n_poses

    @property
    def states(self) -> array[int]:
        """Poses with an estimated state so far, increasing (an ``array('q')``: 8 bytes a state)."""
        return self.front.states

    @property
    def done(self) -> bool:
        """True when every pose has been processed."""
        return self.front.done

    def step(self) -> None:
        """Process the readings of the next pose; update the solver when the schedule says so.

        A step that fails or is interrupted (Ctrl-C) may stop between the front end and the solver (the pose's
        readings taken but not given, or the solver updated but not told to the front end): the estimator then
        refuses every later step, naming the pose and the cause, where going on would drop those readings or give
        them twice. Its queries still answer for what the solver holds (an iSAM2 update itself is undone whole)."""
        if self.broken is not None:
            raise SteamError(
                f"{self.broken}: the front end and the solver may disagree on what was given, so this stream cannot "
                "go on; its queries answer for what the solver holds, and a new StreamingEstimator runs it again"
            )
        pose = self.front.n_processed
        try:
            self._step()
        except BaseException as err:
            if self.front.n_processed != pose:  # the front end took the pose (before that, nothing has changed)
                self.broken = f"the step of pose {pose} was stopped by {type(err).__name__}: {err}"
            raise

    def _step(self) -> None:
        """:meth:`step`'s work."""
        start = time.perf_counter()
        new = self.front.step()
        self._pending.extend(new.factors)
        for k, v in new.values.items():
            self._pending_values.insert(k, v, new.kinds.get(k))
        if self.schedule.due(new):
            self._update(new.pose)
        self.step_seconds.append(time.perf_counter() - start)

    def _update(self, pose: int) -> None:
        """Give the new factors to the solver (the first time, from a batch LM solve if the schedule says so)."""
        start = time.perf_counter()
        values, schedule = self._pending_values, self.setup.schedule
        if not self.schedule.started and schedule.initial_batch:
            tol = schedule.initial_batch_tolerance
            values = levenberg_marquardt(
                FactorGraph(self._pending), values, ordering="amd", relative_tolerance=tol, absolute_tolerance=tol
            ).values
        # the gate: new readings at the prediction; the fit: at the new estimate
        self.divergence.gate(self._pending, partial(self._predicted, prediction=values), pose)
        self.solver.update(self._pending, values)
        after = EstimatesAfter(self.solver, X(pose))
        self.divergence.fit(self._pending, after, pose)
        forget_landmarks(self.front.landmarks, self.solver)  # seen again, a landmark enters anew
        if self.options.converge_at_end:  # (a lag, which forgets factors, refuses it)
            self.factors.extend(self._pending)
        if pose == self.schedule.last_pose:
            for _ in range(schedule.final_updates):
                self.solver.update([], Values())
            if self.options.converge_at_end:
                self._converge()
        self.schedule.updated()
        self._pending, self._pending_values = [], Values()
        self.n_solved = len(self.states)
        # the front end predicts from the newest state's estimate: the fit's query gave it, unless the fit asked
        # nothing or the solver has moved since (the last pose: the final updates, converge_at_end's new solver)
        latest = after.answered.get(X(pose)) if pose != self.schedule.last_pose else None
        self.front.rebase(self.solver.estimate_of(X(pose)) if latest is None else latest)
        self.update_steps.append(pose)
        self.update_seconds.append(time.perf_counter() - start)

    def _predicted(self, keys: list[Key], prediction: Values) -> dict[Key, NDArray]:
        """The prediction of ``keys`` before an update: a new variable's initial value, the solver's estimate
        of one it holds (asked once for all of them)."""
        held = [k for k in keys if k not in prediction]
        out = self.solver.estimates_of(held) if held else {}
        out.update((k, prediction[k]) for k in keys if k in prediction)
        return out

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

    # -- queries (``past``: how a forgotten variable is read, "lagged" or "smoothed"; online_solver.PASTS) --

    def landmark_estimates(self, *, past: str = "lagged") -> dict[int, NDArray]:
        """Current estimate of every landmark the solver holds: id → (2,)."""
        if not self.schedule.started:
            return {}
        held = (lid for lid in sorted(self.front.landmarks) if L(lid) not in self._pending_values)
        return {lid: self.solver.estimate_of(L(lid), past=past).copy() for lid in held}

    def solved(self, *, past: str = "lagged") -> Trajectory:
        """The trajectory the solver holds: its states, queried at any time (Eq. 18)."""
        seen = SolverView(self.solver, past)
        return Trajectory(seen, self.states[: self.n_solved], self.readings.clock, self.front.prior)

    def estimate_at(
        self, t: float, *, covariance: bool = False, past: str = "lagged"
    ) -> NDArray | tuple[NDArray, NDArray]:
        """The state x(t) (n,) at any time t in the data's seconds from the first solved state on (the GP prior's
        clock is the set-up's, ``readings.clock`` maps between them), with its covariance (n, n) if asked:
        [YIB Eq. 18] between states, the prior's prediction after the last one (``Trajectory.at``)."""
        return self.solved(past=past).at(t, covariance=covariance)

    def trajectory(self, *, past: str = "lagged") -> tuple[NDArray, NDArray]:
        """Times (n_poses,) in the data's seconds and states (n_poses, n) at every pose of the solved span (Eq. 18
        between states)."""
        return self.solved(past=past).at_every_pose()

    # -- a whole run --

    @limited
    def run(self, ground_truth: NDArray | None = None, *, covariances: bool = False) -> RunResult:
        """Process the stream to its end (or the time budget); ``ground_truth`` (n_poses, ≥3) with x,
        y in columns 1-2 (the CMU GT layout) gives the RMSE; ``covariances`` adds the final marginals."""
        if flag("covariances", covariances) and self.options.lag is not None:  # before the run, not after it
            raise SteamError(
                f"covariances=True gives every state's final marginal covariance, which lag={self.options.lag!r} "
                "forgets: drop one of them"
            )
        o = self.options
        budget, completed = o.time_budget_s, True
        label = progress.stream_label(self.name, o.method, self.setup.schedule.every, o.skip, o.interpolate)
        with progress.bar(self.n_poses, label, o.progress, unit="pose") as shown:
            while not self.done:
                self.step()
                shown.update(1)
                if budget is not None and sum(self.step_seconds) > budget and not self.done:
                    completed = False
                    progress.say(
                        f"{label}: time budget {budget:g} s used up after {len(self.step_seconds):,} of "
                        f"{self.n_poses:,} poses; the run stops there (reported as cut short)",
                        o.progress,
                    )
                    break
        return self.result(ground_truth, completed and self.n_poses == self.readings.n_poses, covariances=covariances)

    def result(
        self, ground_truth: NDArray | None = None, completed: bool = True, *, covariances: bool = False
    ) -> RunResult:
        """A :class:`RunResult` of what has been processed so far, scored against ``ground_truth`` (CMU GT layout,
        x, y in columns 1-2) if given. With ``lag_history`` its trajectory is the past smoothed from the current
        window, and the estimates as they left the window give ``rmse_lagged_m``; no later query changes."""
        history = self.options.lag_history
        past = "smoothed" if history else "lagged"
        solved = self.solved(past=past)
        times, states = solved.at_every_pose()
        truth = None if ground_truth is None else np.asarray(ground_truth)[: len(times), 1:3]
        poses = np.array(solved.states, dtype=int)
        marks = self.landmark_estimates(past=past)
        convergence = self.convergence
        return RunResult(
            options=self.options,
            schedule=self.setup.schedule,
            times=times,
            trajectory=states,
            state_poses=poses,
            landmarks=marks,
            step_seconds=np.array(self.step_seconds),
            update_steps=np.array(self.update_steps, dtype=int),
            update_seconds=np.array(self.update_seconds),
            n_poses_total=self.readings.n_poses,
            n_steps_processed=self.front.n_processed,
            completed=completed,
            rmse_m=scored(states, truth),
            rmse_states_m=scored(states, truth, poses),
            covariances=solved.covariances([L(i) for i in marks]) if covariances else None,
            peak_rss_mb=peak_rss_mb(),
            convergence_s=None if convergence is None else self.convergence_seconds,
            converged_at_end=None if convergence is None else convergence.converged,
            n_marginalized=self.solver.n_marginalized,
            peak_window=self.solver.peak_window,
            rmse_lagged_m=scored(self.trajectory()[1], truth) if history else None,
            history_smoothing_s=self.solver.smoothing_seconds,
            divergence=tuple(self.divergence.findings),
        )


@limited
def run_online(
    data, setup: PaperSetup, options: StreamOptions | None = None, *, covariances: bool = False, **changes
) -> RunResult:
    """Stream ``data`` (a :class:`~steam_ref.datasets.RangeDataset` or
    :class:`~steam_ref.datasets.LandmarkDataset`, or the :class:`Readings` made from one) through the chosen solver.

    ``options`` default to :class:`StreamOptions`'s defaults; keyword ``changes`` override fields. A data
    set's ground truth, when it has one, gives the RMSE; :class:`Readings` carry none.
    """
    options = StreamOptions() if options is None else instance("options", options, StreamOptions, OPTIONS_HOW)
    options = options.replace(**changes) if changes else options
    if isinstance(data, Readings):
        readings, truth = data, None
    else:
        readings, truth = Readings.from_dataset(data, setup), data.ground_truth
    name = getattr(data, "name", None)
    return StreamingEstimator(readings, setup, options, name=name).run(truth, covariances=covariances)
