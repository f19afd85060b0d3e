"""Trajectory error as the field reports it: APE and RPE of planar poses, with their statistics.

- **APE** (absolute pose error) compares each estimated pose with the true one at the same time, after
  an optional alignment (:mod:`.align`): the translation error ‖p̂ᵢ - pᵢ‖ and the heading error
  abs(wrap(θ̂ᵢ - θᵢ)), the angle of the relative rotation Rᵢᵀ R̂ᵢ.
- **RPE** (relative pose error) compares motions: for a pair (i, j), the true motion Qᵢ⁻¹Qⱼ against the
  estimated one Pᵢ⁻¹Pⱼ, E = (Qᵢ⁻¹Qⱼ)⁻¹ (Pᵢ⁻¹Pⱼ). In SE(2), ‖t(E)‖ = ‖R(θ̂ᵢ)ᵀ(p̂ⱼ - p̂ᵢ) - R(θᵢ)ᵀ(pⱼ - pᵢ)‖
  and the angle of E is abs(wrap((θ̂ⱼ - θ̂ᵢ) - (θⱼ - θᵢ))). Pairs are Δ poses apart, or the first pose at
  least Δ metres further along the path; consecutive (i₀ = 0, i₁ = i₀ + Δ, ...) or ``all_pairs``.

These are the definitions of evo's ``metrics.APE`` and ``metrics.RPE`` (translation_part,
rotation_angle_rad) restricted to the plane, with pairs chosen the way evo's ``filters`` choose them;
``tests/test_evaluate.py`` checks the figures against evo's on the same TUM files to 1e-9. How the two
relate: unaligned, they are the same definitions; evo aligns in SE(3) / Sim(3) (Umeyama in space), which on
planar poses (z = 0, rotations about z) finds the rotation about z and the planar translation our SE(2) /
Sim(2) alignment finds, so ``ape(align='se2')`` equals evo's APE after ``align`` and ``ape(align='sim2')``
after ``align(correct_scale=True)``, unless the estimate is nearer a mirror image of the truth than a turned
copy: then evo turns it upside down, a half turn about an axis in the plane (:mod:`.align`). RPE pairs are
chosen on the truth here by default (evo's ``pairs_from_reference=True``); ``pairs_from='estimate'`` is evo's
default. Evo's yaw-only planar alignment of 3-D trajectories (its issue 746) is what ``se2`` is for planar ones.

:func:`group_ape` is the unaligned APE of poses on any group of rigid motions (SE(3)): the translation error and
the angle of the relative rotation, evo's ``APE`` with no alignment.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..arguments import finite, flag, floats, is_integer, number, real_array
from ..dead_reckoning import wrap_angle
from ..errors import ShapeError, SteamError
from ..lie import LieGroup
from ..lie.points import position
from .align import ALIGNMENTS, Alignment, align_planar

_BLOCK = 4096  # pairs a relative pose error computes at once

__all__ = ["Statistics", "PoseError", "ape", "group_ape", "rpe", "rpe_pairs", "planar_poses"]


def planar_poses(name: str, poses: object) -> NDArray:
    """``poses`` as a finite float (n, 3) [x, y, θ] array, n ≥ 1 (itself if it is one: read, never written);
    ShapeError / SteamError naming it."""
    out = floats(name, poses)  # never booleans, complex numbers or strings
    if out.ndim != 2 or out.shape[1] != 3 or len(out) == 0:
        raise ShapeError(f"{name} must be an (n, 3) array of poses [x, y, θ], n >= 1; got shape {out.shape}")
    if not np.all(np.isfinite(out)):
        row = int(np.flatnonzero(~np.isfinite(out).all(axis=1))[0])
        raise SteamError(f"{name}[{row}] is not finite: {out[row].tolist()}")
    return out


@dataclass(frozen=True)
class Statistics:
    """RMSE, mean, median and max of a list of errors (and how many)."""

    rmse: float
    mean: float
    median: float
    max: float
    n: int

    @classmethod
    def of(cls, errors: NDArray) -> Statistics:
        e = _errors(errors)
        top, u = _scaled(e)
        if top == 0.0:
            return cls(0.0, 0.0, 0.0, 0.0, e.size)
        return cls(_rmse(top, u), top * float(np.mean(u)), top * float(np.median(u)), float(np.max(e)), e.size)

    @staticmethod
    def rmse_of(errors: NDArray) -> float:
        """The RMSE of :meth:`of` alone, with its checks: no median, so no sorted copy of the errors."""
        return _rmse(*_scaled(_errors(errors)))

    def to_dict(self) -> dict:
        return {"rmse": self.rmse, "mean": self.mean, "median": self.median, "max": self.max, "n": self.n}


@dataclass(frozen=True)
class PoseError:
    """Translation [m] and heading [rad] errors of each pose (APE) or pair (RPE), and their statistics."""

    translation: NDArray  # (n,) [m]
    heading: NDArray  # (n,) [rad], in [0, π]
    alignment: Alignment  # what was applied to the estimate first (identity for RPE or no alignment)

    @property
    def translation_stats(self) -> Statistics:
        return Statistics.of(self.translation)

    @property
    def heading_stats(self) -> Statistics:
        return Statistics.of(self.heading)

    def to_dict(self) -> dict:
        return {"translation_m": self.translation_stats.to_dict(), "heading_rad": self.heading_stats.to_dict()}

    def __repr__(self) -> str:  # the statistics with their units; the errors of each pose are the fields
        t, h = self.translation_stats, self.heading_stats
        return (
            f"PoseError(n={t.n}, translation RMSE {t.rmse:.6g} m (mean {t.mean:.6g}, median {t.median:.6g}, max "
            f"{t.max:.6g}), heading RMSE {h.rmse:.6g} rad (max {h.max:.6g}), alignment={self.alignment!r})"
        )


def _same_shape(truth: object, estimate: object) -> tuple[NDArray, NDArray]:
    truth, estimate = planar_poses("truth", truth), planar_poses("estimate", estimate)
    if truth.shape != estimate.shape:
        raise ShapeError(
            f"truth and estimate must hold the same poses, got {len(truth)} and {len(estimate)}: "
            "sample the estimate at the truth's times first (evaluate.states_at)"
        )
    return truth, estimate


def ape(truth: object, estimate: object, *, align: str | None = None) -> PoseError:
    """Absolute pose error of ``estimate`` against ``truth`` (both (n, 3) [x, y, θ] at the same times),
    the estimate first aligned onto the truth by ``align``: None, 'se2' or 'sim2' (:func:`align_planar`)."""
    truth, estimate = _same_shape(truth, estimate)
    if align not in ALIGNMENTS:
        raise SteamError(f"align must be one of {ALIGNMENTS}, got {align!r}")
    transform = (
        Alignment.identity()
        if align is None
        else align_planar(estimate[:, :2], truth[:, :2], with_scale=align == "sim2")
    )
    moved = transform.apply(estimate)
    translation = np.hypot(moved[:, 0] - truth[:, 0], moved[:, 1] - truth[:, 1])
    heading = np.abs(wrap_angle(moved[:, 2] - truth[:, 2]))
    return PoseError(translation, heading, transform)


def group_ape(group: LieGroup, truth: object, estimate: object) -> PoseError:
    """Absolute pose error, unaligned, of the poses ``estimate`` against ``truth`` (both (n, group.size) elements of
    ``group``, a group of rigid motions: SE(2), SE(3)): ‖t̂ᵢ - tᵢ‖ and the angle of the relative rotation, that of
    Log(Tᵢ⁻¹ T̂ᵢ) (in [0, π]); on SE(2) what :func:`ape` gives."""
    t, e = real_array("truth", truth), real_array("estimate", estimate)
    if t.shape != e.shape or t.ndim != 2 or t.shape[1] != group.size or len(t) == 0:
        raise ShapeError(
            f"truth and estimate must be two (n, {group.size}) arrays of one shape (poses of {group!r}), "
            f"got {t.shape} and {e.shape}"
        )
    finite("truth", t)
    finite("estimate", e)
    translation = np.linalg.norm(position(group, e)[0] - position(group, t)[0], axis=-1)
    rotation = np.asarray(group.angle(group.log(group.between(t, e))), dtype=float)
    return PoseError(translation, rotation, Alignment.identity())


def rpe_pairs(
    poses: object, delta: float, *, unit: str = "poses", all_pairs: bool = False, relative_tolerance: float = 0.1
) -> list[tuple[int, int]]:
    """The index pairs (i, j) an RPE compares, chosen on ``poses`` (n, 3).

    ``unit='poses'``: j = i + Δ, Δ a positive integer; i = 0, Δ, 2Δ, ... or, ``all_pairs``, every i.
    ``unit='m'``: consecutive pairs end at the first pose at least Δ metres of path after the pair's
    start; with ``all_pairs``, every i is paired with the later pose whose path distance from it is
    nearest to Δ, taken when within ``relative_tolerance`` Δ of it (evo's ``rel_delta_tol``, 0.1).
    """
    return [(i, j) for i, j in _pairs(poses, delta, unit, all_pairs, relative_tolerance).tolist()]


def _pairs(poses: object, delta: float, unit: str, all_pairs: bool, relative_tolerance: float) -> NDArray:
    """The pairs of :func:`rpe_pairs` as an (m, 2) int array (a list of tuples took 120 bytes a pose)."""
    poses = planar_poses("poses", poses)
    n = len(poses)
    flag("all_pairs", all_pairs)
    if number("relative_tolerance", relative_tolerance) < 0:
        raise SteamError(f"relative_tolerance must be a number >= 0, got relative_tolerance={relative_tolerance!r}")
    if unit == "poses":
        if not is_integer(delta) or delta < 1:
            raise SteamError(f"an RPE over poses needs delta, a positive integer, got {delta!r}")
        starts = np.arange(0, n - int(delta), 1 if all_pairs else int(delta))  # each with i + Δ < n
        return np.column_stack([starts, starts + int(delta)])
    if unit != "m":
        raise SteamError(f"unit must be 'poses' or 'm', got {unit!r}")
    if isinstance(delta, bool) or not isinstance(delta, (int, float, np.integer, np.floating)) or not delta > 0:
        raise SteamError(f"an RPE over metres needs delta, a finite number > 0, got {delta!r}")
    if not np.isfinite(delta):
        raise SteamError(f"an RPE over metres needs delta, a finite number > 0, got {delta!r}")
    step = np.hypot(*np.diff(poses[:, :2], axis=0).T)
    if all_pairs:
        path = np.concatenate([[0.0], np.cumsum(step)])
        out = []
        for i in range(n - 1):
            ahead = path[i + 1 :] - path[i]
            k = int(np.argmin(np.abs(ahead - delta)))
            if abs(ahead[k] - delta) <= relative_tolerance * delta:
                out.append((i, i + 1 + k))
        return np.array(out, dtype=int).reshape(-1, 2)
    marks, travelled = [0], 0.0
    for i in range(1, n):
        travelled += float(step[i - 1])
        if travelled >= delta:
            marks.append(i)
            travelled = 0.0
    return np.array(list(itertools.pairwise(marks)), dtype=int).reshape(-1, 2)


def rpe(
    truth: object,
    estimate: object,
    delta: float = 1,
    *,
    unit: str = "poses",
    all_pairs: bool = False,
    pairs_from: str = "truth",
    relative_tolerance: float = 0.1,
) -> PoseError:
    """Relative pose error of ``estimate`` against ``truth`` (both (n, 3) at the same times) over pairs
    ``delta`` apart (:func:`rpe_pairs`, chosen on the truth's path, or the estimate's with
    ``pairs_from='estimate'``, evo's default). No pair ``delta`` apart is a SteamError naming ``delta``."""
    truth, estimate = _same_shape(truth, estimate)
    if pairs_from not in ("truth", "estimate"):
        raise SteamError(f"pairs_from must be 'truth' or 'estimate', got {pairs_from!r}")
    pairs = _pairs(truth if pairs_from == "truth" else estimate, delta, unit, all_pairs, relative_tolerance)
    if not len(pairs):
        raise SteamError(
            f"no pair of poses delta={delta!r} {unit} apart in a trajectory of {len(truth)} poses "
            f"(pairs chosen on the {pairs_from}'s path): give a smaller delta"
        )
    translation, heading = np.empty(len(pairs)), np.empty(len(pairs))
    for lo in range(0, len(pairs), _BLOCK):  # by blocks: a long run's temporaries stay a block's
        i, j, at = pairs[lo : lo + _BLOCK, 0], pairs[lo : lo + _BLOCK, 1], slice(lo, lo + _BLOCK)
        (x_true, y_true, turn_true), (x_est, y_est, turn_est) = _motion(truth, i, j), _motion(estimate, i, j)
        translation[at] = np.hypot(x_est - x_true, y_est - y_true)  # ‖t(E)‖: R(-Δθ_true) is an isometry
        heading[at] = np.abs(wrap_angle(turn_est - turn_true))
    return PoseError(translation, heading, Alignment.identity())


def _motion(p: NDArray, i: NDArray, j: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Pᵢ⁻¹Pⱼ of each pair: the step pⱼ - pᵢ seen from pose i (x, y), and the turn."""
    c, s = np.cos(p[i, 2]), np.sin(p[i, 2])
    dx, dy = p[j, 0] - p[i, 0], p[j, 1] - p[i, 1]
    return c * dx + s * dy, c * dy - s * dx, p[j, 2] - p[i, 2]


def _errors(errors: object) -> NDArray:
    """Errors to summarise: a finite 1-d float64 array of at least one (read, not copied, when it is one)."""
    e = floats("errors", errors)
    if e.ndim != 1:
        raise ShapeError(f"errors must be a 1-d array, one error per pose or pair, got shape {e.shape}")
    finite("errors", e)
    if e.size == 0:
        raise SteamError("no errors to summarise: the trajectory has no pose (or no pair) to compare")
    return e


def _rmse(top: float, u: NDArray) -> float:
    """√(mean e²) of the errors e = top · u (:func:`_scaled`): no overflow or underflow."""
    return 0.0 if top == 0.0 else top * float(np.sqrt(np.mean(u * u)))


def _scaled(e: NDArray) -> tuple[float, NDArray]:
    """The largest error and the errors divided by it (unless 0): e * e overflows past 1e154, underflows below 1e-162."""
    top = float(np.max(np.abs(e)))
    return top, e if top == 0.0 else e / top
