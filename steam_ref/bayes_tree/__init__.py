"""The Bayes tree and the incremental solver built on it.  [YIB Sec. III, K12]

- :mod:`.symbolic`: orderings → cliques, and clique surgery, structure only (the orderings
  themselves, iSAM2's constrained minimum degree included, are in :mod:`steam_ref.linear.ordering`);
- :mod:`.tree`: :class:`Clique` (a Gaussian conditional), :class:`BayesTree`, elimination and
  back-substitution;
- :mod:`.params`: :class:`ISAM2Params`, the solver's thresholds (GTSAM's defaults);
- :mod:`.undo` and :mod:`.state`: the one undo log, and :class:`~.state.SolverState`, every store of a solver;
- :mod:`.isam`: :class:`IncrementalSolver`, the update of Algorithm 1 (steps 2-7);
- :mod:`.backsolve`: its partial back-substitution [K12 Alg. 7];
- :mod:`.marginalization`: :func:`marginalize`, variables out of the tree, leaving their marginal factor;
- :mod:`.fixed_lag`: :class:`FixedLagSmoother`, iSAM2 over a sliding window of a lag in seconds;
- :mod:`.history`: the conditionals a fixed-lag smoother forgot, kept to smooth its past at the end.
"""

from .fixed_lag import FixedLagSmoother
from .isam import IncrementalSolver, UpdateReport
from .marginalization import MarginalFactor, MarginalizationReport, marginalize
from .params import ISAM2Params
from .symbolic import CliqueTree, SymbolicClique, build_cliques, symbolic_elimination
from .tree import BayesTree, Clique, eliminate, eliminate_clique

__all__ = [
    "IncrementalSolver",
    "ISAM2Params",
    "UpdateReport",
    "SymbolicClique",
    "CliqueTree",
    "symbolic_elimination",
    "build_cliques",
    "Clique",
    "BayesTree",
    "eliminate",
    "eliminate_clique",
    "FixedLagSmoother",
    "MarginalFactor",
    "MarginalizationReport",
    "marginalize",
]
