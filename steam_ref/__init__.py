"""steam_ref: incremental sparse GP regression for continuous-time STEAM.

A reference implementation of Yan, Indelman and Boots, "Incremental Sparse GP Regression for
Continuous-time Trajectory Estimation & Mapping": the GP motion prior, its factors and
interpolation, batch Gauss-Newton (PB, PBVR), and the Bayes tree (BTGP). Equations are cited in
the code as [YIB Eq. n]; see docs/references.md.
"""

from typing import TYPE_CHECKING

from ._package import __version__ as __version__
from ._package import lazy_names
from .errors import (
    ClockError,
    ConvergenceError,
    ConvergenceWarning,
    DataError,
    DegenerateMeasurementWarning,
    DivergenceWarning,
    IllConditionedWarning,
    KindError,
    NumericalError,
    ShapeError,
    SteamError,
    SteamWarning,
    UncleanedDataWarning,
    UnderdeterminedError,
    UnknownVariableError,
    WrappedTurnWarning,
)

# Every other name a user types, and the module it lives in. They load when first touched (PEP 562), so
# `import steam_ref` costs the exception family only; a user of the Bayes tree never loads the paper's
# experiment machinery, its data loaders or matplotlib. tests/test_architecture.py checks this table
# against __all__ and against each module's own __all__.
_HOMES = {
    "Key": "variables",
    "X": "variables",
    "L": "variables",
    "Values": "variables",
    "FactorGraph": "graph",
    "Factor": "factors",
    "GPPriorFactor": "factors",
    "PriorFactor": "factors",
    "OdometryFactor": "factors",
    "VelocityFactor": "factors",
    "RangeFactor": "factors",
    "BearingFactor": "factors",
    "BearingRangeFactor": "factors",
    "InterpolatedFactor": "factors",
    "gp_prior_factors": "factors",
    "LieGroup": "lie",
    "SE2": "lie",
    "SO3": "lie",
    "SE3": "lie",
    "GroupState": "lie",
    "SE2_STATE": "lie",
    "Huber": "robust",
    "Tukey": "robust",
    "LinearSystem": "linear",
    "xl_ordering": "linear",
    "amd_ordering": "linear",
    "blas_threads": "linear",
    "marginal_covariances": "covariance",
    "sparse_marginal_covariances": "covariance",
    "sparse_joint_covariance": "covariance",
    "predict_state": "motion",
    "MotionPrior": "motion",
    "motion_prior": "motion",
    "finish_at_optimum": "finish",
    "Trajectory": "trajectory",
    "gauss_newton": "batch",
    "levenberg_marquardt": "batch",
    "batch_solve": "batch",
    "BatchResult": "batch",
    "BayesTree": "bayes_tree",
    "IncrementalSolver": "bayes_tree",
    "ISAM2Params": "bayes_tree",
    "FixedLagSmoother": "bayes_tree",
    "RangeDataset": "datasets",
    "LandmarkDataset": "datasets",
    "load_dataset": "datasets",
    "generate_synthetic": "datasets",
    "PaperSetup": "paper.presets",
    "StreamOptions": "paper.options",
    "run_online": "paper.online",
    "ape": "evaluate",
    "rpe": "evaluate",
    "align_planar": "evaluate",
    "write_tum": "evaluate",
    "read_tum": "evaluate",
    "nees": "evaluate",
    "chi2_band": "evaluate",
    "fit_qc": "evaluate.fit_qc",
    "QcFit": "evaluate.fit_qc",
}


__getattr__, __dir__ = lazy_names(globals(), _HOMES)


if TYPE_CHECKING:  # what a type checker and an IDE see: the same names, imported eagerly
    from .batch import BatchResult, batch_solve, gauss_newton, levenberg_marquardt
    from .bayes_tree import BayesTree, FixedLagSmoother, IncrementalSolver, ISAM2Params
    from .covariance import marginal_covariances, sparse_joint_covariance, sparse_marginal_covariances
    from .datasets import LandmarkDataset, RangeDataset, generate_synthetic, load_dataset
    from .evaluate import align_planar, ape, chi2_band, nees, read_tum, rpe, write_tum
    from .evaluate.fit_qc import QcFit, fit_qc
    from .factors import (
        BearingFactor,
        BearingRangeFactor,
        Factor,
        GPPriorFactor,
        InterpolatedFactor,
        OdometryFactor,
        PriorFactor,
        RangeFactor,
        VelocityFactor,
        gp_prior_factors,
    )
    from .finish import finish_at_optimum
    from .graph import FactorGraph
    from .lie import SE2, SE2_STATE, SE3, SO3, GroupState, LieGroup
    from .linear import LinearSystem, amd_ordering, blas_threads, xl_ordering
    from .motion import MotionPrior, motion_prior, predict_state
    from .paper.online import run_online
    from .paper.options import StreamOptions
    from .paper.presets import PaperSetup
    from .robust import Huber, Tukey
    from .trajectory import Trajectory
    from .variables import Key, L, Values, X

__all__ = [
    "SteamError",
    "ShapeError",
    "DataError",
    "UnknownVariableError",
    "UnderdeterminedError",
    "KindError",
    "NumericalError",
    "ClockError",
    "ConvergenceError",
    "IllConditionedWarning",
    "ConvergenceWarning",
    "DivergenceWarning",
    "SteamWarning",
    "UncleanedDataWarning",
    "DegenerateMeasurementWarning",
    "WrappedTurnWarning",
    "Key",
    "X",
    "L",
    "Values",
    "FactorGraph",
    "Factor",
    "GPPriorFactor",
    "PriorFactor",
    "OdometryFactor",
    "VelocityFactor",
    "RangeFactor",
    "BearingFactor",
    "BearingRangeFactor",
    "InterpolatedFactor",
    "gp_prior_factors",
    "LieGroup",
    "SE2",
    "SO3",
    "SE3",
    "GroupState",
    "SE2_STATE",
    "Huber",
    "Tukey",
    "LinearSystem",
    "xl_ordering",
    "amd_ordering",
    "blas_threads",
    "marginal_covariances",
    "sparse_marginal_covariances",
    "sparse_joint_covariance",
    "predict_state",
    "MotionPrior",
    "motion_prior",
    "finish_at_optimum",
    "Trajectory",
    "gauss_newton",
    "levenberg_marquardt",
    "batch_solve",
    "BatchResult",
    "BayesTree",
    "IncrementalSolver",
    "ISAM2Params",
    "FixedLagSmoother",
    "RangeDataset",
    "LandmarkDataset",
    "load_dataset",
    "generate_synthetic",
    "PaperSetup",
    "StreamOptions",
    "run_online",
    "ape",
    "rpe",
    "align_planar",
    "write_tum",
    "read_tum",
    "nees",
    "chi2_band",
    "fit_qc",
    "QcFit",
]
