"""The estimated trajectory as a function of time: states, Eq. 18 between them, covariances.

A :class:`Trajectory` reads a solver's current estimate of the states at the poses ``states``. At a
state it returns the solver's estimate and marginal covariance; between states tᵢ < t < tⱼ, the motion
prior's interpolated state (for a vector-space prior x̄(t) = Λ(t) x̄ᵢ + Ψ(t) x̄ⱼ [YIB Eq. 18]) and its
covariance from the joint covariance of (xᵢ, xⱼ); after the last state t_N, the prior's prediction (for a
vector-space prior Φ(t, t_N) x̄_N and Φ P_N Φᵀ + Q(t - t_N)). The motion prior
(:class:`~steam_ref.motion.MotionPrior`) owns each of these; the trajectory asks it. Before the first state
there is no prior to speak of (the GP starts there, [YIB Eq. 14]) and a query is an error.

Time: a query and every time returned are on the data's clock (seconds); the GP works on the model's.
Given a :class:`~steam_ref.gp.clock.Clock` the trajectory maps a query through it; given plain pose times,
the two clocks are one.

Every covariance is that of the state's tangent under the prior's kind: on SE(2) states (``motion_prior('se2',
qc)``) the right tangent at the point the solver linearized at (a batch result's estimate, an incremental solver's
``linearization_point``: :mod:`steam_ref.covariance`), its pose block in the *body frame* (``lie.state``;
``lie.world_position_covariance`` turns its position block to the world frame).

What it reads (:class:`Estimates`, a protocol): ``estimate_of(key)`` and ``estimate()`` (and, where the solver has
it, ``estimates_of(keys)``: the states at every pose are read a block at a time), and, only when a covariance is
asked for, ``marginal_covariances``, ``joint_covariance`` and ``joint_covariances``. Every solver's result has them,
each through its own public methods: a :class:`~steam_ref.batch.BatchResult` (its covariances are blocks of 𝓘⁻¹ with
every factor linearized at its estimate, one sparse factorization per query; a result that kept no factors says so),
an :class:`~steam_ref.bayes_tree.IncrementalSolver` (from its Bayes tree) and a
:class:`~steam_ref.bayes_tree.FixedLagSmoother` (its window). A query that needs a state a fixed-lag smoother has
marginalized raises :class:`~steam_ref.errors.UnknownVariableError` naming the time, the state and the update that
forgot it: the trajectory reads the window, not a past the smoother no longer holds (with ``keep_history=True``,
``smoothed_history()`` gives the forgotten states, smoothed by all the data, to read instead).
"""

from __future__ import annotations

import itertools
from array import array
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from .arguments import finite, flag, number, real_array
from .errors import ClockError, ShapeError, SteamError, UnknownVariableError
from .gp.clock import Clock
from .gp.sde import LinearSDE
from .motion import MotionPrior, as_motion_prior
from .variables import Key, Values, X, key_list, kind_clash

__all__ = ["Trajectory", "Covariances", "Estimates"]


class Estimates(Protocol):
    """What a :class:`Trajectory` reads of a solver's result (module docstring): a ``BatchResult``, an
    ``IncrementalSolver``, a ``FixedLagSmoother`` or anything else with these methods. The covariance queries
    are read only when a covariance is asked for."""

    def estimate_of(self, key: Key) -> NDArray: ...  # one variable's estimate (n,)

    def estimate(self) -> Values: ...  # every variable's

    def marginal_covariances(self, keys: Sequence[Key]) -> dict[Key, NDArray]: ...

    def joint_covariance(self, keys: Sequence[Key]) -> NDArray: ...

    def joint_covariances(self, groups: Sequence[Sequence[Key]]) -> list[NDArray]: ...

    # Optional, read where the solver has it (every solver of the package does): ``kind_of(key)``, the kind it holds a
    # variable as, which must be the prior's (a vector state read by the SE(2) prior was silently read wrong).


_READS = ("estimate_of", "estimate")  # what every query needs; the covariance queries are checked when called
BLOCK = 1024  # states read at once by Trajectory.at_every_pose


@dataclass(frozen=True)
class Covariances:
    """Final marginal covariances of a run, in the order of its times and landmark ids, each in the coordinates of
    the prior's state covariance (its ``kind``'s tangent): [x, y, θ] and [ẋ, ẏ, θ̇] in the world frame for a
    vector-space prior; on SE(2) the right tangent at the estimate, the pose block in the body frame and the
    velocity block the body twist's [vx, vy, ω] (``lie.world_position_covariance`` turns a position block to the
    world frame)."""

    pose: NDArray  # (n, 3, 3) of the pose at every covered pose
    velocity: NDArray  # (n, 3, 3) of the velocity at every covered pose
    landmark: NDArray  # (m, 2, 2) of each landmark, in the order of ``landmark_ids``
    landmark_ids: tuple[int, ...]  # (m,) the landmarks' ids


def _pose_indices(states: Sequence[int]) -> array[int]:
    """Pose indices, strictly increasing, as an ``array('q')``: 8 bytes a state, where a list holds an int object and
    a slot each (40 bytes; a long run's 20,000 states made 0.8 MB, and as much again while converted)."""
    if isinstance(states, (str, bytes)) or not isinstance(states, Iterable):
        raise SteamError(f"states must be a list of pose indices, got states={states!r}")
    given: Sequence[object] | NDArray = states if isinstance(states, (Sequence, np.ndarray, array)) else list(states)
    if not isinstance(given, np.ndarray) and any(isinstance(s, Key) for s in given):  # NumPy reads X(i) as ('x', i)
        shown = ", ".join(map(repr, given[:4])) + (", ..." if len(given) > 4 else "")
        raise SteamError(
            f"states must be pose indices (integers >= 0), not keys: got states=[{shown}]; "
            "for states X(0), X(1), ... give [0, 1, ...], [k.index for k in keys]"
        )
    out = np.asarray(given)
    if out.size and (out.ndim != 1 or out.dtype.kind not in "iu" or out.min() < 0):
        raise SteamError(f"states must be pose indices (integers >= 0), got states={out.tolist()!r:.120}")
    if out.size and out.max() > np.iinfo(np.int64).max:  # (unsigned: an int64 would wrap it, np.diff too)
        raise SteamError(f"states names pose {int(out.max())}, past any file's poses")
    out = out.astype(np.int64)
    if np.any(np.diff(out) <= 0):
        i = int(np.flatnonzero(np.diff(out) <= 0)[0])
        raise SteamError(
            f"states must increase strictly, but states[{i}] = {out[i]} and states[{i + 1}] = {out[i + 1]}"
        )
    kept = array("q")
    kept.frombytes(out.tobytes())  # (an empty input's float dtype too, as int64)
    return kept


def _pose_times(times: NDArray, states: array[int]) -> NDArray:
    """The time of every pose: finite, non-decreasing, covering every state, strictly increasing at the states."""
    times = real_array("times", times)
    if times.ndim != 1:
        raise ShapeError(f"times must be a 1-d array, one time per pose, got shape {times.shape}")
    if np.any(np.diff(finite("times", times)) < 0):
        i = int(np.flatnonzero(np.diff(times) < 0)[0])
        raise SteamError(f"times must not decrease, but times[{i}] = {times[i]} and times[{i + 1}] = {times[i + 1]}")
    if states and states[-1] >= len(times):
        raise SteamError(f"states names pose {states[-1]}, but times has {len(times)} poses")
    at = times[states]
    if np.any(np.diff(at) <= 0):
        i = int(np.flatnonzero(np.diff(at) <= 0)[0])
        raise SteamError(f"two states share the time {at[i]}: poses {states[i]} and {states[i + 1]}")
    return times


def _kept(times: NDArray, states: array[int]) -> NDArray:
    """:func:`_pose_times` checked; the clock's own array when it is read-only float64 (a clock made by ``Clock.of``
    is), not a copy beside it (8 bytes a pose, twice)."""
    checked = _pose_times(times, states)
    shared = isinstance(times, np.ndarray) and times.dtype == np.float64 and times.ndim == 1
    return times if shared and not times.flags.writeable else checked


class Trajectory:
    """A solver's states at poses ``states`` (sorted), queried at any time from the first state on.

    ``prior`` is the motion prior the states were estimated with: a :class:`~steam_ref.motion.MotionPrior`
    (``PaperSetup.motion_prior()``, ``steam_ref.motion_prior('se2', qc)``), or Qc (3, 3) of the paper's WNOA
    prior, or any :class:`~steam_ref.gp.LinearSDE` (WNOJ, Singer: states of 9 numbers), each read by
    :func:`~steam_ref.motion.as_motion_prior`. ``times`` (n_poses,) must be finite and non-decreasing,
    ``states`` strictly increasing pose indices into it at strictly increasing times. ``times`` may be a
    :class:`~steam_ref.gp.clock.Clock`: then ``times`` are its seconds (what queries and answers use) and the
    prior runs on its model times.
    """

    def __init__(
        self,
        solver: Estimates,
        states: Sequence[int],
        times: NDArray | Clock,
        prior: MotionPrior | NDArray | LinearSDE,
    ):
        if missing := [name for name in _READS if not callable(getattr(solver, name, None))]:
            raise SteamError(
                f"solver must give its estimates (estimate_of(key) and estimate(), as a BatchResult, IncrementalSolver "
                f"or FixedLagSmoother does); {type(solver).__name__} has no {' or '.join(missing)}"
            )
        self.solver = solver  # an Estimates: a solver or its result
        self.states = _pose_indices(states)  # poses with a state, increasing (an array('q'))
        self.clock = times if isinstance(times, Clock) else Clock.of(_pose_times(times, self.states))
        self.times = _kept(self.clock.seconds, self.states)  # (n_poses,) time of every pose [data's clock]
        self.model_times = _kept(self.clock.model, self.states)  # (n_poses,) the same on the prior's clock
        self.prior = as_motion_prior(prior)  # everything that differs between priors
        self.n = self.prior.state_dim  # size of a state
        if self.states:  # the newest state: a fixed-lag smoother still holds it
            newest = X(self.states[-1])
            size = np.shape(solver.estimate_of(newest))
            if size != (self.n,):
                raise ShapeError(f"the prior has states of {self.n} numbers, the solver's {newest!r} has shape {size}")
            kind_of = getattr(solver, "kind_of", None)  # optional (the protocol's comment)
            held = kind_of(newest) if callable(kind_of) else self.prior.kind
            if held is not self.prior.kind and held != self.prior.kind:
                raise kind_clash(
                    newest, held, "the solver", self.prior.kind, f"the trajectory's {self.prior.name} prior"
                )

    def __repr__(self) -> str:
        if not self.states:
            return f"<Trajectory of no state, {self.prior.name} prior>"
        first, last = self.states[0], self.states[-1]
        return (
            f"<Trajectory of {len(self.states)} states, x{first}..x{last} at {self.times[first]:.6g}..{self.times[last]:.6g}"
            f" s, {self.prior.name} prior of {self.n} numbers a state; at(t): the state at t s from the first state on>"
        )

    def _read(self, t: float | str, read, *args):
        """``read(*args)`` of the solver; a state it no longer holds is an UnknownVariableError naming the time ``t``
        (or what needed it)."""
        try:
            return read(*args)
        except UnknownVariableError as e:
            where = f"at t={t!r} s" if isinstance(t, float) else t
            raise UnknownVariableError(f"the trajectory {where} needs a state the solver does not hold: {e}") from e

    def _between(self, a: int, b: int, t: float, xa: NDArray, xb: NDArray) -> NDArray:
        """x̄(t) between the states at poses a and b, ta <= t <= tb.  [YIB Eq. 18]

        A pose may share its time with a state (times need only not decrease): x(ta) is the state at a.
        ``t`` is on the model's clock."""
        ta, tb = self.model_times[a], self.model_times[b]
        if t in (ta, tb):
            return (xa if t == ta else xb).copy()
        return self.prior.interpolate(ta, xa, tb, xb, t)  # [YIB Eq. 18]

    def _between_covariance(self, a: int, b: int, t: float, xa: NDArray, xb: NDArray, joint: NDArray) -> NDArray:
        """Cov x(t) between the states at poses a and b (estimates xa, xb; joint covariance ``joint``)."""
        ta, tb = self.model_times[a], self.model_times[b]
        if t in (ta, tb):  # a pose at a state's time: that state's marginal, a block of the joint
            return joint[: self.n, : self.n].copy() if t == ta else joint[self.n :, self.n :].copy()
        return self.prior.interpolate_covariance(ta, xa, tb, xb, t, joint)

    def neighbours(self, t: float) -> tuple[int, int] | int:
        """The state at time t, or the two states around it."""
        t = number("t", t)
        times, solved = self.times, self.states
        if not solved:
            raise SteamError(f"time t={t!r} is outside the estimated span: no solved state yet")
        if not times[solved[0]] <= t <= times[solved[-1]]:
            raise ClockError(
                f"time t={t!r} is outside the estimated span [{times[solved[0]]:g}, {times[solved[-1]]:g}]"
            )
        j = int(np.searchsorted(times[solved], t))
        return solved[j] if times[solved[j]] == t else (solved[j - 1], solved[j])

    def at(self, t: float, *, covariance: bool = False) -> NDArray | tuple[NDArray, NDArray]:
        """The state x(t) (n,), with its covariance (n, n) if asked, for any t from the first state on.

        Between states: [YIB Eq. 18]; after the last state t_N: the prior's prediction from x̄_N, P_N.
        """
        t = number("t", t)
        flag("covariance", covariance)
        solved, times = self.states, self.times
        if solved and t < times[solved[0]]:  # a ClockError, as states_at's (errors.ClockError: one meaning)
            raise ClockError(
                f"time t={t!r} is before the first estimated state at t={times[solved[0]]:g}: the GP prior starts "
                f"there, so queries need t >= {times[solved[0]]:g} (after the last state, at t={times[solved[-1]]:g}, "
                "the prior extrapolates)"
            )
        if solved and t > times[solved[-1]]:
            last, key, m = self.model_times[solved[-1]], X(solved[-1]), float(self.clock.to_model(t))
            x1 = self._read(t, self.solver.estimate_of, key)
            mean = self.prior.extrapolate(last, x1, m)  # [YIB Eq. 22]
            if not covariance:
                return mean
            cov1 = self._read(t, self.solver.joint_covariance, [key])
            return mean, self.prior.extrapolate_covariance(last, x1, m, cov1)
        near = self.neighbours(t)
        if isinstance(near, int):
            mean = np.array(self._read(t, self.solver.estimate_of, X(near)))
            return (mean, self._read(t, self.solver.joint_covariance, [X(near)])) if covariance else mean
        a, b = near
        m = float(self.clock.to_model(t))
        xa, xb = self._read(t, self.solver.estimate_of, X(a)), self._read(t, self.solver.estimate_of, X(b))
        mean = self._between(a, b, m, xa, xb)
        if not covariance:
            return mean
        joint = self._read(t, self.solver.joint_covariance, [X(a), X(b)])
        return mean, self._between_covariance(a, b, m, xa, xb, joint)

    def at_every_pose(self) -> tuple[NDArray, NDArray]:
        """Times (m,) and states (m, n) at every pose of the span, from the first state's pose to the last's
        (m = states[-1] - states[0] + 1; row k is pose states[0] + k). The states are read :data:`BLOCK` at a time
        (``estimates_of(keys)``, where the solver has it; else ``estimate()`` once): beside the answer, memory for a
        block, not a copy of the whole estimate (a fixed-lag run's 20,000 forgotten states made one of 7 MB)."""
        solved = self.states
        if not solved:
            return np.zeros(0), np.zeros((0, self.n))
        times, first, read = self.model_times, solved[0], getattr(self.solver, "estimates_of", None)
        whole = None if callable(read) else self.solver.estimate()
        out = np.empty((solved[-1] + 1 - first, self.n))
        a, xa = solved[0], np.zeros(0)
        for start in range(0, len(solved), BLOCK):
            poses = solved[start : start + BLOCK]
            keys = [X(i) for i in poses]
            values = self._read("at every pose", read, keys) if whole is None else whole
            if gone := [k for k in keys if k not in values]:
                raise UnknownVariableError(
                    f"the trajectory's every pose needs {gone[0]!r} (t={self.times[gone[0].index]:g} s), which the "
                    "solver does not hold"
                )
            for b, key in zip(poses, keys, strict=True):
                xb = values[key]
                out[b - first] = xb
                for p in range(a + 1, b):
                    out[p - first] = self._between(a, b, times[p], xa, xb)  # [YIB Eq. 18]
                a, xa = b, xb
        return self.times[first : solved[-1] + 1].copy(), out

    def covariances(self, landmarks: Sequence[Key]) -> Covariances:
        """Marginal covariances at every pose of the span (interpolated between states; row k is pose
        states[0] + k, as in :meth:`at_every_pose`) and of ``landmarks``, in the prior's coordinates
        (:class:`Covariances`: on SE(2), body frame)."""
        solved, landmarks = self.states, key_list("landmarks", landmarks, distinct=True)
        d = self.prior.qc.shape[0]  # p's size: a pose [x, y, θ] and its rates come first in every planar state
        if d != 3:
            raise SteamError(
                f"covariances are those of planar poses [x, y, θ] and their rates; this prior's p has d = {d} numbers"
            )
        wanted = list(dict.fromkeys([X(i) for i in solved] + landmarks))  # a state given as a landmark: refused below
        marg = self._read("covariances", self.solver.marginal_covariances, wanted)
        for k in landmarks:
            if marg[k].shape != (2, 2):
                raise ShapeError(
                    f"landmarks names {k!r}, a variable of size {marg[k].shape[0]}; a landmark has 2 numbers"
                )
        gaps = [(a, b) for a, b in itertools.pairwise(solved) if b > a + 1]
        joints = (
            dict(zip(gaps, self.solver.joint_covariances([(X(a), X(b)) for a, b in gaps]), strict=True)) if gaps else {}
        )
        first = solved[0] if solved else 0
        full = np.empty((solved[-1] + 1 - first if solved else 0, self.n, self.n))
        for a in solved:
            full[a - first] = marg[X(a)]
        for a, b in gaps:
            xa, xb = self.solver.estimate_of(X(a)), self.solver.estimate_of(X(b))
            for p in range(a + 1, b):
                full[p - first] = self._between_covariance(a, b, self.model_times[p], xa, xb, joints[(a, b)])
        marks = np.array([marg[k] for k in landmarks]).reshape(-1, 2, 2)
        return Covariances(full[:, :3, :3].copy(), full[:, 3:6, 3:6].copy(), marks, tuple(k.index for k in landmarks))
