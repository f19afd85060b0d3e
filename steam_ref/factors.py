"""Factors of the STEAM factor graph: the GP prior, measurements and priors.  [YIB Eq. 2, 22, 26-33]

A factor f(θ) ∝ exp(-½ ‖e(θ)‖²_Σ) has an error e = h(θ) - y (for a prior, θ - mean) and a noise
covariance Σ. It gives its *unwhitened* error and Jacobians; whitening by W (WᵀW = Σ⁻¹) and the
robust loss are applied by :func:`steam_ref.linear.system.linearize`.

Every ``error``/``jacobians`` is written once, with NumPy broadcasting over leading axes, so the same
code evaluates one factor (arguments of shape (d,)) or a whole batch of factors of one type
(arguments of shape (n, d), built by :meth:`Factor.stack`). This keeps a batch linearization of
twenty thousand factors fast without a second, "vectorized" copy of any measurement model.

The trajectory state is x = [x, y, θ, ẋ, ẏ, θ̇] (d = 3, so 6 numbers); the GP prior factor works for
any d. Landmarks are ℓ = [x, y].
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from .errors import ShapeError, SteamError
from .gp.interpolate import interpolation_matrices
from .gp.prior import process_noise_sqrt_information, transition
from .pose2 import wrap_angle
from .variables import Key
from .robust import RobustLoss

__all__ = [
    "Factor",
    "GPPriorFactor",
    "PriorFactor",
    "OdometryFactor",
    "VelocityFactor",
    "RangeFactor",
    "BearingFactor",
    "BearingRangeFactor",
    "InterpolatedFactor",
    "gp_prior_factors",
    "sqrt_information",
]

STATE_DIM = 6  # [x, y, θ, ẋ, ẏ, θ̇]
LANDMARK_DIM = 2


def sqrt_information(noise: NDArray | float, m: int) -> NDArray:
    """Upper-triangular W with WᵀW = Σ⁻¹, from sigmas (m,) / a scalar sigma, or a covariance (m, m)."""
    noise = np.asarray(noise, dtype=float)
    if noise.ndim == 0:
        noise = np.full(m, float(noise))
    if not np.all(np.isfinite(noise)):
        raise ShapeError(f"noise must be finite, got {noise.tolist()}")
    if noise.shape == (m,):
        if np.any(noise <= 0):
            raise SteamError(f"sigmas must be positive, got {noise.tolist()}")
        return np.diag(1.0 / noise)
    if noise.shape == (m, m):
        try:
            # Σ⁻¹ = Wᵀ W with W upper triangular: W = chol(Σ⁻¹)ᵀ.
            return np.linalg.cholesky(np.linalg.inv(noise)).T
        except np.linalg.LinAlgError:
            raise SteamError(f"noise covariance is not positive definite: {noise.tolist()}") from None
    raise ShapeError(f"noise must be a scalar, sigmas of shape ({m},) or a covariance ({m}, {m}); got {noise.shape}")


def _vector(value: NDArray | float, m: int, what: str) -> NDArray:
    v = np.array(value, dtype=float).reshape(-1)
    if v.shape != (m,) or not np.all(np.isfinite(v)):
        raise ShapeError(f"{what} must be {m} finite numbers, got {np.asarray(value).tolist()}")
    return v


def _jacobian(x: NDArray, m: int) -> NDArray:
    """A zero Jacobian (..., m, dim) for the leading shape of x."""
    return np.zeros(x.shape[:-1] + (m, x.shape[-1]))


@dataclass(frozen=True, eq=False)
class Factor:
    """Base class. Subclasses set ``keys``, ``key_dims``, ``sqrt_information`` and the model.

    ``_batched`` lists the per-factor array fields that :meth:`stack` concatenates.
    """

    keys: tuple[Key, ...]
    sqrt_information: NDArray  # W (m, m), upper triangular, WᵀW = Σ⁻¹
    loss: RobustLoss | None = field(default=None, kw_only=True)  # None: plain least squares

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information",)  # per-factor arrays
    _batched_factors: ClassVar[tuple[str, ...]] = ()  # wrapped factors, stacked by their own class
    key_dims: ClassVar[tuple[int, ...]] = ()

    @property
    def dim(self) -> int:
        """Size m of the error."""
        return self.sqrt_information.shape[-1]

    def error(self, *xs: NDArray) -> NDArray:
        """Unwhitened error e = h(θ) - y: (..., m)."""
        raise NotImplementedError

    def jacobians(self, *xs: NDArray) -> tuple[NDArray, ...]:
        """∂e/∂xₖ for each key: each (..., m, dₖ)."""
        raise NotImplementedError

    def batch_signature(self) -> tuple:
        """Factors with equal signatures can be stacked and evaluated together."""
        return (type(self), self.loss, self.dim)

    @classmethod
    def stack(cls, factors: list[Factor]) -> Factor:
        """One instance whose array fields have a leading axis over ``factors`` (same signature)."""
        batch = object.__new__(cls)
        for name in cls._batched:
            object.__setattr__(batch, name, np.stack([getattr(f, name) for f in factors]))
        for name in cls._batched_factors:
            inner = [getattr(f, name) for f in factors]
            object.__setattr__(batch, name, type(inner[0]).stack(inner))
        object.__setattr__(batch, "keys", None)
        object.__setattr__(batch, "loss", factors[0].loss)
        return batch

    def whitened_error(self, *xs: NDArray) -> NDArray:
        """W e (no robust loss): its squared norm is the Mahalanobis norm of Eq. 6."""
        return np.einsum("...ij,...j->...i", self.sqrt_information, self.error(*xs))


# --- The GP motion prior ------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class GPPriorFactor(Factor):
    """The GP prior between consecutive estimated states.  [YIB Eq. 22-23]

    e = x(tᵢ) - Φ(tᵢ, tᵢ₋₁) x(tᵢ₋₁) - vᵢ,   Σ = Qᵢ.
    Build it with :meth:`wnoa` (the paper's prior) or :meth:`from_matrices` (any LTI SDE).
    """

    phi: NDArray = None  # Φ(tᵢ, tᵢ₋₁), (2d, 2d)
    v: NDArray = None  # vᵢ of Eq. 23, (2d,)

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "phi", "v")

    @classmethod
    def wnoa(cls, key1: Key, key2: Key, dt: float, qc: NDArray) -> GPPriorFactor:
        """The white-noise-on-acceleration prior over a gap dt.  [YIB Eq. 22, 30-31]"""
        w = process_noise_sqrt_information(dt, qc)  # WᵀW = Qᵢ⁻¹, memoised per (dt, Qc)
        d = w.shape[0] // 2
        return cls((key1, key2), w, phi=transition(dt, d), v=np.zeros(2 * d))

    @classmethod
    def from_matrices(cls, key1: Key, key2: Key, phi: NDArray, q: NDArray, v: NDArray | None = None) -> GPPriorFactor:
        """From Φ(tᵢ, tᵢ₋₁), Qᵢ and vᵢ of any LTI SDE (see ``steam_ref.gp.sde``).  [YIB Eq. 22]"""
        phi = np.asarray(phi, dtype=float)
        n = phi.shape[0]
        if phi.shape != (n, n):
            raise ShapeError(f"Φ must be square, got {phi.shape}")
        v = np.zeros(n) if v is None else _vector(v, n, "v_i")
        return cls((key1, key2), sqrt_information(q, n), phi=phi, v=v)

    @property
    def key_dims(self) -> tuple[int, int]:  # type: ignore[override]
        n = self.phi.shape[-1]
        return (n, n)

    def error(self, x1: NDArray, x2: NDArray) -> NDArray:
        return x2 - np.einsum("...ij,...j->...i", self.phi, x1) - self.v  # [YIB Eq. 22]

    def jacobians(self, x1: NDArray, x2: NDArray) -> tuple[NDArray, NDArray]:
        eye = np.broadcast_to(np.eye(self.phi.shape[-1]), self.phi.shape)
        return -self.phi, eye


def gp_prior_factors(keys: list[Key], times: NDArray, qc: NDArray) -> list[GPPriorFactor]:
    """The M - 1 WNOA prior factors linking consecutive states at strictly increasing times."""
    times = np.asarray(times, dtype=float)
    if times.ndim != 1 or len(times) != len(keys):
        raise ShapeError(f"need one time per key: {len(keys)} keys, times of shape {times.shape}")
    gaps = np.diff(times)
    if np.any(~(gaps > 0)):
        i = int(np.flatnonzero(~(gaps > 0))[0])
        raise SteamError(f"times must increase strictly: t[{i}]={times[i]} then t[{i + 1}]={times[i + 1]}")
    return [GPPriorFactor.wnoa(keys[i], keys[i + 1], gaps[i], qc) for i in range(len(gaps))]


# --- Priors -------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class PriorFactor(Factor):
    """A Gaussian prior on one variable, e = θ - mean (a state, or a landmark as in Eq. 4)."""

    mean: NDArray = None  # (d,)

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "mean")

    @classmethod
    def create(cls, key: Key, mean: NDArray, noise: NDArray | float, *, loss: RobustLoss | None = None) -> PriorFactor:
        """Prior N(mean, Σ) on ``key``; noise is sigmas (d,) or a covariance (d, d)."""
        mean = np.array(mean, dtype=float).reshape(-1)
        mean = _vector(mean, mean.shape[0], f"prior mean of {key}")
        return cls((key,), sqrt_information(noise, mean.shape[0]), mean=mean, loss=loss)

    @property
    def key_dims(self) -> tuple[int]:  # type: ignore[override]
        return (self.mean.shape[-1],)

    def error(self, x: NDArray) -> NDArray:
        return x - self.mean

    def jacobians(self, x: NDArray) -> tuple[NDArray]:
        return (np.broadcast_to(np.eye(x.shape[-1]), x.shape[:-1] + (x.shape[-1], x.shape[-1])),)


# --- Measurements of one state ------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class OdometryFactor(Factor):
    """Odometry as in [YIB Eq. 32]: forward speed and yaw rate of the state.

    h(x) = [cos θ ẋ + sin θ ẏ,  θ̇].
    """

    measured: NDArray = None  # (2,) [forward speed, yaw rate]

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "measured")
    key_dims: ClassVar[tuple[int, ...]] = (STATE_DIM,)

    @classmethod
    def create(cls, key: Key, measured: NDArray, noise: NDArray | float, *, loss: RobustLoss | None = None) -> OdometryFactor:
        """Odometry reading ``measured`` = [v, θ̇] on state ``key``."""
        return cls((key,), sqrt_information(noise, 2), measured=_vector(measured, 2, "odometry"), loss=loss)

    def error(self, x: NDArray) -> NDArray:
        th, xd, yd, thd = x[..., 2], x[..., 3], x[..., 4], x[..., 5]
        h = np.stack([np.cos(th) * xd + np.sin(th) * yd, thd], axis=-1)  # [YIB Eq. 32]
        return h - self.measured

    def jacobians(self, x: NDArray) -> tuple[NDArray]:
        th, xd, yd = x[..., 2], x[..., 3], x[..., 4]
        c, s = np.cos(th), np.sin(th)
        J = _jacobian(x, 2)
        J[..., 0, 2] = -s * xd + c * yd
        J[..., 0, 3] = c
        J[..., 0, 4] = s
        J[..., 1, 5] = 1.0
        return (J,)


@dataclass(frozen=True, eq=False)
class VelocityFactor(Factor):
    """Odometry as the paper's scripts use it: the velocity projected into the body frame.

    h(x) = [cos θ ẋ + sin θ ẏ,  -sin θ ẋ + cos θ ẏ,  θ̇]  ≈  [distance/dt, 0, heading change/dt].
    """

    measured: NDArray = None  # (3,) [forward, lateral, yaw rate]

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "measured")
    key_dims: ClassVar[tuple[int, ...]] = (STATE_DIM,)

    @classmethod
    def create(cls, key: Key, measured: NDArray, noise: NDArray | float, *, loss: RobustLoss | None = None) -> VelocityFactor:
        """Projected-velocity reading [forward, lateral, yaw rate] on state ``key``."""
        return cls((key,), sqrt_information(noise, 3), measured=_vector(measured, 3, "projected velocity"), loss=loss)

    def error(self, x: NDArray) -> NDArray:
        th, xd, yd, thd = x[..., 2], x[..., 3], x[..., 4], x[..., 5]
        c, s = np.cos(th), np.sin(th)
        h = np.stack([c * xd + s * yd, -s * xd + c * yd, thd], axis=-1)
        return h - self.measured

    def jacobians(self, x: NDArray) -> tuple[NDArray]:
        th, xd, yd = x[..., 2], x[..., 3], x[..., 4]
        c, s = np.cos(th), np.sin(th)
        J = _jacobian(x, 3)
        J[..., 0, 2], J[..., 0, 3], J[..., 0, 4] = -s * xd + c * yd, c, s
        J[..., 1, 2], J[..., 1, 3], J[..., 1, 4] = -c * xd - s * yd, -s, c
        J[..., 2, 5] = 1.0
        return (J,)


# --- Measurements of a state and a landmark -----------------------------------------------------


def _offset(x: NDArray, l: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """Landmark position relative to the robot: dx, dy, and the distance r (r = 0 is an error)."""
    dx, dy = l[..., 0] - x[..., 0], l[..., 1] - x[..., 1]
    r = np.hypot(dx, dy)
    if np.any(r == 0):
        raise SteamError("robot position coincides with a landmark: range and bearing are not differentiable there")
    return dx, dy, r


def _range_row(x: NDArray, l: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """r = ‖[x y]ᵀ - ℓ‖ and its rows of ∂r/∂x (..., 6), ∂r/∂ℓ (..., 2).  [YIB Eq. 33]"""
    dx, dy, r = _offset(x, l)
    Jx = np.zeros(x.shape)
    Jx[..., 0], Jx[..., 1] = -dx / r, -dy / r
    return r, Jx, np.stack([dx / r, dy / r], axis=-1)


def _bearing_row(x: NDArray, l: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """b = atan2(ℓy - y, ℓx - x) - θ and its rows of ∂b/∂x (..., 6), ∂b/∂ℓ (..., 2)."""
    dx, dy, r = _offset(x, l)
    r2 = r**2
    Jx = np.zeros(x.shape)
    Jx[..., 0], Jx[..., 1], Jx[..., 2] = dy / r2, -dx / r2, -1.0
    return np.arctan2(dy, dx) - x[..., 2], Jx, np.stack([-dy / r2, dx / r2], axis=-1)


@dataclass(frozen=True, eq=False)
class RangeFactor(Factor):
    """Range from the robot's position to a landmark, ‖[x y]ᵀ - ℓ‖₂.  [YIB Eq. 33]"""

    measured: NDArray = None  # (1,) range [m]

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "measured")
    key_dims: ClassVar[tuple[int, ...]] = (STATE_DIM, LANDMARK_DIM)

    @classmethod
    def create(cls, state: Key, landmark: Key, measured: float, sigma: float, *, loss: RobustLoss | None = None) -> RangeFactor:
        """Range reading ``measured`` from state ``state`` to landmark ``landmark``."""
        return cls((state, landmark), sqrt_information(sigma, 1), measured=_vector(measured, 1, "range"), loss=loss)

    def error(self, x: NDArray, l: NDArray) -> NDArray:
        return _range_row(x, l)[0][..., None] - self.measured  # [YIB Eq. 33]

    def jacobians(self, x: NDArray, l: NDArray) -> tuple[NDArray, NDArray]:
        _, Jx, Jl = _range_row(x, l)
        return Jx[..., None, :], Jl[..., None, :]


@dataclass(frozen=True, eq=False)
class BearingFactor(Factor):
    """Bearing of a landmark in the robot frame, atan2(ℓy - y, ℓx - x) - θ, error wrapped to [-π, π)."""

    measured: NDArray = None  # (1,) bearing [rad]

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "measured")
    key_dims: ClassVar[tuple[int, ...]] = (STATE_DIM, LANDMARK_DIM)

    @classmethod
    def create(cls, state: Key, landmark: Key, measured: float, sigma: float, *, loss: RobustLoss | None = None) -> BearingFactor:
        """Bearing reading ``measured`` (rad) from ``state`` to ``landmark``."""
        return cls((state, landmark), sqrt_information(sigma, 1), measured=_vector(measured, 1, "bearing"), loss=loss)

    def error(self, x: NDArray, l: NDArray) -> NDArray:
        return wrap_angle(_bearing_row(x, l)[0] - self.measured[..., 0])[..., None]

    def jacobians(self, x: NDArray, l: NDArray) -> tuple[NDArray, NDArray]:
        _, Jx, Jl = _bearing_row(x, l)
        return Jx[..., None, :], Jl[..., None, :]


@dataclass(frozen=True, eq=False)
class BearingRangeFactor(Factor):
    """Bearing and range of a landmark together: e = [bearing error (wrapped), range error]."""

    measured: NDArray = None  # (2,) [bearing rad, range m]

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "measured")
    key_dims: ClassVar[tuple[int, ...]] = (STATE_DIM, LANDMARK_DIM)

    @classmethod
    def create(cls, state: Key, landmark: Key, bearing: float, range_: float, noise: NDArray, *, loss: RobustLoss | None = None) -> BearingRangeFactor:
        """Bearing-range reading; noise is sigmas (2,) or a covariance (2, 2) for [bearing, range]."""
        return cls((state, landmark), sqrt_information(noise, 2), measured=_vector([bearing, range_], 2, "bearing-range"), loss=loss)

    def error(self, x: NDArray, l: NDArray) -> NDArray:
        b, r = _bearing_row(x, l)[0], _range_row(x, l)[0]
        return np.stack([wrap_angle(b - self.measured[..., 0]), r - self.measured[..., 1]], axis=-1)

    def jacobians(self, x: NDArray, l: NDArray) -> tuple[NDArray, NDArray]:
        (_, bx, bl), (_, rx, rl) = _bearing_row(x, l), _range_row(x, l)
        return np.stack([bx, rx], axis=-2), np.stack([bl, rl], axis=-2)


# --- Measurements at a missing (interpolated) state ---------------------------------------------


@dataclass(frozen=True, eq=False)
class InterpolatedFactor(Factor):
    """A measurement at a time τ with no estimated state, moved onto its two neighbours.  [YIB Eq. 29]

    The wrapped ``inner`` factor's first key stands for the missing state x(τ) (it is not a variable
    of the graph); its other keys (a landmark, say) are kept. With the zero-mean prior,
    x̄(τ) = Λ(τ) x̄(tᵢ₋₁) + Ψ(τ) x̄(tᵢ)  [YIB Eq. 18], so

        e(xᵢ₋₁, xᵢ, …) = e_inner(Λ xᵢ₋₁ + Ψ xᵢ, …),   ∂e/∂xᵢ₋₁ = H Λ,  ∂e/∂xᵢ = H Ψ   [YIB Eq. 19, 29]
    """

    inner: Factor = None  # the measurement at x(τ)
    lam: NDArray = None  # Λ(τ), (6, 6)
    psi: NDArray = None  # Ψ(τ), (6, 6)

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "lam", "psi")
    _batched_factors: ClassVar[tuple[str, ...]] = ("inner",)

    @classmethod
    def create(cls, inner: Factor, key1: Key, key2: Key, t1: float, t2: float, tau: float, qc: NDArray) -> InterpolatedFactor:
        """Move ``inner`` (a factor on x(τ), t1 < τ < t2) onto the states ``key1`` at t1 and ``key2`` at t2."""
        if isinstance(inner, InterpolatedFactor):
            raise SteamError("an interpolated factor cannot wrap another interpolated factor")
        lam, psi = interpolation_matrices(t1, t2, tau, qc)  # [YIB Eq. 16]
        if lam.shape[0] != inner.key_dims[0]:
            raise ShapeError(f"Qc gives states of size {lam.shape[0]}, {type(inner).__name__} expects {inner.key_dims[0]}")
        keys = (key1, key2) + tuple(inner.keys[1:])
        return cls(keys, inner.sqrt_information, inner=inner, lam=lam, psi=psi, loss=inner.loss)

    @property
    def key_dims(self) -> tuple[int, ...]:  # type: ignore[override]
        d = self.inner.key_dims[0]
        return (d, d) + tuple(self.inner.key_dims[1:])

    def batch_signature(self) -> tuple:
        return (type(self), self.inner.batch_signature())

    def interpolated_state(self, x1: NDArray, x2: NDArray) -> NDArray:
        """x̄(τ) = Λ x̄₁ + Ψ x̄₂  [YIB Eq. 18]."""
        return np.einsum("...ij,...j->...i", self.lam, x1) + np.einsum("...ij,...j->...i", self.psi, x2)

    def error(self, x1: NDArray, x2: NDArray, *rest: NDArray) -> NDArray:
        return self.inner.error(self.interpolated_state(x1, x2), *rest)  # [YIB Eq. 29]

    def jacobians(self, x1: NDArray, x2: NDArray, *rest: NDArray) -> tuple[NDArray, ...]:
        H, *others = self.inner.jacobians(self.interpolated_state(x1, x2), *rest)
        return (H @ self.lam, H @ self.psi, *others)  # [YIB Eq. 19, 29]
