"""steam_ref's own results for the ``se2`` suite: ``steam_ref.lie`` and the SE(2) factors on a case's inputs.

A problem's variables named 'x<i>' are SE(2) states (``Values(kinds={k: SE2_STATE})``, retracted on the
right); 'l<j>' are landmarks (vectors). Factor specs of the suite::

    se2_prior        keys [x1, x2], dt, qc (3×3 on [vx, vy, ω]), model   e = γ₂ - Φ(Δt) γ₁, Σ = Q(Δt)
    se2_state_prior  keys [x], mean, sigmas (6)                          e = x ⊖ mean
    se2_range        keys [x, l], measured, sigma                        e = |l - p| - r
    prior            keys [l], mean, sigmas (2)                          e = l - mean
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..batch import gauss_newton
from ..bayes_tree import IncrementalSolver
from ..errors import SteamError
from ..factors import Factor, LiePriorFactor, LieStatePrior, PoseReading, PriorFactor
from ..gp import interpolation_matrices
from ..graph import FactorGraph
from ..lie import SE2, SE2_STATE
from ..lie.gp import interpolate, interpolate_covariance_se2
from ..variables import Values
from . import spec

__all__ = ["run_se2_case", "se2_factor", "se2_values"]


def se2_factor(f: Mapping) -> Factor:
    """A steam_ref factor from an se2 factor spec (module docstring)."""
    keys = [spec.key(k) for k in f["keys"]]
    kind = f["type"]
    if kind == "se2_prior":
        return LiePriorFactor.create(keys[0], keys[1], float(f["dt"]), np.asarray(f["qc"], float), f["model"])
    if kind == "se2_state_prior":
        return LieStatePrior.create(keys[0], np.asarray(f["mean"], float), np.asarray(f["sigmas"], float))
    if kind == "se2_range":
        return PoseReading.range(keys[0], keys[1], float(f["measured"]), float(f["sigma"]))
    if kind == "prior":
        return PriorFactor.create(keys[0], np.asarray(f["mean"], float), np.asarray(f["sigmas"], float))
    raise SteamError(f"unknown se2 factor type {kind!r}")


def se2_values(named: Mapping) -> Values:
    """Values from name → vector, the 'x<i>' ones SE(2) states."""
    values = {spec.key(k): np.asarray(v, float) for k, v in named.items()}
    return Values(values, kinds={k: SE2_STATE for k in values if k.symbol == "x"})


def _prior(inputs: Mapping) -> dict:
    f = LiePriorFactor.create(
        spec.key("x1"), spec.key("x2"), float(inputs["dt"]), np.asarray(inputs["qc"], float), inputs["model"]
    )
    x1, x2 = np.asarray(inputs["x1"], float), np.asarray(inputs["x2"], float)
    H0, H1 = f.jacobians(x1, x2)
    return {"error": f.error(x1, x2), "H_0": H0, "H_1": H1, "cost": 0.5 * float(np.sum(f.whitened_error(x1, x2) ** 2))}


def _interpolation(inputs: Mapping) -> dict:
    x1, x2, model = np.asarray(inputs["x1"], float), np.asarray(inputs["x2"], float), inputs["model"]
    t1, t2, tau, qc = float(inputs["t1"]), float(inputs["t2"]), float(inputs["tau"]), np.asarray(inputs["qc"], float)
    if "joint_cov" in inputs:
        x, cov = interpolate_covariance_se2(t1, t2, tau, qc, x1, x2, inputs["joint_cov"], model)
        return {"x_tau": x, "cov_tau": cov}
    lam, psi = interpolation_matrices(t1, t2, tau, qc)
    x, J1, J2 = interpolate(x1, x2, lam, psi, model)
    return {"x_tau": x, "J_1": J1, "J_2": J2}


def _batch(inputs: Mapping) -> dict:
    p, n = inputs["problem"], int(inputs["iterations"])
    graph, values = FactorGraph([se2_factor(f) for f in p["factors"]]), se2_values(p["values"])
    iterates = {k: [np.asarray(v, float)] for k, v in p["values"].items()}
    for k in range(1, n + 1):
        result = gauss_newton(
            graph,
            values,
            max_iterations=k,
            relative_tolerance=0.0,
            absolute_tolerance=0.0,
            step_tolerance=0.0,
            check=False,
        )
        for name in iterates:
            iterates[name].append(result.values[spec.key(name)])
    costs = [result.initial_cost] + [it.cost for it in result.iterations]
    costs += [costs[-1]] * (n + 1 - len(costs))
    return {"iterates": {k: np.array(v) for k, v in iterates.items()}, "costs": np.array(costs)}


def _incremental(inputs: Mapping) -> dict:
    isam2 = {k: (float(v) if k != "relinearize_skip" else int(v)) for k, v in inputs["isam2"].items()}
    solver = IncrementalSolver(None, **isam2)
    out: dict = {}
    for k, u in enumerate(inputs["stream"]["updates"], start=1):
        report = solver.update([se2_factor(f) for f in u["factors"]], se2_values(u["values"]))
        out[f"relinearized_{k}"] = sorted(spec.key_name(v) for v in report.relinearized)
        estimate = solver.estimate()
        out[f"estimate_{k}"] = {spec.key_name(key): np.asarray(estimate[key]) for key in estimate}
    return out


def run_se2_case(inputs: Mapping) -> dict:
    """The quantities of an se2 case computed by steam_ref."""
    kind = inputs["kind"]
    if kind == "exp":
        poses = SE2.exp(np.asarray(inputs["xi"], float))
        return {"exp": poses, "log_of_exp": SE2.log(poses)}
    if kind == "log":
        tangents = SE2.log(np.asarray(inputs["poses"], float))
        return {"log": tangents, "exp_of_log": SE2.exp(tangents)}
    if kind == "jacobians":
        xi = np.asarray(inputs["xi"], float)
        return {"Jr": SE2.right_jacobian(xi), "Jr_inv": SE2.right_jacobian_inverse(xi)}
    if kind == "between":
        a, b = np.asarray(inputs["a"], float), np.asarray(inputs["b"], float)
        rel, Ha, Hb = SE2.between(a, b, jacobians=True)
        return {"between": rel, "H_a": Ha, "H_b": Hb, "Ad_a": SE2.adjoint(a)}
    if kind == "prior":
        return _prior(inputs)
    if kind == "state_prior":
        f = LieStatePrior.create(spec.key("x0"), np.asarray(inputs["mean"], float), 1.0)
        x = np.asarray(inputs["x"], float)
        return {"error": f.error(x), "H_0": f.jacobians(x)[0]}
    if kind == "interpolation":
        return _interpolation(inputs)
    if kind == "batch":
        return _batch(inputs)
    if kind == "incremental":
        return _incremental(inputs)
    raise SteamError(f"unknown se2 case kind {kind!r}")
