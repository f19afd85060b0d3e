"""A synthetic exploration task like the paper's: WNOA path, odometry, landmarks, ranges.  [YIB Sec. IV-A]"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from ..arguments import is_integer
from ..dead_reckoning import integrate_odometry, wrap_angle
from ..errors import ShapeError, SteamError
from ..gp.prior import check_qc, process_noise, transition
from .table import RangeDataset

__all__ = ["generate_synthetic", "synthetic_bytes", "MAX_SYNTHETIC_BYTES"]

# What generate_synthetic holds at its peak, measured with tracemalloc (tests/test_bad_api_inputs_refused.py checks
# it bounds the peak): about 260 bytes a pose (its sampled state and noise, ground truth, odometry, dead reckoning and
# range, a few float64 rows each) and 1,050 a landmark (its 64 candidate places, drawn at once), beside a few MB of
# chunked temporaries. Rounded up here.
_BYTES_PER_POSE, _BYTES_PER_LANDMARK, _BYTES_FIXED = 300, 1_200, 8_000_000

# The largest task generated: 4 GiB, about 14 million steps, ten thousand times the paper's 1,500 (and a minute of
# its step-by-step sampling). A fixed ceiling, not the machine's free memory, so that a call is refused, or not, the
# same on every machine, as a seed gives the same data set everywhere; past it NumPy's bare MemoryError, or the
# machine swapping, would be the answer instead.
MAX_SYNTHETIC_BYTES = 4 * 2**30


def synthetic_bytes(n_steps: int, n_landmarks: int) -> int:
    """About the most memory (bytes) :func:`generate_synthetic` holds at once for a task of this size (a bound)."""
    return _BYTES_PER_POSE * (n_steps + 1) + _BYTES_PER_LANDMARK * n_landmarks + _BYTES_FIXED


def _sample_wnoa(rng: np.random.Generator, n: int, qc: NDArray) -> NDArray:
    """(n, 4) exact samples [x, y, ẋ, ẏ] of the WNOA GP at t = 1..n, from x(0) = 0.  [YIB Eq. 30-31]"""
    phi = transition(1.0, 2)  # Φ(t+1, t)                        [YIB Eq. 16]
    chol = np.linalg.cholesky(process_noise(1.0, qc))  # Q(1) = L Lᵀ  [YIB Eq. 17]
    noise = rng.standard_normal((n, 4)) @ chol.T
    states, x = np.empty((n, 4)), np.zeros(4)
    for k in range(n):
        x = phi @ x + noise[k]
        states[k] = x
    return states


def _noisy_odometry(rng: np.random.Generator, gt: NDArray, sigmas: NDArray) -> NDArray:
    """(n_poses - 1, 3) DR rows: time of pose k+1, |p[k+1] - p[k]| + noise, wrapped Δθ + noise."""
    distance = np.hypot(*np.diff(gt[:, 1:3], axis=0).T)
    turn = np.diff(gt[:, 3])
    noise = rng.standard_normal((len(distance), 2)) * sigmas
    return np.column_stack([gt[1:, 0], distance + noise[:, 0], wrap_angle(turn + noise[:, 1])])


def scatter_landmarks(rng: np.random.Generator, path: NDArray, anchors: NDArray, reach: tuple[float, float]) -> NDArray:
    """(n, 2) landmark positions, landmark j placed by pose ``anchors[j]`` of ``path`` (n_poses, 2).

    Each sits at a uniform bearing and a uniform distance in [lo, hi] = ``reach`` from its anchor
    pose; of 64 such candidates the first at least lo from every pose of the path is kept (else
    the one farthest from the path).
    """
    lo, hi = reach
    n = len(anchors)
    bearing = rng.uniform(0, 2 * np.pi, (n, 64))
    radius = rng.uniform(lo, hi, (n, 64))
    tree, out = cKDTree(path), np.empty((n, 2))
    for a in range(0, n, 512):  # rows at a time: the candidates' temporaries stay small (16 MB whole at 20,000 poses)
        rows = slice(a, a + 512)
        offsets = radius[rows, :, None] * np.stack([np.cos(bearing[rows]), np.sin(bearing[rows])], axis=-1)
        points = path[anchors[rows], None, :] + offsets
        clearance = tree.query(points.reshape(-1, 2))[0].reshape(-1, 64)
        ok = clearance >= lo
        pick = np.where(ok.any(axis=1), ok.argmax(axis=1), clearance.argmax(axis=1))
        out[rows] = points[np.arange(len(pick)), pick]
    return out


def observed_landmarks(
    rng: np.random.Generator, path: NDArray, xy: NDArray, anchors: NDArray, n_nearest: int
) -> NDArray:
    """(n_poses,) index of the landmark ranged at each pose: one drawn among its n_nearest,
    except that at its anchor pose a landmark is the one ranged (so every landmark is seen)."""
    k, chunk = min(n_nearest, len(xy)), max(1, 200_000 // len(xy))  # rows at a time: memory stays small
    nearest = np.empty((len(path), k), dtype=int)
    for a in range(0, len(path), chunk):
        p = path[a : a + chunk]
        dist = np.hypot(p[:, None, 0] - xy[None, :, 0], p[:, None, 1] - xy[None, :, 1])
        nearest[a : a + chunk] = np.argsort(dist, axis=1, kind="stable")[:, :k]
    rows = np.arange(len(path))
    pick = nearest[rows, rng.integers(0, nearest.shape[1], len(path))]
    pick[anchors] = np.arange(len(xy))  # later anchors win if n_landmarks > n_poses
    return pick


def ids_by_first_sighting(pick: NDArray, n: int) -> NDArray:
    """(n,) id of each landmark: 1, 2, ... in order of first sighting; unseen ones last."""
    seen = pick[np.sort(np.unique(pick, return_index=True)[1])]
    order = np.concatenate([seen, np.setdiff1d(np.arange(n), seen)])
    ids = np.empty(n, dtype=int)
    ids[order] = np.arange(1, n + 1)
    return ids


def _landmarks_and_ranges(
    rng: np.random.Generator,
    gt: NDArray,
    n: int,
    reach: tuple[float, float],
    n_nearest: int,
    sigma: float,
) -> tuple[NDArray, NDArray]:
    """(n, 3) landmarks id, x, y and (n_poses, 4) ranges time, sender 1, id, range.  [YIB Eq. 33]"""
    path = gt[:, 1:3]
    anchors = (2 * np.arange(n) + 1) * len(gt) // (2 * n)  # evenly spaced pose indices
    xy = scatter_landmarks(rng, path, anchors, reach)
    pick = observed_landmarks(rng, path, xy, anchors, n_nearest)
    ids = ids_by_first_sighting(pick, n)
    true = np.hypot(*(path - xy[pick]).T)
    measured = true + sigma * rng.standard_normal(len(gt))  # [YIB Eq. 33]
    negative = np.flatnonzero(measured < 0)
    while negative.size:  # a range is a distance: its noise is redrawn (N(0, σ²) truncated at -true)
        measured[negative] = true[negative] + sigma * rng.standard_normal(negative.size)
        negative = negative[measured[negative] < 0]
    ranges = np.column_stack([gt[:, 0], np.ones(len(gt)), ids[pick], measured])
    return np.column_stack([ids, xy])[np.argsort(ids)], ranges


def _is_count(value: object, lowest: int) -> bool:
    """An integer (:func:`~steam_ref.arguments.is_integer`) >= ``lowest``."""
    return is_integer(value) and bool(value >= lowest)


def _is_number(value: object, lowest: float, strict: bool) -> bool:
    """A finite real above ``lowest`` (``strict``) or at least ``lowest``; never a bool."""
    return bool(
        not isinstance(value, bool)
        and isinstance(value, (int, float, np.integer, np.floating))
        and math.isfinite(value)
        and (value > lowest if strict else value >= lowest)
    )


def check_generator_args(
    n_steps: int,
    n_landmarks: int,
    sigmas: object,
    range_sigma: float,
    reach: object,
    n_nearest: int,
    seed: int,
) -> NDArray:
    """The odometry sigmas (2,) after checking every argument (SteamError naming the bad one)."""
    if not is_integer(seed) or seed < 0:
        raise SteamError(f"seed must be an integer >= 0, got {seed!r}")
    for name, value in (("n_steps", n_steps), ("n_landmarks", n_landmarks), ("n_nearest", n_nearest)):
        if not _is_count(value, 1):
            raise SteamError(f"{name} must be a positive integer, got {value!r}")
    try:
        sigmas = np.asarray(sigmas, dtype=float).ravel()
    except (TypeError, ValueError):
        raise SteamError(f"odometry_sigmas must be two finite values >= 0, got {sigmas!r}") from None
    if sigmas.shape != (2,) or not np.all(np.isfinite(sigmas)) or np.any(sigmas < 0):
        raise SteamError(f"odometry_sigmas must be two finite values >= 0, got {sigmas.tolist()}")
    if not _is_number(range_sigma, 0, strict=False):
        raise SteamError(f"range_sigma must be finite and >= 0, got {range_sigma!r}")
    if not (
        isinstance(reach, (tuple, list))
        and len(reach) == 2
        and all(_is_number(r, 0, strict=True) for r in reach)
        and reach[0] <= reach[1]
    ):
        raise SteamError(f"landmark_distance must be (lo, hi) with 0 < lo <= hi, both finite; got {reach!r}")
    return sigmas


def _generator_qc(qc: ArrayLike | None) -> NDArray:
    """Qc for (x, y): the default 1.5e-5 I, a scalar times I, or a (2, 2) matrix."""
    qc = np.asarray(1.5e-5 if qc is None else qc, dtype=float)
    qc = qc * np.eye(2) if qc.ndim == 0 else qc
    if qc.shape != (2, 2):
        raise ShapeError(f"qc must be a scalar or (2, 2) for x, y; got shape {qc.shape}")
    return check_qc(qc)


def generate_synthetic(
    n_steps: int = 1500,
    n_landmarks: int = 298,
    seed: int = 0,
    *,
    qc: ArrayLike | None = None,
    odometry_sigmas: ArrayLike = (0.023, 0.023),
    range_sigma: float = 0.1,
    landmark_distance: tuple[float, float] = (2.0, 5.0),
    n_nearest: int = 10,
) -> RangeDataset:
    """A synthetic exploration task like the paper's (Section IV-A, ``Syn_theta_Plaza.mat``).

    Returns n_steps + 1 poses at t = 1, 2, ..., n_steps + 1 (dt = 1), n_steps odometry rows,
    n_landmarks landmarks (ids 1..n) and one range per pose (n_steps + 1 rows, sender id 1).

    - Path: [x, y, ẋ, ẏ] sampled exactly from the zero-mean WNOA GP [YIB Eq. 30-31] with
      x(0) = 0 at t = 0, Qc = ``qc`` (scalar or (2, 2); default 1.5e-5 I). The heading is
      θ = atan2(ẏ, ẋ), wrapped to (-π, π]: in the paper's file the heading is the direction of
      motion (the lateral part of each step relative to θ_k has std 0.0057 m = √(Qc/3) for
      Qc ≈ 1e-4), not an independent GP component, so the projected-velocity odometry
      [YIB Eq. 32] has zero lateral velocity. The default Qc gives a median travel of about
      0.17 km (10-90 %: 0.11-0.30 km over seeds), like the file's 172 m (Table I: 0.2 km);
      the file's local wiggle suggests Qc ≈ 1e-4, which would make the path ~0.45 km long.
    - Odometry row k (time of pose k+1): distance ‖p[k+1] - p[k]‖ and heading change
      θ[k+1] - θ[k] wrapped to [-π, π), plus N(0, σ²) noise, σ = ``odometry_sigmas``
      (default 0.023 m and 0.023 rad: the file's residual stds). Distances may come out negative.
    - Dead reckoning: :func:`integrate_odometry` from ground-truth pose 0, as in the file.
    - Landmarks: landmark j is placed by pose round((j + 1/2) n_poses / n_landmarks) (every ~5
      steps, as in the file, where landmark j is nearest to pose ~5j), at a uniform bearing and
      a uniform distance in ``landmark_distance`` = (2, 5) m from it, and at least 2 m from every
      pose (the file's landmarks are 2.0-5.0 m from its path).
    - Ranges: one at every pose (pose 0 too, as in the file), to a landmark drawn uniformly among
      the ``n_nearest`` = 10 nearest (in the file the observed landmark's rank among the nearest
      is uniform on 0..9), except that each landmark is the one ranged at its own anchor pose, so
      every landmark is seen. Ids run 1..n in order of first sighting, as in the file. Noise is
      N(0, σ²), σ = ``range_sigma``, default 0.1 m: the file's residual std is 0.10 m. (The paper's
      solver assumes 1 m; pass range_sigma=1.0 for data that match that model.) A reading whose
      noise would make it negative has its noise drawn again (landmarks are at least 2 m away, so
      this needs range_sigma of about 0.5 m or more to happen at all).

    Draws come from ``np.random.default_rng(seed)``, so a seed gives the same data set everywhere. A task that would
    need more than :data:`MAX_SYNTHETIC_BYTES` of memory (:func:`synthetic_bytes`: about 14 million steps) is refused
    before anything is drawn.
    """
    sigmas = check_generator_args(
        n_steps, n_landmarks, odometry_sigmas, range_sigma, landmark_distance, n_nearest, seed
    )
    n_steps, n_landmarks, n_nearest = int(n_steps), int(n_landmarks), int(n_nearest)
    if (need := synthetic_bytes(n_steps, n_landmarks)) > MAX_SYNTHETIC_BYTES:
        raise SteamError(
            f"n_steps={n_steps}, n_landmarks={n_landmarks}: the generated task would need about {need / 1e9:.3g} GB "
            f"of memory, past generate_synthetic's ceiling of {MAX_SYNTHETIC_BYTES / 1e9:.3g} GB "
            f"(MAX_SYNTHETIC_BYTES, about {(MAX_SYNTHETIC_BYTES - _BYTES_FIXED) // _BYTES_PER_POSE:,} steps)"
        )
    qc = _generator_qc(qc)
    rng = np.random.default_rng(seed)
    states = _sample_wnoa(rng, n_steps + 1, qc)
    times = np.arange(1, n_steps + 2, dtype=float)
    gt = np.column_stack([times, states[:, :2], np.arctan2(states[:, 3], states[:, 2])])
    odometry = _noisy_odometry(rng, gt, sigmas)
    landmarks, ranges = _landmarks_and_ranges(
        rng, gt, int(n_landmarks), landmark_distance, int(n_nearest), float(range_sigma)
    )
    source = f"generated(seed={seed}, n_steps={n_steps}, n_landmarks={n_landmarks})"
    dead_reckoning = integrate_odometry(gt[0], odometry)
    return RangeDataset("synthetic", gt, odometry, dead_reckoning, landmarks, ranges, source, time_origin="generated")
