"""Fidelity: a run against the authors' own saved BTGP runs, pose by pose.  [YIB Sec. IV]

The paper's public repository (``XinyanGT/online-gpslam-code``, ``matlab/Data/``) holds the authors'
outputs of BTGP/1 with every pose an estimated state: ``Plaza1_full_data_run.mat`` (MATLAB + GTSAM
3.2 on ``Plaza1_thrown_away_some_range.mat``; final poses, velocities, landmarks, 3x3 marginal
covariances of every pose and velocity, 2x2 of every landmark) and ``Syn_full_data_run.mat`` (the
synthetic set; no covariances). They are read from ``authors/`` in the data search path
(:func:`steam_ref.datasets.default_data_dirs`). :func:`compare` measures how far a
:class:`~steam_ref.paper.results.RunResult` lands from one of them.

Conventions of the saved files: ``XYT``/``XYT_dot`` rows follow ``estStateInds`` (pose indices);
``XY`` rows are the landmarks in GTSAM key order, i.e. by increasing id; ``landmarkMarginal`` rows
follow the data set's ``TL`` rows; ``diff`` is ground truth minus estimate at the states.
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..arguments import asymmetric
from ..datasets import RangeDataset, read_mat
from ..datasets.registry import DATASETS
from ..datasets.search import find_named, not_found
from ..dead_reckoning import wrap_angle
from ..errors import DataError
from .results import RunResult, position_rmse

__all__ = [
    "AUTHORS_RUNS",
    "AuthorsRun",
    "Fidelity",
    "find_authors_file",
    "load_authors_run",
    "compare",
]

AUTHORS_RUNS = {  # data set → its authors' run, a file in authors/: read from the registry (DataSet.authors_run)
    name: Path(DATASETS[s.authors_run].files[0].local).name for name, s in DATASETS.items() if s.authors_run
}


@dataclass(frozen=True)
class AuthorsRun:
    """One of the authors' saved BTGP runs."""

    name: str  # the data set: 'plaza' or 'paper-synthetic'
    state_poses: NDArray  # (M,) pose indices with a state
    poses: NDArray  # (M, 3) final [x, y, θ]
    velocities: NDArray  # (M, 3) final [ẋ, ẏ, θ̇]
    landmarks: dict[int, NDArray]  # id → final (2,)
    pose_covariance: NDArray | None  # (M, 3, 3) final marginals, when saved
    velocity_covariance: NDArray | None  # (M, 3, 3)
    landmark_covariance: dict[int, NDArray] | None  # id → (2, 2)
    step_seconds: NDArray  # (n_steps,) MATLAB + GTSAM 3.2 time per step
    source: Path  # the file read


def find_authors_file(name: str, data_dir: str | os.PathLike | None = None) -> Path:
    """The authors' saved run of data set ``name`` in the data search path; DataError saying where to put it."""
    if name not in AUTHORS_RUNS:
        raise DataError(f"no saved authors' run for data set {name!r}; there is one for {', '.join(AUTHORS_RUNS)}")
    file = AUTHORS_RUNS[name]
    got = find_named(f"authors/{file}", data_dir)  # a cached copy that is not the published file is refused
    if got is not None:
        return got[0]
    fetch, put = DATASETS[name].authors_run, "the authors/ folder (from XinyanGT/online-gpslam-code matlab/Data)"
    assert fetch is not None  # AUTHORS_RUNS holds only the sets that name their authors' run
    raise not_found(f"the authors' run authors/{file}", fetch, data_dir, put)


def _read(path: Path) -> dict:
    """The arrays of a saved run; DataError when it cannot be read or lacks one."""
    m = read_mat(path)
    missing = [k for k in ("estStateInds", "XYT", "XYT_dot", "XY", "diff", "step_t") if k not in m]
    if missing:
        raise DataError(f"{path}: no array {missing[0]!r}; is it one of the authors' *_full_data_run.mat files?")
    return m


def _table(path: Path, m: dict, key: str, columns: int, rows: int | None = None) -> NDArray:
    """``m[key]`` as a finite float (rows, columns) array; DataError naming the file, array and entry."""
    value = m[key]
    if not isinstance(value, np.ndarray) or value.dtype.kind not in "biuf":
        raise DataError(f"{path}: {key} is not a numeric matrix (got {getattr(value, 'dtype', type(value))})")
    if value.ndim != 2 or value.shape[1] < columns or (rows is not None and value.shape[0] != rows):
        want = f"({'n' if rows is None else rows}, {columns})"
        raise DataError(f"{path}: {key} has shape {value.shape}, expected {want}")
    value = value[:, :columns].astype(float)
    bad = np.argwhere(~np.isfinite(value))
    if bad.size:
        raise DataError(
            f"{path}: {key}[{bad[0][0]}, {bad[0][1]}] is {value[tuple(bad[0])]}: every value must be finite"
        )
    return value


def _covariances(path: Path, cells: NDArray, what: str, d: int) -> NDArray:
    """(n, d, d) from a column of MATLAB cells, each a finite, symmetric, positive definite d x d."""
    for k, cell in enumerate(cells):
        c = np.asarray(cell)
        if c.dtype.kind not in "biuf" or c.shape != (d, d) or not np.all(np.isfinite(c)):
            raise DataError(f"{path}: {what} {k} must be a finite {d}x{d} matrix, got {c.dtype} of shape {c.shape}")
    out = np.stack([np.asarray(c, dtype=float) for c in cells]) if len(cells) else np.zeros((0, d, d))
    bad = np.flatnonzero(asymmetric(out))  # the authors' files: below 1e-15 of the largest entry
    if bad.size:
        k = int(bad[0])
        asym, size = np.abs(out[k] - out[k].T).max(), np.abs(out[k]).max()
        raise DataError(
            f"{path}: {what} {k} is not symmetric (|C - Cᵀ| up to {asym:.3g}, |C| up to {size:.3g}): not a covariance"
        )
    low = np.linalg.eigvalsh(out).min(axis=1, initial=np.inf) if len(out) else np.zeros(0)
    bad = np.flatnonzero(low <= 0)
    if bad.size:
        k = int(bad[0])
        raise DataError(
            f"{path}: {what} {k} is not positive definite (smallest eigenvalue {low[k]:.3g}): not a covariance"
        )
    return out


def _check_same_data(path: Path, m: dict, data: RangeDataset) -> NDArray:
    """The saved run's state poses, after checking it was run on ``data``: its ``diff`` (ground truth
    minus estimate) plus its estimate must be ``data``'s ground truth at those poses."""
    inds = _table(path, {"estStateInds": np.reshape(m["estStateInds"], (-1, 1))}, "estStateInds", 1)[:, 0]
    poses = inds.astype(int)
    if np.any(inds != poses) or np.any(poses < 0) or np.any(np.diff(poses) <= 0):
        raise DataError(f"{path}: estStateInds must be increasing pose indices >= 0")
    if poses.max(initial=-1) >= data.n_poses or np.shape(m["XY"]) != (data.n_landmarks, 2):
        raise DataError(
            f"{path} was run on a data set with states up to pose {poses.max(initial=-1)} and {np.shape(m['XY'])[0]} "
            f"landmarks; {data.name!r} has {data.n_poses} poses and {data.n_landmarks} landmarks"
        )
    truth = _table(path, m, "diff", 2, len(poses)) + _table(path, m, "XYT", 3, len(poses))[:, :2]
    if not np.allclose(truth, data.ground_truth[poses, 1:3], rtol=0, atol=1e-6):
        raise DataError(f"{path} was not run on this data set ({data.source}): its ground truth differs")
    saved = m.get("nNonInterpRangeMeasurements")
    if (
        isinstance(saved, np.ndarray)
        and saved.dtype.kind in "iuf"
        and saved.size
        and int(saved.ravel()[0]) != data.n_ranges
    ):
        raise DataError(
            f"{path} used {int(saved.ravel()[0])} range readings, {data.name!r} has {data.n_ranges} "
            "(the original Plaza files, not the cleaned one?)"
        )
    return poses


def load_authors_run(name: str, data: RangeDataset, data_dir: str | os.PathLike | None = None) -> AuthorsRun:
    """The authors' saved run on data set ``name`` ('plaza' or 'paper-synthetic'), checked against ``data``.

    Every array must be numeric, finite and of the expected shape, and each saved marginal a
    symmetric (:func:`~steam_ref.arguments.asymmetric`) positive definite matrix; else DataError naming it."""
    path = find_authors_file(name, data_dir)
    m = _read(path)
    poses = _check_same_data(path, m, data)
    ids = sorted(int(i) for i in data.landmarks[:, 0])
    tl_ids = [int(i) for i in data.landmarks[:, 0]]
    saved = m.get("stateMarginal")
    cov = saved if isinstance(saved, np.ndarray) and saved.dtype == object else None
    landmark_shape = () if m.get("landmarkMarginal") is None else np.shape(m["landmarkMarginal"])
    if cov is not None and (cov.shape != (len(poses), 2) or landmark_shape != (data.n_landmarks, 1)):
        raise DataError(
            f"{path}: stateMarginal has shape {cov.shape} and landmarkMarginal {landmark_shape}; "
            f"expected ({len(poses)}, 2) and ({data.n_landmarks}, 1)"
        )
    marks = _table(path, m, "XY", 2, data.n_landmarks)
    landmark_cov = _covariances(path, m["landmarkMarginal"][:, 0], "landmarkMarginal", 2) if cov is not None else None
    return AuthorsRun(
        name,
        poses,
        _table(path, m, "XYT", 3, len(poses)),
        _table(path, m, "XYT_dot", 3, len(poses)),
        {i: marks[k] for k, i in enumerate(ids)},
        _covariances(path, cov[:, 0], "stateMarginal pose", 3) if cov is not None else None,
        _covariances(path, cov[:, 1], "stateMarginal velocity", 3) if cov is not None else None,
        {i: landmark_cov[k] for k, i in enumerate(tl_ids)} if landmark_cov is not None else None,
        _table(path, m, "step_t", 1)[:, 0],
        path,
    )


def _relative_frobenius(ours: NDArray, theirs: NDArray) -> NDArray:
    """‖A - B‖_F / ‖B‖_F for stacks of matrices (n, d, d)."""
    return np.linalg.norm(ours - theirs, axis=(1, 2)) / np.linalg.norm(theirs, axis=(1, 2))


@dataclass(frozen=True)
class Fidelity:
    """How far a run lands from the authors' saved run (distances in metres)."""

    dataset: str  # data set name
    n_states: int  # states compared
    pose_rms_m: float  # RMS over the states of ‖p_ours - p_authors‖ (x, y)
    pose_max_m: float  # its maximum
    pose_max_at: int  # the pose index where the maximum is
    heading_max_rad: float  # max |wrap(θ_ours - θ_authors)|, the wrap to [-π, π)
    landmark_max_m: float  # max over landmarks of ‖ℓ_ours - ℓ_authors‖
    rmse_m: float  # our position RMSE against ground truth at the states
    authors_rmse_m: float  # the authors' (the same score of their estimate)
    pose_cov_median: float | None  # relative Frobenius difference of the 3x3 pose marginals, median over states
    pose_cov_max: float | None  # ... maximum over states
    velocity_cov_median: float | None  # the same for the velocity marginals
    velocity_cov_max: float | None
    landmark_cov_max: float | None  # the same for the 2x2 landmark marginals, maximum over landmarks

    def to_dict(self) -> dict:
        """Rounded figures for a JSON line."""
        return {k: (round(v, 7) if isinstance(v, float) else v) for k, v in asdict(self).items()}


def compare(result: RunResult, authors: AuthorsRun, ground_truth: NDArray) -> tuple[Fidelity, NDArray]:
    """Figures of ``result`` against ``authors`` and the per-state distances (M,) [m]."""
    if not np.array_equal(result.state_poses, authors.state_poses):
        raise DataError(
            f"the run has {result.n_states} states, the authors' {len(authors.state_poses)}: "
            "compare runs with the same state layout (every pose a state)"
        )
    missing = sorted(set(authors.landmarks) - set(result.landmarks))
    if missing:
        raise DataError(f"the run has no estimate of landmark {missing[0]}, which the authors' run has")
    if len(ground_truth) <= result.state_poses.max(initial=0):
        raise DataError(
            f"ground truth has {len(ground_truth)} rows, the run's states reach pose {result.state_poses.max()}"
        )
    ours = result.trajectory[result.state_poses]
    dist = np.hypot(*(ours[:, :2] - authors.poses[:, :2]).T)
    truth = np.asarray(ground_truth)[result.state_poses, 1:3]
    marks = [np.hypot(*(result.landmarks[i] - p)) for i, p in authors.landmarks.items()]
    cov = {}
    # the authors' three kinds of marginal are saved together, or none of them
    pose_cov, velocity_cov, landmark_cov = (
        authors.pose_covariance,
        authors.velocity_covariance,
        authors.landmark_covariance,
    )
    if (
        pose_cov is not None
        and velocity_cov is not None
        and landmark_cov is not None
        and result.covariances is not None
    ):
        c = result.covariances
        p = _relative_frobenius(c.pose[result.state_poses], pose_cov)
        v = _relative_frobenius(c.velocity[result.state_poses], velocity_cov)
        theirs = np.stack([landmark_cov[i] for i in c.landmark_ids])
        lm = _relative_frobenius(c.landmark, theirs)
        cov = dict(
            pose_cov_median=float(np.median(p)),
            pose_cov_max=float(p.max()),
            velocity_cov_median=float(np.median(v)),
            velocity_cov_max=float(v.max()),
            landmark_cov_max=float(lm.max()),
        )
    fid = Fidelity(
        authors.name,
        len(dist),
        float(np.sqrt(np.mean(dist**2))),
        float(dist.max()),
        int(result.state_poses[dist.argmax()]),
        float(np.abs(wrap_angle(ours[:, 2] - authors.poses[:, 2])).max()),  # θ and θ + 2π are one heading
        float(max(marks)),
        position_rmse(ours[:, :2], truth),
        position_rmse(authors.poses[:, :2], truth),
        **{
            k: cov.get(k)
            for k in ("pose_cov_median", "pose_cov_max", "velocity_cov_median", "velocity_cov_max", "landmark_cov_max")
        },
    )
    return fid, dist
