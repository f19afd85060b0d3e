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

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arguments import finite
from ..dead_reckoning import wrap_angle
from ..errors import ShapeError, SteamError
from .group import LieGroup, matrix_of
from .se2_series import SERIES_BELOW, Coefficients, coefficients

__all__ = ["SE2", "SE2Group", "wrap", "SERIES_BELOW"]


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
    if np.count_nonzero(inside) == inside.size:
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


def _exp_translation(xi: NDArray) -> tuple[NDArray, NDArray]:
    """Exp(ξ)'s translation t = V(φ) ρ, V = [[A, -B], [B, A]] (``SE2Group.exp``, ``compose_exp``).  [DER 11.1]"""
    k = coefficients(xi[..., 2])
    A, B, r1, r2 = k["A"], k["B"], xi[..., 0], xi[..., 1]
    return A * r1 - B * r2, B * r1 + A * r2


def _composed(a: NDArray, x: NDArray, y: NDArray, theta: NDArray) -> NDArray:
    """T_a T_b = [t_a + R_a t_b; θ_a + θ_b wrapped] from b's parts t_b = (x, y), θ_b (``_compose``, ``compose_exp``)."""
    c, s = _rot(a[..., 2])
    return _stacked([a[..., 0] + c * x - s * y, a[..., 1] + s * x + c * y, wrap(a[..., 2] + theta)])


def _jr_inverse_column(gamma: NDArray, r1: NDArray, r2: NDArray) -> tuple[NDArray, NDArray]:
    """J_r(ξ)⁻¹'s last column above its 1, (γρ₁ + ρ₂/2, γρ₂ - ρ₁/2), from γ at φ and ξ's translation ρ; J_r(ξ)⁻¹ is
    [[α, -φ/2, ·], [φ/2, α, ·], [0, 0, 1]] (``SE2Group.right_jacobian_inverse``, ``log_between``).  [DER 11.5]"""
    return gamma * r1 + r2 / 2, gamma * r2 - r1 / 2


def _jr_inverse_derivative(
    k: Coefficients, r1: NDArray, r2: NDArray, v1: NDArray, v2: NDArray, w: NDArray
) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """The entries (γw, w/2, α'v₁ - v₂/2 + γ'ρ₁w, v₁/2 + α'v₂ + γ'ρ₂w) of ∂(J_r(ξ)⁻¹ v)/∂ξ =
    [[γw, w/2, ·], [-w/2, γw, ·], [0, 0, 0]] from the coefficients ``k`` at φ, ξ's ρ and v = [v₁, v₂, w]
    (``SE2Group.jr_inverse_times_jacobian``, ``log_between``).  [DER 11.6]"""
    a1, g1 = k["alpha1"], k["gamma1"]
    return k["gamma"] * w, w / 2, a1 * v1 - v2 / 2 + g1 * r1 * w, v1 / 2 + a1 * v2 + g1 * r2 * w


class SE2Group(LieGroup):
    """SE(2) on poses [x, y, θ] and twists [ρx, ρy, φ] (module docstring); its one instance is :data:`SE2`."""

    name = "se2"
    dim = 3
    size = 3
    series_below = SERIES_BELOW

    def exp(self, xi: ArrayLike) -> NDArray:
        """Exp(ξ) as a pose [x, y, θ], θ wrapped exactly at any size: t = V(φ) ρ, V = [[A, -B], [B, A]].  [DER 11.1]"""
        xi = self._twists("xi", xi)
        return _stacked([*_exp_translation(xi), wrap(xi[..., 2])])  # [DER 11.1]

    def log(self, a: ArrayLike) -> NDArray:
        """Log(T) = [V(φ)⁻¹ t; φ], φ = θ wrapped to (-π, π]; V⁻¹ = [[α, φ/2], [-φ/2, α]].  [DER 11.1-11.2]"""
        pose = self._elements("a", a)
        phi = wrap(pose[..., 2])
        al, b = coefficients(phi)["alpha"], phi / 2
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

    def from_matrix(self, M: ArrayLike) -> NDArray:
        """[x, y, θ] of [[R(θ), t], [0, 1]], θ = atan2(R₁₀, R₀₀) in (-π, π]."""
        M = self._algebra("M", M, 3)
        return _stacked([M[..., 0, 2], M[..., 1, 2], wrap(np.arctan2(M[..., 1, 0], M[..., 0, 0]))])

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
        k = coefficients(xi[..., 2])
        A, B, C, D = k["A"], k["B"], k["C"], k["D"]
        r1, r2 = xi[..., 0], xi[..., 1]
        return matrix_of(  # [DER 11.4]
            [[A, B, C * r1 - D * r2], [-B, A, D * r1 + C * r2], [0.0, 0.0, 1.0]], r1
        )

    def right_jacobian_inverse(self, xi: ArrayLike) -> NDArray:
        """J_r(ξ)⁻¹ = [[α, -φ/2, γρ₁ + ρ₂/2], [φ/2, α, γρ₂ - ρ₁/2], [0, 0, 1]] in closed form.  [DER 11.5]"""
        xi = self._twists("xi", xi)
        k = coefficients(xi[..., 2])
        al, h, r1 = k["alpha"], xi[..., 2] / 2, xi[..., 0]
        j13, j23 = _jr_inverse_column(k["gamma"], r1, xi[..., 1])
        return matrix_of([[al, -h, j13], [h, al, j23], [0.0, 0.0, 1.0]], r1)  # [DER 11.5]

    def adjoint(self, a: ArrayLike) -> NDArray:
        """Ad(T) = [[R, [y, -x]ᵀ], [0, 1]]: T Exp(ξ) T⁻¹ = Exp(Ad(T) ξ).  [DER 11.8]"""
        pose = self._elements("a", a)
        c, s = _rot(pose[..., 2])
        return matrix_of([[c, -s, pose[..., 1]], [s, c, -pose[..., 0]], [0.0, 0.0, 1.0]], c)  # [DER 11.8]

    def _compose(self, a: NDArray, b: NDArray) -> NDArray:
        """T_a T_b = [t_a + R_a t_b; θ_a + θ_b wrapped]."""
        return _composed(a, b[..., 0], b[..., 1], b[..., 2])

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
        k, r1, r2 = coefficients(xi[..., 2]), xi[..., 0], xi[..., 1]
        gw, h, d13, d23 = np.broadcast_arrays(*_jr_inverse_derivative(k, r1, r2, v[..., 0], v[..., 1], v[..., 2]))
        return matrix_of([[gw, h, d13], [-h, gw, d23], [0.0, 0.0, 0.0]], gw)  # [DER 11.6]

    def _log_between(
        self, a: NDArray, b: NDArray, v: NDArray, jacobians: bool
    ) -> tuple[NDArray, NDArray] | tuple[NDArray, NDArray, NDArray, NDArray, NDArray]:
        """ξ = Log(a⁻¹ b), u = J_r(ξ)⁻¹ v and (``jacobians``) ∂ξ/∂δa, ∂ξ/∂δb = J_r(ξ)⁻¹, ∂u/∂ξ in one pass over the
        coefficients of φ [DER 11.1-11.6]; ∂ξ/∂δa = -J_r(ξ)⁻¹ Ad(Exp(-ξ)) = -J_r(-ξ)⁻¹ (J_r(ξ)⁻¹ Ad(Exp(-ξ)) is
        J_l(ξ)⁻¹ = J_r(-ξ)⁻¹ [SOLA]): (11.5) at -ξ, α even and γ odd in φ, so no rotation of ξ is needed."""
        c, s = _rot(a[..., 2])
        dx, dy = b[..., 0] - a[..., 0], b[..., 1] - a[..., 1]
        x, y = c * dx + s * dy, -s * dx + c * dy  # t of a⁻¹ b (``_between``)
        phi = wrap(b[..., 2] - a[..., 2])
        k = coefficients(phi)
        al, g, h = k["alpha"], k["gamma"], phi / 2
        r1, r2 = al * x + h * y, -h * x + al * y  # Log  [DER 11.1-11.2]
        v1, v2, w = v[..., 0], v[..., 1], v[..., 2]
        j13, j23 = _jr_inverse_column(g, r1, r2)  # [DER 11.5]
        xi, u = _stacked([r1, r2, phi]), _stacked([al * v1 - h * v2 + j13 * w, h * v1 + al * v2 + j23 * w, w])
        if not jacobians:
            return xi, u
        out = np.zeros(np.broadcast_shapes(r1.shape, w.shape) + (3, 3, 3))
        da, db, du = out[..., 0, :, :], out[..., 1, :, :], out[..., 2, :, :]
        da[..., 0, 0] = da[..., 1, 1] = -al  # -J_r(-ξ)⁻¹
        db[..., 0, 0] = db[..., 1, 1] = al  # J_r(ξ)⁻¹  [DER 11.5]
        da[..., 0, 1] = db[..., 0, 1] = -h
        da[..., 1, 0] = db[..., 1, 0] = h
        # -J_r(-ξ)⁻¹'s column: (11.5)'s at -ξ negated, which is (11.5)'s with γ → -γ (γ odd in φ, the column linear in ρ)
        da[..., 0, 2], da[..., 1, 2] = _jr_inverse_column(-g, r1, r2)
        da[..., 2, 2] = -1.0
        db[..., 0, 2], db[..., 1, 2], db[..., 2, 2] = j13, j23, 1.0
        gw, hw, du[..., 0, 2], du[..., 1, 2] = _jr_inverse_derivative(k, r1, r2, v1, v2, w)  # [DER 11.6]
        du[..., 0, 0] = du[..., 1, 1] = gw
        du[..., 0, 1], du[..., 1, 0] = hw, -hw
        return xi, u, da, db, du

    def compose_exp(self, a: ArrayLike, xi: ArrayLike) -> NDArray:
        """T Exp(ξ) = [t + R(θ) V(φ) ρ; θ + φ wrapped] in one pass: the same products as ``exp`` then ``compose``."""
        a, xi = self._elements("a", a), self._twists("xi", xi)
        return _composed(a, *_exp_translation(xi), wrap(xi[..., 2]))  # [DER 11.1]

    # --- a planar robot: an SE(2) pose is [x, y, θ] itself -------------------------------------------

    def state_names(self) -> tuple[str, ...]:
        """[px, py, θ, vx, vy, ω] as files write them."""
        return ("x", "y", "theta", "vx", "vy", "omega")

    def from_planar(self, pose: ArrayLike) -> NDArray:
        """[x, y, θ] with θ taken to (-π, π] as -wrap_angle(-θ) (``dead_reckoning``: the heading a planar front
        end has always handed a state, bit for bit; :func:`wrap` may differ from it in the last bit)."""
        pose = finite("pose", np.array(self._as_last("pose", pose, 3, "a planar pose [x, y, θ]")))  # a copy
        pose[..., 2] = -wrap_angle(-pose[..., 2])
        return pose

    def to_planar(self, a: ArrayLike) -> NDArray:
        """The pose [x, y, θ] as it is."""
        return np.array(self._elements("a", a))

    def body_twist(self, a: ArrayLike, velocity: ArrayLike) -> NDArray:
        """[R(θ)ᵀ [ẋ, ẏ]; θ̇]: the velocity in the robot's own frame (forward, lateral, yaw rate)."""
        a, v = self._elements("a", a), self._as_last("velocity", velocity, 3, "a planar velocity [ẋ, ẏ, θ̇]")
        c, s = _rot(a[..., 2])
        if a.ndim == 1 and v.shape == (3,):  # one state (a front end's new one): the same products in Python's floats
            (v1, v2, v3), cf, sf = v.tolist(), float(c), float(s)
            return np.array([cf * v1 + sf * v2, -sf * v1 + cf * v2, v3])
        return _stacked([c * v[..., 0] + s * v[..., 1], -s * v[..., 0] + c * v[..., 1], v[..., 2]])

    def world_velocity(self, a: ArrayLike, twist: ArrayLike) -> NDArray:
        """[R(θ) [vx, vy]; ω]: the body twist in the world frame."""
        a, w = self._elements("a", a), self._twists("twist", twist)
        c, s = _rot(a[..., 2])
        return _stacked([c * w[..., 0] - s * w[..., 1], s * w[..., 0] + c * w[..., 1], w[..., 2]])

    def jr_times_jacobian(self, xi: ArrayLike, v: ArrayLike) -> NDArray:
        """∂(J_r(ξ) v)/∂ξ, exact: (..., 3, 3).  [DER 11.7]"""
        xi, v = self._twists("xi", xi), self._twists("v", v)
        k = coefficients(xi[..., 2])
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
