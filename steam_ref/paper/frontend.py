"""Algorithm 1 step 1: readings in, new variables, initial values and factors out.  [YIB Alg. 1]

The one home of the rules that turn a data set's readings into a factor graph, pose by pose, as a
robot would meet them:

- **Layout** (:class:`Layout`): which poses get an estimated state x(tᵢ): pose 0, any pose ``skip``
  steps after the previous state, every pose with a landmark reading when ``range_states``, and the
  last pose.
- **Readings → factors**: a projected-velocity reading is a :class:`~steam_ref.factors.VelocityFactor`
  of its pose, a range a :class:`~steam_ref.factors.RangeFactor` to its landmark (Eq. 33), with the
  set-up's noise and robust loss; a bearing a :class:`~steam_ref.factors.BearingFactor`, a
  bearing-range a :class:`~steam_ref.factors.BearingRangeFactor`, each with its own sigmas.
- **Readings between states** are buffered until the next state exists, then enter as interpolated
  factors on the two neighbouring states (Eq. 29), velocity readings with the looser
  ``interpolated_velocity_sigmas``; with ``interpolate=False`` they are dropped.
- **The motion prior** (``PaperSetup.motion_prior()``, a :class:`~steam_ref.motion.MotionPrior`) owns what
  differs between priors, and the front end asks it: each new state brings its prior factor to the previous
  one (Eq. 22); a velocity reading, a range, bearing or bearing-range, a reading between states (Eq. 29), the
  first state's prior and a new state's first value (its kind in ``NewStep.kinds``) are what it makes of them
  (the paper's WNOA; WNOJ / Singer, states of 9 numbers whose acceleration starts at zero; WNOA on SE(2),
  a pose and its body twist).
- **Landmarks**: a surveyed landmark enters with its prior at its surveyed position (Eq. 4), at its
  first sighting or, when the set-up says so (Plaza), all of them at pose 0. A landmark nobody
  surveyed (Victoria Park's trees) enters at its first sighting with no prior, placed where its first
  bearing-range reading puts it seen from the pose predicted at that reading (the script's
  ``lastPose.transform_from(...)``); a range or a bearing alone cannot place it (SteamError).
- **Initial values** (as the paper's scripts make them): a new pose is the previous pose composed
  with the odometry (:func:`steam_ref.dead_reckoning.compose`; [dx, dy, dθ] = velocity × dt); its velocity is the backward difference over
  the last step, (pᵢ - pᵢ₋₁)/dt, the only velocity a causal front end knows when the state is made
  (the scripts take the heading part as the difference of two GTSAM ``Pose2`` headings, each wrapped
  to (-π, π], so it is off by ±2π where the heading crosses ±π; ``PaperSetup.pose2_heading_rate_guess``).
  After a solver update the caller hands the front end the latest state's estimate
  (:meth:`FrontEnd.rebase`), so predictions compose from the estimate, not from dead reckoning.

The batch problem is everything the front end yields (:func:`steam_ref.paper.problem.build_problem`); the
streaming solvers (PB, PBVR, BTGP) consume the same steps, so the two agree by construction.
"""

from __future__ import annotations

from array import array
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from ..arguments import is_integer
from ..dead_reckoning import compose, transform_from, wrap_angle
from ..errors import SteamError
from ..factors import BearingFactor, BearingRangeFactor, Factor, PriorFactor, RangeFactor
from ..manifold import Manifold
from ..variables import Key, L, X
from .presets import PaperSetup
from .readings import Readings

__all__ = ["Layout", "NewStep", "FrontEnd"]


@dataclass(frozen=True)
class Layout:
    """Which poses get an estimated state, and what happens to readings between states."""

    skip: int = 1  # a state at most ``skip`` steps after the previous one (the time-step difference of Fig. 3/4)
    range_states: bool = False  # also a state at every pose with a landmark reading (the Plaza scripts)
    interpolate: bool = True  # readings between states: interpolated (Eq. 29) or dropped

    def __post_init__(self) -> None:
        if not is_integer(self.skip) or self.skip < 1:
            raise SteamError(f"skip must be a positive integer, got {self.skip!r}")

    def is_state(self, pose: int, last_state: int, has_range: bool, last_pose: int) -> bool:
        """Pose ``pose`` gets a state, given the previous state and whether it has a range reading."""
        return pose == 0 or pose - last_state >= self.skip or pose == last_pose or (self.range_states and has_range)

    def state_poses(self, n_poses: int, range_poses: NDArray | None = None) -> NDArray:
        """(M,) the poses that get a state, in order, for a stream of ``n_poses`` poses."""
        has_range = np.zeros(n_poses, dtype=bool)
        if range_poses is not None:
            range_poses = np.asarray(range_poses, dtype=int)
            if range_poses.size and not (range_poses.min() >= 0 and range_poses.max() < n_poses):
                raise SteamError(
                    f"range poses must lie in [0, {n_poses}), got {range_poses.min()}..{range_poses.max()}"
                )
            has_range[range_poses] = True
        chosen = [0]
        for i in range(1, n_poses):
            if self.is_state(i, chosen[-1], bool(has_range[i]), n_poses - 1):
                chosen.append(i)
        return np.array(chosen)


@dataclass
class NewStep:
    """What one pose of the stream adds to the problem (filled by the front end, read by the caller)."""

    pose: int  # the pose (time step) processed
    is_state: bool  # the pose got an estimated state X(pose)
    factors: list[Factor]  # the new factors released at this pose
    values: dict[Key, NDArray] = field(default_factory=dict)  # initial values of the new variables
    n_landmark_readings: int = 0  # range, bearing and bearing-range factors among ``factors`` (plain or interpolated)
    kinds: dict[Key, Manifold] = field(default_factory=dict)  # how each new state moves (the motion prior's kind)


def _pose2_heading(theta: float) -> float:
    """θ as GTSAM's ``Pose2.theta()`` returns it: wrapped to (-π, π]."""
    return float(-wrap_angle(-theta))


class FrontEnd:
    """Algorithm 1 step 1 over a :class:`Readings` stream: :meth:`step` once per pose, in order."""

    def __init__(self, readings: Readings, setup: PaperSetup, layout: Layout = Layout(), n_poses: int | None = None):
        if n_poses is not None and (not is_integer(n_poses) or n_poses < 1):
            raise SteamError(f"n_poses must be a positive integer (or None for all), got {n_poses!r}")
        self.readings, self.setup, self.layout = readings, setup, layout
        self.prior = setup.motion_prior()  # what differs between priors, asked of one object
        self.n_poses = readings.n_poses if n_poses is None else min(int(n_poses), readings.n_poses)  # poses to process
        self.states = array("q")  # poses with a state so far, increasing (8 bytes each: a long run's record)
        self.landmarks: set[int] = set()  # landmark ids with a variable
        self._bounds = readings.range_rows()
        self._bearing_bounds = readings.bearings.rows(readings.n_poses)
        self._bearing_range_bounds = readings.bearing_ranges.rows(readings.n_poses)
        self._placed: dict[int, NDArray] = {}  # an unsurveyed landmark's position from its first bearing-range reading
        self._next = 0  # the pose step() processes next
        self._buffer: list[tuple[int, Factor, bool]] = []  # (pose, reading, of a landmark?) after the last state
        self._pose = readings.first_pose.copy()  # predicted [x, y, θ] of the latest pose
        self._velocity = setup.first_velocity.copy()  # predicted velocity over the latest step
        self._range_loss = setup.range_loss  # one loss for every range (a batch of them then shares the object)

    @property
    def n_processed(self) -> int:
        """Poses processed so far."""
        return self._next

    @property
    def done(self) -> bool:
        """True when every pose has been processed."""
        return self._next >= self.n_poses

    def __iter__(self) -> Iterator[NewStep]:
        while not self.done:
            yield self.step()

    def rebase(self, pose_estimate: NDArray) -> None:
        """The latest state's estimate [x, y, θ, ...]: the next prediction composes from it."""
        self._pose = np.array(pose_estimate[:3], dtype=float)

    def step(self) -> NewStep:
        """Process the readings of the next pose."""
        if self.done:
            raise SteamError(f"the stream has ended: all {self.n_poses} poses processed")
        i = self._next
        self._next += 1
        if i > 0:
            self._predict(i)
        has_reading = any(b[i + 1] > b[i] for b in (self._bounds, self._bearing_bounds, self._bearing_range_bounds))
        if not self.layout.is_state(i, self.states[-1] if self.states else 0, has_reading, self.n_poses - 1):
            if self.layout.interpolate:
                self._buffer.append((i, self._velocity_factor(i, interpolated=True), False))
                self._buffer.extend((i, f, True) for f in self._landmark_factors(i))
            return NewStep(i, False, [])
        return self._new_state(i)

    # -- the pieces --

    def _predict(self, i: int) -> None:
        """Initial guess of pose i: odometry row i - 1 composed onto the latest pose."""
        dt = self.readings.model_times[i] - self.readings.model_times[i - 1]  # 1 on the pose-index clock
        forward, lateral, turn = self.readings.velocity[i] * dt
        new = compose(self._pose, forward, turn, lateral)
        self._velocity = (new - self._pose) / dt  # backward difference over the step just made
        if self.setup.pose2_heading_rate_guess:  # the scripts difference GTSAM Pose2 headings, each in (-π, π]
            self._velocity[2] = (_pose2_heading(new[2]) - _pose2_heading(self._pose[2])) / dt
        self._pose = new

    def _new_state(self, i: int) -> NewStep:
        """X(i): its value, the GP prior to the previous state, the buffered and its own readings."""
        dt = self.readings.model_times[i] - self.readings.model_times[i - 1] if i > 0 else 1.0
        value = self.prior.initial_state(self._pose, self._velocity, dt)  # WNOJ / Singer: acceleration zero
        key = X(i)
        out = NewStep(i, True, [], {key: value}, kinds={key: self.prior.kind})
        if i == 0:
            out.factors.append(self._first_state_prior())
            if self.setup.landmarks_up_front:
                for lid in self.readings.landmarks:
                    self._landmark(lid, out)
        else:
            prev = self.states[-1]
            out.factors.append(self._gp_prior(prev, i))
            for pose, inner, landmark in self._buffer:
                self._release(self._interpolated(inner, prev, i, pose), out, landmark)
            self._buffer = []
            self._release(self._velocity_factor(i, interpolated=False), out, False)
        for f in self._landmark_factors(i):
            self._release(f, out, True)
        self.states.append(i)
        return out

    def _release(self, factor: Factor, out: NewStep, landmark: bool) -> None:
        """A factor joins the step's new factors; a landmark seen for the first time enters (:meth:`_landmark`)."""
        if landmark:  # a range, bearing or bearing-range: its last key is the landmark
            self._landmark(factor.keys[-1].index, out)
            out.n_landmark_readings += 1
        out.factors.append(factor)

    def _landmark(self, lid: int, out: NewStep) -> None:
        """Landmark ``lid``'s variable, once: at its surveyed position with a prior there (Eq. 4), or,
        not surveyed, where its first bearing-range reading placed it, with no prior."""
        if lid in self.landmarks:
            return
        if lid in self.readings.landmarks:
            mark = self.readings.landmarks[lid]
            out.factors.append(PriorFactor.create(L(lid), mark, self.setup.landmark_prior_sigma))
            out.values[L(lid)] = mark.copy()
        elif lid in self._placed:
            out.values[L(lid)] = self._placed.pop(lid)
        else:
            raise SteamError(
                f"landmark {lid} is not surveyed and its first reading is a range or a bearing alone, "
                f"which cannot place it: it needs a surveyed position or a bearing-range reading first"
            )
        self.landmarks.add(lid)

    def _first_state_prior(self) -> Factor:
        """Priors on pose 0 (at ground truth) and on velocity 0 (and acceleration 0), as one prior on X(0)."""
        s = self.setup
        sigmas = (s.first_pose_sigmas, s.first_velocity_sigmas, s.first_acceleration_sigmas)
        return self.prior.first_state_prior(X(0), self.readings.first_pose, s.first_velocity, sigmas)

    def _gp_prior(self, a: int, b: int) -> Factor:
        """The GP prior factor between states a and b.  [YIB Eq. 22]"""
        t = self.readings.model_times
        return self.prior.prior_factor(X(a), X(b), t[b] - t[a])

    def _interpolated(self, inner: Factor, a: int, b: int, pose: int) -> Factor:
        """``inner`` (a reading at the pose without a state) on states a and b.  [YIB Eq. 29]"""
        t = self.readings.model_times
        return self.prior.interpolated_factor(inner, X(a), X(b), t[a], t[b], t[pose])

    def _velocity_factor(self, i: int, interpolated: bool) -> Factor:
        """Odometry row i - 1 as the velocity reading of pose i (the projected velocity, or on SE(2) the body twist)."""
        sigmas = self.setup.interpolated_velocity_sigmas if interpolated else self.setup.velocity_sigmas
        return self.prior.velocity_reading(X(i), self.readings.velocity[i], sigmas)

    def _landmark_factors(self, i: int) -> list[Factor]:
        """The landmark readings of pose i as factors on X(i) (X(i) may be a pose without a state): its
        ranges, bearings, then bearing-ranges, each as the motion prior reads a pose reading on its state; a
        bearing-range places a landmark not met before."""
        r, loss, n, pose = self.readings, self._range_loss, self.prior.state_dim, self.prior.pose_reading
        out: list[Factor] = [
            pose(
                RangeFactor.create(
                    X(i), L(r.range_landmark[k]), r.range_value[k], r.range_sigma[k], loss=loss, state_dim=n
                )
            )
            for k in range(self._bounds[i], self._bounds[i + 1])
        ]
        b = r.bearings
        for k in range(self._bearing_bounds[i], self._bearing_bounds[i + 1]):
            out.append(pose(BearingFactor.create(X(i), L(b.landmark[k]), b.value[k, 0], b.sigma[k, 0], state_dim=n)))
        br = r.bearing_ranges
        for k in range(self._bearing_range_bounds[i], self._bearing_range_bounds[i + 1]):
            lid, (bearing, distance) = int(br.landmark[k]), br.value[k]
            out.append(pose(BearingRangeFactor.create(X(i), L(lid), bearing, distance, br.sigma[k], state_dim=n)))
            self._place(lid, bearing, distance)
        return out

    def _place(self, lid: int, bearing: float, distance: float) -> None:
        """An unsurveyed landmark not met before: where this bearing-range reading puts it from the predicted pose."""
        r = self.readings
        if lid not in r.landmarks and lid not in self.landmarks and lid not in self._placed:
            self._placed[lid] = transform_from(self._pose, distance * np.array([np.cos(bearing), np.sin(bearing)]))
