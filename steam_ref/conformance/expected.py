"""The oracle's answer to each independent case, from the case's inputs (see :mod:`.oracle`, :mod:`.oracle_graph`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..errors import SteamError
from . import oracle as o
from . import oracle_graph as g
from . import oracle_lag as lag
from .oracle_se2 import se2_case

__all__ = ["oracle_case", "oracle_alternatives", "fixed_lag_quantities", "ALTERNATIVES"]


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


def _incremental(name: str, inputs: Mapping) -> dict:
    isam2 = inputs["isam2"]
    threshold, skip = float(isam2["relinearize_threshold"]), int(isam2["relinearize_skip"])
    estimates, moved = g.stream(inputs["stream"]["variables"], inputs["stream"]["updates"], threshold, skip)
    out: dict = {f"estimate_{k}": e for k, e in enumerate(estimates, start=1)}
    if name.startswith("partial_"):
        out = {**{f"relinearized_{k}": m for k, m in enumerate(moved, start=1)}, **out}
    return out


def _fixed_lag(inputs: Mapping) -> dict:
    isam2, stream = inputs["isam2"], inputs["stream"]
    threshold, skip = float(isam2["relinearize_threshold"]), int(isam2["relinearize_skip"])
    return fixed_lag_quantities(
        lag.fixed_lag(stream["variables"], stream["updates"], float(inputs["lag"]), threshold, skip)
    )


def fixed_lag_quantities(replay: Sequence[Mapping]) -> dict:
    """The dense replay's per-update records (:func:`.oracle_lag.fixed_lag`) as a fixed_lag case's quantities."""
    out: dict = {}
    for k, r in enumerate(replay, start=1):
        out[f"marginalized_{k}"] = r["marginalized"]
        if r["marginalized"]:
            out[f"separator_{k}"] = r["separator"]
            out[f"marginal_point_{k}"] = r["point"]
            out[f"marginal_information_{k}"] = r["information"]
            out[f"marginal_vector_{k}"] = r["vector"]
        out[f"estimate_{k}"] = r["estimate"]
        out[f"covariances_{k}"] = r["covariances"]
    return out


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
        return _incremental(name, inputs)
    if suite == "fixed_lag":
        return _fixed_lag(inputs)
    if suite == "se2":
        return se2_case(inputs)
    raise SteamError(f"no oracle for suite {suite!r}")


ALTERNATIVES = {  # how the kit names a combination of alternative conventions → oracle switches
    "paper-sign": {"paper_sign": True},
    "symmetric-whitener": {"symmetric": True},
    "paper-sign+symmetric-whitener": {"paper_sign": True, "symmetric": True},
}


def oracle_alternatives(suite: str, inputs: Mapping) -> dict:
    """The convention-dependent quantities of a case under each combination of the alternative conventions.

    Only quantities whose values differ from the kit's own conventions are listed.
    """
    out: dict = {}
    for name, switches in ALTERNATIVES.items():
        alt: dict = {}
        if suite == "gp" and inputs["kind"] == "wnoa" and switches.get("symmetric"):
            qc = np.asarray(inputs["qc"], float)
            A, F = o.model_matrices("wnoa", qc.shape[0])
            alt["W"] = o.sqrt_information(o.process_noise(A, F, qc, float(inputs["dt"])), symmetric=True)
        elif suite == "factors":
            spec = inputs["factor"]
            xs = [inputs["values"][k] for k in spec["keys"]]
            mine, theirs = o.linearize_factor(spec, xs), o.linearize_factor(spec, xs, **switches)
            alt = {q: v for q, v in theirs.items() if q not in ("cost", "weight") and not np.array_equal(v, mine[q])}
        elif suite == "linear":
            problem = g.Problem(inputs["problem"])
            A, b, _ = g.dense_system(problem, problem.values, inputs["ordering"], **switches)
            A0, b0, _ = g.dense_system(problem, problem.values, inputs["ordering"])
            alt = {q: v for q, v, v0 in (("A", A, A0), ("b", b, b0)) if not np.array_equal(v, v0)}
        if alt:
            out[name] = alt
    return out
