"""SE(3), the group of rigid motions in space: :data:`SE3`, an instance of :class:`~steam_ref.lie.group.LieGroup`.  [DER 13]

A pose T = (R, t) acts on a point as p ↦ R p + t; it is stored as 12 numbers [t; R row-major] (translation
first, as the tangent), its tangent ξ = [ρ; φ] (translation first, as SE(2) here and [SOLA]; GTSAM's ``Pose3``
puts the rotation first, [ω; v]). The protocol's conventions are in ``lie.group``; this module holds SE(3)'s own:

- Exp(ξ) = (Exp_SO3(φ), V(φ) ρ) with V = J_l(φ) = A I + D φ^ + Ct φφᵀ (any finite angle), Log by SO(3)'s Log (exact up to θ = π)
  and V⁻¹ = α I - φ^/2 + γt φφᵀ [B24; SOLA App. D; DER 13.1-13.2];
- J_r(ξ) = [[J_r(φ), Q_r(ρ, φ)], [0, J_r(φ)]] and its closed-form inverse [[J_r⁻¹, -J_r⁻¹ Q_r J_r⁻¹], [0, J_r⁻¹]]:
  Barfoot's Q block [B24; BF14] (for the right Jacobian, Q_r(ρ, φ) = Q_l(-ρ, -φ)), written in the frame of
  the rotation axis, where each entry of Q_r and of -J_r⁻¹ Q_r J_r⁻¹ is one coefficient times a component of ρ
  [DER 13.4];
- Ad(T) = [[R, t^ R], [0, R]]; the values of compose, inverse and between;
- the exact derivatives of J_r(ξ) v and J_r(ξ)⁻¹ v in the same frame [DER 13.5]: every term, where GTSAM 4.3
  truncates a series for the second and STEAM keeps only its first-order term.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .coefficients import DEFINITIONS, SERIES_BELOW, Coefficients, coefficients_at
from .group import LieGroup, matrix_of
from .so3 import SO3, axis_frame, check_rotation, hat3, isotropic, mm3, mv3, rotation_angle, unit_axis

__all__ = ["SE3", "SE3Group", "SE3V", "SE3VectorGroup"]


def _split(a: NDArray) -> tuple[NDArray, NDArray]:
    """An element's translation (..., 3) and rotation matrix (..., 3, 3)."""
    return a[..., :3], a[..., 3:].reshape(a.shape[:-1] + (3, 3))


def _join(t: NDArray, R: NDArray) -> NDArray:
    """The element [t; R row-major] (..., 12)."""
    flat = R.reshape(R.shape[:-2] + (9,))
    shape = np.broadcast_shapes(t.shape[:-1], flat.shape[:-1])
    return np.concatenate([np.broadcast_to(t, shape + (3,)), np.broadcast_to(flat, shape + (9,))], axis=-1)


def _blocks(tl: NDArray, tr: NDArray, br: NDArray) -> NDArray:
    """The 6 × 6 [[tl, tr], [0, br]] from 3 × 3 blocks."""
    tl, tr, br = np.broadcast_arrays(tl, tr, br)
    return np.concatenate([np.concatenate([tl, tr], -1), np.concatenate([np.zeros_like(tl), br], -1)], -2)


def _conjugate(F: NDArray, M: NDArray) -> NDArray:
    """diag(F, F) M diag(F, F)ᵀ for a 6 × 6 M, block by block (exact where F is a signed permutation)."""
    Ft = np.swapaxes(F, -1, -2)
    return np.concatenate(
        [
            np.concatenate([mm3(mm3(F, M[..., 3 * i : 3 * i + 3, 3 * j : 3 * j + 3]), Ft) for j in (0, 1)], -1)
            for i in (0, 1)
        ],
        -2,
    )


class SE3Group(LieGroup):
    """SE(3) on poses stored as [t; R row-major] and twists [ρ; φ] (module docstring); its one instance is :data:`SE3`."""

    name = "se3"
    dim = 6
    size = 12
    series_below = SERIES_BELOW
    coefficient_definitions = DEFINITIONS

    def coefficients(self, theta: ArrayLike) -> dict[str, NDArray]:
        """The coefficients of ``lie.coefficients`` at the angles θ (those of SO(3) too)."""
        return coefficients_at(theta)

    def exp(self, xi: ArrayLike) -> NDArray:
        """Exp(ξ) = (Exp(φ), V(φ) ρ), V = A I + D φ^ + Ct φφᵀ.  [DER 13.1]"""
        xi = self._twists("xi", xi)
        rho, phi = xi[..., :3], xi[..., 3:]
        R = SO3.rotation(phi)  # (refuses an infinite or NaN angle)
        theta, u = unit_axis(phi)
        k = Coefficients(theta)
        return _join(mv3(isotropic(k["A"], k["B"], k["C"] * theta, u), rho), R)

    def log(self, a: ArrayLike) -> NDArray:
        """Log(T) = [V(φ)⁻¹ t; φ], φ = Log(R) (angle in [0, π]), V⁻¹ = α I - φ^/2 + γt φφᵀ.  [DER 13.2]"""
        t, R = _split(self._elements("a", a))
        phi = SO3.log_matrix(R)
        theta, u = unit_axis(phi)
        k = Coefficients(theta)
        return np.concatenate([mv3(isotropic(k["alpha"], -theta / 2, k["gamma"] * theta, u), t), phi], axis=-1)

    def hat(self, xi: ArrayLike) -> NDArray:
        """ξ^ = [[φ^, ρ], [0, 0]] (4 × 4)."""
        xi = self._twists("xi", xi)
        top = np.concatenate([hat3(xi[..., 3:]), xi[..., :3, None]], axis=-1)
        return np.concatenate([top, np.zeros(top.shape[:-2] + (1, 4))], axis=-2)

    def vee(self, X: ArrayLike) -> NDArray:
        """[X₀₃, X₁₃, X₂₃, X₂₁, X₀₂, X₁₀]."""
        X = self._algebra("X", X, 4)
        return np.stack([X[..., 0, 3], X[..., 1, 3], X[..., 2, 3], X[..., 2, 1], X[..., 0, 2], X[..., 1, 0]], -1)

    def matrix(self, a: ArrayLike) -> NDArray:
        """[[R, t], [0, 1]] (4 × 4)."""
        t, R = _split(self._elements("a", a))
        top = np.concatenate([R, t[..., None]], axis=-1)
        return np.concatenate([top, np.broadcast_to([0.0, 0.0, 0.0, 1.0], top.shape[:-2] + (1, 4))], axis=-2)

    def from_matrix(self, M: ArrayLike) -> NDArray:
        """[t; R row-major] of [[R, t], [0, 1]]."""
        M = self._algebra("M", M, 4)
        return _join(M[..., :3, 3], M[..., :3, :3])

    def angle(self, xi: ArrayLike) -> NDArray:
        """θ = ‖φ‖, the angle every coefficient's series switch tests."""
        return rotation_angle(self._twists("xi", xi)[..., 3:])

    def check_stored(self, name: str, a: NDArray) -> None:
        """A pose [t; R row-major] whose R is a rotation to 1e-9 (SO(3)'s check); SteamError naming ``name``."""
        check_rotation(name, a[3:].reshape(3, 3))

    def right_jacobian(self, xi: ArrayLike) -> NDArray:
        """J_r(ξ) = [[J_r(φ), Q_r], [0, J_r(φ)]] (GTSAM's ``Pose3.ExpmapDerivative``, reordered).  [DER 13.3-13.4]"""
        xi = self._twists("xi", xi)
        J = SO3.right_jacobian(xi[..., 3:])
        return _blocks(J, _q_block(xi, _q_r), J)

    def right_jacobian_inverse(self, xi: ArrayLike) -> NDArray:
        """J_r(ξ)⁻¹ = [[J_r(φ)⁻¹, -J_r⁻¹ Q_r J_r⁻¹], [0, J_r(φ)⁻¹]] in closed form.  [DER 13.4]"""
        xi = self._twists("xi", xi)
        Ji = SO3.right_jacobian_inverse(xi[..., 3:])
        return _blocks(Ji, _q_block(xi, _q_r_inverse), Ji)

    def adjoint(self, a: ArrayLike) -> NDArray:
        """Ad(T) = [[R, t^ R], [0, R]]: T Exp(ξ) T⁻¹ = Exp(Ad(T) ξ).  [DER 13.6]"""
        t, R = _split(self._elements("a", a))
        return _blocks(R, mm3(hat3(t), R), R)

    def jr_times_jacobian(self, xi: ArrayLike, v: ArrayLike) -> NDArray:
        """∂(J_r(ξ) v)/∂ξ (6 × 6), exact, from the axis frame.  [DER 13.5]"""
        return _derivative(self._twists("xi", xi), self._twists("v", v), _jr_v)

    def jr_inverse_times_jacobian(self, xi: ArrayLike, v: ArrayLike) -> NDArray:
        """∂(J_r(ξ)⁻¹ v)/∂ξ (6 × 6), exact, from the axis frame.  [DER 13.5]"""
        return _derivative(self._twists("xi", xi), self._twists("v", v), _jr_inverse_v)

    def _compose(self, a: NDArray, b: NDArray) -> NDArray:
        """(R_a R_b, t_a + R_a t_b)."""
        (ta, Ra), (tb, Rb) = _split(a), _split(b)
        return _join(ta + mv3(Ra, tb), mm3(Ra, Rb))

    def _inverse(self, a: NDArray) -> NDArray:
        """(Rᵀ, -Rᵀ t)."""
        t, R = _split(a)
        Rt = np.swapaxes(R, -1, -2)
        return _join(-mv3(Rt, t), Rt)

    def _between(self, a: NDArray, b: NDArray) -> NDArray:
        """(R_aᵀ R_b, R_aᵀ (t_b - t_a)) (GTSAM's ``Pose3.between``)."""
        (ta, Ra), (tb, Rb) = _split(a), _split(b)
        Rt = np.swapaxes(Ra, -1, -2)
        return _join(mv3(Rt, tb - ta), mm3(Rt, Rb))


# --- the axis frame: φ = θ e_z, r = Fᵀρ, each entry one coefficient times components [DER 13.4-13.5] ---------------

_Entries = Callable[..., NDArray]


def _q_block(xi: NDArray, entries: _Entries) -> NDArray:
    """F M Fᵀ with M = entries(coefficients, r1, r2, r3), r = Fᵀρ."""
    theta, u = unit_axis(xi[..., 3:])
    F = axis_frame(u)
    Ft = np.swapaxes(F, -1, -2)
    r = mv3(Ft, xi[..., :3])
    return mm3(mm3(F, entries(Coefficients(theta), r[..., 0], r[..., 1], r[..., 2])), Ft)


def _q_r(k: Coefficients, r1: NDArray, r2: NDArray, r3: NDArray) -> NDArray:
    """Q_r(ρ, θ e_z).  [DER 13.4]"""
    A1, B1, C, D = k["A1"], k["B1"], k["C"], k["D"]
    return matrix_of(
        [
            [A1 * r3, B1 * r3, C * r1 - D * r2],
            [-B1 * r3, A1 * r3, D * r1 + C * r2],
            [C * r1 + D * r2, -D * r1 + C * r2, 0.0],
        ],
        r1 * C,
    )


def _q_r_inverse(k: Coefficients, r1: NDArray, r2: NDArray, r3: NDArray) -> NDArray:
    """-J_r⁻¹ Q_r J_r⁻¹ at (ρ, θ e_z).  [DER 13.4]"""
    a1, G = k["alpha1"], k["gamma"]
    return matrix_of(
        [
            [a1 * r3, -r3 / 2, G * r1 + r2 / 2],
            [r3 / 2, a1 * r3, -r1 / 2 + G * r2],
            [G * r1 - r2 / 2, r1 / 2 + G * r2, 0.0],
        ],
        r1 * G,
    )


def _derivative(xi: NDArray, v: NDArray, entries: _Entries) -> NDArray:
    """diag(F, F) M diag(F, F)ᵀ with M = entries(coefficients, r, v) in the axis frame."""
    theta, u = unit_axis(xi[..., 3:])
    F = axis_frame(u)
    Ft = np.swapaxes(F, -1, -2)
    r, u, w = mv3(Ft, xi[..., :3]), mv3(Ft, v[..., :3]), mv3(Ft, v[..., 3:])
    M = entries(Coefficients(theta), *(x[..., i] for x in (r, u, w) for i in range(3)))
    return _conjugate(F, M)


def _jr_v(k: Coefficients, *components: NDArray) -> NDArray:
    """∂(J_r(ξ) v)/∂ξ at φ = θ e_z, from r = Fᵀρ and v = [Fᵀv_ρ; Fᵀv_φ]; columns ∂/∂ρ then ∂/∂φ.  [DER 13.5]"""
    r1, r2, r3, v1, v2, v3, v4, v5, v6 = components
    A1, B1, C, D, C1, D1 = k["A1"], k["B1"], k["C"], k["D"], k["C1"], k["D1"]
    A2, B2, Ct, A1t, E1 = k["A2"], k["B2"], k["Ct"], k["A1t"], k["E1"]
    so3 = [
        [C * v6, -D * v6, A1 * v4 + B1 * v5],
        [D * v6, C * v6, -B1 * v4 + A1 * v5],
        [C * v4 - D * v5, D * v4 + C * v5, 0.0],
    ]
    rows = [
        so3[0]
        + [
            E1 * r1 * v4 + D1 * r1 * v5 + Ct * r2 * v5 + C1 * r3 * v6 + C * v3,
            Ct * r1 * v5 + A1t * r2 * v4 + D1 * r2 * v5 - D1 * r3 * v6 - D * v3,
            C1 * r1 * v6 - D1 * r2 * v6 + A2 * r3 * v4 + B2 * r3 * v5 + A1 * v1 + B1 * v2,
        ],
        so3[1]
        + [
            -D1 * r1 * v4 + A1t * r1 * v5 + Ct * r2 * v4 + D1 * r3 * v6 + D * v3,
            Ct * r1 * v4 - D1 * r2 * v4 + E1 * r2 * v5 + C1 * r3 * v6 + C * v3,
            D1 * r1 * v6 + C1 * r2 * v6 - B2 * r3 * v4 + A2 * r3 * v5 - B1 * v1 + A1 * v2,
        ],
        so3[2]
        + [
            -2 * Ct * r1 * v6 + C1 * r3 * v4 - D1 * r3 * v5 + C * v1 - D * v2,
            -2 * Ct * r2 * v6 + D1 * r3 * v4 + C1 * r3 * v5 + D * v1 + C * v2,
            C1 * r1 * v4 - D1 * r1 * v5 + D1 * r2 * v4 + C1 * r2 * v5,
        ],
    ]
    rows += [[0.0, 0.0, 0.0] + row for row in so3]
    return matrix_of(rows, r1 * v1 * C)


def _jr_inverse_v(k: Coefficients, *components: NDArray) -> NDArray:
    """∂(J_r(ξ)⁻¹ v)/∂ξ at φ = θ e_z, from the same components.  [DER 13.5]"""
    r1, r2, r3, v1, v2, v3, v4, v5, v6 = components
    G, a1, a2, Gt, a1t, G1, G2 = (k[n] for n in ("gamma", "alpha1", "alpha2", "gammat", "alpha1t", "G1", "G2"))
    so3 = [
        [G * v6, v6 / 2, a1 * v4 - v5 / 2],
        [-v6 / 2, G * v6, v4 / 2 + a1 * v5],
        [G * v4 + v5 / 2, -v4 / 2 + G * v5, 0.0],
    ]
    rows = [
        so3[0]
        + [
            G1 * r1 * v4 + Gt * r2 * v5 + G2 * r3 * v6 + G * v3,
            Gt * r1 * v5 + a1t * r2 * v4 + v3 / 2,
            G2 * r1 * v6 + a2 * r3 * v4 + a1 * v1 - v2 / 2,
        ],
        so3[1]
        + [
            a1t * r1 * v5 + Gt * r2 * v4 - v3 / 2,
            Gt * r1 * v4 + G1 * r2 * v5 + G2 * r3 * v6 + G * v3,
            G2 * r2 * v6 + a2 * r3 * v5 + v1 / 2 + a1 * v2,
        ],
        so3[2]
        + [
            -2 * Gt * r1 * v6 + G2 * r3 * v4 + G * v1 + v2 / 2,
            -2 * Gt * r2 * v6 + G2 * r3 * v5 - v1 / 2 + G * v2,
            G2 * r1 * v4 + G2 * r2 * v5,
        ],
    ]
    rows += [[0.0, 0.0, 0.0] + row for row in so3]
    return matrix_of(rows, r1 * v1 * G)


SE3 = SE3Group()  # the group SE(3): every function of it is a method of this object


class SE3VectorGroup(SE3Group):
    """SE(3) on poses stored as [t; φ], φ the rotation vector of R (its angle in [0, π]): the same group, tangent and
    Jacobians as :data:`SE3`, its elements 6 numbers as its tangent has, so a state on it has as many numbers as its
    tangent (the solvers' rule, ``steam_ref.manifold``) and batch, iSAM2 and the fixed-lag smoother run on it
    unchanged; its one instance is :data:`SE3V`. Each value goes through :data:`SE3`'s: R = Exp(φ) in, φ = Log(R)
    out (exact up to π), so a composed pose's rotation is rounded once more than SE3's."""

    name = "se3v"
    size = 6

    @staticmethod
    def _full(a: NDArray) -> NDArray:
        return np.concatenate([a[..., :3], SO3.exp(a[..., 3:])], axis=-1)

    @staticmethod
    def _vector(a: NDArray) -> NDArray:
        t, R = _split(a)
        return np.concatenate([t, SO3.log_matrix(R)], axis=-1)

    def exp(self, xi: ArrayLike) -> NDArray:
        """Exp(ξ) = (V(φ) ρ, φ) for an angle up to π; beyond, the rotation vector of Exp(φ).  [DER 13.1]"""
        return self._vector(SE3.exp(xi))

    def log(self, a: ArrayLike) -> NDArray:
        return SE3.log(self._full(self._elements("a", a)))

    def matrix(self, a: ArrayLike) -> NDArray:
        return SE3.matrix(self._full(self._elements("a", a)))

    def from_matrix(self, M: ArrayLike) -> NDArray:
        """[t; Log(R)] of [[R, t], [0, 1]] (the angle in [0, π])."""
        return self._vector(SE3.from_matrix(M))

    def check_stored(self, name: str, a: NDArray) -> None:
        """Nothing: every finite [t; φ] is a pose (``check`` refuses the rest, naming ``name``)."""
        del name, a

    def adjoint(self, a: ArrayLike) -> NDArray:
        return SE3.adjoint(self._full(self._elements("a", a)))

    def _compose(self, a: NDArray, b: NDArray) -> NDArray:
        return self._vector(SE3.compose(self._full(a), self._full(b)))  # the public map: SE3 owns its kernels

    def _inverse(self, a: NDArray) -> NDArray:
        return self._vector(SE3.inverse(self._full(a)))

    def _between(self, a: NDArray, b: NDArray) -> NDArray:
        return self._vector(SE3.between(self._full(a), self._full(b)))


SE3V = SE3VectorGroup()
