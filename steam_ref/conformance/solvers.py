"""steam_ref's answer to the cases that solve a problem: its linearization, Gauss-Newton, the Bayes tree, iSAM2 and
the fixed-lag smoother on a case's problem or stream, whatever its variables' kinds (the kind of each key comes
from the factor specs that name it, :func:`.spec.key_kinds`: an SE(2) or SE(3) state or a plain vector; an SE(3)
state is solved in lie.SE3V's form and its estimates written back in the kit's, :data:`.spec.SOLVER_FORMS`).

Each function returns every quantity its computation gives (the Bayes tree's cliques, conditionals and
covariances; iSAM2's estimates, the variables it relinearized and its tree edits); a case is checked on those its
``tolerance`` names.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from ..batch import gauss_newton
from ..bayes_tree import BayesTree, FixedLagSmoother, IncrementalSolver, MarginalFactor
from ..covariance import tree_joint_covariance
from ..errors import SteamError
from ..graph import FactorGraph
from ..linear.cholesky import solve
from ..linear.ordering import Ordering
from ..linear.system import GaussianFactor, LinearSystem, linearize
from ..variables import Values
from . import spec

__all__ = ["linear", "batch", "bayes_tree", "incremental", "fixed_lag", "positive_rows"]


def positive_rows(R: NDArray, *others: NDArray) -> tuple[NDArray, ...]:
    """Scale the rows of an upper-triangular R (and of ``others``, row for row) so that diag R > 0."""
    s = np.where(np.diagonal(R) < 0, -1.0, 1.0)
    return (R * s[:, None], *[(o * s[:, None] if o.ndim == 2 else o * s) for o in others])


def _problem(inputs: Mapping):
    p = inputs["problem"]
    factors = [spec.solver_factor(f) for f in p["factors"]]
    values = spec.solver_values(p["values"], p["factors"])
    return p, factors, values, spec.ordering(inputs["ordering"], p["variables"]) if "ordering" in inputs else None


def _gaussian_factors(factors, values) -> tuple[list[GaussianFactor], list]:
    """Each factor's linearization, in factor order, and the linearized groups."""
    groups = linearize(factors, values)
    out: list = [None] * len(factors)
    for g in groups:
        for i, gf in zip(g.factor_ids, g.gaussian_factors(), strict=True):
            out[int(i)] = gf
    return out, groups


def _assemble_R(tree: BayesTree, ordering: Ordering) -> tuple[NDArray, NDArray]:
    """The dense R (n, n) and d of the tree's conditionals, rows and columns in ``ordering``."""
    n = ordering.total_dim
    R, d = np.zeros((n, n)), np.zeros(n)
    for c in tree.cliques.values():
        cols = np.concatenate(
            [
                ordering.offset_of[k] + np.arange(dim)
                for k, dim in zip(c.frontals + c.separator, c.frontal_dims + c.separator_dims, strict=True)
            ]
        )
        block = np.hstack([np.triu(c.R), c.S])
        rows = cols[: c.R.shape[0]]  # a frontal's rows sit at its own columns
        R[np.ix_(rows, cols)] = block
        d[rows] = c.d
    R, d = positive_rows(R, d)
    return R, d


def linear(inputs: Mapping) -> dict:
    """A, b (rows in factor order, columns in the case's ordering), 𝓘, Aᵀb, R, d and δ."""
    _p, factors, values, ordering = _problem(inputs)
    gfs, groups = _gaussian_factors(factors, values)
    system = LinearSystem.from_groups(groups, ordering)
    rows_of: dict[int, NDArray] = {}  # factor → its rows of A
    r = 0
    for g in groups:
        n, m = g.rhs.shape
        for i, fid in enumerate(g.factor_ids):
            rows_of[int(fid)] = np.arange(r + i * m, r + (i + 1) * m)
        r += n * m
    perm = np.concatenate([rows_of[j] for j in range(len(factors))])
    info, rhs = system.information()
    R, d = _assemble_R(BayesTree.from_factors(gfs, ordering), ordering)
    delta, _ = solve(system)
    return {
        "A": system.A.toarray()[perm],
        "b": system.b[perm],
        "information": info.toarray(),
        "rhs": rhs,
        "R": R,
        "d": d,
        "delta": delta,
    }


def batch(inputs: Mapping) -> dict:
    """Gauss-Newton's iterates (x ← x ⊕ δ) and the cost at each, in the case's ordering (else steam_ref's)."""
    p, factors, values, ordering = _problem(inputs)
    graph, n = FactorGraph(factors), int(inputs["iterations"])
    given = {} if ordering is None else {"ordering": ordering}  # else steam_ref's own
    iterates = {k: [np.asarray(v, float)] for k, v in p["values"].items()}
    if n < 1:
        raise SteamError(f"a batch case runs at least one iteration, got iterations={n}")
    for k in range(1, n + 1):
        result = gauss_newton(
            graph,
            values,
            max_iterations=k,
            relative_tolerance=0.0,
            absolute_tolerance=0.0,
            step_tolerance=0.0,
            check=False,
            **given,
        )
        for name in iterates:
            iterates[name].append(spec.kit_value(result.values, spec.key(name)))
    costs = [result.initial_cost] + [it.cost for it in result.iterations]
    costs += [costs[-1]] * (n + 1 - len(costs))  # a run stopped early by an unchanged cost stays there
    return {"iterates": {k: np.array(v) for k, v in iterates.items()}, "costs": np.array(costs)}


def _clique_list(tree: BayesTree, order: list[str]) -> list[dict]:
    pos = {k: i for i, k in enumerate(order)}
    out = []
    for cid, c in tree.cliques.items():
        parent = tree.parent[cid]
        out.append(
            {
                "frontals": [spec.key_name(k) for k in c.frontals],
                "separator": [spec.key_name(k) for k in c.separator],
                "parent": None if parent is None else spec.key_name(tree.cliques[parent].frontals[0]),
            }
        )
    return sorted(out, key=lambda c: pos[c["frontals"][0]])


def bayes_tree(inputs: Mapping) -> dict:
    """The tree of the case's ordering: its cliques, each clique's conditional, and (given ``groups``) joint
    covariances."""
    _p, factors, values, ordering = _problem(inputs)
    gfs, _ = _gaussian_factors(factors, values)
    tree = BayesTree.from_factors(gfs, ordering)
    conditionals = {}
    for c in tree.cliques.values():
        R, S, d = positive_rows(c.R, c.S, c.d)
        conditionals[spec.key_name(c.frontals[0])] = {"R": np.triu(R), "S": S, "d": d}
    out = {"cliques": _clique_list(tree, list(inputs["ordering"])), "conditionals": conditionals}
    if "groups" in inputs:
        out["covariances"] = {
            ",".join(g): tree_joint_covariance(tree, [spec.key(k) for k in g]) for g in inputs["groups"]
        }
    return out


def _isam2(inputs: Mapping) -> dict:
    """The case's iSAM2 settings; the kit's tree edits and fill are those of unmerged cliques (docs/conformance.md)."""
    given = {k: (float(v) if k != "relinearize_skip" else int(v)) for k, v in inputs["isam2"].items()}
    return {"amalgamation_zeros": 0.0} | given


def _named(estimate: Values) -> dict[str, NDArray]:
    """Each variable's estimate by name, in the kit's stored form."""
    return {spec.key_name(key): spec.kit_value(estimate, key) for key in estimate}


def incremental(inputs: Mapping) -> dict:
    """After each update: the estimate, the variables relinearized, the cliques removed and orphaned (each named
    by its frontals) and the fill of R."""
    solver = IncrementalSolver(None, **_isam2(inputs))
    out: dict[str, object] = {}
    seen: list[Mapping] = []  # every factor spec so far: the kinds of the variables
    for k, u in enumerate(inputs["stream"]["updates"], start=1):
        seen += u["factors"]
        before = {cid: [spec.key_name(v) for v in c.frontals] for cid, c in solver.tree.cliques.items()}
        report = solver.update([spec.solver_factor(f) for f in u["factors"]], spec.solver_values(u["values"], seen))
        out[f"update_{k}"] = {
            "removed": sorted(before[c] for c in report.removed_cliques),
            "orphans": sorted(before[o] for o in report.orphans),
        }
        out[f"nnz_{k}"] = report.tree_nnz
        out[f"relinearized_{k}"] = sorted(spec.key_name(v) for v in report.relinearized)
        out[f"estimate_{k}"] = _named(solver.estimate())
    return out


def _marginal_factor(smoother: FixedLagSmoother, ids, order: list[str]) -> dict:
    """The marginal factors ``ids`` summed into Λ, η over their keys in ``order``, and their point θ̄⁰."""
    factors = [f for f in (smoother.factors[j] for j in ids) if isinstance(f, MarginalFactor)]
    if len(factors) != len(ids):
        raise SteamError(f"factors {list(ids)} are not all marginal factors")
    names = {spec.key_name(k) for f in factors for k in f.keys}
    sep = [k for k in order if k in names]
    dims = {spec.key_name(k): d for f in factors for k, d in zip(f.keys, f.dims, strict=True)}
    start = dict(zip(sep, np.cumsum([0] + [dims[k] for k in sep]), strict=False))
    n = sum(dims[k] for k in sep)
    info, vector, point = np.zeros((n, n)), np.zeros(n), np.zeros(n)
    for f in factors:
        idx = np.concatenate([start[spec.key_name(k)] + np.arange(d) for k, d in zip(f.keys, f.dims, strict=True)])
        info[np.ix_(idx, idx)] += f.A.T @ f.A
        vector[idx] += f.A.T @ f.b
        point[idx] = f.theta0
    return {"separator": sep, "point": point, "information": info, "vector": vector}


def fixed_lag(inputs: Mapping) -> dict:
    """A FixedLagSmoother run on the stream: after each update what went, its marginal factor, the window."""
    stream = inputs["stream"]
    order = list(stream["variables"])
    smoother = FixedLagSmoother(float(inputs["lag"]), **_isam2(inputs))
    out: dict[str, object] = {}
    seen: list[Mapping] = []
    for k, u in enumerate(stream["updates"], start=1):
        seen += u["factors"]
        smoother.update(
            [spec.solver_factor(f) for f in u["factors"]],
            spec.solver_values(u["values"], seen),
            timestamps={spec.key(n): float(t) for n, t in u["timestamps"].items()},
        )
        done = smoother.last_marginalization
        gone = set() if done is None else {spec.key_name(v) for v in done.keys}
        out[f"marginalized_{k}"] = [v for v in order if v in gone]
        if done is not None:
            m = _marginal_factor(smoother, done.marginal_factors, order)
            out[f"separator_{k}"] = m["separator"]
            out[f"marginal_point_{k}"] = m["point"]
            out[f"marginal_information_{k}"] = m["information"]
            out[f"marginal_vector_{k}"] = m["vector"]
        out[f"estimate_{k}"] = _named(smoother.estimate())
        covs = smoother.marginal_covariances()
        out[f"covariances_{k}"] = {spec.key_name(key): np.asarray(c) for key, c in covs.items()}
    return out
