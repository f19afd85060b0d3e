"""steam_ref: incremental sparse GP regression for continuous-time STEAM.

A reference implementation of Yan, Indelman and Boots, "Incremental Sparse GP Regression for
Continuous-time Trajectory Estimation & Mapping": the GP motion prior, its factors and
interpolation, batch Gauss-Newton (PB, PBVR), and the Bayes tree (BTGP). Equations are cited in
the code as [YIB Eq. n]; see docs/references.md.
"""

from importlib import metadata as _metadata

from .batch import BatchResult, batch_solve, gauss_newton, levenberg_marquardt
from .bayes_tree import BayesTree, IncrementalSolver, ISAM2Params
from .covariance import marginal_covariances
from .datasets import LandmarkDataset, RangeDataset, generate_synthetic, load_dataset
from .errors import (
    ConvergenceWarning,
    DataError,
    IllConditionedWarning,
    NumericalError,
    ShapeError,
    SteamError,
    UnderdeterminedError,
    UnknownVariableError,
)
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
from .graph import FactorGraph
from .linear import LinearSystem, amd_ordering, xl_ordering
from .online import StreamOptions, run_online
from .readings import PaperSetup
from .robust import Huber, Tukey
from .variables import Key, L, Values, X

try:
    __version__ = _metadata.version("steam_ref")  # written once, in pyproject.toml
except _metadata.PackageNotFoundError:  # the source folder on sys.path, never installed
    __version__ = "0+unknown"

__all__ = [
    "SteamError",
    "ShapeError",
    "DataError",
    "UnknownVariableError",
    "UnderdeterminedError",
    "NumericalError",
    "IllConditionedWarning",
    "ConvergenceWarning",
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
    "Huber",
    "Tukey",
    "LinearSystem",
    "xl_ordering",
    "amd_ordering",
    "marginal_covariances",
    "gauss_newton",
    "levenberg_marquardt",
    "batch_solve",
    "BatchResult",
    "BayesTree",
    "IncrementalSolver",
    "ISAM2Params",
    "RangeDataset",
    "LandmarkDataset",
    "load_dataset",
    "generate_synthetic",
    "PaperSetup",
    "StreamOptions",
    "run_online",
]
