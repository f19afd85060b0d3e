"""Finish an incremental solve at the batch optimum of all its factors.  [YIB Eq. 6-11, Alg. 1]

iSAM2 moves a variable's linearization point θ̄ only when its increment reaches the threshold β
(``relinearize_threshold``, 0.1 by default) and only every ``relinearize_skip``-th update, so its estimate
θ̄ + δ is the solution of a system linearized where each variable last moved: it may rest up to about β
from the optimum (on a toy problem with GTSAM's defaults, about a centimetre). Updates with no new factors do
not close that gap, because a δ below β never moves θ̄.

:func:`finish_at_optimum` closes it with the solver's public API only: it puts every factor of the solver,
at the solver's estimate, into a new :class:`~steam_ref.bayes_tree.IncrementalSolver` with both thresholds 0
and skip 1 (where each update with no new factors is one Gauss-Newton step on all factors,
:class:`~steam_ref.bayes_tree.ISAM2Params`), updates it until the largest entry of the step is below a
tolerance, and certifies the estimate with the batch check (:func:`~steam_ref.batch.check_stationarity`):
the result says ``converged`` only if that check passed.
"""

from __future__ import annotations

import numpy as np

from .arguments import is_integer
from .batch import BatchResult, Iteration, certify, check_options, prepare
from .bayes_tree import FixedLagSmoother, IncrementalSolver
from .errors import SteamError
from .graph import FactorGraph
from .linear.threads import limited

__all__ = ["finish_at_optimum"]


@limited
def finish_at_optimum(
    solver: IncrementalSolver,
    *,
    step_tolerance: float = 1e-9,
    max_updates: int = 50,
    relative_tolerance: float = 1e-8,
    absolute_tolerance: float = 1e-12,
    backend: str | None = None,
) -> BatchResult:
    """The batch optimum of every factor of ``solver``, iterated from its estimate; ``solver`` is not changed.

    Gauss-Newton steps, each one update of a fresh solver with both thresholds 0 (module docstring), until
    the largest entry of a step is at most ``step_tolerance`` or ``max_updates`` updates have run. The
    result is a :class:`~steam_ref.batch.BatchResult` (``values``, ``converged``, ``reason``,
    ``stationarity``, one ``Iteration`` per update, and the covariance queries at the optimum, such as
    ``marginal_covariance(key)``); ``converged`` is True only when the step fell below the tolerance
    **and** :func:`~steam_ref.batch.check_stationarity` at the returned estimate found one more step would
    lower the cost by at most ``max(relative_tolerance * cost, absolute_tolerance)``. To go on updating
    from the optimum: ``IncrementalSolver(solver.params).update(list(result.factors), result.values)``.

    A solver that has marginalized variables (a :class:`~steam_ref.bayes_tree.FixedLagSmoother`) no longer
    holds the whole problem and is refused.
    """
    if not isinstance(solver, IncrementalSolver):
        raise SteamError(
            "this FixedLagSmoother marginalizes what leaves its window: it does not hold the whole problem, so it has "
            "no batch optimum to finish at"
            if isinstance(solver, FixedLagSmoother)
            else f"solver must be an IncrementalSolver, got solver={solver!r}"
        )
    check_options(
        step_tolerance=step_tolerance, relative_tolerance=relative_tolerance, absolute_tolerance=absolute_tolerance
    )
    if not is_integer(max_updates) or max_updates < 1:
        raise SteamError(f"max_updates must be an integer ≥ 1, got max_updates={max_updates!r}")
    factors = solver.factors
    if any(f is None for f in factors):
        raise SteamError(
            f"this {type(solver).__name__} has marginalized variables: it does not hold the whole problem, so it has "
            "no batch optimum to finish at"
        )
    graph, start = FactorGraph(factors), solver.estimate()
    backend, order, cost0 = prepare(graph, start, "amd", backend, max_updates)
    gauss_newton = IncrementalSolver(
        solver.params.replace(relinearize_threshold=0.0, relinearize_skip=1, wildfire_threshold=0.0)
    )
    iterations: list[Iteration] = []
    rule, values = "", start
    for i in range(max_updates):
        # the first update linearizes every factor at the start; each later one at the last estimate [YIB Eq. 9-11]
        if i == 0:
            gauss_newton.update(factors, start)
        else:
            gauss_newton.update()
        step = np.concatenate([d.ravel() for d in gauss_newton.delta().values()])
        values = gauss_newton.estimate().copy()
        iterations.append(Iteration(graph.error(values), float(np.linalg.norm(step))))
        largest = float(np.max(np.abs(step))) if step.size else 0.0
        if largest <= step_tolerance:
            rule = f"largest step entry {largest:.3g} below {step_tolerance:g}"
            break
    converged, reason, found = certify(
        graph, values, order, backend, rule, (relative_tolerance, absolute_tolerance), True
    )
    return BatchResult(values, cost0, iterations, converged, reason, order, 0, backend, found, tuple(factors))
