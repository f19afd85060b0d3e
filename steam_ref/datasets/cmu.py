"""Loaders of the CMU range-only files: a .mat (GT, DR, TL, TD, optional DRp) or the text release.

Conventions, checked on the reference files (see ``data/README.md`` for the figures):

- Dead reckoning, when recomputed (:func:`integrate_odometry`), moves along the heading *before*
  the turn: p[k+1] = p[k] + d_k [cos θ_k, sin θ_k], θ[k+1] = θ[k] + Δθ_k, from ground-truth row 0.
  That reproduces the paper-synthetic file's DRp to the last bit. Plaza's DRp is kept as given:
  its heading column equals GT's heading, its step lengths equal DR's distances, but its
  positions follow a drifting heading that is not in the files, so it cannot be recomputed.
- The original Plaza ranges (all 3,529) and the cleaned file's 3,363 contain two blocks of
  readings whose time stamps go back (by 64 s and 50 s in the original, 18 s and 50 s in the
  cleaned file); their ranges match ground truth at their own time stamps, not at their row
  position. The loaders keep the rows in file order, as
  the paper's scripts read them, and name the rows that go back in ``source``.
- A text table (``*_DR.txt``, ``*_TD.txt``) follows :data:`TEXT_TABLE_RULE` (its lines read by
  :func:`~steam_ref.datasets.textfile.text_lines`, the rule every text reader shares). Its last line must end
  with a newline: a file cut inside its last number keeps its field count and still parses
  (``5.29560000000000031e+01`` cut after ``5.2956`` reads as 5.2956), so the missing newline is the
  only sign of the cut. A file cut exactly at a line end loses whole rows and cannot be told from a
  shorter file; DR's rows are counted against GT's, and TD's against the .mat's copy when it has
  one (the Plaza files do), so only a TD with no copy in the .mat can lose rows unnoticed.

Errors: any failure to read a file, and any :class:`ShapeError` or :class:`DataError` of
:class:`RangeDataset`, is raised as :class:`DataError` prefixed with the file name. Rows are
0-based in ``array[row, column]`` messages; text files give "line N, column C", both 1-based.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..arguments import DECIMAL
from ..dead_reckoning import integrate_odometry
from ..errors import DataError, SteamError
from .matfile import read_mat
from .table import CMU_COLUMNS, MAX_EXACT, RangeDataset, frozen_table
from .textfile import text_lines

__all__ = ["load_cmu_mat", "load_cmu_text", "TEXT_TABLE_RULE"]

TEXT_TABLE_RULE = (
    "ASCII; every line ends with a newline, the last one too (a file cut inside its last number would "
    "otherwise load that number cut short); fields separated by spaces or tabs; each a finite plain "
    "decimal number; the same number of fields on every non-blank line"
)


def _order_note(ranges: NDArray) -> str:
    """A note naming the range rows that go back in time (kept in file order), or ''."""
    back = np.flatnonzero(np.diff(ranges[:, 0]) < 0) + 1 if len(ranges) else np.zeros(0, int)
    if not back.size:
        return ""
    rows = ", ".join(str(int(k)) for k in back[:5]) + (", ..." if back.size > 5 else "")
    return f"TD kept in file order: row(s) {rows} go back in time"


def _assemble(name: str, where: str, tables: dict[str, NDArray]) -> RangeDataset:
    """RangeDataset from CMU tables (DRp may be absent); any error is re-raised naming ``where``."""
    notes = []
    try:
        gt = frozen_table("GT", tables["GT"], CMU_COLUMNS["ground_truth"][1])
        tl = frozen_table("TL", tables["TL"], CMU_COLUMNS["landmarks"][1])
        dr = frozen_table("DR", tables["DR"], CMU_COLUMNS["odometry"][1])
        drp = tables.get("DRp")
        if drp is not None:
            drp = frozen_table("DRp", drp, CMU_COLUMNS["dead_reckoning"][1])
            if drp.shape[0] != gt.shape[0]:
                raise DataError(
                    f"DRp has {drp.shape[0]} rows but GT has {gt.shape[0]}: expected one per pose "
                    "(a file without DRp has it recomputed from DR)"
                )
        else:
            notes.append("DRp recomputed from DR (the file has none)")
            drp = integrate_odometry(gt[0], dr)
        td = frozen_table("TD", tables["TD"], CMU_COLUMNS["ranges"][1])
        note = _order_note(td)
        notes += [note] if note else []
        source = "; ".join([where] + notes)
        return RangeDataset(name, gt, dr, drp, tl, td, source, time_origin="file")
    except SteamError as err:
        raise DataError(f"{where}: {err}") from None


def _mat_table(content: dict[str, NDArray], key: str, path: Path) -> NDArray:
    if key not in content:
        raise DataError(f"{path}: no array {key!r} (it holds {sorted(content) or 'nothing'})")
    value = content[key]
    if not isinstance(value, np.ndarray) or value.dtype.kind not in "iuf":  # a logical matrix is not 0s and 1s
        got = f"an array of {value.dtype}" if isinstance(value, np.ndarray) else f"a {type(value).__name__}"
        raise DataError(f"{path}: {key} is not a numeric matrix (got {got})")
    if value.dtype.kind in "iu":  # an integer beyond 2^53 would become another integer as float64, in silence
        beyond = np.argwhere(np.abs(value.astype(object)) > MAX_EXACT) if value.size else np.zeros((0, 2), int)
        if len(beyond):
            at = tuple(int(i) for i in beyond[0])
            where = ", ".join(map(str, at))
            raise DataError(
                f"{path}: {key}[{where}] = {value[at]} is an integer float64 cannot hold (above 2^53); "
                f"it would be read as another number"
            )
    return value.astype(float)


def load_cmu_mat(path: str | os.PathLike, name: str | None = None) -> RangeDataset:
    """A CMU-layout .mat (GT, DR, TL, TD, optional DRp), e.g. ``Syn_theta_Plaza.mat``.

    DRp is recomputed with :func:`integrate_odometry` when the file lacks it (``source`` says
    so); a DRp whose row count differs from GT's is refused, not replaced. Other arrays (``usefulRangeInd``, ``addedK``) are
    ignored. Range rows keep the file's order (rows going back in time are noted in ``source``).
    """
    path = Path(path)
    content = read_mat(path)
    tables = {key: _mat_table(content, key, path) for key in ("GT", "DR", "TL", "TD")}
    if "DRp" in content:
        tables["DRp"] = _mat_table(content, "DRp", path)
    return _assemble(name or path.stem, str(path), tables)


_NUMBER = DECIMAL  # the one rule for numbers written as text (steam_ref.arguments)
_BLANKS = re.compile(r"[ \t]+")


def _read_text_table(path: Path, columns: tuple[str, ...]) -> NDArray:
    """(n, len(columns)) numbers of a text table; DataError naming the file, line and column.

    The rule (:data:`TEXT_TABLE_RULE`): ASCII; every line ends with a newline (``\\n`` or
    ``\\r\\n``), the last one too; fields are separated by spaces or tabs; each field is a plain
    decimal number (no nan, inf, hex, ``_`` or non-ASCII digits) that is finite; every non-blank
    line has exactly ``len(columns)`` fields; blank lines are skipped.
    """
    lines = text_lines(path)
    rows = []
    for line_no, body in enumerate(lines, start=1):
        fields = [f for f in _BLANKS.split(body) if f]
        if not fields:
            continue
        if len(fields) != len(columns):
            raise DataError(
                f"{path} line {line_no}: expected {len(columns)} numbers ({', '.join(columns)}), "
                f"got {len(fields)}: {body.strip()!r}"
            )
        for c, f in enumerate(fields):
            if not _NUMBER.fullmatch(f) or not np.isfinite(float(f)):
                raise DataError(
                    f"{path} line {line_no}, column {c + 1} ({columns[c]}): {f!r} is not a finite decimal number"
                )
        rows.append([float(f) for f in fields])
    if not rows:
        raise DataError(f"{path}: the file holds no rows")
    return np.array(rows)


def _text_prefix(folder: Path) -> str:
    prefixes = sorted(p.name[: -len("_DR.txt")] for p in folder.glob("*_DR.txt"))
    if len(prefixes) != 1:
        found = (
            f"several ({', '.join(prefixes)}): give the one to read, e.g. {folder / (prefixes[0] + '_DR.txt')} "
            f"(prefix= in Python)"
            if prefixes
            else "none"
        )
        raise DataError(f"{folder}: expected one *_DR.txt file to pick the data set, found {found}")
    return prefixes[0]


def _check_same(text: NDArray, content: dict[str, NDArray], key: str, txt: Path, mat: Path) -> None:
    """The .mat's copy of DR or TD, when it has one, must equal the text file exactly."""
    if key not in content:
        return
    other = _mat_table(content, key, mat)
    if other.shape != text.shape:
        raise DataError(f"{mat}: {key} has shape {other.shape} but {txt} holds {text.shape}")
    diff = np.flatnonzero(np.any(other != text, axis=1))
    if diff.size:
        k = int(diff[0])
        raise DataError(f"{mat}: {key} row {k} differs from {txt} line {k + 1}")


def load_cmu_text(
    folder: str | os.PathLike,
    prefix: str | None = None,
    *,
    name: str | None = None,
) -> RangeDataset:
    """The original CMU text release: ``<prefix>_DR.txt``, ``<prefix>_TD.txt`` and ``<prefix>_.mat``.

    As shipped in the gtsam wheel's ``Data/`` folder (Plaza1, Plaza2). The text files give DR
    (odometry, no header, tab separated) and TD (all ranges); the .mat gives GT and TL, and usually
    also DRp, DR and TD: when it holds DR or TD they must equal the text files, else DataError.
    ``folder`` may also be the ``*_DR.txt`` file itself. In Plaza1, GT row 0 (t = 3856.857 s) has no
    odometry row; DR row k carries GT row k+1's time stamp, so it ends at pose k + 1.
    """
    folder = Path(folder)
    if folder.is_file() and folder.name.endswith("_DR.txt"):
        folder, prefix = folder.parent, folder.name[: -len("_DR.txt")]
    if not folder.is_dir():
        raise DataError(f"{folder}: {'not a folder (nor a *_DR.txt file)' if folder.exists() else 'no such folder'}")
    prefix = prefix or _text_prefix(folder)
    dr_path, td_path = folder / f"{prefix}_DR.txt", folder / f"{prefix}_TD.txt"
    mats = [p for p in (folder / f"{prefix}_.mat", folder / f"{prefix}.mat") if p.is_file()]
    for path in (dr_path, td_path):
        if not path.is_file():
            raise DataError(f"{path}: {'not a file' if path.exists() else 'no such file'} (needed with {dr_path.name})")
    if not mats:
        raise DataError(f"{folder}: no {prefix}_.mat holding GT and TL next to {dr_path.name}")
    content = read_mat(mats[0])
    dr = _read_text_table(dr_path, CMU_COLUMNS["odometry"][1])
    td = _read_text_table(td_path, CMU_COLUMNS["ranges"][1])
    _check_same(dr, content, "DR", dr_path, mats[0])
    _check_same(td, content, "TD", td_path, mats[0])
    tables = {"GT": _mat_table(content, "GT", mats[0]), "TL": _mat_table(content, "TL", mats[0])}
    tables.update(DR=dr, TD=td)
    if "DRp" in content:
        tables["DRp"] = _mat_table(content, "DRp", mats[0])
    where = f"{dr_path}, {td_path}, {mats[0]}"
    return _assemble(name or prefix, where, tables)
