"""The oracle's answer to each independent case, from the case's inputs: one table keyed by case type.

:data:`ORACLES` maps a case's type (:func:`.kitio.case_type`: its suite, and the ``kind`` its inputs name) to
the function computing its quantities with the oracles (:mod:`.oracle`, :mod:`.oracle_graph`,
:mod:`.oracle_lag`, :mod:`.oracle_lie`). A problem's Gauss-Newton and iSAM2 replay are one each, in the space
the type names: the vector space, or SE(2) states (:data:`.oracle_lie.LIE`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from functools import partial

import numpy as np
from threadpoolctl import threadpool_limits

from ..errors import SteamError
from . import oracle as o
from . import oracle_graph as g
from . import oracle_lag as lag
from . import oracle_lie as lie
from . import oracle_rigid as se3
from .kitio import case_type

__all__ = ["ORACLES", "oracle_case", "oracle_alternatives", "fixed_lag_quantities", "ALTERNATIVES"]

# --- gp -------------------------------------------------------------------------------------------


def _sde(kind: str, inputs: Mapping) -> dict:
    """Φ, Q (and Q⁻¹, W where the kit has them) of WNOA, WNOJ or Singer [YIB Eq. 16-17]."""
    qc = np.asarray(inputs["qc"], float)
    A, F = o.model_matrices(kind, qc.shape[0], inputs.get("alpha"))
    dt = float(inputs["dt"])
    Q = o.process_noise(A, F, qc, dt)
    out = {"Phi": o.transition(A, dt), "Q": Q}
    if kind != "singer":
        out["Qinv"] = np.linalg.inv(Q)
    if kind == "wnoa":
        out["W"] = o.sqrt_information(Q)
    return out


def _lti(inputs: Mapping) -> dict:
    A, F, v, qc = (np.asarray(inputs[k], float) for k in ("A", "F", "v", "qc"))
    dt = float(inputs["dt"])
    return {"Phi": o.transition(A, dt), "Q": o.process_noise(A, F, qc, dt), "v_i": o.input_integral(A, v, dt)}


def _extrapolation(inputs: Mapping) -> dict:
    qc = np.asarray(inputs["qc"], float)
    A, F = o.model_matrices("wnoa", qc.shape[0])
    x, cov = o.extrapolation(A, F, qc, float(inputs["t"]) - float(inputs["t1"]), inputs["x1"], inputs["cov1"])
    return {"x_t": x, "cov_t": cov}


def _interpolation(model: str, inputs: Mapping) -> dict:
    """Λ, Ψ and x(τ), or (given ``joint_cov``) the covariance at τ, from the dense kernel [YIB Eq. 12, 16, 18]."""
    qc = np.asarray(inputs["qc"], float)
    A, F = o.model_matrices(model, qc.shape[0], inputs.get("alpha"))
    lam, psi, cond = o.interpolation(A, F, qc, float(inputs["t1"]), float(inputs["t2"]), float(inputs["tau"]))
    if "joint_cov" in inputs:
        G = np.hstack([lam, psi])
        cov = G @ np.asarray(inputs["joint_cov"], float) @ G.T + cond
        return {"cov_tau": (cov + cov.T) / 2}
    x_tau = lam @ np.asarray(inputs["x1"], float) + psi @ np.asarray(inputs["x2"], float)
    return {"Lambda": lam, "Psi": psi, "x_tau": x_tau}


# --- factors and problems ---------------------------------------------------------------------------


def _factor(inputs: Mapping) -> dict:
    spec = inputs["factor"]
    return o.linearize_factor(spec, [inputs["values"][k] for k in spec["keys"]])


def _linear(inputs: Mapping) -> dict:
    problem = g.Problem(inputs["problem"])
    A, b, _ = g.dense_system(problem, problem.values, inputs["ordering"])
    return {"A": A, "b": b, **g.factorize(A, b)}


def _batch(space: g.Space, inputs: Mapping) -> dict:
    """Gauss-Newton's iterates and costs in ``space``, in the case's ordering (else the variables' order)."""
    problem = g.Problem(inputs["problem"])
    order = inputs.get("ordering", list(problem.dims))
    iterates, costs = g.gauss_newton(problem, order, int(inputs["iterations"]), space)
    return {"iterates": {k: np.array([it[k] for it in iterates]) for k in problem.dims}, "costs": np.array(costs)}


def _bayes_tree(inputs: Mapping) -> dict:
    """The cliques of the case's ordering, their conditionals and (given ``groups``) the joint covariances."""
    problem, order = g.Problem(inputs["problem"]), list(inputs["ordering"])
    found = g.cliques(order, [f["keys"] for f in problem.factors])
    A, b, _ = g.dense_system(problem, problem.values, order)
    f = g.factorize(A, b)
    out = {"cliques": found, "conditionals": g.conditionals(problem, order, f["R"], f["d"], found)}
    if "groups" in inputs:
        out["covariances"] = g.covariances(problem, order, f["information"], inputs["groups"])
    return out


def _incremental(space: g.Space, inputs: Mapping) -> dict:
    """The estimate after each update and the variables relinearized at each, replayed densely in ``space``."""
    isam2 = inputs["isam2"]
    threshold, skip = float(isam2["relinearize_threshold"]), int(isam2["relinearize_skip"])
    estimates, moved = g.stream(inputs["stream"]["variables"], inputs["stream"]["updates"], threshold, skip, space)
    out: dict = {f"relinearized_{k}": m for k, m in enumerate(moved, start=1)}
    return {**out, **{f"estimate_{k}": e for k, e in enumerate(estimates, start=1)}}


def _fixed_lag(space: g.Space, inputs: Mapping) -> dict:
    isam2, stream = inputs["isam2"], inputs["stream"]
    threshold, skip = float(isam2["relinearize_threshold"]), int(isam2["relinearize_skip"])
    return fixed_lag_quantities(
        lag.fixed_lag(stream["variables"], stream["updates"], float(inputs["lag"]), threshold, skip, space=space)
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


# --- a Lie group ------------------------------------------------------------------------------------


def _rows(f: Callable[[np.ndarray], np.ndarray], items) -> np.ndarray:
    return np.array([f(np.asarray(v, float)) for v in items])


def _exp(inputs: Mapping, half_turn: float | None = lie.HALF_TURN) -> dict:
    poses = _rows(partial(lie.exp, half_turn=half_turn), inputs["xi"])
    return {"exp": poses, "log_of_exp": _rows(partial(lie.log, half_turn=half_turn), poses)}


def _log(inputs: Mapping, half_turn: float | None = lie.HALF_TURN) -> dict:
    tangents = _rows(partial(lie.log, half_turn=half_turn), inputs["poses"])
    return {"log": tangents, "exp_of_log": _rows(partial(lie.exp, half_turn=half_turn), tangents)}


def _jacobians(inputs: Mapping) -> dict:
    return {"Jr": _rows(lie.right_jacobian, inputs["xi"]), "Jr_inv": _rows(lie.right_jacobian_inverse, inputs["xi"])}


def _between(inputs: Mapping) -> dict:
    a, b = np.asarray(inputs["a"], float), np.asarray(inputs["b"], float)
    Ha, Hb = (lie.numeric_jacobian(lie.between, [a, b], k, lambda p, q: lie.log(lie.between(p, q))) for k in (0, 1))
    return {"between": lie.between(a, b), "H_a": Ha, "H_b": Hb, "Ad_a": lie.adjoint(a)}


def _lie_prior(inputs: Mapping) -> dict:
    """The WNOA prior between two states: a factor case whose inputs name the two states x1, x2."""
    spec = {"type": "se2_prior", "keys": ["x1", "x2"], **{k: inputs[k] for k in ("dt", "qc", "model")}}
    return lie.linearize_factor(spec, [inputs["x1"], inputs["x2"]])


def _lie_state_prior(inputs: Mapping) -> dict:
    """A prior on one state (its error x ⊖ mean and Jacobian; no noise given)."""
    e, (H,) = lie.factor_jacobians({"type": "se2_state_prior", "mean": inputs["mean"]}, [inputs["x"]])
    return {"error": e, "H_0": H}


def _lie_reading(inputs: Mapping) -> dict:
    """A reading of SE(2) states (kit v5): a factor case whose spec names its states and landmark."""
    spec = inputs["factor"]
    return lie.linearize_factor(spec, [inputs["values"][k] for k in spec["keys"]])


def _se3_rows(inputs: Mapping) -> dict:
    items = [np.asarray(v, float) for v in inputs["xi" if "xi" in inputs else "phi"]]
    if "phi" in inputs:  # SO(3)
        exps = [se3.so3_exp(v) for v in items]
        return {"exp": np.array(exps), "log_of_exp": np.array([se3.so3_log(r) for r in exps])}
    exps = [se3.exp(v) for v in items]
    return {"exp": np.array(exps), "log_of_exp": np.array([se3.log(p) for p in exps])}


def _se3_jacobians(inputs: Mapping) -> dict:
    items = [np.asarray(v, float) for v in inputs["xi" if "xi" in inputs else "phi"]]
    return {"Jr": _rows(se3.right_jacobian, items), "Jr_inv": _rows(se3.right_jacobian_inverse, items)}


def _se3_between(inputs: Mapping) -> dict:
    a, b = np.asarray(inputs["a"], float), np.asarray(inputs["b"], float)
    Ha, Hb = (se3.numeric_jacobian(se3.between, [a, b], k, lambda p, q: se3.log(se3.between(p, q))) for k in (0, 1))
    return {"between": se3.between(a, b), "H_a": Ha, "H_b": Hb, "Ad_a": se3.adjoint(a)}


def _se3_prior(kind: str, inputs: Mapping) -> dict:
    spec = {"type": kind, "keys": ["x1", "x2"], **{k: inputs[k] for k in ("dt", "qc", "model") if k in inputs}}
    return se3.linearize_factor(spec, [inputs["x1"], inputs["x2"]])


def _se3_state_prior(inputs: Mapping) -> dict:
    e, (H,) = se3.factor_jacobians({"type": "se3_state_prior", "mean": inputs["mean"]}, [inputs["x"]])
    return {"error": e, "H_0": H}


def _one_thread(f: Callable[[Mapping], dict]) -> Callable[[Mapping], dict]:
    """``f`` under a one-thread BLAS: OpenBLAS's threads make each 3×3 ``expm`` a thousand times slower on a busy
    machine."""

    def run(inputs: Mapping) -> dict:
        with threadpool_limits(limits=1, user_api="blas"):
            return f(inputs)

    return run


# Case type → the oracle's quantities of a case of that type. A new type is a row here and one in
# runner.RUNNERS (tests/test_conformance.py checks that both cover every case of every shipped kit).
ORACLES: dict[str, Callable[[Mapping], dict]] = {
    "gp/wnoa": partial(_sde, "wnoa"),
    "gp/wnoj": partial(_sde, "wnoj"),
    "gp/singer": partial(_sde, "singer"),
    "gp/lti": _lti,
    "gp/extrapolation": _extrapolation,
    "gp/interpolation": partial(_interpolation, "wnoa"),
    "gp/interpolation_covariance": partial(_interpolation, "wnoa"),
    "gp/singer_interpolation": partial(_interpolation, "singer"),
    "factors": _factor,
    "linear": _linear,
    "batch": partial(_batch, g.VECTOR),
    "bayes_tree": _bayes_tree,
    "incremental": partial(_incremental, g.VECTOR),
    "fixed_lag": partial(_fixed_lag, g.VECTOR),
    "se2/exp": _one_thread(_exp),
    "se2/log": _one_thread(_log),
    "se2/jacobians": _one_thread(_jacobians),
    "se2/between": _one_thread(_between),
    "se2/prior": _one_thread(_lie_prior),
    "se2/state_prior": _one_thread(_lie_state_prior),
    "se2/interpolation": _one_thread(lie.interpolation_quantities),
    "se2/batch": _one_thread(partial(_batch, lie.LIE)),
    "se2/incremental": _one_thread(partial(_incremental, lie.LIE)),
    "se2/reading": _one_thread(_lie_reading),
    "se2/retract": _one_thread(lie.retraction_quantities),
    "se2/extrapolation": _one_thread(lie.extrapolation_quantities),
    "se2/fixed_lag": _one_thread(partial(_fixed_lag, lie.LIE)),
    "se3/so3_exp": _one_thread(_se3_rows),
    "se3/so3_jacobians": _one_thread(_se3_jacobians),
    "se3/exp": _one_thread(_se3_rows),
    "se3/jacobians": _one_thread(_se3_jacobians),
    "se3/between": _one_thread(_se3_between),
    "se3/prior": _one_thread(partial(_se3_prior, "se3_prior")),
    "se3/wnoj_prior": _one_thread(partial(_se3_prior, "se3_wnoj_prior")),
    "se3/state_prior": _one_thread(_se3_state_prior),
    "se3/interpolation": _one_thread(se3.interpolation_quantities),
    "se3/wnoj_interpolation": _one_thread(se3.interpolation_quantities),
    "se3/extrapolation": _one_thread(se3.extrapolation_quantities),
    "se3/batch": _one_thread(partial(_batch, se3.LIE3)),
    "se3/incremental": _one_thread(partial(_incremental, se3.LIE3)),
}


def oracle_case(suite: str, name: str, inputs: Mapping) -> dict:
    """The oracle's quantities of an independent case (a superset of those it is checked on), computed without
    steam_ref's numerics."""
    kind = case_type(suite, inputs)
    if kind not in ORACLES:
        raise SteamError(f"case {suite}/{name}: no oracle for case type {kind!r}")
    return ORACLES[kind](inputs)


# How the kit names a combination of alternative conventions → oracle switches.
ALTERNATIVES: dict[str, dict[str, object]] = {
    "paper-sign": {"paper_sign": True},
    "symmetric-whitener": {"symmetric": True},
    "paper-sign+symmetric-whitener": {"paper_sign": True, "symmetric": True},
    "signed-half-turn": {"half_turn": None},  # kit v5: SE(2)'s ±π kept as computed (gtsam.Pose2's)
}
SIGN_AND_WHITENER = ("paper-sign", "symmetric-whitener", "paper-sign+symmetric-whitener")


def _whitener_alternative(inputs: Mapping, switches: Mapping) -> dict:
    if not switches.get("symmetric"):
        return {}
    qc = np.asarray(inputs["qc"], float)
    A, F = o.model_matrices("wnoa", qc.shape[0])
    return {"W": o.sqrt_information(o.process_noise(A, F, qc, float(inputs["dt"])), symmetric=True)}


def _factor_alternative(inputs: Mapping, switches: Mapping) -> dict:
    spec = inputs["factor"]
    xs = [inputs["values"][k] for k in spec["keys"]]
    mine, theirs = o.linearize_factor(spec, xs), o.linearize_factor(spec, xs, **switches)
    return {q: v for q, v in theirs.items() if q not in ("cost", "weight") and not np.array_equal(v, mine[q])}


def _linear_alternative(inputs: Mapping, switches: Mapping) -> dict:
    problem = g.Problem(inputs["problem"])
    A, b, _ = g.dense_system(problem, problem.values, inputs["ordering"], **switches)
    A0, b0, _ = g.dense_system(problem, problem.values, inputs["ordering"])
    return {q: v for q, v, v0 in (("A", A, A0), ("b", b, b0)) if not np.array_equal(v, v0)}


def _half_turn_alternative(mine: Callable[..., dict], inputs: Mapping, switches: Mapping) -> dict:
    """Exp and Log of SE(2) with atan2's ±π kept (the half turn signed as computed): the quantities that differ."""
    theirs, kit = _one_thread(partial(mine, half_turn=switches["half_turn"]))(inputs), _one_thread(mine)(inputs)
    return {q: v for q, v in theirs.items() if not np.array_equal(v, kit[q])}


# Case type → its quantities under alternative conventions, and the combinations (ALTERNATIVES) it has them for
# (types not listed depend on none).
ALTERNATIVE_ORACLES: dict[str, tuple[Callable[[Mapping, Mapping], dict], tuple[str, ...]]] = {
    "gp/wnoa": (_whitener_alternative, SIGN_AND_WHITENER),
    "factors": (_factor_alternative, SIGN_AND_WHITENER),
    "linear": (_linear_alternative, SIGN_AND_WHITENER),
    "se2/exp": (partial(_half_turn_alternative, _exp), ("signed-half-turn",)),
    "se2/log": (partial(_half_turn_alternative, _log), ("signed-half-turn",)),
}


def oracle_alternatives(suite: str, inputs: Mapping) -> dict:
    """The convention-dependent quantities of a case under each combination of the alternative conventions its type
    depends on. Only quantities whose values differ from the kit's own conventions are listed, and only combinations
    that change some (a checker takes, of the conventions given, those a case's alternatives name)."""
    alternative, names = ALTERNATIVE_ORACLES.get(case_type(suite, inputs), (None, ()))
    if alternative is None:
        return {}
    out = {name: alternative(inputs, ALTERNATIVES[name]) for name in names}
    return {name: alt for name, alt in out.items() if alt}
