"""The paper's experimental set-up, and the STEAM problem built from a range-only data set.  [YIB Sec. IV]

:class:`PaperSetup` holds every parameter of the paper's experiments (from its public scripts, as
summarised in ``shared/data/README.md``); ``PaperSetup.synthetic()`` and ``PaperSetup.plaza()`` are the
documented defaults and any field can be overridden with ``dataclasses.replace``.

:class:`Readings` turns a :class:`~steam_ref.datasets.RangeDataset` into the measurement stream the
solvers consume: time is the odometry row index (dt = 1), pose i is ground-truth row i, odometry
row k is a projected-velocity reading of pose k + 1, and each range belongs to the first pose at
or after its time stamp. :func:`build_problem` makes the whole batch problem (Eq. 6) from it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from .datasets import RangeDataset
from .pose2 import integrate_odometry
from .errors import SteamError
from .factors import Factor, GPPriorFactor, InterpolatedFactor, PriorFactor, RangeFactor, VelocityFactor
from .graph import FactorGraph
from .variables import L, Values, X
from .robust import Tukey

__all__ = ["PaperSetup", "Readings", "SteamProblem", "build_problem", "dead_reckoning_values", "estimated_poses", "position_rmse"]


@dataclass(frozen=True)
class PaperSetup:
    """Parameters of one of the paper's experiments."""

    name: str  # 'synthetic' or 'plaza'
    qc: NDArray  # (3, 3) power spectral density of the WNOA prior [YIB Eq. 31]
    velocity_sigmas: NDArray  # (3,) projected-velocity noise at an estimated state
    interpolated_velocity_sigmas: NDArray  # (3,) the same reading when interpolated (Eq. 29)
    range_sigma: float  # [m]
    tukey_c: float | None  # Tukey threshold on whitened range errors; None: plain least squares
    landmark_prior_sigma: float  # [m] prior on landmarks at their surveyed positions (Eq. 4)
    first_pose_sigmas: NDArray  # (3,) prior on pose 0 at ground truth
    first_velocity_sigmas: NDArray  # (3,) prior on velocity 0 at ``first_velocity``
    first_velocity: NDArray = field(default_factory=lambda: np.full(3, 1e-4))  # (3,)
    range_correction_steps: int = 0  # fit r' = a r + b on ranges of the first N poses; 0: none
    start_after_ranges: int = 0  # incremental solvers start after this many ranges (batch LM first)

    @classmethod
    def synthetic(cls) -> PaperSetup:
        """The synthetic exploration task (Sec. IV-A)."""
        return cls(
            name="synthetic",
            qc=0.01 * np.diag([1.0, 1.0, 25.0]),
            velocity_sigmas=np.array([0.5, 0.5, 1.0]),
            interpolated_velocity_sigmas=np.array([0.5, 0.5, 1.0]),
            range_sigma=1.0,
            tukey_c=15.0,
            landmark_prior_sigma=1.0,
            first_pose_sigmas=np.array([1.0, 1.0, np.pi]),
            first_velocity_sigmas=np.array([1.0, 1.0, np.pi]),
        )

    @classmethod
    def plaza(cls) -> PaperSetup:
        """The Autonomous Lawnmower 'Plaza' run (Sec. IV-B)."""
        return cls(
            name="plaza",
            qc=0.05 * np.diag([1.0, 1.0, 2.0]),
            velocity_sigmas=np.array([0.05, 0.01, 0.02]),
            interpolated_velocity_sigmas=np.array([0.5, 0.01, 0.02]),
            range_sigma=20.0,
            tukey_c=15.0,
            landmark_prior_sigma=1.0,
            first_pose_sigmas=np.array([1.0, 1.0, np.pi]),
            first_velocity_sigmas=np.array([1.0, 1.0, np.pi]),
            range_correction_steps=3000,
            start_after_ranges=50,
        )

    @classmethod
    def named(cls, name: str) -> PaperSetup:
        """The preset called 'synthetic' or 'plaza'."""
        if name not in ("synthetic", "plaza"):
            raise SteamError(f"unknown preset {name!r}; use 'synthetic' or 'plaza'")
        return cls.synthetic() if name == "synthetic" else cls.plaza()

    def replace(self, **changes) -> PaperSetup:
        """A copy with some fields changed."""
        return replace(self, **changes)

    @property
    def range_loss(self) -> Tukey | None:
        """The robust loss on ranges."""
        return None if self.tukey_c is None else Tukey(self.tukey_c)


@dataclass(frozen=True)
class Readings:
    """The measurement stream of a data set, in solver terms (time = pose index, dt = 1)."""

    times: NDArray  # (n_poses,) time of pose i: i
    velocity: NDArray  # (n_poses, 3) projected velocity reading of pose i; row 0 unused (NaN)
    range_pose: NDArray  # (n_ranges,) pose each range belongs to
    range_landmark: NDArray  # (n_ranges,) landmark id
    range_value: NDArray  # (n_ranges,) range [m], corrected if the set-up says so
    range_correction: tuple[float, float]  # (a, b) of r' = a r + b; (1, 0) when not corrected
    first_pose: NDArray  # (3,) ground-truth pose 0 [x, y, θ]
    landmarks: dict[int, NDArray]  # id → surveyed position (2,)

    @classmethod
    def from_dataset(cls, data: RangeDataset, setup: PaperSetup) -> Readings:
        """Convert a data set following the paper's scripts (see the module docstring)."""
        n = data.n_poses
        velocity = np.full((n, 3), np.nan)
        velocity[1:, 0] = data.odometry[:, 1]  # distance / dt with dt = 1
        velocity[1:, 1] = 0.0  # no lateral motion
        velocity[1:, 2] = data.odometry[:, 2]  # heading change / dt
        pose = data.range_state_indices()
        value = data.ranges[:, 3].astype(float)
        a, b = 1.0, 0.0
        if setup.range_correction_steps > 0:
            a, b = _affine_range_fit(value, data.gt_ranges(), pose < setup.range_correction_steps)
            value = a * value + b
        marks = {int(i): np.array([x, y]) for i, x, y in data.landmarks}
        return cls(
            np.arange(n, dtype=float), velocity, pose, data.ranges[:, 2].astype(int), value, (a, b),
            data.ground_truth[0, 1:4].copy(), marks,
        )

    @property
    def n_poses(self) -> int:
        """Number of poses (time steps + 1)."""
        return len(self.times)


def _affine_range_fit(measured: NDArray, true: NDArray, use: NDArray) -> tuple[float, float]:
    """Least-squares (a, b) with a·measured + b ≈ true over the readings selected by ``use``."""
    if np.count_nonzero(use) < 2:
        raise SteamError(f"range correction needs at least 2 readings in its window, got {np.count_nonzero(use)}")
    M = np.column_stack([measured[use], np.ones(np.count_nonzero(use))])
    (a, b), *_ = np.linalg.lstsq(M, true[use], rcond=None)
    return float(a), float(b)


@dataclass(frozen=True)
class SteamProblem:
    """A batch STEAM problem: factors, a starting estimate, and which poses are estimated."""

    graph: FactorGraph  # all factors
    initial: Values  # starting estimate of every variable
    estimated: NDArray  # (M,) sorted pose indices with a state X(i)
    times: NDArray  # (n_poses,) time of every pose
    setup: PaperSetup


def state_factor(inner: Factor, pose: int, estimated: NDArray, times: NDArray, setup: PaperSetup) -> Factor | None:
    """A reading of pose ``pose`` as a factor on estimated states.

    ``inner`` names X(pose). If that state is estimated, it is returned as it is; otherwise it is
    interpolated between the neighbouring estimated states (Eq. 29). Returns None when ``pose``
    lies outside the estimated span (nothing to interpolate from).
    """
    j = int(np.searchsorted(estimated, pose))
    if j < len(estimated) and estimated[j] == pose:
        return inner
    if j == 0 or j == len(estimated):
        return None
    i1, i2 = int(estimated[j - 1]), int(estimated[j])
    return InterpolatedFactor.create(inner, X(i1), X(i2), times[i1], times[i2], times[pose], setup.qc)


def _velocity_reading(readings: Readings, pose: int, setup: PaperSetup, interpolated: bool) -> VelocityFactor:
    sigmas = setup.interpolated_velocity_sigmas if interpolated else setup.velocity_sigmas
    return VelocityFactor.create(X(pose), readings.velocity[pose], sigmas)


def build_problem(
    data: RangeDataset, setup: PaperSetup, *, skip: int = 1, interpolate: bool = True, range_states: bool = False
) -> SteamProblem:
    """The batch problem over all of ``data``: priors, GP prior factors and every reading.

    The poses with an estimated state are :func:`estimated_poses` (``range_states`` adds every pose
    with a range reading). Readings at other poses are interpolated (Eq. 29) when
    ``interpolate``, otherwise dropped (the paper's "without interpolation").
    """
    readings = Readings.from_dataset(data, setup)
    n = readings.n_poses
    estimated = estimated_poses(n, skip, readings.range_pose if range_states else None)
    chosen = set(estimated.tolist())
    times = readings.times
    graph = FactorGraph(prior_factors(readings, setup))
    graph.add(GPPriorFactor.wnoa(X(a), X(b), times[b] - times[a], setup.qc) for a, b in zip(estimated, estimated[1:]))
    for lid in sorted(set(readings.range_landmark.tolist())):
        graph.add(landmark_prior(readings, lid, setup))
    readings_at = [(p, _velocity_reading(readings, p, setup, p not in chosen)) for p in range(1, n)]
    readings_at += [
        (int(p), RangeFactor.create(X(p), L(lid), r, setup.range_sigma, loss=setup.range_loss))
        for p, lid, r in zip(readings.range_pose, readings.range_landmark, readings.range_value)
    ]
    for pose, inner in readings_at:
        if pose in chosen or interpolate:
            f = state_factor(inner, pose, estimated, times, setup)
            if f is not None:
                graph.add(f)
    initial = dead_reckoning_values(readings, data, estimated)
    return SteamProblem(graph, initial, estimated, times, setup)


def estimated_poses(n_poses: int, skip: int, range_poses: NDArray | None = None) -> NDArray:
    """The poses that get an estimated state, in the order a stream meets them: (M,) sorted.

    Pose 0, the last pose, any pose ``skip`` steps after the previous state, and, when
    ``range_poses`` is given, every pose in it. Without range poses this is every ``skip``-th pose,
    the "time-step difference between estimated states" of [YIB Sec. IV]. With them it is the
    layout of the paper's Plaza script (``skip`` = 5: a state at every range reading and at
    most 5 steps apart), whose estimate the paper publishes.
    """
    if isinstance(skip, bool) or int(skip) != skip or skip < 1:
        raise SteamError(f"skip must be a positive integer, got {skip!r}")
    has_range = np.zeros(n_poses, dtype=bool)
    if range_poses is not None:
        has_range[np.asarray(range_poses, dtype=int)] = True
    chosen = [0]
    for i in range(1, n_poses):
        if has_range[i] or i - chosen[-1] >= skip or i == n_poses - 1:
            chosen.append(i)
    return np.array(chosen)


def prior_factors(readings: Readings, setup: PaperSetup) -> list[Factor]:
    """Priors on pose 0 (at ground truth) and on velocity 0, as one prior on X(0)."""
    mean = np.concatenate([readings.first_pose, setup.first_velocity])
    sigmas = np.concatenate([setup.first_pose_sigmas, setup.first_velocity_sigmas])
    return [PriorFactor.create(X(0), mean, sigmas)]


def landmark_prior(readings: Readings, lid: int, setup: PaperSetup) -> PriorFactor:
    """Prior on landmark ``lid`` at its surveyed position (Eq. 4)."""
    return PriorFactor.create(L(lid), readings.landmarks[lid], setup.landmark_prior_sigma)


def dead_reckoning_values(readings: Readings, data: RangeDataset, estimated: NDArray) -> Values:
    """Initial estimate: odometry integrated from the ground-truth pose 0, velocities by differences.

    Landmarks start at their surveyed positions.
    """
    start = np.concatenate([[data.ground_truth[0, 0]], readings.first_pose])
    path = integrate_odometry(start, data.odometry)[:, 1:4]
    vel = np.vstack([np.diff(path, axis=0), np.zeros((1, 3))])  # velocity over the next step, dt = 1
    values = Values({X(i): np.concatenate([path[i], vel[i]]) for i in estimated})
    for lid in sorted(set(readings.range_landmark.tolist())):
        values.insert(L(lid), readings.landmarks[lid])
    return values


def position_rmse(positions: NDArray, truth: NDArray) -> float:
    """Root-mean-square distance between estimated and true positions, both (n, 2)."""
    return float(np.sqrt(np.mean(np.sum((np.asarray(positions) - np.asarray(truth)) ** 2, axis=1))))


def _pose_keys_within(factor: Factor, last: int) -> bool:
    return all(k.kind != "x" or k.index <= last for k in factor.keys)


def _extend_by_odometry(values: Values, guess: Values, anchor: int, poses: list[int]) -> None:
    """Insert states for ``poses`` from ``guess`` (dead reckoning), moved rigidly so that the guess's
    state ``anchor`` lands on the current estimate of ``anchor``: composing odometry from there."""
    a_est, a_dr = values[X(anchor)], guess[X(anchor)]
    dth = a_est[2] - a_dr[2]
    c, s = np.cos(dth), np.sin(dth)
    R = np.array([[c, -s], [s, c]])
    for i in poses:
        g = guess[X(i)]
        p = R @ (g[:2] - a_dr[:2]) + a_est[:2]
        values.insert(X(i), np.concatenate([p, [g[2] + dth], R @ g[3:5], [g[5]]]))


def sequential_batch(problem: SteamProblem, *, chunk: int = 100, ordering: str = "amd", final_iterations: int = 50, **options):
    """Batch solution of ``problem`` started from a sequence of growing batches.

    Dead reckoning drifts far (about 21 m RMS on the paper's synthetic set), too far for
    Gauss-Newton on everything at once, which then stops in a local minimum. So the batch is
    initialised as a robot would do it: solve the first ``chunk`` poses, extend the estimate by
    odometry to the next ``chunk`` poses, solve again (warm-started), and so on; the last solve
    is a full Gauss-Newton on all the data. Returns the final :class:`~steam_ref.batch.BatchResult`.
    """
    from .batch import gauss_newton

    est = [int(i) for i in problem.estimated]
    values = Values((k, problem.initial[k]) for k in problem.initial.landmarks())
    values.insert(X(est[0]), problem.initial[X(est[0])])
    done = 0  # position in est of the last solved state
    for stop in range(chunk, est[-1] + chunk, chunk):
        new = [i for i in est[done + 1 :] if i <= stop]
        if not new:
            continue
        _extend_by_odometry(values, problem.initial, est[done], new)
        done += len(new)
        last = est[done]
        sub = FactorGraph(f for f in problem.graph if _pose_keys_within(f, last))
        used = set(sub.keys())
        sub_values = Values((k, values[k]) for k in values if k in used)
        final = last == est[-1]
        result = gauss_newton(sub, sub_values, ordering=ordering, max_iterations=final_iterations if final else 10, **options)
        for k in result.values:
            values.insert(k, result.values[k])
    return result
