"""Readings of a rigid body moving in 3-D (or on a plane), each at its own time, and tasks drawn from the model.

:class:`RigidReadings` is what a run on states of a group of rigid motions reads (``steam_ref.paper.rigid`` builds
its problem): the state times, and tables of timed readings, each a reading of :mod:`steam_ref.factors.point_readings`
(position fixes, gyro rates, ranges and body-frame points of landmarks, a survey of the landmarks), with held-out
position fixes beside them that no estimator sees (scored afterwards). A reading at a state's time is read on that
state; any other between the two states around it, through the prior's interpolation.

:func:`sample_rigid_task` draws a task from the estimator's own model, the same way the planar sampler does
(:func:`~steam_ref.datasets.sample_from_model`): the states from the motion prior (``MotionPrior.sample_states``:
the first from the first state's prior, each next by the prior's exact transition and noise in the local
variables of the state before, so the prior's residual at the truth is its noise), every reading from its
factor's model with its own Gaussian noise, the landmarks placed around the path in 3-D and surveyed with their
prior's noise. The default first twist [1, 0, 0.1, 0, 0, 0.15] (m/s, rad/s) is a vehicle driving forward, turning
left and climbing: a helix, bent by the model's noise.

:func:`generate_rigid` is the generated 3-D data set (``steam-ref run --dataset synthetic-3d``): a task drawn from
the SE(3) WNOA prior at :data:`RIGID_QC`, every other position fix held out, the true states kept in ``truth``.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arguments import integer
from ..errors import DataError, ShapeError, SteamError
from ..lie import GroupState
from ..lie.points import point_dim, position, rotation_part, to_body
from ..lie.state import group_state
from ..manifold import Manifold
from ..motion import MotionPrior, motion_prior
from .landmarks import check_integer_ids
from .table import ids_text, number_text, rows_of

__all__ = ["RigidReadings", "RigidSample", "sample_rigid_task", "generate_rigid", "RIGID_NOISE", "RIGID_QC"]

_TABLES = ("positions", "gyro", "ranges", "points")  # the tables of readings, each row [t, ...]

# The sigmas of a drawn task's readings, and of the first state's prior (pose block, twist block).
RIGID_NOISE = {
    "position": 0.1,  # m, each axis
    "gyro": 0.01,  # rad/s, each axis
    "range": 0.05,  # m
    "point": 0.05,  # m, each axis of the body-frame point
    "landmark": 0.2,  # m, the survey's, each axis
    "first_pose": 0.05,  # the first state's pose, each tangent direction
    "first_twist": 0.05,  # its twist
}
SIGMA_OF = {"positions": "position", "gyro": "gyro", "ranges": "range", "points": "point", "landmarks": "landmark"}
RIGID_QC = np.diag([0.02, 0.005, 0.005, 0.001, 0.001, 0.002])  # a drawn task's Qc on SE(3) (docs/experiments.md)
RIGID_STEPS, RIGID_LANDMARKS = 40, 8  # the generated set's size by default (and its landmarks' density)


@dataclass(frozen=True)
class RigidReadings:
    """Timed readings of one rigid body's states on ``kind`` (its group and derivatives), for a run.

    Tables, one row per reading (times in the data's seconds, any order): ``positions`` [t, p (k)], ``gyro``
    [t, ω], ``ranges`` [t, landmark id, r], ``points`` [t, landmark id, q (k) in the body frame], ``landmarks``
    [id, surveyed position (k)]; each table's sigma in ``sigmas`` (keys as :data:`RIGID_NOISE`).
    ``held_out`` [t, p (k)]: position fixes kept from every estimator, to score it. ``first_state``: the first
    state's prior mean; ``initial_states``: each state's first value (None: the prior's prediction from the one
    before); ``truth``: the true states (n, kind.size) of a generated set, None for a real one.
    """

    name: str
    kind: GroupState
    state_times: NDArray  # (n,), increasing
    sigmas: dict[str, float]
    positions: NDArray
    gyro: NDArray
    ranges: NDArray = field(default_factory=lambda: np.zeros((0, 3)))
    points: NDArray = field(default_factory=lambda: np.zeros((0, 2)))
    landmarks: NDArray = field(default_factory=lambda: np.zeros((0, 1)))
    held_out: NDArray = field(default_factory=lambda: np.zeros((0, 1)))
    first_state: NDArray | None = None
    initial_states: NDArray | None = None  # (n, kind.size) each state's first value; None: the prior's predictions
    qc: NDArray | None = None  # the Qc (dim, dim) the data set runs with unless told otherwise
    source: str = ""
    lacks: str = ""  # what the data set does not have (no ground truth, ...), said in a run's report
    truth: NDArray | None = None  # (n, kind.size) the true states (a generated set's), never read by an estimator

    def __post_init__(self) -> None:
        k = point_dim(self.kind.group)
        r = self.kind.group.dim - k
        t = np.asarray(self.state_times, dtype=float)
        if t.ndim != 1 or len(t) < 2 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise DataError(f"{self.name}: the state times must be 2 or more finite times, increasing strictly")
        widths = {"positions": 1 + k, "gyro": 1 + r, "ranges": 3, "points": 2 + k, "landmarks": 1 + k}
        for table, width in widths.items():
            a = np.asarray(getattr(self, table), dtype=float)
            if a.size == 0:
                a = np.zeros((0, width))
            if a.ndim != 2 or a.shape[1] != width or not np.all(np.isfinite(a)):
                raise DataError(f"{self.name}: {table} must be rows of {width} finite numbers, got shape {a.shape}")
            object.__setattr__(self, table, a)
        held = np.asarray(self.held_out, dtype=float)
        object.__setattr__(self, "held_out", held.reshape(-1, 1 + k) if held.size else np.zeros((0, 1 + k)))
        object.__setattr__(self, "state_times", t)
        _check_landmarks(self)
        _check_states(self)
        needed = [SIGMA_OF[table] for table in SIGMA_OF if len(getattr(self, table))]
        needed += ["first_pose", "first_twist"] if self.first_state is not None else []
        missing = [key for key in needed if key not in self.sigmas]
        if missing:
            raise DataError(f"{self.name}: sigmas has no {missing[0]!r} (its readings need {', '.join(needed)})")

    @property
    def n_readings(self) -> int:
        return sum(len(getattr(self, t)) for t in _TABLES)

    def head(self, n: int) -> RigidReadings:
        """The first ``n`` (>= 2) states and the readings up to the last one's time (held-out fixes too)."""
        n = integer("n", n, 2)
        if n >= len(self.state_times):
            return self
        end = self.state_times[n - 1]
        cut = {table: getattr(self, table)[getattr(self, table)[:, 0] <= end] for table in (*_TABLES, "held_out")}
        initial = None if self.initial_states is None else self.initial_states[:n]
        truth = None if self.truth is None else self.truth[:n]
        return replace(self, state_times=self.state_times[:n], initial_states=initial, truth=truth, **cut)

    def on(self, kind: Manifold) -> RigidReadings:
        """The same readings for states of ``kind`` (a group of the same dimensions, any number of derivatives):
        each first value's (and true state's) pose Exp(Log(T)) on the new group, its twist kept, an acceleration
        added as zero or dropped."""
        if kind is self.kind:
            return self
        kind = group_state(kind)
        old, new = self.kind.group, kind.group
        if (old.dim, point_dim(old)) != (new.dim, point_dim(new)):
            raise DataError(f"{self.name}: its states are on {old!r}; {new!r} moves points of another dimension")

        def moved(x: NDArray | None) -> NDArray | None:
            if x is None:
                return None
            x = np.asarray(x, dtype=float)
            d, twist = old.dim, x[..., old.size : old.size + old.dim]
            extra = np.zeros(x.shape[:-1] + (d * (kind.derivatives - 1),))
            return np.concatenate([new.exp(old.log(x[..., : old.size])), twist, extra], axis=-1)

        return replace(
            self,
            kind=kind,
            first_state=moved(self.first_state),
            initial_states=moved(self.initial_states),
            truth=moved(self.truth),
        )


@dataclass(frozen=True)
class RigidSample:
    """A task drawn from the estimator's model: the readings it sees, and the truth it does not."""

    data: RigidReadings
    states: NDArray  # (n, kind.size) the true states, as the prior holds them
    landmarks: dict[int, NDArray]  # id → true position (k,)
    prior: MotionPrior


def _noise(rng: np.random.Generator, sigma: float, shape: tuple[int, ...]) -> NDArray:
    return sigma * rng.standard_normal(shape)


def sample_rigid_task(
    prior: MotionPrior,
    n_steps: int,
    n_landmarks: int,
    seed: int | np.random.SeedSequence,
    *,
    dt: float = 1.0,
    first_twist: ArrayLike = (1.0, 0.0, 0.1, 0.0, 0.0, 0.15),
    noise: dict[str, float] | None = None,
    gps_every: int = 5,
    landmark_distance: tuple[float, float] = (4.0, 8.0),
) -> RigidSample:
    """A task of ``n_steps`` + 1 states ``dt`` apart and ``n_landmarks`` landmarks, drawn from ``prior`` (a prior on
    a group of rigid motions: 'se3', 'se3-wnoj', ...; module docstring). Each state has a gyro reading, a range and
    a body-frame point of its nearest landmark; every ``gps_every``-th state a position fix. ``noise`` overrides
    :data:`RIGID_NOISE`. A draw the model cannot read (a step turning beyond π) is a DataError naming the step."""
    kind = group_state(prior.kind, f"the state of {prior!r}")
    g = kind.group
    k, spin = point_dim(g), rotation_part(g)
    n = integer("n_steps", n_steps, 1) + 1
    n_landmarks = integer("n_landmarks", n_landmarks, 1)
    gps_every = integer("gps_every", gps_every, 1)
    sig = RIGID_NOISE | (noise or {})
    rng = np.random.default_rng(seed)
    twist = np.asarray(first_twist, dtype=float)
    if twist.shape != (g.dim,):
        raise SteamError(f"first_twist must be {g.dim} numbers (a twist of {g!r}), got {twist.tolist()}")
    blocks = [np.full(g.dim, sig["first_pose"]), np.full(g.dim, sig["first_twist"])]
    blocks += [np.full(g.dim, sig["first_twist"])] * (kind.derivatives - 1)  # an acceleration's, if the state has one
    states = prior.sample_states(rng, n, float(dt), twist, blocks)  # [YIB Eq. 22; DER 11.11, 14.1]
    times = dt * np.arange(n, dtype=float)
    poses = states[:, : g.size]
    path = position(g, poses)[0]
    # Landmarks around the path: each beside one of evenly spread states, in a random direction in k-space.
    anchors = (2 * np.arange(n_landmarks) + 1) * n // (2 * n_landmarks)
    direction = rng.standard_normal((n_landmarks, k))
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    truth = path[anchors] + direction * rng.uniform(*landmark_distance, size=(n_landmarks, 1))
    nearest = np.argmin(np.linalg.norm(path[:, None, :] - truth[None], axis=-1), axis=1)
    body = to_body(g, poses, truth[nearest])[0]  # each state's nearest landmark in its body frame  [DER 15.2]
    ranges = np.linalg.norm(body, axis=1) + _noise(rng, sig["range"], (n,))
    if np.any(ranges < 0):
        raise DataError(f"state {int(np.argmax(ranges < 0))}'s range came out negative: place the landmarks further")
    fixes = np.arange(0, n, gps_every)
    spin_rates = states[:, g.size + spin.start : g.size + spin.stop]
    data = RigidReadings(
        "rigid-model",
        kind,
        times,
        dict(sig),
        positions=np.column_stack([times[fixes], path[fixes] + _noise(rng, sig["position"], (len(fixes), k))]),
        gyro=np.column_stack([times, spin_rates + _noise(rng, sig["gyro"], spin_rates.shape)]),
        ranges=np.column_stack([times, nearest, ranges]),
        points=np.column_stack([times, nearest, body + _noise(rng, sig["point"], body.shape)]),
        landmarks=np.column_stack([np.arange(n_landmarks), truth + _noise(rng, sig["landmark"], truth.shape)]),
        first_state=np.concatenate([g.identity(), twist, np.zeros(g.dim * (kind.derivatives - 1))]),
        source=f"sample_rigid_task(prior={prior.name!r}, n_steps={n - 1}, n_landmarks={n_landmarks})",
    )
    return RigidSample(data, states, {j: truth[j].copy() for j in range(n_landmarks)}, prior)


def generate_rigid(n_steps: int = RIGID_STEPS, seed: int = 0) -> RigidReadings:
    """The generated 3-D data set 'synthetic-3d': a task of ``n_steps`` 1 s steps drawn from the SE(3) WNOA prior at
    :data:`RIGID_QC` (:func:`sample_rigid_task`, landmarks as dense as :data:`RIGID_STEPS` steps with
    :data:`RIGID_LANDMARKS`), a position fix every 5 s of which every other one is held out (10 s between the fixes
    an estimator reads), its true states in ``truth`` and :data:`RIGID_QC` as the Qc it runs with."""
    n_steps = integer("n_steps", n_steps, 1)
    n_landmarks = max(1, round(n_steps * RIGID_LANDMARKS / RIGID_STEPS))
    task = sample_rigid_task(motion_prior("se3", RIGID_QC), n_steps, n_landmarks, seed)
    fixes = task.data.positions
    return replace(
        task.data,
        name="synthetic-3d",
        positions=fixes[0::2],
        held_out=fixes[1::2],
        truth=task.states,
        qc=RIGID_QC.copy(),
        source=f"generate_rigid(n_steps={n_steps}, seed={seed})",
    )


def _check_landmarks(data: RigidReadings) -> None:
    """``data``'s landmarks: integer ids, each surveyed once; every range's and body-frame point's landmark among
    them (a reading of an id not surveyed, 0.5 or 99, was read as landmark 0 or failed with a KeyError)."""
    check_integer_ids("landmarks", data.landmarks[:, 0], 0)
    known = data.landmarks[:, 0]
    for table in ("ranges", "points"):
        ids = getattr(data, table)[:, 1]
        missing = rows_of(known, ids)[1]
        if missing is not None:
            raise DataError(
                f"{data.name}: {table} row {missing} (t={number_text(getattr(data, table)[missing, 0])}) names "
                f"landmark id {number_text(ids[missing])}, which is not in landmarks; known ids: {ids_text(known)}"
            )


def _check_states(data: RigidReadings) -> None:
    """``data``'s first state (size,), the first values and the truth (n, size) as ``kind`` stores a state; ShapeError
    naming the one that is not."""
    n, size = len(data.state_times), data.kind.size
    for name, shape in (("first_state", (size,)), ("initial_states", (n, size)), ("truth", (n, size))):
        value = getattr(data, name)
        if value is not None and np.shape(value) != shape:
            raise ShapeError(
                f"{data.name}: {name} must be {shape} ({data.kind!r} states at the {n} state times), got shape "
                f"{np.shape(value)}"
            )
