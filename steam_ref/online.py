"""The streaming front end of BTGP and its batch competitors.  [YIB Alg. 1 step 1, Sec. III-B, IV]

Readings arrive in time order, one time step (pose) at a time, as from a robot. The front end
decides which poses get an estimated state x(tᵢ): a pose ``skip`` steps after the previous state,
plus (when ``range_states``) every pose with a range reading, plus the last one
(:func:`~steam_ref.problem.estimated_poses`). A reading at an estimated pose becomes an ordinary factor on it; a reading at any other pose is buffered until the next
estimated state exists and then enters as an interpolated factor on its two neighbours (Eq. 29),
or is dropped when ``interpolate=False`` (the paper's "without interpolation"). Each new state
brings a GP prior factor (Eq. 22) to the previous one, and an initial guess made by composing
odometry from the latest estimate, as the paper's scripts do.

The accumulated new factors go to a solver after every ``every`` range readings (the paper's '/1'
and '/10' schedules) and at the last pose. Three solvers share one small interface:

- ``pb``: periodic batch Gauss-Newton over everything so far, XL ordering, warm-started [YIB Sec. IV];
- ``pbvr``: the same with AMD reordering at every update;
- ``btgp``: the Bayes tree (:class:`steam_ref.bayes_tree.IncrementalSolver`, Alg. 1 steps 2-7).

On Plaza the solvers start only once ``start_after_ranges`` (50) ranges have arrived, with one
batch Levenberg-Marquardt solve of everything so far, as in the paper's script.

Per update the front end touches only the current step, the buffer of readings since the last
state and the estimate of the latest state, so its work does not grow with the trajectory.
"""

from __future__ import annotations

import resource
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .batch import gauss_newton, levenberg_marquardt, make_ordering
from .bayes_tree import IncrementalSolver
from .errors import SteamError
from .factors import Factor, GPPriorFactor, InterpolatedFactor, RangeFactor, VelocityFactor
from .gp.interpolate import interpolate_covariance, interpolation_matrices
from .graph import FactorGraph
from .variables import Key, L, Values, X
from .linear.solve import SparseCholesky
from .linear.system import LinearSystem
from .pose2 import compose
from .problem import PaperSetup, Readings, landmark_prior, position_rmse, prior_factors

__all__ = [
    "METHODS",
    "StreamOptions",
    "OnlineSolver",
    "PeriodicBatchSolver",
    "BayesTreeSolver",
    "make_solver",
    "StreamingEstimator",
    "RunResult",
    "run_online",
    "default_options",
    "joint_covariance",
]

METHODS = ("btgp", "pb", "pbvr")


# --- Options ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class StreamOptions:
    """How a run is streamed and solved; every field can be overridden."""

    method: str = "btgp"  # 'btgp', 'pb' or 'pbvr'
    every: int = 1  # update after this many range readings ('/1', '/10')
    skip: int = 1  # a state at most skip poses after the previous one (every skip-th pose)
    interpolate: bool = True  # readings between states: interpolated (Eq. 29) or dropped
    range_states: bool = False  # also estimate every pose that has a range reading
    start_after_ranges: int | None = None  # None: the set-up's (Plaza 50, synthetic 0)
    final_updates: int = 0  # extra solver updates with no new factors after the last pose
    relinearize_threshold: float | dict[str, float] = 0.1  # BTGP: one threshold, or one per kind {'x': …, 'l': …}
    relinearize_skip: int = 10  # BTGP: check relinearization every this many updates (GTSAM's default)
    wildfire_threshold: float = 1e-3  # BTGP: stop back-substitution below this change
    pb_relative_tolerance: float = 1e-5  # PB/PBVR Gauss-Newton stopping rule (GTSAM's default)
    pb_max_iterations: int = 100  # PB/PBVR iterations per update
    max_poses: int | None = None  # process only this prefix of the poses
    time_budget_s: float | None = None  # stop when the run has taken this long (reported)
    progress: bool = False  # tqdm progress bar

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise SteamError(f"unknown method {self.method!r}; use one of {', '.join(METHODS)}")
        for name in ("every", "skip"):
            value = getattr(self, name)
            if isinstance(value, bool) or int(value) != value or value < 1:
                raise SteamError(f"{name} must be a positive integer, got {value!r}")
        if self.max_poses is not None and self.max_poses < 2:
            raise SteamError(f"max_poses must be at least 2, got {self.max_poses!r}")
        if self.time_budget_s is not None and not self.time_budget_s > 0:
            raise SteamError(f"time_budget_s must be positive, got {self.time_budget_s!r}")
        if self.start_after_ranges is not None and self.start_after_ranges < 0:
            raise SteamError(f"start_after_ranges must be >= 0, got {self.start_after_ranges!r}")

    def replace(self, **changes) -> StreamOptions:
        """A copy with some fields changed."""
        from dataclasses import replace

        return replace(self, **changes)


def default_options(setup: PaperSetup, **changes) -> StreamOptions:
    """The documented defaults for a preset: the synthetic script ends with 10 extra updates."""
    base = StreamOptions(final_updates=10 if setup.name == "synthetic" else 0)
    return base.replace(**changes) if changes else base


# --- Solvers ------------------------------------------------------------------------------------


class OnlineSolver:
    """What the front end needs from a solver."""

    name: str = ""

    def update(self, factors: list[Factor], values: Values) -> None:
        """Add new factors and the initial estimates of new variables, then re-solve."""
        raise NotImplementedError

    def estimate_of(self, key: Key) -> NDArray:
        """Current estimate of one variable."""
        raise NotImplementedError

    def estimate(self) -> Values:
        """Current estimate of every variable."""
        raise NotImplementedError

    def joint_covariance(self, keys: Sequence[Key]) -> NDArray:
        """Joint marginal covariance of ``keys``, (Σdₖ, Σdₖ), in the order given."""
        raise NotImplementedError


def joint_covariance(factors: Sequence[Factor], values: Values, keys: Sequence[Key]) -> NDArray:
    """Joint block of 𝓘⁻¹ for ``keys``, linearized at ``values``.  [YIB Eq. 11: cov δθ* = 𝓘⁻¹]

    One sparse Cholesky factorization (AMD order) and one solve with Σdₖ right-hand sides.
    """
    graph = FactorGraph(factors)
    order = make_ordering(graph, values, "amd")
    system = LinearSystem.build(graph.factors, values, order)
    info, _ = system.information()
    chol = SparseCholesky.factor(info, order)
    cols = np.concatenate([order.offset_of[k] + np.arange(values.dim(k)) for k in keys])
    E = np.zeros((info.shape[0], len(cols)))
    E[cols, np.arange(len(cols))] = 1.0
    block = np.asarray(chol.solve(E))[cols]
    return 0.5 * (block + block.T)


class PeriodicBatchSolver(OnlineSolver):
    """PB (XL ordering) or PBVR (AMD): Gauss-Newton over everything, warm-started.  [YIB Sec. IV]"""

    def __init__(self, ordering: str = "xl", relative_tolerance: float = 1e-5, max_iterations: int = 100):
        self.name = "pb" if ordering == "xl" else "pbvr"
        self.ordering = ordering
        self.options = dict(relative_tolerance=relative_tolerance, max_iterations=max_iterations)
        self.graph = FactorGraph()
        self.values = Values()
        self.iterations: list[int] = []  # Gauss-Newton iterations of each update

    def update(self, factors: list[Factor], values: Values) -> None:
        self.graph.add(factors)
        for k in values:
            self.values.insert(k, values[k])
        result = gauss_newton(self.graph, self.values, ordering=self.ordering, **self.options)
        self.values = result.values
        self.iterations.append(len(result.iterations))

    def estimate_of(self, key: Key) -> NDArray:
        return self.values[key]

    def estimate(self) -> Values:
        return self.values

    def joint_covariance(self, keys: Sequence[Key]) -> NDArray:
        return joint_covariance(self.graph.factors, self.values, keys)


class BayesTreeSolver(OnlineSolver):
    """BTGP: the incremental solver of :mod:`steam_ref.bayes_tree`.  [YIB Alg. 1 steps 2-7]

    The defaults are GTSAM's ISAM2 defaults, which the paper's scripts use: relinearization
    threshold 0.1, checked every 10th update, wildfire threshold 1e-3.
    """

    name = "btgp"

    def __init__(self, relinearize_threshold: float | dict = 0.1, relinearize_skip: int = 10, wildfire_threshold: float = 1e-3):
        if not isinstance(relinearize_threshold, dict):
            relinearize_threshold = float(relinearize_threshold)
        self.inner = IncrementalSolver(
            relinearize_threshold=relinearize_threshold,
            relinearize_skip=relinearize_skip,
            wildfire_threshold=wildfire_threshold,
        )
        self.reports: list = []  # UpdateReport of each update

    def update(self, factors: list[Factor], values: Values) -> None:
        self.reports.append(self.inner.update(factors, values))

    def estimate_of(self, key: Key) -> NDArray:
        return self.inner.estimate_of(key)

    def estimate(self) -> Values:
        return self.inner.estimate()

    def joint_covariance(self, keys: Sequence[Key]) -> NDArray:
        return self.inner.joint_marginal_covariance(list(keys))  # from the tree's cliques


def make_solver(options: StreamOptions) -> OnlineSolver:
    """The solver ``options.method`` names, configured from ``options``."""
    if options.method == "btgp":
        return BayesTreeSolver(options.relinearize_threshold, options.relinearize_skip, options.wildfire_threshold)
    return PeriodicBatchSolver(
        "xl" if options.method == "pb" else "amd", options.pb_relative_tolerance, options.pb_max_iterations
    )


# --- Results ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RunResult:
    """What one streamed run did and produced."""

    method: str  # 'btgp', 'pb' or 'pbvr'
    options: StreamOptions  # everything the run was configured with
    times: NDArray  # (n,) time of every pose covered by the estimate
    estimates: NDArray  # (n, 6) [x, y, θ, ẋ, ẏ, θ̇] at every covered pose (interpolated by Eq. 18)
    estimated: NDArray  # (M,) pose indices that had an estimated state
    landmarks: dict[int, NDArray]  # landmark id → estimate (2,)
    step_seconds: NDArray  # (n_steps,) wall time of each processed step (front end + solver)
    update_steps: NDArray  # (U,) pose index at which each solver update ran
    update_seconds: NDArray  # (U,) wall time of each solver update
    n_poses_total: int  # poses in the data set
    n_steps_processed: int  # poses the stream reached (all of them unless cut short)
    completed: bool  # False when the time budget or max_poses cut the run short
    rmse_m: float  # position RMSE over every covered pose against ground truth (NaN without it)
    rmse_estimated_m: float  # the same over the estimated states only
    peak_rss_mb: float  # peak resident memory of the process so far

    @property
    def n_estimated_states(self) -> int:
        """Number of estimated states M."""
        return len(self.estimated)

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
        u = self.update_seconds
        return {
            "dataset": dataset,
            "method": self.method,
            "every": self.options.every,
            "skip": self.options.skip,
            "interpolate": self.options.interpolate,
            "range_states": self.options.range_states,
            "n_estimated_states": self.n_estimated_states,
            "n_poses": int(len(self.times)),
            "n_updates": int(len(u)),
            "rmse_m": _json_float(self.rmse_m),
            "rmse_estimated_m": _json_float(self.rmse_estimated_m),
            "total_s": round(self.total_s, 4),
            "update_s_median": round(float(np.median(u)), 6) if len(u) else None,
            "update_s_p95": round(float(np.percentile(u, 95)), 6) if len(u) else None,
            "peak_rss_mb": round(self.peak_rss_mb, 1),
            "completed": self.completed,
        }


def _json_float(x: float) -> float | None:
    return None if not np.isfinite(x) else round(float(x), 6)


def peak_rss_mb() -> float:
    """Peak resident set size of this process in MB (Linux reports KB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


# --- The front end ------------------------------------------------------------------------------


class StreamingEstimator:
    """Algorithm 1 step 1 on a :class:`Readings` stream, feeding an :class:`OnlineSolver`.

    Call :meth:`step` once per pose (or :meth:`run`); query :meth:`estimate_at` and
    :meth:`landmark_estimates` at any moment.
    """

    def __init__(self, readings: Readings, setup: PaperSetup, options: StreamOptions, solver: OnlineSolver | None = None):
        self.readings, self.setup, self.options = readings, setup, options
        self.solver = solver if solver is not None else make_solver(options)
        n = readings.n_poses if options.max_poses is None else min(options.max_poses, readings.n_poses)
        self.n_poses = n  # poses this run will process
        self.start_after = setup.start_after_ranges if options.start_after_ranges is None else options.start_after_ranges
        order = np.argsort(readings.range_pose, kind="stable")
        self._range_order = order
        self._range_bounds = np.searchsorted(readings.range_pose[order], np.arange(n + 1), side="left")
        self.next_pose = 0  # the pose step() processes next
        self.states: list[int] = []  # estimated poses so far, increasing
        self.solved_states = 0  # how many of ``states`` the solver holds
        self._pending: list[Factor] = []  # new factors not yet given to the solver
        self._pending_values = Values()  # initial estimates of new variables not yet given
        self._buffer: list[tuple[int, Factor]] = []  # readings at poses after the last state
        self._landmarks: set[int] = set()  # landmarks with a variable
        self._ranges_released = 0  # range factors released to the solver's stream so far
        self._ranges_since_update = 0
        self._started = False  # the solver has had its first update
        self._pose = readings.first_pose.copy()  # predicted [x, y, θ] of the current pose
        self._velocity = np.zeros(3)  # predicted velocity over the last step
        self.step_seconds: list[float] = []
        self.update_steps: list[int] = []
        self.update_seconds: list[float] = []

    # -- the stream --

    @property
    def done(self) -> bool:
        """True when every pose has been processed."""
        return self.next_pose >= self.n_poses

    def step(self) -> None:
        """Process the readings of the next pose; update the solver when the schedule says so."""
        if self.done:
            raise SteamError(f"the stream has ended: all {self.n_poses} poses processed")
        start = time.perf_counter()
        i = self.next_pose
        if i == 0:
            self._begin()
        else:
            self._predict(i)
            if self._is_state(i):
                self._add_state(i)
            else:
                self._buffer_readings(i)
            if self.states[-1] == i and (self._ranges_since_update >= self.options.every or i == self.n_poses - 1):
                self._update(i)
        self.next_pose += 1
        self.step_seconds.append(time.perf_counter() - start)

    def _is_state(self, i: int) -> bool:
        """Pose i gets an estimated state: ``skip`` steps after the last one, at a range reading if
        asked, and the last pose (the rule of ``problem.estimated_poses``, decided as the stream goes)."""
        if i - self.states[-1] >= self.options.skip or i == self.n_poses - 1:
            return True
        return self.options.range_states and self._range_bounds[i + 1] > self._range_bounds[i]

    def _begin(self) -> None:
        """Pose 0: its state, the prior on it, and its range readings."""
        guess = np.concatenate([self._pose, self.setup.first_velocity])
        self.states.append(0)
        self._pending_values.insert(X(0), guess)
        self._pending.extend(prior_factors(self.readings, self.setup))
        for inner in self._ranges_at(0):  # they go to the solver with the next state
            self._release(inner)

    def _predict(self, i: int) -> None:
        """Initial guess of pose i: compose odometry row i-1 onto the latest pose (paper's scripts)."""
        distance, _, turn = self.readings.velocity[i]
        new = compose(self._pose, distance, turn)
        self._velocity = new - self._pose  # dt = 1
        self._pose = new

    def _ranges_at(self, i: int) -> list[Factor]:
        """Range readings of pose i as factors on X(i) (X(i) may be a missing state)."""
        r, s = self.readings, self.setup
        rows = self._range_order[self._range_bounds[i] : self._range_bounds[i + 1]]
        return [
            RangeFactor.create(X(i), L(r.range_landmark[k]), r.range_value[k], s.range_sigma, loss=s.range_loss)
            for k in rows
        ]

    def _velocity_at(self, i: int, interpolated: bool) -> VelocityFactor:
        sigmas = self.setup.interpolated_velocity_sigmas if interpolated else self.setup.velocity_sigmas
        return VelocityFactor.create(X(i), self.readings.velocity[i], sigmas)

    def _buffer_readings(self, i: int) -> None:
        """Readings at a missing state wait for the next state, or are dropped without interpolation."""
        if self.options.interpolate:
            self._buffer.append((i, self._velocity_at(i, interpolated=True)))
            self._buffer.extend((i, f) for f in self._ranges_at(i))

    def _add_state(self, i: int) -> None:
        """New state X(i): GP prior to the previous state, its readings, the buffered readings."""
        prev = self.states[-1]
        self._pending_values.insert(X(i), np.concatenate([self._pose, self._velocity]))
        self._pending.append(self._gp_prior(prev, i))
        for pose, inner in self._buffer:
            self._release(self._interpolated(inner, prev, i, pose))
        self._buffer = []
        self._release(self._velocity_at(i, interpolated=False))
        for inner in self._ranges_at(i):
            self._release(inner)
        self.states.append(i)

    def _gp_prior(self, a: int, b: int) -> GPPriorFactor:
        """The GP prior factor between states a and b.  [YIB Eq. 22]"""
        times = self.readings.times
        return GPPriorFactor.wnoa(X(a), X(b), times[b] - times[a], self.setup.qc)

    def _interpolated(self, inner: Factor, a: int, b: int, pose: int) -> InterpolatedFactor:
        """``inner`` (a reading at the missing pose) on states a and b.  [YIB Eq. 29]"""
        t = self.readings.times
        return InterpolatedFactor.create(inner, X(a), X(b), t[a], t[b], t[pose], self.setup.qc)

    def _release(self, factor: Factor) -> None:
        """A factor joins the new-factor set; a landmark seen for the first time gets its prior."""
        inner = factor.inner if isinstance(factor, InterpolatedFactor) else factor
        if isinstance(inner, RangeFactor):
            lid = factor.keys[-1].index
            if lid not in self._landmarks:
                self._landmarks.add(lid)
                self._pending.append(landmark_prior(self.readings, lid, self.setup))
                self._pending_values.insert(L(lid), self.readings.landmarks[lid])
            self._ranges_released += 1
            self._ranges_since_update += 1
        self._pending.append(factor)

    def _update(self, i: int) -> None:
        """Give the new factors to the solver (after a first batch LM solve on Plaza)."""
        last = i == self.n_poses - 1
        if not self._started and self._ranges_released < self.start_after and not last:
            return
        start = time.perf_counter()
        values = self._pending_values
        if not self._started and self.start_after > 0:
            values = levenberg_marquardt(FactorGraph(self._pending), values, ordering="amd").values
        self.solver.update(self._pending, values)
        self._started = True
        self._pending, self._pending_values = [], Values()
        self._ranges_since_update = 0
        self.solved_states = len(self.states)
        self._pose = self.solver.estimate_of(X(self.states[-1]))[:3].copy()  # compose from the estimate
        if last:
            for _ in range(self.options.final_updates):
                self.solver.update([], Values())
        self.update_steps.append(i)
        self.update_seconds.append(time.perf_counter() - start)

    # -- queries --

    def landmark_estimates(self) -> dict[int, NDArray]:
        """Current estimate of every landmark the solver holds: id → (2,)."""
        if not self._started:
            return {}
        return {lid: self.solver.estimate_of(L(lid)).copy() for lid in sorted(self._landmarks) if L(lid) not in self._pending_values}

    def _neighbours(self, t: float) -> tuple[int, int] | int:
        """The solved state at time t, or the two solved states around it."""
        times = self.readings.times
        solved = self.states[: self.solved_states]
        if not solved or not times[solved[0]] <= t <= times[solved[-1]]:
            span = "no solved state yet" if not solved else f"[{times[solved[0]]:g}, {times[solved[-1]]:g}]"
            raise SteamError(f"time t={t!r} is outside the estimated span {span}")
        j = int(np.searchsorted(times[solved], t))
        if times[solved[j]] == t:
            return solved[j]
        return solved[j - 1], solved[j]

    def estimate_at(self, t: float, *, covariance: bool = False) -> NDArray | tuple[NDArray, NDArray]:
        """The state x(t) (6,) at any time within the solved span, with its covariance (6, 6) if asked.

        At an estimated state: the solver's estimate and marginal covariance. Between states i, j:
        x̄(t) = Λ(t) x̄ᵢ + Ψ(t) x̄ⱼ [YIB Eq. 18], and the covariance from the joint covariance of
        (xᵢ, xⱼ) by :func:`steam_ref.gp.interpolate.interpolate_covariance`.
        """
        near = self._neighbours(float(t))
        if isinstance(near, int):
            mean = self.solver.estimate_of(X(near)).copy()
            return (mean, self.solver.joint_covariance([X(near)])) if covariance else mean
        a, b = near
        times, qc = self.readings.times, self.setup.qc
        lam, psi = interpolation_matrices(times[a], times[b], t, qc)
        mean = lam @ self.solver.estimate_of(X(a)) + psi @ self.solver.estimate_of(X(b))  # [YIB Eq. 18]
        if not covariance:
            return mean
        joint = self.solver.joint_covariance([X(a), X(b)])
        return mean, interpolate_covariance(times[a], times[b], t, qc, joint)

    def trajectory(self) -> tuple[NDArray, NDArray]:
        """Times (n,) and states (n, 6) at every pose of the solved span, interpolated between
        states by Eq. 18. Reads the solver's whole estimate once."""
        solved = self.states[: self.solved_states]
        if not solved:
            return np.zeros(0), np.zeros((0, 6))
        values = self.solver.estimate()
        times = self.readings.times
        out = np.empty((solved[-1] + 1, 6))
        for a, b in zip(solved, solved[1:]):
            xa, xb = values[X(a)], values[X(b)]
            out[a] = xa
            for p in range(a + 1, b):
                lam, psi = interpolation_matrices(times[a], times[b], times[p], self.setup.qc)  # [YIB Eq. 16]
                out[p] = lam @ xa + psi @ xb  # [YIB Eq. 18]
        out[solved[-1]] = values[X(solved[-1])]
        return times[: solved[-1] + 1].copy(), out

    # -- a whole run --

    def run(self, ground_truth: NDArray | None = None) -> RunResult:
        """Process the stream to its end (or the time budget); ``ground_truth`` (n_poses, ≥3) x, y
        in columns 1-2 (the CMU GT layout) gives the RMSE."""
        from tqdm import tqdm

        budget = self.options.time_budget_s
        completed = True
        with tqdm(total=self.n_poses, disable=not self.options.progress, desc=self.options.method, mininterval=0.5) as bar:
            while not self.done:
                self.step()
                bar.update(1)
                if budget is not None and sum(self.step_seconds) > budget and not self.done:
                    completed = False
                    break
        return self.result(ground_truth, completed and self.n_poses == self.readings.n_poses)

    def result(self, ground_truth: NDArray | None = None, completed: bool = True) -> RunResult:
        """A :class:`RunResult` of what has been processed so far."""
        times, states = self.trajectory()
        estimated = np.array(self.states[: self.solved_states], dtype=int)
        rmse = rmse_est = float("nan")
        if ground_truth is not None and len(times):
            truth = np.asarray(ground_truth)[: len(times), 1:3]
            rmse = position_rmse(states[:, :2], truth)
            rmse_est = position_rmse(states[estimated, :2], truth[estimated])
        return RunResult(
            self.options.method, self.options, times, states, estimated, self.landmark_estimates(),
            np.array(self.step_seconds), np.array(self.update_steps, dtype=int), np.array(self.update_seconds),
            self.readings.n_poses, self.next_pose, completed, rmse, rmse_est, peak_rss_mb(),
        )


def run_online(data, setup: PaperSetup, options: StreamOptions | None = None, **changes) -> RunResult:
    """Stream a :class:`~steam_ref.datasets.RangeDataset` through the chosen solver.

    ``options`` default to :func:`default_options` for ``setup``; keyword ``changes`` override fields.
    """
    options = default_options(setup) if options is None else options
    options = options.replace(**changes) if changes else options
    readings = Readings.from_dataset(data, setup)
    return StreamingEstimator(readings, setup, options).run(data.ground_truth)
