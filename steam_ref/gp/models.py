"""Motion priors beyond WNOA with Φ(Δt) and Q(Δt) in closed form: WNOJ and Singer.  [YIB Eq. 14, 17]

Both have the state x(t) = [p(t); ṗ(t); p̈(t)] with p of any dimension d and are LTI SDEs of
[YIB Eq. 14] driven by white noise w(t) ~ GP(0, Qc δ(t - t')) on the jerk:

    WNOJ (white noise on jerk):    p⃛ = w,          A = [[0, I, 0], [0, 0, I], [0, 0, 0]],  F = [0; 0; I]
    Singer [S70] (α > 0):          p⃛ = -α p̈ + w,   A = [[0, I, 0], [0, 0, I], [0, 0, -αI]], F = [0; 0; I]

In Singer's model the acceleration is a first-order Gauss-Markov (Ornstein-Uhlenbeck) process
with time constant 1/α; its stationary covariance is Qc / (2α), so Singer's σ_m² per axis is
Qc = 2α σ_m². As α → 0 it becomes WNOJ. Derivations: docs/derivations.md, section 6.

Every matrix is a 3 × 3 scalar pattern Kronecker-multiplied with I (Φ) or Qc (Q), because each
axis obeys the same scalar SDE and all axes share one w. With x = αΔt, Φ and Q are written with
the functions φ_k(z) = Σₙ zⁿ / (n + k)! (φ₀ = eᶻ, φ₁ = (eᶻ - 1)/z, φ₂ = (eᶻ - 1 - z)/z²):

    Φ(Δt) = [[1, Δt, Δt² φ₂(-x)], [0, 1, Δt φ₁(-x)], [0, 0, e⁻ˣ]] ⊗ I
    Q(Δt)_rc = Δt^(k_r + k_c + 1) S_rc(x) ⊗ Qc,   k = (2, 1, 0) for (p, ṗ, p̈)

where S(x) is given below in closed form (for x outside [-1, 1]) and as its power series (on [-1, 1]), which has no
cancellation for small αΔt; S(0) is WNOJ's matrix. ``LinearSDE.wnoj`` / ``LinearSDE.singer``
build the SDEs and use these forms; ``steam_ref.gp.prior`` holds WNOA's.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from math import factorial

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arguments import number, time_step
from ..errors import NumericalError, SteamError
from .prior import check_d, check_qc, finite_result, qc_inverse
from .prior import process_noise as wnoa_process_noise
from .prior import process_noise_sqrt_information as wnoa_sqrt_information
from .prior import transition as wnoa_transition

__all__ = [
    "check_alpha",
    "wnoj_matrices",
    "wnoj_transition",
    "wnoj_process_noise",
    "wnoj_process_noise_inverse",
    "singer_matrices",
    "singer_transition",
    "singer_process_noise",
    "check_singer_step",
    "SINGER_LARGEST_ALPHA_DT",
    "ClosedForm",
]

_SERIES_TERMS = 24  # |x| ≤ 1: the n-th term is at most 2ⁿ / (n + 1)! (S_aa's), under 3e-18 of S at n = 24
_SERIES_RADIUS = 1.0  # beyond it the closed forms lose at most ~30 ulp to cancellation
_FAR = 1e15  # x beyond it: e⁻ˣ = 0 in float64, and S in powers of 1/x (x⁵ in the closed forms overflows from 4.5e61)

# φ_k(z) = Σₙ zⁿ / (n + k)!, k = 0, 1, 2
_PHI_SERIES = np.array([[1.0 / factorial(n + k) for n in range(_SERIES_TERMS)] for k in range(3)])
# S_rc(x) = ∫₀¹ u^(k_r + k_c) φ_{k_r}(-xu) φ_{k_c}(-xu) du = Σₙ (-x)ⁿ c_n / (k_r + k_c + n + 1),
# c_n = Σᵢ 1 / ((i + k_r)! (n - i + k_c)!)  (Cauchy product of the two series, then ∫ u^(k + n) du)
_K = (2, 1, 0)
_S_SERIES = np.array(
    [
        [
            [
                sum(1.0 / (factorial(i + kr) * factorial(n - i + kc)) for i in range(n + 1)) / (kr + kc + n + 1)
                for n in range(_SERIES_TERMS)
            ]
            for kc in _K
        ]
        for kr in _K
    ]
)
_WNOJ_S = np.array([[1 / 20, 1 / 8, 1 / 6], [1 / 8, 1 / 3, 1 / 2], [1 / 6, 1 / 2, 1.0]])  # ∫₀¹ uᵏʳ⁺ᵏᶜ/(k_r! k_c!) du


def check_alpha(alpha: object, name: str = "alpha") -> float:
    """α as a float, or raise if it is not a positive finite number (a bool or a string is not one)."""
    value = number(name, alpha)
    if value <= 0:
        raise SteamError(f"{name} must be a positive finite number, got {name}={value}")
    return value


# --- WNOJ -----------------------------------------------------------------------------------------


def wnoj_matrices(d: int) -> tuple[NDArray, NDArray]:
    """A (3d, 3d) and F (3d, d) of p⃛ = w."""
    d = check_d(d)
    A = np.kron(np.eye(3, k=1), np.eye(d))  # [[0, I, 0], [0, 0, I], [0, 0, 0]]
    F = np.kron(np.array([[0.0], [0.0], [1.0]]), np.eye(d))
    return A, F


def wnoj_transition(dt: float, d: int) -> NDArray:
    """Φ(t + Δt, t) = exp(A Δt) of WNOJ, any finite Δt: (3d, 3d).  [YIB Eq. 16]"""
    dt, d = time_step(dt, positive=False), check_d(d)
    t = np.float64(dt)  # NumPy arithmetic: an overflow gives inf (checked), not Python's OverflowError
    with np.errstate(over="ignore", invalid="ignore"):
        phi = np.kron(np.array([[1.0, t, t**2 / 2], [0.0, 1.0, t], [0.0, 0.0, 1.0]]), np.eye(d))
    return finite_result("Φ(dt) of WNOJ", phi, dt=dt)


def wnoj_process_noise(dt: float, qc: ArrayLike) -> NDArray:
    """Q(Δt) of WNOJ: [[Δt⁵/20, Δt⁴/8, Δt³/6], [Δt⁴/8, Δt³/3, Δt²/2], [Δt³/6, Δt²/2, Δt]] ⊗ Qc.  [YIB Eq. 17]"""
    dt, qc = time_step(dt), check_qc(qc)
    t = np.float64(dt)
    with np.errstate(over="ignore", invalid="ignore"):
        D = np.array([t**2, t, 1.0])
        q = np.kron(t * _WNOJ_S * np.outer(D, D), qc)
    return finite_result("Q(dt) of WNOJ", q, dt=dt)


def wnoj_process_noise_inverse(dt: float, qc: ArrayLike) -> NDArray:
    """Q(Δt)⁻¹ of WNOJ: [[720/Δt⁵, -360/Δt⁴, 60/Δt³], [-360/Δt⁴, 192/Δt³, -36/Δt²], [60/Δt³, -36/Δt², 9/Δt]] ⊗ Qc⁻¹."""
    dt, qi = time_step(dt), qc_inverse(qc)
    pattern = np.array([[720.0, -360.0, 60.0], [-360.0, 192.0, -36.0], [60.0, -36.0, 9.0]])
    t = np.float64(dt)
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        Di = np.array([t**-2, t**-1, 1.0])
        q_inv = np.kron(pattern * np.outer(Di, Di) / t, qi)
    return finite_result("Q(dt)⁻¹ of WNOJ", q_inv, dt=dt)


# --- Singer ---------------------------------------------------------------------------------------


def singer_matrices(d: int, alpha: float) -> tuple[NDArray, NDArray]:
    """A (3d, 3d) and F (3d, d) of p⃛ = -α p̈ + w."""
    alpha, d = check_alpha(alpha), check_d(d)
    A = np.kron(np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -alpha]]), np.eye(d))
    return A, wnoj_matrices(d)[1]


def _phi12(x: float) -> tuple[float, float]:
    """φ₁(-x), φ₂(-x) without cancellation at small |x|."""
    if abs(x) <= _SERIES_RADIUS:
        z = -x
        return float(np.polynomial.polynomial.polyval(z, _PHI_SERIES[1])), float(
            np.polynomial.polynomial.polyval(z, _PHI_SERIES[2])
        )
    em1 = np.expm1(-x)  # e⁻ˣ - 1
    return -em1 / x, (x + em1) / x / x  # not / x²: that overflows for αΔt > 1e154


def singer_transition(dt: float, alpha: float, d: int) -> NDArray:
    """Φ(t + Δt, t) = exp(A Δt) of Singer's model, any finite Δt: (3d, 3d).  [YIB Eq. 16]

    [[1, Δt, (αΔt - 1 + e^{-αΔt})/α²], [0, 1, (1 - e^{-αΔt})/α], [0, 0, e^{-αΔt}]] ⊗ I.
    """
    dt, alpha, d = time_step(dt, positive=False), check_alpha(alpha), check_d(d)
    t = np.float64(dt)  # NumPy arithmetic: an overflow gives inf (checked), not Python's OverflowError
    with np.errstate(over="ignore", invalid="ignore"):
        x = alpha * t
        phi1, phi2 = _phi12(x)
        phi = np.kron(np.array([[1.0, t, t**2 * phi2], [0.0, 1.0, t * phi1], [0.0, 0.0, np.exp(-x)]]), np.eye(d))
    return finite_result("Φ(dt) of Singer's model", phi, dt=dt, alpha=alpha)


def _singer_s(x: float) -> NDArray:
    """S(x), x = αΔt > 0: Q_rc = Δt^(k_r + k_c + 1) S_rc(x) ⊗ Qc. See docs/derivations.md, section 6."""
    if x <= _SERIES_RADIUS:
        return np.polynomial.polynomial.polyval(-x, _S_SERIES.transpose(2, 0, 1))
    if x > _FAR:  # the closed forms below with E = 0, em1 = em2 = -1, in y = 1/x: no power of x to overflow
        y = 1 / x
        pp = y * y * (1 / 3 + y * (-1 + y * (1 + y / 2)))
        pv, pa, vv, va = y * y * (1 - y) ** 2 / 2, y * y * y / 2, y * y * (1 - 1.5 * y), y * y / 2
        return np.array([[pp, pv, pa], [pv, vv, va], [pa, va, y / 2]])
    E, em1, em2 = np.exp(-x), np.expm1(-x), np.expm1(-2 * x)  # e⁻ˣ, e⁻ˣ - 1, e⁻²ˣ - 1
    pp = (x**3 / 3 - x**2 + x - 2 * x * E - em2 / 2) / x**5
    pv = (x + em1) ** 2 / (2 * x**4)
    pa = (-em2 / 2 - x * E) / x**3
    vv = (x + 2 * em1 - em2 / 2) / x**3
    va = em1**2 / (2 * x**2)
    aa = -em2 / (2 * x)
    return np.array([[pp, pv, pa], [pv, vv, va], [pa, va, aa]])


def singer_process_noise(dt: float, alpha: float, qc: ArrayLike) -> NDArray:
    """Q(Δt) of Singer's model: (3d, 3d).  [YIB Eq. 17]

    Entries (× Qc), x = αΔt, E = e⁻ˣ:  Q_pp = (x³/3 - x² + x - 2xE + (1 - E²)/2)/α⁵,
    Q_pv = (x - 1 + E)²/(2α⁴), Q_pa = ((1 - E²)/2 - xE)/α³, Q_vv = (x - 3/2 + 2E - E²/2)/α³,
    Q_va = (1 - E)²/(2α²), Q_aa = (1 - E²)/(2α); evaluated by a series for x ≤ 1.
    """
    dt, alpha, qc = time_step(dt), check_alpha(alpha), check_qc(qc)
    t = np.float64(dt)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
        D = np.array([t**2, t, 1.0])
        q = t * _singer_s(alpha * t) * np.outer(D, D)
    finite_result("Q(dt) of Singer's model", q, dt=dt, alpha=alpha)
    if not np.all(np.diag(q) > 0):  # a variance that underflowed: no Q float64 holds
        raise NumericalError(
            f"Q(dt) of Singer's model has a variance below float64's range at dt={dt!r}, alpha={alpha!r} "
            f"(diagonal {np.diag(q).tolist()}): the time step or alpha is too large or too small for float64 to "
            "represent this prior"
        )
    return finite_result("Q(dt) of Singer's model", np.kron(q, qc), dt=dt, alpha=alpha)


# Singer's prior over Δt with x = αΔt ≫ 1 (S(x) above in y = 1/x): Q_vv → Δt Qc/α² = Δt³ Qc/x², Q_pp → Δt³ Qc/(3α²),
# Q_aa → Qc/(2α): against WNOJ with the same Qc over the same Δt (Q_vv = Δt³ Qc/3, Q_pp = Δt⁵ Qc/20, Q_aa = Δt Qc) the
# prior holds the twist x²/3 times as stiffly, the pose 3x²/20 times, the acceleration only 2x times; the twist's
# x²/3 is the largest. Beyond sqrt(1/eps) = 6.7e7 that stiffness leaves float64 unable to resolve the readings beside
# the prior (the rule of the CLI's --qc-scale): the elimination breaks down, or its answer is ill-conditioned. So
# x²/3 <= sqrt(1/eps), x <= 1.4e4 (a 3-D task of 10 states, 1 s apart: clean at x = 1.4e4, ill-conditioned at 3.3e4,
# broken down at 1e6, blaming a state as if a prior were missing).
SINGER_LARGEST_ALPHA_DT = float(np.sqrt(3 / np.sqrt(np.finfo(float).eps)))


def check_singer_step(dt: float, alpha: float) -> None:
    """Refuse a prior factor of Singer's model over ``dt`` whose αΔt exceeds :data:`SINGER_LARGEST_ALPHA_DT`: a
    :class:`~steam_ref.errors.NumericalError` naming the time constant 1/α, α, the interval and what to give."""
    dt, alpha = time_step(dt), check_alpha(alpha)
    x = alpha * dt
    if x > SINGER_LARGEST_ALPHA_DT:
        raise NumericalError(
            f"Singer's prior with time_constant={1 / alpha:.3g} (alpha={alpha:.3g}) over an interval dt={dt!r}: "
            f"alpha*dt = {x:.3g} makes its Q(dt) hold the twist {x * x / 3:.2g} times as stiffly as WNOJ's "
            f"with the same Qc, beyond float64's resolution beside the readings (alpha*dt <= "
            f"{SINGER_LARGEST_ALPHA_DT:.3g}); give a time constant of at least {dt / SINGER_LARGEST_ALPHA_DT:.3g} "
            f"on the prior's clock, or the WNOA prior the model tends to"
        )


# --- the models LinearSDE knows in closed form ----------------------------------------------------


def _wnoa_matrices(d: int) -> tuple[NDArray, NDArray]:
    """A (2d, 2d) and F (2d, d) of p̈ = w.  [YIB Eq. 31]"""
    I, O = np.eye(check_d(d)), np.zeros((d, d))
    return np.block([[O, I], [O, O]]), np.vstack([O, I])


@dataclass(frozen=True)
class _Forms:
    """One model's closed forms, each taking Singer's α last (None for a model without one); ``sqrt_information``
    (W with WᵀW = Q(Δt)⁻¹, memoised by value) only for a model that has it in closed form."""

    matrices: Callable[[int, float | None], tuple[NDArray, NDArray]]
    transition: Callable[[float, int, float | None], NDArray]
    process_noise: Callable[[float, ArrayLike, float | None], NDArray]
    has_alpha: bool = False
    sqrt_information: Callable[[float, ArrayLike, float | None], NDArray] | None = None
    check_step: Callable[[float, float | None], None] | None = None  # refuses a prior factor's dt float64 cannot hold


_FORMS: dict[str, _Forms] = {  # a model LinearSDE knows in closed form is one entry here
    "wnoa": _Forms(
        lambda d, _: _wnoa_matrices(d),
        lambda dt, d, _: wnoa_transition(dt, d),
        lambda dt, qc, _: wnoa_process_noise(dt, qc),
        sqrt_information=lambda dt, qc, _: wnoa_sqrt_information(dt, qc),
    ),
    "wnoj": _Forms(
        lambda d, _: wnoj_matrices(d),
        lambda dt, d, _: wnoj_transition(dt, d),
        lambda dt, qc, _: wnoj_process_noise(dt, qc),
    ),
    "singer": _Forms(
        lambda d, alpha: singer_matrices(d, _given(alpha)),
        lambda dt, d, alpha: singer_transition(dt, _given(alpha), d),
        lambda dt, qc, alpha: singer_process_noise(dt, _given(alpha), qc),
        has_alpha=True,
        check_step=lambda dt, alpha: check_singer_step(dt, _given(alpha)),
    ),
}


def _given(alpha: float | None) -> float:
    """α of a model that has one (set and checked by ``ClosedForm.__post_init__``)."""
    if alpha is None:
        raise SteamError("this model has no alpha")
    return alpha


@dataclass(frozen=True)
class ClosedForm:
    """A motion prior with Φ and Q in closed form: 'wnoa' [YIB Eq. 30-31], 'wnoj' or 'singer' (α)."""

    name: str
    alpha: float | None = None  # Singer's α; None for the others

    def __post_init__(self) -> None:
        forms = _FORMS.get(self.name) if isinstance(self.name, str) else None
        if forms is None:
            raise SteamError(f"unknown closed-form model name={self.name!r}; use 'wnoa', 'wnoj' or 'singer'")
        if forms.has_alpha:
            object.__setattr__(self, "alpha", check_alpha(self.alpha))
        elif self.alpha is not None:
            raise SteamError(f"only the 'singer' model has an alpha, got alpha={self.alpha!r} for {self.name!r}")

    def matrices(self, d: int) -> tuple[NDArray, NDArray]:
        """A and F of the model for p of dimension d."""
        return _FORMS[self.name].matrices(d, self.alpha)

    def transition(self, dt: float, d: int) -> NDArray:
        """Φ(t + Δt, t), any finite Δt."""
        return _FORMS[self.name].transition(dt, d, self.alpha)

    def process_noise(self, dt: float, qc: ArrayLike) -> NDArray:
        """Q(Δt), Δt > 0."""
        return _FORMS[self.name].process_noise(dt, qc, self.alpha)

    def sqrt_information(self, dt: float, qc: ArrayLike) -> NDArray | None:
        """W with WᵀW = Q(Δt)⁻¹ in closed form, memoised by value (WNOA's [YIB Eq. 17]); None for a model
        without one (its factor factors Q(Δt) itself)."""
        form = _FORMS[self.name].sqrt_information
        return None if form is None else form(dt, qc, self.alpha)

    def check_step(self, dt: float) -> None:
        """Refuse ``dt`` as a prior factor's interval where the model's Q(Δt) is too stiff for float64 beside the
        readings (Singer's: :func:`check_singer_step`); every Δt > 0 for the others."""
        check = _FORMS[self.name].check_step
        if check is not None:
            check(dt, self.alpha)
