"""What every case is made of: :class:`Case`, the tolerance helpers, and the numbers and oracle
descriptions that several suites share."""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["Case", "tol", "EXACT"]

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
ORACLE_KERNEL = (
    "oracle: [Λ Ψ] = K(τ)K⁻¹ and the conditional covariance by conditioning the dense prior of "
    "[x(t₁); x(τ); x(t₂)] (Eq. 12)"
)
ORACLE_FACTOR = (
    "oracle: the error written out from its equation; Jacobians by complex-step differentiation; "
    "Λ, Ψ by the dense kernel"
)
ORACLE_DENSE = (
    "oracle: dense A, b from the oracle's factors; 𝓘 = AᵀA; R = upper Cholesky factor of 𝓘; dense triangular solves"
)

QC_DIAG = [[0.5, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 0.1]]
QC_FULL = [[0.5, 0.2, 0.05], [0.2, 0.4, 0.05], [0.05, 0.05, 0.1]]
X1 = [1.0, 2.0, 0.3, 0.8, -0.2, 0.1]
X2 = [1.45, 1.9, 0.38, 0.7, -0.1, 0.12]
