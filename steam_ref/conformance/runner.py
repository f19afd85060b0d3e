"""steam_ref's own results for the kit's cases: the installed code run on each case's stored inputs.

:func:`run_case` is what an implementation under test does, written with steam_ref: it reads a
case's inputs and returns its output quantities in the kit's conventions (a superset of those the case
is checked on). :data:`RUNNERS` maps each case type (:func:`.kitio.case_type`: the suite, and the ``kind``
its inputs name) to the function computing it; every suite's factor specs are read by one table
(:mod:`.spec`), and the problems of every suite are solved by :mod:`steam_ref.conformance.solvers`, whatever their variables'
kinds. ``selftest`` checks these results against the shipped kit; the build uses them as the expected
values of the cases that are not independent, and checks them against the oracle for those that are.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping
from functools import partial

import numpy as np
from numpy.typing import NDArray

from .. import lie
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
from ..gp.interpolate import interpolation_terms
from ..lie import SE2, SE2_STATE, gp_accel
from ..lie import gp as lie_gp
from ..lie.group import LieGroup
from ..linear.system import linearize
from . import solvers, spec
from .kitio import case_type

__all__ = ["RUNNERS", "run_case"]


def _qc(inputs: Mapping) -> NDArray:
    return np.asarray(inputs["qc"], float)


# --- gp -------------------------------------------------------------------------------------------


def _wnoa(inputs: Mapping) -> dict:
    dt, qc = float(inputs["dt"]), _qc(inputs)
    return {
        "Phi": transition(dt, qc.shape[0]),
        "Q": process_noise(dt, qc),
        "Qinv": process_noise_inverse(dt, qc),
        "W": process_noise_sqrt_information(dt, qc),
    }


def _lti(inputs: Mapping) -> dict:
    A, F, v = (np.asarray(inputs[k], float) for k in ("A", "F", "v"))
    sde, dt = LinearSDE(A, F, _qc(inputs), v).general(), float(inputs["dt"])
    return {"Phi": sde.transition(dt), "Q": sde.process_noise(dt), "v_i": sde.input_integral(dt)}


def _wnoj(inputs: Mapping) -> dict:
    dt, qc = float(inputs["dt"]), _qc(inputs)
    return {
        "Phi": wnoj_transition(dt, qc.shape[0]),
        "Q": wnoj_process_noise(dt, qc),
        "Qinv": wnoj_process_noise_inverse(dt, qc),
    }


def _singer(inputs: Mapping) -> dict:
    dt, alpha, qc = float(inputs["dt"]), float(inputs["alpha"]), _qc(inputs)
    return {"Phi": singer_transition(dt, alpha, qc.shape[0]), "Q": singer_process_noise(dt, alpha, qc)}


def _extrapolation(inputs: Mapping) -> dict:
    sde, t1, t = LinearSDE.wnoa(_qc(inputs)), float(inputs["t1"]), float(inputs["t"])
    return {
        "x_t": extrapolate_state_sde(sde, t1, inputs["x1"], t),
        "cov_t": extrapolate_covariance_sde(sde, t1, t, inputs["cov1"]),
    }


def _times(inputs: Mapping) -> tuple[float, float, float]:
    return float(inputs["t1"]), float(inputs["t2"]), float(inputs["tau"])


def _interpolation(inputs: Mapping) -> dict:
    (t1, t2, tau), qc = _times(inputs), _qc(inputs)
    lam, psi = interpolation_matrices(t1, t2, tau, qc)
    return {"Lambda": lam, "Psi": psi, "x_tau": interpolate_state(t1, inputs["x1"], t2, inputs["x2"], tau, qc)}


def _interpolation_covariance(inputs: Mapping) -> dict:
    (t1, t2, tau), joint = _times(inputs), np.asarray(inputs["joint_cov"], float)
    return {"cov_tau": interpolate_covariance(t1, t2, tau, _qc(inputs), joint)}


def _singer_interpolation(inputs: Mapping) -> dict:
    (t1, t2, tau), sde = _times(inputs), LinearSDE.singer(_qc(inputs), float(inputs["alpha"]))
    lam, psi = interpolation_matrices_sde(sde, t1, t2, tau)
    return {"Lambda": lam, "Psi": psi, "x_tau": interpolate_state_sde(sde, t1, inputs["x1"], t2, inputs["x2"], tau)}


# --- factors --------------------------------------------------------------------------------------


def _factor(inputs: Mapping) -> dict:
    """A factor at given values: e, W e, H_k, A_k, b, the cost (and the robust weight)."""
    with warnings.catch_warnings():  # a case at a degenerate point is evaluated there on purpose
        warnings.simplefilter("ignore", DegenerateMeasurementWarning)
        f = spec.factor(inputs["factor"])
        values = spec.values(inputs["values"], spec.key_kinds([inputs["factor"]]))
        xs = [values[k] for k in f.keys]
        we = f.whitened_error(*xs)
        (group,) = linearize([f], values)
        out: dict[str, NDArray | float] = {"error": f.error(*xs), "whitened_error": we}
        out.update({f"H_{k}": H for k, H in enumerate(f.jacobians(*xs))})
        out.update({f"A_{k}": J[0] for k, J in enumerate(group.jacobian_blocks())})
        out["b"], out["cost"] = group.rhs[0], float(group.costs[0])
        if f.loss is not None:
            out["weight"] = float(f.loss.weight(np.asarray(np.linalg.norm(we))))
        return out


def _lie_prior(inputs: Mapping) -> dict:
    """The WNOA prior between two SE(2) states: a factor case whose inputs name the two states x1, x2."""
    factor = {"type": "se2_prior", "keys": ["x1", "x2"], **{k: inputs[k] for k in ("dt", "qc", "model")}}
    return _factor({"factor": factor, "values": {"x1": inputs["x1"], "x2": inputs["x2"]}})


def _lie_state_prior(inputs: Mapping) -> dict:
    """A prior on one SE(2) state: its error x ⊖ mean and Jacobian (no noise given: unit sigmas)."""
    factor = {"type": "se2_state_prior", "keys": ["x0"], "mean": inputs["mean"], "sigmas": [1.0] * 6}
    return _factor({"factor": factor, "values": {"x0": inputs["x"]}})


# --- a Lie group ----------------------------------------------------------------------------------


def _group(name: str) -> LieGroup:
    """The group a case type names (SE(3) and SO(3) load when a case first asks)."""
    return getattr(lie, name)


def _exp(name: str, inputs: Mapping) -> dict:
    g = _group(name)
    elements = g.exp(np.asarray(inputs["xi" if "xi" in inputs else "phi"], float))
    return {"exp": elements, "log_of_exp": g.log(elements)}


def _log(name: str, inputs: Mapping) -> dict:
    g = _group(name)
    tangents = g.log(np.asarray(inputs["poses"], float))
    return {"log": tangents, "exp_of_log": g.exp(tangents)}


def _jacobians(name: str, inputs: Mapping) -> dict:
    g = _group(name)
    xi = np.asarray(inputs["xi" if "xi" in inputs else "phi"], float)
    return {"Jr": g.right_jacobian(xi), "Jr_inv": g.right_jacobian_inverse(xi)}


def _between(name: str, inputs: Mapping) -> dict:
    g = _group(name)
    a, b = np.asarray(inputs["a"], float), np.asarray(inputs["b"], float)
    between, Ha, Hb = g.between(a, b, jacobians=True)
    return {"between": between, "H_a": Ha, "H_b": Hb, "Ad_a": g.adjoint(a)}


def _se3_prior(kind: str, inputs: Mapping) -> dict:
    """A prior between two SE(3) states (``kind`` its factor type): a factor case naming the states x1, x2."""
    factor = {"type": kind, "keys": ["x1", "x2"], **{k: inputs[k] for k in ("dt", "qc", "model") if k in inputs}}
    return _factor_alone(factor, [inputs["x1"], inputs["x2"]])


def _se3_state_prior(inputs: Mapping) -> dict:
    factor = {"type": "se3_state_prior", "keys": ["x0"], "mean": inputs["mean"], "sigmas": [1.0] * 12}
    return _factor_alone(factor, [inputs["x"]])


def _factor_alone(factor_spec: Mapping, xs: list) -> dict:
    """A factor's error, whitened error, Jacobians and cost from its own methods (an SE(3) state is stored in more
    numbers than its tangent has, which the linear layer's size check does not take yet)."""
    f = spec.factor(factor_spec)
    xs = [np.asarray(x, float) for x in xs]
    we = f.whitened_error(*xs)
    out: dict = {"error": f.error(*xs), "whitened_error": we, "cost": 0.5 * float(we @ we)}
    out.update({f"H_{k}": H for k, H in enumerate(f.jacobians(*xs))})
    return out


def _se3_interpolation(inputs: Mapping) -> dict:
    """The local GP between two SE(3) states: x(τ), J_1, J_2 (and, given ``joint_cov``, its covariance)."""
    x1, x2, model = np.asarray(inputs["x1"], float), np.asarray(inputs["x2"], float), inputs["model"]
    (t1, t2, tau), qc = _times(inputs), _qc(inputs)
    lam, psi = interpolation_matrices(t1, t2, tau, qc)
    x, J1, J2 = lie_gp.interpolate(x1, x2, lam, psi, model, group=lie.SE3)
    out = {"x_tau": x, "J_1": J1, "J_2": J2}
    if "joint_cov" in inputs:
        _, out["cov_tau"] = lie_gp.interpolate_covariance(
            t1, t2, tau, qc, x1, x2, inputs["joint_cov"], model, group=lie.SE3
        )
    return out


def _se3_wnoj_interpolation(inputs: Mapping) -> dict:
    x1, x2 = np.asarray(inputs["x1"], float), np.asarray(inputs["x2"], float)
    lam, psi, offset = interpolation_terms(LinearSDE.wnoj(_qc(inputs)), *_times(inputs))
    x, J1, J2 = gp_accel.interpolate(x1, x2, lam, psi, offset, group=lie.SE3)
    return {"x_tau": x, "J_1": J1, "J_2": J2}


def _se3_extrapolation(inputs: Mapping) -> dict:
    x1, t1, t = np.asarray(inputs["x1"], float), float(inputs["t1"]), float(inputs["t"])
    if len(x1) == 24:  # WNOJ: a pose, its twist and acceleration
        sde, s = LinearSDE.wnoj(_qc(inputs)), t - t1
        phi, offset = sde.transition(s), sde.input_integral(s)
        x, J = gp_accel.extrapolate(x1, phi, offset, group=lie.SE3)
        _, cov = gp_accel.extrapolate_covariance(x1, phi, offset, sde.process_noise(s), inputs["cov1"], group=lie.SE3)
        return {"x_t": x, "J_1": J, "cov_t": cov}
    x, J = lie_gp.extrapolate(x1, t1, t, group=lie.SE3)
    _, cov = lie_gp.extrapolate_covariance(x1, t1, t, _qc(inputs), inputs["cov1"], group=lie.SE3)
    return {"x_t": x, "J_1": J, "cov_t": cov}


def _lie_interpolation(inputs: Mapping) -> dict:
    """The local GP between two SE(2) states: x(τ) and its Jacobians, or (given ``joint_cov``) its covariance."""
    x1, x2, model = np.asarray(inputs["x1"], float), np.asarray(inputs["x2"], float), inputs["model"]
    (t1, t2, tau), qc = _times(inputs), _qc(inputs)
    if "joint_cov" in inputs:
        x, cov = lie_gp.interpolate_covariance(t1, t2, tau, qc, x1, x2, inputs["joint_cov"], model, group=SE2)
        return {"x_tau": x, "cov_tau": cov}
    lam, psi = interpolation_matrices(t1, t2, tau, qc)
    x, J1, J2 = lie_gp.interpolate(x1, x2, lam, psi, model, group=SE2)
    return {"x_tau": x, "J_1": J1, "J_2": J2}


def _lie_extrapolation(inputs: Mapping) -> dict:
    """The prediction after the last SE(2) state: x(t), ∂x(t)/∂x₁ and its covariance under the case's model."""
    x1, t1, t = np.asarray(inputs["x1"], float), float(inputs["t1"]), float(inputs["t"])
    x, J = lie_gp.extrapolate(x1, t1, t, group=SE2)
    _, cov = lie_gp.extrapolate_covariance(x1, t1, t, _qc(inputs), inputs["cov1"], inputs["model"], group=SE2)
    return {"x_t": x, "J_1": J, "cov_t": cov}


def _lie_retraction(inputs: Mapping) -> dict:
    """x ⊕ δ of each row on SE(2) states, and (x ⊕ δ) ⊖ x."""
    x, delta = np.asarray(inputs["x"], float), np.asarray(inputs["delta"], float)
    moved = SE2_STATE.retract(x, delta)
    return {"retract": moved, "local": SE2_STATE.local(x, moved)}


# Case type → steam_ref's quantities of a case of that type. A new type is a row here and one in
# expected.ORACLES (tests/test_conformance.py checks that both cover every case of every shipped kit).
RUNNERS: dict[str, Callable[[Mapping], dict]] = {
    "gp/wnoa": _wnoa,
    "gp/wnoj": _wnoj,
    "gp/singer": _singer,
    "gp/lti": _lti,
    "gp/extrapolation": _extrapolation,
    "gp/interpolation": _interpolation,
    "gp/interpolation_covariance": _interpolation_covariance,
    "gp/singer_interpolation": _singer_interpolation,
    "factors": _factor,
    "linear": solvers.linear,
    "batch": solvers.batch,
    "bayes_tree": solvers.bayes_tree,
    "incremental": solvers.incremental,
    "fixed_lag": solvers.fixed_lag,
    "se2/exp": partial(_exp, "SE2"),
    "se2/log": partial(_log, "SE2"),
    "se2/jacobians": partial(_jacobians, "SE2"),
    "se2/between": partial(_between, "SE2"),
    "se2/prior": _lie_prior,
    "se2/state_prior": _lie_state_prior,
    "se2/interpolation": _lie_interpolation,
    "se2/batch": solvers.batch,
    "se2/incremental": solvers.incremental,
    "se2/reading": _factor,  # kit v5: readings of SE(2) states, as the factors suite's cases
    "se2/retract": _lie_retraction,
    "se2/extrapolation": _lie_extrapolation,
    "se2/fixed_lag": solvers.fixed_lag,
    "se3/so3_exp": partial(_exp, "SO3"),
    "se3/so3_jacobians": partial(_jacobians, "SO3"),
    "se3/exp": partial(_exp, "SE3"),
    "se3/jacobians": partial(_jacobians, "SE3"),
    "se3/between": partial(_between, "SE3"),
    "se3/prior": partial(_se3_prior, "se3_prior"),
    "se3/wnoj_prior": partial(_se3_prior, "se3_wnoj_prior"),
    "se3/state_prior": _se3_state_prior,
    "se3/interpolation": _se3_interpolation,
    "se3/wnoj_interpolation": _se3_wnoj_interpolation,
    "se3/extrapolation": _se3_extrapolation,
    "se3/batch": solvers.batch,  # kit v5: on lie.SE3V's form of the states (spec.SOLVER_FORMS)
    "se3/incremental": solvers.incremental,
}


def run_case(suite: str, name: str, inputs: Mapping) -> dict:
    """The output quantities of one case, computed by steam_ref from the case's inputs (a superset of those the
    case is checked on)."""
    kind = case_type(suite, inputs)
    if kind not in RUNNERS:
        raise SteamError(f"case {suite}/{name}: no runner for case type {kind!r}")
    return RUNNERS[kind](inputs)
