"""The Bayes tree and the incremental solver built on it.  [YIB Sec. III, K12]

- :mod:`.symbolic`: orderings → cliques, and clique surgery, structure only (the orderings
  themselves, iSAM2's constrained minimum degree included, are in :mod:`steam_ref.linear.ordering`);
- :mod:`.tree`: :class:`Clique` (a Gaussian conditional), :class:`BayesTree`, elimination and
  back-substitution; :mod:`.dot`: the tree as GTSAM's ``dot()`` text, and its fill ``tree_nnz``;
- :mod:`.params`: :class:`ISAM2Params`, the solver's thresholds (GTSAM's defaults);
- :mod:`.undo` and :mod:`.state`: the one undo log, and :class:`~.state.SolverState`, every store of a solver;
- :mod:`.isam`: :class:`IncrementalSolver`, the update of Algorithm 1 (steps 2-7), and its public
  ``marginalize_leaves`` (:func:`marginalize` as a function);
- :mod:`.backsolve`: its partial back-substitution [K12 Alg. 7];
- :mod:`.marginalization`: how variables leave the tree, leaving their marginal factor;
- :mod:`.fixed_lag`: :class:`FixedLagSmoother`, which holds an IncrementalSolver over a sliding window of a lag;
- :mod:`.history`: the conditionals a fixed-lag smoother forgot, kept to smooth its past at the end.
"""

from .fixed_lag import FixedLagSmoother
from .isam import IncrementalSolver, UpdateReport, marginalize
from .marginalization import MarginalFactor, MarginalizationReport
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
