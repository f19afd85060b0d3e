"""SO(3), the group of rotations in space: :data:`SO3`, an instance of :class:`~steam_ref.lie.group.LieGroup`.  [DER 13]

A rotation R is stored as its 9 entries, row-major (R.reshape(3, 3) is the matrix; GTSAM's ``Rot3`` in its
matrix mode, Eigen's ``Matrix3``); its tangent is φ ∈ R³ (the rotation vector: R = Exp(φ) turns by θ = ‖φ‖
about u = φ/θ). Log's angle lies in [0, π]. The protocol's conventions (right Jacobians, broadcasting, a value
and its Jacobians from one call) are in ``lie.group``; this module holds what is SO(3)'s own, and what SE(3)
shares with it:

- Exp by Rodrigues, R = cos θ I + sin θ u^ + (1 - cos θ) uuᵀ at any finite angle, and Log exact up to θ = π: the angle from atan2 of the skew
  and the trace parts, the axis from the skew part below π/2 and from the symmetric part R + Rᵀ above, where
  the skew part vanishes (GTSAM's ``Rot3::Logmap`` took both from the skew part and lost up to 2e-4 near π);
- J_r = A I - D φ^ + Ct φφᵀ and its inverse α I + φ^/2 + γt φφᵀ in closed form [FCDS17; SOLA App. B; B24];
- the exact derivatives of J_r(φ)^{±1} v, written in the frame of the rotation axis (:func:`axis_frame`), where
  each entry is one coefficient of ``lie.coefficients`` times a component of v [DER 13.5];
- :func:`rotation_angle`, :func:`unit_axis`, :func:`axis_frame`, :func:`isotropic` and the 3 × 3 products
  SE(3) builds on.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import ShapeError, SteamError
from .coefficients import DEFINITIONS, SERIES_BELOW, Coefficients, coefficients_at
from .group import LieGroup, matrix_of

__all__ = [
    "SO3",
    "SO3Group",
    "rotation_angle",
    "axis_frame",
    "unit_axis",
    "finite_angles",
    "check_rotation",
    "isotropic",
    "mm3",
    "mv3",
    "hat3",
]

ORTHONORMAL_TOL = 1e-9  # check(): the largest |RᵀR - I| entry a stored rotation may carry


def mm3(a: NDArray, b: NDArray) -> NDArray:
    """a b for stacks of 3 × 3 matrices, summed in a fixed order (a batch gives each matrix's own bits)."""
    return (
        a[..., :, 0, None] * b[..., None, 0, :]
        + a[..., :, 1, None] * b[..., None, 1, :]
        + a[..., :, 2, None] * b[..., None, 2, :]
    )


def mv3(a: NDArray, v: NDArray) -> NDArray:
    """a v for stacks of 3 × 3 matrices and 3-vectors."""
    return a[..., :, 0] * v[..., 0, None] + a[..., :, 1] * v[..., 1, None] + a[..., :, 2] * v[..., 2, None]


def hat3(w: NDArray) -> NDArray:
    """w^, the 3 × 3 skew matrix of w: w^ x = w × x."""
    x, y, z = w[..., 0], w[..., 1], w[..., 2]
    return matrix_of([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]], x)


def rotation_angle(phi: NDArray) -> NDArray:
    """θ = ‖φ‖ by hypot (no overflow or underflow in the squares; exact on an axis)."""
    return np.hypot(np.hypot(phi[..., 0], phi[..., 1]), phi[..., 2])


def unit_axis(phi: NDArray) -> tuple[NDArray, NDArray]:
    """θ = ‖φ‖ and the unit axis u = φ/θ (e_z where θ = 0, where every closed form is the same for any axis)."""
    theta = rotation_angle(phi)
    with np.errstate(divide="ignore", invalid="ignore"):
        u = np.where(theta[..., None] > 0, phi / theta[..., None], np.array([0.0, 0.0, 1.0]))
    return theta, u


def finite_angles(name: str, theta: NDArray) -> NDArray:
    """``theta`` itself; ShapeError naming ``name`` if an angle is infinite or NaN (it has no rotation)."""
    if not np.all(np.isfinite(theta)):
        bad = theta.ravel()[int(np.flatnonzero(~np.isfinite(theta))[0])]
        raise ShapeError(f"{name} must turn by a finite angle, got an angle of {bad}")
    return theta


def axis_frame(u: NDArray) -> NDArray:
    """A rotation F (..., 3, 3) whose third column is the unit axis u, so Fᵀφ = θ e_z: Duff et al.'s branch-free
    basis ("Building an orthonormal basis, revisited", JCGT 2017). On a coordinate axis F is a signed
    permutation, so moving into the frame and back is exact there."""
    x, y, z = u[..., 0], u[..., 1], u[..., 2]
    s = np.copysign(1.0, z)
    a = -1.0 / (s + z)
    b = x * y * a
    return matrix_of([[1 + s * x * x * a, b, x], [s * b, s + y * y * a, y], [-s * x, -y, z]], x)


def isotropic(a: NDArray, b: NDArray | float, c: NDArray, u: NDArray) -> NDArray:
    """a I + b u^ + c uuᵀ (..., 3, 3) for a unit axis u: a rotation-invariant matrix function of φ = θu, each
    coefficient already scaled by its power of θ, so nothing overflows at any θ."""
    out = a[..., None, None] * np.eye(3) + np.asarray(b)[..., None, None] * hat3(u)
    return out + c[..., None, None] * u[..., :, None] * u[..., None, :]


class SO3Group(LieGroup):
    """SO(3) on rotations stored as 9 numbers (R row-major) and rotation vectors φ (module docstring); its one
    instance is :data:`SO3`."""

    name = "so3"
    dim = 3
    size = 9
    series_below = SERIES_BELOW
    coefficient_definitions = DEFINITIONS

    def coefficients(self, theta: ArrayLike) -> dict[str, NDArray]:
        """The coefficients of ``lie.coefficients`` at the angles θ."""
        return coefficients_at(theta)

    def exp(self, xi: ArrayLike) -> NDArray:
        """Exp(φ) = cos θ I + sin θ u^ + (1 - cos θ) uuᵀ (Rodrigues), flat; any finite angle.  [DER 13.1]"""
        phi = self._twists("xi", xi)
        return self.rotation(phi).reshape(phi.shape[:-1] + (9,))

    def rotation(self, phi: ArrayLike) -> NDArray:
        """Exp(φ) as a (..., 3, 3) matrix; ShapeError for an infinite or NaN angle."""
        theta, u = unit_axis(self._twists("xi", phi))
        finite_angles("xi", theta)
        return isotropic(np.cos(theta), np.sin(theta), 2 * np.square(np.sin(theta / 2)), u)

    def log(self, a: ArrayLike) -> NDArray:
        """Log(R): the rotation vector, its angle in [0, π], exact up to π.  [DER 13.2]"""
        a = self._elements("a", a)
        return self.log_matrix(a.reshape(a.shape[:-1] + (3, 3)))

    def log_matrix(self, R: ArrayLike) -> NDArray:
        """Log of a (..., 3, 3) rotation matrix. θ = atan2(‖w‖, (tr R - 1)/2) with w = vee(R - Rᵀ)/2 = sin θ u;
        below π/2 the axis is w/‖w‖, φ = w/A(θ); above, (R + Rᵀ)/2 - cos θ I = (1 - cos θ) uuᵀ gives u from its
        largest column, signed to agree with w: no quantity there is a small difference.  [DER 13.2]"""
        R = np.asarray(R, dtype=float)
        if R.shape[-2:] != (3, 3):
            raise ShapeError(f"R must be a rotation matrix (3 × 3 in its last two axes), got shape {R.shape}")
        w = 0.5 * np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
        c = 0.5 * (R[..., 0, 0] + R[..., 1, 1] + R[..., 2, 2] - 1)
        theta = np.arctan2(rotation_angle(w), c)
        M = 0.5 * (R + np.swapaxes(R, -1, -2)) - c[..., None, None] * np.eye(3)  # (1 - c) uuᵀ
        d = np.diagonal(M, axis1=-2, axis2=-1)
        col = np.take_along_axis(M, np.argmax(d, axis=-1)[..., None, None], axis=-1)[..., 0]
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # each branch is used where it is exact
            by_skew = w / Coefficients(theta)["A"][..., None]  # θ ≤ π/2
            u = col / np.sqrt(np.max(d, axis=-1) * (1 - c))[..., None]  # θ > π/2, where 1 - c > 1
            by_axis = theta[..., None] * np.where((np.sum(u * w, axis=-1) < 0)[..., None], -u, u)
        return np.where((c >= 0)[..., None], by_skew, by_axis)

    def hat(self, xi: ArrayLike) -> NDArray:
        """φ^ = [[0, -φz, φy], [φz, 0, -φx], [-φy, φx, 0]]."""
        return hat3(self._twists("xi", xi))

    def vee(self, X: ArrayLike) -> NDArray:
        """[X₂₁, X₀₂, X₁₀]."""
        X = self._algebra("X", X, 3)
        return np.stack([X[..., 2, 1], X[..., 0, 2], X[..., 1, 0]], axis=-1)

    def matrix(self, a: ArrayLike) -> NDArray:
        """R (..., 3, 3)."""
        a = self._elements("a", a)
        return a.reshape(a.shape[:-1] + (3, 3))

    def from_matrix(self, M: ArrayLike) -> NDArray:
        """R's 9 entries, row-major."""
        M = self._algebra("M", M, 3)
        return M.reshape(M.shape[:-2] + (9,))

    def angle(self, xi: ArrayLike) -> NDArray:
        """θ = ‖φ‖, the angle every coefficient's series switch tests."""
        return rotation_angle(self._twists("xi", xi))

    def check_stored(self, name: str, a: NDArray) -> None:
        """A rotation (9 numbers, R row-major) with every entry of RᵀR - I within ±1e-9 and det R > 0; SteamError
        naming ``name`` otherwise."""
        check_rotation(name, a.reshape(3, 3))

    def right_jacobian(self, xi: ArrayLike) -> NDArray:
        """J_r(φ) = A I - D φ^ + Ct φφᵀ = A I - B u^ + Cθ uuᵀ (GTSAM's ``Rot3.ExpmapDerivative``).  [DER 13.3]"""
        theta, u = unit_axis(self._twists("xi", xi))
        k = Coefficients(theta)
        return isotropic(k["A"], -k["B"], k["C"] * theta, u)

    def right_jacobian_inverse(self, xi: ArrayLike) -> NDArray:
        """J_r(φ)⁻¹ = α I + φ^/2 + γt φφᵀ = α I + (θ/2) u^ + γθ uuᵀ in closed form.  [DER 13.3]"""
        theta, u = unit_axis(self._twists("xi", xi))
        k = Coefficients(theta)
        return isotropic(k["alpha"], theta / 2, k["gamma"] * theta, u)

    def adjoint(self, a: ArrayLike) -> NDArray:
        """Ad(R) = R."""
        return self.matrix(a)

    def jr_times_jacobian(self, xi: ArrayLike, v: ArrayLike) -> NDArray:
        """∂(J_r(φ) v)/∂φ, exact, from the axis frame: F M Fᵀ with M's entries C, D, A1, B1 times Fᵀv.  [DER 13.5]"""
        phi, v = self._twists("xi", xi), self._twists("v", v)
        return _in_frame(phi, v, _jr_v)

    def jr_inverse_times_jacobian(self, xi: ArrayLike, v: ArrayLike) -> NDArray:
        """∂(J_r(φ)⁻¹ v)/∂φ, exact, from the axis frame: entries γ, 1/2, α1 times Fᵀv.  [DER 13.5]"""
        phi, v = self._twists("xi", xi), self._twists("v", v)
        return _in_frame(phi, v, _jr_inverse_v)

    def _compose(self, a: NDArray, b: NDArray) -> NDArray:
        shape = np.broadcast_shapes(a.shape, b.shape)
        return mm3(a.reshape(a.shape[:-1] + (3, 3)), b.reshape(b.shape[:-1] + (3, 3))).reshape(shape)

    def _inverse(self, a: NDArray) -> NDArray:
        return np.swapaxes(a.reshape(a.shape[:-1] + (3, 3)), -1, -2).reshape(a.shape)

    def _between(self, a: NDArray, b: NDArray) -> NDArray:
        shape = np.broadcast_shapes(a.shape, b.shape)
        Ra = a.reshape(a.shape[:-1] + (3, 3))
        return mm3(np.swapaxes(Ra, -1, -2), b.reshape(b.shape[:-1] + (3, 3))).reshape(shape)


def check_rotation(name: str, R: NDArray) -> None:
    """SteamError naming ``name`` unless R (3, 3) is a rotation to ORTHONORMAL_TOL."""
    off = float(np.max(np.abs(R.T @ R - np.eye(3))))
    if not off <= ORTHONORMAL_TOL or np.linalg.det(R) <= 0:
        raise SteamError(
            f"{name}: not a rotation matrix (|RᵀR - I| up to {off:.3g}, det {np.linalg.det(R):.6g}); "
            f"SO(3) keeps R orthonormal to {ORTHONORMAL_TOL:g}"
        )


def _in_frame(phi: NDArray, v: NDArray, entries: Callable[..., NDArray]) -> NDArray:
    """F M Fᵀ, M = entries(coefficients, Fᵀv) the matrix in the axis frame."""
    theta, u = unit_axis(phi)
    F = axis_frame(u)
    w = mv3(np.swapaxes(F, -1, -2), v)
    M = entries(Coefficients(theta), w[..., 0], w[..., 1], w[..., 2])
    return mm3(mm3(F, M), np.swapaxes(F, -1, -2))


def _jr_v(k: Coefficients, w1: NDArray, w2: NDArray, w3: NDArray) -> NDArray:
    """∂(J_r v)/∂φ in the axis frame (φ = θ e_z, v = w).  [DER 13.5]"""
    A1, B1, C, D = k["A1"], k["B1"], k["C"], k["D"]
    return matrix_of(
        [
            [C * w3, -D * w3, A1 * w1 + B1 * w2],
            [D * w3, C * w3, -B1 * w1 + A1 * w2],
            [C * w1 - D * w2, D * w1 + C * w2, 0.0],
        ],
        w1 * C,
    )


def _jr_inverse_v(k: Coefficients, w1: NDArray, w2: NDArray, w3: NDArray) -> NDArray:
    """∂(J_r⁻¹ v)/∂φ in the axis frame.  [DER 13.5]"""
    G, a1 = k["gamma"], k["alpha1"]
    return matrix_of(
        [
            [G * w3, w3 / 2, a1 * w1 - w2 / 2],
            [-w3 / 2, G * w3, w1 / 2 + a1 * w2],
            [G * w1 + w2 / 2, -w1 / 2 + G * w2, 0.0],
        ],
        w1 * G,
    )


SO3 = SO3Group()  # the group SO(3): every function of it is a method of this object
