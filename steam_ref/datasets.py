"""Range-only SLAM data sets: one dataclass, the CMU loaders, the synthetic generator.  [YIB Sec. IV]

Every source ends up as a :class:`RangeDataset` in the CMU range-only layout (one row per record):

    ground_truth    GT   (n_poses, 4)      time, x, y, heading
    odometry        DR   (n_poses - 1, 3)  time, distance travelled, heading change
    dead_reckoning  DRp  (n_poses, 4)      time, x, y, heading
    landmarks       TL   (n_landmarks, 3)  id, x, y
    ranges          TD   (n_ranges, 4)     time, sender id, landmark id, range

Conventions, checked on the reference files (see ``data/README.md`` for the figures):

- Odometry row k ends at pose k + 1: its time stamp equals that of ground-truth row k + 1, and it
  holds the distance travelled and the heading change from pose k to pose k + 1. Both CMU .mat
  files (paper-synthetic and Plaza, cleaned or original) follow this exactly; a file that does
  not is rejected with a :class:`DataError`, never re-aligned.
- Which pose a range reading belongs to is the front end's rule, not the data set's
  (:func:`steam_ref.readings.attach_ranges`).
- Dead reckoning, when recomputed (:func:`integrate_odometry`), moves along the heading *before*
  the turn: p[k+1] = p[k] + d_k [cos θ_k, sin θ_k], θ[k+1] = θ[k] + Δθ_k, from ground-truth row 0.
  That reproduces the paper-synthetic file's DRp to the last bit. Plaza's DRp is kept as given:
  its heading column equals GT's heading, its step lengths equal DR's distances, but its
  positions follow a drifting heading that is not in the files, so it cannot be recomputed.
- The original Plaza ranges (all 3,529) and the cleaned file's 3,363 contain two blocks of
  readings whose time stamps go back by about 64 s and 50 s (their ranges match ground truth at
  their own time stamps, not at their row position). The loaders keep the rows in file order, as
  the paper's scripts read them, and name the rows that go back in ``source``.

Errors: a table of the wrong shape given to :class:`RangeDataset` raises :class:`ShapeError`;
bad content (NaN, pose times not increasing, unknown landmark ids) raises :class:`DataError`; the
loaders re-raise either as :class:`DataError` prefixed with the file name. Rows are 0-based in
``array[row, column]`` messages and 1-based as "line N" for text files.
"""

from __future__ import annotations

import importlib.util
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.io
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from .errors import DataError, ShapeError, SteamError
from .gp.prior import check_qc, process_noise, transition
from .pose2 import integrate_odometry, wrap_angle

__all__ = [
    "RangeDataset",
    "load_cmu_mat",
    "load_cmu_text",
    "gtsam_data_dir",
    "default_data_dirs",
    "load_dataset",
    "generate_synthetic",
    "DATA_DIR_ENV",
]

DATA_DIR_ENV = "STEAM_REF_DATA_DIR"
_TIME_TOL = 1e-6  # [s] odometry row k and pose k + 1 must agree to this
_COLUMNS = {  # field -> (CMU array name, column names)
    "ground_truth": ("GT", ("time", "x", "y", "heading")),
    "odometry": ("DR", ("time", "distance", "heading change")),
    "dead_reckoning": ("DRp", ("time", "x", "y", "heading")),
    "landmarks": ("TL", ("id", "x", "y")),
    "ranges": ("TD", ("time", "sender id", "landmark id", "range")),
}
_FILES = {"paper-synthetic": "Syn_theta_Plaza.mat", "plaza": "Plaza1_thrown_away_some_range.mat"}


def _num(value: float) -> str:
    return repr(float(value))


# --------------------------------------------------------------------------------------------
# The data set
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class RangeDataset:
    """A 2-D range-only SLAM data set in the CMU layout; arrays are read-only float64 copies.

    Checked on construction: table shapes (ShapeError); finite values, strictly increasing pose
    times, odometry row k stamped with the time of pose k + 1 (to 1 µs), one dead-reckoning row
    per pose, integer and unique landmark ids, integer sender ids,
    and every ranged landmark id present in ``landmarks`` (DataError). Dead-reckoning times are
    not compared with pose times: Plaza's DRp row 0 is stamped 0.0226 s after GT row 0.
    """

    name: str  # short label, e.g. "plaza"
    ground_truth: NDArray = field(repr=False)  # (n_poses, 4): time [s], x [m], y [m], heading [rad]
    odometry: NDArray = field(repr=False)  # (n_poses - 1, 3): time, distance [m], heading change [rad]
    dead_reckoning: NDArray = field(repr=False)  # (n_poses, 4): time, x, y, heading
    landmarks: NDArray = field(repr=False)  # (n_landmarks, 3): id, x, y
    ranges: NDArray = field(repr=False)  # (n_ranges, 4): time, sender id, landmark id, range [m]
    source: str = ""  # a path, or "generated(seed=...)", plus notes on any rework

    def __post_init__(self) -> None:
        for name, (_, columns) in _COLUMNS.items():
            object.__setattr__(self, name, _frozen_table(name, getattr(self, name), columns))
        self._check_times()
        self._check_ids()

    def __repr__(self) -> str:
        return (
            f"RangeDataset(name={self.name!r}, n_poses={self.n_poses}, n_landmarks={self.n_landmarks}, "
            f"n_ranges={self.n_ranges}, source={self.source!r})"
        )

    @property
    def n_poses(self) -> int:
        return self.ground_truth.shape[0]

    @property
    def n_landmarks(self) -> int:
        return self.landmarks.shape[0]

    @property
    def n_ranges(self) -> int:
        return self.ranges.shape[0]

    @property
    def landmark_ids(self) -> NDArray:
        """(n_landmarks,) int ids, in the row order of ``landmarks`` (not necessarily sorted)."""
        return self.landmarks[:, 0].astype(int)

    @property
    def times(self) -> NDArray:
        """(n_poses,) pose times, a read-only view of ``ground_truth[:, 0]``."""
        return self.ground_truth[:, 0]

    def landmark_rows(self, ids: ArrayLike) -> NDArray:
        """(n,) row of ``landmarks`` holding each id; DataError naming the first unknown id."""
        ids = np.asarray(ids, dtype=float).ravel()
        rows, missing = _rows_of(self.landmarks[:, 0], ids)
        if missing is not None:
            raise DataError(
                f"landmark id {ids[missing]:g} (entry {missing}) is not in landmarks; "
                f"known ids: {_ids_text(self.landmarks[:, 0])}"
            )
        return rows

    def ranges_going_back(self) -> NDArray:
        """(k,) rows of ``ranges`` whose time is earlier than the row before's (kept in file order)."""
        return np.flatnonzero(np.diff(self.ranges[:, 0]) < 0) + 1

    def to_cmu_arrays(self) -> dict[str, NDArray]:
        """Writable copies under the CMU names GT, DR, DRp, TL, TD (for ``scipy.io.savemat``)."""
        return {cmu: np.array(getattr(self, name)) for name, (cmu, _) in _COLUMNS.items()}

    def _check_times(self) -> None:
        t, n = self.times, self.n_poses
        if n == 0:
            raise DataError("ground_truth has no rows: a data set needs at least one pose")
        bad = np.flatnonzero(np.diff(t) <= 0)
        if bad.size:
            k = int(bad[0]) + 1
            raise DataError(
                f"pose times must increase strictly: ground_truth row {k} has t={_num(t[k])} "
                f"after t={_num(t[k - 1])} at row {k - 1}"
            )
        for name, rows in (("odometry", n - 1), ("dead_reckoning", n)):
            if getattr(self, name).shape[0] != rows:
                raise DataError(
                    f"{name} has {getattr(self, name).shape[0]} rows but ground_truth has {n} poses: "
                    f"expected {rows}"
                )
        off = np.flatnonzero(np.abs(self.odometry[:, 0] - t[1:]) > _TIME_TOL)
        if off.size:
            k = int(off[0])
            raise DataError(
                f"odometry row {k} has t={_num(self.odometry[k, 0])} but pose {k + 1} has "
                f"t={_num(t[k + 1])}: odometry row k must end at pose k+1"
            )

    def _check_ids(self) -> None:
        for name, column in (("landmarks", 0), ("ranges", 1), ("ranges", 2)):
            values = getattr(self, name)[:, column]
            bad = np.flatnonzero(values != np.round(values))
            if bad.size:
                k = int(bad[0])
                label = _COLUMNS[name][1][column]
                raise DataError(f"{name}[{k}, {column}] ({label}) = {_num(values[k])} is not an integer")
        ids = self.landmarks[:, 0]
        order = np.argsort(ids, kind="stable")
        same = np.flatnonzero(np.diff(ids[order]) == 0)
        if same.size:
            r1, r2 = int(order[same[0]]), int(order[same[0] + 1])
            raise DataError(f"landmark id {ids[r1]:g} appears twice, in landmarks rows {r1} and {r2}")
        missing = _rows_of(ids, self.ranges[:, 2])[1]
        if missing is not None:
            raise DataError(
                f"ranges row {missing} (t={_num(self.ranges[missing, 0])}) names landmark id "
                f"{self.ranges[missing, 2]:g}, which is not in landmarks; known ids: {_ids_text(ids)}"
            )


def _rows_of(known: NDArray, ids: NDArray) -> tuple[NDArray, int | None]:
    """Row of ``known`` holding each of ``ids``, and the index of the first id not there (or None)."""
    order = np.argsort(known, kind="stable")
    pos = np.minimum(np.searchsorted(known[order], ids), max(len(known) - 1, 0))
    found = known[order][pos] == ids if len(known) else np.zeros(len(ids), bool)
    missing = np.flatnonzero(~found)
    return order[pos] if len(known) else pos, (int(missing[0]) if missing.size else None)


def _ids_text(ids: NDArray) -> str:
    ids = np.sort(ids)
    if len(ids) <= 12:
        return "[" + ", ".join(f"{i:g}" for i in ids) + "]"
    return f"{len(ids)} ids from {ids[0]:g} to {ids[-1]:g}"


def _frozen_table(name: str, value: ArrayLike, columns: tuple[str, ...]) -> NDArray:
    """A read-only float64 copy of one table, checked for shape (ShapeError) and finiteness (DataError)."""
    try:
        table = np.array(value, dtype=float)
    except (TypeError, ValueError) as err:
        raise ShapeError(f"{name} must be a numeric array, got {type(value).__name__}: {err}") from None
    if table.size == 0:
        table = table.reshape(0, len(columns))
    if table.ndim != 2 or table.shape[1] != len(columns):
        raise ShapeError(
            f"{name} must have shape (n, {len(columns)}) with columns {', '.join(columns)}; "
            f"got shape {table.shape}"
        )
    bad = np.argwhere(~np.isfinite(table))
    if bad.size:
        r, c = (int(i) for i in bad[0])
        raise DataError(f"{name}[{r}, {c}] ({columns[c]}) is {table[r, c]}: every value must be finite")
    table.setflags(write=False)
    return table


# --------------------------------------------------------------------------------------------
# Loaders
# --------------------------------------------------------------------------------------------


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
        gt = _frozen_table("GT", tables["GT"], _COLUMNS["ground_truth"][1])
        tl = _frozen_table("TL", tables["TL"], _COLUMNS["landmarks"][1])
        dr = _frozen_table("DR", tables["DR"], _COLUMNS["odometry"][1])
        drp = tables.get("DRp")
        if drp is None or np.shape(drp)[0] != gt.shape[0]:
            got = "no DRp" if drp is None else f"DRp has {np.shape(drp)[0]} rows, GT {gt.shape[0]}"
            notes.append(f"DRp recomputed from DR ({got})")
            drp = integrate_odometry(gt[0], dr)
        td = _frozen_table("TD", tables["TD"], _COLUMNS["ranges"][1])
        note = _order_note(td)
        notes += [note] if note else []
        source = "; ".join([where] + notes)
        return RangeDataset(name, gt, dr, drp, tl, td, source)
    except SteamError as err:
        raise DataError(f"{where}: {err}") from None


def _read_mat(path: Path) -> dict[str, NDArray]:
    """The arrays of a MATLAB v5 file; any failure (missing, truncated, corrupt) → DataError."""
    if not path.is_file():
        raise DataError(f"{path}: no such file")
    try:
        content = scipy.io.loadmat(path)
    except Exception as err:  # scipy raises ValueError, OSError, TypeError, zlib errors...
        reason = f"{type(err).__name__}: {err}"
        raise DataError(f"{path}: cannot read it as a MATLAB .mat file ({reason})") from None
    return {k: v for k, v in content.items() if not k.startswith("__")}


def _mat_table(content: dict[str, NDArray], key: str, path: Path, required: bool = True) -> NDArray | None:
    if key not in content:
        if not required:
            return None
        raise DataError(f"{path}: no array {key!r} (it holds {sorted(content) or 'nothing'})")
    value = content[key]
    if not isinstance(value, np.ndarray) or value.dtype.kind not in "biuf":
        raise DataError(f"{path}: {key} is not a numeric matrix (got {getattr(value, 'dtype', type(value))})")
    return value.astype(float)


def load_cmu_mat(path: str | os.PathLike, name: str | None = None) -> RangeDataset:
    """A CMU-layout .mat (GT, DR, TL, TD, optional DRp), e.g. ``Syn_theta_Plaza.mat``.

    DRp is recomputed with :func:`integrate_odometry` when the file lacks it or its row count
    differs from GT's (``source`` says so). Other arrays (``usefulRangeInd``, ``addedK``) are
    ignored. Range rows keep the file's order (rows going back in time are noted in ``source``).
    """
    path = Path(path)
    content = _read_mat(path)
    tables = {key: _mat_table(content, key, path) for key in ("GT", "DR", "TL", "TD")}
    drp = _mat_table(content, "DRp", path, required=False)
    if drp is not None:
        tables["DRp"] = drp
    return _assemble(name or path.stem, str(path), tables)


def _read_text_table(path: Path, columns: tuple[str, ...]) -> NDArray:
    """(n, len(columns)) numbers of a whitespace-separated text file; DataError naming file and line."""
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as err:
        raise DataError(f"{path}: cannot read it as text ({type(err).__name__}: {err})") from None
    rows = []
    for line_no, line in enumerate(text.splitlines(), start=1):
        fields = line.split()
        if not fields:
            continue
        try:
            row = [float(f) for f in fields]
        except ValueError:
            raise DataError(f"{path} line {line_no}: not a number in {line.strip()!r}") from None
        if len(row) != len(columns) or not np.all(np.isfinite(row)):
            raise DataError(
                f"{path} line {line_no}: expected {len(columns)} finite numbers "
                f"({', '.join(columns)}), got {line.strip()!r}"
            )
        rows.append(row)
    if not rows:
        raise DataError(f"{path}: the file holds no rows")
    return np.array(rows)


def _text_prefix(folder: Path) -> str:
    prefixes = sorted(p.name[: -len("_DR.txt")] for p in folder.glob("*_DR.txt"))
    if len(prefixes) != 1:
        found = f"several ({', '.join(prefixes)}): pass prefix=" if prefixes else "none"
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
        raise DataError(f"{folder}: no such folder")
    prefix = prefix or _text_prefix(folder)
    dr_path, td_path = folder / f"{prefix}_DR.txt", folder / f"{prefix}_TD.txt"
    mats = [p for p in (folder / f"{prefix}_.mat", folder / f"{prefix}.mat") if p.is_file()]
    for path in (dr_path, td_path):
        if not path.is_file():
            raise DataError(f"{path}: no such file (needed with {dr_path.name})")
    if not mats:
        raise DataError(f"{folder}: no {prefix}_.mat holding GT and TL next to {dr_path.name}")
    content = _read_mat(mats[0])
    dr = _read_text_table(dr_path, _COLUMNS["odometry"][1])
    td = _read_text_table(td_path, _COLUMNS["ranges"][1])
    _check_same(dr, content, "DR", dr_path, mats[0])
    _check_same(td, content, "TD", td_path, mats[0])
    tables = {"GT": _mat_table(content, "GT", mats[0]), "TL": _mat_table(content, "TL", mats[0])}
    tables.update(DR=dr, TD=td)
    if "DRp" in content:
        tables["DRp"] = _mat_table(content, "DRp", mats[0])
    where = f"{dr_path}, {td_path}, {mats[0]}"
    return _assemble(name or prefix, where, tables)


# --------------------------------------------------------------------------------------------
# Finding files
# --------------------------------------------------------------------------------------------


def gtsam_data_dir() -> Path | None:
    """The ``Data/`` folder of an installed gtsam wheel, or None (gtsam is found, not imported)."""
    try:
        spec = importlib.util.find_spec("gtsam")
    except (ImportError, ValueError):
        return None
    for location in (spec.submodule_search_locations or []) if spec else []:
        folder = Path(location) / "Data"
        if folder.is_dir():
            return folder
    return None


def default_data_dirs(data_dir: str | os.PathLike | None = None) -> list[Path]:
    """Folders searched for data files, in order, without duplicates; they need not exist.

    Exactly three places: ``data_dir`` (the CLI's ``--data-dir``), then ``$STEAM_REF_DATA_DIR``,
    then the ``Data/`` folder of an installed gtsam wheel. Nothing relative to the working
    directory or to this package's location is searched.
    """
    env = os.environ.get(DATA_DIR_ENV) or None
    folders: list[Path] = []
    for candidate in (data_dir, env, gtsam_data_dir()):
        if candidate is not None and Path(candidate).resolve() not in folders:
            folders.append(Path(candidate).resolve())
    return folders


def _find(file_names: tuple[str, ...], folders: list[Path]) -> Path | None:
    """The first folder holding all of ``file_names`` (joined to the first name), or None."""
    for folder in folders:
        if all((folder / f).is_file() for f in file_names):
            return folder / file_names[0]
    return None


def _not_found(what: str, folders: list[Path], hint: str) -> DataError:
    """One line: what is missing, every folder searched, and where to put the file."""
    looked = ", ".join(str(f) for f in folders) or f"nowhere (no --data-dir, ${DATA_DIR_ENV} unset, no gtsam)"
    return DataError(f"{what} not found; looked in: {looked}. {hint}")


def load_dataset(
    name_or_path: str | os.PathLike, data_dir: str | os.PathLike | None = None, seed: int = 0
) -> RangeDataset:
    """A data set by name or path.

    Names: "synthetic" (generated, see :func:`generate_synthetic`; ``seed`` applies),
    "paper-synthetic" (``Syn_theta_Plaza.mat``), "plaza" (``Plaza1_thrown_away_some_range.mat``,
    else the original Plaza1 text files with all 3,529 ranges, e.g. from an installed gtsam).
    Named files are searched for in :func:`default_data_dirs`: ``data_dir`` (``--data-dir``),
    ``$STEAM_REF_DATA_DIR``, the installed gtsam's ``Data/``. Anything else is a path: a CMU .mat
    file or a folder of CMU text files; a bare file name that is not in the working directory is
    also searched for there. A missing file raises DataError naming the folders searched and
    where to put it.
    """
    key = str(name_or_path)
    if key == "synthetic":
        return generate_synthetic(seed=seed)
    folders = default_data_dirs(data_dir)
    hint = f"Put the file in a folder and pass that folder as --data-dir (data_dir= in Python) or set ${DATA_DIR_ENV} to it"
    if key in _FILES:
        found = _find((_FILES[key],), folders)
        if found is not None:
            return load_cmu_mat(found, name=key)
        if key == "plaza":
            text = _find(("Plaza1_DR.txt", "Plaza1_TD.txt", "Plaza1_.mat"), folders)
            if text is not None:
                return load_cmu_text(text.parent, "Plaza1", name=key)
            hint += " (or `pip install gtsam`: its Data/ has Plaza1_DR.txt, Plaza1_TD.txt, Plaza1_.mat)"
        raise _not_found(f"data set {key!r} ({_FILES[key]})", folders, hint + ".")
    path = Path(name_or_path)
    if not path.exists() and not path.is_absolute() and len(path.parts) == 1:
        path = _find((path.name,), folders) or path
    if path.is_dir() or path.name.endswith("_DR.txt"):
        return load_cmu_text(path)
    if path.is_file():
        return load_cmu_mat(path)
    names = ", ".join(["synthetic", *_FILES])
    raise _not_found(f"data set {key!r} (not one of {names}, nor a file or folder)", folders, hint + ".")


# --------------------------------------------------------------------------------------------
# Synthetic data  [YIB Sec. IV-A]
# --------------------------------------------------------------------------------------------


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


def _scatter_landmarks(
    rng: np.random.Generator, path: NDArray, anchors: NDArray, reach: tuple[float, float]
) -> NDArray:
    """(n, 2) landmark positions, landmark j placed by pose ``anchors[j]`` of ``path`` (n_poses, 2).

    Each sits at a uniform bearing and a uniform distance in [lo, hi] = ``reach`` from its anchor
    pose; of 64 such candidates the first at least lo from every pose of the path is kept (else
    the one farthest from the path).
    """
    lo, hi = reach
    n = len(anchors)
    bearing = rng.uniform(0, 2 * np.pi, (n, 64))
    radius = rng.uniform(lo, hi, (n, 64))
    offsets = radius[..., None] * np.stack([np.cos(bearing), np.sin(bearing)], axis=-1)
    points = path[anchors, None, :] + offsets
    clearance = cKDTree(path).query(points.reshape(-1, 2))[0].reshape(n, 64)
    ok = clearance >= lo
    pick = np.where(ok.any(axis=1), ok.argmax(axis=1), clearance.argmax(axis=1))
    return points[np.arange(n), pick]


def _observed_landmarks(
    rng: np.random.Generator, path: NDArray, xy: NDArray, anchors: NDArray, n_nearest: int
) -> NDArray:
    """(n_poses,) index of the landmark ranged at each pose: one drawn among its n_nearest,
    except that at its anchor pose a landmark is the one ranged (so every landmark is seen)."""
    dist = np.hypot(path[:, None, 0] - xy[None, :, 0], path[:, None, 1] - xy[None, :, 1])
    nearest = np.argsort(dist, axis=1, kind="stable")[:, : min(n_nearest, len(xy))]
    rows = np.arange(len(path))
    pick = nearest[rows, rng.integers(0, nearest.shape[1], len(path))]
    pick[anchors] = np.arange(len(xy))  # later anchors win if n_landmarks > n_poses
    return pick


def _ids_by_first_sighting(pick: NDArray, n: int) -> NDArray:
    """(n,) id of each landmark: 1, 2, ... in order of first sighting; unseen ones last."""
    seen = pick[np.sort(np.unique(pick, return_index=True)[1])]
    order = np.concatenate([seen, np.setdiff1d(np.arange(n), seen)])
    ids = np.empty(n, dtype=int)
    ids[order] = np.arange(1, n + 1)
    return ids


def _landmarks_and_ranges(
    rng: np.random.Generator, gt: NDArray, n: int, reach: tuple[float, float], n_nearest: int,
    sigma: float,
) -> tuple[NDArray, NDArray]:
    """(n, 3) landmarks id, x, y and (n_poses, 4) ranges time, sender 1, id, range.  [YIB Eq. 33]"""
    path = gt[:, 1:3]
    anchors = (2 * np.arange(n) + 1) * len(gt) // (2 * n)  # evenly spaced pose indices
    xy = _scatter_landmarks(rng, path, anchors, reach)
    pick = _observed_landmarks(rng, path, xy, anchors, n_nearest)
    ids = _ids_by_first_sighting(pick, n)
    measured = np.hypot(*(path - xy[pick]).T) + sigma * rng.standard_normal(len(gt))  # [YIB Eq. 33]
    ranges = np.column_stack([gt[:, 0], np.ones(len(gt)), ids[pick], measured])
    return np.column_stack([ids, xy])[np.argsort(ids)], ranges


def _check_generator_args(
    n_steps: int, n_landmarks: int, sigmas: NDArray, range_sigma: float, reach: tuple[float, float],
    n_nearest: int,
) -> None:
    if int(n_steps) != n_steps or n_steps < 1:
        raise SteamError(f"n_steps must be a positive integer, got {n_steps!r}")
    if int(n_landmarks) != n_landmarks or n_landmarks < 1:
        raise SteamError(f"n_landmarks must be a positive integer, got {n_landmarks!r}")
    if sigmas.shape != (2,) or not np.all(np.isfinite(sigmas)) or np.any(sigmas < 0):
        raise SteamError(f"odometry_sigmas must be two finite values >= 0, got {sigmas.tolist()}")
    if not (np.isfinite(range_sigma) and range_sigma >= 0):
        raise SteamError(f"range_sigma must be finite and >= 0, got {range_sigma!r}")
    if not (0 < reach[0] <= reach[1] < np.inf):
        raise SteamError(f"landmark_distance must be (lo, hi) with 0 < lo <= hi, got {reach!r}")
    if int(n_nearest) != n_nearest or n_nearest < 1:
        raise SteamError(f"n_nearest must be a positive integer, got {n_nearest!r}")


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
    - Odometry row k (time of pose k+1): distance |p[k+1] - p[k]| and heading change
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
      N(0, ``range_sigma``²), default 0.1 m: the file's residual std is 0.10 m. (The paper's
      solver assumes 1 m; pass range_sigma=1.0 for data that match that model.)

    Draws come from ``np.random.default_rng(seed)``, so a seed gives the same data set everywhere.
    """
    sigmas = np.asarray(odometry_sigmas, dtype=float).ravel()
    _check_generator_args(n_steps, n_landmarks, sigmas, range_sigma, landmark_distance, n_nearest)
    qc = _generator_qc(qc)
    rng = np.random.default_rng(seed)
    states = _sample_wnoa(rng, n_steps + 1, qc)
    times = np.arange(1, n_steps + 2, dtype=float)
    gt = np.column_stack([times, states[:, :2], np.arctan2(states[:, 3], states[:, 2])])
    odometry = _noisy_odometry(rng, gt, sigmas)
    landmarks, ranges = _landmarks_and_ranges(rng, gt, int(n_landmarks), landmark_distance,
                                              int(n_nearest), float(range_sigma))
    source = f"generated(seed={seed}, n_steps={n_steps}, n_landmarks={n_landmarks})"
    dead_reckoning = integrate_odometry(gt[0], odometry)
    return RangeDataset("synthetic", gt, odometry, dead_reckoning, landmarks, ranges, source)
