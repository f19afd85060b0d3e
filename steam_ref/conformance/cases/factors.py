"""The ``factors`` suite: every factor type at given points."""

from __future__ import annotations

from .base import ORACLE_FACTOR, QC_DIAG, QC_FULL, X1, X2, Case, tol

__all__ = ["factor_cases"]

L0, L1 = [4.0, 6.0], [-2.0, 3.5]
FACTOR_TOL = {
    "error": tol(1e-12, 1e-15),
    "whitened_error": tol(1e-11, 1e-14),
    "H": tol(1e-10, 1e-14),
    "A": tol(1e-10, 1e-14),
    "b": tol(1e-11, 1e-14),
    "cost": tol(1e-11, 1e-15),
    "weight": tol(1e-12, 1e-15),
}


def _factor_case(name: str, equation: str, description: str, spec: dict, values: dict) -> Case:
    n = len(spec["keys"])
    quantities = ["error", "whitened_error", *[f"H_{k}" for k in range(n)], *[f"A_{k}" for k in range(n)], "b", "cost"]
    if "loss" in spec or "loss" in spec.get("inner", {}):
        quantities.append("weight")
    tolerance = {q: FACTOR_TOL[q.split("_")[0] if q[:2] in ("H_", "A_") else q] for q in quantities}
    if spec["type"] == "interpolated":
        tolerance = {q: (tol(1e-8, 1e-12) if q != "weight" else t) for q, t in tolerance.items()}
    return Case(name, equation, description, {"factor": spec, "values": values}, tolerance, True, ORACLE_FACTOR)


def factor_cases() -> list[Case]:
    xa, la = {"x0": X1, "x1": X2}, {"x0": X1, "l0": L0}
    rng = lambda measured, sigma, **loss: {
        "type": "range",
        "keys": ["x0", "l0"],
        "measured": measured,
        "sigma": sigma,
        **loss,
    }
    huber, tukey = {"type": "huber", "k": 1.345}, {"type": "tukey", "c": 4.685}
    x_back = [1.0, 2.0, -0.45, 0.8, -0.2, 0.1]
    c = [
        _factor_case(
            "gp_prior_diag_qc",
            "[YIB Eq. 22, 30-31]",
            "GP prior over Δt = 0.5, diagonal Qc",
            {"type": "gp_prior", "keys": ["x0", "x1"], "dt": 0.5, "qc": QC_DIAG},
            xa,
        ),
        _factor_case(
            "gp_prior_full_qc",
            "[YIB Eq. 22, 30-31]",
            "GP prior over Δt = 0.35, full Qc",
            {"type": "gp_prior", "keys": ["x0", "x1"], "dt": 0.35, "qc": QC_FULL},
            xa,
        ),
        _factor_case(
            "prior_state",
            "[YIB Eq. 5]",
            "prior on a state, sigmas",
            {
                "type": "prior",
                "keys": ["x0"],
                "mean": [0.95, 2.1, 0.25, 0.75, -0.15, 0.05],
                "sigmas": [0.1, 0.1, 0.05, 0.2, 0.2, 0.1],
            },
            {"x0": X1},
        ),
        _factor_case(
            "prior_landmark",
            "[YIB Eq. 4]",
            "prior on a landmark, full covariance",
            {"type": "prior", "keys": ["l0"], "mean": [3.8, 6.3], "covariance": [[0.25, 0.05], [0.05, 0.16]]},
            {"l0": L0},
        ),
        _factor_case(
            "odometry",
            "[YIB Eq. 32]",
            "forward speed and yaw rate",
            {"type": "odometry", "keys": ["x0"], "measured": [0.75, 0.09], "sigmas": [0.05, 0.01]},
            {"x0": X1},
        ),
        _factor_case(
            "velocity",
            "[YIB Sec. IV]",
            "the scripts' projected velocity [forward, lateral, yaw rate]",
            {"type": "velocity", "keys": ["x0"], "measured": [0.8, 0.02, 0.11], "sigmas": [0.05, 0.05, 0.01]},
            {"x0": X1},
        ),
        _factor_case("range", "[YIB Eq. 33]", "range to a landmark", rng(4.9, 0.2), la),
        _factor_case(
            "range_huber_inside",
            "[YIB Eq. 33]",
            "Huber (k = 1.345), whitened error 0.5: weight 1",
            rng(4.9, 0.2, loss=huber),
            la,
        ),
        _factor_case(
            "range_huber_outside",
            "[YIB Eq. 33]",
            "Huber (k = 1.345), whitened error 4: weight k/s",
            rng(4.2, 0.2, loss=huber),
            la,
        ),
        _factor_case(
            "range_tukey_inside", "[YIB Eq. 33]", "Tukey (c = 4.685), whitened error 2.5", rng(4.5, 0.2, loss=tukey), la
        ),
        _factor_case(
            "range_tukey_outside",
            "[YIB Eq. 33]",
            "Tukey (c = 4.685), whitened error 7.5: weight 0",
            rng(3.5, 0.2, loss=tukey),
            la,
        ),
        _factor_case(
            "bearing",
            "[YIB Eq. 2]",
            "bearing atan2(ℓy - y, ℓx - x) - θ (a sensor the paper does not use)",
            {"type": "bearing", "keys": ["x0", "l0"], "measured": 0.6, "sigma": 0.05},
            la,
        ),
        _factor_case(
            "bearing_wrap",
            "[YIB Eq. 2]",
            "bearing whose raw error is 6.23 rad: wrapped to [-π, π)",
            {"type": "bearing", "keys": ["x0", "l1"], "measured": -3.1, "sigma": 0.05},
            {"x0": x_back, "l1": L1},
        ),
        _factor_case(
            "bearing_range",
            "[YIB Eq. 33]",
            "bearing and range together, full covariance",
            {
                "type": "bearing_range",
                "keys": ["x0", "l1"],
                "measured": [2.35, 3.4],
                "covariance": [[0.0025, 0.001], [0.001, 0.04]],
            },
            {"x0": X1, "l1": L1},
        ),
        _factor_case(
            "interpolated_range",
            "[YIB Eq. 18-19, 29, 33]",
            "a range at τ = 0.2 between states at 0 and 0.5",
            {
                "type": "interpolated",
                "keys": ["x0", "x1", "l0"],
                "t1": 0.0,
                "t2": 0.5,
                "tau": 0.2,
                "qc": QC_DIAG,
                "inner": {"type": "range", "measured": 4.95, "sigma": 0.2},
            },
            {**xa, "l0": L0},
        ),
        _factor_case(
            "interpolated_velocity",
            "[YIB Eq. 18-19, 29]",
            "a projected velocity at τ = 0.35 between states at 0 and 0.5",
            {
                "type": "interpolated",
                "keys": ["x0", "x1"],
                "t1": 0.0,
                "t2": 0.5,
                "tau": 0.35,
                "qc": QC_DIAG,
                "inner": {"type": "velocity", "measured": [0.75, 0.0, 0.11], "sigmas": [0.5, 0.01, 0.02]},
            },
            xa,
        ),
        _factor_case(
            "interpolated_range_tukey",
            "[YIB Eq. 29, 33]",
            "an interpolated range with Tukey's loss (c = 4.685)",
            {
                "type": "interpolated",
                "keys": ["x0", "x1", "l0"],
                "t1": 0.0,
                "t2": 0.5,
                "tau": 0.4,
                "qc": QC_DIAG,
                "inner": {"type": "range", "measured": 4.6, "sigma": 0.2, "loss": tukey},
            },
            {**xa, "l0": L0},
        ),
        _factor_case(
            "gp_prior_heading_past_pi",
            "[YIB Eq. 22, 30-31]",
            "GP prior between headings 3.05 and 3.35 (past π, continuous): nothing is wrapped, the states "
            "are used as given",
            {"type": "gp_prior", "keys": ["x0", "x1"], "dt": 0.5, "qc": QC_DIAG},
            {"x0": [1.0, 2.0, 3.05, 0.8, -0.2, 0.5], "x1": [1.4, 1.92, 3.35, 0.78, -0.15, 0.55]},
        ),
        _factor_case(
            "gp_prior_heading_jump",
            "[YIB Eq. 22, 30-31]",
            "GP prior between headings stored 3.05 and -3.0 (2π apart, less 0.23): the heading error is "
            "-6.3, not wrapped (the conventions wrap bearing errors only); a port that wraps it gets -0.017",
            {"type": "gp_prior", "keys": ["x0", "x1"], "dt": 0.5, "qc": QC_DIAG},
            {"x0": [1.0, 2.0, 3.05, 0.8, -0.2, 0.5], "x1": [1.4, 1.92, -3.0, 0.78, -0.15, 0.55]},
        ),
        _factor_case(
            "range_huber_at_threshold",
            "[YIB Eq. 33]",
            "Huber (k = 2) exactly at its threshold: range 5, measured 4.5, σ = 0.25, so ‖We‖ = 2 = k exactly "
            "(every step exact in binary): weight 1, cost k²/2 (both branches agree there)",
            rng(4.5, 0.25, loss={"type": "huber", "k": 2.0}),
            {"x0": [1.0, 2.0, 0.3, 0.8, -0.2, 0.1], "l0": L0},
        ),
        _factor_case(
            "range_tukey_at_threshold",
            "[YIB Eq. 33]",
            "Tukey (c = 2) exactly at its threshold: ‖We‖ = 2 = c exactly: weight 0, cost c²/6, A and b zero",
            rng(4.5, 0.25, loss={"type": "tukey", "c": 2.0}),
            {"x0": [1.0, 2.0, 0.3, 0.8, -0.2, 0.1], "l0": L0},
        ),
        _factor_case(  # kit v4
            "range_at_landmark",
            "[YIB Eq. 33]",
            "the robot exactly at the landmark: the distance is 0, so the error is 0 - r = -0.4; the norm has no "
            "derivative there, and by the kit's convention (conventions, range_at_landmark; gpslam's and STEAM's) "
            "H_0, H_1, A_0 and A_1 are zero rows, b = -W e",
            rng(0.4, 0.2),
            {"x0": [2.0, 3.0, 0.3, 0.8, -0.2, 0.1], "l0": [2.0, 3.0]},
        ),
    ]
    return c
