"""The solvers a stream can feed: PB, PBVR, BTGP and the fixed-lag BTGP, each an :class:`OnlineSolver`.  [YIB Sec. IV]

- ``pb``: periodic batch Gauss-Newton over everything so far, XL ordering, warm-started;
- ``pbvr``: the same with AMD reordering at every update;
- ``btgp``: the Bayes tree (:class:`steam_ref.bayes_tree.IncrementalSolver`, Alg. 1 steps 2-7);
  with a lag, :class:`FixedLagTreeSolver` (:class:`steam_ref.bayes_tree.FixedLagSmoother`), the one home of a
  stream's fixed-lag rule, with the re-entry of a forgotten landmark (:func:`forget_landmarks`).

What the run loop asks of each, and how a forgotten past is read (``past``), is :mod:`steam_ref.paper.online_solver`'s.
"""

from __future__ import annotations

import time
from array import array
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..batch import gauss_newton
from ..bayes_tree import FixedLagSmoother, IncrementalSolver, ISAM2Params, UpdateReport
from ..choices import BATCH_ORDERINGS, METHODS
from ..covariance import sparse_joint_covariance, sparse_joint_covariances, sparse_marginal_covariances
from ..errors import SteamError
from ..factors import Factor
from ..graph import FactorGraph
from ..variables import Key, Values, X, check_new_values
from .online_solver import OnlineSolver, check_past

__all__ = [
    "METHODS",
    "PB_RELATIVE_TOLERANCE",
    "PB_MAX_ITERATIONS",
    "PeriodicBatchSolver",
    "BayesTreeSolver",
    "FixedLagTreeSolver",
    "forget_landmarks",
    "make_solver",
]

PB_RELATIVE_TOLERANCE = 1e-5  # PB/PBVR stop when the cost falls by less than this fraction (GTSAM's default)
KEPT_REPORTS = 100  # a BTGP stream keeps the UpdateReports of its latest updates only (each names every key it touched)
PB_MAX_ITERATIONS = 100  # PB/PBVR Gauss-Newton iterations per update at most (GTSAM's default)


def forget_landmarks(landmarks: set[int], solver: OnlineSolver) -> None:
    """The re-entry rule of every stream: the landmarks ``solver``'s last update forgot leave ``landmarks`` (the ids
    its front end has given a variable), so the next reading of one brings it in anew, as at its first sighting (its
    first value and prior). Never held, a reading of a forgotten landmark would be refused (UnknownVariableError)."""
    landmarks.difference_update(k.index for k in solver.forgotten() if k.symbol == "l")


class PeriodicBatchSolver(OnlineSolver):
    """PB (XL ordering) or PBVR (AMD): Gauss-Newton over everything, warm-started.  [YIB Sec. IV]"""

    def __init__(
        self,
        ordering: str = "xl",
        relative_tolerance: float = PB_RELATIVE_TOLERANCE,
        max_iterations: int = PB_MAX_ITERATIONS,
    ):
        if ordering not in tuple(BATCH_ORDERINGS):  # (a tuple: an unhashable ordering is refused, not a TypeError)
            raise SteamError(f"PB and PBVR order by {' or '.join(map(repr, BATCH_ORDERINGS))}, got {ordering=}")
        self.name = BATCH_ORDERINGS[ordering].lower()  # the one pairing of PB with XL and PBVR with AMD
        self.ordering = ordering
        self.relative_tolerance, self.max_iterations = relative_tolerance, max_iterations
        self.graph = FactorGraph()
        self.values = Values()
        self.iterations: list[int] = []  # Gauss-Newton iterations of each update

    def update(self, factors: list[Factor], values: Values) -> None:
        """Gauss-Newton over every factor so far and ``factors``, from the estimate and ``values``. The new graph and
        estimate are made aside and kept only once the solve returns: a failed or interrupted update (an
        UnderdeterminedError, Ctrl-C) leaves the solver as it was."""
        check_new_values(values, self.values)
        graph, start = self.graph.copy(), self.values.copy()
        graph.add(factors)
        for k in values:
            start.insert(k, values[k], values.kind(k))
        # check=False: the paper's PB stops on GTSAM's rule alone, and timing it is the point.
        result = gauss_newton(
            graph,
            start,
            ordering=self.ordering,
            check=False,
            relative_tolerance=self.relative_tolerance,
            max_iterations=self.max_iterations,
        )
        self.graph, self.values = graph, result.values  # one line: the update is kept whole or not at all
        self.iterations.append(len(result.iterations))

    def estimate_of(self, key: Key, *, past: str = "lagged") -> NDArray:
        check_past(past)  # nothing forgotten: one past
        return self.values[key]

    def estimate(self, *, past: str = "lagged") -> Values:
        check_past(past)
        return self.values

    def marginal_covariances(self, keys: Sequence[Key]) -> dict[Key, NDArray]:
        return sparse_marginal_covariances(self.graph.factors, self.values, keys)  # at the estimate

    def joint_covariance(self, keys: Sequence[Key]) -> NDArray:
        return sparse_joint_covariance(self.graph.factors, self.values, keys)  # at the estimate

    def joint_covariances(self, groups: Sequence[Sequence[Key]]) -> list[NDArray]:
        return sparse_joint_covariances(self.graph.factors, self.values, groups)  # at the estimate


class BayesTreeSolver(OnlineSolver):
    """BTGP: the incremental solver of :mod:`steam_ref.bayes_tree`.  [YIB Alg. 1 steps 2-7]"""

    name = "btgp"

    def __init__(self, params: ISAM2Params | None = None, *, inner: IncrementalSolver | FixedLagSmoother | None = None):
        self.inner: IncrementalSolver | FixedLagSmoother = IncrementalSolver(params) if inner is None else inner
        self.reports: list[UpdateReport] = []  # the latest KEPT_REPORTS updates' reports: memory stays flat
        self.tree_nnz = array("q")  # nonzeros of R after each update (GTSAM's treeNnz): the fill, 8 bytes an update
        self.phase_seconds: dict[str, float] = {}  # seconds in each phase of the update, summed over every update
        self.clique_solves = 0  # cliques back-substitution solved, over every update

    def update(self, factors: list[Factor], values: Values) -> None:
        self._keep(self.inner.update(factors, values))

    def _keep(self, report: UpdateReport) -> None:
        """What the stream keeps of an update: the report itself among the latest KEPT_REPORTS, its figures always."""
        self.reports.append(report)
        del self.reports[:-KEPT_REPORTS]
        self.tree_nnz.append(report.tree_nnz)
        for phase, seconds in report.timings.items():
            self.phase_seconds[phase] = self.phase_seconds.get(phase, 0.0) + seconds
        self.clique_solves += report.backsubstituted_cliques

    def estimate_of(self, key: Key, *, past: str = "lagged") -> NDArray:
        check_past(past)  # nothing forgotten: one past
        return self.inner.estimate_of(key)

    def estimate(self, *, past: str = "lagged") -> Values:
        check_past(past)
        return self.inner.estimate()

    def estimates_of(self, keys: Sequence[Key], *, past: str = "lagged") -> dict[Key, NDArray]:
        if isinstance(self.inner, IncrementalSolver):
            check_past(past)  # nothing forgotten: one past
            return self.inner.estimates_of(keys)  # the stale ones formed in one call per kind
        return super().estimates_of(keys, past=past)  # each as estimate_of reads it (in the window, or forgotten)

    def marginal_covariance(self, key: Key) -> NDArray:
        return self.inner.marginal_covariance(key)  # one walk down the root path

    def marginal_covariances(self, keys: Sequence[Key]) -> dict[Key, NDArray]:
        return self.inner.marginal_covariances(keys)  # one pass down the tree

    def joint_covariance(self, keys: Sequence[Key]) -> NDArray:
        return self.inner.joint_covariance(keys)  # from the tree's cliques

    def joint_covariances(self, groups: Sequence[Sequence[Key]]) -> list[NDArray]:
        return self.inner.joint_covariances(groups)  # one pass down the tree where a clique holds a group


class FixedLagTreeSolver(BayesTreeSolver):
    """BTGP over a window of ``lag`` seconds: :class:`~steam_ref.bayes_tree.FixedLagSmoother` in a stream, the
    planar one's and the 3-D one's (``paper.rigid.solve_rigid``): the one home of their rule.

    A state X(i) is stamped with its time (``times[i]``: a pose's, a 3-D run's state's), a landmark with the newest
    state's time of each update whose factors name it, so it is forgotten a lag after it was last seen (read again,
    it enters anew: :func:`forget_landmarks`). A marginalized
    variable is read as ``past`` says: ``"lagged"``, its estimate at the moment it was marginalized (what a
    fixed-lag smoother reports), or ``"smoothed"``, given all the data so far
    (:meth:`FixedLagSmoother.smoothed_history`; needs ``keep_history``). Its covariance is no longer known
    and a query raises the smoother's :class:`~steam_ref.errors.UnknownVariableError`.
    """

    name = "btgp"
    inner: FixedLagSmoother

    def __init__(
        self, params: ISAM2Params | None, lag: float, times: NDArray, *, keep_history: bool = False, batch: float = 0.0
    ):
        super().__init__(inner=FixedLagSmoother(lag, params, keep_history=keep_history, batch=batch))
        self.times = np.asarray(times, dtype=float)  # time of each pose
        self._states = np.zeros((0, 0))  # (n_poses, n) estimate of each marginalized state X(pose), row by pose
        self._retired_states = np.zeros(len(self.times), dtype=bool)  # by pose: its state was marginalized
        self._landmarks: dict[Key, NDArray] = {}  # marginalized landmark → its estimate then
        self._forgotten: list[Key] = []  # the variables the last update marginalized
        self._smoothed: dict[Key, NDArray] | None = None  # the smoothed past, computed once per update when asked
        self._smoothing_s: float | None = None  # the wall time of computing it

    def update(self, factors: list[Factor], values: Values) -> None:
        stamps = {k: float(self.times[k.index]) for k in values if k.symbol == "x"}
        newest = max(stamps.values(), default=self.inner.newest)
        if np.isfinite(newest):
            stamps |= {k: newest for f in factors for k in f.keys if k.symbol != "x"}
        self._smoothed = self._smoothing_s = None
        self._keep(self.inner.update(factors, values, timestamps=stamps))
        done = self.inner.last_marginalization
        self._forgotten = [] if done is None else list(done.keys)
        for k, v in ({} if done is None else done.estimates).items():
            if k.symbol == "x":
                if not self._states.size:
                    self._states = np.zeros((len(self.times), len(v)))
                self._states[k.index] = v
                self._retired_states[k.index] = True
            else:
                self._landmarks[k] = v
        for k in values:
            self._landmarks.pop(k, None)  # entered again: the window's estimate is the one

    def forgotten(self) -> Sequence[Key]:
        """The variables the last update marginalized."""
        return self._forgotten

    @property
    def n_marginalized(self) -> int | None:
        """Variables (states and landmarks) marginalized so far, a count."""
        return self.inner.n_marginalized

    @property
    def peak_window(self) -> int | None:
        """Most variables the window has held at once (after an update, before it marginalizes), a count."""
        return self.inner.peak_window

    @property
    def smoothing_seconds(self) -> float | None:
        """Wall time of the latest ``past="smoothed"`` backward pass since the last update, seconds (None: none ran)."""
        return self._smoothing_s

    def _smoothed_past(self) -> dict[Key, NDArray]:
        """Every marginalized variable's estimate given all the data so far, computed at the first ask after
        an update (one backward pass, timed) and kept until the next."""
        if self._smoothed is None:
            start = time.perf_counter()
            self._smoothed = self.inner.smoothed_history()
            self._smoothing_s = time.perf_counter() - start
        return self._smoothed

    def _checked(self, past: str) -> str:
        """``past`` itself; a :class:`SteamError` for an unknown one, or for ``"smoothed"`` without the history."""
        if check_past(past) == "smoothed" and self.inner.history is None:
            raise SteamError(
                "past='smoothed' needs the forgotten conditionals: make the solver with keep_history=True "
                "(StreamOptions(lag_history=True))"
            )
        return past

    def retired(self, key: Key, *, past: str = "lagged") -> NDArray | None:
        """The estimate of ``key`` if it was marginalized, read as ``past`` says (None while it is in the window,
        or never held)."""
        self._checked(past)
        lagged = self._landmarks.get(key)  # a landmark that enters again leaves _landmarks
        if key.symbol == "x":  # a state never enters again
            retired = 0 <= key.index < len(self.times) and self._retired_states[key.index]
            lagged = self._states[key.index] if retired else None
        return None if lagged is None else self._past(key, lagged, past)

    def _past(self, key: Key, lagged: NDArray, past: str) -> NDArray:
        """A marginalized variable's estimate: the one it left the window with, or the smoothed one."""
        return lagged if past == "lagged" else self._smoothed_past().get(key, lagged)

    def estimate_of(self, key: Key, *, past: str = "lagged") -> NDArray:
        retired = self.retired(key, past=past)
        return self.inner.estimate_of(key) if retired is None else retired

    def estimate(self, *, past: str = "lagged") -> Values:
        self._checked(past)
        out = self.inner.estimate()
        for i in np.flatnonzero(self._retired_states).tolist():
            out.insert(X(i), self._past(X(i), self._states[i], past))
        for k, v in self._landmarks.items():  # never in the window (popped when one enters again)
            out.insert(k, self._past(k, v, past))
        return out


def make_solver(
    method: str,
    *,
    isam2: ISAM2Params | None = None,
    pb_relative_tolerance: float = PB_RELATIVE_TOLERANCE,
    pb_max_iterations: int = PB_MAX_ITERATIONS,
    lag: float | None = None,
    times: NDArray | None = None,
    keep_history: bool = False,
    lag_batch: float = 0.0,
) -> OnlineSolver:
    """The solver ``method`` names ('btgp', 'pb' or 'pbvr'); with a ``lag`` (seconds, BTGP only), the fixed-lag
    one, stamping each pose with ``times[pose]``, keeping the forgotten conditionals if ``keep_history``, and
    marginalizing in batches of ``lag_batch`` seconds (:class:`~steam_ref.bayes_tree.FixedLagSmoother`'s ``batch``)."""
    if method not in METHODS:
        raise SteamError(f"unknown method {method!r}; use one of {', '.join(METHODS)}")
    if keep_history and lag is None:
        raise SteamError("keep_history keeps what a lag forgets: give a lag too")
    if lag is not None:
        if method != "btgp" or times is None:
            raise SteamError(f"a lag (lag={lag!r}) needs method='btgp' and the poses' times, got method={method!r}")
        return FixedLagTreeSolver(isam2, lag, times, keep_history=keep_history, batch=lag_batch)
    if method == "btgp":
        return BayesTreeSolver(isam2)
    return PeriodicBatchSolver("xl" if method == "pb" else "amd", pb_relative_tolerance, pb_max_iterations)
