"""Planar poses [x, y, θ]: angle wrapping and dead reckoning, the one home of both.

Odometry row k of a CMU data set holds the distance travelled and the heading change from pose k
to pose k + 1. Dead reckoning composes it onto a pose the way GTSAM's ``Pose2.compose`` with
``Pose2(distance, 0, turn)`` does, which is how the paper's scripts predict each new pose: move
along the heading held *before* the turn, then turn. Odometry with a sideways part (GTSAM's text
files: a ``Pose2`` between consecutive poses, [dx, dy, dθ] in the frame of the first) composes as
``Pose2(dx, dy, dθ)``. Headings are not wrapped here, so a heading that is integrated over a long
run stays continuous.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .arguments import finite, number, real_array
from .errors import ShapeError

__all__ = ["wrap_angle", "compose", "integrate_odometry", "transform_from"]


def wrap_angle(a: ArrayLike) -> NDArray:
    """Angles mapped to [-π, π), up to rounding: an angle within an ulp below an odd multiple of -π maps to +π
    (a + π rounds onto a multiple of 2π), the same heading."""
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def compose(pose: ArrayLike, distance: float, turn: float, lateral: float = 0.0) -> NDArray:
    """pose ⊕ (distance, lateral, turn): [x + d cos θ - l sin θ, y + d sin θ + l cos θ, θ + Δθ], θ not wrapped."""
    pose = real_array("pose", pose)
    if pose.shape != (3,):
        raise ShapeError(f"pose must be (3,) x, y, heading; got shape {pose.shape}")
    x, y, th = finite("pose", pose)
    distance, turn, lateral = number("distance", distance), number("turn", turn), number("lateral", lateral)
    c, s = np.cos(th), np.sin(th)
    return np.array([x + (distance * c - lateral * s), y + (distance * s + lateral * c), th + turn])


def transform_from(pose: ArrayLike, point: ArrayLike) -> NDArray:
    """A point given in the frame of ``pose`` [x, y, θ], in the world frame (GTSAM's ``Pose2.transform_from``)."""
    pose, point = real_array("pose", pose), real_array("point", point)
    if pose.shape != (3,) or point.shape != (2,):
        raise ShapeError(f"pose must be (3,) and point (2,); got shapes {pose.shape} and {point.shape}")
    x, y, th = finite("pose", pose)
    px, py = finite("point", point)
    c, s = np.cos(th), np.sin(th)
    return np.array([x + (c * px - s * py), y + (s * px + c * py)])


def integrate_odometry(start: ArrayLike, odometry: ArrayLike) -> NDArray:
    """Dead reckoning from a start pose: (n + 1, 4) rows time, x, y, heading.

    start: (4,) time, x, y, heading of pose 0; odometry: (n, 3) time, distance, heading change, or
    (n, 4) time, dx, dy, heading change (a ``Pose2`` between; the 3-column form has dy = 0); a flat
    row is not taken for (1, 3). The vectorised form of applying :func:`compose` row by row (a test
    checks the two agree).
    """
    start, odometry = real_array("start", start), real_array("odometry", odometry)
    if start.shape != (4,):
        raise ShapeError(f"start must be (4,) time, x, y, heading; got shape {start.shape}")
    if odometry.ndim != 2 or odometry.shape[1] not in (3, 4):
        raise ShapeError(
            f"odometry must be (n, 3) time, distance, turn or (n, 4) time, dx, dy, turn; got shape {odometry.shape}"
        )
    finite("start", start), finite("odometry", odometry)
    forward, turn = odometry[:, 1], odometry[:, -1]
    lateral = odometry[:, 2] if odometry.shape[1] == 4 else np.zeros(len(odometry))
    heading = start[3] + np.concatenate([[0.0], np.cumsum(turn)])
    c, s = np.cos(heading[:-1]), np.sin(heading[:-1])
    steps = np.column_stack([forward * c - lateral * s, forward * s + lateral * c])
    xy = start[1:3] + np.concatenate([np.zeros((1, 2)), np.cumsum(steps, axis=0)])
    times = np.concatenate([[start[0]], odometry[:, 0]])
    return np.column_stack([times, xy, heading])
