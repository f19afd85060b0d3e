"""Readings of SE(2) states in the ``se2`` suite (kit v5; kit v4 had a range only inside its solves): range, bearing
and bearing-range of the pose to a landmark, the body-twist reading, and readings at a time τ between two states
through the local GP's mean (both models, t₁ ≠ 0). Each is a factor case as the factors suite's: error, whitened
error, Jacobians in the right tangent of each state (H_k, A_k), b and cost. Every case is independent:
:mod:`steam_ref.conformance.oracle_lie` (the error written out, Jacobians by Romberg-extrapolated central
differences through the right retraction, the local GP from the dense WNOA kernel).
"""

from __future__ import annotations

from collections.abc import Mapping

from .base import AT_TAU, EXACT_JACOBIAN, GROUP, Case, tol
from .lie_groups import QC

__all__ = ["reading_cases"]

ORACLE_READING = (
    "oracle: the error written out from the pose [x, y, theta] (as the factors suite's vector state) or the body "
    "twist; Jacobians by central differences (h = 0.04, 0.02, 0.01, 0.005, Romberg) through the right retraction "
    "x + d = (T Exp(d[:3]), w + d[3:]) of each state (a landmark: l + d)"
)
ORACLE_AT_TAU = (
    ORACLE_READING + "; x(tau) the local GP's mean, Lambda and Psi by conditioning the dense WNOA prior of the local "
    "variable [xi; xi_dot]"
)
EQUATION = "[YIB Eq. 29, 33] on SE(2) states; README 'SE(2)'"

STATE = [1.0, 2.0, 0.3, 0.8, -0.1, 0.4]  # x0: heading 0.3, moving forward and turning
MARK = [-1.5, 2.6]  # l0: behind the robot (its bearing 2.6 rad from the heading)
X1 = [1.0, 2.0, 2.9, 1.2, 0.1, 0.9]  # the states around tau: the second heading past +pi, stored as -3.0
X2 = [-0.15, 2.2, -3.0, 1.1, -0.1, 1.0]


def _quantities(keys: int, value: Mapping) -> dict:
    out = {"error": value, "whitened_error": value}
    out.update({f"H_{k}": EXACT_JACOBIAN for k in range(keys)})
    out.update({f"A_{k}": EXACT_JACOBIAN for k in range(keys)})
    return {**out, "b": value, "cost": tol(1e-11)}


def _reading(name: str, description: str, spec: dict, values: dict, tau: bool = False) -> Case:
    inputs = {"kind": "reading", "factor": spec, "values": values}
    value = AT_TAU if tau else GROUP  # error, whitened error, b
    source = ORACLE_AT_TAU if tau else ORACLE_READING
    return Case(name, EQUATION, description, inputs, _quantities(len(spec["keys"]), value), True, source)


WHAT = (
    "e = h(x, l) - y; H_0 = de/d(delta) in the right tangent of the state (the pose's position moves by R(theta) "
    "d_rho: H_0's position columns are the vector state's times R(theta)), H_1 = de/dl; A_k = W H_k, W upper "
    "triangular with W^T W = Sigma^-1; b = -W e; cost = 1/2 |W e|^2"
)


def reading_cases() -> list[Case]:
    twist = {"type": "se2_velocity", "measured": [1.15, 0.2, 0.95], "sigmas": [0.1, 0.05, 0.02]}
    at_tau = {"t1": 4.5, "t2": 5.25, "qc": QC}
    return [
        _reading(
            "range_reading",
            f"range from an SE(2) state's position to a landmark, e = |l - p| - r. {WHAT}",
            {"type": "se2_range", "keys": ["x0", "l0"], "measured": 2.4, "sigma": 0.1},
            {"x0": STATE, "l0": MARK},
        ),
        _reading(
            "bearing_reading_wrapped",
            "bearing of a landmark in the body frame, e = wrap(atan2(ly - py, lx - px) - theta - y) with wrap to "
            f"[-pi, pi): here h = 2.606 and y = -3.1, so h - y = 5.706 wraps to -0.577 (a port without the wrap "
            f"fails). {WHAT}",
            {"type": "se2_bearing", "keys": ["x0", "l0"], "measured": -3.1, "sigma": 0.05},
            {"x0": STATE, "l0": MARK},
        ),
        _reading(
            "bearing_range_reading_full_covariance",
            f"bearing and range together, e = [bearing error (wrapped); range error], with a full 2x2 covariance of "
            f"[bearing, range] (W is not diagonal). {WHAT}",
            {
                "type": "se2_bearing_range",
                "keys": ["x0", "l0"],
                "measured": [2.5, 2.45],
                "covariance": [[0.0025, 0.001], [0.001, 0.04]],
            },
            {"x0": STATE, "l0": MARK},
        ),
        _reading(
            "body_velocity_reading",
            "the body twist [vx, vy, w] of an SE(2) state read directly, e = w - z; H_0 = [0 I] in the right tangent "
            "(the retraction moves the twist by d[3:])",
            {"type": "se2_velocity", "keys": ["x0"], "measured": [0.75, 0.05, 0.35], "sigmas": [0.1, 0.05, 0.02]},
            {"x0": STATE},
        ),
        _reading(
            "interpolated_bearing_range_late",
            "a bearing-range reading at tau = 4.8 between states at t1 = 4.5 and t2 = 5.25 (Lambda, Psi of tau - t1 "
            "and t2 - tau), model 'local-variable', the headings 2.9 and -3.0 (xi's angle 0.383 across +-pi): e = "
            "e_inner(x(tau), l) with x(tau) the local GP's mean (T1 Exp(xi(tau)), J_r(xi(tau)) xi_dot(tau)); H_0, H_1 "
            "in the right tangents of the two states, H_2 = de/dl",
            {
                "type": "se2_interpolated",
                "keys": ["x1", "x2", "l0"],
                **at_tau,
                "tau": 4.8,
                "model": "local-variable",
                "inner": {"type": "se2_bearing_range", "measured": [-2.0, 2.0], "sigmas": [0.05, 0.1]},
            },
            {"x1": X1, "x2": X2, "l0": MARK},
            tau=True,
        ),
        _reading(
            "interpolated_velocity_simplified",
            "a body-twist reading at tau = 5.1 between the same states, model 'simplified' (the twist at tau is "
            "xi_dot(tau), no J_r): e = w(tau) - z; H_0, H_1 in the right tangents of the two states",
            {
                "type": "se2_interpolated",
                "keys": ["x1", "x2"],
                **at_tau,
                "tau": 5.1,
                "model": "simplified",
                "inner": twist,
            },
            {"x1": X1, "x2": X2},
            tau=True,
        ),
    ]
