"""Batch Gauss-Newton and Levenberg-Marquardt on the STEAM problem.  [YIB Eq. 6-11]

Each iteration linearizes every factor at θ̄ (Eq. 9), solves 𝓘 δθ* = Aᵀb (Eq. 11) by sparse
Cholesky under the chosen ordering ('xl': the paper's PB, 'amd': PBVR, 'natural'; see
:mod:`steam_ref.linear.ordering`), and updates
θ̄ ← θ̄ + δθ*. The ordering depends only on which variables share factors, so it is computed once.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from .errors import SteamError
from .graph import FactorGraph
from .variables import Values
from .linear import ordering as linear_ordering
from .linear.ordering import Ordering, sparse_backend
from .linear.solve import SparseCholesky
from .linear.system import LinearSystem, linearize

__all__ = ["Iteration", "BatchResult", "make_ordering", "gauss_newton", "levenberg_marquardt", "batch_solve"]


@dataclass(frozen=True)
class Iteration:
    """What one iteration did."""

    cost: float  # cost ½Σρ after the iteration (before, for a rejected LM step)
    step_norm: float  # ‖δθ*‖₂ of the step tried
    damping: float = 0.0  # Levenberg-Marquardt λ used (0 for Gauss-Newton)
    accepted: bool = True  # False for a rejected LM step


@dataclass(frozen=True)
class BatchResult:
    """The outcome of a batch solve."""

    values: Values  # final estimate
    initial_cost: float  # cost at the initial estimate
    iterations: list[Iteration] = field(default_factory=list)  # one per iteration
    converged: bool = False  # a stopping rule was met before max_iterations
    reason: str = ""  # which rule stopped it
    ordering: Ordering | None = None  # elimination order used
    factor_nnz: int = 0  # nonzeros of the Cholesky factor under that ordering
    backend: str = ""  # sparse Cholesky backend

    @property
    def cost(self) -> float:
        """Final cost."""
        return self.iterations[-1].cost if self.iterations else self.initial_cost


def make_ordering(graph: FactorGraph, values: Values, ordering: str | Ordering, backend: str | None = None) -> Ordering:
    """:func:`steam_ref.linear.ordering.make_ordering` for the variables of ``graph`` (first-seen order)."""
    keys = graph.keys()
    dims = {k: values.dim(k) for k in keys}
    return linear_ordering.make_ordering(ordering, keys, dims, (f.keys for f in graph), backend)


def _step(graph: FactorGraph, values: Values, ordering: Ordering, backend: str, damping: float):
    """Linearize, solve (𝓘 + λ diag 𝓘) δ = Aᵀb; return δ (ordered), cost at θ̄, factor nnz."""
    groups = linearize(graph.factors, values)
    system = LinearSystem.from_groups(groups, ordering)
    info, rhs = system.information()
    if damping > 0:
        info = info + damping * sp.diags(info.diagonal())
    chol = SparseCholesky.factor(info.tocsc(), ordering, backend)
    return system.split(chol.solve(rhs)), sum(g.cost for g in groups), chol.nnz


def _prepare(graph: FactorGraph, initial: Values, ordering: str | Ordering, backend: str | None) -> tuple[str, Ordering, float]:
    """Checks shared by both solvers: the backend, the estimates' sizes, the ordering, the start cost."""
    backend = sparse_backend(backend)
    graph.check_values(initial)
    return backend, make_ordering(graph, initial, ordering, backend), graph.error(initial)


def _converged(old: float, new: float, step: float, rtol: float, atol: float, steptol: float) -> str:
    if new <= atol:
        return f"cost {new:.3g} below absolute tolerance {atol:g}"
    if abs(old - new) <= rtol * max(old, 1e-300):
        return f"relative cost decrease {abs(old - new) / max(old, 1e-300):.3g} below {rtol:g}"
    if step <= steptol:
        return f"step norm {step:.3g} below {steptol:g}"
    return ""


def gauss_newton(
    graph: FactorGraph,
    initial: Values,
    *,
    ordering: str | Ordering = "amd",
    max_iterations: int = 50,
    relative_tolerance: float = 1e-8,
    absolute_tolerance: float = 1e-12,
    step_tolerance: float = 1e-9,
    backend: str | None = None,
    verbose: bool = False,
) -> BatchResult:
    """Gauss-Newton: θ̄ ← θ̄ + δθ* with δθ* from Eq. 11, until a stopping rule holds.

    Stops when the cost falls below ``absolute_tolerance``, decreases by less than
    ``relative_tolerance`` times itself, or the step norm is below ``step_tolerance``.
    """
    backend, order, cost0 = _prepare(graph, initial, ordering, backend)
    values, iterations, reason, nnz, cost = initial.copy(), [], "", 0, cost0
    for _ in range(max_iterations):
        delta, _, nnz = _step(graph, values, order, backend, 0.0)
        values = values.retract(delta)
        new_cost = graph.error(values)
        step = float(np.sqrt(sum(float(v @ v) for v in delta.values())))
        iterations.append(Iteration(new_cost, step))
        if verbose:
            print(f"GN {len(iterations):3d}: cost {new_cost:.9g}  |step| {step:.3g}")
        reason = _converged(cost, new_cost, step, relative_tolerance, absolute_tolerance, step_tolerance)
        cost = new_cost
        if reason:
            break
    return BatchResult(values, cost0, iterations, bool(reason), reason or "max_iterations", order, nnz, backend)


def levenberg_marquardt(
    graph: FactorGraph,
    initial: Values,
    *,
    ordering: str | Ordering = "amd",
    max_iterations: int = 100,
    relative_tolerance: float = 1e-8,
    absolute_tolerance: float = 1e-12,
    step_tolerance: float = 1e-9,
    initial_damping: float = 1e-5,
    damping_factor: float = 10.0,
    max_damping: float = 1e10,
    backend: str | None = None,
    verbose: bool = False,
) -> BatchResult:
    """Levenberg-Marquardt with Marquardt's scaling: (𝓘 + λ diag 𝓘) δ = Aᵀb.

    A step that lowers the cost is taken and λ divided by ``damping_factor``; otherwise λ is
    multiplied by it and the step retried. Stops on the Gauss-Newton rules, or when λ exceeds
    ``max_damping``.
    """
    backend, order, cost0 = _prepare(graph, initial, ordering, backend)
    values, iterations, reason, nnz, lam, cost = initial.copy(), [], "", 0, initial_damping, cost0
    while len(iterations) < max_iterations and not reason:
        delta, _, nnz = _step(graph, values, order, backend, lam)
        trial = values.retract(delta)
        new_cost = graph.error(trial)
        step = float(np.sqrt(sum(float(v @ v) for v in delta.values())))
        accepted = new_cost < cost
        iterations.append(Iteration(new_cost if accepted else cost, step, lam, accepted))
        if verbose:
            print(f"LM {len(iterations):3d}: cost {new_cost:.9g} λ {lam:.1e} {'ok' if accepted else 'rejected'}")
        if accepted:
            reason = _converged(cost, new_cost, step, relative_tolerance, absolute_tolerance, step_tolerance)
            values, cost, lam = trial, new_cost, max(lam / damping_factor, 1e-12)
        else:
            lam *= damping_factor
            if lam > max_damping:
                reason = f"damping {lam:.1e} above {max_damping:.1e}: no step lowers the cost"
    return BatchResult(values, cost0, iterations, bool(reason), reason or "max_iterations", order, nnz, backend)


def batch_solve(graph: FactorGraph, initial: Values, *, method: str = "gn", **options) -> Values:
    """The MAP estimate of Eq. 6 by Gauss-Newton ('gn') or Levenberg-Marquardt ('lm')."""
    if method == "gn":
        return gauss_newton(graph, initial, **options).values
    if method == "lm":
        return levenberg_marquardt(graph, initial, **options).values
    raise SteamError(f"unknown method {method!r}; use 'gn' or 'lm'")
