"""Aligning an estimated planar trajectory onto the truth: SE(2) and Sim(2), in closed form.  [U91]

The least-squares similarity (or rigid motion) taking points xᵢ onto yᵢ minimises
Σ ‖yᵢ - (s R xᵢ + t)‖² [U91 Eq. 1]. Umeyama's solution [U91 Lemma, Eq. 38-42] is an SVD of the
cross-covariance Σxy = (1/n) Σ (yᵢ - μy)(xᵢ - μx)ᵀ; in the plane that SVD has a closed form. Write the
centred points as complex numbers x̃ᵢ, ỹᵢ: then Σ ỹᵢ conj(x̃ᵢ) = a + i b with a = Σ x̃ᵢ·ỹᵢ (the dot
products) and b = Σ x̃ᵢ × ỹᵢ (the cross products), and

    φ = atan2(b, a)                     the rotation R(φ) (never a reflection: a rotation by construction)
    s = √(a² + b²) / Σ ‖x̃ᵢ‖²           the scale [U91 Eq. 42] (1 for SE(2))
    t = μy - s R(φ) μx                  the translation [U91 Eq. 41]

This is Umeyama's R = U S Vᵀ with S = diag(1, det U det V), written out for 2 × 2 matrices: the
rotation turning the centred estimate onto the centred truth, and tr(DS) = √(a² + b²). On planar data
(z = 0, rotations about z) it is the same transform evo's SE(3) / Sim(3) ``align`` finds when the 2 × 2
cross-covariance has det > 0 (every trajectory that roughly follows the truth), which ``tests/test_evaluate.py``
checks against evo itself. When det < 0 (the estimate nearer a mirror image of the truth than a turned copy) the
two differ: in space, a reflection in the plane times one of z is a rotation (a half turn about an axis in the
plane), and evo's SE(3) Umeyama takes it, turning the estimate upside down; here the rotation stays about z, the
best of those (``tests/test_evaluate_against_evo_on_hard_paths.py``). Where a = b = 0 every rotation fits
equally well (a mirror image of a symmetric set, or points uncorrelated with the truth's) and none is returned.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ..arguments import finite, floats, number, real_array
from ..dead_reckoning import wrap_angle
from ..errors import ShapeError, SteamError

__all__ = ["Alignment", "align_planar", "alignment_defect", "ALIGNMENTS"]

# A spread of points below (ROUNDING · largest coordinate)² per point is rounding, not motion: the centring
# subtraction of equal points leaves a few ulps, and a rotation fitted to them is noise.
ROUNDING = 8 * np.finfo(float).eps

ALIGNMENTS = (None, "se2", "sim2")  # none, rigid (rotation + translation), similarity (+ scale)


@dataclass(frozen=True)
class Alignment:
    """p ↦ s R(φ) p + t and θ ↦ θ + φ: the transform applied to an estimate."""

    angle: float  # φ [rad]
    translation: NDArray  # t (2,) [m]
    scale: float = 1.0  # s

    def __post_init__(self) -> None:
        translation = finite("translation", real_array("translation", self.translation))
        if translation.shape != (2,):
            raise ShapeError(f"translation must be a finite (2,) vector, got shape {translation.shape}")
        if number("scale", self.scale) <= 0:
            raise SteamError(f"scale must be a finite number > 0, got scale={self.scale!r}")
        object.__setattr__(self, "angle", number("angle", self.angle))
        object.__setattr__(self, "translation", translation)
        object.__setattr__(self, "scale", float(self.scale))

    @classmethod
    def identity(cls) -> Alignment:
        return cls(0.0, np.zeros(2), 1.0)

    @property
    def rotation(self) -> NDArray:
        c, s = np.cos(self.angle), np.sin(self.angle)
        return np.array([[c, -s], [s, c]])

    def apply(self, poses: NDArray) -> NDArray:
        """Poses (n, 3) [x, y, θ] moved by this transform; headings wrapped to [-π, π)."""
        poses = finite("poses", floats("poses", poses))
        if poses.ndim != 2 or poses.shape[1] != 3:
            raise ShapeError(f"poses must be an (n, 3) array of poses [x, y, θ], got shape {poses.shape}")
        xy = self.scale * poses[:, :2] @ self.rotation.T + self.translation
        return np.column_stack([xy, wrap_angle(poses[:, 2] + self.angle)])

    def to_dict(self) -> dict:
        return {"angle_rad": float(self.angle), "translation_m": self.translation.tolist(), "scale": float(self.scale)}


def _centred(points: NDArray) -> tuple[NDArray, NDArray, float]:
    """Mean, the centred points as unit directions' weights x̃ᵢ / ‖x̃‖, and ‖x̃‖ = √(Σ ‖x̃ᵢ‖²) = √(n σ²)
    [U91 Eq. 34-36]; ‖x̃‖ is 0 when the spread is rounding only (see ROUNDING). Computed on the points
    divided by the power of two at their largest coordinate: no overflow, no underflow, and no rounding before
    the centring, whose differences of near numbers are then exact (a division by the largest coordinate itself
    rounded each to 1e-16 of it, 5e-10 m at a UTM northing, and turned the rotation of points 0.1 m apart at
    4.5e8 m by 1e-7 rad); in one array, changed in place."""
    top = max(float(points.max()), -float(points.min()))  # max |xᵢ|, with no array of the absolute values
    if top == 0.0:
        return np.zeros(2), np.zeros_like(points), 0.0
    scale = float(np.ldexp(1.0, int(np.frexp(top)[1]) - 1))  # 2ᵉ <= top < 2ᵉ⁺¹: finite up to float64's largest
    p = points / scale
    mu = p.mean(axis=0)
    p -= mu
    norm = float(np.sqrt(np.sum(p * p)))
    if norm <= np.sqrt(len(points)) * ROUNDING:
        return mu * scale, np.zeros_like(points), 0.0
    p /= norm
    return mu * scale, p, norm * scale


def _checked(estimate: object, truth: object) -> tuple[NDArray, NDArray]:
    x, y = floats("estimate", estimate), floats("truth", truth)
    if x.ndim != 2 or x.shape[1] != 2 or x.shape != y.shape or len(x) < 2:
        raise SteamError(
            f"alignment needs two (n, 2) position arrays of one shape, n >= 2; got {x.shape} and {y.shape}"
        )
    finite("estimate", x), finite("truth", y)
    return x, y


def alignment_defect(estimate: object, truth: object) -> str | None:
    """Why no rotation aligns ``estimate`` onto ``truth`` (positions (n, 2)), or None when one does: the
    truth's positions coincide (a robot that does not move), the estimate's do, or the two are
    uncorrelated (Σ ỹᵢ conj(x̃ᵢ) is rounding beside √(Σ‖x̃ᵢ‖² Σ‖ỹᵢ‖²), its Cauchy-Schwarz bound: every rotation fits
    equally well, as for a mirror image of a symmetric set; points at right angles to the truth's are a quarter turn)."""
    return _fit(*_checked(estimate, truth))[0]


def _fit(x: NDArray, y: NDArray) -> tuple[str | None, tuple[NDArray, NDArray, float, float, float, float]]:
    """(why no rotation aligns ``x`` onto ``y``, or None; μx, μy, ‖x̃‖, ‖ỹ‖ and (a, b) / (‖x̃‖ ‖ỹ‖): Σ x̃ᵢ·ỹᵢ and
    Σ x̃ᵢ × ỹᵢ of the centred points, each in [-1, 1] by Cauchy-Schwarz), each point centred once."""
    (mu_x, u, norm_x), (mu_y, v, norm_y) = _centred(x), _centred(y)
    a = float(np.sum(u * v))  # Σ x̃ᵢ·ỹᵢ
    b = float(np.sum(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]))  # Σ x̃ᵢ × ỹᵢ
    defect = None
    if norm_y == 0.0:
        defect = (
            "alignment is undefined: the truth's positions all coincide (it does not move), no rotation is determined"
        )
    elif norm_x == 0.0:
        defect = "alignment is undefined: the estimate's positions all coincide, no rotation is determined"
    elif np.hypot(a, b) <= len(x) * ROUNDING:
        defect = (
            "alignment is undefined: the estimate's positions are uncorrelated with the truth's (every rotation fits "
            "them equally well: a mirror image of a symmetric set, say), no rotation is determined"
        )
    return defect, (mu_x, mu_y, norm_x, norm_y, a, b)


def align_planar(estimate: NDArray, truth: NDArray, *, with_scale: bool = False) -> Alignment:
    """The SE(2) (or, ``with_scale``, Sim(2)) transform minimising Σ ‖truthᵢ - (s R estimateᵢ + t)‖².  [U91]

    ``estimate`` and ``truth`` are positions (n, 2), n ≥ 2, not all at one point (to rounding): where no
    rotation is determined (:func:`alignment_defect` says why) a SteamError says so. A rigid alignment
    (``with_scale=False``) is Umeyama's with s fixed at 1 [U91 Eq. 40-41].
    """
    defect, (mu_x, mu_y, norm_x, norm_y, a, b) = _fit(*_checked(estimate, truth))  # a + i b: Σ ỹᵢ conj(x̃ᵢ) / (‖x̃‖ ‖ỹ‖)
    if defect is not None:
        raise SteamError(defect)
    angle = float(np.arctan2(b, a))  # R = U S Vᵀ in the plane     [U91 Eq. 39-40]
    scale = float(np.hypot(a, b) * (norm_y / norm_x)) if with_scale else 1.0  # s = tr(DS) / σx²  [U91 Eq. 42]
    c, s = np.cos(angle), np.sin(angle)
    translation = mu_y - scale * np.array([[c, -s], [s, c]]) @ mu_x  # [U91 Eq. 41]
    return Alignment(angle, translation, scale)
