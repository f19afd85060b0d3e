"""Loader of GTSAM's planar text format (``load2D``): ``ODOMETRY`` and ``LANDMARK`` rows, e.g. Victoria Park.

The file ``victoria_park.txt`` in the gtsam wheel's ``Data/`` folder (the classic Victoria Park run:
6,968 odometry steps, 3,640 sightings of 151 trees, known data association) has two kinds of row,
one per line, in the order the robot met them:

    ODOMETRY i j dx dy dθ c11 c12 c13 c22 c23 c33   pose j = pose i ⊕ Pose2(dx, dy, dθ); covariance upper triangle
    LANDMARK i j x y v1 v2 v3                        landmark j seen from pose i at (x, y) in the robot frame; covariance [v1 v2; v2 v3]

How they are read, following GTSAM's ``load2D`` (a test checks bearing, range and sigmas against
``gtsam.load2D`` on the file):

- The odometry rows form one chain (row k starts where row k - 1 ended). Pose ids and landmark ids
  share one numbering in GTSAM's file, so the pose ids skip the landmarks' (0, 1, 2, 3, 4, 6, ...):
  pose k is the k-th pose of the chain, its id is kept in ``poses[:, 1]``, and its **time is k**
  (the file has no time stamps; the authors' script runs with dt = 1). The authors'
  ``new_victoria_park.txt`` is the same file renumbered: poses 0..6968 and landmarks 1..151 in the
  order of their first sighting; here the landmarks keep the file's ids (5, 9, 32, ...).
- A sighting becomes a bearing-range reading at the time of its pose: bearing = atan2(y, x),
  range = hypot(x, y), sigmas sqrt(v1 / 10) rad and sqrt(v1) m. GTSAM's comment: the x-y
  covariance "is not very good, so assume it describes the uncertainty at a range of 10m". GTSAM
  does this when abs(v1 - v3) < 1e-4 and silently uses sigmas 1, 1 otherwise; this loader refuses
  such a row, and one with v2 ≠ 0 (which GTSAM ignores), naming the line.
- The odometry covariance is kept as given (``odometry_covariance``); a set-up may use its own
  sigmas (Victoria Park's preset uses the script's, which equal the file's diagonal).

Ids are read as integers, never through a float (two ids 2^53 and 2^53 + 1 stay two): digits only
(``5.0``, ``5e0``, ``-5`` are refused), at most :data:`MAX_ID` = 2^53, since the data set keeps ids in
float64 columns, which hold every integer up to 2^53 exactly and would merge larger ones.

The file's lines are read by :func:`~steam_ref.datasets.textfile.text_lines` (a regular file, ASCII, its last
line ended by a newline). Errors: :class:`DataError` naming the file and the line (1-based) for a row that cannot be read,
an unknown row type, a pose id the odometry has not reached, an id used for both a pose and a
landmark, a sighting at range 0; any error of :class:`LandmarkDataset`'s checks is re-raised
prefixed with the file name.
"""

from __future__ import annotations

import math
import os
import re
from pathlib import Path

import numpy as np

from ..arguments import DECIMAL
from ..errors import DataError, SteamError
from .landmarks import LandmarkDataset
from .table import MAX_EXACT
from .textfile import text_lines

__all__ = ["load_gtsam_2d", "GTSAM_ISOTROPY_TOL", "MAX_ID"]

GTSAM_ISOTROPY_TOL = 1e-4  # load2D converts a sighting's covariance only when |v1 - v3| is below this
_NUMBER = DECIMAL  # the one rule for numbers written as text (steam_ref.arguments)
_FIELDS = {"ODOMETRY": 11, "LANDMARK": 7}  # numbers after the tag
_ID = re.compile(r"[0-9]+")  # an id: digits only (GTSAM reads a size_t)
MAX_ID = MAX_EXACT  # the largest id the data set's float64 tables hold exactly (with all below it)


def _numbers(path: Path, line_no: int, tag: str, fields: list[str]) -> tuple[int, int, list[float]]:
    """The two ids (exact integers) and the other numbers of a row."""
    if len(fields) != _FIELDS[tag]:
        raise DataError(
            f"{path} line {line_no}: a {tag} row has {_FIELDS[tag]} numbers after the tag, got {len(fields)}"
        )
    ids = []
    for c in (0, 1):  # read as integers, never through a float: 2^53 + 1 and 2^53 stay two ids
        if not _ID.fullmatch(fields[c]):
            raise DataError(
                f"{path} line {line_no}, field {c + 2}: id {fields[c]!r} is not a non-negative integer written in digits"
            )
        ids.append(int(fields[c]))
        if ids[-1] > MAX_ID:
            raise DataError(
                f"{path} line {line_no}, field {c + 2}: id {fields[c]} is above 2^53, the largest a data set's "
                f"float64 id columns hold exactly (it would be merged with its neighbours)"
            )
    out = []
    for c, f in enumerate(fields[2:], start=2):
        if not _NUMBER.fullmatch(f) or not math.isfinite(float(f)):
            raise DataError(f"{path} line {line_no}, field {c + 2}: {f!r} is not a finite decimal number")
        out.append(float(f))
    return ids[0], ids[1], out


def load_gtsam_2d(path: str | os.PathLike, name: str | None = None) -> LandmarkDataset:
    """A :class:`LandmarkDataset` from a GTSAM planar text file of ODOMETRY and LANDMARK rows (see the module)."""
    path = Path(path)
    lines = text_lines(path)
    pose_of: dict[int, int] = {}  # file id -> pose index
    landmark_line: dict[int, int] = {}  # landmark id -> line of its first sighting
    odometry, covariance, sightings = [], [], []
    lines_of: list[int] = []  # the line of each sighting
    last = None  # the pose id the odometry has reached
    for line_no, line in enumerate(lines, start=1):
        fields = line.split()
        if not fields:
            continue
        tag = fields[0]
        if tag not in _FIELDS:
            raise DataError(
                f"{path} line {line_no}: unknown row type {tag!r}; this loader reads ODOMETRY and LANDMARK rows (GTSAM's load2D format)"
            )
        i, j, v = _numbers(path, line_no, tag, fields[1:])
        if tag == "ODOMETRY":
            if last is None:
                pose_of[i], last = 0, i
            if i != last:
                raise DataError(
                    f"{path} line {line_no}: ODOMETRY from pose id {i}, but the odometry so far ends at pose id {last}: "
                    f"the rows must form one chain"
                )
            if j in pose_of or j in landmark_line:
                kind = "a pose" if j in pose_of else f"landmark (line {landmark_line[j]})"
                raise DataError(f"{path} line {line_no}: ODOMETRY to pose id {j}, which is already {kind}")
            pose_of[j], last = len(pose_of), j
            odometry.append([float(pose_of[j]), *v[0:3]])
            covariance.append(v[3:9])
        else:
            if i not in pose_of:
                raise DataError(
                    f"{path} line {line_no}: LANDMARK seen from pose id {i}, which the odometry has not reached "
                    f"(unknown pose id; poses so far: {len(pose_of)})"
                )
            if j in pose_of:
                raise DataError(f"{path} line {line_no}: LANDMARK id {j} is also a pose id")
            x, y, v1, v2, v3 = v
            if v2 != 0 or abs(v1 - v3) >= GTSAM_ISOTROPY_TOL or v1 <= 0:
                raise DataError(
                    f"{path} line {line_no}: LANDMARK covariance [{v1:g} {v2:g}; {v2:g} {v3:g}] is not v·I with v > 0; "
                    f"GTSAM's load2D then ignores it (sigmas 1, 1), so this loader refuses it"
                )
            r = math.hypot(x, y)
            if r == 0:
                raise DataError(f"{path} line {line_no}: LANDMARK {j} seen at range 0: its bearing is undefined")
            landmark_line.setdefault(j, line_no)
            sightings.append([float(pose_of[i]), float(j), math.atan2(y, x), r, math.sqrt(v1 / 10.0), math.sqrt(v1)])
            lines_of.append(line_no)
    if not odometry:
        raise DataError(f"{path}: no ODOMETRY rows: a data set needs at least two poses")
    ids = sorted(pose_of, key=lambda i: pose_of[i])
    poses = np.column_stack([np.arange(len(ids), dtype=float), np.array(ids, dtype=float)])
    marks = np.array(list(landmark_line), dtype=float)  # in the order of first sighting
    note = f"{path}; time = pose index (dt = 1), pose ids of the file in poses[:, 1]"
    try:
        return LandmarkDataset(
            name or path.stem,
            poses,
            np.array(odometry),
            np.array(covariance),
            bearing_ranges=np.array(sightings).reshape(-1, 6),
            landmark_ids=marks,
            source=note,
            time_origin="generated",
        )
    except SteamError as err:  # a sighting the data set's checks name by its row: say its line too
        text = re.sub(r"bearing_ranges\[(\d+), ", lambda m: f"line {lines_of[int(m[1])]}, {m[0]}", str(err))
        raise DataError(f"{path}: {text}") from None
