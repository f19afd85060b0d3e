"""A run on the states of a group of rigid motions (SE(3)): timed readings to factors, solved in batch, by BTGP or by
a fixed-lag smoother; the trajectory read at held-out times; NEES on tasks drawn from the model (:class:`RigidStudy`,
the 3-D study of ``steam-ref consistency``).

The front end (:func:`steps`) is the planar one's idea on :class:`~steam_ref.datasets.rigid.RigidReadings`: a state
at each of the data's state times, the prior's factor between consecutive states (``MotionPrior.prior_factor``
[YIB Eq. 22]), every reading at a state's time on that state, every other one between the two states around it
through the prior's one interpolation (``MotionPrior.interpolated_factor`` [YIB Eq. 29]); a landmark enters with its
survey as a prior [YIB Eq. 4] when first read, and again when read after a fixed-lag smoother forgot it. Readings
before the first state or after the last are dropped (counted). The steps are what each update of an incremental
solver adds (step i: state i, its prior factor, the readings in (tᵢ₋₁, tᵢ]); the batch problem is all of them at once.
Everything asks the prior, so SE(3) with WNOA of either residual, WNOJ or Singer's model runs the same way (no branch
on a prior or group).

The fixed-lag run is the planar stream's (:class:`~steam_ref.paper.solvers.FixedLagTreeSolver`, one home for both): a
state is stamped with its time, a landmark with the newest state's time of each update that reads it, so it leaves the
window a lag after it was last read (the window holds the last lag's states and landmarks, whatever the map's size);
read again, it enters anew (:func:`~steam_ref.paper.solvers.forget_landmarks`), at its survey with its survey's prior.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterator
from dataclasses import dataclass, field
from itertools import compress

import numpy as np
from numpy.typing import NDArray

from ..arguments import integer, real_array
from ..batch import gauss_newton
from ..datasets.rigid import RIGID_NOISE, RIGID_QC, SIGMA_OF, RigidReadings, RigidSample, sample_rigid_task
from ..errors import ShapeError, SteamError, WrappedTurnWarning
from ..evaluate import nees
from ..factors import Factor, LieStatePrior, PriorFactor
from ..factors.point_readings import AngularVelocityReading, PointReading, PositionReading, RangeReading
from ..graph import FactorGraph
from ..lie.points import position
from ..lie.state import group_state
from ..linear.threads import limited
from ..motion import MotionPrior, as_motion_prior, motion_prior
from ..variables import Key, L, Values, X
from .solvers import BayesTreeSolver, FixedLagTreeSolver, forget_landmarks

__all__ = [
    "Step",
    "steps",
    "solve_rigid",
    "RigidRun",
    "held_out_errors",
    "straight_line_errors",
    "straight_line_at",
    "check_turns",
    "rigid_nees",
    "RIGID_QC",
    "RigidSetup",
    "RigidStudy",
]

METHODS = ("batch", "btgp", "fixed-lag")
_AT = 1e-9  # s: a reading this near a state's time is read on that state
# The batch optimum's stopping rules (benchmarks/se2_vs_gtsam.py's 'exact optimum'): at Gauss-Newton's defaults
# (relative cost decrease 1e-8) a KITTI prefix, whose gyro bias leaves large residuals and linear convergence, stopped
# 6.7e-5 from the minimum that the settled BTGP stream reaches at a lower cost
# (tests/test_kitti_batch_optimum_against_gtsam.py).
OPTIMUM_RELATIVE, OPTIMUM_STEP = 1e-14, 1e-12  # the relative decrease of the cost, the norm of a step


@dataclass(frozen=True)
class Step:
    """What an update adds: state ``index``, its first value, its factors and new landmarks' first values."""

    index: int
    value: NDArray
    factors: list[Factor]
    landmarks: dict[Key, NDArray]


def _reading(data: RigidReadings, table: str, row: NDArray, key: Key) -> Factor:
    """The factor of one row of a table, on the state ``key`` (the state at the reading's time)."""
    g, n, sigma = data.kind.group, data.kind.derivatives, data.sigmas[SIGMA_OF[table]]
    if table == "positions":
        return PositionReading.create(key, row[1:], sigma, group=g, derivatives=n)
    if table == "gyro":
        return AngularVelocityReading.create(key, row[1:], sigma, group=g, derivatives=n)
    if table == "ranges":
        return RangeReading.create(key, L(int(row[1])), row[2], sigma, group=g, derivatives=n)
    return PointReading.create(key, L(int(row[1])), row[2:], sigma, group=g, derivatives=n)


TABLES = ("positions", "gyro", "ranges", "points")


def first_state_prior(data: RigidReadings) -> Factor:
    """The first state's prior: at ``data.first_state`` with the sigmas 'first_pose' and 'first_twist'."""
    if data.first_state is None:
        raise SteamError(f"{data.name}: no first state to put the first state's prior at")
    d = data.kind.group.dim
    sig = np.r_[np.full(d, data.sigmas["first_pose"]), np.full(data.kind.dim - d, data.sigmas["first_twist"])]
    return LieStatePrior.create(X(0), data.first_state, sig, group=data.kind.group, derivatives=data.kind.derivatives)


def steps(
    data: RigidReadings, prior: MotionPrior, initial: NDArray | None = None, *, entered: set[int] | None = None
) -> Iterator[Step]:
    """The updates of a run, state by state (module docstring). ``initial`` (n, state size): each state's first
    value; None: the prior's prediction from the one before (the first at ``data.first_state``). ``entered``: the
    ids of the landmarks given a variable so far, read and filled at each step; a fixed-lag caller takes out the
    ones its solver forgot (:func:`~steam_ref.paper.solvers.forget_landmarks`), and the next reading of one brings it
    in anew, as at its first reading."""
    if prior.kind is not data.kind:
        raise SteamError(f"{data.name} has states of kind {data.kind!r}; the prior {prior.name!r} has {prior.kind!r}")
    t = data.state_times
    if initial is not None:
        initial = real_array("initial", initial)
        if initial.shape != (len(t), prior.state_dim):
            raise ShapeError(
                f"initial must be ({len(t)}, {prior.state_dim}): a first value for each of {data.name}'s {len(t)} "
                f"states, as {prior.name!r} stores a state; got shape {initial.shape}"
            )
    slot = {}  # each reading's state: the first tᵢ ≥ τ - _AT; -1 before the first state, n after the last (dropped)
    for table in TABLES:
        tau = getattr(data, table)[:, 0]
        slot[table] = np.where(tau < t[0] - _AT, -1, np.searchsorted(t, tau - _AT))
    survey = {int(row[0]): row[1:] for row in data.landmarks}
    seen: set[int] = set() if entered is None else entered
    value = np.asarray(data.first_state if initial is None else initial[0], dtype=float)
    for i in range(len(t)):
        if initial is not None:
            value = initial[i]
        elif i:
            value = prior.predict(value, t[i] - t[i - 1])
        factors = [first_state_prior(data)] if i == 0 else [prior.prior_factor(X(i - 1), X(i), t[i] - t[i - 1])]
        new: dict[Key, NDArray] = {}
        for table in TABLES:
            rows = getattr(data, table)[slot[table] == i]
            inners = [_reading(data, table, row, X(i)) for row in rows]
            between = np.abs(rows[:, 0] - t[i]) > _AT  # read between states i-1 and i: moved in one call
            moved = iter(_between(prior, list(compress(inners, between)), i, t, rows[between, 0]))
            for row, inner, interpolated in zip(rows, inners, between, strict=True):
                if table in ("ranges", "points") and int(row[1]) not in seen:
                    j = int(row[1])
                    seen.add(j)
                    new[L(j)] = survey[j]
                    factors.append(
                        PriorFactor.create(L(j), survey[j], data.sigmas[SIGMA_OF["landmarks"]])
                    )  # [YIB Eq. 4]
                factors.append(next(moved) if interpolated else inner)
        yield Step(i, np.asarray(value, dtype=float), factors, new)


def _between(prior: MotionPrior, inners: list[Factor], i: int, t: NDArray, taus: NDArray) -> list[Factor]:
    """The readings ``inners`` at ``taus``, between states i-1 and i, moved onto them.  [YIB Eq. 29]"""
    return prior.interpolated_factors(inners, X(i - 1), X(i), t[i - 1], t[i], taus) if inners else []


@dataclass
class RigidRun:
    """A solved run: its states' estimates (n, size) and the solver (covariances), with what it dropped."""

    states: NDArray
    solver: object
    dropped: int


def dropped_readings(data: RigidReadings) -> int:
    """Readings before the first state or after the last (no state to read them on)."""
    t = data.state_times
    return sum(
        int(np.sum((getattr(data, tb)[:, 0] < t[0] - _AT) | (getattr(data, tb)[:, 0] > t[-1] + _AT))) for tb in TABLES
    )


@limited
def solve_rigid(
    data: RigidReadings, prior: MotionPrior, method: str = "batch", *, initial: NDArray | None = None, lag: float = 10.0
) -> RigidRun:
    """Solve ``data`` with ``prior`` by ``method``: 'batch' (Gauss-Newton from the first values to the optimum: until
    the cost falls by less than 1e-14 of itself, :data:`OPTIMUM_RELATIVE`, and checked stationary), 'btgp' (iSAM2, one
    update per state) or 'fixed-lag' (the states and landmarks of the last ``lag`` seconds kept, module docstring; a
    state's estimate is the one it had at the end of the update that forgot it)."""
    if method not in METHODS:
        raise SteamError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    prior = as_motion_prior(prior)
    data = _readings(data).on(prior.kind)  # the data's first values as the prior's states
    n = len(data.state_times)
    initial = data.initial_states if initial is None else initial
    if method == "batch":
        graph, values = FactorGraph(), {}
        for step in steps(data, prior, initial):
            graph.add(step.factors)
            values[X(step.index)] = step.value
            values.update(step.landmarks)
        result = gauss_newton(
            graph,
            graph.with_kinds(Values(values)),
            max_iterations=30,
            relative_tolerance=OPTIMUM_RELATIVE,
            step_tolerance=OPTIMUM_STEP,
        )
        states = np.array([result.values[X(i)] for i in range(n)])
        check_turns(data, prior, states)
        return RigidRun(states, result, dropped_readings(data))
    solver = BayesTreeSolver() if method == "btgp" else FixedLagTreeSolver(None, lag, data.state_times)
    out, entered = np.empty((n, prior.state_dim)), set[int]()
    for step in steps(data, prior, initial, entered=entered):
        value = step.value if step.index == 0 else prior.predict(out[step.index - 1], _gap(data, step.index))
        solver.update(step.factors, Values({X(step.index): value if initial is None else step.value, **step.landmarks}))
        forget_landmarks(entered, solver)  # last read a lag ago: out of the window; read again, it enters anew
        out[step.index] = solver.estimate_of(X(step.index))  # the newest state: the next one's prediction starts there
    final = solver.estimates_of([X(i) for i in range(n)])  # all at once, at the end (a forgotten state as it left)
    out = np.array([final[X(i)] for i in range(n)])
    check_turns(data, prior, out)
    return RigidRun(out, solver, dropped_readings(data))


def check_turns(data: RigidReadings, prior: MotionPrior, states: NDArray) -> None:
    """:class:`~steam_ref.errors.WrappedTurnWarning` naming the first pair of consecutive states whose body twist, at
    either end, turns by π or more over their gap (the group's angle of Δt ϖ): the prior's local variable
    Log(Tᵢ₋₁⁻¹ Tᵢ) [DER 11.11] holds less than half a turn, so such an estimate is one of several minima. A run
    with a gap of 100 s in a turn at 0.15 rad/s ended 4.2 m apart by batch and by BTGP, each converged, no word said."""
    g = group_state(prior.kind).group
    twist = np.asarray(states, dtype=float)[:, g.size : g.size + g.dim]
    gap = np.diff(data.state_times)[:, None]
    turn = np.maximum(g.angle(gap * twist[:-1]), g.angle(gap * twist[1:]))
    past = np.flatnonzero(~(turn < np.pi))
    if past.size:
        i = int(past[0]) + 1
        warnings.warn(
            f"{data.name}: between states {i - 1} and {i} ({float(gap[i - 1, 0]):g} s apart) the estimate's twist "
            f"turns by {float(turn[i - 1]):.3g} rad, π or more ({past.size} such gap(s)): the prior reads the turn "
            "modulo a full one, so this is one of several minima; add states in the gap",
            WrappedTurnWarning,
            stacklevel=3,
        )


def _gap(data: RigidReadings, i: int) -> float:
    return float(data.state_times[i] - data.state_times[i - 1])


def _positions_at(data: RigidReadings, prior: MotionPrior, states: NDArray, times: NDArray) -> NDArray:
    """The GP's mean position at each of ``times`` (inside the states' span) [YIB Eq. 18]: between the states
    around it, or a state's own at its time."""
    t, g = data.state_times, group_state(prior.kind).group
    out = []
    for tau in times:
        i = int(np.clip(np.searchsorted(t, tau), 1, len(t) - 1))
        if abs(tau - t[i]) <= _AT or abs(tau - t[i - 1]) <= _AT:
            x = states[i] if abs(tau - t[i]) <= _AT else states[i - 1]
        else:
            x = prior.interpolate(t[i - 1], states[i - 1], t[i], states[i], tau)
        out.append(position(g, x[: g.size])[0])
    return np.array(out)


def _readings(data: object) -> RigidReadings:
    """``data`` if it is a :class:`RigidReadings`, else a SteamError saying what it is."""
    if isinstance(data, RigidReadings):
        return data
    hint = " (a RigidSample's readings are its .data)" if isinstance(data, RigidSample) else ""
    raise SteamError(f"data must be a RigidReadings{hint}, got a {type(data).__name__}")


def held_out_errors(data: RigidReadings, prior: MotionPrior, states: NDArray) -> NDArray:
    """The distance (m) between each held-out fix inside the states' span and the kept fixes' span (the fixes
    :func:`straight_line_errors` scores) and the GP-interpolated position."""
    rows = _inside(data)
    if not len(rows):  # none inside the span (a short run)
        return np.zeros(0)
    return np.linalg.norm(_positions_at(data, prior, states, rows[:, 0]) - rows[:, 1:], axis=1)


def straight_line_errors(data: RigidReadings) -> NDArray:
    """The same distances for a straight line between the position fixes before and after each held-out one."""
    rows = _inside(data)
    return np.linalg.norm(straight_line_at(data, rows[:, 0]) - rows[:, 1:], axis=1) if len(rows) else np.zeros(0)


def straight_line_at(data: RigidReadings, times: NDArray) -> NDArray:
    """(m, k) the position at each of ``times`` on the straight line between the position fixes before and after it
    (the first two or last two fixes' line, continued, outside them); SteamError with fewer than two fixes."""
    fixes = data.positions[np.argsort(data.positions[:, 0])]
    if len(fixes) < 2:
        raise SteamError(f"{data.name}: a straight line between position fixes needs two, it has {len(fixes)}")
    i = np.clip(np.searchsorted(fixes[:, 0], times), 1, len(fixes) - 1)
    a, b = fixes[i - 1], fixes[i]
    s = (np.asarray(times, dtype=float) - a[:, 0]) / (b[:, 0] - a[:, 0])
    return (1 - s)[:, None] * a[:, 1:] + s[:, None] * b[:, 1:]


def _inside(data: RigidReadings) -> NDArray:
    """The held-out fixes strictly inside the states' span and the kept fixes' (where the straight line is drawn):
    none without a kept fix."""
    data = _readings(data)
    t, rows = data.state_times, data.held_out
    fixes = data.positions[:, 0]
    if not len(fixes):  # no kept fix: no span (min() of nothing was a NumPy ValueError)
        return rows[:0]
    keep = (rows[:, 0] > max(t[0], fixes.min())) & (rows[:, 0] < min(t[-1], fixes.max()))
    return rows[keep]


def rigid_nees(run: RigidRun, truth: NDArray, prior: MotionPrior) -> dict[str, NDArray]:
    """NEES of each state's pose and twist blocks (the truth in the right tangent at the estimate, x_true ⊖ x̂, the
    covariance's coordinates) from the solver's marginal covariances."""
    d = group_state(prior.kind).group.dim
    keys = [X(i) for i in range(len(truth))]
    covs = run.solver.marginal_covariances(keys)  # type: ignore[attr-defined]
    errors = np.array([prior.kind.local(x, y) for x, y in zip(run.states, truth, strict=True)])
    P = np.array([covs[k] for k in keys])
    return {
        "pose": nees(errors[:, :d], P[:, :d, :d]),
        "twist": nees(errors[:, d : 2 * d], P[:, d : 2 * d, d : 2 * d]),
    }


@dataclass(frozen=True)
class RigidSetup:
    """The model a 3-D study draws its tasks from and its estimators assume: a prior of the table on a group of rigid
    motions (``prior``, a name of ``MOTION_PRIORS``) with ``qc``; the readings' and first state's sigmas are
    ``RIGID_NOISE`` with ``noise`` in place of its entries."""

    prior: str = "se3"
    qc: NDArray = field(default_factory=lambda: RIGID_QC.copy())
    noise: dict[str, float] = field(default_factory=dict)

    def motion_prior(self) -> MotionPrior:
        return motion_prior(self.prior, self.qc)


@dataclass(frozen=True)
class RigidStudy:
    """A Monte Carlo consistency study on 3-D tasks (``steam-ref consistency --prior se3``): each run draws task
    ``index`` from the set-up's model (:func:`~steam_ref.datasets.rigid.sample_rigid_task`, child ``index`` of
    SeedSequence(seed)), solves it with each of ``estimators`` (methods of :func:`solve_rigid`: BTGP first, then the
    batch optimum descended from BTGP's estimate, the planar study's second start) and scores each state's pose and
    twist by its NEES (:func:`rigid_nees`). The same interface as the planar ``paper.consistency.ConsistencyStudy``."""

    n_steps: int = 40
    n_landmarks: int = 8
    seed: int = 0
    setup: RigidSetup = field(default_factory=RigidSetup)
    estimators: tuple[str, ...] = ("batch", "btgp")

    def __post_init__(self) -> None:
        for name in ("n_steps", "n_landmarks"):
            integer(f"RigidStudy.{name}", getattr(self, name), 1)
        integer("RigidStudy.seed", self.seed, 0)
        unknown = [e for e in self.estimators if e not in METHODS[:2]]  # fixed-lag keeps no marginal of a past state
        if unknown or not self.estimators:
            raise SteamError(f"unknown estimator {unknown[0] if unknown else None!r}; use some of batch, btgp")

    @property
    def kinds(self) -> dict[str, int]:
        """Each kind of state the study scores, with its dimension d (the group's)."""
        d = group_state(self.setup.motion_prior().kind).group.dim
        return {"pose": d, "twist": d}

    def describe(self) -> dict:
        """The study's parameters (a resumed file must have been written by the same study)."""
        return {
            "n_steps": self.n_steps,
            "n_landmarks": self.n_landmarks,
            "seed": self.seed,
            "setup": "rigid-model",
            "prior": self.setup.prior,
            "qc": self.setup.qc.tolist(),
            "noise": RIGID_NOISE | self.setup.noise,
            "estimators": list(self.estimators),
        }

    def sample(self, index: int) -> RigidSample:
        seed = np.random.SeedSequence(self.seed, spawn_key=(index,))  # = SeedSequence(seed).spawn(n)[index]
        return sample_rigid_task(
            self.setup.motion_prior(), self.n_steps, self.n_landmarks, seed, noise=self.setup.noise
        )

    def run(self, index: int) -> dict:
        """Run ``index``: {estimator: {'pose': [NEES of each state], 'twist': [...], 'warnings': [...]}} (JSON)."""
        task, prior = self.sample(index), self.setup.motion_prior()
        out, start = {}, None
        for method in sorted(self.estimators, key=lambda m: m != "btgp"):
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                solved = solve_rigid(task.data, prior, method, initial=start if method == "batch" else None)
                scores = rigid_nees(solved, task.states, prior)
            start = solved.states if method == "btgp" else start
            out[method] = {k: v.tolist() for k, v in scores.items()}
            out[method]["warnings"] = sorted({str(w.message)[:200] for w in caught})
        return {name: out[name] for name in self.estimators}
