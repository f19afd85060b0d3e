"""Priors and measurement factors: odometry, projected velocity, range, bearing.  [YIB Eq. 4, 32-33]

Every motion prior lays a state out as [p; ṗ; ...], p = [x, y, θ] (docs/api.md, "Conventions"): WNOA's
[x, y, θ, ẋ, ẏ, θ̇], WNOJ's and Singer's add [ẍ, ÿ, θ̈]. A measurement reads the pose from x[0:3] and the
velocity from x[3:6], its Jacobian zero on the rest; ``state_dim`` (6 by default) says how long the state is.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import ClassVar, TypeVar

import numpy as np
from numpy.typing import NDArray

from ..arguments import is_integer, real_array
from ..dead_reckoning import wrap_angle
from ..errors import DegenerateMeasurementWarning, ShapeError, SteamError
from ..robust import RobustLoss
from ..variables import Key
from .base import LANDMARK_DIM, STATE_DIM, Factor, sqrt_information, zero_jacobian
from .measured import bearing_reading, check_resolved, measured_vector, range_reading

__all__ = [
    "StateMeasurement",
    "PriorFactor",
    "OdometryFactor",
    "VelocityFactor",
    "RangeFactor",
    "BearingFactor",
    "BearingRangeFactor",
]


# --- Priors -------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class PriorFactor(Factor):
    """A Gaussian prior on one variable: a state's start, or a landmark's surveyed position.  [YIB Eq. 4-5]

        ``PriorFactor.create(key, mean, noise, *, loss=None)``

    ``key``: ``X(i)`` or ``L(j)``; ``mean``: the variable's prior mean, a (d,) vector (a state
    [x, y, θ, ẋ, ẏ, θ̇], velocity in the world frame; a landmark [x, y]); ``noise``: a sigma, sigmas (d,) or a
    covariance (d, d), in the variable's units (m, rad, m/s, rad/s); ``loss``: ``Huber(k)``, ``Tukey(c)`` or None.
    Conventions (state layout, frames, units): docs/api.md.

    Error:  e = θ - mean   (d,)
    """

    mean: NDArray  # (d,)

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "mean")

    @classmethod
    def create(cls, key: Key, mean: NDArray, noise: NDArray | float, *, loss: RobustLoss | None = None) -> PriorFactor:
        """Prior N(mean, Σ) on ``key``; mean is a vector (d,), noise a sigma, sigmas (d,) or a covariance (d, d)."""
        mean = real_array("mean", mean)
        if mean.ndim != 1 or mean.shape[0] == 0:
            raise ShapeError(f"mean (of the prior on {key!r}) must be a non-empty 1-D vector, got shape {mean.shape}")
        mean = measured_vector(mean, mean.shape[0], "mean")
        W = sqrt_information(noise, mean.shape[0])
        check_resolved("PriorFactor", (key,), tuple(f"mean[{i}]" for i in range(len(mean))), mean, W)
        return cls((key,), W, mean=mean, loss=loss)

    @property
    def key_dims(self) -> tuple[int]:  # type: ignore[override]
        return (self.mean.shape[-1],)

    def error(self, x: NDArray) -> NDArray:
        return x - self.mean

    def jacobians(self, x: NDArray) -> tuple[NDArray]:
        return (np.broadcast_to(np.eye(x.shape[-1]), x.shape[:-1] + (x.shape[-1], x.shape[-1])),)


# --- Measurements of one state ------------------------------------------------------------------


def _check_state_dim(state_dim: object) -> int:
    """A state [p; ṗ; ...] with p = [x, y, θ]: a whole number of 3-blocks, at least pose and velocity."""
    if not is_integer(state_dim) or state_dim < 6 or state_dim % 3:
        raise SteamError(
            f"state_dim must be a multiple of 3, at least 6 ([p; ṗ; ...], p = [x, y, θ]); got {state_dim!r}"
        )
    return int(state_dim)


@dataclass(frozen=True, eq=False)
class StateMeasurement(Factor):
    """Base of the factors that read a state's pose x[0:3] (and velocity x[3:6]), first key."""

    state_dim: int = field(default=STATE_DIM, kw_only=True)  # 6 (WNOA) or 9 (WNOJ, Singer)

    other_dims: ClassVar[tuple[int, ...]] = ()  # sizes of the keys after the state
    _shared: ClassVar[tuple[str, ...]] = ("state_dim",)  # one state size per batch (it is in the signature)
    n_states: ClassVar[int | None] = 1  # a state, then the landmarks it reads (other_dims)

    def __post_init__(self) -> None:
        super().__post_init__()
        _check_state_dim(self.state_dim)

    @property
    def key_dims(self) -> tuple[int, ...]:  # type: ignore[override]
        return (self.state_dim,) + self.other_dims

    def batch_signature(self) -> tuple:
        return super().batch_signature() + (self.state_dim,)


_OfState = TypeVar("_OfState", bound="_VelocityReading")


@dataclass(frozen=True, eq=False)
class _VelocityReading(StateMeasurement):
    """Base of a reading of one state's velocity (:class:`OdometryFactor`, :class:`VelocityFactor`): ``_size``
    numbers with their noise."""

    measured: NDArray  # (_size,) the reading

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "measured")
    _size: ClassVar[int]  # how many numbers the reading has

    @classmethod
    def create(
        cls: type[_OfState],
        key: Key,
        measured: NDArray,
        noise: NDArray | float,
        *,
        loss: RobustLoss | None = None,
        state_dim: int = STATE_DIM,
    ) -> _OfState:
        """The reading ``measured`` (the class's numbers: [v, θ̇] of odometry, [forward, lateral, yaw rate] of a
        velocity) on state ``key``; noise a sigma, sigmas or a covariance."""
        measured = measured_vector(measured, cls._size, "measured")
        return cls((key,), sqrt_information(noise, cls._size), measured=measured, loss=loss, state_dim=state_dim)


@dataclass(frozen=True, eq=False)
class OdometryFactor(_VelocityReading):
    """Odometry as the paper writes it: the state's forward speed and yaw rate.  [YIB Eq. 32]

        ``OdometryFactor.create(key, measured, noise, *, loss=None, state_dim=6)``

    ``key``: the state ``X(i)``; ``measured``: [v, ω], forward speed (m/s) and yaw rate (rad/s, counter-clockwise
    positive); ``noise``: a sigma, sigmas (2,) or a covariance (2, 2); ``state_dim``: 6, or 9 for WNOJ/Singer.

    Error:  e = [cos θ ẋ + sin θ ẏ,  θ̇] - [v, ω]   (the state's velocity [ẋ, ẏ] is in the world frame)

    The paper's scripts, and so every run of steam_ref's front end, use the three-component
    :class:`VelocityFactor` instead (the lateral speed measured as zero); this factor is here for a reader
    checking Eq. 32 and for users whose odometry has two components. Conventions: docs/api.md.
    """

    _size = 2  # [forward speed, yaw rate]

    def error(self, x: NDArray) -> NDArray:
        th, xd, yd, thd = x[..., 2], x[..., 3], x[..., 4], x[..., 5]
        h = np.stack([np.cos(th) * xd + np.sin(th) * yd, thd], axis=-1)  # [YIB Eq. 32]
        return h - self.measured

    def jacobians(self, x: NDArray) -> tuple[NDArray]:
        th, xd, yd = x[..., 2], x[..., 3], x[..., 4]
        c, s = np.cos(th), np.sin(th)
        J = zero_jacobian(x, 2)
        J[..., 0, 2] = -s * xd + c * yd
        J[..., 0, 3] = c
        J[..., 0, 4] = s
        J[..., 1, 5] = 1.0
        return (J,)


@dataclass(frozen=True, eq=False)
class VelocityFactor(_VelocityReading):
    """Odometry as the paper's scripts use it: the state's velocity seen in the robot frame.  [YIB Sec. IV]

        ``VelocityFactor.create(key, measured, noise, *, loss=None, state_dim=6)``

    ``key``: the state ``X(i)``; ``measured``: [forward, lateral, yaw rate] (m/s, m/s, rad/s), for a wheeled
    robot [distance / dt, 0, heading change / dt]; ``noise``: a sigma, sigmas (3,) or a covariance (3, 3);
    ``state_dim``: 6, or 9 for WNOJ/Singer.

    Error:  e = [cos θ ẋ + sin θ ẏ,  -sin θ ẋ + cos θ ẏ,  θ̇] - measured

    The state's velocity [ẋ, ẏ] is in the world frame; this factor turns it by -θ into the robot's (x forward,
    y left). Conventions: docs/api.md.
    """

    _size = 3  # [forward, lateral, yaw rate]

    def error(self, x: NDArray) -> NDArray:
        return self.error_and_jacobians(x, jacobians=False)[0]

    def jacobians(self, x: NDArray) -> tuple[NDArray, ...]:
        return self.error_and_jacobians(x)[1]

    def error_and_jacobians(self, x: NDArray, jacobians: bool = True) -> tuple[NDArray, tuple[NDArray, ...]]:
        th, xd, yd, thd = x[..., 2], x[..., 3], x[..., 4], x[..., 5]
        c, s = np.cos(th), np.sin(th)
        h = np.empty(x.shape[:-1] + (3,))  # filled row by row: np.stack's result at a fraction of its call cost
        h[..., 0], h[..., 1], h[..., 2] = c * xd + s * yd, -s * xd + c * yd, thd
        if not jacobians:  # the error alone
            return h - self.measured, ()
        J = zero_jacobian(x, 3)  # from the same cos θ and sin θ
        J[..., 0, 2], J[..., 0, 3], J[..., 0, 4] = -s * xd + c * yd, c, s
        J[..., 1, 2], J[..., 1, 3], J[..., 1, 4] = -c * xd - s * yd, -s, c
        J[..., 2, 5] = 1.0
        return h - self.measured, (J,)


# --- Measurements of a state and a landmark -----------------------------------------------------


def _distance(x: NDArray, l: NDArray) -> tuple[NDArray, NDArray]:
    """r = ‖[x y]ᵀ - ℓ‖ and the difference ℓ - [x y]ᵀ (..., 2).  [YIB Eq. 33]
    At r = 0 the norm has no derivative: a warning (the Jacobian rows there are zero, :func:`_range_row`)."""
    d = l[..., :2] - x[..., :2]
    r = np.hypot(d[..., 0], d[..., 1])
    if np.count_nonzero(r) < r.size:  # somewhere at the landmark (``r.all()``, at a tenth of its cost on a scalar)
        message = "a range with the robot exactly at the landmark: error 0 - r, its Jacobian (undefined) zero rows"
        warnings.warn(message, DegenerateMeasurementWarning, stacklevel=4)
    return r, d


def _range_row(x: NDArray, l: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """r = ‖[x y]ᵀ - ℓ‖ and its rows of ∂r/∂x (..., state size), ∂r/∂ℓ (..., 2).  [YIB Eq. 33]
    At r = 0 zero rows: gpslam's and STEAM's convention (and :func:`_distance`'s warning)."""
    r, d = _distance(x, l)
    at = None if np.count_nonzero(r) == r.size else (r == 0)[..., None]  # nowhere at the landmark (the usual case)
    u = d / r[..., None] if at is None else np.where(at, 0.0, d / np.where(at, 1.0, r[..., None]))
    Jx = np.zeros(x.shape)
    Jx[..., :2] = 0.0 - u  # 0.0 - u: +0.0, not -0.0, at the landmark
    return r, Jx, u


def _bearing_row(x: NDArray, l: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """b = atan2(ℓy - y, ℓx - x) - θ and its rows of ∂b/∂x (..., state size), ∂b/∂ℓ (..., 2)."""
    dx, dy = l[..., 0] - x[..., 0], l[..., 1] - x[..., 1]
    if np.any((r := np.hypot(dx, dy)) == 0):
        raise SteamError("robot position coincides with a landmark: a bearing has no value there (a range has: 0)")
    r2 = r**2
    Jx = np.zeros(x.shape)
    Jx[..., 0], Jx[..., 1], Jx[..., 2] = dy / r2, -dx / r2, -1.0
    return np.arctan2(dy, dx) - x[..., 2], Jx, np.stack([-dy / r2, dx / r2], axis=-1)


_Reading = TypeVar("_Reading", bound="_LandmarkReading")


@dataclass(frozen=True, eq=False)
class _LandmarkReading(StateMeasurement):
    """Base of a reading of one number about a landmark with its sigma (:class:`RangeFactor`, :class:`BearingFactor`):
    ``create`` and the Jacobians from the reading's rows of ∂/∂x and ∂/∂ℓ."""

    measured: NDArray  # (1,) the reading

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "measured")
    other_dims: ClassVar[tuple[int, ...]] = (LANDMARK_DIM,)
    _reads: ClassVar[str]  # the reading's name in an error ("range", "bearing")

    @staticmethod
    def _reading(name: str, measured: float) -> NDArray:
        """The reading checked (``measured.range_reading``, ``bearing_reading``)."""
        raise NotImplementedError

    @staticmethod
    def _rows(x: NDArray, l: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """The reading's value and its rows of ∂/∂x, ∂/∂ℓ (``_range_row``, ``_bearing_row``)."""
        raise NotImplementedError

    @classmethod
    def create(
        cls: type[_Reading],
        state: Key,
        landmark: Key,
        measured: float,
        sigma: float,
        *,
        loss: RobustLoss | None = None,
        state_dim: int = STATE_DIM,
    ) -> _Reading:
        """The reading ``measured`` (a range in m, not negative; a bearing in rad) of ``landmark`` from ``state``, with
        standard deviation ``sigma``."""
        reading = cls._reading("measured", measured)
        W = sqrt_information(sigma, 1, "sigma")
        check_resolved(cls.__name__, (state, landmark), (cls._reads,), reading, W)
        return cls((state, landmark), W, measured=reading, loss=loss, state_dim=state_dim)

    def jacobians(self, x: NDArray, l: NDArray) -> tuple[NDArray, NDArray]:
        _, Jx, Jl = self._rows(x, l)  # called here, not through error_and_jacobians: a range's warning's stacklevel
        return Jx[..., None, :], Jl[..., None, :]


@dataclass(frozen=True, eq=False)
class RangeFactor(_LandmarkReading):
    """A range reading: the distance from the robot's position to a landmark.  [YIB Eq. 33]

        ``RangeFactor.create(state, landmark, measured, sigma, *, loss=None, state_dim=6)``

    ``state``: ``X(i)``; ``landmark``: ``L(j)``; ``measured``: the range r (m, not negative); ``sigma``: its
    standard deviation (m); ``loss``: ``Huber(k)``, ``Tukey(c)`` (outliers) or None; ``state_dim``: 6, or 9.
    Conventions (frames, units): docs/api.md.

    Error:  e = ‖[x, y] - ℓ‖₂ - r
    """

    _reads = "range"
    _reading = staticmethod(range_reading)
    _rows = staticmethod(_range_row)

    def error(self, x: NDArray, l: NDArray) -> NDArray:
        return _distance(x, l)[0][..., None] - self.measured  # [YIB Eq. 33]

    def error_and_jacobians(self, x: NDArray, l: NDArray) -> tuple[NDArray, tuple[NDArray, NDArray]]:
        r, Jx, Jl = _range_row(x, l)  # one distance for the error and its Jacobians
        return r[..., None] - self.measured, (Jx[..., None, :], Jl[..., None, :])


@dataclass(frozen=True, eq=False)
class BearingFactor(_LandmarkReading):
    """A bearing reading: the direction of a landmark in the robot frame.

        ``BearingFactor.create(state, landmark, measured, sigma, *, loss=None, state_dim=6)``

    ``state``: ``X(i)``; ``landmark``: ``L(j)``; ``measured``: the bearing b (rad, within a full turn: abs(b) <= 2π,
    as float32 rounds it): 0 straight ahead (along the heading θ), positive counter-clockwise (to the robot's left);
    ``sigma``: its standard deviation (rad).
    Conventions (frames, units): docs/api.md.

    Error:  e = wrap(atan2(ℓy - y, ℓx - x) - θ - b),   wrap to [-π, π)
    """

    _reads = "bearing"
    _reading = staticmethod(bearing_reading)
    _rows = staticmethod(_bearing_row)

    def error(self, x: NDArray, l: NDArray) -> NDArray:
        return wrap_angle(_bearing_row(x, l)[0] - self.measured[..., 0])[..., None]


@dataclass(frozen=True, eq=False)
class BearingRangeFactor(StateMeasurement):
    """A bearing and a range of a landmark together (a laser's or a camera's sighting).

        ``BearingRangeFactor.create(state, landmark, bearing, range_, noise, *, loss=None, state_dim=6)``

    ``state``: ``X(i)``; ``landmark``: ``L(j)``; ``bearing``: b (rad, abs(b) <= 2π, as float32 rounds it) in the robot frame, 0 straight ahead,
    positive counter-clockwise (to the left); ``range_``: r (m, not negative); ``noise``: sigmas (2,) or a
    covariance (2, 2) of [b, r]. Conventions (frames, units): docs/api.md.

    Error:  e = [wrap(atan2(ℓy - y, ℓx - x) - θ - b),  ‖[x, y] - ℓ‖₂ - r],   wrap to [-π, π)
    """

    measured: NDArray  # (2,) [bearing rad, range m]

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "measured")
    other_dims: ClassVar[tuple[int, ...]] = (LANDMARK_DIM,)

    @classmethod
    def create(
        cls,
        state: Key,
        landmark: Key,
        bearing: float,
        range_: float,
        noise: NDArray,
        *,
        loss: RobustLoss | None = None,
        state_dim: int = STATE_DIM,
    ) -> BearingRangeFactor:
        """Bearing-range reading; noise is sigmas (2,) or a covariance (2, 2) for [bearing, range]."""
        measured = np.concatenate([bearing_reading("bearing", bearing), range_reading("range", range_)])
        W = sqrt_information(noise, 2)
        check_resolved("BearingRangeFactor", (state, landmark), ("bearing", "range"), measured, W)
        return cls((state, landmark), W, measured=measured, loss=loss, state_dim=state_dim)

    def error(self, x: NDArray, l: NDArray) -> NDArray:
        b, r = _bearing_row(x, l)[0], _distance(x, l)[0]
        return np.stack([wrap_angle(b - self.measured[..., 0]), r - self.measured[..., 1]], axis=-1)

    def jacobians(self, x: NDArray, l: NDArray) -> tuple[NDArray, NDArray]:
        (_, bx, bl), (_, rx, rl) = _bearing_row(x, l), _range_row(x, l)  # not through error_and_jacobians: stacklevel
        return np.stack([bx, rx], axis=-2), np.stack([bl, rl], axis=-2)

    def error_and_jacobians(self, x: NDArray, l: NDArray) -> tuple[NDArray, tuple[NDArray, NDArray]]:
        (b, bx, bl), (r, rx, rl) = _bearing_row(x, l), _range_row(x, l)  # one of each for the error and Jacobians
        e = np.stack([wrap_angle(b - self.measured[..., 0]), r - self.measured[..., 1]], axis=-1)
        return e, (np.stack([bx, rx], axis=-2), np.stack([bl, rl], axis=-2))
