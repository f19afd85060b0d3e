"""Batch Gauss-Newton and Levenberg-Marquardt on the STEAM problem.  [YIB Eq. 6-11]

Each iteration linearizes every factor at θ̄ (Eq. 9), solves 𝓘 δθ* = Aᵀb (Eq. 11) by sparse Cholesky under the chosen
ordering ('xl': the paper's PB, 'amd': PBVR, 'natural'; :mod:`steam_ref.linear.ordering`; computed once), and updates
θ̄ ← θ̄ ⊕ δθ* by each variable's kind, as its factors declare it (:mod:`steam_ref.manifold`).

Iterations stop on GTSAM's rules (the cost, or its relative decrease, below a tolerance) or on a
small step. A stopping rule is not a proof, so before a result says ``converged`` the returned estimate is
checked (:func:`check_stationarity`): one more Gauss-Newton step from it must promise to lower the cost by no
more than the tolerance, and 𝓘 there must be well enough conditioned for float64 to compute that step at all.

It also declares the steps a solver built on them reuses (the internal API of :mod:`steam_ref.paper.converge`):
:func:`check_options`, :func:`graph_and_values` and :func:`prepare` (the checks and set-up both solvers share),
:func:`gauss_newton_step` (one step of Eq. 11) and :func:`certify` (the rule and check that decide ``converged``).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from functools import partial

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray

from .arguments import is_integer
from .covariance import SparseCovariances
from .errors import ConvergenceError, IllConditionedWarning, NumericalError, SteamError
from .factors import Factor
from .graph import FactorGraph
from .linear.cholesky import SparseCholesky, Symbolic
from .linear.ordering import Ordering, make_ordering, sparse_backend
from .linear.system import LinearSystem
from .linear.threads import limited
from .variables import Key, Values, as_values

__all__ = [
    "Iteration",
    "Stationarity",
    "BatchResult",
    "MAX_CONDITION",
    "check_stationarity",
    "gauss_newton",
    "levenberg_marquardt",
    "batch_solve",
    # internal API: the steps a solver built on these reuses (steam_ref.paper.converge)
    "check_options",
    "graph_and_values",
    "prepare",
    "gauss_newton_step",
    "certify",
]

# Largest condition number of the scaled information matrix for which a result may say "converged". Sparse
# Cholesky's relative error in the step is about cond · ε (ε = 2.2e-16 in float64) [Higham, Accuracy and Stability
# of Numerical Algorithms, Thm. 10.6 with van der Sluis's scaling]; at 1e12 that is 2e-4, still enough for the
# step to tell a stationary point from a slope. Beyond it the check itself cannot be trusted.
MAX_CONDITION = 1e12


@dataclass(frozen=True)
class Iteration:
    """What one iteration did."""

    cost: float  # cost ½Σρ after the iteration (before, for a rejected LM step)
    step_norm: float  # ‖δθ*‖₂ of the step tried
    damping: float = 0.0  # Levenberg-Marquardt λ used (0 for Gauss-Newton)
    accepted: bool = True  # False for a rejected LM step


@dataclass(frozen=True)
class Stationarity:
    """What :func:`check_stationarity` found at an estimate θ̄ (A, b linearized there, 𝓘 = AᵀA)."""

    cost: float  # the cost at θ̄
    predicted_decrease: float  # ½ (Aᵀb)ᵀ 𝓘⁻¹ (Aᵀb): what one more Gauss-Newton step would gain
    gradient_norm: float  # ‖Aᵀb‖∞, the cost's gradient (zero at a stationary point)
    condition: float  # 1-norm condition estimate of D^-½ 𝓘 D^-½, D = diag 𝓘 (units do not matter)

    @property
    def well_conditioned(self) -> bool:
        """Whether float64 resolves the Gauss-Newton step here (condition ≤ :data:`MAX_CONDITION`)."""
        return self.condition <= MAX_CONDITION

    def holds(self, relative_tolerance: float, absolute_tolerance: float) -> bool:
        """Well conditioned, and one more step would lower the cost by at most the tolerance."""
        return self.well_conditioned and self.predicted_decrease <= max(
            relative_tolerance * self.cost, absolute_tolerance
        )


@dataclass(frozen=True)
class BatchResult(SparseCovariances):
    """The outcome of a batch solve; ``marginal_covariance(key)`` and the other queries give blocks of 𝓘⁻¹ at
    ``values`` (:class:`~steam_ref.covariance.SparseCovariances`)."""

    values: Values  # final estimate
    initial_cost: float  # cost at the initial estimate
    iterations: list[Iteration] = field(default_factory=list, repr=False)  # one per iteration
    converged: bool = False  # a stopping rule was met AND the returned estimate passed the stationarity check
    reason: str = ""  # which rule stopped it, and what the check found
    ordering: Ordering | None = field(default=None, repr=False)  # elimination order used
    factor_nnz: int = 0  # nonzeros of the Cholesky factor under that ordering
    backend: str = ""  # sparse Cholesky backend
    stationarity: Stationarity | None = None  # the check at the returned estimate (None: not checked)
    factors: tuple[Factor, ...] = field(default=(), repr=False)  # the factors solved: the covariances' 𝓘

    @property
    def cost(self) -> float:
        """Final cost."""
        return self.iterations[-1].cost if self.iterations else self.initial_cost


def _step(
    graph: FactorGraph,
    values: Values,
    ordering: Ordering,
    backend: str,
    damping: float,
    symbolic: Symbolic | None = None,
) -> tuple[dict[Key, NDArray], float, int]:
    """Linearize, solve (𝓘 + λ diag 𝓘) δ = Aᵀb; return δ (ordered), cost at θ̄, factor nnz (``symbolic``: reused
    analysis, the pattern is the same at every iteration)."""
    groups = graph.batches().linearize(values)  # h(θ̄ + δθ) ≈ h(θ̄) + H δθ  [YIB Eq. 9]
    system = LinearSystem.from_groups(groups, ordering)
    info, rhs = system.information()  # 𝓘 = P⁻¹ + Hᵀ R⁻¹ H and b, whitened: AᵀA and Aᵀb  [YIB Eq. 11]
    if damping > 0:
        info = info + damping * sp.diags(info.diagonal())  # Marquardt's scaling: 𝓘 + λ diag 𝓘
    chol = SparseCholesky.factor(info.tocsc(), ordering, backend, check_symmetry=False, symbolic=symbolic)
    delta = chol.solve(rhs)  # 𝓘 δθ* = b by LLᵀ = 𝓘 and two triangular solves  [YIB Eq. 11]
    if not np.all(np.isfinite(delta)):
        bad = int(np.flatnonzero(~np.isfinite(delta))[0])
        key = ordering.keys[int(np.searchsorted(ordering.offsets, bad, side="right") - 1)]
        raise NumericalError(f"the Gauss-Newton step of {key!r} is not finite (the information matrix overflows)")
    return system.split(delta), sum(g.cost for g in groups), chol.nnz


def gauss_newton_step(
    graph: FactorGraph, values: Values, ordering: Ordering, backend: str
) -> tuple[Values, dict[Key, NDArray], float]:
    """Internal API. One Gauss-Newton step from ``values`` (Eq. 11): (θ̄ ⊕ δθ*, δθ* by key, the cost at θ̄)."""
    delta, cost, _ = _step(graph, values, ordering, backend, 0.0)
    return values.retract(delta), delta, cost  # θ̄ ⊕ δθ*  [YIB Eq. 9-11]


def _scaled_condition(info: sp.csc_matrix, chol: SparseCholesky) -> float:
    """1-norm condition estimate of S 𝓘 S, S = diag(𝓘)^-½, from the factor of 𝓘 [Higham & Tisseur 2000]."""
    s = 1.0 / np.sqrt(info.diagonal())
    scaled = sp.diags(s) @ info @ sp.diags(s)
    n = info.shape[0]
    apply = lambda v: chol.solve(np.ravel(v) / s) / s
    inverse = spla.LinearOperator((n, n), matvec=apply, rmatvec=apply, dtype=float)  # symmetric
    return float(abs(scaled).sum(axis=0).max() * spla.onenormest(inverse))


def check_stationarity(
    graph: FactorGraph | Iterable[Factor], values: Mapping, ordering: str | Ordering, backend: str | None = None
) -> Stationarity:
    """How far ``values`` is from a stationary point of the cost, and whether float64 can tell.

    Linearizes at θ̄ and computes the Gauss-Newton step δ = 𝓘⁻¹Aᵀb: its model decrease ½ (Aᵀb)ᵀδ is what one more
    iteration would gain, a scale-free measure of the gradient Aᵀb (zero exactly at a stationary point). The condition
    estimate says whether that step means anything. ``graph``, ``values`` and ``ordering`` (a name or an Ordering) as
    :func:`gauss_newton` takes them; a value no factor names is refused (the check would say nothing of it)."""
    graph, values = graph if isinstance(graph, FactorGraph) else FactorGraph(graph), as_values("values", values)
    if extra := set(values).difference(graph.keys()):
        raise SteamError(f"check_stationarity: variable {min(extra, key=repr)!r} has a value but no factor names it")
    backend = sparse_backend(backend)
    ordering = make_ordering(ordering, graph.keys(), values.dims(), [f.keys for f in graph], backend)
    groups = graph.batches().linearize(values)  # [YIB Eq. 9]
    info, rhs = LinearSystem.from_groups(groups, ordering).information()
    chol = SparseCholesky.factor(info, ordering, backend, check_symmetry=False)  # AᵀA  [YIB Eq. 11]
    delta = chol.solve(rhs)  # δθ* = 𝓘⁻¹ b  [YIB Eq. 11]
    gradient = float(np.max(np.abs(rhs))) if len(rhs) else 0.0
    return Stationarity(sum(g.cost for g in groups), 0.5 * float(rhs @ delta), gradient, _scaled_condition(info, chol))


def certify(
    graph: FactorGraph,
    values: Values,
    order: Ordering,
    backend: str,
    rule: str,
    tolerances: tuple[float, float],
    check: bool,
) -> tuple[bool, str, Stationarity | None]:
    """Internal API. (converged, reason, the check) for ``values``, where ``rule`` ('' for none: the
    iterations ran out) stopped the iterations; ``tolerances`` (relative, absolute) of the cost decrease
    one more step may promise; ``check`` False skips :func:`check_stationarity` (never ``converged``)."""
    if not check:
        return False, f"{rule or 'max_iterations'} (stationarity not checked)", None
    found = check_stationarity(graph, values, order, backend)
    if not found.well_conditioned:
        message = (
            f"{rule or 'max_iterations'}; the information matrix is too ill-conditioned to trust the answer: "
            f"condition ≈ {found.condition:.1e} > {MAX_CONDITION:.0e} (see docs/derivations.md, 'The smallest time gap')"
        )
        warnings.warn(message, IllConditionedWarning, stacklevel=3)
        return False, message, found
    tolerance = max(tolerances[0] * found.cost, tolerances[1])
    gain = (
        f"one more Gauss-Newton step would lower the cost by {found.predicted_decrease:.3g}, "
        f"{'within' if found.predicted_decrease <= tolerance else 'above'} the tolerance {tolerance:.3g} "
        f"(max of {tolerances[0]:g} × cost {found.cost:.6g} and {tolerances[1]:g}); condition ≈ {found.condition:.1e} ≤ {MAX_CONDITION:.0e}"
    )
    if not rule:
        return False, f"max_iterations: {gain}", found
    if not found.holds(*tolerances):
        return False, f"{rule}, but {gain}: not a stationary point", found
    return True, f"{rule}; stationary: {gain}", found


def check_options(**options: object) -> None:
    """Internal API. Every tolerance and damping option a finite number ≥ 0 (the damping ones > 0), named on failure."""
    for name, value in options.items():
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float, np.integer, np.floating))
            or not math.isfinite(value)
            or value < 0
        ):
            raise SteamError(f"{name} must be a finite number ≥ 0, got {value!r}")
        if name in ("initial_damping", "max_damping") and value == 0:
            raise SteamError(f"{name} must be > 0, got {value!r}")
        if name == "damping_factor" and value <= 1:
            raise SteamError(f"damping_factor must be > 1, got {value!r}")


def graph_and_values(
    graph: FactorGraph | Iterable[Factor], initial: Values | Mapping[Key, NDArray]
) -> tuple[FactorGraph, Values]:
    """Internal API. The graph (a FactorGraph, or any iterable of factors) and the initial estimate (a Values or a
    mapping), each variable of the kind its factors declare (:class:`~steam_ref.errors.KindError` if any disagree)."""
    graph = graph if isinstance(graph, FactorGraph) else FactorGraph(graph)
    return graph, graph.with_kinds(as_values("initial", initial))


def prepare(
    graph: FactorGraph, initial: Values, ordering: str | Ordering, backend: str | None, max_iterations: object
) -> tuple[str, Ordering, float]:
    """Internal API. The checks both solvers share (the graph and estimates, the backend); returns
    (backend, the ordering of the graph's variables, the cost at ``initial``)."""
    if not is_integer(max_iterations) or max_iterations < 0:
        raise SteamError(f"max_iterations must be an integer ≥ 0, got {max_iterations!r}")
    if len(graph) == 0:
        raise SteamError("the factor graph is empty: there is nothing to solve")
    backend = sparse_backend(backend)
    graph.check_values(initial)
    named = set(graph.keys())
    unconstrained = [k for k in initial if k not in named]
    if unconstrained:
        raise SteamError(
            f"variable {unconstrained[0]!r} has an initial value but no factor names it, so nothing estimates it"
        )
    order = make_ordering(ordering, graph.keys(), initial.dims(), [f.keys for f in graph], backend)
    return backend, order, graph.error(initial)


def _converged(old: float, new: float, step: float, rtol: float, atol: float, steptol: float, undamped=None) -> str:
    """The rule that stops the iterations, or "" (a damped step: when ``undamped()``, the step at λ = 0, is short too)."""
    if new <= atol:
        return f"cost {new:.3g} below absolute tolerance {atol:g}"
    if abs(old - new) <= rtol * max(old, 1e-300):
        return f"relative cost decrease {abs(old - new) / max(old, 1e-300):.3g} below {rtol:g}"
    if step <= steptol and (undamped is None or (gn := _norm(undamped()[0])) <= steptol):
        return f"step norm {step:.3g} below {steptol:g}" + (f", Gauss-Newton's {gn:.3g} too" if undamped else "")
    return ""


def _norm(delta: dict[Key, NDArray]) -> float:
    return float(np.sqrt(sum(float(v @ v) for v in delta.values())))


@limited
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
    check: bool = True,
    verbose: bool = False,
) -> BatchResult:
    """Gauss-Newton: θ̄ ← θ̄ ⊕ δθ* with δθ* from Eq. 11, until a stopping rule holds.

    ``graph``: a FactorGraph or any iterable of factors; ``initial``: a Values or any mapping key → vector.

    Stops when the cost falls below ``absolute_tolerance``, decreases by less than
    ``relative_tolerance`` times itself, or the step norm is below ``step_tolerance``. With ``check``
    (the default) the result is ``converged`` only if the returned estimate also passes
    :func:`check_stationarity` with the same tolerances (one more linearization and factorization);
    an ill-conditioned system gives an :class:`~steam_ref.errors.IllConditionedWarning`. A NaN or inf
    anywhere raises :class:`~steam_ref.errors.NumericalError` naming the factor or variable.
    """
    check_options(
        relative_tolerance=relative_tolerance, absolute_tolerance=absolute_tolerance, step_tolerance=step_tolerance
    )
    graph, initial = graph_and_values(graph, initial)
    backend, order, cost0 = prepare(graph, initial, ordering, backend, max_iterations)
    iterations: list[Iteration] = []
    values, rule, nnz, cost, symbolic = initial.copy(), "", 0, cost0, Symbolic()  # one pattern: analysed once
    for _ in range(max_iterations):
        delta, _, nnz = _step(graph, values, order, backend, 0.0, symbolic)
        values = values.retract(delta)  # θ̄ ← θ̄ ⊕ δθ*  [YIB Eq. 9-11]
        new_cost = graph.error(values)
        step = _norm(delta)
        iterations.append(Iteration(new_cost, step))
        if verbose:
            print(f"GN {len(iterations):3d}: cost {new_cost:.9g}  |step| {step:.3g}")
        rule = _converged(cost, new_cost, step, relative_tolerance, absolute_tolerance, step_tolerance)
        cost = new_cost
        if rule:
            break
    tolerances = (relative_tolerance, absolute_tolerance)
    converged, reason, found = certify(graph, values, order, backend, rule, tolerances, check)
    return BatchResult(values, cost0, iterations, converged, reason, order, nnz, backend, found, tuple(graph))


@limited
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
    check: bool = True,
    verbose: bool = False,
) -> BatchResult:
    """Levenberg-Marquardt with Marquardt's scaling: (𝓘 + λ diag 𝓘) δ = Aᵀb.

    A step that lowers the cost is taken and λ divided by ``damping_factor``; otherwise λ is multiplied by it and
    the step retried. Stops on the Gauss-Newton rules, judged on the steps taken, a short one only if the Gauss-Newton
    step (λ = 0) from where it led is short too: a damped step's length is the trust region's radius, not the distance
    to a minimum [Nocedal & Wright 2006, §10.3; Madsen, Nielsen & Tingleff 2004, §3.2]; or when λ exceeds
    ``max_damping`` (no step lowers the cost). ``converged`` as in :func:`gauss_newton`.
    """
    check_options(
        relative_tolerance=relative_tolerance,
        absolute_tolerance=absolute_tolerance,
        step_tolerance=step_tolerance,
        initial_damping=initial_damping,
        damping_factor=damping_factor,
        max_damping=max_damping,
    )
    graph, initial = graph_and_values(graph, initial)
    backend, order, cost0 = prepare(graph, initial, ordering, backend, max_iterations)
    iterations: list[Iteration] = []
    values, rule, nnz, lam, cost, symbolic = initial.copy(), "", 0, initial_damping, cost0, Symbolic()
    while len(iterations) < max_iterations and not rule:
        delta, _, nnz = _step(graph, values, order, backend, lam, symbolic)
        trial = values.retract(delta)
        new_cost = graph.error(trial)
        step = _norm(delta)
        accepted = new_cost < cost
        iterations.append(Iteration(new_cost if accepted else cost, step, lam, accepted))
        if verbose:
            print(f"LM {len(iterations):3d}: cost {new_cost:.9g} λ {lam:.1e} {'ok' if accepted else 'rejected'}")
        if accepted:
            undamped = partial(_step, graph, trial, order, backend, 0.0, symbolic)  # one more factorization
            rule = _converged(cost, new_cost, step, relative_tolerance, absolute_tolerance, step_tolerance, undamped)
            values, cost, lam = trial, new_cost, max(lam / damping_factor, 1e-12)
        else:
            lam *= damping_factor
            if lam > max_damping:
                rule = f"damping {lam:.1e} above {max_damping:.1e}: no step lowers the cost"
    tolerances = (relative_tolerance, absolute_tolerance)
    converged, reason, found = certify(graph, values, order, backend, rule, tolerances, check)
    return BatchResult(values, cost0, iterations, converged, reason, order, nnz, backend, found, tuple(graph))


def batch_solve(graph: FactorGraph, initial: Values, *, method: str = "gn", **options) -> Values:
    """The MAP estimate of Eq. 6 by Gauss-Newton ('gn') or Levenberg-Marquardt ('lm').

    Raises :class:`~steam_ref.errors.ConvergenceError` unless the result is ``converged`` (checked):
    this short form returns only the estimate, so it returns only one it has checked.
    """
    if method == "gn":
        result = gauss_newton(graph, initial, **options)
    elif method == "lm":
        result = levenberg_marquardt(graph, initial, **options)
    else:
        raise SteamError(f"unknown method {method!r}; use 'gn' or 'lm'")
    if not result.converged:
        raise ConvergenceError(f"{method.upper()} did not converge: {result.reason}")
    return result.values
