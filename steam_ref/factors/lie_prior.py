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
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..arguments import finite, real_array
from ..errors import ShapeError, SteamError
from ..gp.prior import check_qc, process_noise_sqrt_information, transition
from ..lie import GroupState, LieGroup
from ..lie.gp import check_model, local_variables
from ..lie.group import check_group
from ..manifold import Manifold
from ..robust import RobustLoss
from ..variables import Key, key_list
from .base import Factor, sqrt_information

__all__ = ["LiePriorFactor", "lie_prior_factors", "LieStatePrior"]


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
        gamma2 = local_variables(x1, x2, self.model, group=self.group, jacobians=False)
        gamma1 = np.concatenate([np.zeros(x1.shape[:-1] + (self.group.dim,)), x1[..., self.group.size :]], axis=-1)
        return gamma2 - np.einsum("...ij,...j->...i", self.phi, gamma1)  # [DER 11.11-11.12]

    def jacobians(self, x1: NDArray, x2: NDArray) -> tuple[NDArray, NDArray]:
        _, d1, d2 = local_variables(x1, x2, self.model, group=self.group)
        d = self.group.dim
        d1 = d1.copy()
        d1[..., :, d:] -= self.phi[..., :, d:]  # ∂(Φ γ₁)/∂ϖ₁ = Φ[:, d:] (γ₁ = [0; ϖ₁])
        return d1, d2


def lie_prior_factors(
    keys: list[Key], times: NDArray, qc: NDArray, model: str = "local-variable", *, group: LieGroup
) -> list[LiePriorFactor]:
    """The M - 1 prior factors on ``group`` linking consecutive states at strictly increasing times."""
    keys, times = key_list("keys", keys), real_array("times", times)
    if times.ndim != 1 or len(times) != len(keys):
        raise ShapeError(f"need one time per key: {len(keys)} keys, times of shape {times.shape}")
    gaps = np.diff(finite("times", times))
    if np.any(~(gaps > 0)):
        i = int(np.flatnonzero(~(gaps > 0))[0])
        raise SteamError(f"times must increase strictly: t[{i}]={times[i]} then t[{i + 1}]={times[i + 1]}")
    return [LiePriorFactor.create(keys[i], keys[i + 1], gaps[i], qc, model, group=group) for i in range(len(gaps))]


@dataclass(frozen=True, eq=False)
class LieStatePrior(Factor):
    """A prior N(mean, Σ) on a group state in the tangent at the mean: e = x ⊖ mean = [Log(M⁻¹T); ϖ - ϖₘ].

    Σ is the covariance of the right tangent at the mean (``lie.state``); ∂e/∂δ = diag(J_r(e_T)⁻¹, I).
    """

    mean: NDArray  # (size + d,)
    group: LieGroup = field(kw_only=True)

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "mean")
    _shared: ClassVar[tuple[str, ...]] = ("group",)

    @property
    def key_kinds(self) -> tuple[Manifold, ...]:
        return (GroupState(self.group),)

    @classmethod
    def create(
        cls, key: Key, mean: NDArray, noise: NDArray | float, *, loss: RobustLoss | None = None, group: LieGroup
    ) -> LieStatePrior:
        """Prior on ``key``; noise is a sigma, sigmas (2d,) or a covariance (2d, 2d) of the tangent at ``mean``."""
        kind = GroupState(check_group(group))
        return cls((key,), sqrt_information(noise, kind.dim), mean=kind.check("mean", mean), loss=loss, group=group)

    @property
    def key_dims(self) -> tuple[int, ...]:  # type: ignore[override]
        return (2 * self.group.dim,)

    def error(self, x: NDArray) -> NDArray:
        return GroupState(self.group).local(self.mean, x)  # x ⊖ mean

    def jacobians(self, x: NDArray) -> tuple[NDArray]:
        e = GroupState(self.group).local(self.mean, x)
        d = self.group.dim
        J = np.zeros(e.shape + (2 * d,))
        J[..., :d, :d] = self.group.right_jacobian_inverse(
            e[..., :d]
        )  # d Log(M⁻¹ T Exp δ) = J_r⁻¹ δ  [DER 11.5, 11.14]
        J[..., d:, d:] = np.eye(d)
        return (J,)
