"""The se3 suite's problems on SE(3) states (kit v5): Gauss-Newton on three states and the same problem as an iSAM2
stream. The oracle solves them on the kit's states [t; R; w] (``oracle_rigid.LIE3``); steam_ref's solvers take a
variable's stored size for its tangent's, so its runner holds each state in lie.SE3V's form [t; phi; w] and writes
the estimates back (``spec.SOLVER_FORMS``).
"""

from __future__ import annotations

from collections.abc import Mapping

from .base import Case, stream_checks, tol
from .rigid_poses import POSE_G0, POSE_G1, POSE_G2

__all__ = ["solve_cases"]

ORACLE_SOLVE = (
    "oracle: dense Gauss-Newton and a dense iSAM2 replay with the oracle's right retraction on SE(3) states, each "
    "factor linearized by the differences above"
)
EQUATION = "[YIB Eq. 6-11, 22, 30-31] on SE(3) states; README 'SE(3)'"
SOLVE = tol(1e-9, 1e-11)
QC = [[0.5 if i == j else 0.0 for j in range(6)] for i in range(3)] + [
    [0.05 if i == j else 0.0 for j in range(6)] for i in range(3, 6)
]


def _case(name: str, description: str, inputs: dict, tolerance: Mapping, source: str) -> Case:
    return Case(name, EQUATION, description, inputs, tolerance, True, source)


def _lv(a: str, b: str, dt: float = 0.5) -> dict:
    return {"type": "se3_prior", "keys": [a, b], "dt": dt, "qc": QC, "model": "local-variable"}


SIGMAS = [0.02, 0.02, 0.02, 0.01, 0.01, 0.01, 0.1, 0.1, 0.1, 0.1, 0.1, 0.1]
FIX_X0 = {
    "type": "se3_state_prior",
    "keys": ["x0"],
    "mean": POSE_G0 + [1.1, 0.0, 0.2, 0.1, -0.04, 1.3],
    "sigmas": SIGMAS,
}
FIX_X2 = {
    "type": "se3_state_prior",
    "keys": ["x2"],
    "mean": POSE_G2 + [1.0, -0.1, 0.25, 0.15, 0.05, 1.2],
    "sigmas": [0.05, 0.05, 0.05, 0.02, 0.02, 0.02, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
}
GYRO_X1 = {
    "type": "se3_velocity",
    "keys": ["x1"],
    "measured": [1.05, 0.05, 0.2, 0.12, -0.02, 1.25],
    "sigmas": [0.1] * 6,
}
START = {
    "x0": POSE_G0 + [1.0, 0.05, 0.15, 0.1, 0.0, 1.2],
    "x1": POSE_G1 + [1.0, 0.0, 0.2, 0.1, -0.05, 1.3],
    "x2": POSE_G2 + [0.9, -0.05, 0.2, 0.1, 0.05, 1.1],
}


def solve_cases() -> list[Case]:
    variables = {"x0": 12, "x1": 12, "x2": 12}
    factors = [FIX_X0, _lv("x0", "x1"), _lv("x1", "x2"), GYRO_X1, FIX_X2]
    updates = [
        {"values": {"x0": START["x0"]}, "factors": [FIX_X0]},
        {"values": {"x1": START["x1"]}, "factors": [_lv("x0", "x1"), GYRO_X1]},
        {"values": {"x2": START["x2"]}, "factors": [_lv("x1", "x2"), FIX_X2]},
    ]
    isam2 = {"relinearize_threshold": 0.02, "relinearize_skip": 1, "wildfire_threshold": 0.0}
    quantities = stream_checks(len(updates), SOLVE)
    return [
        _case(
            "batch_three_states",
            "Gauss-Newton on three SE(3) states 0.5 s apart (local-variable WNOA priors, a state prior on x0 and on x2, "
            "a body-twist reading at x1, e = w - z); every iterate x <- x + delta (right retraction) and the cost at "
            "each, from a given start; 'variables' gives each state's tangent size (12), values hold 18 numbers",
            {
                "kind": "batch",
                "problem": {"variables": variables, "factors": factors, "values": START},
                "iterations": 3,
            },
            {"iterates": SOLVE, "costs": SOLVE},
            ORACLE_SOLVE,
        ),
        _case(
            "incremental_three_updates",
            "the same problem as a stream of three iSAM2 updates (one state per update with its factors), "
            "relinearization threshold 0.02 checked every update, full back-substitution; relinearized_k and "
            "estimate_k = theta + delta after each update",
            {"kind": "incremental", "stream": {"variables": variables, "updates": updates}, "isam2": isam2},
            quantities,
            ORACLE_SOLVE,
        ),
    ]
