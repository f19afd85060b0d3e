"""A task drawn from the very model the estimator assumes: the ground truth for consistency checks.

:func:`~steam_ref.datasets.generate_synthetic` imitates the paper's *file*: its path is a WNOA sample of
(x, y) only with Qc = 1.5e-5 I, the heading is the direction of motion (no GP component), odometry is
distance and turn with 0.023 noise, ranges have 0.1 m noise. The paper's solver assumes something else
(Qc = 0.01 diag(1, 1, 25) on x, y, θ; projected-velocity sigmas 0.5, 0.5, 1; ranges 1 m with a Tukey
loss; landmark priors at the surveyed positions, pose 0's prior at ground truth). Its errors are not
drawn from the covariances the solver reports, so NEES on it would measure the mismatch, not the
solver. :func:`sample_from_model` draws everything from the estimator's own model instead, asking its motion
prior (:class:`~steam_ref.motion.MotionPrior`) for what differs between priors:

- the states (``MotionPrior.sample_states``): the first from the first state's prior, pose about the origin
  with ``first_pose_sigmas`` (the origin is the prior's mean: a data set without ground truth starts the front
  end there), velocity about ``first_velocity`` with ``first_velocity_sigmas`` (an acceleration about zero with
  ``first_acceleration_sigmas``, when the state has one); each next one by the prior's exact transition and
  noise over dt = 1 (the paper's WNOA: xₖ₊₁ = Φ(1) xₖ + wₖ, wₖ ~ N(0, Q(1)) [YIB Eq. 16-17, 30-31]; on SE(2)
  in the local variables of the state before, ``motion.LieGroupWnoa``);
- odometry at pose k: what the prior's velocity reading measures (``MotionPrior.body_velocity``: the projected
  velocity [R(θₖ)ᵀṗₖ; θ̇ₖ] [YIB Eq. 32] on a vector state, the body twist on SE(2)) plus N(0, diag(σᵥ²));
- landmarks: true positions as :func:`generate_synthetic` places them (but ``landmark_distance`` away,
  6-10 m by default, so that a range's Gaussian noise never makes it negative), surveyed at the true
  position plus N(0, σₗ² I) (the prior [YIB Eq. 4] is then exactly right);
- one range per pose, ‖pₖ - lⱼ‖ + N(0, σᵣ²) [YIB Eq. 33], to one of the ``n_nearest`` landmarks.

Times are 0, 1, ..., n_steps (dt = 1). The data set carries no ground truth (the estimator must not see
it); the truth is returned beside it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import DataError, SteamError
from ..gp.sde import LinearSDE
from ..motion import MotionPrior, as_motion_prior
from .landmarks import LandmarkDataset
from .synthetic import check_generator_args, ids_by_first_sighting, observed_landmarks, scatter_landmarks

__all__ = ["ModelSample", "sample_from_model"]


@dataclass(frozen=True)
class ModelSample:
    """A task drawn from the estimator's model: the data it sees, and the truth it does not."""

    data: LandmarkDataset  # odometry, ranges, surveyed landmarks; no ground truth
    states: NDArray  # (n_poses, n) true states as the prior holds them: [x, y, θ, ẋ, ẏ, θ̇] (θ not wrapped); SE(2):
    # [x, y, θ, vx, vy, ω], θ wrapped (prior.world_states gives every prior's in the world frame)
    landmarks: dict[int, NDArray]  # id → true position (2,)
    prior: MotionPrior  # the model the states were drawn from


def _positive3(name: str, value: ArrayLike, *, positive: bool = True) -> NDArray:
    v = np.asarray(value, dtype=float).ravel()
    if v.shape != (3,) or not np.all(np.isfinite(v)) or (positive and np.any(v <= 0)):
        raise SteamError(f"{name} must be 3 finite numbers{' > 0' if positive else ''}, got {v.tolist()}")
    return v


def _checked(
    n_steps: int,
    n_landmarks: int,
    seed: int | np.random.SeedSequence,
    velocity_sigmas: ArrayLike,
    range_sigma: float,
    landmark_sigma: float,
    first_velocity: ArrayLike,
    landmark_distance: tuple[float, float],
    n_nearest: int,
) -> tuple[int, int, NDArray, NDArray]:
    """The sampler's arguments checked: SteamError naming the first bad one."""
    if not isinstance(seed, np.random.SeedSequence):
        check_generator_args(n_steps, n_landmarks, (0, 0), 0.0, landmark_distance, n_nearest, seed)
    else:
        check_generator_args(n_steps, n_landmarks, (0, 0), 0.0, landmark_distance, n_nearest, 0)
    sv = _positive3("velocity_sigmas", velocity_sigmas)
    fv = _positive3("first_velocity", first_velocity, positive=False)
    for name, value in (("range_sigma", range_sigma), ("landmark_sigma", landmark_sigma)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value < np.inf:
            raise SteamError(f"{name} must be a finite number > 0, got {value!r}")
    return int(n_steps), int(n_landmarks), sv, fv


def sample_from_model(
    n_steps: int,
    n_landmarks: int,
    seed: int | np.random.SeedSequence,
    *,
    prior: MotionPrior | ArrayLike | LinearSDE,
    velocity_sigmas: ArrayLike,
    range_sigma: float,
    landmark_sigma: float,
    first_pose_sigmas: ArrayLike,
    first_velocity: ArrayLike,
    first_velocity_sigmas: ArrayLike,
    first_acceleration_sigmas: ArrayLike | None = None,
    landmark_distance: tuple[float, float] = (6.0, 10.0),
    n_nearest: int = 10,
) -> ModelSample:
    """A task of n_steps + 1 poses and n_landmarks landmarks drawn from the estimator's model (module
    docstring). ``prior``: the motion prior (a :class:`~steam_ref.motion.MotionPrior`, or Qc of the paper's WNOA
    prior); ``seed``: an integer or a :class:`numpy.random.SeedSequence` (one child of a spawn). A prior whose
    draw cannot be read by its own model (an SE(2) step turning beyond ±π) is a DataError naming the step."""
    n_steps, n_landmarks, sv, fv = _checked(
        n_steps, n_landmarks, seed, velocity_sigmas, range_sigma, landmark_sigma, first_velocity, landmark_distance,
        n_nearest,
    )  # fmt: skip
    prior = as_motion_prior(prior)
    sigmas = [
        _positive3("first_pose_sigmas", first_pose_sigmas),
        _positive3("first_velocity_sigmas", first_velocity_sigmas),
    ]
    if first_acceleration_sigmas is not None:
        sigmas.append(_positive3("first_acceleration_sigmas", first_acceleration_sigmas))
    rng = np.random.default_rng(seed)
    n = n_steps + 1
    states = prior.sample_states(rng, n, 1.0, fv, sigmas)  # [YIB Eq. 16-17, 22]
    # Odometry of pose k: what the prior's velocity reading measures, plus its noise.  [YIB Eq. 32]
    velocity = prior.body_velocity(states[1:]) + sv * rng.standard_normal((n_steps, 3))
    times = np.arange(n, dtype=float)
    odometry = np.column_stack([times[1:], velocity])  # dt = 1: the step is the velocity
    covariance = np.tile([sv[0] ** 2, 0, 0, sv[1] ** 2, 0, sv[2] ** 2], (n_steps, 1))
    source = f"sample_from_model(n_steps={n_steps}, n_landmarks={n_landmarks}, prior={prior.name!r})"
    return _task(
        rng,
        states,
        prior,
        odometry,
        covariance,
        source,
        n_landmarks,
        range_sigma,
        landmark_sigma,
        landmark_distance,
        n_nearest,
    )


def _task(
    rng: np.random.Generator,
    states: NDArray,
    prior: MotionPrior,
    odometry: NDArray,
    covariance: NDArray,
    source: str,
    n_landmarks: int,
    range_sigma: float,
    landmark_sigma: float,
    landmark_distance: tuple[float, float],
    n_nearest: int,
) -> ModelSample:
    """Landmarks around the path states[:, :2], one range per pose, the survey; the task and its truth."""
    n = len(states)
    times = np.arange(n, dtype=float)
    # Landmarks and ranges.  [YIB Eq. 4, 33]
    path = states[:, :2]
    anchors = (2 * np.arange(n_landmarks) + 1) * n // (2 * n_landmarks)
    truth_xy = scatter_landmarks(rng, path, anchors, landmark_distance)
    pick = observed_landmarks(rng, path, truth_xy, anchors, int(n_nearest))
    ids = ids_by_first_sighting(pick, n_landmarks)
    ranges = np.hypot(*(path - truth_xy[pick]).T) + range_sigma * rng.standard_normal(n)
    if np.any(ranges < 0):
        k = int(np.flatnonzero(ranges < 0)[0])
        raise DataError(
            f"pose {k}'s range came out negative ({ranges[k]!r} m): the landmarks are too near for range_sigma "
            f"{range_sigma!r}; place them further (landmark_distance)"
        )
    survey = truth_xy + landmark_sigma * rng.standard_normal(truth_xy.shape)
    order = np.argsort(ids)
    data = LandmarkDataset(
        "synthetic-model",
        poses=np.column_stack([times, np.arange(n)]),
        odometry=odometry,
        odometry_covariance=covariance,
        ranges=np.column_stack([times, ids[pick], ranges, np.full(n, float(range_sigma))]),
        landmarks=np.column_stack([ids[order], survey[order]]),
        source=source,
        time_origin="generated",
    )
    return ModelSample(data, states, {int(ids[j]): truth_xy[j].copy() for j in range(n_landmarks)}, prior)
