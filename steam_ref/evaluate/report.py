"""A continuous-time estimate evaluated where the truth is, and the figures a run's JSON line reports.

The estimate is a function of time (:class:`~steam_ref.trajectory.Trajectory`): at a time between two
states it is the GP interpolation x̄(t) = Λ(t) x̄ᵢ + Ψ(t) x̄ⱼ [YIB Eq. 18] (Λ, Ψ from Φ and Q
[YIB Eq. 16-17]), so it can be compared with ground truth at the truth's own time stamps, with no
nearest-time matching (:func:`states_at`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..arguments import flag, integer, real_array
from ..errors import ClockError, ShapeError, SteamError
from ..trajectory import Trajectory
from .align import alignment_defect
from .metrics import ape, planar_poses, rpe

__all__ = ["states_at", "trajectory_figures"]


def states_at(
    trajectory: Trajectory, times: object, *, covariance: bool = False, extrapolate: bool = False
) -> NDArray | tuple[NDArray, NDArray]:
    """The estimated state (n, d) at each of ``times`` (n,) [YIB Eq. 18], with its covariance (n, d, d)
    when asked (the interpolated covariance between states).

    ``times`` are on the trajectory's data clock, in seconds (``trajectory.times``: a data set's own stamps,
    so a truth's own time stamps query it directly), whatever clock its GP prior ran on.
    A time after the last state raises :class:`ClockError` unless ``extrapolate``: there the answer is the
    prior's prediction from the last state (:meth:`Trajectory.at`), not an estimate, and truth stamped on
    another clock would otherwise be compared with predictions alone. A time before the first state always
    raises :class:`ClockError` (pose indices against a trajectory stamped in seconds, say)."""
    if not isinstance(trajectory, Trajectory):
        raise SteamError(f"expected a steam_ref.trajectory.Trajectory, got {type(trajectory).__name__}")
    flag("extrapolate", extrapolate)
    t = real_array("times", times)
    if t.ndim != 1:
        raise ShapeError(f"times must be a 1-d array, one time per query, got shape {t.shape}")
    if trajectory.states:
        first, last = (float(trajectory.times[trajectory.states[i]]) for i in (0, -1))
        clock = f"the trajectory's times are in seconds; its prior's clock: {trajectory.clock.describe()}"
        if np.any(t < first):
            k = int(np.flatnonzero(t < first)[0])
            raise ClockError(
                f"times[{k}] = {float(t[k])!r} is before the first estimated state at t={first:g}: times on another "
                f"clock (a pose index, another origin) cannot be compared with this trajectory ({clock})"
            )
        if not extrapolate and np.any(t > last):
            k = int(np.flatnonzero(t > last)[0])
            raise ClockError(
                f"times[{k}] = {float(t[k])!r} is after the last estimated state at t={last:g}: there the trajectory is "
                f"the prior's prediction, not an estimate (pass extrapolate=True to have it), and times on another "
                f"clock cannot be compared with it ({clock})"
            )
    if not covariance:
        return np.array([trajectory.at(float(ti)) for ti in t]).reshape(len(t), trajectory.n)
    pairs = [trajectory.at(float(ti), covariance=True) for ti in t]
    means = np.array([m for m, _ in pairs]).reshape(len(t), trajectory.n)
    covs = np.array([c for _, c in pairs]).reshape(len(t), trajectory.n, trajectory.n)
    return means, covs


def trajectory_figures(truth: object, estimate: object, *, rpe_delta: int = 1) -> dict:
    """APE unaligned, SE(2)- and Sim(2)-aligned, and RPE over ``rpe_delta`` poses, of planar poses (n, 3)
    at the same times: {'ape': {...}, 'ape_se2': {...}, 'ape_sim2': {...}, 'rpe': {...}}, each with
    translation [m] and heading [rad] statistics (:class:`~steam_ref.evaluate.metrics.Statistics`).
    With one pose there is nothing to align, so 'ape_se2' and 'ape_sim2' are left out; with ``rpe_delta``
    poses or fewer there is no pair, so 'rpe' is left out. Where no rotation aligns the two (the truth
    does not move: :func:`~steam_ref.evaluate.align.alignment_defect`), 'ape_se2' and 'ape_sim2' are None
    and 'alignment_undefined' says why: the other figures stand."""
    truth, estimate = planar_poses("truth", truth), planar_poses("estimate", estimate)
    rpe_delta = integer("rpe_delta", rpe_delta, minimum=1)
    out: dict = {"ape": ape(truth, estimate).to_dict()}
    if len(truth) >= 2:
        defect = alignment_defect(estimate[:, :2], truth[:, :2])
        for align in ("se2", "sim2"):
            if defect is not None:
                out[f"ape_{align}"] = None
                continue
            err = ape(truth, estimate, align=align)
            out[f"ape_{align}"] = err.to_dict() | {"alignment": err.alignment.to_dict()}
            del err  # its errors by pose: not held through the next figure
        if defect is not None:
            out["alignment_undefined"] = defect
    if len(truth) > rpe_delta:
        out["rpe"] = rpe(truth, estimate, rpe_delta).to_dict() | {"delta_poses": rpe_delta}
    return out
