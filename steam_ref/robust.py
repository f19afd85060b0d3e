"""Robust losses applied by iteratively reweighted least squares.

A robust factor replaces ½‖e‖² by ρ(‖e‖) of its *whitened* error e. Gauss-Newton then sees the
error and Jacobian scaled by √w with w = ρ'(s)/s, recomputed at every linearization (IRLS), as in
GTSAM's ``noiseModel::Robust``. The paper's scripts put a Tukey loss (c = 15) on every range.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .arguments import number
from .errors import SteamError

__all__ = ["RobustLoss", "Huber", "Tukey"]


class RobustLoss:
    """ρ(s) of the whitened error norm s, and its IRLS weight w(s) = ρ'(s)/s."""

    def rho(self, s: NDArray) -> NDArray:
        raise NotImplementedError

    def weight(self, s: NDArray) -> NDArray:
        raise NotImplementedError

    def weight_and_rho(self, s: NDArray) -> tuple[NDArray, NDArray]:
        """w(s) and ρ(s) together, what a linearization asks for (a loss may share their work, equal to the two calls')."""
        return self.weight(s), self.rho(s)


def _threshold(loss: str, name: str, value: object) -> float:
    """A loss's threshold as a float: a positive finite number. An infinite one would be plain least
    squares for Huber and NaN for Tukey (c² · 0); use ``loss=None`` for plain least squares."""
    try:
        t = number(name, value)
    except SteamError as exc:
        raise SteamError(f"{loss} threshold: {exc}") from None
    if t <= 0:
        raise SteamError(f"{loss} threshold must be positive, got {name}={t}")
    if not _SMALLEST <= t <= _LARGEST:
        raise SteamError(
            f"{loss} threshold {name}={t!r}: its square, which the loss {'of an outlier ' if loss == 'Tukey' else ''}"
            f"is made of, {'overflows' if t > 1 else 'underflows'} float64; use {_SMALLEST:.3g} <= {name} <= {_LARGEST:.3g}"
            + (" (or loss=None for plain least squares)" if t > 1 else "")
        )
    return t


_LARGEST = float(np.sqrt(np.finfo(float).max) / 10)  # ρ holds the threshold squared (Tukey: c²/6; Huber at 10 k: 10 k²)
_SMALLEST = float(np.sqrt(np.finfo(float).tiny) * 3)  # and a normal float, not 0


@dataclass(frozen=True)
class Huber(RobustLoss):
    """ρ(s) = s²/2 for abs(s) ≤ k, k abs(s) - k²/2 beyond: quadratic core, linear tails."""

    k: float = 1.345  # threshold on the whitened error

    def __post_init__(self) -> None:
        object.__setattr__(self, "k", _threshold("Huber", "k", self.k))

    def rho(self, s: NDArray) -> NDArray:
        a = np.abs(s)
        core = np.minimum(a, self.k)  # squared only within the core: a**2 of a far outlier would overflow
        return np.where(a <= self.k, 0.5 * core**2, self.k * a - 0.5 * self.k**2)

    def weight(self, s: NDArray) -> NDArray:
        a = np.abs(s)
        return np.where(a <= self.k, 1.0, self.k / np.maximum(a, self.k))


@dataclass(frozen=True)
class Tukey(RobustLoss):
    """Tukey's biweight: ρ(s) = c²/6 (1 - (1 - (s/c)²)³) for abs(s) ≤ c, constant c²/6 beyond."""

    c: float = 4.685  # errors beyond c whitened sigmas get zero weight

    def __post_init__(self) -> None:
        object.__setattr__(self, "c", _threshold("Tukey", "c", self.c))

    def rho(self, s: NDArray) -> NDArray:
        return self.weight_and_rho(s)[1]

    def weight(self, s: NDArray) -> NDArray:
        return self.weight_and_rho(s)[0]

    def weight_and_rho(self, s: NDArray) -> tuple[NDArray, NDArray]:
        """w(s) = (1 - u²)² and ρ(s) = c²/6 (1 - (1 - u²)³) from one u = min(abs(s), c) / c, which is at most 1 and
        cannot overflow (beyond c, u = 1: weight 0, ρ = c²/6). The ``where`` only maps a NaN's weight to 0."""
        one = s.shape == (1,)  # a stream's usual batch: one number, in Python floats (the same IEEE operations)
        x = s.item() if one else s
        u = (min(abs(x), self.c) if one else np.minimum(np.abs(x), self.c)) / self.c  # min keeps a NaN first
        t = 1 - u * u  # u * u is NumPy's u**2, a float's too
        w = (t * t if u <= 1.0 else 0.0) if one else np.where(u <= 1.0, t * t, 0.0)
        rho = self.c**2 / 6 * (1 - t**3)
        return (np.array((w,)), np.array((rho,))) if one else (np.asarray(w), np.asarray(rho))
