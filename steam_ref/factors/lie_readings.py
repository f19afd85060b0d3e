"""Measurements of Lie-group states (a pose and its body twist), at a state or at a time between two.  [DER 11.14-11.16]

Each factor holds its group (``group=``, always given; ``SE2``'s states are [px, py, θ, vx, vy, ω]).
Every Jacobian is with respect to the right tangent δ of the state (``GroupState(group)``, for SE(2)
``steam_ref.lie.SE2_STATE``). :class:`PoseReading` reads a planar pose: to first order the position
moves by R(θ) δρ and the heading by δφ, so a reading of the pose alone (range, bearing, bearing-range)
has the vector-space model's error, and its Jacobian is the vector-space one times ∂[p; θ]/∂δ =
diag(R(θ), 1) [DER 11.14] (one home for each model). :class:`BodyVelocityFactor` reads the body twist,
and :class:`LieInterpolatedFactor` moves any of them to a time τ between two states through the local
GP of ``lie.gp`` (the group form of [YIB Eq. 29]).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arguments import number
from ..errors import ShapeError, SteamError
from ..gp.interpolate import interpolation_matrices, interpolation_matrices_many
from ..gp.prior import check_qc
from ..lie import GroupState, LieGroup
from ..lie.gp import check_model, interpolate
from ..lie.group import check_group
from ..manifold import Manifold
from ..robust import RobustLoss
from ..variables import Key
from .base import Factor, sqrt_information
from .lie_prior import BetweenGroupStates, OneGroupState
from .measured import measured_vector
from .measurements import BearingFactor, BearingRangeFactor, RangeFactor

__all__ = ["PoseReading", "BodyVelocityFactor", "LieInterpolatedFactor", "check_pose_reading"]

_POSE_READINGS = (RangeFactor, BearingFactor, BearingRangeFactor)


def check_pose_reading(reading: object, size: int) -> Factor:
    """``reading`` itself when it is a range, bearing or bearing-range factor made for a state of ``size`` numbers
    (``state_dim=size``): what a motion prior's ``pose_reading`` and :class:`PoseReading` take; SteamError (ShapeError
    for the size) naming it otherwise."""
    if not isinstance(reading, _POSE_READINGS):
        raise SteamError(f"a pose reading is a range, bearing or bearing-range factor, got {reading!r:.120}")
    if reading.key_dims[0] != size:
        raise ShapeError(
            f"{type(reading).__name__} on {reading.keys[0]!r} was made for a state of {reading.key_dims[0]} numbers, "
            f"the state here has {size}: make it with state_dim={size}"
        )
    return reading


@dataclass(frozen=True, eq=False)
class PoseReading(Factor):
    """A reading of a planar pose [px, py, θ] of a group state and a landmark: range, bearing or bearing-range.

    e = e_inner(x, ℓ) (the vector-space model reads [px, py, θ] alike); ∂e/∂δ = ∂e_inner/∂[p; θ] diag(R(θ), 1).
    The group must store its poses as [px, py, θ] (SE(2)). Build it with :meth:`range`, :meth:`bearing`,
    :meth:`bearing_range`.
    """

    inner: Factor  # RangeFactor, BearingFactor or BearingRangeFactor with state_dim the group state's size
    group: LieGroup = field(kw_only=True)
    derivatives: int = field(default=1, kw_only=True)  # the state's: 1 (pose, twist) or 2 (and its acceleration)

    _batched_factors: ClassVar[tuple[str, ...]] = ("inner",)
    _shared: ClassVar[tuple[str, ...]] = ("group", "derivatives")

    def __post_init__(self) -> None:
        super().__post_init__()
        group = check_group(self.group)
        if (group.size, group.dim) != (3, 3):
            raise SteamError(
                f"PoseReading reads a planar pose [px, py, θ]; {group!r} stores {group.size} numbers with a "
                f"{group.dim}-d tangent"
            )
        check_pose_reading(self.inner, GroupState(group, self.derivatives).size)

    @classmethod
    def _wrap(cls, inner: Factor, group: LieGroup) -> PoseReading:
        return cls(inner.keys, inner.sqrt_information, inner=inner, loss=inner.loss, group=group)

    @classmethod
    def range(
        cls,
        state: Key,
        landmark: Key,
        measured: float,
        sigma: float,
        *,
        loss: RobustLoss | None = None,
        group: LieGroup,
    ) -> PoseReading:
        """Range (m) from the state's position to ``landmark``.  [YIB Eq. 33]"""
        return cls._wrap(RangeFactor.create(state, landmark, measured, sigma, loss=loss), group)

    @classmethod
    def bearing(
        cls,
        state: Key,
        landmark: Key,
        measured: float,
        sigma: float,
        *,
        loss: RobustLoss | None = None,
        group: LieGroup,
    ) -> PoseReading:
        """Bearing (rad) of ``landmark`` in the robot frame, error wrapped."""
        return cls._wrap(BearingFactor.create(state, landmark, measured, sigma, loss=loss), group)

    @classmethod
    def bearing_range(
        cls,
        state: Key,
        landmark: Key,
        bearing: float,
        range_: float,
        noise: NDArray,
        *,
        loss: RobustLoss | None = None,
        group: LieGroup,
    ) -> PoseReading:
        """Bearing and range together; noise: sigmas (2,) or a covariance (2, 2) of [bearing, range]."""
        return cls._wrap(BearingRangeFactor.create(state, landmark, bearing, range_, noise, loss=loss), group)

    @property
    def key_dims(self) -> tuple[int, ...]:  # type: ignore[override]
        return self.inner.key_dims

    @property
    def key_kinds(self) -> tuple[Manifold, ...]:
        return (GroupState(self.group, self.derivatives), *self.inner.key_kinds[1:])  # a state, then the landmark

    def batch_signature(self) -> tuple:
        return (type(self), self.group, self.derivatives, self.inner.batch_signature())

    def error(self, x: NDArray, l: NDArray) -> NDArray:
        return self.inner.error(x, l)

    def jacobians(self, x: NDArray, l: NDArray) -> tuple[NDArray, NDArray]:
        Hx, Hl = self.inner.jacobians(x, l)
        c, s = np.cos(x[..., 2])[..., None], np.sin(x[..., 2])[..., None]
        J = np.zeros(Hx.shape)
        J[..., 0] = Hx[..., 0] * c + Hx[..., 1] * s  # ∂e/∂p · R(θ)  [DER 11.14]
        J[..., 1] = -Hx[..., 0] * s + Hx[..., 1] * c
        J[..., 2] = Hx[..., 2]
        return J, Hl


@dataclass(frozen=True, eq=False)
class BodyVelocityFactor(OneGroupState):
    """A reading of a group state's body twist (SE(2): [forward, lateral, yaw rate]): e = ϖ - measured, ∂e/∂δ = [0 I]."""

    measured: NDArray  # (d,)

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "measured")

    @classmethod
    def create(
        cls,
        key: Key,
        measured: NDArray,
        noise: NDArray | float,
        *,
        loss: RobustLoss | None = None,
        group: LieGroup,
        derivatives: int = 1,
    ) -> BodyVelocityFactor:
        """Reading ``measured`` = ϖ (SE(2): [vx, vy, ω]) in the body frame; noise a sigma, sigmas (d,) or a covariance;
        ``derivatives`` the state's (``GroupState(group, derivatives)``)."""
        d = check_group(group).dim
        measured = measured_vector(measured, d, "measured")
        GroupState(group, derivatives)  # refuses a number of derivatives no state holds
        return cls(
            (key,), sqrt_information(noise, d), measured=measured, loss=loss, group=group, derivatives=derivatives
        )

    def error(self, x: NDArray) -> NDArray:
        n, d = self.group.size, self.group.dim
        return x[..., n : n + d] - self.measured

    def jacobians(self, x: NDArray) -> tuple[NDArray]:
        d = self.group.dim
        J = np.zeros(x.shape[:-1] + (d, (1 + self.derivatives) * d))
        J[..., :, d : 2 * d] = np.eye(d)
        return (J,)


@dataclass(frozen=True, eq=False)
class LieInterpolatedFactor(BetweenGroupStates):
    """A reading at a time τ with no state, moved onto the group states at t₁ < τ < t₂.  [YIB Eq. 29; DER 11.16]

    e(x₁, x₂, …) = e_inner(x(τ), …) with x(τ) the local GP's mean (``lie.gp.interpolate``), and
    ∂e/∂x₁ = H J₁, ∂e/∂x₂ = H J₂ for H the inner factor's Jacobian in the tangent at x(τ).
    """

    lam: NDArray  # Λ(τ), (2d, 2d)
    psi: NDArray  # Ψ(τ), (2d, 2d)
    model: str = field(default="local-variable", kw_only=True)

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "lam", "psi")
    _shared: ClassVar[tuple[str, ...]] = ("model", "group")
    derivatives = 1

    @classmethod
    def create(
        cls,
        inner: Factor,
        key1: Key,
        key2: Key,
        t1: float,
        t2: float,
        tau: float,
        qc: NDArray,
        model: str = "local-variable",
        *,
        group: LieGroup,
    ) -> LieInterpolatedFactor:
        """Move ``inner`` (on the state at τ on ``group``, t1 < τ < t2) onto ``key1`` at t1 and ``key2`` at t2."""
        cls.check_inner(inner, GroupState(check_group(group)))
        t1, t2, tau = number("t1", t1), number("t2", t2), number("tau", tau)
        d, qc = group.dim, check_qc(qc)
        if qc.shape != (d, d):
            raise SteamError(f"qc must be ({d}, {d}) on the body twist of a state on {group!r}, got {np.shape(qc)}")
        return cls.of_checked(inner, key1, key2, t1, t2, tau, qc, check_model(model), group)

    @classmethod
    def of_checked(
        cls,
        inner: Factor,
        key1: Key,
        key2: Key,
        t1: float,
        t2: float,
        tau: float,
        qc: NDArray,
        model: str,
        group: LieGroup,
    ) -> LieInterpolatedFactor:
        """:meth:`create` with ``inner`` (a reading on ``group``'s state), ``qc``, ``model`` and ``group`` checked
        already (a motion prior's own, checked when it was made: ``motion.LieGroupWnoa``); t1 < tau < t2 is checked
        here (``interpolation_matrices``).  [YIB Eq. 16, 29]"""
        lam, psi = interpolation_matrices(t1, t2, tau, qc)  # [YIB Eq. 16]
        return cls._of_matrices(inner, key1, key2, lam, psi, model, group)

    @classmethod
    def many_of_checked(
        cls,
        inners: Sequence[Factor],
        key1: Key,
        key2: Key,
        t1: float,
        t2: float,
        taus: ArrayLike,
        qc: NDArray,
        model: str,
        group: LieGroup,
    ) -> list[LieInterpolatedFactor]:
        """:meth:`of_checked` of each of ``inners`` at its time in ``taus`` (n,), all between ``key1`` at t1 and
        ``key2`` at t2, with every Λ(τ), Ψ(τ) formed in one call.  [YIB Eq. 16, 29]"""
        lam, psi = interpolation_matrices_many(t1, t2, taus, qc)  # [YIB Eq. 16]
        return [
            cls._of_matrices(inner, key1, key2, a, b, model, group)
            for inner, a, b in zip(inners, lam, psi, strict=True)
        ]

    @classmethod
    def _of_matrices(
        cls, inner: Factor, key1: Key, key2: Key, lam: NDArray, psi: NDArray, model: str, group: LieGroup
    ) -> LieInterpolatedFactor:
        keys = (key1, key2) + tuple(inner.keys[1:])
        return cls(
            keys, inner.sqrt_information, inner=inner, lam=lam, psi=psi, model=model, group=group, loss=inner.loss
        )

    def batch_signature(self) -> tuple:
        return (type(self), self.model, self.group, self.inner.batch_signature())

    def interpolated_state(self, x1: NDArray, x2: NDArray) -> NDArray:
        """x(τ) = (T₁ Exp ξ(τ), ϖ(τ)) from γ(τ) = Λ γ₁ + Ψ γ₂.  [YIB Eq. 18; DER 11.15]"""
        return interpolate(x1, x2, self.lam, self.psi, self.model, group=self.group, jacobians=False)

    def jacobians(self, x1: NDArray, x2: NDArray, *rest: NDArray) -> tuple[NDArray, ...]:
        return self.error_and_jacobians(x1, x2, *rest)[1]

    def error_and_jacobians(self, x1: NDArray, x2: NDArray, *rest: NDArray) -> tuple[NDArray, tuple[NDArray, ...]]:
        """The error and its Jacobians from one interpolation (x(τ) is the same either way)."""
        x, J1, J2 = interpolate(x1, x2, self.lam, self.psi, self.model, group=self.group)
        H, *others = self.inner.jacobians(x, *rest)
        return self.inner.error(x, *rest), (H @ J1, H @ J2, *others)  # [YIB Eq. 29]
