"""A run's two clocks, the data's seconds and the model's time, and the one map between them.

The **data's clock** is the time stamps of a data set's poses, in seconds: its file's, or a generator's
(a data set says which). Every time a user gives or reads is on it: a fixed lag, a query of the
trajectory, the ``times`` of every file a run writes.

The **model's clock** is the time the GP prior sees: tᵢ in the transition Φ(tⱼ, tᵢ) and the process
noise Qᵢ of a prior factor [YIB Eq. 14, 17, 22], and the interpolation between states [YIB Eq. 16-18].
A set-up chooses it (:data:`CLOCK_BASES`):

- ``'seconds'``: the model's time is the data's. A prior's Δt is the time between its states in seconds,
  and Qc is a power spectral density per second.
- ``'pose-index'``: pose i is at model time i, whatever its stamp: Δt = 1 per pose, so Qc is per pose step
  and an odometry reading's distance is a velocity per pose step. This is what the paper's scripts do on
  the CMU range-only sets (``synthetic_isam2.m``, ``plaza_isam2.m``: one GP step per odometry row), and what
  reproducing their figures needs. On Plaza one step is 0.171-0.232 s (median 0.200 s); on Plaza2,
  0.008-0.350 s (median 0.100 s); the synthetic set is stamped 1 s apart, where the two clocks differ only
  by their origin.

The map is pose by pose: pose i is at ``seconds[i]`` on the data's clock and ``model[i]`` on the model's.
Between two poses it is linear; before the first pose and after the last it continues with the end
step's rate, so the prior's prediction after the last state stays defined. :class:`Clock` is the one
place this map lives.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arguments import finite, real_array
from ..errors import ShapeError, SteamError

__all__ = ["Clock", "CLOCK_BASES", "TIME_ORIGINS"]

CLOCK_BASES = ("seconds", "pose-index")  # what the model's time of a pose is
TIME_ORIGINS = ("file", "generated", "given")  # where a data set's seconds come from


@dataclass(frozen=True, eq=False)
class Clock:
    """The time of every pose on the data's clock (``seconds``) and on the model's (``model``).

    Build one with :meth:`of`; ``basis`` says how ``model`` follows from ``seconds`` and ``origin``
    where the seconds come from (a file's stamps, a generator's, or the caller's arrays).
    """

    seconds: NDArray  # (n_poses,) the data's time of each pose [s], non-decreasing
    model: NDArray  # (n_poses,) the time the GP prior sees at each pose
    basis: str  # one of CLOCK_BASES
    origin: str = "given"  # one of TIME_ORIGINS

    @classmethod
    def of(cls, seconds: ArrayLike, basis: str = "seconds", origin: str = "given") -> Clock:
        """The clock of poses stamped ``seconds`` (one time at least); SteamError names a bad basis, origin or
        time, or no time at all (a clock of no pose maps nothing: every query of it would be undefined)."""
        if basis not in CLOCK_BASES:
            raise SteamError(f"unknown clock basis {basis!r}; use one of {', '.join(CLOCK_BASES)}")
        if origin not in TIME_ORIGINS:
            raise SteamError(f"unknown origin of the times {origin!r}; use one of {', '.join(TIME_ORIGINS)}")
        t = np.array(real_array("times", seconds), dtype=float)
        if t.ndim != 1:
            raise ShapeError(f"times must be a 1-d array, one time per pose, got shape {t.shape}")
        if not t.size:
            raise SteamError("times is empty: a clock needs the time of one pose at least")
        bad = np.flatnonzero(~np.isfinite(t))
        if bad.size:
            raise SteamError(f"times[{int(bad[0])}] = {float(t[bad[0]])!r}: every pose time must be finite")
        step = np.diff(t)
        back = np.flatnonzero(step < 0 if basis == "seconds" else step <= 0)
        if back.size:
            i = int(back[0])
            need = "not decrease" if basis == "seconds" else "increase strictly (a pose-index clock maps between them)"
            raise SteamError(
                f"pose times must {need}, but times[{i}] = {float(t[i])!r} and times[{i + 1}] = {float(t[i + 1])!r}"
            )
        model = t.copy() if basis == "seconds" else np.arange(len(t), dtype=float)
        for a in (t, model):
            a.setflags(write=False)
        return cls(t, model, basis, origin)

    @property
    def n_poses(self) -> int:
        return len(self.seconds)

    def prefix(self, n_poses: int) -> Clock:
        """The clock of the first ``n_poses`` poses."""
        return Clock(self.seconds[:n_poses], self.model[:n_poses], self.basis, self.origin)

    def to_model(self, t: ArrayLike) -> NDArray:
        """The model's time at data time(s) ``t`` [s] (the same shape); ShapeError naming ``t`` unless finite numbers."""
        return self._map(finite("t", real_array("t", t)), self.seconds, self.model)

    def to_seconds(self, m: ArrayLike) -> NDArray:
        """The data's time [s] at model time(s) ``m`` (the same shape); ShapeError naming ``m`` unless finite numbers."""
        return self._map(finite("m", real_array("m", m)), self.model, self.seconds)

    def _map(self, x: NDArray, xp: NDArray, fp: NDArray) -> NDArray:
        if self.basis == "seconds" or len(xp) < 2:
            return x + (fp[0] - xp[0] if len(xp) else 0.0)
        out = np.interp(x, xp, fp)  # exact at a pose: a query at a pose's stamp lands on its state
        first = (fp[1] - fp[0]) / (xp[1] - xp[0])
        last = (fp[-1] - fp[-2]) / (xp[-1] - xp[-2])
        out = np.where(x < xp[0], fp[0] + (x - xp[0]) * first, out)
        return np.where(x > xp[-1], fp[-1] + (x - xp[-1]) * last, out)

    @property
    def unit(self) -> str:
        """One unit of the model's time: ``'s'`` on a 'seconds' clock, ``'step'`` (a pose step) on a 'pose-index' one."""
        return "s" if self.basis == "seconds" else "step"

    def describe(self) -> str:
        """One line: the basis, what one model time unit is in seconds, where the seconds come from."""
        origin = {"file": "the file's stamps", "generated": "generated stamps", "given": "the given stamps"}[
            self.origin
        ]
        if self.basis == "seconds":
            return f"the model's time is the data's seconds ({origin})"
        step = np.diff(self.seconds)
        if not step.size or step.min() == step.max():
            spread = f"{step[0]:.3g} s" if step.size else "undefined (one pose)"
        else:
            spread = f"{step.min():.3g}-{step.max():.3g} s, median {np.median(step):.3g} s"
        return f"pose-index: the GP prior sees dt = 1 per pose; one pose step is {spread} ({origin})"
