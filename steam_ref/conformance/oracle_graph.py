"""Independent expected values for whole problems: dense linear algebra, written from the definitions.

A problem is given in the kit's own format: ``variables`` (key → size, in a natural order),
``factors`` (specs, see :mod:`.oracle`) and ``values`` (key → vector). Everything is dense NumPy:

- A, b stacked in factor order, columns in a given ordering [YIB Eq. 9-11, 21]; 𝓘 = AᵀA, Aᵀb;
- R: the upper Cholesky factor of 𝓘 (positive diagonal), d = R⁻ᵀAᵀb, δ = R⁻¹d [YIB Eq. 11, 21];
- Gauss-Newton iterates θ ← θ ⊕ δ from a start [YIB Eq. 6-11], in a :class:`Space`: the vector space
  (θ + δ, complex-step Jacobians) or another's retraction and linearization (:data:`.oracle_lie.LIE`);
- the cliques of an elimination order: the elimination game and the clique rule of [K12 Alg. 1-2],
  written here a second time; each clique's conditional read off the dense R [YIB Eq. 25];
- covariances: blocks of the dense 𝓘⁻¹;
- a stream of updates: per-variable linearization points moved when max|δ| reaches the threshold,
  every factor linearized at them, a dense solve per update (threshold 0: one Gauss-Newton step on
  all factors so far per update; inf: the linear solve at the first linearization point), in a :class:`Space`.

Only NumPy/SciPy and :mod:`.oracle` are used: none of steam_ref's linear algebra or solvers.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from .oracle import linearize_factor

__all__ = [
    "Space",
    "VECTOR",
    "Problem",
    "dense_system",
    "factorize",
    "gauss_newton",
    "cliques",
    "conditionals",
    "covariances",
    "stream",
]


@dataclass(frozen=True)
class Space:
    """Where a problem's variables live, for the oracle's solvers: how a variable moves by a step δ (``retract``:
    x ⊕ δ), what a factor spec linearized at its variables' values is (``linearize``: a dict with ``A_k`` per
    key, ``b`` and ``cost``, as :func:`.oracle.linearize_factor` returns it), and the step from x₀ to x
    (``local``: x ⊖ x₀, the inverse of ``retract``; a frozen marginal factor's shift, :mod:`.oracle_lag`)."""

    retract: Callable[[NDArray, NDArray], NDArray]
    linearize: Callable[..., Mapping]
    local: Callable[[NDArray, NDArray], NDArray] = lambda x0, x: x - x0


VECTOR = Space(lambda x, delta: x + delta, linearize_factor)  # θ + δ; Jacobians by complex steps


class Problem:
    """A problem spec: variables (key → size), factor specs, values (key → vector)."""

    def __init__(self, spec: Mapping):
        self.dims = {k: int(n) for k, n in spec["variables"].items()}
        self.factors = list(spec["factors"])
        self.values = {k: np.asarray(v, float) for k, v in spec.get("values", {}).items()}

    def offsets(self, order: Sequence[str]) -> dict[str, int]:
        """First column of each variable under ``order``."""
        out, o = {}, 0
        for k in order:
            out[k] = o
            o += self.dims[k]
        return out


def dense_system(
    problem: Problem,
    values: Mapping[str, NDArray],
    order: Sequence[str],
    space: Space = VECTOR,
    **conventions: bool,
) -> tuple[NDArray, NDArray, float]:
    """Dense A (rows in factor order, columns in ``order``), b and the cost at ``values``, each factor linearized
    by ``space``.

    ``conventions``: ``paper_sign``, ``symmetric`` of :func:`.oracle.linearize_factor` (the vector space's).
    """
    off = problem.offsets(order)
    n = sum(problem.dims[k] for k in order)
    rows, rhs, cost = [], [], 0.0
    for spec in problem.factors:
        lin = space.linearize(spec, [values[k] for k in spec["keys"]], **conventions)
        block = np.zeros((len(lin["b"]), n))
        for slot, key in enumerate(spec["keys"]):
            block[:, off[key] : off[key] + problem.dims[key]] = lin[f"A_{slot}"]
        rows.append(block)
        rhs.append(lin["b"])
        cost += lin["cost"]
    return np.vstack(rows), np.concatenate(rhs), cost


def factorize(A: NDArray, b: NDArray) -> dict[str, NDArray]:
    """𝓘 = AᵀA, Aᵀb, R (upper, positive diagonal, RᵀR = 𝓘), d = R⁻ᵀAᵀb and δ = 𝓘⁻¹Aᵀb."""
    info, rhs = A.T @ A, A.T @ b
    R = np.linalg.cholesky(info).T
    d = scipy.linalg.solve_triangular(R, rhs, trans="T", lower=False)
    delta = scipy.linalg.solve_triangular(R, d, lower=False)
    return {"information": info, "rhs": rhs, "R": R, "d": d, "delta": delta}


def _split(problem: Problem, order: Sequence[str], x: NDArray) -> dict[str, NDArray]:
    off = problem.offsets(order)
    return {k: x[off[k] : off[k] + problem.dims[k]] for k in order}


def gauss_newton(
    problem: Problem, order: Sequence[str], iterations: int, space: Space = VECTOR
) -> tuple[list[dict[str, NDArray]], list[float]]:
    """The start and ``iterations`` Gauss-Newton iterates θ ← θ ⊕ δ in ``space``, and the cost at each."""
    values = dict(problem.values)
    iterates, costs = [values], []
    for _ in range(iterations):
        A, b, cost = dense_system(problem, values, order, space)
        costs.append(cost)
        step = _split(problem, order, factorize(A, b)["delta"])
        values = {k: space.retract(values[k], step[k]) for k in order}
        iterates.append(values)
    costs.append(dense_system(problem, values, order, space)[2])
    return iterates, costs


def cliques(order: Sequence[str], factor_keys: Sequence[Sequence[str]]) -> list[dict]:
    """Cliques of eliminating in ``order``: frontals, separator (both in elimination order), parent.

    The elimination game gives each variable's separator sᵢ; walking the order backwards, a variable
    whose separator is exactly the variables of its parent's clique joins that clique, any other starts
    a new clique under it [K12 Alg. 1-2]. The parent is named by its first frontal; cliques are listed
    by the position of their first frontal.
    """
    pos = {k: i for i, k in enumerate(order)}
    adj: dict[str, set] = {k: set() for k in order}
    for keys in factor_keys:
        for k in keys:
            adj[k].update(set(keys) - {k})
    sep = {}
    for v in order:  # eliminate v: its later neighbours become a clique (fill)
        later = sorted((u for u in adj[v] if pos[u] > pos[v]), key=lambda u: pos[u])
        sep[v] = later
        for u in later:
            adj[u].update(set(later) - {u})
    owner: dict[str, int] = {}
    found: list[dict] = []
    for v in reversed(order):
        s = sep[v]
        if s:
            parent = owner[s[0]]
            members = set(found[parent]["frontals"]) | set(found[parent]["separator"])
            if set(s) == members:
                found[parent]["frontals"].insert(0, v)
                owner[v] = parent
                continue
        owner[v] = len(found)
        found.append({"frontals": [v], "separator": list(s), "parent": None if not s else owner[s[0]]})
    for c in found:
        if c["parent"] is not None:
            c["parent"] = found[c["parent"]]["frontals"][0]
    return sorted(found, key=lambda c: pos[c["frontals"][0]])


def conditionals(problem: Problem, order: Sequence[str], R: NDArray, d: NDArray, found: list[dict]) -> dict[str, dict]:
    """Each clique's P(F | S): its rows of the dense R (F's columns → R, S's → S) and of d, by first frontal."""
    off = problem.offsets(order)

    def cols(keys):
        return np.concatenate([np.arange(off[k], off[k] + problem.dims[k]) for k in keys]) if keys else np.zeros(0, int)

    out = {}
    for c in found:
        f, s = cols(c["frontals"]), cols(c["separator"])
        out[c["frontals"][0]] = {"R": R[np.ix_(f, f)], "S": R[np.ix_(f, s)], "d": d[f]}
    return out


def covariances(
    problem: Problem, order: Sequence[str], info: NDArray, groups: Sequence[Sequence[str]]
) -> dict[str, NDArray]:
    """The block of 𝓘⁻¹ of each group of keys (stacked in the order given), named 'k1,k2,...'."""
    cov = np.linalg.inv(info)
    cov = (cov + cov.T) / 2
    off = problem.offsets(order)
    out = {}
    for keys in groups:
        idx = np.concatenate([np.arange(off[k], off[k] + problem.dims[k]) for k in keys])
        out[",".join(keys)] = cov[np.ix_(idx, idx)]
    return out


def stream(
    variables: Mapping[str, int], updates: Sequence[Mapping], threshold: float, skip: int = 1, space: Space = VECTOR
) -> tuple[list[dict[str, NDArray]], list[list[str]]]:
    """The estimate after each update of a stream, and the variables relinearized at each.

    iSAM2 with full back-substitution keeps a linearization point θ̄ⱼ per variable and the exact
    solution δ of the system linearized there. At the start of every ``skip``-th update, each
    variable whose last δⱼ has max|δⱼ| ≥ ``threshold`` moves: θ̄ⱼ ← θ̄ⱼ ⊕ δⱼ (a new variable starts
    at its given value with δ = 0). A factor relinearized because one of its variables moved is
    linearized at θ̄ of all its variables, and one whose variables did not move kept the linearization
    at those same θ̄: so every factor is linearized at the current θ̄, and the estimate is θ̄ ⊕ δ.
    ``threshold`` 0 is one Gauss-Newton step per update; inf never relinearizes. ``space``: how variables
    move and factors linearize (:class:`Space`).
    """
    factors: list = []
    theta: dict[str, NDArray] = {}
    delta: dict[str, NDArray] = {}
    out, moved_at = [], []
    for step, u in enumerate(updates, start=1):
        factors.extend(u["factors"])
        moved: list[str] = []
        if step % skip == 0:
            moved = [k for k in theta if float(np.max(np.abs(delta[k]))) >= threshold]
            for k in moved:
                theta[k] = space.retract(theta[k], delta[k])
        for k, v in u["values"].items():
            theta[k] = np.asarray(v, float)
        order = [k for k in variables if k in theta]
        problem = Problem({"variables": {k: variables[k] for k in order}, "factors": factors})
        A, b, _ = dense_system(problem, theta, order, space)
        delta = _split(problem, order, factorize(A, b)["delta"])
        out.append({k: space.retract(theta[k], delta[k]) for k in order})
        moved_at.append(sorted(moved))
    return out, moved_at
