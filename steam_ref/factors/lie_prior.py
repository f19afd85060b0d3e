"""Factors on SE(2) states x = [px, py, θ, vx, vy, ω]: the WNOA prior of both models, and priors.  [AB15; DER 11]

The state kind is ``steam_ref.lie.SE2_STATE`` (a pose and its body twist, retracted on the right):
every Jacobian here is with respect to the right tangent δ of each state, x ⊕ δ = (T Exp(δ[:3]),
ϖ + δ[3:]), which is what a solver on that kind linearizes in.

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

from ..arguments import finite, real_array, time_step
from ..errors import ShapeError, SteamError
from ..gp.prior import check_qc, process_noise_sqrt_information, transition
from ..lie import SE2_STATE, STATE_SIZE, se2
from ..lie.gp import check_model, local_variables
from ..manifold import Manifold
from ..robust import RobustLoss
from ..variables import Key, key_list
from .base import Factor, sqrt_information

__all__ = ["LiePriorFactor", "lie_prior_factors", "LieStatePrior", "check_se2_state"]


def check_se2_state(name: str, x: object) -> NDArray:
    """An SE(2) state [px, py, θ, vx, vy, ω] as a finite (6,) array, θ in (-π, π]; SteamError otherwise."""
    x = real_array(name, x)
    if x.shape != (STATE_SIZE,):
        raise ShapeError(f"{name} must be an SE(2) state [px, py, θ, vx, vy, ω] (6 numbers), got shape {x.shape}")
    finite(name, x)
    if not -np.pi < x[2] <= np.pi:
        raise SteamError(f"{name}: the heading of an SE(2) state must lie in (-π, π], got θ={float(x[2])!r}")
    return x


@dataclass(frozen=True, eq=False)
class LiePriorFactor(Factor):
    """The WNOA prior on SE(2) between consecutive states (module docstring).  [DER 11.11-11.13]

    e = γ₂ - Φ(Δt) γ₁, γ₁ = [0; ϖ₁], γ₂ = [ξ; J_r(ξ)⁻¹ ϖ₂] ("local-variable") or [ξ; ϖ₂] ("simplified"),
    ξ = Log(T₁⁻¹T₂); Σ = Q(Δt) of the vector-space WNOA prior with Qc read in the body frame.
    Jacobians exact (∂(J_r(ξ)⁻¹ ϖ₂)/∂ξ included; GTSAM truncates it to a series).
    """

    phi: NDArray  # Φ(Δt), (6, 6)
    model: str = field(default="local-variable", kw_only=True)

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "phi")
    _shared: ClassVar[tuple[str, ...]] = ("model",)
    key_dims: ClassVar[tuple[int, ...]] = (STATE_SIZE, STATE_SIZE)

    @property
    def key_kinds(self) -> tuple[Manifold, ...]:
        return (SE2_STATE, SE2_STATE)

    def __post_init__(self) -> None:
        super().__post_init__()
        check_model(self.model)

    @classmethod
    def create(cls, key1: Key, key2: Key, dt: float, qc: NDArray, model: str = "local-variable") -> LiePriorFactor:
        """The prior over a gap dt > 0 with Qc (3, 3) on the body twist [vx, vy, ω].  [YIB Eq. 17, 22]"""
        dt = time_step(dt)
        qc = check_qc(qc)
        if qc.shape != (3, 3):
            raise ShapeError(f"qc must be (3, 3) on [vx, vy, ω] for an SE(2) prior, got shape {qc.shape}")
        w = process_noise_sqrt_information(dt, qc)  # WᵀW = Q(Δt)⁻¹  [YIB Eq. 17]
        return cls((key1, key2), w, phi=transition(dt, 3), model=check_model(model))

    def batch_signature(self) -> tuple:
        return super().batch_signature() + (self.model,)

    def error(self, x1: NDArray, x2: NDArray) -> NDArray:
        gamma2 = local_variables(x1, x2, self.model)[0]
        gamma1 = np.concatenate([np.zeros(x1.shape[:-1] + (3,)), x1[..., 3:]], axis=-1)
        return gamma2 - np.einsum("...ij,...j->...i", self.phi, gamma1)  # [DER 11.11-11.12]

    def jacobians(self, x1: NDArray, x2: NDArray) -> tuple[NDArray, NDArray]:
        _, d1, d2 = local_variables(x1, x2, self.model)
        d1 = d1.copy()
        d1[..., :, 3:] -= self.phi[..., :, 3:]  # ∂(Φ γ₁)/∂ϖ₁ = Φ[:, 3:] (γ₁ = [0; ϖ₁])
        return d1, d2


def lie_prior_factors(
    keys: list[Key], times: NDArray, qc: NDArray, model: str = "local-variable"
) -> list[LiePriorFactor]:
    """The M - 1 SE(2) prior factors linking consecutive states at strictly increasing times."""
    keys, times = key_list("keys", keys), real_array("times", times)
    if times.ndim != 1 or len(times) != len(keys):
        raise ShapeError(f"need one time per key: {len(keys)} keys, times of shape {times.shape}")
    gaps = np.diff(finite("times", times))
    if np.any(~(gaps > 0)):
        i = int(np.flatnonzero(~(gaps > 0))[0])
        raise SteamError(f"times must increase strictly: t[{i}]={times[i]} then t[{i + 1}]={times[i + 1]}")
    return [LiePriorFactor.create(keys[i], keys[i + 1], gaps[i], qc, model) for i in range(len(gaps))]


@dataclass(frozen=True, eq=False)
class LieStatePrior(Factor):
    """A prior N(mean, Σ) on an SE(2) state in the tangent at the mean: e = x ⊖ mean = [Log(M⁻¹T); ϖ - ϖₘ].

    Σ is the covariance of the right tangent at the mean (``lie.state``); ∂e/∂δ = diag(J_r(e_T)⁻¹, I).
    """

    mean: NDArray  # (6,)

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "mean")
    key_dims: ClassVar[tuple[int, ...]] = (STATE_SIZE,)

    @property
    def key_kinds(self) -> tuple[Manifold, ...]:
        return (SE2_STATE,)

    @classmethod
    def create(
        cls, key: Key, mean: NDArray, noise: NDArray | float, *, loss: RobustLoss | None = None
    ) -> LieStatePrior:
        """Prior on ``key``; noise is a sigma, sigmas (6,) or a covariance (6, 6) of the tangent at ``mean``."""
        return cls((key,), sqrt_information(noise, STATE_SIZE), mean=check_se2_state("mean", mean), loss=loss)

    def error(self, x: NDArray) -> NDArray:
        return SE2_STATE.local(self.mean, x)  # x ⊖ mean

    def jacobians(self, x: NDArray) -> tuple[NDArray]:
        e = SE2_STATE.local(self.mean, x)
        J = np.zeros(x.shape + (STATE_SIZE,))
        J[..., :3, :3] = se2.right_jacobian_inverse(e[..., :3])  # d Log(M⁻¹ T Exp δ) = J_r⁻¹ δ  [DER 11.5, 11.14]
        J[..., 3:, 3:] = np.eye(3)
        return (J,)
