"""What a factor is given as measured: a vector of numbers, one number (a range, a bearing), each finite, and
resolved by float64 to within its sigma (``check_resolved``). The one home of each rule, for every factor
(:mod:`steam_ref.factors.measurements`, :mod:`steam_ref.factors.point_readings`,
:mod:`steam_ref.factors.lie_readings`, :mod:`steam_ref.factors.gp`).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from ..arguments import finite, real_array
from ..errors import ShapeError, SteamError
from ..variables import FLOAT64
from .base import FLOAT_TYPES, Memo

__all__ = ["measured_vector", "measured_scalar", "check_resolved", "range_reading", "bearing_reading"]


_SIGMAS = Memo()  # the sigmas of each W met so far, by its float64 bytes (its size among them)


def _sigmas(W: NDArray) -> NDArray:
    """The standard deviations (m,) of the noise whose square-root information is W (m, m), memoised by value:
    a stream's readings of one sensor share their W, each step."""
    memo = W.tobytes()
    sigma = _SIGMAS.get(memo)
    if sigma is None:
        with np.errstate(all="ignore"):
            rows = np.linalg.inv(W)  # Σ = W⁻¹W⁻ᵀ: sigma i is the norm of row i, scaled so 1e-200 does not underflow
            big = np.maximum(np.abs(rows).max(axis=1), np.finfo(float).tiny)
            sigma = _SIGMAS.keep(memo, big * np.sqrt(((rows / big[:, None]) ** 2).sum(axis=1)))
    return sigma


def check_resolved(factor: str, keys: tuple, labels: tuple[str, ...], measured: NDArray, W: NDArray) -> None:
    """Each measured number is resolved by float64 to within its sigma: a value whose float spacing
    exceeds its sigma (a bearing of 1e17 rad, numbers there 16 rad apart; a sigma of 1e-150 m on a
    range of 10 m) is no reading a sensor gives, and its whitened error would be rounding noise.
    ``factor`` on ``keys`` names the reading (written out only for the error)."""
    sigma = _sigmas(W)
    spacing = np.spacing(np.abs(measured))  # finite by the callers' checks: no warning to silence
    coarse = spacing > sigma
    if coarse.any():
        i = int(np.flatnonzero(coarse)[0])
        raise SteamError(
            f"{factor} on {', '.join(map(repr, keys))}: {labels[i] if i < len(labels) else f'measured[{i}]'} = "
            f"{float(measured[i])!r} with sigma {float(sigma[i]):.3g}: float64 numbers there are "
            f"{float(spacing[i]):.3g} apart, more than the sigma, so the reading carries nothing float64 can resolve"
        )


def measured_vector(value: NDArray | float, m: int, what: str) -> NDArray:
    """``value`` as a float vector (m,): a 1-d array of m finite numbers, or a number when m = 1."""
    if type(value) is np.ndarray and value.dtype is FLOAT64 and value.shape == (m,):  # (m,) float64: one copy, one sum
        v = value.copy()
        if math.isfinite(sum(v.tolist())):  # finite, as each number is (if it overflowed, the checks below decide)
            return v
    elif m == 1 and type(value) in FLOAT_TYPES and math.isfinite(value):  # one finite number
        return np.array((value,))
    v = real_array(what, value)
    if v.shape != (m,) and not (m == 1 and v.ndim == 0):
        raise ShapeError(
            f"{what} must be {m} finite number{'s' if m > 1 else ''} (shape ({m},)), got {np.asarray(value).tolist()}"
        )
    return finite(what, v.reshape(m))


def measured_scalar(value: float, what: str) -> NDArray:
    """A reading documented as one number (a range, a bearing) as a (1,) vector: a finite number, a NumPy scalar or a
    0-d array, never a sequence (``[5.0]`` is not ``5.0``: :mod:`steam_ref.arguments`' rule for a number)."""
    if type(value) in FLOAT_TYPES and math.isfinite(value):  # one finite number (the usual case)
        return np.array((value,))
    v = real_array(what, value)  # numbers only (not a string, a bool, None)
    if v.shape != ():
        raise ShapeError(f"{what} must be 1 finite number (a scalar, not a sequence), got {np.asarray(value).tolist()}")
    return finite(what, v.reshape(1))


def range_reading(name: str, measured: float) -> NDArray:
    """A range reading as a (1,) vector: a finite distance (one number); a negative one is a bad reading, not a far
    landmark. The one check of a range, on every state (``point_readings.RangeReading`` too)."""
    r = measured_scalar(measured, name)
    if r[0] < 0:
        raise SteamError(f"a range cannot be negative, got {name}={float(r[0])!r}")
    return r


# rad: a bearing beyond a full turn either way is no sensor's, most often degrees. The bound is 2π as float32 rounds it
# (up, by 1.7e-7): a float32 sensor's full turn, np.float32(2π), is a reading of a full turn, not one past it.
MAX_BEARING = float(np.float32(2 * math.pi))


def bearing_reading(name: str, measured: float) -> NDArray:
    """A bearing reading as a (1,) vector: a finite angle (one number) in radians, within a full turn either way
    (abs(b) <= 2π covers both a sensor's [-π, π) and its [0, 2π]; the bound is 2π as float32 rounds it,
    :data:`MAX_BEARING`, so a float32 reading of a full turn is read as given, not clipped). A larger one is refused,
    not wrapped: it is almost always degrees (a reading of 90 is a quarter turn in degrees, 14 turns in radians), or
    radians past a full turn, and the message gives both ways to say what was meant."""
    b = measured_scalar(measured, name)
    if abs(b[0]) > MAX_BEARING:
        value = float(b[0])
        raise SteamError(
            f"a bearing is in radians, within a full turn (abs({name}) <= 2π, or {MAX_BEARING!r}: 2π as float32 "
            f"rounds it), got {name}={value!r}: if it is in degrees, give np.radians({value!r}) = "
            f"{math.radians(value):.6g}; if it is radians past a full turn, give it wrapped, "
            f"math.remainder({value!r}, 2 * math.pi) = {math.remainder(value, 2 * math.pi):.6g}"
        )
    return b
