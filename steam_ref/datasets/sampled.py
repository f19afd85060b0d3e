"""A task drawn from the very model the estimator assumes: the ground truth for consistency checks.

:func:`~steam_ref.datasets.generate_synthetic` imitates the paper's *file*: its path is a WNOA sample of
(x, y) only with Qc = 1.5e-5 I, the heading is the direction of motion (no GP component), odometry is
distance and turn with 0.023 noise, ranges have 0.1 m noise. The paper's solver assumes something else
(Qc = 0.01 diag(1, 1, 25) on x, y, θ; projected-velocity sigmas 0.5, 0.5, 1; ranges 1 m with a Tukey
loss; landmark priors at the surveyed positions, pose 0's prior at ground truth). Its errors are not
drawn from the covariances the solver reports, so NEES on it would measure the mismatch, not the
solver. :func:`sample_from_model` draws everything from the estimator's own model instead:

- x₀ = [p₀; ṗ₀]: p₀ ~ N(0, diag(first_pose_sigmas²)) (the origin is the prior's mean: a data set
  without ground truth starts the front end there), ṗ₀ ~ N(first_velocity, diag(first_velocity_sigmas²));
- xₖ₊₁ = Φ(1) xₖ + wₖ, wₖ ~ N(0, Q(1)) with the estimator's Qc on x, y and θ [YIB Eq. 16-17, 30-31];
- odometry at pose k: the projected velocity h(xₖ) = [R(θₖ)ᵀṗₖ; θ̇ₖ] [YIB Eq. 32] plus N(0, diag(σᵥ²));
- landmarks: true positions as :func:`generate_synthetic` places them (but ``landmark_distance`` away,
  6-10 m by default, so that a range's Gaussian noise never makes it negative), surveyed at the true
  position plus N(0, σₗ² I) (the prior [YIB Eq. 4] is then exactly right);
- one range per pose, ‖pₖ - lⱼ‖ + N(0, σᵣ²) [YIB Eq. 33], to one of the ``n_nearest`` landmarks.

:func:`sample_se2_from_model` draws the same kind of task from the SE(2) WNOA model (``steam_ref.lie.gp``).

Times are 0, 1, ..., n_steps (dt = 1). The data set carries no ground truth (the estimator must not see
it); the truth is returned beside it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import DataError, SteamError
from ..gp.prior import check_qc, process_noise, transition
from ..lie import SE2
from ..lie.gp import check_model
from .landmarks import LandmarkDataset
from .synthetic import check_generator_args, ids_by_first_sighting, observed_landmarks, scatter_landmarks

__all__ = ["ModelSample", "sample_from_model", "sample_se2_from_model"]


@dataclass(frozen=True)
class ModelSample:
    """A task drawn from the estimator's model: the data it sees, and the truth it does not."""

    data: LandmarkDataset  # odometry, ranges, surveyed landmarks; no ground truth
    states: NDArray  # (n_poses, 6) true [x, y, θ, ẋ, ẏ, θ̇] (θ not wrapped); SE(2): [x, y, θ, vx, vy, ω], θ wrapped
    landmarks: dict[int, NDArray]  # id → true position (2,)


def _positive3(name: str, value: ArrayLike, *, positive: bool = True) -> NDArray:
    v = np.asarray(value, dtype=float).ravel()
    if v.shape != (3,) or not np.all(np.isfinite(v)) or (positive and np.any(v <= 0)):
        raise SteamError(f"{name} must be 3 finite numbers{' > 0' if positive else ''}, got {v.tolist()}")
    return v


def _checked(
    n_steps: int,
    n_landmarks: int,
    seed: int | np.random.SeedSequence,
    qc: ArrayLike,
    velocity_sigmas: ArrayLike,
    range_sigma: float,
    landmark_sigma: float,
    first_pose_sigmas: ArrayLike,
    first_velocity: ArrayLike,
    first_velocity_sigmas: ArrayLike,
    landmark_distance: tuple[float, float],
    n_nearest: int,
) -> tuple[int, int, NDArray, NDArray, NDArray, NDArray, NDArray]:
    """The samplers' arguments checked: SteamError naming the first bad one."""
    if not isinstance(seed, np.random.SeedSequence):
        check_generator_args(n_steps, n_landmarks, (0, 0), 0.0, landmark_distance, n_nearest, seed)
    else:
        check_generator_args(n_steps, n_landmarks, (0, 0), 0.0, landmark_distance, n_nearest, 0)
    qc = check_qc(np.asarray(qc, dtype=float))
    if qc.shape != (3, 3):
        raise SteamError(f"qc must be (3, 3) for x, y, θ, got shape {qc.shape}")
    sv = _positive3("velocity_sigmas", velocity_sigmas)
    fps, fvs = (
        _positive3("first_pose_sigmas", first_pose_sigmas),
        _positive3("first_velocity_sigmas", first_velocity_sigmas),
    )
    fv = _positive3("first_velocity", first_velocity, positive=False)
    for name, value in (("range_sigma", range_sigma), ("landmark_sigma", landmark_sigma)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 < value < np.inf:
            raise SteamError(f"{name} must be a finite number > 0, got {value!r}")
    return int(n_steps), int(n_landmarks), qc, sv, fps, fv, fvs


def sample_from_model(
    n_steps: int,
    n_landmarks: int,
    seed: int | np.random.SeedSequence,
    *,
    qc: ArrayLike,
    velocity_sigmas: ArrayLike,
    range_sigma: float,
    landmark_sigma: float,
    first_pose_sigmas: ArrayLike,
    first_velocity: ArrayLike,
    first_velocity_sigmas: ArrayLike,
    landmark_distance: tuple[float, float] = (6.0, 10.0),
    n_nearest: int = 10,
) -> ModelSample:
    """A task of n_steps + 1 poses and n_landmarks landmarks drawn from the estimator's model (module
    docstring). ``seed`` is an integer or a :class:`numpy.random.SeedSequence` (one child of a spawn)."""
    n_steps, n_landmarks, qc, sv, fps, fv, fvs = _checked(
        n_steps, n_landmarks, seed, qc, velocity_sigmas, range_sigma, landmark_sigma, first_pose_sigmas,
        first_velocity, first_velocity_sigmas, landmark_distance, n_nearest,
    )  # fmt: skip
    rng = np.random.default_rng(seed)
    n = n_steps + 1
    # The path: x₀ from the first state's prior, then the GP's exact transitions.  [YIB Eq. 16-17]
    phi, chol = transition(1.0, 3), np.linalg.cholesky(process_noise(1.0, qc))
    states = np.empty((n, 6))
    states[0] = np.concatenate([fps * rng.standard_normal(3), fv + fvs * rng.standard_normal(3)])
    noise = rng.standard_normal((n_steps, 6)) @ chol.T
    for k in range(1, n):
        states[k] = phi @ states[k - 1] + noise[k - 1]
    # Odometry of pose k: the projected velocity [YIB Eq. 32] plus its noise.
    th, xd, yd, thd = states[1:, 2], states[1:, 3], states[1:, 4], states[1:, 5]
    c, s = np.cos(th), np.sin(th)
    velocity = np.column_stack([c * xd + s * yd, -s * xd + c * yd, thd]) + sv * rng.standard_normal((n_steps, 3))
    times = np.arange(n, dtype=float)
    odometry = np.column_stack([times[1:], velocity])  # dt = 1: the step is the velocity
    covariance = np.tile([sv[0] ** 2, 0, 0, sv[1] ** 2, 0, sv[2] ** 2], (n_steps, 1))
    source = f"sample_from_model(n_steps={n_steps}, n_landmarks={n_landmarks})"
    return _task(
        rng,
        states,
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
    return ModelSample(data, states, {int(ids[j]): truth_xy[j].copy() for j in range(n_landmarks)})


def sample_se2_from_model(
    n_steps: int,
    n_landmarks: int,
    seed: int | np.random.SeedSequence,
    *,
    qc: ArrayLike,
    velocity_sigmas: ArrayLike,
    range_sigma: float,
    landmark_sigma: float,
    first_pose_sigmas: ArrayLike,
    first_velocity: ArrayLike,
    first_velocity_sigmas: ArrayLike,
    landmark_distance: tuple[float, float] = (6.0, 10.0),
    n_nearest: int = 10,
    model: str = "local-variable",
) -> ModelSample:
    """A task drawn from the SE(2) WNOA model (``steam_ref.lie.gp``; ``model`` names its residual).

    The states are SE(2) states [px, py, θ, vx, vy, ω] (θ in (-π, π], ϖ the body twist):

    - x₀: T₀ = Exp(n), n ~ N(0, diag(first_pose_sigmas²)) (the pose prior in the tangent at the
      identity, right retraction), ϖ₀ ~ N(first_velocity, diag(first_velocity_sigmas²));
    - each step in the local variables of the state before it [DER 11.10-11.11]: γ₂ = Φ(1) [0; ϖₖ] + w,
      w ~ N(0, Q(1)) with Qc on the body twist, then Tₖ₊₁ = Tₖ Exp(γ₂[:3]) and ϖₖ₊₁ = J_r(γ₂[:3]) γ₂[3:]
      ("local-variable") or γ₂[3:] ("simplified"), so the model's residual at the truth is w exactly;
    - odometry at pose k: the body twist ϖₖ plus N(0, diag(σᵥ²)) (dt = 1: a row holds the reading);
    - landmarks, their survey and one range per pose as :func:`sample_from_model` draws them.

    A step whose turn γ₂[2] leaves (-π, π) is not a draw the model can represent (its residual would
    read the wrapped angle): DataError naming the step.
    """
    n_steps, n_landmarks, qc, sv, fps, fv, fvs = _checked(
        n_steps, n_landmarks, seed, qc, velocity_sigmas, range_sigma, landmark_sigma, first_pose_sigmas,
        first_velocity, first_velocity_sigmas, landmark_distance, n_nearest,
    )  # fmt: skip
    model = check_model(model)
    rng = np.random.default_rng(seed)
    n = n_steps + 1
    chol = np.linalg.cholesky(process_noise(1.0, qc))
    states = np.empty((n, 6))
    states[0] = np.concatenate([SE2.exp(fps * rng.standard_normal(3)), fv + fvs * rng.standard_normal(3)])
    noise = rng.standard_normal((n_steps, 6)) @ chol.T
    for k in range(1, n):
        twist = states[k - 1, 3:]
        gamma = np.concatenate([twist, twist]) + noise[k - 1]  # Φ(1) [0; ϖ] + w  [YIB Eq. 22; DER 11.11]
        if not -np.pi < gamma[2] < np.pi:
            raise DataError(f"step {k} turned {gamma[2]!r} rad, outside (-π, π): no SE(2) WNOA residual reads it")
        states[k, :3] = SE2.compose(states[k - 1, :3], SE2.exp(gamma[:3]))  # Tₖ₊₁ = Tₖ Exp(ξ)
        states[k, 3:] = SE2.right_jacobian(gamma[:3]) @ gamma[3:] if model == "local-variable" else gamma[3:]
    velocity = states[1:, 3:] + sv * rng.standard_normal((n_steps, 3))  # the body twist, read
    odometry = np.column_stack([np.arange(1.0, n), velocity])  # dt = 1: the step is the velocity
    covariance = np.tile([sv[0] ** 2, 0, 0, sv[1] ** 2, 0, sv[2] ** 2], (n_steps, 1))
    source = f"sample_se2_from_model(n_steps={n_steps}, n_landmarks={n_landmarks}, model={model!r})"
    return _task(
        rng,
        states,
        odometry,
        covariance,
        source,
        n_landmarks,
        range_sigma,
        landmark_sigma,
        landmark_distance,
        n_nearest,
    )
