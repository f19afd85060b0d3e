"""Planar poses [x, y, θ]: angle wrapping and dead reckoning, the one home of both.

Odometry row k of a CMU data set holds the distance travelled and the heading change from pose k
to pose k + 1. Dead reckoning composes it onto a pose the way GTSAM's ``Pose2.compose`` with
``Pose2(distance, 0, turn)`` does, which is how the paper's scripts predict each new pose: move
along the heading held *before* the turn, then turn. Headings are not wrapped here, so a heading
that is integrated over a long run stays continuous.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .arguments import finite, number, real_array
from .errors import ShapeError

__all__ = ["wrap_angle", "compose", "integrate_odometry"]


def wrap_angle(a: ArrayLike) -> NDArray:
    """Angles mapped to [-π, π)."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def compose(pose: ArrayLike, distance: float, turn: float) -> NDArray:
    """pose ⊕ (distance, 0, turn): [x + d cos θ, y + d sin θ, θ + Δθ], θ not wrapped."""
    pose = real_array("pose", pose)
    if pose.shape != (3,):
        raise ShapeError(f"pose must be (3,) x, y, heading; got shape {pose.shape}")
    x, y, th = finite("pose", pose)
    distance, turn = number("distance", distance), number("turn", turn)
    return np.array([x + distance * np.cos(th), y + distance * np.sin(th), th + turn])


def integrate_odometry(start: ArrayLike, odometry: ArrayLike) -> NDArray:
    """Dead reckoning from a start pose: (n + 1, 4) rows time, x, y, heading.

    start: (4,) time, x, y, heading of pose 0; odometry: (n, 3) time, distance, heading change
    (n ≥ 0; a flat (3,) row is not taken for (1, 3)). The vectorised form of applying :func:`compose`
    row by row (a test checks the two agree).
    """
    start, odometry = real_array("start", start), real_array("odometry", odometry)
    if start.shape != (4,):
        raise ShapeError(f"start must be (4,) time, x, y, heading; got shape {start.shape}")
    if odometry.ndim != 2 or odometry.shape[1] != 3:
        raise ShapeError(f"odometry must be (n, 3) rows time, distance, heading change; got shape {odometry.shape}")
    finite("start", start), finite("odometry", odometry)
    heading = start[3] + np.concatenate([[0.0], np.cumsum(odometry[:, 2])])
    steps = odometry[:, 1, None] * np.column_stack([np.cos(heading[:-1]), np.sin(heading[:-1])])
    xy = start[1:3] + np.concatenate([np.zeros((1, 2)), np.cumsum(steps, axis=0)])
    times = np.concatenate([[start[0]], odometry[:, 0]])
    return np.column_stack([times, xy, heading])
