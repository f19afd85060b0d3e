"""Finish an incremental solve at the batch optimum of all its factors.  [YIB Eq. 6-11, Alg. 1]

iSAM2 moves a variable's linearization point θ̄ only when its increment reaches the threshold β
(``relinearize_threshold``, 0.1 by default) and only every ``relinearize_skip``-th update, so its estimate
θ̄ + δ is the solution of a system linearized where each variable last moved: it may rest up to about β
from the optimum (on a toy problem with GTSAM's defaults, about a centimetre). Updates with no new factors do
not close that gap, because a δ below β never moves θ̄.

:func:`finish_at_optimum` closes it with the solver's public API only: it runs the batch's Gauss-Newton
(:func:`~steam_ref.batch.gauss_newton`) on every factor of the solver from the solver's estimate, with the batch's
stopping rules and its check (:func:`~steam_ref.batch.check_stationarity`), so it certifies exactly the optimum
the batch certifies from there. A rule on the step alone (the largest entry below an absolute 1e-9, its
rule before) would not do: with a vector-space prior Gauss-Newton closes the whole map's turn only linearly,
each step a fixed fraction of the way (docs/derivations.md §9), so on a figure-eight with sharp turns it ran out
of iterations (50, the step 0.8 times the one before) long after the batch's check had passed. When the
iterations run out, the reason says how far the estimate is (what one more step would gain, against the
tolerance) and how fast the steps were shrinking.
"""

from __future__ import annotations

import dataclasses

from .arguments import is_integer
from .batch import BatchResult, check_options, gauss_newton
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

    Exactly :func:`~steam_ref.batch.gauss_newton` on ``solver.factors`` from ``solver.estimate()`` (AMD
    ordering, at most ``max_updates`` iterations): it stops when the cost falls below ``absolute_tolerance``,
    decreases by less than ``relative_tolerance`` times itself, or the step's norm falls below
    ``step_tolerance``, and ``converged`` is True only when one of those held **and**
    :func:`~steam_ref.batch.check_stationarity` at the returned estimate found that one more Gauss-Newton step
    would lower the cost by at most ``max(relative_tolerance * cost, absolute_tolerance)``, in a system well
    enough conditioned to tell. ``reason`` says which rule stopped it and what the check found; when the
    iterations ran out, also how fast the steps were shrinking. For an optimum tighter than the batch's, lower
    ``relative_tolerance`` (e.g. 1e-15) and ``step_tolerance``. The result is a
    :class:`~steam_ref.batch.BatchResult` (``values``, ``iterations``, ``stationarity``, the covariance queries
    at the optimum, such as ``marginal_covariance(key)``). To go on updating from the optimum:
    ``IncrementalSolver(solver.params).update(list(result.factors), result.values)``.

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
    if not factors:
        raise SteamError("the factor graph is empty: there is nothing to solve")
    result = gauss_newton(
        FactorGraph(factors),
        solver.estimate(),
        ordering="amd",
        max_iterations=max_updates,
        relative_tolerance=relative_tolerance,
        absolute_tolerance=absolute_tolerance,
        step_tolerance=step_tolerance,
        backend=backend,
    )
    steps = [it.step_norm for it in result.iterations]
    if result.converged or len(steps) < 2 or not steps[-2] > 0:
        return result
    rate = steps[-1] / steps[-2]  # Gauss-Newton along the map's turn: a fixed fraction per step (derivations §9)
    return dataclasses.replace(
        result,
        reason=f"{result.reason}; the last step's norm was {steps[-1]:.2g}, {rate:.2f} times the one before"
        + (" (linear convergence: docs/derivations.md §9; raise max_updates)" if 0.1 < rate < 1 else ""),
    )
