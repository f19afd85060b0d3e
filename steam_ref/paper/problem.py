"""The batch STEAM problem of a data set: everything the front end yields.  [YIB Eq. 6, Sec. IV]

:func:`build_problem` runs :class:`~steam_ref.paper.frontend.FrontEnd` over the whole stream and
collects its factors and initial values; the streaming solvers consume the same steps, so the batch
and the streamed problem are the same factor graph by construction. :func:`sequential_batch` solves
it the way a robot would start: a growing batch, warm-started chunk by chunk. :func:`converged_batch`
polishes that to the optimum, the reference a run is scored against when there is no ground truth
(:func:`score_against_batch`, Victoria Park).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..arguments import is_integer
from ..batch import BatchResult, gauss_newton
from ..datasets import LandmarkDataset, RangeDataset
from ..errors import SteamError
from ..graph import FactorGraph
from ..linear.threads import limited
from ..variables import L, Values, X
from .converge import converge
from .frontend import FrontEnd, Layout
from .presets import PaperSetup
from .readings import Readings

__all__ = [
    "SteamProblem",
    "build_problem",
    "sequential_batch",
    "converged_batch",
    "SAME_MINIMUM",
    "BatchScore",
    "reference_batch",
    "score_estimate",
    "score_against_batch",
]


@dataclass(frozen=True)
class SteamProblem:
    """A batch STEAM problem: factors, a starting estimate, and which poses have a state."""

    graph: FactorGraph  # all factors
    initial: Values  # starting estimate of every variable (dead reckoning, surveyed landmarks)
    states: NDArray  # (M,) sorted pose indices with a state X(i)
    readings: Readings  # the stream the problem was built from
    setup: PaperSetup  # the paper's parameters used
    layout: Layout  # the state layout used

    @property
    def times(self) -> NDArray:
        """(n_poses,) time of every pose in seconds, on the data's clock."""
        return self.readings.times

    @property
    def model_times(self) -> NDArray:
        """(n_poses,) time of every pose on the model's clock: what the GP prior sees."""
        return self.readings.model_times


def build_problem(
    data: RangeDataset | LandmarkDataset | Readings, setup: PaperSetup, layout: Layout | None = None, **layout_fields
) -> SteamProblem:
    """The batch problem over all of ``data``: every factor and initial value the front end yields.

    ``layout`` (or its fields as keywords: ``skip``, ``range_states``, ``interpolate``) chooses the
    states; the default is a state at every pose.
    """
    readings = data if isinstance(data, Readings) else Readings.from_dataset(data, setup)
    layout = Layout(**layout_fields) if layout is None else layout
    front = FrontEnd(readings, setup, layout)
    graph, initial = FactorGraph(), Values()
    for step in front:
        graph.add(step.factors)
        for k, v in step.values.items():
            initial.insert(k, v, step.kinds.get(k))
    return SteamProblem(graph, initial, np.array(front.states), readings, setup, layout)


@limited
def sequential_batch(
    problem: SteamProblem, *, chunk: int = 100, ordering: str = "amd", final_iterations: int = 50, **options
) -> BatchResult:
    """Batch solution of ``problem`` started from a sequence of growing batches.

    Dead reckoning drifts far (about 21 m RMS on the paper's synthetic set), too far for
    Gauss-Newton on everything at once, which then stops in a local minimum. So the batch is
    initialised as a robot would do it: the front end streams the first ``chunk`` poses, they are
    solved (at most 10 Gauss-Newton iterations), the next poses are predicted from that estimate,
    and so on; the last solve is a full Gauss-Newton on all the data. Returns its result (only that
    one is checked for stationarity).
    """
    for name, value in (("chunk", chunk), ("final_iterations", final_iterations)):
        if not is_integer(value) or value < 1:
            raise SteamError(f"{name} must be a positive integer, got {value!r}")
    front = FrontEnd(problem.readings, problem.setup, problem.layout)
    graph, values, stop = FactorGraph(), Values(), chunk
    result = None
    for step in front:
        graph.add(step.factors)
        for k, v in step.values.items():
            values.insert(k, v, step.kinds.get(k))
        if step.is_state and (step.pose >= stop or front.done):
            its = final_iterations if front.done else 10
            result = gauss_newton(graph, values, ordering=ordering, max_iterations=its, check=front.done, **options)
            values = result.values
            front.rebase(values[X(step.pose)])
            stop = (step.pose // chunk + 1) * chunk
    if result is None:
        raise SteamError(f"the problem has {problem.readings.n_poses} pose(s): a batch needs at least two")
    return result


@limited
def converged_batch(
    problem: SteamProblem,
    *,
    start: Values | None = None,
    step_tolerance: float = 1e-6,
    chunk: int = 100,
    ordering: str = "amd",
) -> BatchResult:
    """A minimum of ``problem`` to where no variable moves by more than ``step_tolerance``: the batch
    reference (:func:`~steam_ref.paper.converge.converge`: Gauss-Newton with an exact line search along the
    map's turn about the origin, and Anderson acceleration; its stationarity checked as usual).

    Starts from ``start`` or else from :func:`sequential_batch` (``chunk``; larger chunks can end in a
    worse minimum: on Victoria Park's first 1,500 poses chunks of 500 reach a cost of 661, of 100 one of
    422).
    """
    values = sequential_batch(problem, chunk=chunk, ordering=ordering).values if start is None else start
    return converge(problem.graph, values, step_tolerance=step_tolerance, ordering=ordering)


def _significant(x: float) -> float:
    """``x`` to 4 significant digits: distances span metres (the stream) to nanometres (converged runs)."""
    return float(f"{float(x):.4g}")


@dataclass(frozen=True)
class BatchScore:
    """An estimate against the converged batch solution of the same problem (no ground truth needed)."""

    poses: NDArray  # (n,) the states compared
    distance: NDArray  # (n,) position distance to the batch optimum at each [m]
    distance_unrotated: (
        NDArray  # (n,) the same once the estimate is turned about the origin onto the optimum (the weak gauge removed)
    )
    rotation: float  # that turn [rad]
    cost_gap: float  # the estimate's cost minus the optimum's
    batch: BatchResult  # the batch solve
    batch_seconds: float  # its wall time
    batch_start: str = "sequential"  # where the reference's descent started: 'sequential' (batch), or 'estimate' when that found the lower minimum

    def summary(self) -> dict:
        """The figures a JSON line reports."""
        d, u = self.distance, self.distance_unrotated
        return {
            "batch_distance_median_m": _significant(np.median(d)),
            "batch_distance_max_m": _significant(np.max(d)),
            "batch_distance_unrotated_median_m": _significant(np.median(u)),
            "batch_distance_unrotated_max_m": _significant(np.max(u)),
            "batch_rotation_rad": float(f"{self.rotation:.3g}"),
            "batch_cost_gap": float(f"{self.cost_gap:.4g}"),
            "batch_converged": self.batch.converged,
            "batch_s": round(self.batch_seconds, 2),
            "batch_start": self.batch_start,
        }


def score_estimate(
    problem: SteamProblem,
    batch: BatchResult,
    estimate: Values,
    batch_seconds: float = 0.0,
    batch_start: str = "sequential",
) -> BatchScore:
    """``estimate`` (every variable of ``problem``) against ``batch``, its solution: distances at the states."""
    poses = np.asarray(problem.states, dtype=int)
    ours = np.array([estimate[X(int(i))][:2] for i in poses])
    best = np.array([batch.values[X(int(i))][:2] for i in poses])
    angle = float(np.arctan2(np.sum(ours[:, 0] * best[:, 1] - ours[:, 1] * best[:, 0]), np.sum(ours * best)))
    c, s = np.cos(angle), np.sin(angle)
    turned = ours @ np.array([[c, s], [-s, c]])
    gap = problem.graph.error(estimate) - problem.graph.error(batch.values)
    return BatchScore(
        poses, np.hypot(*(ours - best).T), np.hypot(*(turned - best).T), angle, gap, batch, batch_seconds, batch_start
    )


SAME_MINIMUM = 1e-6  # relative cost difference below which two converged descents count as one minimum


def reference_batch(problem: SteamProblem, estimate: Values | None = None) -> tuple[BatchResult, str]:
    """The batch reference for scoring ``estimate``: :func:`converged_batch` from the sequential batch and,
    when an estimate is given, from it too, whichever minimum is lower: ``(result, 'sequential' | 'estimate')``.
    A descent from the estimate guards against the batch stopping in a worse minimum than the run found;
    two descents into one minimum differ in cost by their tolerance only, so the estimate's must be lower
    by more than :data:`SAME_MINIMUM` (relative) to be taken."""
    best, where = converged_batch(problem), "sequential"
    if estimate is not None:
        other = converged_batch(problem, start=estimate)
        if other.cost < best.cost * (1 - SAME_MINIMUM):
            best, where = other, "estimate"
    return best, where


def score_against_batch(result, readings: Readings, setup: PaperSetup) -> BatchScore:
    """A streamed run (:class:`~steam_ref.paper.results.RunResult`) against the batch optimum of the same problem
    (:func:`reference_batch`): the same set-up and layout, the poses up to the run's last solved state,
    compared at its states. A fixed-lag run (``lag``) forgot states and landmarks the batch has: refused."""
    if result.options.lag is not None:
        raise SteamError(
            f"scoring against the batch optimum needs every state and landmark the run estimated, and lag="
            f"{result.options.lag!r} forgot the old ones"
        )
    states = np.asarray(result.state_poses, dtype=int)
    last = int(states[-1]) + 1
    problem = build_problem(
        readings if last == readings.n_poses else readings.prefix(last), setup, result.options.layout
    )
    estimate = Values(
        {X(int(i)): np.asarray(result.trajectory[i]) for i in states}
        | {L(j): np.asarray(p) for j, p in result.landmarks.items()},
        kinds=problem.initial.kinds(),  # SE(2) states move as such
    )
    start = time.perf_counter()
    batch, where = reference_batch(problem, estimate)
    return score_estimate(problem, batch, estimate, time.perf_counter() - start, where)
