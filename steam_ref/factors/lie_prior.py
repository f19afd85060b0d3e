"""Factors on the states of a Lie group (a pose T and its body twist ϖ): the WNOA prior of both models, and priors.  [AB15; DER 11]

Each factor holds its group (``group=``, a :class:`~steam_ref.lie.LieGroup`, always given; ``SE2``'s
states are x = [px, py, θ, vx, vy, ω]); the state kind is ``GroupState(group)`` (``steam_ref.lie.SE2_STATE``
for SE(2): a pose and its body twist, retracted on the right). Every Jacobian here is with respect to the
right tangent δ of each state, x ⊕ δ = (T Exp(δT), ϖ + δϖ), which is what a solver on that kind
linearizes in.

- :class:`LiePriorFactor`: the WNOA prior between consecutive states, e = γ₂ - Φ(Δt) γ₁ in the local
  variables of ``lie.gp`` with the vector-space Q(Δt) [DER 11.10-11.12; YIB Eq. 17, 22]. ``model``
  "local-variable": e = [ξ - Δt ϖ₁; J_r(ξ)⁻¹ ϖ₂ - ϖ₁] (GTSAM 4.3 ``WnoaMotionFactorPose2``, STEAM
  ``const_vel_se2``); "simplified": e = [ξ - Δt ϖ₁; ϖ₂ - ϖ₁] (gpslam, Theseus); ξ = Log(T₁⁻¹ T₂).
- :class:`LieStatePrior`: a Gaussian prior in the tangent at a mean, e = x ⊖ mean.
- :class:`LieAccelPriorFactor`, :class:`LieAccelInterpolatedFactor`: on states with an acceleration
  (``GroupState(group, 2)``: pose, body twist, its rate), the prior of a three-block LTI model (WNOJ, Singer) in the
  exact local variables of ``lie.gp_accel``, and a reading at a time between two states moved onto them
  [TYB19; DER 14].
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..arguments import number, time_step
from ..errors import ShapeError, SteamError
from ..gp.interpolate import interpolation_terms
from ..gp.prior import check_qc, process_noise_sqrt_information, transition
from ..gp.sde import LinearSDE
from ..lie import GroupState, LieGroup, gp_accel
from ..lie.gp import check_model, local_variables
from ..lie.group import check_group
from ..lie.points import point_dim
from ..manifold import VECTOR, Manifold
from ..robust import RobustLoss
from ..variables import Key
from .base import Factor, check_factor, sqrt_information
from .gp import consecutive_gaps

__all__ = ["LiePriorFactor", "lie_prior_factors", "LieStatePrior", "LieAccelPriorFactor", "LieAccelInterpolatedFactor"]


@dataclass(frozen=True, eq=False)
class LiePriorFactor(Factor):
    """The WNOA prior on a group between consecutive states (module docstring).  [DER 11.11-11.13]

    e = γ₂ - Φ(Δt) γ₁, γ₁ = [0; ϖ₁], γ₂ = [ξ; J_r(ξ)⁻¹ ϖ₂] ("local-variable") or [ξ; ϖ₂] ("simplified"),
    ξ = Log(T₁⁻¹T₂); Σ = Q(Δt) of the vector-space WNOA prior with Qc read in the body frame.
    Jacobians exact (∂(J_r(ξ)⁻¹ ϖ₂)/∂ξ included; GTSAM truncates it to a series).
    """

    phi: NDArray  # Φ(Δt), (2d, 2d)
    model: str = field(default="local-variable", kw_only=True)
    group: LieGroup = field(kw_only=True)

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "phi")
    _shared: ClassVar[tuple[str, ...]] = ("model", "group")
    n_states: ClassVar[int | None] = 2

    @property
    def key_kinds(self) -> tuple[Manifold, ...]:
        return (GroupState(self.group), GroupState(self.group))

    def __post_init__(self) -> None:
        super().__post_init__()
        check_model(self.model)
        check_group(self.group)

    @classmethod
    def create(
        cls, key1: Key, key2: Key, dt: float, qc: NDArray, model: str = "local-variable", *, group: LieGroup
    ) -> LiePriorFactor:
        """The prior over a gap dt > 0 with Qc (d, d) on the body twist (SE(2): [vx, vy, ω]).  [YIB Eq. 17, 22]"""
        qc = check_qc(qc)
        d = check_group(group).dim
        if qc.shape != (d, d):
            raise ShapeError(f"qc must be ({d}, {d}) on the body twist for a prior on {group!r}, got shape {qc.shape}")
        return cls.of_checked(key1, key2, dt, qc, check_model(model), group)

    @classmethod
    def of_checked(cls, key1: Key, key2: Key, dt: float, qc: NDArray, model: str, group: LieGroup) -> LiePriorFactor:
        """:meth:`create` with ``qc``, ``model`` and ``group`` checked already (a motion prior's own, checked when it
        was made: ``motion.LieGroupWnoa``); ``dt`` is checked here.  [YIB Eq. 17, 22]"""
        w = process_noise_sqrt_information(dt, qc)  # WᵀW = Q(Δt)⁻¹, memoised per (dt, Qc)  [YIB Eq. 17]
        return cls((key1, key2), w, phi=transition(dt, group.dim), model=model, group=group)

    @property
    def key_dims(self) -> tuple[int, ...]:  # type: ignore[override]
        return (2 * self.group.dim,) * 2

    def batch_signature(self) -> tuple:
        return super().batch_signature() + (self.model, self.group)

    def error(self, x1: NDArray, x2: NDArray) -> NDArray:
        return self._error(x1, local_variables(x1, x2, self.model, group=self.group, jacobians=False))

    def _error(self, x1: NDArray, gamma2: NDArray) -> NDArray:
        gamma1 = np.concatenate([np.zeros(x1.shape[:-1] + (self.group.dim,)), x1[..., self.group.size :]], axis=-1)
        return gamma2 - np.einsum("...ij,...j->...i", self.phi, gamma1)  # [DER 11.11-11.12]

    def jacobians(self, x1: NDArray, x2: NDArray) -> tuple[NDArray, NDArray]:
        return self.error_and_jacobians(x1, x2)[1]

    def error_and_jacobians(self, x1: NDArray, x2: NDArray) -> tuple[NDArray, tuple[NDArray, NDArray]]:
        """The error and its Jacobians from one evaluation of the local variables (γ₂ is the same either way)."""
        gamma2, d1, d2 = local_variables(x1, x2, self.model, group=self.group)
        d = self.group.dim
        d1 = d1.copy()
        d1[..., :, d:] -= self.phi[..., :, d:]  # ∂(Φ γ₁)/∂ϖ₁ = Φ[:, d:] (γ₁ = [0; ϖ₁])
        return self._error(x1, gamma2), (d1, d2)


def lie_prior_factors(
    keys: list[Key], times: NDArray, qc: NDArray, model: str = "local-variable", *, group: LieGroup
) -> list[LiePriorFactor]:
    """The M - 1 prior factors on ``group`` linking consecutive states at strictly increasing times."""
    keys, gaps = consecutive_gaps(keys, times)
    return [LiePriorFactor.create(keys[i], keys[i + 1], gaps[i], qc, model, group=group) for i in range(len(gaps))]


@dataclass(frozen=True, eq=False)
class OneGroupState(Factor):
    """Base of a factor on one state of a group, ``GroupState(group, derivatives)``, its first key, and on
    ``n_landmarks`` points of the group's k-space after it (:class:`LieStatePrior`, ``lie_readings.BodyVelocityFactor``,
    the readings of ``point_readings``): its keys' kinds and sizes, and the group and derivatives a batch shares."""

    group: LieGroup = field(kw_only=True)
    derivatives: int = field(default=1, kw_only=True)  # the state's: 1 (pose, twist) or 2 (and its acceleration)

    _shared: ClassVar[tuple[str, ...]] = ("group", "derivatives")
    n_landmarks: ClassVar[int] = 0  # the landmarks it reads, after the state
    n_states: ClassVar[int | None] = 1  # a state, then its n_landmarks landmarks

    @property
    def key_kinds(self) -> tuple[Manifold, ...]:
        return (GroupState(self.group, self.derivatives),) + (VECTOR,) * self.n_landmarks

    @property
    def key_dims(self) -> tuple[int, ...]:  # type: ignore[override]
        state = (GroupState(self.group, self.derivatives).dim,)  # its check of the derivatives, too
        return state + (point_dim(self.group),) * self.n_landmarks if self.n_landmarks else state

    def batch_signature(self) -> tuple:
        return super().batch_signature() + (self.group, self.derivatives)


@dataclass(frozen=True, eq=False)
class LieStatePrior(OneGroupState):
    """A prior N(mean, Σ) on a group state in the tangent at the mean: e = x ⊖ mean = [Log(M⁻¹T); ϖ - ϖₘ].

    Σ is the covariance of the right tangent at the mean (``lie.state``); ∂e/∂δ = diag(J_r(e_T)⁻¹, I).
    """

    mean: NDArray  # (size + d,), or (size + 2d,) with an acceleration

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "mean")

    @classmethod
    def create(
        cls,
        key: Key,
        mean: NDArray,
        noise: NDArray | float,
        *,
        loss: RobustLoss | None = None,
        group: LieGroup,
        derivatives: int = 1,
    ) -> LieStatePrior:
        """Prior on ``key``; noise is a sigma, sigmas or a covariance of the tangent at ``mean`` ((1 + derivatives) d)."""
        kind = GroupState(check_group(group), derivatives)
        return cls(
            (key,), sqrt_information(noise, kind.dim), mean=kind.check("mean", mean), loss=loss, group=group,
            derivatives=derivatives,
        )  # fmt: skip

    def error(self, x: NDArray) -> NDArray:
        return GroupState(self.group, self.derivatives).local(self.mean, x)  # x ⊖ mean

    def jacobians(self, x: NDArray) -> tuple[NDArray]:
        e = GroupState(self.group, self.derivatives).local(self.mean, x)
        d = self.group.dim
        J = np.zeros(e.shape + (e.shape[-1],))
        J[..., :d, :d] = self.group.right_jacobian_inverse(
            e[..., :d]
        )  # d Log(M⁻¹ T Exp δ) = J_r⁻¹ δ  [DER 11.5, 11.14]
        J[..., d:, d:] = np.eye(e.shape[-1] - d)
        return (J,)


@dataclass(frozen=True, eq=False)
class LieAccelPriorFactor(Factor):
    """The prior of a three-block LTI model (WNOJ, Singer) between consecutive states with an acceleration on a group:
    e = γ₂ - Φ(Δt) γ₁ - v(Δt) in the exact local variables of ``lie.gp_accel``; Σ = Q(Δt) of the model with Qc
    read in the body frame; Jacobians exact (the second derivative of J_r(ξ)⁻¹ ϖ₂ included).  [TYB19; DER 14.1, 14.4]"""

    phi: NDArray  # Φ(Δt), (3d, 3d)
    offset: NDArray  # v(Δt), (3d,)
    group: LieGroup = field(kw_only=True)

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "phi", "offset")
    _shared: ClassVar[tuple[str, ...]] = ("group",)
    n_states: ClassVar[int | None] = 2

    @property
    def key_kinds(self) -> tuple[Manifold, ...]:
        return (GroupState(self.group, 2),) * 2

    @classmethod
    def create(cls, key1: Key, key2: Key, dt: float, sde: LinearSDE, *, group: LieGroup) -> LieAccelPriorFactor:
        """The prior over a gap dt > 0 of ``sde`` (3 blocks of the group's dim: ``LinearSDE.wnoj``, ``.singer``)."""
        dt, d = time_step(dt), check_group(group).dim
        if sde.n != 3 * d:
            raise ShapeError(
                f"the model's states have {sde.n} numbers; a pose, twist and acceleration on {group!r} {3 * d}"
            )
        w = sde.sqrt_information(dt)
        q = sde.process_noise(dt)  # [YIB Eq. 17]
        w = sqrt_information(q, 3 * d, "Q(dt)") if w is None else w
        return cls((key1, key2), w, phi=sde.transition(dt), offset=sde.input_integral(dt), group=group)

    @property
    def key_dims(self) -> tuple[int, ...]:  # type: ignore[override]
        return (3 * self.group.dim,) * 2

    def batch_signature(self) -> tuple:
        return super().batch_signature() + (self.group,)

    def error(self, x1: NDArray, x2: NDArray) -> NDArray:
        return gp_accel.prior_error(x1, x2, self.phi, self.offset, group=self.group)  # [DER 14.1]

    def jacobians(self, x1: NDArray, x2: NDArray) -> tuple[NDArray, NDArray]:
        return gp_accel.prior_jacobians(x1, x2, self.phi, group=self.group)  # [DER 14.4]


@dataclass(frozen=True, eq=False)
class BetweenGroupStates(Factor):
    """Base of a reading at a time τ between two states on a group, moved onto them by the prior's interpolation
    (``lie_readings.LieInterpolatedFactor``, :class:`LieAccelInterpolatedFactor`): e = e_inner(x(τ), …) for x(τ) its
    :meth:`interpolated_state`; the keys, their kinds and sizes: the two states, then the inner reading's others.
    [YIB Eq. 29]"""

    inner: Factor  # a reading of a state GroupState(group, derivatives) (its first key stands for the state at τ)
    group: LieGroup = field(kw_only=True)

    _batched_factors: ClassVar[tuple[str, ...]] = ("inner",)
    _shared: ClassVar[tuple[str, ...]] = ("group",)
    derivatives: ClassVar[int]  # the states': 1 (pose, twist) or 2 (and its acceleration)
    n_states: ClassVar[int | None] = 2  # its two states (the inner reading checks its own keys)
    roles_of_states_only: ClassVar[bool] = True

    @classmethod
    def check_inner(cls, inner: Factor, kind: Manifold) -> None:
        """SteamError unless ``inner`` reads one state of ``kind`` (any reading: lie_readings, point_readings)."""
        if check_factor("inner", inner).key_kinds[0] is not kind:
            raise SteamError(f"inner must read a state of kind {kind!r} (the reading at tau), got {inner!r}")

    @property
    def key_dims(self) -> tuple[int, ...]:  # type: ignore[override]
        return (GroupState(self.group, self.derivatives).dim,) * 2 + tuple(self.inner.key_dims[1:])

    @property
    def key_kinds(self) -> tuple[Manifold, ...]:
        return (GroupState(self.group, self.derivatives),) * 2 + tuple(self.inner.key_kinds[1:])

    def interpolated_state(self, x1: NDArray, x2: NDArray) -> NDArray:
        """x(τ) between the states x₁ and x₂.  [YIB Eq. 18]"""
        raise NotImplementedError

    def error(self, x1: NDArray, x2: NDArray, *rest: NDArray) -> NDArray:
        return self.inner.error(self.interpolated_state(x1, x2), *rest)  # [YIB Eq. 29]


@dataclass(frozen=True, eq=False)
class LieAccelInterpolatedFactor(BetweenGroupStates):
    """A reading at a time τ between two states with an acceleration, moved onto them through ``lie.gp_accel``:
    e = e_inner(x(τ), …), ∂e/∂x₁ = H J₁, ∂e/∂x₂ = H J₂.  [YIB Eq. 29; DER 14.5]"""

    lam: NDArray  # Λ(τ), (3d, 3d)
    psi: NDArray  # Ψ(τ), (3d, 3d)
    offset: NDArray  # c, (3d,) [YIB Eq. 23]

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "lam", "psi", "offset")
    derivatives = 2

    @classmethod
    def create(
        cls, inner: Factor, key1: Key, key2: Key, t1: float, t2: float, tau: float, sde: LinearSDE, *, group: LieGroup
    ) -> LieAccelInterpolatedFactor:
        """Move ``inner`` (on the state at τ, t1 < τ < t2) onto ``key1`` at t1 and ``key2`` at t2."""
        cls.check_inner(inner, GroupState(check_group(group), 2))
        t1, t2, tau = number("t1", t1), number("t2", t2), number("tau", tau)
        lam, psi, offset = interpolation_terms(sde, t1, t2, tau)  # [YIB Eq. 16, 23]
        keys = (key1, key2) + tuple(inner.keys[1:])
        return cls(
            keys, inner.sqrt_information, inner=inner, lam=lam, psi=psi, offset=offset, group=group, loss=inner.loss
        )

    def batch_signature(self) -> tuple:
        return (type(self), self.group, self.inner.batch_signature())

    def interpolated_state(self, x1: NDArray, x2: NDArray) -> NDArray:
        """x(τ) from γ(τ) = Λ γ₁ + Ψ γ₂ + c.  [YIB Eq. 18; DER 14.5]"""
        return gp_accel.interpolate(x1, x2, self.lam, self.psi, self.offset, group=self.group, jacobians=False)  # type: ignore[return-value]

    def jacobians(self, x1: NDArray, x2: NDArray, *rest: NDArray) -> tuple[NDArray, ...]:
        x, J1, J2 = gp_accel.interpolate(x1, x2, self.lam, self.psi, self.offset, group=self.group)
        H, *others = self.inner.jacobians(x, *rest)
        return (H @ J1, H @ J2, *others)  # [YIB Eq. 29]
