"""The oracle's answer to each independent case, from the case's inputs (see :mod:`.oracle`, :mod:`.oracle_graph`)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..errors import SteamError
from . import oracle as o
from . import oracle_graph as g

__all__ = ["oracle_case"]


def _gp(inputs: Mapping) -> dict:
    kind = inputs["kind"]
    qc = np.asarray(inputs["qc"], float)
    d = qc.shape[0]
    if kind in ("wnoa", "wnoj", "singer"):
        A, F = o.model_matrices(kind, d, inputs.get("alpha"))
        dt = float(inputs["dt"])
        Q = o.process_noise(A, F, qc, dt)
        out = {"Phi": o.transition(A, dt), "Q": Q}
        if kind != "singer":
            out["Qinv"] = np.linalg.inv(Q)
        if kind == "wnoa":
            out["W"] = o.sqrt_information(Q)
        return out
    if kind == "lti":
        A, F, v, dt = (
            np.asarray(inputs["A"], float),
            np.asarray(inputs["F"], float),
            np.asarray(inputs["v"], float),
            float(inputs["dt"]),
        )
        return {"Phi": o.transition(A, dt), "Q": o.process_noise(A, F, qc, dt), "v_i": o.input_integral(A, v, dt)}
    t1 = float(inputs["t1"])
    if kind == "extrapolation":
        A, F = o.model_matrices("wnoa", d)
        x, cov = o.extrapolation(A, F, qc, float(inputs["t"]) - t1, inputs["x1"], inputs["cov1"])
        return {"x_t": x, "cov_t": cov}
    A, F = o.model_matrices("singer" if kind == "singer_interpolation" else "wnoa", d, inputs.get("alpha"))
    lam, psi, cond = o.interpolation(A, F, qc, t1, float(inputs["t2"]), float(inputs["tau"]))
    if kind == "interpolation_covariance":
        G = np.hstack([lam, psi])
        cov = G @ np.asarray(inputs["joint_cov"], float) @ G.T + cond
        return {"cov_tau": (cov + cov.T) / 2}
    if kind in ("interpolation", "singer_interpolation"):
        return {
            "Lambda": lam,
            "Psi": psi,
            "x_tau": lam @ np.asarray(inputs["x1"], float) + psi @ np.asarray(inputs["x2"], float),
        }
    raise SteamError(f"unknown gp case kind {kind!r}")


def _linear(inputs: Mapping) -> dict:
    problem = g.Problem(inputs["problem"])
    A, b, _ = g.dense_system(problem, problem.values, inputs["ordering"])
    return {"A": A, "b": b, **g.factorize(A, b)}


def _batch(inputs: Mapping) -> dict:
    problem = g.Problem(inputs["problem"])
    iterates, costs = g.gauss_newton(problem, inputs["ordering"], int(inputs["iterations"]))
    return {"iterates": {k: np.array([it[k] for it in iterates]) for k in problem.dims}, "costs": np.array(costs)}


def _bayes_tree(name: str, inputs: Mapping) -> dict:
    problem, order = g.Problem(inputs["problem"]), list(inputs["ordering"])
    found = g.cliques(order, [f["keys"] for f in problem.factors])
    if name.endswith("_cliques"):
        return {"cliques": found}
    A, b, _ = g.dense_system(problem, problem.values, order)
    f = g.factorize(A, b)
    if name.endswith("_conditionals"):
        return {"conditionals": g.conditionals(problem, order, f["R"], f["d"], found)}
    return {"covariances": g.covariances(problem, order, f["information"], inputs["groups"])}


def _incremental(inputs: Mapping) -> dict:
    relinearize = float(inputs["isam2"]["relinearize_threshold"]) == 0.0
    estimates = g.stream(inputs["stream"]["variables"], inputs["stream"]["updates"], relinearize)
    return {f"estimate_{k}": e for k, e in enumerate(estimates, start=1)}


def oracle_case(suite: str, name: str, inputs: Mapping) -> dict:
    """The expected output quantities of an independent case, computed without steam_ref's solvers."""
    if suite == "gp":
        return _gp(inputs)
    if suite == "factors":
        spec = inputs["factor"]
        return o.linearize_factor(spec, [inputs["values"][k] for k in spec["keys"]])
    if suite == "linear":
        return _linear(inputs)
    if suite == "batch":
        return _batch(inputs)
    if suite == "bayes_tree":
        return _bayes_tree(name, inputs)
    if suite == "incremental":
        return _incremental(inputs)
    raise SteamError(f"no oracle for suite {suite!r}")
