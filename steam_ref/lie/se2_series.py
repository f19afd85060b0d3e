"""The series and closed forms of SE(2)'s coefficients of φ, each computed once per angle.  [DER 11.3-11.7]

A = sin φ/φ, B = (1 - cos φ)/φ, C = (φ - sin φ)/φ², D = (1 - cos φ)/φ², α = (φ/2) cot(φ/2), γ = (1 - α)/φ and their
derivatives (a trailing 1 is d/dφ): each summed from its Taylor series for abs(φ) < 1 (``SERIES_BELOW``) and taken in
closed form above, so none loses precision to cancellation near φ = 0; the SE(2) group (``lie.se2``) reads them
through :func:`coefficients`, which shares one angle's coefficients among the kernels that read it in turn.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import scipy.special
from numpy.typing import ArrayLike, NDArray

from .coefficients import horner

__all__ = ["Coefficients", "SERIES_BELOW", "coefficients"]

SERIES_BELOW = 1.0  # |φ| below this: the coefficients from their series (each converges fast there)
_TERMS = 14  # terms of each series: the last is below 1e-22 of the first at |φ| = 1
_k = np.arange(_TERMS)
_fact = np.array([float(math.factorial(n)) for n in range(2 * _TERMS + 6)])
# Coefficients of each series in powers of φ² (c[0] + c[1] φ² + ...), from sin and cos's Taylor series.
_A = (-1.0) ** _k / _fact[2 * _k + 1]  # sin φ / φ
_A1 = (-1.0) ** (_k + 1) * 2 * (_k + 1) / _fact[2 * _k + 3]  # (d/dφ of sin φ/φ) / φ
_D = (-1.0) ** _k / _fact[2 * _k + 2]  # (1 - cos φ) / φ²
_D1 = (-1.0) ** (_k + 1) * 2 * (_k + 1) / _fact[2 * _k + 4]  # (d/dφ of D) / φ
_C = (-1.0) ** _k / _fact[2 * _k + 3]  # (φ - sin φ) / φ³
_C1 = (-1.0) ** _k * (2 * _k + 1) / _fact[2 * _k + 3]  # d/dφ of C = (φ - sin φ) / φ²
# (1 - (φ/2) cot(φ/2)) / φ = Σₙ |B₂ₙ| φ²ⁿ⁻¹ / (2n)! = Σₙ 2 ζ(2n) φ²ⁿ⁻¹ / (2π)²ⁿ (Bernoulli numbers B₂ₙ)
_G = 2 * scipy.special.zeta(2.0 * (_k + 1)) / (2 * np.pi) ** (2.0 * (_k + 1))  # γ / φ  [DER 11.3]
_G1 = (2 * _k + 1) * _G  # d/dφ of γ
# B' = 2 sin h g(h) / φ² with h = φ/2 and g(h) = 2h cos h - sin h, which vanishes at h* (tan h* = 2h*, φ* = 2h* ≈ 2.331,
# where B = (1 - cos φ)/φ peaks): within _ROOT_NEAR of h*, g is summed from its Taylor series about h*, so B' keeps
# its relative precision through its zero [DER 11.7]. h* = _ROOT_HI + _ROOT_LO to 32 digits (mpmath's findroot).
_ROOT_HI, _ROOT_LO = 1.1655611852072114, -1.0746027478595998e-16
_ROOT_NEAR = 0.05  # |h - h*| below this: 12 terms, the last below 1e-20 of g
_rc, _rs = math.cos(_ROOT_HI), math.sin(_ROOT_HI)
_cos_k, _sin_k = (_rc, -_rs, -_rc, _rs), (_rs, _rc, -_rs, -_rc)  # the k-th derivatives of cos and sin at h*, k mod 4
# g⁽ᵏ⁾(h*) / k! for k = 1..12, g⁽ᵏ⁾ = 2h cos⁽ᵏ⁾ + 2k cos⁽ᵏ⁻¹⁾ - sin⁽ᵏ⁾; g(h) = Σ _ROOT_G[k-1] (h - h*)ᵏ
_ROOT_G = np.array(
    [(2 * _ROOT_HI * _cos_k[k % 4] + 2 * k * _cos_k[(k - 1) % 4] - _sin_k[k % 4]) / _fact[k] for k in range(1, 13)]
)


_SERIES = {"A": _A, "A1": _A1, "D": _D, "D1": _D1, "C": _C, "C1": _C1, "G": _G, "G1": _G1}
_ROW = {name: i for i, name in enumerate(_SERIES)}
_TABLE = np.stack(list(_SERIES.values()), axis=1)  # (_TERMS, 8): term k of every series in row k


_POWERS = np.arange(_TERMS, dtype=float)
_TERMS_BY_SERIES = np.ascontiguousarray(_TABLE.T)  # (8, _TERMS)


def _series_sums(z: NDArray) -> NDArray:
    """Every series of _TABLE at z, (..., 8): Σₖ cₖ zᵏ, each term from zᵏ and the sum over k in one reduction (the
    same operations for each z whatever the shape, so one φ alone gets the same numbers as in a batch). Each series'
    terms fall as 1/(2k)! or faster for abs(z) < 1, so the sum is good to a few ulps."""
    return ((z[..., None] ** _POWERS)[..., None, :] * _TERMS_BY_SERIES).sum(axis=-1)


class Coefficients:
    """The coefficients of J_r, J_r⁻¹ and Exp/Log at φ and their derivatives, each computed when first
    read [DER 11.3-11.7]: A = sin φ/φ, B = (1 - cos φ)/φ, C = (φ - sin φ)/φ²,
    D = (1 - cos φ)/φ², α = (φ/2) cot(φ/2), γ = (1 - α)/φ; a trailing 1 is d/dφ."""

    def __init__(self, phi: ArrayLike):
        self.phi = np.asarray(phi, dtype=float)
        self.small = np.abs(self.phi) < SERIES_BELOW
        n_small = np.count_nonzero(self.small)  # (a third of the cost of .all() and .any() on a few numbers)
        self.all_small, self.any_small = n_small == self.small.size, n_small > 0
        if self.all_small:
            self.z = self.phi * self.phi
        else:
            with np.errstate(over="ignore"):  # |φ| > 1e154: φ² is inf, and the closed forms' O(1/φ²) terms 0
                self.z = self.phi * self.phi
        self._known: dict[str, NDArray] = {}
        self._sums: NDArray | None = None  # every series at z, summed when the first is read

    def _sum(self, name: str) -> NDArray:
        """The series ``name`` at z = φ², from every series summed at the first one read (``_series_sums``)."""
        if self._sums is None:
            self._sums = _series_sums(self.z)
        return self._sums[..., _ROW[name]]

    def _pick(self, series: Callable[[], NDArray], closed: Callable[[], NDArray]) -> NDArray:
        """The series below SERIES_BELOW, the closed form above (each a thunk, evaluated only if needed)."""
        if self.all_small:
            return series()
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # the closed forms at φ = 0 are not used
            if not self.any_small:
                return closed()
            return np.where(self.small, series(), closed())

    def __getitem__(self, name: str) -> NDArray:
        if name not in self._known:
            self._known[name] = getattr(self, "_" + name)()
        return self._known[name]

    def _A(self) -> NDArray:
        return self._pick(lambda: self._sum("A"), lambda: np.sin(self.phi) / self.phi)

    def _D(self) -> NDArray:  # 1 - cos φ = 2 sin²(φ/2): no cancellation
        return self._pick(lambda: self._sum("D"), lambda: 2 * np.square(np.sin(self.phi / 2)) / self.z)

    def _B(self) -> NDArray:
        return self.phi * self["D"]

    def _C(self) -> NDArray:
        return self._pick(lambda: self.phi * self._sum("C"), lambda: (self.phi - np.sin(self.phi)) / self.z)

    def _A1(self) -> NDArray:
        return self._pick(lambda: self.phi * self._sum("A1"), lambda: (np.cos(self.phi) - self["A"]) / self.phi)

    def _D1(self) -> NDArray:
        return self._pick(lambda: self.phi * self._sum("D1"), lambda: (self["A"] - 2 * self["D"]) / self.phi)

    def _B1(self) -> NDArray:  # B' = A - D: above the switch 2 sin h g(h)/φ², h = φ/2, g(h) = 2h cos h - sin h
        return self._pick(lambda: self["D"] + self.phi * self["D1"], self._B1_closed)

    def _B1_closed(self) -> NDArray:
        h = np.abs(self.phi) / 2  # B' is even in φ
        g = 2 * h * np.cos(h) - np.sin(h)
        d = (h - _ROOT_HI) - _ROOT_LO  # h - h*: the first difference is exact near h*
        near = np.abs(d) < _ROOT_NEAR
        if np.any(near):
            g = np.where(near, d * horner(_ROOT_G, d), g)  # Taylor series of g about its root h*
        return 2 * np.sin(h) * g / self.z

    def _C1(self) -> NDArray:
        h = self.phi / 2  # C' = D - 2C/φ = 4 cos h (sin h - h cos h)/φ³: no cancellation at φ = π, where C' = 0
        return self._pick(
            lambda: self._sum("C1"), lambda: 4 * np.cos(h) * (np.sin(h) - h * np.cos(h)) / (self.z * self.phi)
        )

    def _alpha(self) -> NDArray:
        h = self.phi / 2
        return self._pick(lambda: 1 - self.z * self._sum("G"), lambda: h * np.cos(h) / np.sin(h))

    def _gamma(self) -> NDArray:
        return self._pick(lambda: self.phi * self._sum("G"), lambda: (1 - self["alpha"]) / self.phi)

    def _alpha1(self) -> NDArray:  # (sin φ - φ) / (2 (1 - cos φ))
        return -self["C"] / (2 * self["D"])

    def _gamma1(self) -> NDArray:
        return self._pick(lambda: self._sum("G1"), lambda: (-self["alpha1"] - self["gamma"]) / self.phi)


# the last φ's coefficients, as one (key, Coefficients) pair replaced whole: the kernels of one factor read the same
# φ in turn; a thread reads the pair once, so it never returns the coefficients another thread's φ put there
_LAST: list[tuple[tuple, Coefficients] | None] = [None]


def coefficients(phi: NDArray) -> Coefficients:
    """The coefficients at φ, shared with the last call at the same φ (Log, J_r⁻¹ and ∂(J_r⁻¹ v)/∂ξ of one local
    variable read one φ in turn: each coefficient is computed once, the same numbers)."""
    phi = np.asarray(phi, dtype=float)
    key = (phi.shape, phi.tobytes())
    last = _LAST[0]
    if last is not None and last[0] == key:
        return last[1]
    found = Coefficients(phi.copy())
    _LAST[0] = (key, found)
    return found
