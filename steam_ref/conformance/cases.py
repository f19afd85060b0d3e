"""The kit's cases, inputs written out here as literal numbers (no random draws: the kit stores them).

Each :class:`Case` says what it computes ([YIB Eq. n]), its inputs, the tolerance of each output
quantity, and whether its expected values come from the independent oracle (:mod:`.oracle`,
:mod:`.oracle_graph`) or from steam_ref itself. The expected values are computed by :mod:`.build`.
The ``paper`` suite's cases are made from the data files by :mod:`.paper`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["Case", "tol", "EXACT", "suite_cases", "SUITE_DOCS"]

EXACT = "exact"


def tol(rtol: float, atol: float = 0.0) -> dict:
    """Pass when max|got - expected| ≤ atol + rtol · max|expected| (normwise)."""
    return {"atol": atol, "rtol": rtol}


@dataclass(frozen=True)
class Case:
    """One case of a suite: inputs, what is expected of which quantity, and where the expectation comes from."""

    name: str
    equation: str  # the paper's equations computed, '[YIB Eq. n]'
    description: str
    inputs: dict
    tolerance: dict  # quantity → tol(...) or EXACT
    independent: bool  # expected values from the oracle (True) or produced by steam_ref (False)
    source: str = ""  # how the expected values are obtained
    notes: dict = field(default_factory=dict)


ORACLE_GP = (
    "oracle: Φ = expm(AΔt) (SciPy); Q and vᵢ by 24-node Gauss-Legendre quadrature of their integrals; "
    "Q⁻¹ by a dense inverse; W = U⁻¹ for Σ = UUᵀ, U upper"
)
ORACLE_KERNEL = "oracle: [Λ Ψ] = K(τ)K⁻¹ and the conditional covariance by conditioning the dense prior of [x(t₁); x(τ); x(t₂)] (Eq. 12)"
ORACLE_FACTOR = "oracle: the error written out from its equation; Jacobians by complex-step differentiation; Λ, Ψ by the dense kernel"
ORACLE_DENSE = (
    "oracle: dense A, b from the oracle's factors; 𝓘 = AᵀA; R = upper Cholesky factor of 𝓘; dense triangular solves"
)

QC_DIAG = [[0.5, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 0.1]]
QC_FULL = [[0.5, 0.2, 0.05], [0.2, 0.4, 0.05], [0.05, 0.05, 0.1]]
X1 = [1.0, 2.0, 0.3, 0.8, -0.2, 0.1]
X2 = [1.45, 1.9, 0.38, 0.7, -0.1, 0.12]


def _spd(n: int, a: int, b: int) -> list[list[float]]:
    """(B Bᵀ + n I) / 64 for the integer matrix B_ij = (a i + b j) mod 7 - 3: exact in binary floating point."""
    B = [[(a * i + b * j) % 7 - 3 for j in range(n)] for i in range(n)]
    return [
        [(sum(B[i][k] * B[j][k] for k in range(n)) + (n if i == j else 0)) / 64 for j in range(n)] for i in range(n)
    ]


# --- gp -------------------------------------------------------------------------------------------


def _gp() -> list[Case]:
    cases = []
    for name, dt, qc in (
        ("wnoa_dt0.1", 0.1, QC_DIAG),
        ("wnoa_dt0.5", 0.5, QC_DIAG),
        ("wnoa_dt2", 2.0, QC_DIAG),
        ("wnoa_dt0.7_full_qc", 0.7, QC_FULL),
    ):
        cases.append(
            Case(
                name,
                "[YIB Eq. 16-17, 22, 30-31]",
                f"WNOA Φ, Q, Q⁻¹ and W (WᵀW = Q⁻¹, upper) over Δt = {dt}",
                {"kind": "wnoa", "dt": dt, "qc": qc},
                {"Phi": tol(1e-13), "Q": tol(1e-12), "Qinv": tol(1e-10), "W": tol(1e-10)},
                True,
                ORACLE_GP,
            )
        )
    lti = {
        "kind": "lti",
        "A": [[-0.3, 1.0, 0.2, 0.0], [-0.5, -0.2, 0.0, 0.4], [0.1, 0.0, -0.6, 1.0], [0.0, 0.3, -0.7, -0.1]],
        "F": [[0.0, 0.0], [1.0, 0.0], [0.0, 0.5], [0.2, 1.0]],
        "qc": [[0.8, 0.1], [0.1, 0.3]],
        "v": [0.1, -0.2, 0.05, 0.3],
    }
    for dt in (0.3, 1.7):
        cases.append(
            Case(
                f"lti_dt{dt}",
                "[YIB Eq. 14, 16-17, 23]",
                f"a general LTI SDE (A, F, Qc, v): Φ, Q and vᵢ over Δt = {dt}",
                {**lti, "dt": dt},
                {"Phi": tol(1e-12), "Q": tol(1e-11), "v_i": tol(1e-11)},
                True,
                ORACLE_GP,
            )
        )
    cases.append(
        Case(
            "wnoj_dt0.4",
            "[YIB Eq. 14, 16-17]",
            "white noise on jerk, x = [p; ṗ; p̈]: Φ, Q, Q⁻¹",
            {"kind": "wnoj", "dt": 0.4, "qc": QC_DIAG},
            {"Phi": tol(1e-13), "Q": tol(1e-12), "Qinv": tol(1e-8)},
            True,
            ORACLE_GP,
        )
    )
    for alpha, dt in ((0.8, 0.4), (3.0, 1.5)):
        cases.append(
            Case(
                f"singer_a{alpha:g}_dt{dt}",
                "[YIB Eq. 14, 16-17]",
                f"Singer's model p⃛ = -α p̈ + w, α = {alpha}: Φ and Q over Δt = {dt} (αΔt = {alpha * dt:g})",
                {"kind": "singer", "alpha": alpha, "dt": dt, "qc": QC_DIAG},
                {"Phi": tol(1e-13), "Q": tol(1e-11)},
                True,
                ORACLE_GP,
            )
        )
    for tau, qc, which in ((1.1, QC_DIAG, "diagonal"), (1.3, QC_FULL, "full"), (1.55, QC_DIAG, "diagonal")):
        cases.append(
            Case(
                f"interp_tau{tau}",
                "[YIB Eq. 16, 18]",
                f"Λ(τ), Ψ(τ) and x̄(τ) = Λ x̄₁ + Ψ x̄₂ for t₁ = 1, t₂ = 1.6, τ = {tau}, {which} Qc",
                {"kind": "interpolation", "t1": 1.0, "t2": 1.6, "tau": tau, "qc": qc, "x1": X1, "x2": X2},
                {"Lambda": tol(1e-9), "Psi": tol(1e-9), "x_tau": tol(1e-9)},
                True,
                ORACLE_KERNEL,
            )
        )
    for tau in (1.1, 1.45):
        cases.append(
            Case(
                f"interp_cov_tau{tau}",
                "[YIB Eq. 16-18]",
                "posterior covariance of x(τ) from the joint covariance P of [x(t₁); x(t₂)]: "
                "[Λ Ψ] P [Λ Ψ]ᵀ + Cov(x(τ) | x(t₁), x(t₂))",
                {
                    "kind": "interpolation_covariance",
                    "t1": 1.0,
                    "t2": 1.6,
                    "tau": tau,
                    "qc": QC_FULL,
                    "joint_cov": _spd(12, 3, 5),
                },
                {"cov_tau": tol(1e-9)},
                True,
                ORACLE_KERNEL,
            )
        )
    cases.append(
        Case(
            "singer_interp_tau0.3",
            "[YIB Eq. 14, 16, 18]",
            "Λ(τ), Ψ(τ), x̄(τ) of Singer's model (α = 0.8), t₁ = 0, t₂ = 0.9",
            {
                "kind": "singer_interpolation",
                "alpha": 0.8,
                "t1": 0.0,
                "t2": 0.9,
                "tau": 0.3,
                "qc": QC_DIAG,
                "x1": X1 + [0.1, -0.05, 0.02],
                "x2": X2 + [0.05, 0.02, -0.01],
            },
            {"Lambda": tol(1e-8), "Psi": tol(1e-8), "x_tau": tol(1e-8)},
            True,
            ORACLE_KERNEL,
        )
    )
    cases.append(
        Case(
            "extrapolate_dt0.4",
            "[YIB Eq. 17, 22]",
            "prediction after the last state: Φ x̄₁ and Φ P₁ Φᵀ + Q",
            {"kind": "extrapolation", "t1": 2.0, "t": 2.4, "qc": QC_FULL, "x1": X1, "cov1": _spd(6, 2, 3)},
            {"x_t": tol(1e-12), "cov_t": tol(1e-12)},
            True,
            ORACLE_GP,
        )
    )
    return cases


# --- factors --------------------------------------------------------------------------------------

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


def _factors() -> list[Case]:
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
    ]
    return c


# --- problems for linear, batch, bayes_tree, incremental ------------------------------------------

STATE, MARK = 6, 2
TRAJ_VALUES = {
    "x0": [0.0, 0.0, 0.1, 1.0, 0.1, 0.05],
    "x1": [0.52, 0.07, 0.13, 0.98, 0.18, 0.06],
    "x2": [1.01, 0.18, 0.16, 0.95, 0.25, 0.04],
    "x3": [1.47, 0.33, 0.19, 0.9, 0.31, 0.07],
    "l0": [2.0, 3.0],
    "l1": [-1.0, 2.5],
}
TRAJ_START = {
    "x0": [0.05, -0.05, 0.12, 0.9, 0.0, 0.0],
    "x1": [0.6, 0.0, 0.1, 0.9, 0.1, 0.1],
    "x2": [1.1, 0.1, 0.2, 0.9, 0.2, 0.0],
    "x3": [1.6, 0.2, 0.25, 0.85, 0.2, 0.1],
    "l0": [2.3, 2.7],
    "l1": [-0.7, 2.8],
}


def _range(x: str, l: str, measured: float, sigma: float = 0.1, **extra) -> dict:
    return {"type": "range", "keys": [x, l], "measured": measured, "sigma": sigma, **extra}


def _velocity(x: str, measured: list[float]) -> dict:
    return {"type": "velocity", "keys": [x], "measured": measured, "sigmas": [0.05, 0.05, 0.02]}


def _gp_prior(a: str, b: str, dt: float = 0.5) -> dict:
    return {"type": "gp_prior", "keys": [a, b], "dt": dt, "qc": QC_DIAG}


TRAJ_FACTORS = [
    {
        "type": "prior",
        "keys": ["x0"],
        "mean": [0.0, 0.0, 0.1, 1.0, 0.1, 0.05],
        "sigmas": [0.01, 0.01, 0.01, 0.1, 0.1, 0.1],
    },
    _gp_prior("x0", "x1"),
    _gp_prior("x1", "x2"),
    _gp_prior("x2", "x3"),
    _velocity("x1", [1.0, 0.0, 0.06]),
    _velocity("x3", [0.95, 0.0, 0.07]),
    _range("x0", "l0", 3.62),
    _range("x1", "l0", 3.3),
    _range("x2", "l1", 3.05),
    _range("x3", "l1", 3.45, loss={"type": "huber", "k": 1.345}),
    _range("x3", "l0", 2.7),
    {"type": "bearing", "keys": ["x2", "l0"], "measured": 1.08, "sigma": 0.02},
    {
        "type": "interpolated",
        "keys": ["x2", "x3", "l1"],
        "t1": 1.0,
        "t2": 1.5,
        "tau": 1.2,
        "qc": QC_DIAG,
        "inner": {"type": "range", "measured": 3.15, "sigma": 0.1},
    },
    {"type": "prior", "keys": ["l0"], "mean": [2.05, 2.95], "sigmas": [0.5, 0.5]},
    {"type": "prior", "keys": ["l1"], "mean": [-0.9, 2.6], "sigmas": [0.5, 0.5]},
]
TRAJECTORY = {
    "variables": {"x0": STATE, "x1": STATE, "x2": STATE, "x3": STATE, "l0": MARK, "l1": MARK},
    "times": {"x0": 0.0, "x1": 0.5, "x2": 1.0, "x3": 1.5},
    "factors": TRAJ_FACTORS,
    "values": TRAJ_VALUES,
}

BEACON_TRUE = {"l0": [3.0, 0.0], "l1": [0.0, 3.0], "l2": [-3.0, 0.0], "l3": [0.0, -3.0]}
BEACONS = {
    "variables": {"l0": MARK, "l1": MARK, "l2": MARK, "l3": MARK, "x0": STATE, "x1": STATE},
    "times": {"x0": 0.0, "x1": 1.0},
    "factors": [
        {
            "type": "prior",
            "keys": ["x0"],
            "mean": [0.0, 0.0, 0.0, 0.5, 0.0, 0.0],
            "sigmas": [0.1, 0.1, 0.05, 0.2, 0.2, 0.1],
        },
        _gp_prior("x0", "x1", 1.0),
        _velocity("x1", [0.5, 0.0, 0.02]),
        *[{"type": "prior", "keys": [k], "mean": m, "sigmas": [0.3, 0.3]} for k, m in BEACON_TRUE.items()],
        _range("x0", "l0", 3.02, 0.05),
        _range("x0", "l1", 2.97, 0.05),
        _range("x0", "l2", 3.01, 0.05),
        _range("x0", "l3", 3.0, 0.05),
        _range("x1", "l0", 2.52, 0.05),
        _range("x1", "l1", 2.93, 0.05, loss={"type": "tukey", "c": 4.685}),
        _range("x1", "l2", 3.49, 0.05),
        _range("x1", "l3", 3.1, 0.05),
    ],
    "values": {
        "l0": [3.1, 0.1],
        "l1": [0.1, 2.9],
        "l2": [-2.95, -0.1],
        "l3": [0.05, -3.05],
        "x0": [0.0, 0.0, 0.0, 0.5, 0.0, 0.0],
        "x1": [0.5, 0.05, 0.02, 0.5, 0.05, 0.02],
    },
}
BEACON_START = {
    "l0": [2.6, 0.4],
    "l1": [0.4, 2.5],
    "l2": [-2.5, 0.4],
    "l3": [0.4, -2.6],
    "x0": [0.1, 0.1, 0.05, 0.4, 0.1, 0.0],
    "x1": [0.7, 0.2, 0.0, 0.4, 0.1, 0.0],
}

ORDERINGS = {
    "trajectory": {
        "xl": ["x0", "x1", "x2", "x3", "l0", "l1"],
        "landmarks_first": ["l0", "l1", "x0", "x1", "x2", "x3"],
        "interleaved": ["x3", "l1", "x0", "l0", "x2", "x1"],
    },
    "beacons": {"natural": ["l0", "l1", "l2", "l3", "x0", "x1"], "states_first": ["x0", "x1", "l0", "l1", "l2", "l3"]},
}
PROBLEMS = {"trajectory": TRAJECTORY, "beacons": BEACONS}
PROBLEM_DOCS = {
    "trajectory": "four states at t = 0, 0.5, 1, 1.5 with a prior, GP priors, velocities, ranges (one Huber), "
    "a bearing, an interpolated range and two landmarks with priors",
    "beacons": "two states and four beacons with priors, ranges from each state to each beacon (one Tukey)",
}
LINEAR_TOL = {
    "A": tol(1e-9, 1e-13),
    "b": tol(1e-10, 1e-13),
    "information": tol(1e-9),
    "rhs": tol(1e-9, 1e-12),
    "R": tol(1e-9),
    "d": tol(1e-9, 1e-12),
    "delta": tol(1e-8, 1e-12),
}


def _linear() -> list[Case]:
    out = []
    for p, o in (("trajectory", "xl"), ("trajectory", "landmarks_first"), ("beacons", "natural")):
        out.append(
            Case(
                f"{p}_{o}",
                "[YIB Eq. 9-11, 21, 25]",
                f"{PROBLEM_DOCS[p]}; ordering {o}: A, b (rows in factor order), 𝓘 = AᵀA, Aᵀb, R (RᵀR = 𝓘), d, δ",
                {"problem": PROBLEMS[p], "ordering": ORDERINGS[p][o]},
                dict(LINEAR_TOL),
                True,
                ORACLE_DENSE,
            )
        )
    return out


def _batch() -> list[Case]:
    out = []
    for p, start, order in (("trajectory", TRAJ_START, "xl"), ("beacons", BEACON_START, "natural")):
        problem = {**PROBLEMS[p], "values": start}
        out.append(
            Case(
                f"{p}_gauss_newton",
                "[YIB Eq. 6-11]",
                f"{PROBLEM_DOCS[p]}: 5 Gauss-Newton iterations from a given start; every iterate and the cost at each",
                {"problem": problem, "ordering": ORDERINGS[p][order], "iterations": 5},
                {"iterates": tol(1e-8, 1e-12), "costs": tol(1e-9)},
                True,
                "oracle: dense Gauss-Newton on the oracle's factors",
            )
        )
    return out


def _bayes_tree() -> list[Case]:
    out = []
    for p, o in (("trajectory", "xl"), ("trajectory", "interleaved"), ("beacons", "states_first")):
        inputs = {"problem": PROBLEMS[p], "ordering": ORDERINGS[p][o]}
        what = f"{PROBLEM_DOCS[p]}, linearized at its values, eliminated in the ordering {o}"
        out.append(
            Case(
                f"{p}_{o}_cliques",
                "[YIB Sec. III-A, Eq. 24-25]",
                f"{what}: the cliques (frontals, separator, parent)",
                inputs,
                {"cliques": EXACT},
                True,
                "oracle: the elimination game and GTSAM's clique rule, written a second time (matches GTSAM 4.3's eliminateMultifrontal)",
            )
        )
        out.append(
            Case(
                f"{p}_{o}_conditionals",
                "[YIB Eq. 24-25]",
                f"{what}: each clique's conditional R, S, d (positive diagonal), by first frontal",
                inputs,
                {"conditionals": tol(1e-9, 1e-12)},
                True,
                "oracle: the rows of the dense R of 𝓘 and of d = R⁻ᵀAᵀb",
            )
        )
        groups = [[k] for k in inputs["ordering"]] + [["x0", "l1"] if p == "trajectory" else ["x0", "l2"], ["l0", "x1"]]
        out.append(
            Case(
                f"{p}_{o}_covariances",
                "[YIB Eq. 11]",
                f"{what}: marginal covariances and joint covariances of pairs, blocks of 𝓘⁻¹",
                {**inputs, "groups": groups},
                {"covariances": tol(1e-9, 1e-13)},
                True,
                "oracle: blocks of the dense inverse of 𝓘",
            )
        )
    return out


def _stream() -> dict:
    return {
        "variables": {"x0": STATE, "x1": STATE, "x2": STATE, "x3": STATE, "l0": MARK, "l1": MARK},
        "updates": [
            {
                "values": {"x0": TRAJ_START["x0"], "l0": TRAJ_START["l0"]},
                "factors": [TRAJ_FACTORS[0], TRAJ_FACTORS[13], TRAJ_FACTORS[6], _velocity("x0", [1.0, 0.0, 0.05])],
            },
            {"values": {"x1": TRAJ_START["x1"]}, "factors": [TRAJ_FACTORS[1], TRAJ_FACTORS[4], TRAJ_FACTORS[7]]},
            {
                "values": {"x2": TRAJ_START["x2"], "l1": TRAJ_START["l1"]},
                "factors": [TRAJ_FACTORS[2], TRAJ_FACTORS[14], TRAJ_FACTORS[8], TRAJ_FACTORS[11]],
            },
            {
                "values": {"x3": TRAJ_START["x3"]},
                "factors": [TRAJ_FACTORS[3], TRAJ_FACTORS[5], TRAJ_FACTORS[9], TRAJ_FACTORS[10], TRAJ_FACTORS[12]],
            },
            {"values": {}, "factors": [_range("x1", "l1", 2.95)]},
        ],
    }


def _incremental() -> list[Case]:
    stream = _stream()
    n = len(stream["updates"])
    est = {f"estimate_{k}": tol(1e-8, 1e-12) for k in range(1, n + 1)}
    every = {"relinearize_threshold": 0.0, "relinearize_skip": 1, "wildfire_threshold": 0.0}
    never = {"relinearize_threshold": "inf", "relinearize_skip": 1, "wildfire_threshold": 0.0}
    return [
        Case(
            "relinearize_every_update_estimates",
            "[YIB Alg. 1, Eq. 9-11]",
            "five updates of iSAM2 with relinearization threshold 0 checked every update and full back-substitution "
            "(wildfire 0): each update is one Gauss-Newton step on every factor so far; the estimate after each",
            {"stream": stream, "isam2": every},
            est,
            True,
            "oracle: one dense Gauss-Newton step per update",
        ),
        Case(
            "no_relinearization_estimates",
            "[YIB Alg. 1, Eq. 9-11]",
            "the same stream with relinearization off (threshold inf) and wildfire 0: every factor stays linearized at the "
            "values first given; the estimate after each update",
            {"stream": stream, "isam2": never},
            est,
            True,
            "oracle: the dense linear solve at the first linearization point",
        ),
        Case(
            "no_relinearization_tree_edits",
            "[YIB Alg. 1 steps 2-5]",
            "the same run: after each update, the cliques removed from the top of the tree and the orphaned subtrees "
            "reattached, each named by its frontal variables. Depends on the elimination order of the removed part "
            "(steam_ref: exact constrained minimum degree, new variables last, ties to the variable listed first)",
            {"stream": stream, "isam2": never},
            {f"update_{k}": EXACT for k in range(1, n + 1)},
            False,
            "produced by steam_ref",
        ),
    ]


SUITE_DOCS = {
    "gp": "the GP prior: Φ, Q, Q⁻¹, W of WNOA (and WNOJ, Singer, a general LTI SDE); Λ, Ψ, the mean and covariance at τ; prediction",
    "factors": "every factor type at given points: error, whitened error, Jacobians (unwhitened H_k, whitened and weighted A_k), b, cost, robust weight",
    "linear": "small problems under given orderings: A, b, 𝓘, Aᵀb, R, d and the Gauss-Newton step δ",
    "batch": "Gauss-Newton iterates and costs from a given start",
    "bayes_tree": "cliques and conditionals of given elimination orders; marginal and joint covariances",
    "incremental": "a stream of five iSAM2 updates: the estimate after each; the cliques removed and the orphans",
    "paper": "the paper's runs (BTGP/1 on the synthetic set and on Plaza): final estimates and RMSE",
}


def suite_cases(suite: str) -> list[Case]:
    """The cases of a suite defined here (not 'paper', which needs the data files)."""
    return {
        "gp": _gp,
        "factors": _factors,
        "linear": _linear,
        "batch": _batch,
        "bayes_tree": _bayes_tree,
        "incremental": _incremental,
    }[suite]()
