"""Readings of a rigid body's state on any group of rigid motions (SE(3), SE(2)): a position fix, the range to a
landmark, a landmark seen in the body frame, a gyro, a pose prior.  [DER 15]

Each is written once against the group protocol through :mod:`steam_ref.lie.points` (a pose's position, a world
point in its body frame, the rotational part of a twist, each with its Jacobian in the right tangent), so SE(3)'s
readings are SE(2)'s with k = 3: no group is named. A landmark is a point of the group's k-space (a
:data:`~steam_ref.manifold.VECTOR` variable of k numbers). Every Jacobian is with respect to the right tangent of
the state (``GroupState(group, derivatives)``: pose, body twist, and with ``derivatives=2`` its rate), so each
reading is read at a time between two states by the one interpolation of its prior
(``MotionPrior.interpolated_factor``: :class:`~steam_ref.factors.lie_readings.LieInterpolatedFactor`,
:class:`~steam_ref.factors.lie_prior.LieAccelInterpolatedFactor`), which takes any reading of such a state.

- :class:`PositionReading`: a position fix (GPS in a local frame), e = t - z, ∂e/∂δ = [R, 0].  [DER 15.1]
- :class:`RangeReading`: e = ‖ℓ - t‖ - r = ‖q‖ - r with q = Rᵀ(ℓ - t); ∂e/∂x = q̂ᵀ ∂q/∂δ, ∂e/∂ℓ = q̂ᵀ Rᵀ.
- :class:`PointReading`: the landmark in the body frame, e = Rᵀ(ℓ - t) - z.  [DER 15.2]
- :class:`AngularVelocityReading`: a gyro, e = ω - z for ω the twist's rotational part.  [DER 15.3]
- :class:`PosePrior`: a pose alone, e = Log(M⁻¹ T), ∂e/∂δ = [J_r(e)⁻¹, 0].  [DER 11.5]
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..errors import SteamError
from ..lie import GroupState, LieGroup
from ..lie.group import check_group
from ..lie.points import point_dim, position, rotation_part, to_body
from ..robust import RobustLoss
from ..variables import Key
from .base import sqrt_information
from .lie_prior import OneGroupState
from .measured import measured_vector, range_reading

__all__ = ["PositionReading", "RangeReading", "PointReading", "AngularVelocityReading", "PosePrior"]


@dataclass(frozen=True, eq=False)
class _StateReading(OneGroupState):
    """A reading of one group state (its first key) and of landmarks of the group's k-space (any further keys,
    ``n_landmarks``)."""

    def _padded(self, H: NDArray, at: slice) -> NDArray:
        """H (..., m, w) placed in the columns ``at`` of a state Jacobian (..., m, state dim), zero elsewhere."""
        J = np.zeros(H.shape[:-1] + (GroupState(self.group, self.derivatives).dim,))
        J[..., at] = H
        return J

    @staticmethod
    def _kind(group: LieGroup, derivatives: int) -> tuple[LieGroup, int]:
        """The group checked (it moves points: ``lie.points.point_dim``) and the state's kind made (checks derivatives)."""
        point_dim(check_group(group))
        GroupState(group, derivatives)
        return group, point_dim(group)


@dataclass(frozen=True, eq=False)
class PositionReading(_StateReading):
    """A position fix: the state's position t (k,) in the world frame (GPS in a local frame).  [DER 15.1]

    e = t - z; ∂e/∂δ = [R, 0] on the pose block (zero on the twist).
    """

    measured: NDArray  # (k,)

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "measured")

    @classmethod
    def create(
        cls, key: Key, measured: NDArray, noise: NDArray | float, *, loss: RobustLoss | None = None,
        group: LieGroup, derivatives: int = 1,
    ) -> PositionReading:  # fmt: skip
        """Position ``measured`` (k,) of state ``key``; noise a sigma, sigmas (k,) or a covariance (k, k)."""
        group, k = cls._kind(group, derivatives)
        z = measured_vector(measured, k, "measured")
        return cls((key,), sqrt_information(noise, k), measured=z, loss=loss, group=group, derivatives=derivatives)

    def error(self, x: NDArray) -> NDArray:
        return position(self.group, x[..., : self.group.size])[0] - self.measured

    def jacobians(self, x: NDArray) -> tuple[NDArray]:
        return (self._padded(position(self.group, x[..., : self.group.size])[1], slice(0, self.group.dim)),)


@dataclass(frozen=True, eq=False)
class RangeReading(_StateReading):
    """The range from the state's position to a landmark ℓ (k,): e = ‖ℓ - t‖ - r.  [YIB Eq. 33; DER 15.2]"""

    measured: NDArray  # (1,) range [m]

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "measured")
    n_landmarks: ClassVar[int] = 1

    @classmethod
    def create(
        cls, state: Key, landmark: Key, measured: float, sigma: float, *, loss: RobustLoss | None = None,
        group: LieGroup, derivatives: int = 1,
    ) -> RangeReading:  # fmt: skip
        """Range ``measured`` (m, not negative) from state ``state`` to landmark ``landmark``; ``sigma`` its sigma."""
        group, _ = cls._kind(group, derivatives)
        r = range_reading("measured", measured)
        W = sqrt_information(sigma, 1, "sigma")
        return cls((state, landmark), W, measured=r, loss=loss, group=group, derivatives=derivatives)

    def error(self, x: NDArray, l: NDArray) -> NDArray:
        q = to_body(self.group, x[..., : self.group.size], l)[0]
        return np.linalg.norm(q, axis=-1)[..., None] - self.measured  # ‖q‖ = ‖ℓ - t‖

    def jacobians(self, x: NDArray, l: NDArray) -> tuple[NDArray, NDArray]:
        q, dq, dl = to_body(self.group, x[..., : self.group.size], l)
        r = np.linalg.norm(q, axis=-1, keepdims=True)
        if np.any(r == 0):
            raise SteamError("RangeReading: the landmark is at the state's position, where a range has no gradient")
        u = (q / r)[..., None, :]  # q̂ᵀ (..., 1, k)
        return self._padded(u @ dq, slice(0, self.group.dim)), u @ dl


@dataclass(frozen=True, eq=False)
class PointReading(_StateReading):
    """A landmark ℓ (k,) seen in the body frame: e = Rᵀ(ℓ - t) - z (a stereo camera's or a lidar's point).  [DER 15.2]"""

    measured: NDArray  # (k,)

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "measured")
    n_landmarks: ClassVar[int] = 1

    @classmethod
    def create(
        cls, state: Key, landmark: Key, measured: NDArray, noise: NDArray | float, *,
        loss: RobustLoss | None = None, group: LieGroup, derivatives: int = 1,
    ) -> PointReading:  # fmt: skip
        """``landmark`` at ``measured`` (k,) in the body frame of ``state``; noise a sigma, sigmas or a covariance."""
        group, k = cls._kind(group, derivatives)
        z = measured_vector(measured, k, "measured")
        return cls(
            (state, landmark), sqrt_information(noise, k), measured=z, loss=loss, group=group, derivatives=derivatives
        )

    def error(self, x: NDArray, l: NDArray) -> NDArray:
        return to_body(self.group, x[..., : self.group.size], l)[0] - self.measured

    def jacobians(self, x: NDArray, l: NDArray) -> tuple[NDArray, NDArray]:
        _, dq, dl = to_body(self.group, x[..., : self.group.size], l)
        return self._padded(dq, slice(0, self.group.dim)), dl


@dataclass(frozen=True, eq=False)
class AngularVelocityReading(_StateReading):
    """A gyro: the body angular velocity, the rotational part ω of the state's twist (SE(3): 3 numbers, SE(2): the
    yaw rate). e = ω - z; ∂e/∂δ = [0, I] on the twist block.  [DER 15.3]"""

    measured: NDArray  # (dim - k,)

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "measured")

    @classmethod
    def create(
        cls, key: Key, measured: NDArray, noise: NDArray | float, *, loss: RobustLoss | None = None,
        group: LieGroup, derivatives: int = 1,
    ) -> AngularVelocityReading:  # fmt: skip
        """Angular velocity ``measured`` (rad/s, in the body frame) of state ``key``; noise a sigma, sigmas or a
        covariance."""
        group, k = cls._kind(group, derivatives)
        m = group.dim - k
        z = measured_vector(measured, m, "measured")
        return cls((key,), sqrt_information(noise, m), measured=z, loss=loss, group=group, derivatives=derivatives)

    def _at(self) -> slice:
        part = rotation_part(self.group)
        return slice(self.group.dim + part.start, self.group.dim + part.stop)  # in the state's tangent

    def error(self, x: NDArray) -> NDArray:
        part = rotation_part(self.group)
        return x[..., self.group.size + part.start : self.group.size + part.stop] - self.measured

    def jacobians(self, x: NDArray) -> tuple[NDArray]:
        m = len(self.measured.T)
        eye = np.broadcast_to(np.eye(m), x.shape[:-1] + (m, m))
        return (self._padded(eye, self._at()),)


@dataclass(frozen=True, eq=False)
class PosePrior(_StateReading):
    """A prior on the pose alone, in the tangent at its mean M: e = Log(M⁻¹ T), ∂e/∂δ = [J_r(e)⁻¹, 0].  [DER 11.5]"""

    mean: NDArray  # (size,), an element of the group

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "mean")

    @classmethod
    def create(
        cls, key: Key, mean: NDArray, noise: NDArray | float, *, loss: RobustLoss | None = None,
        group: LieGroup, derivatives: int = 1,
    ) -> PosePrior:  # fmt: skip
        """Prior on the pose of ``key`` at the element ``mean``; noise a sigma, sigmas (dim,) or a covariance of the
        pose's right tangent at the mean."""
        GroupState(check_group(group), derivatives)  # any group: a pose prior needs no point
        mean = group.check("mean", mean)
        W = sqrt_information(noise, group.dim)
        return cls((key,), W, mean=mean, loss=loss, group=group, derivatives=derivatives)

    def error(self, x: NDArray) -> NDArray:
        return self.group.log(self.group.between(self.mean, x[..., : self.group.size]))

    def jacobians(self, x: NDArray) -> tuple[NDArray]:
        e = self.error(x)
        return (self._padded(self.group.right_jacobian_inverse(e), slice(0, self.group.dim)),)
