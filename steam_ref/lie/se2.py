"""SE(2), the group of planar poses: :data:`SE2`, the first instance of :class:`~steam_ref.lie.group.LieGroup`.  [SOLA App. C]

A pose T = (R(θ), t) acts on a point as p ↦ R p + t; it is stored as [x, y, θ] with θ in (-π, π],
its tangent ξ = [ρx, ρy, φ] (translation first, as GTSAM's ``Pose2`` and [SOLA]). The protocol's
conventions (right Jacobians, broadcasting, value and Jacobians from one call) are in ``lie.group``;
this module holds what is SE(2)'s own:

- Exp, Log (Log's angle in (-π, π]), hat/vee, the 3 × 3 matrix of a pose, J_r and its closed-form
  inverse J_r⁻¹ [DER 11.5], Ad(T), the values of compose, inverse and between;
- the exact derivatives of J_r(ξ)⁻¹ v and J_r(ξ) v with respect to ξ (the SE(2) WNOA residual and
  the interpolation need them) [DER 11.6-11.7];
- :func:`wrap`, an angle to (-π, π], reduced exactly at any size (so are Exp's and compose's angles).

Every coefficient (sin φ/φ, (1 - cos φ)/φ², (φ - sin φ)/φ², (φ/2) cot(φ/2) and the rest, with their
derivatives) is summed from its Taylor series for abs(φ) < 1 (``SERIES_BELOW``) and taken in closed form above, so
none loses precision to cancellation near φ = 0 [DER 11.3-11.7].
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import scipy.special
from numpy.typing import ArrayLike, NDArray

from ..dead_reckoning import wrap_angle
from ..errors import ShapeError, SteamError
from .group import LieGroup, matrix_of

__all__ = ["SE2", "SE2Group", "wrap", "SERIES_BELOW"]

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


def _poly(c: NDArray, z: NDArray) -> NDArray:
    """Σ c[k] zᵏ by Horner's rule; at one z in Python's floats (the same IEEE double products and sums, rounded
    alike, so the same number to the last bit) at a fortieth of the cost of a NumPy operation on a 1-element array."""
    if z.size == 1:
        zf, terms = float(z.flat[0]), c.tolist()
        value = terms[-1]
        for ck in terms[-2::-1]:
            value = value * zf + ck
        out = np.empty_like(z)
        out[...] = value
        return out
    out = np.full_like(z, c[-1])
    for ck in c[-2::-1]:
        out = out * z + ck
    return out


class _Coefficients:
    """The coefficients of J_r, J_r⁻¹ and Exp/Log at φ and their derivatives, each computed when first
    read [DER 11.3-11.7]: A = sin φ/φ, B = (1 - cos φ)/φ, C = (φ - sin φ)/φ²,
    D = (1 - cos φ)/φ², α = (φ/2) cot(φ/2), γ = (1 - α)/φ; a trailing 1 is d/dφ."""

    def __init__(self, phi: ArrayLike):
        self.phi = np.asarray(phi, dtype=float)
        self.small = np.abs(self.phi) < SERIES_BELOW
        self.all_small = bool(self.small.all())
        self.any_small = self.all_small or bool(self.small.any())
        if self.all_small:
            self.z = self.phi**2
        else:
            with np.errstate(over="ignore"):  # |φ| > 1e154: φ² is inf, and the closed forms' O(1/φ²) terms 0
                self.z = self.phi**2
        self._known: dict[str, NDArray] = {}

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
        return self._pick(lambda: _poly(_A, self.z), lambda: np.sin(self.phi) / self.phi)

    def _D(self) -> NDArray:  # 1 - cos φ = 2 sin²(φ/2): no cancellation
        return self._pick(lambda: _poly(_D, self.z), lambda: 2 * np.sin(self.phi / 2) ** 2 / self.z)

    def _B(self) -> NDArray:
        return self.phi * self["D"]

    def _C(self) -> NDArray:
        return self._pick(lambda: self.phi * _poly(_C, self.z), lambda: (self.phi - np.sin(self.phi)) / self.z)

    def _A1(self) -> NDArray:
        return self._pick(lambda: self.phi * _poly(_A1, self.z), lambda: (np.cos(self.phi) - self["A"]) / self.phi)

    def _D1(self) -> NDArray:
        return self._pick(lambda: self.phi * _poly(_D1, self.z), lambda: (self["A"] - 2 * self["D"]) / self.phi)

    def _B1(self) -> NDArray:  # B' = A - D: above the switch 2 sin h g(h)/φ², h = φ/2, g(h) = 2h cos h - sin h
        return self._pick(lambda: self["D"] + self.phi * self["D1"], self._B1_closed)

    def _B1_closed(self) -> NDArray:
        h = np.abs(self.phi) / 2  # B' is even in φ
        g = 2 * h * np.cos(h) - np.sin(h)
        d = (h - _ROOT_HI) - _ROOT_LO  # h - h*: the first difference is exact near h*
        near = np.abs(d) < _ROOT_NEAR
        if np.any(near):
            g = np.where(near, d * _poly(_ROOT_G, d), g)  # Taylor series of g about its root h*
        return 2 * np.sin(h) * g / self.z

    def _C1(
        self,
    ) -> NDArray:  # C' = D - 2C/φ = 4 cos h (sin h - h cos h)/φ³, h = φ/2: no cancellation at φ = π, where C' = 0
        h = self.phi / 2
        return self._pick(
            lambda: _poly(_C1, self.z), lambda: 4 * np.cos(h) * (np.sin(h) - h * np.cos(h)) / (self.z * self.phi)
        )

    def _alpha(self) -> NDArray:
        h = self.phi / 2
        return self._pick(lambda: 1 - self.z * _poly(_G, self.z), lambda: h * np.cos(h) / np.sin(h))

    def _gamma(self) -> NDArray:
        return self._pick(lambda: self.phi * _poly(_G, self.z), lambda: (1 - self["alpha"]) / self.phi)

    def _alpha1(self) -> NDArray:  # (sin φ - φ) / (2 (1 - cos φ))
        return -self["C"] / (2 * self["D"])

    def _gamma1(self) -> NDArray:
        return self._pick(lambda: _poly(_G1, self.z), lambda: (-self["alpha1"] - self["gamma"]) / self.phi)


# the last φ's coefficients, as one (key, _Coefficients) pair replaced whole: the kernels of one factor read the same
# φ in turn; a thread reads the pair once, so it never returns the coefficients another thread's φ put there
_LAST: list[tuple[tuple, _Coefficients] | None] = [None]


def _coefficients(phi: NDArray) -> _Coefficients:
    """The coefficients at φ, shared with the last call at the same φ (Log, J_r⁻¹ and ∂(J_r⁻¹ v)/∂ξ of one local
    variable read one φ in turn: each coefficient is computed once, the same numbers)."""
    phi = np.asarray(phi, dtype=float)
    key = (phi.shape, phi.tobytes())
    last = _LAST[0]
    if last is not None and last[0] == key:
        return last[1]
    found = _Coefficients(phi.copy())
    _LAST[0] = (key, found)
    return found


def _stacked(values: list[NDArray]) -> NDArray:
    """``np.stack(values, axis=-1)`` for arrays of one shape, written in place (np.stack costs twenty times more on a
    few numbers)."""
    out = np.empty(np.shape(values[0]) + (len(values),))
    for i, v in enumerate(values):
        out[..., i] = v
    return out


def wrap(theta: ArrayLike) -> NDArray:
    """Angles mapped to (-π, π]; an angle already there is returned unchanged, bit for bit.

    Any other finite angle is reduced exactly (to the rounding of the result), as atan2(sin θ, cos θ): the sin
    and cos that Exp reads, whose argument reduction is exact at every size, so a pose's heading and its
    translation agree at any abs(θ) (subtracting a rounded 2π lost abs(θ)·2.4e-17: 2.1 rad at θ = 1e15, every digit
    from 1e16). An infinite or NaN angle has no reduction and is refused (ShapeError naming it).
    """
    theta = np.asarray(theta, dtype=float)
    inside = (theta > -np.pi) & (theta <= np.pi)
    if inside.all():
        return theta
    if not np.all(np.isfinite(theta)):
        bad = theta.ravel()[int(np.flatnonzero(~np.isfinite(theta))[0])]
        raise ShapeError(f"an angle to wrap to (-π, π] must be finite, got {bad}")
    sin = np.sin(theta)
    w = np.arctan2(sin, np.cos(theta))
    # atan2 rounded onto -π: the true angle is -π + |sin θ|; the nearer of the two angles of (-π, π] beside it,
    # π (a turn away: |sin θ| + (π - fl(π))) or the float above -fl(π) (ulp - |sin θ| + (π - fl(π)))
    above = np.nextafter(-np.pi, 0)
    w = np.where(w <= -np.pi, np.where(-sin > (above + np.pi) / 2, above, np.pi), w)
    return np.where(inside, theta, w)


def _rot(theta: NDArray) -> tuple[NDArray, NDArray]:
    return np.cos(theta), np.sin(theta)


class SE2Group(LieGroup):
    """SE(2) on poses [x, y, θ] and twists [ρx, ρy, φ] (module docstring); its one instance is :data:`SE2`."""

    name = "se2"
    dim = 3
    size = 3
    series_below = SERIES_BELOW

    def exp(self, xi: ArrayLike) -> NDArray:
        """Exp(ξ) as a pose [x, y, θ], θ wrapped exactly at any size: t = V(φ) ρ, V = [[A, -B], [B, A]].  [DER 11.1]"""
        xi = self._twists("xi", xi)
        k = _coefficients(xi[..., 2])
        A, B = k["A"], k["B"]
        r1, r2 = xi[..., 0], xi[..., 1]
        return _stacked([A * r1 - B * r2, B * r1 + A * r2, wrap(xi[..., 2])])  # [DER 11.1]

    def log(self, a: ArrayLike) -> NDArray:
        """Log(T) = [V(φ)⁻¹ t; φ], φ = θ wrapped to (-π, π]; V⁻¹ = [[α, φ/2], [-φ/2, α]].  [DER 11.1-11.2]"""
        pose = self._elements("a", a)
        phi = wrap(pose[..., 2])
        al, b = _coefficients(phi)["alpha"], phi / 2
        x, y = pose[..., 0], pose[..., 1]
        return _stacked([al * x + b * y, -b * x + al * y, phi])  # [DER 11.1-11.2]

    def hat(self, xi: ArrayLike) -> NDArray:
        """ξ^ = [[0, -φ, ρx], [φ, 0, ρy], [0, 0, 0]]."""
        xi = self._twists("xi", xi)
        r1, r2, p = xi[..., 0], xi[..., 1], xi[..., 2]
        return matrix_of([[0.0, -p, r1], [p, 0.0, r2], [0.0, 0.0, 0.0]], p)

    def vee(self, X: ArrayLike) -> NDArray:
        """[ρx, ρy, φ] = [X₀₂, X₁₂, X₁₀]."""
        X = self._algebra("X", X, 3)
        return _stacked([X[..., 0, 2], X[..., 1, 2], X[..., 1, 0]])

    def matrix(self, a: ArrayLike) -> NDArray:
        """[[R(θ), t], [0, 1]]."""
        pose = self._elements("a", a)
        c, s = _rot(pose[..., 2])
        return matrix_of([[c, -s, pose[..., 0]], [s, c, pose[..., 1]], [0.0, 0.0, 1.0]], c)

    def angle(self, xi: ArrayLike) -> NDArray:
        """abs(φ), the angle every coefficient's series switch tests."""
        return np.abs(self._twists("xi", xi)[..., 2])

    def check_stored(self, name: str, a: NDArray) -> None:
        """A pose [x, y, θ] with θ in (-π, π]; SteamError naming ``name`` otherwise."""
        if not -np.pi < a[2] <= np.pi:
            raise SteamError(f"{name}: the heading of an SE(2) pose must lie in (-π, π], got θ={float(a[2])!r}")

    def right_jacobian(self, xi: ArrayLike) -> NDArray:
        """J_r(ξ): Exp(ξ + dξ) ≈ Exp(ξ) Exp(J_r(ξ) dξ) (GTSAM's ``Pose2.ExpmapDerivative``).  [DER 11.4]"""
        xi = self._twists("xi", xi)
        k = _coefficients(xi[..., 2])
        A, B, C, D = k["A"], k["B"], k["C"], k["D"]
        r1, r2 = xi[..., 0], xi[..., 1]
        return matrix_of(  # [DER 11.4]
            [[A, B, C * r1 - D * r2], [-B, A, D * r1 + C * r2], [0.0, 0.0, 1.0]], r1
        )

    def right_jacobian_inverse(self, xi: ArrayLike) -> NDArray:
        """J_r(ξ)⁻¹ = [[α, -φ/2, γρ₁ + ρ₂/2], [φ/2, α, γρ₂ - ρ₁/2], [0, 0, 1]] in closed form.  [DER 11.5]"""
        xi = self._twists("xi", xi)
        g = _coefficients(xi[..., 2])
        al, G, b = g["alpha"], g["gamma"], xi[..., 2] / 2
        r1, r2 = xi[..., 0], xi[..., 1]
        return matrix_of([[al, -b, G * r1 + r2 / 2], [b, al, G * r2 - r1 / 2], [0.0, 0.0, 1.0]], r1)  # [DER 11.5]

    def adjoint(self, a: ArrayLike) -> NDArray:
        """Ad(T) = [[R, [y, -x]ᵀ], [0, 1]]: T Exp(ξ) T⁻¹ = Exp(Ad(T) ξ).  [DER 11.8]"""
        pose = self._elements("a", a)
        c, s = _rot(pose[..., 2])
        return matrix_of([[c, -s, pose[..., 1]], [s, c, -pose[..., 0]], [0.0, 0.0, 1.0]], c)  # [DER 11.8]

    def _compose(self, a: NDArray, b: NDArray) -> NDArray:
        """T_a T_b = [t_a + R_a t_b; θ_a + θ_b wrapped]."""
        c, s = _rot(a[..., 2])
        x = a[..., 0] + c * b[..., 0] - s * b[..., 1]
        y = a[..., 1] + s * b[..., 0] + c * b[..., 1]
        return _stacked([x, y, wrap(a[..., 2] + b[..., 2])])

    def _inverse(self, a: NDArray) -> NDArray:
        """T⁻¹ = [-Rᵀ t; -θ wrapped]."""
        c, s = _rot(a[..., 2])
        x, y = a[..., 0], a[..., 1]
        return _stacked([-(c * x + s * y), s * x - c * y, wrap(-a[..., 2])])

    def _between(self, a: NDArray, b: NDArray) -> NDArray:
        """T_a⁻¹ T_b = [R_aᵀ (t_b - t_a); θ_b - θ_a wrapped] (GTSAM's ``Pose2.between``)."""
        c, s = _rot(a[..., 2])
        dx, dy = b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]
        return _stacked([c * dx + s * dy, -s * dx + c * dy, wrap(b[..., 2] - a[..., 2])])

    def jr_inverse_times_jacobian(self, xi: ArrayLike, v: ArrayLike) -> NDArray:
        """∂(J_r(ξ)⁻¹ v)/∂ξ, exact, in closed form: (..., 3, 3).  [DER 11.6]"""
        xi, v = self._twists("xi", xi), self._twists("v", v)
        g = _coefficients(xi[..., 2])
        G, a1, G1 = g["gamma"], g["alpha1"], g["gamma1"]
        r1, r2 = xi[..., 0], xi[..., 1]
        u1, u2, w = v[..., 0], v[..., 1], v[..., 2]
        r1, r2, u1, u2, w, G, a1, G1 = np.broadcast_arrays(r1, r2, u1, u2, w, G, a1, G1)
        return matrix_of(
            [
                [G * w, w / 2, a1 * u1 - u2 / 2 + G1 * r1 * w],
                [-w / 2, G * w, u1 / 2 + a1 * u2 + G1 * r2 * w],
                [0.0, 0.0, 0.0],
            ],
            r1,
        )

    # --- a planar robot: an SE(2) pose is [x, y, θ] itself -------------------------------------------

    def state_names(self) -> tuple[str, ...]:
        """[px, py, θ, vx, vy, ω] as files write them."""
        return ("x", "y", "theta", "vx", "vy", "omega")

    def from_planar(self, pose: ArrayLike) -> NDArray:
        """[x, y, θ] with θ taken to (-π, π] as -wrap_angle(-θ) (``dead_reckoning``: the heading a planar front
        end has always handed a state, bit for bit; :func:`wrap` may differ from it in the last bit)."""
        pose = np.array(pose, dtype=float)
        pose[..., 2] = -wrap_angle(-pose[..., 2])
        return pose

    def to_planar(self, a: ArrayLike) -> NDArray:
        """The pose [x, y, θ] as it is."""
        return np.array(a, dtype=float)

    def body_twist(self, a: ArrayLike, velocity: ArrayLike) -> NDArray:
        """[R(θ)ᵀ [ẋ, ẏ]; θ̇]: the velocity in the robot's own frame (forward, lateral, yaw rate)."""
        a, v = np.asarray(a, dtype=float), np.asarray(velocity, dtype=float)
        c, s = _rot(a[..., 2])
        if a.ndim == 1 and v.shape == (3,):  # one state (a front end's new one): the same products in Python's floats
            (v1, v2, v3), cf, sf = v.tolist(), float(c), float(s)
            return np.array([cf * v1 + sf * v2, -sf * v1 + cf * v2, v3])
        return _stacked([c * v[..., 0] + s * v[..., 1], -s * v[..., 0] + c * v[..., 1], v[..., 2]])

    def world_velocity(self, a: ArrayLike, twist: ArrayLike) -> NDArray:
        """[R(θ) [vx, vy]; ω]: the body twist in the world frame."""
        a, w = np.asarray(a, dtype=float), np.asarray(twist, dtype=float)
        c, s = _rot(a[..., 2])
        return _stacked([c * w[..., 0] - s * w[..., 1], s * w[..., 0] + c * w[..., 1], w[..., 2]])

    def jr_times_jacobian(self, xi: ArrayLike, v: ArrayLike) -> NDArray:
        """∂(J_r(ξ) v)/∂ξ, exact: (..., 3, 3).  [DER 11.7]"""
        xi, v = self._twists("xi", xi), self._twists("v", v)
        k = _coefficients(xi[..., 2])
        r1, r2 = xi[..., 0], xi[..., 1]
        v1, v2, v3 = v[..., 0], v[..., 1], v[..., 2]
        A1, B1, C, C1, D, D1 = k["A1"], k["B1"], k["C"], k["C1"], k["D"], k["D1"]
        r1, r2, v1, v2, v3, A1, B1, C, C1, D, D1 = np.broadcast_arrays(r1, r2, v1, v2, v3, A1, B1, C, C1, D, D1)
        return matrix_of(
            [
                [C * v3, -D * v3, A1 * v1 + B1 * v2 + (C1 * r1 - D1 * r2) * v3],
                [D * v3, C * v3, -B1 * v1 + A1 * v2 + (D1 * r1 + C1 * r2) * v3],
                [0.0, 0.0, 0.0],
            ],
            r1,
        )


SE2 = SE2Group()  # the group SE(2): every function of it is a method of this object
