"""The ``gp`` suite: Φ, Q, Q⁻¹, W of the priors; Λ, Ψ, the mean and covariance at τ; prediction."""

from __future__ import annotations

from .base import ORACLE_GP, ORACLE_KERNEL, QC_DIAG, QC_FULL, X1, X2, Case, tol

__all__ = ["gp_cases"]


def exact_spd(n: int, a: int, b: int) -> list[list[float]]:
    """(B Bᵀ + n I) / 64 for the integer matrix B_ij = (a i + b j) mod 7 - 3: exact in binary floating point."""
    B = [[(a * i + b * j) % 7 - 3 for j in range(n)] for i in range(n)]
    return [
        [(sum(B[i][k] * B[j][k] for k in range(n)) + (n if i == j else 0)) / 64 for j in range(n)] for i in range(n)
    ]


def small_spd(n: int, a: int, b: int, divisor: float = 16) -> list[list[float]]:
    """:func:`exact_spd` divided entry by entry by ``divisor`` (16: still exact), the covariances of the Lie suites."""
    return [[v / divisor for v in row] for row in exact_spd(n, a, b)]


# --- gp -------------------------------------------------------------------------------------------


def gp_cases() -> list[Case]:
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
                    "joint_cov": exact_spd(12, 3, 5),
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
            {"kind": "extrapolation", "t1": 2.0, "t": 2.4, "qc": QC_FULL, "x1": X1, "cov1": exact_spd(6, 2, 3)},
            {"x_t": tol(1e-12), "cov_t": tol(1e-12)},
            True,
            ORACLE_GP,
        )
    )
    return cases
