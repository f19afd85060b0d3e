"""The batch STEAM problem of a data set: everything the front end yields.  [YIB Eq. 6, Sec. IV]

:func:`build_problem` runs :class:`~steam_ref.frontend.FrontEnd` over the whole stream and
collects its factors and initial values; the streaming solvers consume the same steps, so the batch
and the streamed problem are the same factor graph by construction. :func:`sequential_batch` solves
it the way a robot would start: a growing batch, warm-started chunk by chunk.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .batch import BatchResult, gauss_newton
from .datasets import RangeDataset
from .errors import SteamError
from .frontend import FrontEnd, Layout
from .graph import FactorGraph
from .readings import PaperSetup, Readings
from .variables import Values, X

__all__ = ["SteamProblem", "build_problem", "sequential_batch"]


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
        """(n_poses,) time of every pose."""
        return self.readings.times


def build_problem(data: RangeDataset | Readings, setup: PaperSetup, layout: Layout | None = None, **layout_fields) -> SteamProblem:
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
            initial.insert(k, v)
    return SteamProblem(graph, initial, np.array(front.states), readings, setup, layout)


def sequential_batch(problem: SteamProblem, *, chunk: int = 100, ordering: str = "amd", final_iterations: int = 50, **options) -> BatchResult:
    """Batch solution of ``problem`` started from a sequence of growing batches.

    Dead reckoning drifts far (about 21 m RMS on the paper's synthetic set), too far for
    Gauss-Newton on everything at once, which then stops in a local minimum. So the batch is
    initialised as a robot would do it: the front end streams the first ``chunk`` poses, they are
    solved (at most 10 Gauss-Newton iterations), the next poses are predicted from that estimate,
    and so on; the last solve is a full Gauss-Newton on all the data. Returns its result (only that
    one is checked for stationarity).
    """
    for name, value in (("chunk", chunk), ("final_iterations", final_iterations)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
            raise SteamError(f"{name} must be a positive integer, got {value!r}")
    front = FrontEnd(problem.readings, problem.setup, problem.layout)
    graph, values, stop = FactorGraph(), Values(), chunk
    result = None
    for step in front:
        graph.add(step.factors)
        for k, v in step.values.items():
            values.insert(k, v)
        if step.is_state and (step.pose >= stop or front.done):
            its = final_iterations if front.done else 10
            result = gauss_newton(graph, values, ordering=ordering, max_iterations=its, check=front.done, **options)
            values = result.values
            front.rebase(values[X(step.pose)])
            stop = (step.pose // chunk + 1) * chunk
    if result is None:
        raise SteamError(f"the problem has {problem.readings.n_poses} pose(s): a batch needs at least two")
    return result
