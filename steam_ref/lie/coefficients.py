"""The coefficients of SO(3)'s and SE(3)'s closed forms: functions of the rotation angle θ ≥ 0.  [DER 13.7]

Every closed form of ``lie.so3`` and ``lie.se3`` (Exp, Log, J_r, J_r⁻¹, their Q blocks and the derivatives of
J_r(ξ)^{±1} v) is written in the frame whose third axis is the rotation axis u = φ/θ; there each entry is one
scalar function of θ times the inputs' components, and :class:`Coefficients` gives those functions (``NAMES``),
each computed when first read. With h = θ/2 and a trailing 1 (2) for d/dθ (d²/dθ²), a trailing t for ÷θ:

    A = sin θ/θ,  B = (1 - cos θ)/θ,  C = (θ - sin θ)/θ²,  D = (1 - cos θ)/θ²,  α = h cot h,  γ = (1 - α)/θ,
    A1, B1, C1, D1, A2, B2, α1, α2,  Ct = C/θ,  A1t = A1/θ,  E1 = Ct - C1,  α1t = α1/θ,  γt = γ/θ,
    G1 = (2γ + α1)/θ,  G2 = -(γ + α1)/θ

(``DEFINITIONS`` states each as a formula a caller evaluates with any math module, mpmath's at 50 digits in the
tests.) **Precision.** Each is summed from its Taylor series in θ below ``SERIES_BELOW`` = 2 and taken in closed
form above, both chosen so that nothing cancels: the series of the sin/cos family alternate with terms no larger
than a few times the sum up to θ = 2, those of the cot family (α, γ and what follows from them) do not alternate
at all; above 2 each closed form is written so that no difference of large terms remains, and the two that
vanish inside (0, π], B1 at θ ≈ 2.3311 and A2 at θ ≈ 2.0816, are summed from the Taylor series of their
numerators about the root within 0.08 of it (the root known to 32 digits, as SE(2)'s B' [DER 11.7]). Every
coefficient is within 1e-13 relative of 50 digits from θ = 1e-12 to π (tests/test_lie_groups.py).

The series are built once at import from those of sin, cos and x cot x (Bernoulli numbers through ζ) by exact
operations on their coefficients: d/dθ, ÷θ, sums. SE(2)'s coefficients (``lie.se2``) are the same functions of
its signed angle, with their own branches.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
import scipy.special
from numpy.typing import ArrayLike, NDArray

__all__ = ["Coefficients", "NAMES", "DEFINITIONS", "SERIES_BELOW", "coefficients_at", "horner"]

SERIES_BELOW = 2.0  # θ below this: every coefficient from its series
_N = 24  # terms in θ² of each series: the last is below 1e-20 of the sum at θ = 2 (cot family: (θ/2π)^48 · 48²)
_k = np.arange(_N)
_fact = np.array([float(math.factorial(n)) for n in range(2 * _N + 4)])

# A series is (c, odd): θ^odd Σ c[k] θ²ᵏ.
Series = tuple[NDArray, bool]


def _d(s: Series) -> Series:
    """d/dθ of a series."""
    c, odd = s
    if odd:  # Σ c θ²ᵏ⁺¹ -> Σ (2k+1) c θ²ᵏ
        return (2 * _k + 1) * c, False
    return np.r_[2 * (_k[:-1] + 1) * c[1:], 0.0], True  # Σ c θ²ᵏ -> θ Σ 2(j+1) c[j+1] θ²ʲ


def _over_t(s: Series) -> Series:
    """A series ÷ θ (an even one must vanish at 0)."""
    c, odd = s
    if odd:
        return c, False
    assert c[0] == 0.0
    return np.r_[c[1:], 0.0], True


def _add(*terms: tuple[float, Series]) -> Series:
    """Σ weight · series, all of one parity."""
    (odd,) = {s[1] for _, s in terms}
    return np.sum([w * s[0] for w, s in terms], axis=0), odd


_S: dict[str, Series] = {
    "A": ((-1.0) ** _k / _fact[2 * _k + 1], False),
    "B": ((-1.0) ** _k / _fact[2 * _k + 2], True),
    "C": ((-1.0) ** _k / _fact[2 * _k + 3], True),
    "D": ((-1.0) ** _k / _fact[2 * _k + 2], False),
    # γ = (1 - (θ/2) cot(θ/2))/θ = Σₙ |B₂ₙ| θ²ⁿ⁻¹/(2n)! = Σₙ 2 ζ(2n) θ²ⁿ⁻¹/(2π)²ⁿ  [DER 11.3]
    "gamma": (2 * scipy.special.zeta(2.0 * (_k + 1)) / (2 * np.pi) ** (2.0 * (_k + 1)), True),
}
_S["alpha"] = (np.r_[1.0, -_S["gamma"][0][:-1]], False)  # α = 1 - θγ
for _name in ("A", "B", "C", "D", "alpha"):
    _S[_name + "1"] = _d(_S[_name])
_S["A2"], _S["B2"], _S["alpha2"] = _d(_S["A1"]), _d(_S["B1"]), _d(_S["alpha1"])
_S["Ct"], _S["A1t"], _S["alpha1t"], _S["gammat"] = (_over_t(_S[n]) for n in ("C", "A1", "alpha1", "gamma"))
_S["E1"] = _add((1.0, _S["Ct"]), (-1.0, _S["C1"]))
_S["G1"] = _over_t(_add((2.0, _S["gamma"]), (1.0, _S["alpha1"])))
_S["G2"] = _over_t(_add((-1.0, _S["gamma"]), (-1.0, _S["alpha1"])))

NAMES = tuple(_S)

# Each coefficient's definition, for a caller's math module m (m.sin, m.cos, m.cot): the tests evaluate them in mpmath.
_Def = Callable[[Any, Any], Any]
DEFINITIONS: dict[str, _Def] = {
    "A": lambda t, m: m.sin(t) / t,
    "B": lambda t, m: (1 - m.cos(t)) / t,
    "C": lambda t, m: (t - m.sin(t)) / t**2,
    "D": lambda t, m: (1 - m.cos(t)) / t**2,
    "gamma": lambda t, m: (1 - t / 2 * m.cot(t / 2)) / t,
    "alpha": lambda t, m: t / 2 * m.cot(t / 2),
    "A1": lambda t, m: (t * m.cos(t) - m.sin(t)) / t**2,
    "B1": lambda t, m: (t * m.sin(t) + m.cos(t) - 1) / t**2,
    "C1": lambda t, m: (2 * m.sin(t) - t - t * m.cos(t)) / t**3,
    "D1": lambda t, m: (t * m.sin(t) + 2 * m.cos(t) - 2) / t**3,
    "alpha1": lambda t, m: (m.sin(t) - t) / (2 * (1 - m.cos(t))),
    "A2": lambda t, m: (2 * m.sin(t) - 2 * t * m.cos(t) - t**2 * m.sin(t)) / t**3,
    "B2": lambda t, m: (t**2 * m.cos(t) - 2 * t * m.sin(t) + 2 - 2 * m.cos(t)) / t**3,
    "alpha2": lambda t, m: -1 / 2 + m.sin(t) * (t - m.sin(t)) / (2 * (1 - m.cos(t)) ** 2),
    "Ct": lambda t, m: (t - m.sin(t)) / t**3,
    "A1t": lambda t, m: (t * m.cos(t) - m.sin(t)) / t**3,
    "alpha1t": lambda t, m: (m.sin(t) - t) / (2 * t * (1 - m.cos(t))),
    "gammat": lambda t, m: (1 - t / 2 * m.cot(t / 2)) / t**2,
    "E1": lambda t, m: (t * m.cos(t) + 2 * t - 3 * m.sin(t)) / t**3,
    "G1": lambda t, m: (2 * (1 - t / 2 * m.cot(t / 2)) / t + (m.sin(t) - t) / (2 * (1 - m.cos(t)))) / t,
    "G2": lambda t, m: -((1 - t / 2 * m.cot(t / 2)) / t + (m.sin(t) - t) / (2 * (1 - m.cos(t)))) / t,
}
assert set(DEFINITIONS) == set(NAMES)


def _taylor_at_root(terms: list[tuple[float, int, str]], root: float, n: int = 14) -> NDArray:
    """n⁽ᵏ⁾(θ*)/k! for k = 1..n, where the numerator n(θ) = Σ c θᵐ f(θ), f in (sin, cos, one), vanishes at θ*:
    Leibniz's rule, (θᵐ f)⁽ᵏ⁾ = Σⱼ C(k, j) m!/(m-j)! θᵐ⁻ʲ f⁽ᵏ⁻ʲ⁾."""

    def f(name: str, order: int) -> float:
        if name == "one":
            return 1.0 if order == 0 else 0.0
        return math.sin(root + order * math.pi / 2) if name == "sin" else math.cos(root + order * math.pi / 2)

    out = []
    for k in range(1, n + 1):
        total = 0.0
        for c, m, name in terms:
            for j in range(min(k, m) + 1):
                total += c * math.comb(k, j) * math.perm(m, j) * root ** (m - j) * f(name, k - j)
        out.append(total / math.factorial(k))
    return np.array(out)


# The two coefficients that vanish inside (0, π]: the root θ* = HI + LO to 32 digits (mpmath's findroot), and the
# Taylor coefficients of the numerator about it. B1 = (θ sin θ + cos θ - 1)/θ², A2 = (2 sin θ - 2θ cos θ - θ² sin θ)/θ³.
_ROOT_NEAR = 0.08  # |θ - θ*| below this: the numerator from its Taylor series (14 terms, the last below 1e-25)
_B1_ROOT = (2.331122370414423, -2.1492054957191997e-16)
_A2_ROOT = (2.0815759778181007, -5.396937873960832e-17)
_B1_TAYLOR = _taylor_at_root([(1.0, 1, "sin"), (1.0, 0, "cos"), (-1.0, 0, "one")], _B1_ROOT[0])
_A2_TAYLOR = _taylor_at_root([(2.0, 0, "sin"), (-2.0, 1, "cos"), (-1.0, 2, "sin")], _A2_ROOT[0])


def horner(c: NDArray, z: NDArray) -> NDArray:
    """Σ c[k] zᵏ by Horner's rule, elementwise over z (any shape): the series of SO(3)'s, SE(3)'s and SE(2)'s
    coefficients (``se2_series``)."""
    out = np.full_like(z, c[-1])
    for ck in c[-2::-1]:
        out = out * z + ck
    return out


class Coefficients:
    """The coefficients at angles θ ≥ 0 (any shape), each computed when first read: ``k["A"]`` (module docstring)."""

    def __init__(self, theta: ArrayLike):
        self.t = np.asarray(theta, dtype=float)
        self.small = self.t < SERIES_BELOW
        self._known: dict[str, NDArray] = {}

    def __getitem__(self, name: str) -> NDArray:
        if name not in self._known:
            self._known[name] = self._pick(name)
        return self._known[name]

    def _series(self, name: str) -> NDArray:
        c, odd = _S[name]
        value = horner(c, self.t * self.t)
        return self.t * value if odd else value

    def _pick(self, name: str) -> NDArray:
        """The series below SERIES_BELOW, the closed form above (each evaluated only where needed)."""
        if np.all(self.small):
            return self._series(name)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # closed forms at θ = 0 are not used
            closed = getattr(self, "_" + name)()
            if not np.any(self.small):
                return closed
            return np.where(self.small, self._series(name), closed)

    def _near_root(self, root: tuple[float, float], taylor: NDArray, value: NDArray) -> NDArray:
        """``value`` (a numerator ÷ θ), or within _ROOT_NEAR of its root θ* its Taylor series there ÷ θ."""
        d = (self.t - root[0]) - root[1]  # θ - θ*: the first difference is exact near θ*
        near = np.abs(d) < _ROOT_NEAR
        return np.where(near, d * horner(taylor, d) / self.t, value) if np.any(near) else value

    # --- closed forms, θ ≥ SERIES_BELOW: 1 - cos θ = 2 sin²h, no difference of large terms, and θ's powers divided
    # one at a time, so none overflows at any finite θ ---------------------------------------------------------

    def _trig(self) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        if "_trig" not in self._known:
            t = self.t
            self._known["_trig"] = np.stack([np.sin(t), np.cos(t), np.sin(t / 2), np.cos(t / 2)])
        s, c, sh, ch = self._known["_trig"]
        return s, c, sh, ch

    def _A(self) -> NDArray:
        return self._trig()[0] / self.t

    def _B(self) -> NDArray:
        sh = self._trig()[2]
        return 2 * (sh * sh) / self.t

    def _C(self) -> NDArray:
        return (self.t - self._trig()[0]) / self.t / self.t

    def _D(self) -> NDArray:
        return self["B"] / self.t

    def _alpha(self) -> NDArray:
        _, _, sh, ch = self._trig()
        return self.t / 2 * ch / sh

    def _gamma(self) -> NDArray:
        return (1 - self["alpha"]) / self.t

    def _A1(self) -> NDArray:
        return (self._trig()[1] - self["A"]) / self.t

    def _B1(self) -> NDArray:  # 2 sin h (θ cos h - sin h)/θ², or about its root
        _, _, sh, ch = self._trig()
        return self._near_root(_B1_ROOT, _B1_TAYLOR, 2 * sh * (ch - sh / self.t)) / self.t

    def _C1(self) -> NDArray:  # 4 cos h (sin h - h cos h)/θ³: zero at θ = π with its relative precision
        _, _, sh, ch = self._trig()
        return 4 * ch * (sh / self.t - ch / 2) / self.t / self.t

    def _D1(self) -> NDArray:
        return (self["A"] - 2 * self["D"]) / self.t

    def _alpha1(self) -> NDArray:  # (sin θ - θ)/(2 (1 - cos θ)) = -C/(2D)
        s, _, sh, _ = self._trig()
        return (s - self.t) / (4 * (sh * sh))

    def _A2(self) -> NDArray:
        s, c, _, _ = self._trig()
        t = self.t
        return self._near_root(_A2_ROOT, _A2_TAYLOR, (2 * s / t - 2 * c) - t * s) / t / t

    def _B2(self) -> NDArray:
        s, c, sh, _ = self._trig()
        t = self.t
        return (c - 2 * s / t + 4 * (sh * sh) / t / t) / t

    def _alpha2(self) -> NDArray:  # -1/2 + sin θ (θ - sin θ)/(2 (1 - cos θ)²)
        s, _, sh, _ = self._trig()
        sh2 = sh * sh
        return -0.5 + s * (self.t - s) / (8 * (sh2 * sh2))

    def _Ct(self) -> NDArray:
        return self["C"] / self.t

    def _A1t(self) -> NDArray:
        return self["A1"] / self.t

    def _alpha1t(self) -> NDArray:
        return self["alpha1"] / self.t

    def _gammat(self) -> NDArray:
        return self["gamma"] / self.t

    def _E1(self) -> NDArray:
        return self["Ct"] - self["C1"]

    def _G1(self) -> NDArray:
        return (2 * self["gamma"] + self["alpha1"]) / self.t

    def _G2(self) -> NDArray:
        return -(self["gamma"] + self["alpha1"]) / self.t


def coefficients_at(theta: ArrayLike) -> dict[str, NDArray]:
    """Every coefficient of :data:`NAMES` at the angles θ (``LieGroup.coefficients`` of SO(3) and SE(3))."""
    k = Coefficients(np.abs(np.asarray(theta, dtype=float)))
    return {name: k[name] for name in NAMES}
