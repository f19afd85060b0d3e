"""Fidelity: a run against the authors' own saved BTGP runs, pose by pose.  [YIB Sec. IV]

The paper's public repository (``XinyanGT/online-gpslam-code``, ``matlab/Data/``) holds the authors'
outputs of BTGP/1 with every pose an estimated state: ``Plaza1_full_data_run.mat`` (MATLAB + GTSAM
3.2 on ``Plaza1_thrown_away_some_range.mat``; final poses, velocities, landmarks, 3x3 marginal
covariances of every pose and velocity, 2x2 of every landmark) and ``Syn_full_data_run.mat`` (the
synthetic set; no covariances). They are read from ``authors/`` in the data search path
(:func:`steam_ref.datasets.default_data_dirs`). :func:`compare` measures how far a
:class:`~steam_ref.results.RunResult` lands from one of them.

Conventions of the saved files: ``XYT``/``XYT_dot`` rows follow ``estStateInds`` (pose indices);
``XY`` rows are the landmarks in GTSAM key order, i.e. by increasing id; ``landmarkMarginal`` rows
follow the data set's ``TL`` rows; ``diff`` is ground truth minus estimate at the states.
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import scipy.io
from numpy.typing import NDArray

from .datasets import DATA_DIR_ENV, RangeDataset, default_data_dirs
from .errors import DataError
from .results import RunResult, position_rmse

__all__ = ["AUTHORS_RUNS", "AuthorsRun", "Fidelity", "find_authors_file", "load_authors_run", "compare"]

AUTHORS_RUNS = {"plaza": "Plaza1_full_data_run.mat", "paper-synthetic": "Syn_full_data_run.mat"}  # data set → file in authors/


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
    folders = default_data_dirs(data_dir)
    for folder in folders:
        if (folder / "authors" / file).is_file():
            return folder / "authors" / file
    looked = ", ".join(str(f) for f in folders) or "nowhere"
    raise DataError(f"the authors' run authors/{file} not found; looked in: {looked}. Put the authors/ folder "
                    f"(from XinyanGT/online-gpslam-code matlab/Data) in --data-dir or ${DATA_DIR_ENV}.")


def _read(path: Path) -> dict:
    """The arrays of a saved run; DataError when it cannot be read or lacks one."""
    try:
        m = scipy.io.loadmat(path)
    except Exception as err:  # scipy raises ValueError, OSError, MatReadError, zlib errors...
        raise DataError(f"{path}: cannot read it as a MATLAB .mat file ({type(err).__name__}: {err})") from None
    missing = [k for k in ("estStateInds", "XYT", "XYT_dot", "XY", "diff", "step_t") if k not in m]
    if missing:
        raise DataError(f"{path}: no array {missing[0]!r}; is it one of the authors' *_full_data_run.mat files?")
    return m


def _check_same_data(path: Path, m: dict, data: RangeDataset) -> NDArray:
    """The saved run's state poses, after checking it was run on ``data``: its ``diff`` (ground truth
    minus estimate) plus its estimate must be ``data``'s ground truth at those poses."""
    poses = m["estStateInds"].ravel().astype(int)
    if poses.max(initial=-1) >= data.n_poses or m["XY"].shape != (data.n_landmarks, 2):
        raise DataError(f"{path} was run on a data set with states up to pose {poses.max()} and {m['XY'].shape[0]} "
                        f"landmarks; {data.name!r} has {data.n_poses} poses and {data.n_landmarks} landmarks")
    truth = m["diff"] + m["XYT"][:, :2]
    if not np.allclose(truth, data.ground_truth[poses, 1:3], rtol=0, atol=1e-6):
        raise DataError(f"{path} was not run on this data set ({data.source}): its ground truth differs")
    saved = m.get("nNonInterpRangeMeasurements")
    if isinstance(saved, np.ndarray) and saved.dtype.kind in "iuf" and int(saved.ravel()[0]) != data.n_ranges:
        raise DataError(f"{path} used {int(saved.ravel()[0])} range readings, {data.name!r} has {data.n_ranges} "
                        "(the original Plaza files, not the cleaned one?)")
    return poses


def load_authors_run(name: str, data: RangeDataset, data_dir: str | os.PathLike | None = None) -> AuthorsRun:
    """The authors' saved run on data set ``name`` ('plaza' or 'paper-synthetic'), checked against ``data``."""
    path = find_authors_file(name, data_dir)
    m = _read(path)
    poses = _check_same_data(path, m, data)
    ids = sorted(int(i) for i in data.landmarks[:, 0])
    tl_ids = [int(i) for i in data.landmarks[:, 0]]
    cov = m.get("stateMarginal")
    has_cov = isinstance(cov, np.ndarray) and cov.dtype == object
    marks_cov = {i: np.asarray(m["landmarkMarginal"][k, 0], float) for k, i in enumerate(tl_ids)} if has_cov else None
    return AuthorsRun(
        name, poses, m["XYT"].astype(float), m["XYT_dot"].astype(float),
        {i: m["XY"][k].astype(float) for k, i in enumerate(ids)},
        np.stack([np.asarray(c, float) for c in cov[:, 0]]) if has_cov else None,
        np.stack([np.asarray(c, float) for c in cov[:, 1]]) if has_cov else None,
        marks_cov, m["step_t"][:, 0].astype(float), path,
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
    heading_max_rad: float  # max |θ_ours - θ_authors|
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
        raise DataError(f"the run has {result.n_states} states, the authors' {len(authors.state_poses)}: "
                        "compare runs with the same state layout (every pose a state)")
    missing = sorted(set(authors.landmarks) - set(result.landmarks))
    if missing:
        raise DataError(f"the run has no estimate of landmark {missing[0]}, which the authors' run has")
    if len(ground_truth) <= result.state_poses.max(initial=0):
        raise DataError(f"ground truth has {len(ground_truth)} rows, the run's states reach pose {result.state_poses.max()}")
    ours = result.trajectory[result.state_poses]
    dist = np.hypot(*(ours[:, :2] - authors.poses[:, :2]).T)
    truth = np.asarray(ground_truth)[result.state_poses, 1:3]
    marks = [np.hypot(*(result.landmarks[i] - p)) for i, p in authors.landmarks.items()]
    cov = {}
    if authors.pose_covariance is not None and result.covariances is not None:
        c = result.covariances
        p = _relative_frobenius(c.pose[result.state_poses], authors.pose_covariance)
        v = _relative_frobenius(c.velocity[result.state_poses], authors.velocity_covariance)
        theirs = np.stack([authors.landmark_covariance[i] for i in c.landmark_ids])
        lm = _relative_frobenius(c.landmark, theirs)
        cov = dict(pose_cov_median=float(np.median(p)), pose_cov_max=float(p.max()), velocity_cov_median=float(np.median(v)),
                   velocity_cov_max=float(v.max()), landmark_cov_max=float(lm.max()))
    fid = Fidelity(
        authors.name, len(dist), float(np.sqrt(np.mean(dist**2))), float(dist.max()), int(result.state_poses[dist.argmax()]),
        float(np.abs(ours[:, 2] - authors.poses[:, 2]).max()), float(max(marks)),
        position_rmse(ours[:, :2], truth), position_rmse(authors.poses[:, :2], truth),
        **{k: cov.get(k) for k in ("pose_cov_median", "pose_cov_max", "velocity_cov_median", "velocity_cov_max", "landmark_cov_max")},
    )
    return fid, dist
