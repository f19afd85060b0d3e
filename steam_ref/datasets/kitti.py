"""Loader of the KITTI GPS and IMU files gtsam ships (``Data/KittiGps_converted.txt``, ``Data/KittiEquivBiasedImu.txt``).

The two files (GTSAM's ``ImuKittiExampleGPS``; a drive of KITTI raw data [GLSU13], 470 s) are:

- ``KittiGps_converted.txt``: a header ``Time,X,Y,Z`` then 470 rows ``t,x,y,z``: GPS fixes (s; m, in a local
  east-north-up frame), about 1 Hz;
- ``KittiEquivBiasedImu.txt``: a header ``Time dt accelX accelY accelZ omegaX omegaY omegaZ`` then 46,968 rows at
  100 Hz: the IMU's specific force (m/s²) and angular rate (rad/s) in the body frame (x forward, y left, z up:
  accelZ ≈ 9.8 at rest), with the biases of a real IMU (its metadata file gives the gyro's white noise
  0.000175 rad/s/√Hz, 0.00175 rad/s at 100 Hz, and a bias random walk; the bias itself is not given).

:func:`load_kitti` reads them as :class:`~steam_ref.datasets.rigid.RigidReadings` on ``GroupState(group)``: a state at
the time of each fix kept, every fifth fix (the 5th, 10th, ...) held out for scoring, every gyro row an
angular-velocity reading (between states, read through the prior's interpolation). The accelerometer is not
read (it needs a bias and gravity in the state). What the data set lacks: ground truth (the fixes are the only
positions, so a run is scored at the held-out fixes, themselves noisy), and the gyro's bias. The sigmas are ours,
chosen before any run: position 0.3 m (GPS in a local frame), gyro 0.005 rad/s (the white noise at 100 Hz plus
room for an unmodelled bias of a few mrad/s; the rows' mean rates are below 1e-3 rad/s about x and y).

Each file is read by :func:`~steam_ref.datasets.textfile.text_lines` (a regular file, ASCII, its last line ended by
a newline: a file cut inside its last number is refused, not read short), and each row is checked:
:class:`~steam_ref.errors.DataError` naming the file and the line (1-based) for a row of the wrong number of fields,
a field that is not a decimal number, a non-finite number, or a time that does not increase.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..arguments import DECIMAL
from ..errors import DataError
from ..lie import GroupState, LieGroup
from ..lie.points import point_dim
from .rigid import RigidReadings
from .textfile import text_lines

__all__ = ["load_kitti", "GPS_FILE", "IMU_FILE", "KITTI_QC", "KITTI_SIGMAS", "HOLD_OUT_EVERY"]

GPS_FILE, IMU_FILE = "KittiGps_converted.txt", "KittiEquivBiasedImu.txt"
_PLAIN = re.compile(r"[0-9eE+\-., \t\n]*")  # what a file of decimal numbers holds (anything else: row by row)
HOLD_OUT_EVERY = 5  # the 5th, 10th, ... fix is held out
KITTI_QC = np.diag([1.0, 0.1, 0.1, 0.01, 0.01, 0.1])  # (m/s²)², (rad/s²)² per Hz: a car, forward; chosen a priori
KITTI_SIGMAS = {
    "position": 0.3,
    "gyro": 0.005,
    "first_pose": 1.0,  # the first state's prior: loose, about the first value (the fixes fix the rest)
    "first_twist": 1.0,
}


def _table(path: Path, header: str, separator: str | None, width: int) -> NDArray:
    """The rows of a text file after its header, each ``width`` decimal numbers, times increasing strictly."""
    lines = text_lines(path, ",")  # a regular file, ASCII, its last line ended (not cut short)
    if not lines or lines[0].split(separator) != header.split(separator):
        raise DataError(f"{path}, line 1: expected the header {header!r}, got {lines[0][:80] if lines else ''!r}")
    body = [line for line in lines[1:] if line.strip()]
    if _PLAIN.fullmatch("\n".join(body)):  # only digits, signs, points, exponents, separators: parse in one call
        try:
            table: NDArray | None = np.array([line.split(separator) for line in body], dtype=float)
        except ValueError:
            table = None
        if table is not None and table.ndim == 2 and table.shape[1] == width and len(table) >= 2:  # noqa: SIM102
            if np.all(np.isfinite(table)) and np.all(np.diff(table[:, 0]) > 0):
                return table
    rows: list[list[float]] = []  # something is wrong: find the first line that says what, row by row
    for no, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        fields = [f.strip() for f in line.split(separator)]
        if len(fields) != width:
            raise DataError(f"{path}, line {no}: expected {width} numbers, got {len(fields)}: {line[:80]!r}")
        bad = next((f for f in fields if not DECIMAL.fullmatch(f)), None)
        if bad is not None:
            raise DataError(f"{path}, line {no}: {bad[:40]!r} is not a decimal number")
        row = [float(f) for f in fields]
        if not all(math.isfinite(v) for v in row):
            raise DataError(f"{path}, line {no}: a number is not finite: {line[:80]!r}")
        if rows and not row[0] > rows[-1][0]:
            raise DataError(f"{path}, line {no}: time {row[0]!r} does not come after {rows[-1][0]!r}")
        rows.append(row)
    if len(rows) < 2:
        raise DataError(f"{path}: fewer than 2 rows of readings")
    return np.array(rows)


def _first_values(fixes: NDArray, group: LieGroup, derivatives: int) -> NDArray:
    """Each state's first value from the fixes alone: at the fix, heading along the central difference of the
    fixes around it (level, no roll), moving forward at the speed of that difference, turning at its heading's rate."""
    t, p = fixes[:, 0], fixes[:, 1:]
    v = np.gradient(p, t, axis=0)
    yaw = np.unwrap(np.arctan2(v[:, 1], v[:, 0]))
    rate = np.gradient(yaw, t)
    d = group.dim
    tangent = np.zeros((len(t), d))
    tangent[:, d - 1] = yaw  # a turn about z: the last tangent direction of a group of rigid motions in 3-D
    poses = group.exp(tangent)
    k = point_dim(group)
    twist = np.zeros((len(t), d))
    twist[:, 0] = np.linalg.norm(v, axis=1)
    twist[:, d - 1] = rate
    shift = np.zeros((len(t), d))
    shift[:, :k] = p
    at = group.compose(group.exp(shift), poses)  # (I, p)(R, 0) = (R, p)
    return np.concatenate([at, twist, np.zeros((len(t), d * (derivatives - 1)))], axis=1)


def load_kitti(folder: str | Path, *, group: LieGroup, derivatives: int = 1, name: str = "kitti") -> RigidReadings:
    """The two files in ``folder`` as timed readings of states on ``GroupState(group, derivatives)`` (a group of
    rigid motions in 3-D: the table's SE(3) priors' group), with their first values (module docstring)."""
    folder = Path(folder)
    kind = GroupState(group, derivatives)
    if point_dim(group) != 3:
        raise DataError(f"KITTI's fixes are points in 3-D; {group!r} moves points in {point_dim(group)}-D")
    gps = _table(folder / GPS_FILE, "Time,X,Y,Z", ",", 4)
    imu = _table(folder / IMU_FILE, "Time dt accelX accelY accelZ omegaX omegaY omegaZ", None, 8)
    held = np.arange(len(gps)) % HOLD_OUT_EVERY == HOLD_OUT_EVERY - 1
    kept = gps[~held]
    return RigidReadings(
        name,
        kind,
        kept[:, 0].copy(),
        dict(KITTI_SIGMAS),
        positions=kept,
        gyro=imu[:, [0, 5, 6, 7]],
        held_out=gps[held],
        first_state=_first_values(kept, group, derivatives)[0],
        initial_states=_first_values(kept, group, derivatives),
        source=f"{folder / GPS_FILE}, {folder / IMU_FILE}; the KITTI files of gtsam's Data/",  # "path, path; note"
        qc=KITTI_QC,
        lacks="ground truth (scored at held-out GPS fixes, themselves noisy) and the gyro's bias (not estimated)",
    )
