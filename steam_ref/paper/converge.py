"""The batch optimum when only a weak prior fixes which way the map points: Gauss-Newton with an exact
line search along the global turn, and Anderson acceleration.

Where nothing is surveyed (Victoria Park), only the prior on pose 0 (heading σ = π) fixes the map's
orientation: turning the whole estimate about the origin (:func:`rotated`: positions, velocities,
accelerations and landmarks rotated, headings shifted) changes no other factor's cost. The cost is
nearly flat along that turn (curvature 1/π² per rad²), but each GP prior factor's error vector turns
with the map, so Gauss-Newton's model, which keeps only the first-order change of each error, has
curvature Σ‖W e⊥‖² over the GP prior factors along the turn's tangent; the second-order change of the
odometry and sighting errors, which it drops, cancels that (docs/derivations.md §9). Where the model's
curvature is many times the cost's own, each step goes a small fraction of the way round, and a stopping
rule on the cost stops Gauss-Newton with the map still turned from the optimum, far from it at a distance
from the origin (Victoria Park's figures: docs/experiments.md). A straight line leaves the turn, so
:func:`converge`

1. takes a Gauss-Newton step (Eq. 11),
2. turns the result by the angle that minimizes the cost along the turn itself: an exact line search
   (Brent) on the few factors the turn changes, :func:`anchored_factors`, found once by turning the
   start; the turn is kept only if the whole cost falls,
3. mixes the last few iterates by Anderson acceleration (:class:`Anderson`), kept only if that lowers
   the cost again: what remains after the turn is a slow bend of the map that Gauss-Newton closes a
   little at each step,

until no variable moves by more than ``step_tolerance``, and then checks the estimate's stationarity as
:func:`~steam_ref.batch.gauss_newton` does. How many iterations and seconds that takes on Victoria Park,
against plain Gauss-Newton alternated with the line search, is measured in docs/experiments.md.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from ..arguments import integer
from ..batch import BatchResult, Iteration, certify, check_options, gauss_newton_step, graph_and_values, prepare
from ..errors import NumericalError, SteamError
from ..graph import FactorGraph
from ..linear.ordering import Ordering
from ..linear.threads import limited
from ..manifold import VECTOR
from ..motion import turned_state
from ..variables import Values

__all__ = ["converge", "rotated", "anchored_factors", "Anderson", "PROBE_TURN"]

PROBE_TURN = 0.1  # [rad] the turn that tells anchored factors from the rest (any angle not a multiple of 2π would do)


def rotated(values: Values, angle: float) -> Values:
    """The whole estimate turned by ``angle`` about the origin: each state as its prior turns it
    (:func:`~steam_ref.motion.turned_state`: positions rotated, headings shifted, a world-frame velocity
    rotated, a body twist kept) and landmarks rotated. Every factor but a prior on an absolute pose,
    velocity or landmark is unchanged by it: the near-symmetry :func:`converge` follows."""
    c, s = np.cos(angle), np.sin(angle)
    out = Values()
    for k in values:
        x, kind = np.array(values[k], dtype=float), values.kind(k)
        if k.symbol == "x":  # a state of the motion prior
            out.insert(k, turned_state(x, kind, angle), kind)
            continue
        x[0], x[1] = c * x[0] - s * x[1], s * x[0] + c * x[1]  # a landmark [x, y]
        out.insert(k, x, kind)
    return out


def anchored_factors(graph: FactorGraph, values: Values) -> FactorGraph:
    """The factors whose whitened error norm changes when the estimate is turned (:func:`rotated`) by
    :data:`PROBE_TURN`: priors on absolute poses, velocities and landmarks, and GP priors whose Qc is not
    the same in x and y. The cost along the turn is theirs plus a constant."""
    turned = rotated(values, PROBE_TURN)
    anchored = []
    for f in graph:
        before = np.linalg.norm(f.whitened_error(*[values[k] for k in f.keys]))
        after = np.linalg.norm(f.whitened_error(*[turned[k] for k in f.keys]))
        if abs(after - before) > 1e-9 * (1.0 + before):
            anchored.append(f)
    return FactorGraph(anchored)


class Anderson:
    """Anderson acceleration of a fixed-point iteration x ← g(x) [Walker & Ni, SIAM J. Numer. Anal. 49(4),
    2011, 'type II']: from the last ``memory`` iterates gₖ and residuals fₖ = gₖ − xₖ, the next iterate
    is gₖ − ΔG γ with γ = argmin ‖fₖ − ΔF γ‖ (ΔF, ΔG the columns of successive differences). On a linear
    map it is GMRES on (I − G); on a slowly converging nonlinear one it extrapolates the slow direction."""

    def __init__(self, memory: int):
        self.memory = integer("memory", memory, 1)
        self.g: list[NDArray] = []
        self.f: list[NDArray] = []

    def reset(self) -> None:
        """Forget the history (after an extrapolation that did not help)."""
        self.g, self.f = self.g[-1:], self.f[-1:]

    def next(self, g: NDArray, f: NDArray) -> NDArray:
        """The accelerated iterate from g = g(x) and f = g(x) − x."""
        self.g, self.f = (self.g + [g])[-(self.memory + 1) :], (self.f + [f])[-(self.memory + 1) :]
        if len(self.f) == 1:
            return g
        dF = np.diff(np.array(self.f), axis=0).T
        dG = np.diff(np.array(self.g), axis=0).T
        gamma = np.linalg.lstsq(dF, f, rcond=None)[0]
        return g - dG @ gamma


class _Layout:
    """Values ↔ one vector, in a fixed key order (for :class:`Anderson`): a vector variable as it is, a variable
    of another kind (an SE(2) state) in the chart x ⊖ x₀ about its value x₀ at the start."""

    def __init__(self, values: Values):
        self.keys = list(values)
        self.cuts = np.cumsum([0] + [values.dim(k) for k in self.keys])
        self.kinds = {k: m for k, m in values.kinds().items() if m is not VECTOR}  # a vector as it is
        self.base = {k: values[k] for k in self.kinds}

    def vector(self, values: Values) -> NDArray:
        return np.concatenate(
            [values[k] if k not in self.kinds else self.kinds[k].local(self.base[k], values[k]) for k in self.keys]
        )

    def values(self, x: NDArray) -> Values:
        out = Values({k: x[a:b].copy() for k, a, b in zip(self.keys, self.cuts[:-1], self.cuts[1:], strict=True)})
        for k, kind in self.kinds.items():
            out.insert(k, kind.retract(self.base[k], out[k]), kind)
        return out


def _best_turn(graph: FactorGraph, anchored: FactorGraph, values: Values, cost: float) -> tuple[Values, float, float]:
    """(estimate, cost, angle): ``values`` turned by the angle that minimizes the cost along the turn, if
    that lowers the whole cost; else ``values`` unchanged (angle 0)."""
    if len(anchored) == 0:  # nothing fixes the orientation: every turn costs the same
        return values, cost, 0.0
    import scipy.optimize  # loaded here, a quarter second that only this search needs (every stream loads the module)

    anchor_keys = anchored.keys()
    at = Values({k: values[k] for k in anchor_keys})
    found = scipy.optimize.minimize_scalar(lambda a: anchored.error(rotated(at, a)), bracket=(-1e-3, 1e-3), tol=1e-12)
    if not np.isfinite(found.x) or found.x == 0.0:
        return values, cost, 0.0
    turned = rotated(values, float(found.x))
    turned_cost = graph.error(turned)
    if turned_cost < cost:
        return turned, turned_cost, float(found.x)
    return values, cost, 0.0


@limited
def converge(
    graph: FactorGraph,
    initial: Values,
    *,
    step_tolerance: float = 1e-6,
    max_iterations: int = 100,
    memory: int = 5,
    relative_tolerance: float = 1e-10,
    ordering: str | Ordering = "amd",
    backend: str | None = None,
) -> BatchResult:
    """The minimum of ``graph``'s cost near ``initial``, when a weak prior is all that fixes the map's
    orientation (see the module docstring): Gauss-Newton, an exact line search along the turn, Anderson
    acceleration (``memory`` iterates).

    Stops when no variable moves by more than ``step_tolerance`` in an iteration (the ∞-norm of the
    fixed-point residual; :class:`~steam_ref.batch.Iteration` records its 2-norm) or after
    ``max_iterations``; the result is ``converged`` only if it also passes
    :func:`~steam_ref.batch.check_stationarity`: one more Gauss-Newton step would lower the cost by at
    most ``relative_tolerance`` times itself.
    """
    check_options(step_tolerance=step_tolerance, relative_tolerance=relative_tolerance)
    if step_tolerance == 0:
        raise SteamError("step_tolerance must be > 0, got 0")
    integer("max_iterations", max_iterations, 1)
    graph, values = graph_and_values(graph, initial)
    backend, order, cost0 = prepare(graph, values, ordering, backend, max_iterations)
    anchored = anchored_factors(graph, values)
    layout, mixer = _Layout(values), Anderson(memory)
    iterations: list[Iteration] = []
    cost, rule = cost0, ""
    for _ in range(max_iterations):
        stepped, _, _ = gauss_newton_step(graph, values, order, backend)
        stepped, stepped_cost, _ = _best_turn(graph, anchored, stepped, graph.error(stepped))
        g = layout.vector(stepped)
        residual = g - layout.vector(values)
        mixed = layout.values(mixer.next(g, residual))
        mixed_cost = graph.error(mixed)
        if mixed_cost < stepped_cost:
            values, cost = mixed, mixed_cost
        else:
            values, cost = stepped, stepped_cost
            mixer.reset()
        iterations.append(Iteration(cost, float(np.linalg.norm(residual))))
        largest = float(np.max(np.abs(residual)))
        if largest <= step_tolerance:
            rule = f"largest move {largest:.3g} below {step_tolerance:g}"
            break
    if not np.isfinite(cost):
        raise NumericalError(f"converge: the cost became {cost} (the start is too far from a minimum)")
    converged, reason, found = certify(graph, values, order, backend, rule, (relative_tolerance, 0.0), True)
    return BatchResult(values, cost0, iterations, converged, reason, order, 0, backend, found, tuple(graph))
