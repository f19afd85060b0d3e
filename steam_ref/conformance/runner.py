"""steam_ref's own results for the kit's cases: the installed code run on each case's stored inputs.

:func:`run_case` is what an implementation under test does, written with steam_ref: it reads a
case's inputs and returns its output quantities in the kit's conventions. ``selftest`` checks its
results against the shipped kit; the build uses them as the expected values of the cases that are
not independent, and checks them against the oracle for those that are.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from ..batch import gauss_newton
from ..bayes_tree import BayesTree, FixedLagSmoother, IncrementalSolver, MarginalFactor
from ..covariance import tree_joint_covariance
from ..errors import DegenerateMeasurementWarning, SteamError
from ..gp import (
    LinearSDE,
    extrapolate_covariance_sde,
    extrapolate_state_sde,
    interpolate_covariance,
    interpolate_state,
    interpolate_state_sde,
    interpolation_matrices,
    interpolation_matrices_sde,
    process_noise,
    process_noise_inverse,
    process_noise_sqrt_information,
    singer_process_noise,
    singer_transition,
    transition,
    wnoj_process_noise,
    wnoj_process_noise_inverse,
    wnoj_transition,
)
from ..graph import FactorGraph
from ..linear.cholesky import solve
from ..linear.ordering import Ordering
from ..linear.system import GaussianFactor, LinearSystem, linearize
from . import spec
from .runner_se2 import run_se2_case

__all__ = ["run_case", "positive_rows"]


def positive_rows(R: NDArray, *others: NDArray) -> tuple[NDArray, ...]:
    """Scale the rows of an upper-triangular R (and of ``others``, row for row) so that diag R > 0."""
    s = np.where(np.diagonal(R) < 0, -1.0, 1.0)
    return (R * s[:, None], *[(o * s[:, None] if o.ndim == 2 else o * s) for o in others])


# --- gp -------------------------------------------------------------------------------------------


def _gp(inputs: Mapping) -> dict:
    kind = inputs["kind"]
    qc = np.asarray(inputs["qc"], float)
    d = qc.shape[0]
    if kind == "wnoa":
        dt = float(inputs["dt"])
        return {
            "Phi": transition(dt, d),
            "Q": process_noise(dt, qc),
            "Qinv": process_noise_inverse(dt, qc),
            "W": process_noise_sqrt_information(dt, qc),
        }
    if kind == "lti":
        sde = LinearSDE(
            np.asarray(inputs["A"], float), np.asarray(inputs["F"], float), qc, np.asarray(inputs["v"], float)
        ).general()
        dt = float(inputs["dt"])
        return {"Phi": sde.transition(dt), "Q": sde.process_noise(dt), "v_i": sde.input_integral(dt)}
    if kind == "wnoj":
        dt = float(inputs["dt"])
        return {
            "Phi": wnoj_transition(dt, d),
            "Q": wnoj_process_noise(dt, qc),
            "Qinv": wnoj_process_noise_inverse(dt, qc),
        }
    if kind == "singer":
        dt, alpha = float(inputs["dt"]), float(inputs["alpha"])
        return {"Phi": singer_transition(dt, alpha, d), "Q": singer_process_noise(dt, alpha, qc)}
    t1 = float(inputs["t1"])
    if kind == "extrapolation":
        sde, t = LinearSDE.wnoa(qc), float(inputs["t"])
        return {
            "x_t": extrapolate_state_sde(sde, t1, inputs["x1"], t),
            "cov_t": extrapolate_covariance_sde(sde, t1, t, inputs["cov1"]),
        }
    t2, tau = float(inputs["t2"]), float(inputs["tau"])
    if kind == "interpolation":
        lam, psi = interpolation_matrices(t1, t2, tau, qc)
        return {"Lambda": lam, "Psi": psi, "x_tau": interpolate_state(t1, inputs["x1"], t2, inputs["x2"], tau, qc)}
    if kind == "interpolation_covariance":
        return {"cov_tau": interpolate_covariance(t1, t2, tau, qc, np.asarray(inputs["joint_cov"], float))}
    if kind == "singer_interpolation":
        sde = LinearSDE.singer(qc, float(inputs["alpha"]))
        lam, psi = interpolation_matrices_sde(sde, t1, t2, tau)
        return {"Lambda": lam, "Psi": psi, "x_tau": interpolate_state_sde(sde, t1, inputs["x1"], t2, inputs["x2"], tau)}
    raise SteamError(f"unknown gp case kind {kind!r}")


# --- factors --------------------------------------------------------------------------------------


def _factor(inputs: Mapping) -> dict:
    with warnings.catch_warnings():  # a case at a degenerate point is evaluated there on purpose
        warnings.simplefilter("ignore", DegenerateMeasurementWarning)
        return _factor_quantities(inputs)


def _factor_quantities(inputs: Mapping) -> dict:
    f = spec.factor(inputs["factor"])
    values = spec.values(inputs["values"])
    xs = [values[k] for k in f.keys]
    e = f.error(*xs)
    we = f.whitened_error(*xs)
    (group,) = linearize([f], values)
    out: dict[str, NDArray | float] = {"error": e, "whitened_error": we}
    out.update({f"H_{k}": H for k, H in enumerate(f.jacobians(*xs))})
    out.update({f"A_{k}": J[0] for k, J in enumerate(group.jacobian_blocks())})
    out["b"], out["cost"] = group.rhs[0], float(group.costs[0])
    if f.loss is not None:
        out["weight"] = float(f.loss.weight(np.asarray(np.linalg.norm(we))))
    return out


# --- problems -------------------------------------------------------------------------------------


def _problem(inputs: Mapping):
    p = inputs["problem"]
    factors = [spec.factor(f) for f in p["factors"]]
    return p, factors, spec.values(p["values"]), spec.ordering(inputs["ordering"], p["variables"])


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


def _linear(inputs: Mapping) -> dict:
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


def _batch(inputs: Mapping) -> dict:
    p, factors, values, ordering = _problem(inputs)
    graph, n = FactorGraph(factors), int(inputs["iterations"])
    options = dict(ordering=ordering, relative_tolerance=0.0, absolute_tolerance=0.0, step_tolerance=0.0, check=False)
    iterates = {k: [np.asarray(v, float)] for k, v in p["values"].items()}
    if n < 1:
        raise SteamError(f"a batch case runs at least one iteration, got iterations={n}")
    for k in range(1, n + 1):
        result = gauss_newton(graph, values, max_iterations=k, **options)
        for name in iterates:
            iterates[name].append(result.values[spec.key(name)])
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


def _bayes_tree(name: str, inputs: Mapping) -> dict:
    _p, factors, values, ordering = _problem(inputs)
    gfs, _ = _gaussian_factors(factors, values)
    tree = BayesTree.from_factors(gfs, ordering)
    if name.endswith("_cliques"):
        return {"cliques": _clique_list(tree, list(inputs["ordering"]))}
    if name.endswith("_conditionals"):
        out = {}
        for c in tree.cliques.values():
            R, S, d = positive_rows(c.R, c.S, c.d)
            out[spec.key_name(c.frontals[0])] = {"R": np.triu(R), "S": S, "d": d}
        return {"conditionals": out}
    return {
        "covariances": {",".join(g): tree_joint_covariance(tree, [spec.key(k) for k in g]) for g in inputs["groups"]}
    }


def _isam2(inputs: Mapping) -> dict:
    return {k: (float(v) if k != "relinearize_skip" else int(v)) for k, v in inputs["isam2"].items()}


def _incremental(name: str, inputs: Mapping) -> dict:
    solver = IncrementalSolver(None, **_isam2(inputs))
    out: dict[str, object] = {}
    for k, u in enumerate(inputs["stream"]["updates"], start=1):
        before = {cid: [spec.key_name(v) for v in c.frontals] for cid, c in solver.tree.cliques.items()}
        report = solver.update(
            [spec.factor(f) for f in u["factors"]], {spec.key(n): np.asarray(v, float) for n, v in u["values"].items()}
        )
        if name.endswith("_tree_edits"):
            out[f"update_{k}"] = {
                "removed": sorted(before[c] for c in report.removed_cliques),
                "orphans": sorted(before[o] for o in report.orphans),
            }
            out[f"nnz_{k}"] = report.tree_nnz
        else:
            if name.startswith("partial_"):
                out[f"relinearized_{k}"] = sorted(spec.key_name(v) for v in report.relinearized)
            estimate = solver.estimate()
            out[f"estimate_{k}"] = {spec.key_name(key): np.asarray(estimate[key]) for key in estimate}
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


def _fixed_lag(inputs: Mapping) -> dict:
    """A FixedLagSmoother run on the stream: after each update what went, its marginal factor, the window."""
    stream = inputs["stream"]
    order = list(stream["variables"])
    smoother = FixedLagSmoother(float(inputs["lag"]), **_isam2(inputs))
    out: dict[str, object] = {}
    for k, u in enumerate(stream["updates"], start=1):
        smoother.update(
            [spec.factor(f) for f in u["factors"]],
            {spec.key(n): np.asarray(v, float) for n, v in u["values"].items()},
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
        estimate = smoother.estimate()
        out[f"estimate_{k}"] = {spec.key_name(key): np.asarray(estimate[key]) for key in estimate}
        covs = smoother.marginal_covariances()
        out[f"covariances_{k}"] = {spec.key_name(key): np.asarray(c) for key, c in covs.items()}
    return out


def run_case(suite: str, name: str, inputs: Mapping) -> dict:
    """The output quantities of one case, computed by steam_ref from the case's inputs."""
    if suite == "gp":
        return _gp(inputs)
    if suite == "factors":
        return _factor(inputs)
    if suite == "linear":
        return _linear(inputs)
    if suite == "batch":
        return _batch(inputs)
    if suite == "bayes_tree":
        return _bayes_tree(name, inputs)
    if suite == "incremental":
        return _incremental(name, inputs)
    if suite == "fixed_lag":
        return _fixed_lag(inputs)
    if suite == "se2":
        return run_se2_case(inputs)
    raise SteamError(f"no runner for suite {suite!r}")
