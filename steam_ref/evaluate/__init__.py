"""Evaluating an estimate: trajectory error (APE, RPE, aligned or not), trajectory files, consistency (NEES).

- :mod:`.align`: the SE(2) / Sim(2) alignment of an estimate onto the truth, Umeyama's closed form in the plane.
- :mod:`.metrics`: APE and RPE of planar poses and their statistics (RMSE, mean, median, max), as evo defines them;
  the APE of poses on SE(3) (any group of rigid motions).
- :mod:`.files`: TUM and KITTI trajectory files, written and read back.
- :mod:`.report`: the estimate at the truth's own times by GP interpolation [YIB Eq. 18]; a run's figures.
- :mod:`.fit_qc`: Qc from data, the maximum-likelihood diagonal Qc of a motion prior from a run's ground-truth poses.
- :mod:`.consistency`: NEES of a state with its covariance, the χ² band of an ANEES over Monte Carlo runs, its verdict and
  the runs a verdict of "consistent" needs.

The Monte Carlo study itself (sampling tasks from the model, running the estimators, over many seeds) is
:mod:`steam_ref.paper.consistency`, since it runs the paper's solvers.
"""

from .align import ALIGNMENTS, Alignment, align_planar, alignment_defect
from .consistency import (
    INCONCLUSIVE,
    LOST_QUANTILE,
    chi2_band,
    chi2_quantile,
    nees,
    pose_errors,
    runs_needed,
    verdict,
)
from .files import read_kitti, read_tum, write_kitti, write_tum
from .fit_qc import QcFit, fit_qc
from .metrics import PoseError, Statistics, ape, group_ape, planar_poses, rpe, rpe_pairs
from .report import states_at, trajectory_figures

__all__ = [
    "ALIGNMENTS",
    "Alignment",
    "align_planar",
    "alignment_defect",
    "Statistics",
    "PoseError",
    "ape",
    "group_ape",
    "rpe",
    "rpe_pairs",
    "planar_poses",
    "write_tum",
    "read_tum",
    "write_kitti",
    "read_kitti",
    "states_at",
    "trajectory_figures",
    "nees",
    "chi2_band",
    "chi2_quantile",
    "pose_errors",
    "verdict",
    "runs_needed",
    "LOST_QUANTILE",
    "INCONCLUSIVE",
    "QcFit",
    "fit_qc",
]
