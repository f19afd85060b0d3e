"""Trajectory files other tools read: TUM (time and pose per line) and KITTI (a 3 × 4 matrix per line).

- **TUM** (the TUM RGB-D benchmark's format, which evo reads): ``timestamp tx ty tz qx qy qz qw`` per
  line, ``#`` comments. A planar pose [x, y, θ] is written as (x, y, 0) and the rotation about z,
  q = (0, 0, sin θ/2, cos θ/2).
- **KITTI** (the odometry benchmark's): the first three rows of the 4 × 4 pose, row by row, 12 numbers
  per line, no time. A planar pose is [[cos θ, -sin θ, 0, x], [sin θ, cos θ, 0, y], [0, 0, 1, 0]], in the
  frame of the estimate (z up), not KITTI's camera frame (z forward).

**Poses in 3-D** (``group=``, a group of rigid motions in 3-D: :data:`~steam_ref.lie.SE3V`, :data:`~steam_ref.lie.SE3`):
the poses are the group's elements (n, group.size), as its states hold them; TUM's line is the translation and the
unit quaternion of R in the order the format names, ``qx qy qz qw`` (scalar last, written with qw >= 0), KITTI's
the 3 × 4 [R | t] row by row, R the body-to-world rotation and t the body's position (the estimate's own frames:
no camera frame is assumed). A quaternion is normalized as read (within 1e-3 of unit norm, as above); a KITTI R within
1e-6 of a rotation is taken as the nearest rotation (its polar factor), so the element is a pose of the group.

Numbers are written with 17 significant digits, so a file read back gives the same times and positions;
a heading comes back through its quaternion or rotation, equal modulo 2π to within rounding (1e-15), and so does a
rotation in 3-D (each entry of R). Without ``group`` the loaders accept planar poses only (z = 0, rotation about z,
to 1e-9; a TUM quaternion of unit norm, to 1e-3; a KITTI R orthonormal with det 1, to 1e-6); with it, any pose in
3-D within the last two. They refuse anything else with a :class:`~steam_ref.errors.DataError` naming the file and line; timestamps must increase
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
from scipy.spatial.transform import Rotation

from ..arguments import parse_decimal, real_array
from ..datasets.textfile import text_lines
from ..dead_reckoning import wrap_angle
from ..errors import DataError, ShapeError, SteamError
from ..files import replace_file
from ..lie import LieGroup
from ..lie.group import check_group
from ..lie.points import point_dim
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


def _in_3d(group: object) -> LieGroup:
    """``group`` if it is a group of rigid motions in 3-D; SteamError naming it otherwise."""
    group = check_group(group)
    if point_dim(group) != 3:
        raise SteamError(f"group must move points in 3-D (SE3V, SE3) for a 3-D trajectory file, got {group!r}")
    return group


def _matrices(group: LieGroup, poses: object) -> NDArray:
    """The 4 × 4 matrices (n, 4, 4) of ``poses`` (n, group.size), each checked as an element of ``group``."""
    a = real_array("poses", poses)
    if a.ndim != 2 or a.shape[1] != group.size or len(a) == 0:
        raise ShapeError(f"poses must be (n, {group.size}) elements of {group!r}, n >= 1; got shape {a.shape}")
    for k, row in enumerate(a):
        group.check(f"poses[{k}]", row)
    return group.matrix(a)


def _rotation_of(q: NDArray) -> NDArray:
    """R (n, 3, 3) of the quaternions q (n, 4) [qx, qy, qz, qw], each divided by its norm (SciPy's ``Rotation``)."""
    return Rotation.from_quat(q).as_matrix()


def _quaternion_of(R: NDArray) -> NDArray:
    """[qx, qy, qz, qw] (n, 4) of the rotations R (n, 3, 3) (SciPy's ``Rotation``), qw >= 0 (q and -q are one
    rotation)."""
    q = Rotation.from_matrix(R).as_quat()
    return np.where(q[:, 3:] < 0, -q, q)


def write_tum(path: str | os.PathLike, times: object, poses: object, *, group: LieGroup | None = None) -> None:
    """Write planar ``poses`` (n, 3) [x, y, θ] at ``times`` (n,) as a TUM trajectory file; with ``group`` (SE3V,
    SE3) poses in 3-D (n, group.size), each its translation and the quaternion qx qy qz qw of its rotation."""
    if group is not None:
        M = _matrices(_in_3d(group), poses)
        t = _times(times, len(M))
        rows = np.column_stack([t, M[:, :3, 3], _quaternion_of(M[:, :3, :3])])
        _write_rows(path, rows, "write_tum", header="timestamp tx ty tz qx qy qz qw")
        return
    poses = planar_poses("poses", poses)
    t = _times(times, len(poses))
    half = poses[:, 2] / 2
    zero = np.zeros(len(poses))
    rows = np.column_stack([t, poses[:, 0], poses[:, 1], zero, zero, zero, np.sin(half), np.cos(half)])
    _write_rows(path, rows, "write_tum", header="timestamp tx ty tz qx qy qz qw (planar: z = 0, rotation about z)")


def _write_rows(path: str | os.PathLike, rows: NDArray, what: str, header: str = "") -> None:
    """``rows`` written to ``path``, 17 significant digits a number, whole or not at all (:func:`replace_file`): a
    folder, a missing folder or a full disk is a SteamError starting with ``what`` and naming the path, and leaves
    what was there as it was."""
    replace_file(path, lambda name: np.savetxt(name, rows, fmt="%.17g", header=header), what)


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


def read_tum(path: str | os.PathLike, *, group: LieGroup | None = None) -> tuple[NDArray, NDArray]:
    """Times (n,) and planar poses (n, 3) [x, y, θ] of a TUM file; DataError for a pose out of the plane. With
    ``group`` (SE3V, SE3): the poses in 3-D as the group's elements (n, group.size), any rotation."""
    group = None if group is None else _in_3d(group)
    rows = _table(path, 8, "TUM")
    t, xyz, q = rows[:, 0], rows[:, 1:4], rows[:, 4:8]
    norm = np.linalg.norm(q, axis=1)
    bad = (np.abs(xyz[:, 2]) > PLANAR_TOLERANCE) | (np.abs(q[:, :2]).max(axis=1) > PLANAR_TOLERANCE * norm)
    bad &= group is None  # a pose in 3-D may leave the plane
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
    if group is not None:
        return t, group.from_matrix(_homogeneous(_rotation_of(q), xyz))
    theta = wrap_angle(2 * np.arctan2(q[:, 2], q[:, 3]))  # q and -q are one rotation: θ in [-π, π)
    return t, np.column_stack([xyz[:, :2], theta])


def _homogeneous(R: NDArray, t: NDArray) -> NDArray:
    """[[R, t], [0, 1]] (n, 4, 4)."""
    M = np.zeros((len(R), 4, 4))
    M[:, :3, :3], M[:, :3, 3], M[:, 3, 3] = R, t, 1.0
    return M


def write_kitti(path: str | os.PathLike, poses: object, *, group: LieGroup | None = None) -> None:
    """Write planar ``poses`` (n, 3) as a KITTI file: the 3 × 4 pose [R | t] row by row, no times; with ``group``
    (SE3V, SE3) poses in 3-D (n, group.size)."""
    if group is not None:
        M = _matrices(_in_3d(group), poses)
        _write_rows(path, M[:, :3, :].reshape(-1, 12), "write_kitti")
        return
    poses = planar_poses("poses", poses)
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    zero, one = np.zeros(len(poses)), np.ones(len(poses))
    rows = np.column_stack([c, -s, zero, poses[:, 0], s, c, zero, poses[:, 1], zero, zero, one, zero])
    _write_rows(path, rows, "write_kitti")


def read_kitti(path: str | os.PathLike, *, group: LieGroup | None = None) -> NDArray:
    """Planar poses (n, 3) of a KITTI file; DataError for a pose out of the plane or a matrix not a rotation. With
    ``group`` (SE3V, SE3): the poses in 3-D as the group's elements (n, group.size), R taken as its nearest
    rotation."""
    if group is not None:
        return _read_kitti_3d(path, _in_3d(group))
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


def _read_kitti_3d(path: str | os.PathLike, group: LieGroup) -> NDArray:
    """The poses in 3-D of a KITTI file: R within ROTATION_TOLERANCE of a rotation, replaced by its polar factor."""
    rows = _table(path, 12, "KITTI").reshape(-1, 3, 4)
    rot, t = rows[:, :, :3], rows[:, :, 3]
    not_rotation = np.max(np.abs(rot @ np.transpose(rot, (0, 2, 1)) - np.eye(3)), axis=(1, 2))
    not_rotation = np.maximum(not_rotation, np.abs(np.linalg.det(rot) - 1))
    if np.any(not_rotation > ROTATION_TOLERANCE):
        k = int(np.flatnonzero(not_rotation > ROTATION_TOLERANCE)[0])
        raise DataError(
            f"{path}, line {_line_of(path, k)}: R is not a rotation (abs of R Rᵀ - I or det R - 1 up to "
            f"{float(not_rotation[k]):.3g} > {ROTATION_TOLERANCE:g})"
        )
    u, _, vt = np.linalg.svd(rot)
    return group.from_matrix(_homogeneous(u @ vt, t))
