"""Trajectory files other tools read: TUM (time and pose per line) and KITTI (a 3 × 4 matrix per line).

- **TUM** (the TUM RGB-D benchmark's format, which evo reads): ``timestamp tx ty tz qx qy qz qw`` per
  line, ``#`` comments. A planar pose [x, y, θ] is written as (x, y, 0) and the rotation about z,
  q = (0, 0, sin θ/2, cos θ/2).
- **KITTI** (the odometry benchmark's): the first three rows of the 4 × 4 pose, row by row, 12 numbers
  per line, no time. A planar pose is [[cos θ, -sin θ, 0, x], [sin θ, cos θ, 0, y], [0, 0, 1, 0]], in the
  frame of the estimate (z up), not KITTI's camera frame (z forward).

Numbers are written with 17 significant digits, so a file read back gives the same times and positions;
a heading comes back through its quaternion or rotation, equal modulo 2π to within rounding (1e-15). The
loaders accept planar poses only (z = 0, rotation about z, to 1e-9; a TUM quaternion of unit norm, to 1e-3; a KITTI
R orthonormal with det 1, to 1e-6) and
refuse anything else with a :class:`~steam_ref.errors.DataError` naming the file and line; timestamps must increase
strictly as float64 reads them (16 significant digits: two stamps that differ only past them, nanoseconds since the
epoch say, are refused, the message showing both as written). A file's lines are read by
:func:`~steam_ref.datasets.textfile.text_lines`, the rule every data file of text follows: a regular file (a FIFO is
refused, not waited on), ASCII, its last line ended by a newline (a file cut inside its last number, TUM's qw, would
still read, its heading moved).
"""

from __future__ import annotations

import os
from decimal import Decimal
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..arguments import parse_decimal, real_array
from ..datasets.textfile import text_lines
from ..dead_reckoning import wrap_angle
from ..errors import DataError, ShapeError
from .metrics import planar_poses

__all__ = [
    "write_tum",
    "read_tum",
    "write_kitti",
    "read_kitti",
    "PLANAR_TOLERANCE",
    "UNIT_TOLERANCE",
    "ROTATION_TOLERANCE",
]

PLANAR_TOLERANCE = 1e-9  # |z|, |qx|, |qy| and the rotation's off-plane entries a planar file may have
# |‖q‖ - 1| a TUM quaternion may have: files of 4 decimals (the TUM RGB-D benchmark's own) are within 2e-4 of 1
UNIT_TOLERANCE = 1e-3
ROTATION_TOLERANCE = 1e-6  # abs of each entry of R Rᵀ - I, and of det R - 1, a KITTI rotation may have


def _times(times: object, n: int) -> NDArray:
    t = real_array("times", times)
    if t.shape != (n,):
        raise ShapeError(f"times must be (n,) with one time per pose ({n}), got shape {t.shape}")
    if not np.all(np.isfinite(t)):
        k = int(np.flatnonzero(~np.isfinite(t))[0])
        raise DataError(f"times must be finite, but times[{k}] = {float(t[k])!r}")
    if np.any(np.diff(t) <= 0):
        k = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
        raise DataError(
            f"times must increase strictly, but times[{k}] = {float(t[k])!r} follows times[{k - 1}] = {float(t[k - 1])!r}"
        )
    return t


def write_tum(path: str | os.PathLike, times: object, poses: object) -> None:
    """Write planar ``poses`` (n, 3) [x, y, θ] at ``times`` (n,) as a TUM trajectory file."""
    poses = planar_poses("poses", poses)
    t = _times(times, len(poses))
    half = poses[:, 2] / 2
    zero = np.zeros(len(poses))
    rows = np.column_stack([t, poses[:, 0], poses[:, 1], zero, zero, zero, np.sin(half), np.cos(half)])
    np.savetxt(path, rows, fmt="%.17g", header="timestamp tx ty tz qx qy qz qw (planar: z = 0, rotation about z)")


def _table(path: str | os.PathLike, columns: int, what: str) -> NDArray:
    """The numbers of a whitespace-separated text file, ``columns`` per line, ``#`` lines skipped."""
    rows = []
    for number, line in enumerate(text_lines(Path(path), ","), start=1):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        parts = line.split()
        if len(parts) != columns:
            raise DataError(f"{path}, line {number}: a {what} line has {columns} numbers, this one {len(parts)}")
        read = [parse_decimal(p) for p in parts]  # the one rule: float() would read "1_0" as 10, "１" as 1
        values = [float(v) for v in read if v is not None]
        if len(values) < len(parts):
            if any(p.lower().lstrip("+-") in ("inf", "infinity", "nan") for p in parts):
                raise DataError(f"{path}, line {number}: not finite: {line[:80]!r}")
            raise DataError(f"{path}, line {number}: not a number in {line[:80]!r}")
        if not all(np.isfinite(values)):  # 1e999 is written as a number and reads as inf
            raise DataError(f"{path}, line {number}: not finite: {line[:80]!r}")
        rows.append(values)
    if not rows:
        raise DataError(f"{path}: no poses in the file")
    return np.array(rows)


def _line_of(path: str | os.PathLike, row: int) -> int:
    """The 1-based line number of data row ``row`` (comments and blank lines skipped)."""
    data = [i for i, line in enumerate(text_lines(Path(path), ","), start=1) if line.strip()[:1] not in ("", "#")]
    return data[row]


def _not_increasing(path: str | os.PathLike, k: int, t: NDArray) -> str:
    """Why data row ``k``'s timestamp is refused: it does not increase on row k - 1's as written, or it does and
    float64 reads the two as one number (stamps in nanoseconds since the epoch, or seconds with 9 decimals: more
    digits than its 16), which the message says rather than showing two equal numbers."""
    line, previous = _line_of(path, k), _line_of(path, k - 1)
    lines = text_lines(Path(path), ",")
    written, written_before = lines[line - 1].split()[0], lines[previous - 1].split()[0]
    if Decimal(written) > Decimal(written_before):
        return (
            f"{path}, line {line}: timestamp {written} follows {written_before} (line {previous}), but the two are one "
            f"number in float64 ({float(t[k])!r}): they differ past its 16 significant digits; write the times with "
            "fewer digits (in seconds, from a nearer origin)"
        )
    return f"{path}, line {line}: timestamp {float(t[k])!r} does not increase (previous {float(t[k - 1])!r})"


def read_tum(path: str | os.PathLike) -> tuple[NDArray, NDArray]:
    """Times (n,) and planar poses (n, 3) [x, y, θ] of a TUM file; DataError for a pose out of the plane."""
    rows = _table(path, 8, "TUM")
    t, xyz, q = rows[:, 0], rows[:, 1:4], rows[:, 4:8]
    norm = np.linalg.norm(q, axis=1)
    bad = (np.abs(xyz[:, 2]) > PLANAR_TOLERANCE) | (np.abs(q[:, :2]).max(axis=1) > PLANAR_TOLERANCE * norm)
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise DataError(
            f"{path}, line {_line_of(path, k)}: not a planar pose (z = {float(xyz[k, 2])!r}, qx = {float(q[k, 0])!r}, qy = {float(q[k, 1])!r}, "
            f"|q| = {float(norm[k])!r}); steam_ref's trajectories are planar"
        )
    not_unit = np.abs(norm - 1) > UNIT_TOLERANCE  # (0, 0, 0, 2) is no rotation: not read as θ = 0
    if not_unit.any():
        k = int(np.flatnonzero(not_unit)[0])
        raise DataError(
            f"{path}, line {_line_of(path, k)}: the quaternion {q[k].tolist()} has |q| = {float(norm[k])!r}, not a "
            f"rotation (a unit quaternion, |q| within {UNIT_TOLERANCE:g} of 1)"
        )
    if np.any(np.diff(t) <= 0):
        k = int(np.flatnonzero(np.diff(t) <= 0)[0]) + 1
        raise DataError(_not_increasing(path, k, t))
    theta = wrap_angle(2 * np.arctan2(q[:, 2], q[:, 3]))  # q and -q are one rotation: θ in [-π, π)
    return t, np.column_stack([xyz[:, :2], theta])


def write_kitti(path: str | os.PathLike, poses: object) -> None:
    """Write planar ``poses`` (n, 3) as a KITTI file: the 3 × 4 pose [R | t] row by row, no times."""
    poses = planar_poses("poses", poses)
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    zero, one = np.zeros(len(poses)), np.ones(len(poses))
    rows = np.column_stack([c, -s, zero, poses[:, 0], s, c, zero, poses[:, 1], zero, zero, one, zero])
    np.savetxt(path, rows, fmt="%.17g")


def read_kitti(path: str | os.PathLike) -> NDArray:
    """Planar poses (n, 3) of a KITTI file; DataError for a pose out of the plane or a matrix not a rotation."""
    rows = _table(path, 12, "KITTI").reshape(-1, 3, 4)
    rot, t = rows[:, :, :3], rows[:, :, 3]
    off_plane = np.max(np.abs(np.concatenate([rot[:, 2, :2], rot[:, :2, 2], t[:, 2:]], axis=1)), axis=1)
    not_rotation = np.max(np.abs(rot @ np.transpose(rot, (0, 2, 1)) - np.eye(3)), axis=(1, 2))
    not_rotation = np.maximum(not_rotation, np.abs(np.linalg.det(rot) - 1))  # det -1: a mirror, orthogonal too
    bad = (
        (off_plane > PLANAR_TOLERANCE)
        | (np.abs(rot[:, 2, 2] - 1) > PLANAR_TOLERANCE)
        | (not_rotation > ROTATION_TOLERANCE)
    )
    if bad.any():
        k = int(np.flatnonzero(bad)[0])
        raise DataError(f"{path}, line {_line_of(path, k)}: not a planar pose [R | t] (R a rotation about z, t_z = 0)")
    return np.column_stack([t[:, :2], np.arctan2(rot[:, 1, 0], rot[:, 0, 0])])
