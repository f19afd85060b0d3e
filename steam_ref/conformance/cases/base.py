"""What every case is made of: :class:`Case`, the tolerance helpers, and the numbers and oracle
descriptions that several suites share; for the Lie suites (se2, se3) their exact tier, what a case of each kind
checks (:data:`LIE_CHECKS`), a group operation's case (:func:`group_case`) and an iSAM2 stream's quantities
(:func:`stream_checks`)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from ..kitio import plain

__all__ = [
    "Case",
    "frozen",
    "tol",
    "EXACT",
    "GROUP",
    "JR_INVERSE",
    "EXACT_JACOBIAN",
    "AT_TAU",
    "COVARIANCE",
    "LIE_CHECKS",
    "RESIDUAL",
    "GROUP_KINDS",
    "group_case",
    "stream_checks",
]

EXACT = "exact"


def tol(rtol: float, atol: float = 0.0) -> Mapping[str, float]:
    """Pass when max|got - expected| ≤ atol + rtol · max|expected| (normwise); read-only, as cases share it."""
    return MappingProxyType({"atol": atol, "rtol": rtol})


def frozen(value):
    """A read-only deep copy of ``value``: mappings → MappingProxyType, lists and tuples → tuples, arrays → a
    read-only copy. The kit writes it as it wrote ``value`` (:func:`~steam_ref.conformance.kitio.plain` reads
    each the same way); what the kit cannot store is refused as it would be at writing."""
    if isinstance(value, Mapping):
        return MappingProxyType({k: frozen(v) for k, v in value.items()})
    if isinstance(value, (list, tuple)):
        return tuple(frozen(v) for v in value)
    if isinstance(value, np.ndarray):
        copy = value.copy()
        copy.setflags(write=False)
        return copy
    plain(value)  # a number, a bool, a string or None (all immutable); anything else raises DataError
    return value


@dataclass(frozen=True)
class Case:
    """One case of a suite: inputs, what is expected of which quantity, and where the expectation comes from."""

    name: str
    equation: str  # the paper's equations computed, '[YIB Eq. n]'
    description: str
    inputs: Mapping  # the case's own read-only copy (see __post_init__)
    tolerance: Mapping  # quantity → tol(...) or EXACT; the case's own read-only copy (see __post_init__)
    independent: bool  # expected values from the oracle (True) or produced by steam_ref (False)
    source: str = ""  # how the expected values are obtained
    notes: Mapping = field(default_factory=dict)  # the case's own read-only copy (see __post_init__)

    def __post_init__(self) -> None:
        # Cases are built from shared tables and numbers (LIE_CHECKS, FACTOR_TOL, QC_DIAG, X1...): each keeps a
        # read-only deep copy of its own, so that no case (or table) can change another's inputs or tolerances.
        for name in ("inputs", "tolerance", "notes"):
            object.__setattr__(self, name, frozen(getattr(self, name)))


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

# The Lie-group suites (se2, se3): the exact tier (README 'The exact tier') and the WNOA prior's two residuals.
GROUP = tol(1e-12, 1e-14)  # closed forms (Exp, Log, J_r, errors): steam_ref and the oracle differ by ~1e-15
JR_INVERSE = tol(1e-11, 1e-13)  # J_r^-1 (the oracle's a dense inverse)
EXACT_JACOBIAN = tol(1e-10, 1e-12)  # Jacobians: forward differences (~1e-8) fail it; kit v4's se2 had 1e-8
AT_TAU = tol(1e-11, 1e-13)  # values through the local GP's mean (an expm and a dense solve more)
COVARIANCE = tol(1e-10, 1e-14)  # covariances through the local GP (kit v5)
_LIE_CHECKS = {
    "prior": {"error": GROUP, "H_0": EXACT_JACOBIAN, "H_1": EXACT_JACOBIAN, "cost": tol(1e-11)},
    "residual": {"error": GROUP, "cost": tol(1e-11)},  # a prior's error and cost alone
    "state_prior": {"error": GROUP, "H_0": EXACT_JACOBIAN},
    "between": {"between": GROUP, "H_a": EXACT_JACOBIAN, "H_b": EXACT_JACOBIAN, "Ad_a": GROUP},
    "interpolation": {"x_tau": AT_TAU, "J_1": EXACT_JACOBIAN, "J_2": EXACT_JACOBIAN},
    "interpolation_covariance": {"x_tau": AT_TAU, "cov_tau": COVARIANCE},
    "extrapolation": {"x_t": AT_TAU, "J_1": EXACT_JACOBIAN, "cov_t": COVARIANCE},
}
# What a case of each kind checks in both Lie suites, at the exact tier; read-only, as many cases share each entry.
LIE_CHECKS: Mapping[str, Mapping[str, Mapping[str, float]]] = MappingProxyType(
    {kind: MappingProxyType(checks) for kind, checks in _LIE_CHECKS.items()}
)
RESIDUAL = {"local-variable": "[xi - dt w1; J_r(xi)^-1 w2 - w1]", "simplified": "[xi - dt w1; w2 - w1]"}  # e of each
GROUP_KINDS = {  # a case of a group's own operations: the input its rows are, the quantities it checks
    "exp": ("xi", {"exp": GROUP, "log_of_exp": GROUP}),
    "log": ("poses", {"log": GROUP, "exp_of_log": GROUP}),
    "jacobians": ("xi", {"Jr": GROUP, "Jr_inv": JR_INVERSE}),
    "so3_exp": ("phi", {"exp": GROUP, "log_of_exp": GROUP}),
    "so3_jacobians": ("phi", {"Jr": GROUP, "Jr_inv": JR_INVERSE}),
}


def group_case(equation: str, source: str, name: str, description: str, kind: str, rows: list) -> Case:
    """A case of Exp, Log or J_r on a Lie group (either Lie suite): ``rows`` under the input :data:`GROUP_KINDS`
    names for ``kind``, the quantities it lists at their tolerances."""
    field_name, checks = GROUP_KINDS[kind]
    return Case(name, equation, description, {"kind": kind, field_name: rows}, dict(checks), True, source)


def stream_checks(updates: int, estimate: Mapping) -> dict:
    """The quantities of an iSAM2 stream on Lie-group states: after each update k, relinearized_k (exact), then
    estimate_k at ``estimate``."""
    return {q: t for k in range(1, updates + 1) for q, t in ((f"relinearized_{k}", EXACT), (f"estimate_{k}", estimate))}
