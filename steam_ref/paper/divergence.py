"""A stream that says when a reading is beyond any plausible noise, or its estimate diverges.

After each update of a stream (:mod:`steam_ref.paper.online`) two checks look at the factors that
update added, in time proportional to them (a cost of every factor after every update would cost
time in proportion to the whole problem, every update), evaluated in batches of one type as a linearization
evaluates them, without Jacobians (:func:`~steam_ref.linear.system.whitened_norms`), at estimates asked for
once per check (a solver's ``estimates_of``: each kind's formed in one call):

- **Before the update, the gate**: each new landmark reading's whitened residual ‖W e‖ at the
  prediction (the solver's estimate of the variables it holds, the front end's initial guess of the
  new ones). A reading a Gaussian sensor gives is a few sigmas off; one placed by dead reckoning after
  a long loop some tens. Beyond :data:`PLAUSIBLE_SIGMAS` (1,000) it is beyond any noise: the warning
  names it. Velocity readings are not gated: the initial guess of a new state is made from them (and
  the scripts' heading-rate guess jumps by 2π/dt where the heading wraps, thousands of its sigmas).
- **After the update, the fit**: the same residuals at the new estimate. Beyond :data:`PLAUSIBLE_SIGMAS`
  the estimate no longer fits what it was just given: it is diverging (the warning names the worst).

Each finding is a :class:`~steam_ref.errors.DivergenceWarning` (not a ConvergenceWarning: nothing was
asked to converge) and is kept in :attr:`DivergenceCheck.findings`, which the run's result and its JSON
report (``divergence``). Robust losses do not hide a reading here: the residual is ‖W e‖, before ρ.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from ..errors import DivergenceWarning
from ..factors import BearingFactor, BearingRangeFactor, Factor, RangeFactor
from ..linear.system import whitened_norms
from ..motion import is_interpolated, reading_inside
from ..variables import Key, Values

__all__ = ["DivergenceCheck", "PLAUSIBLE_SIGMAS", "fits", "worst_fit"]

PLAUSIBLE_SIGMAS = 1e3  # a whitened residual above this is beyond any plausible noise
MAX_FINDINGS = 20  # findings kept for the result (the warnings say every one)

Estimates = Callable[[list[Key]], Mapping[Key, NDArray]]  # the estimates of the keys asked, in one call


def fits(factors: Sequence[Factor], estimates: Estimates) -> NDArray:
    """(n,) ‖W e‖ of each of ``factors`` (inf when it is not finite) at the values ``estimates`` gives for their
    keys, asked once for all of them: the factors evaluated in batches of one type, as a linearization evaluates
    them without Jacobians (:func:`~steam_ref.linear.system.whitened_norms`)."""
    if not factors:
        return np.zeros(0)
    keys = list(dict.fromkeys(k for f in factors for k in f.keys))
    return whitened_norms(factors, Values.adopt(estimates(keys)))


def worst_fit(factors: Sequence[Factor], estimates: Estimates) -> tuple[float, Factor | None]:
    """The largest ‖W e‖ among ``factors`` at the values ``estimates`` gives, and its factor (None: no factors)."""
    return _worst(fits(factors, estimates), factors)


def _worst(residuals: NDArray, factors: Sequence[Factor]) -> tuple[float, Factor | None]:
    """The largest of ``residuals`` and its factor (0 and None: no factors)."""
    if not factors:
        return 0.0, None
    i = int(residuals.argmax())
    return float(residuals[i]), factors[i]


def _is_landmark_reading(factor: Factor) -> bool:
    inner = reading_inside(factor)
    return isinstance(inner, (RangeFactor, BearingFactor, BearingRangeFactor))


def describe(factor: Factor) -> str:
    """A factor as the reading it holds: its kind, variables and measured value."""
    inner = reading_inside(factor)
    measured = getattr(inner, "measured", getattr(inner, "mean", None))
    what = "" if measured is None else f" reading {np.asarray(measured).tolist()}"
    where = ", ".join(repr(k) for k in factor.keys)
    between = " (interpolated between its states)" if is_interpolated(factor) else ""
    return f"{type(inner).__name__} on {where}{between}{what}"


class DivergenceCheck:
    """The two checks around each update of a stream (see the module)."""

    def __init__(self, limit: float = PLAUSIBLE_SIGMAS):
        self.limit = limit  # sigmas beyond any plausible noise
        self.findings: list[str] = []  # what was found, in order (at most MAX_FINDINGS)
        self.count = 0  # how many findings in all
        self._absurd: set[int] = set()  # ids of the readings the last gate found beyond any noise
        self.diverged_at: int | None = None  # the pose of the first update after which the estimate did not fit

    def _found(self, message: str) -> None:
        self.count += 1
        if len(self.findings) < MAX_FINDINGS:
            self.findings.append(message)
        warnings.warn(message, DivergenceWarning, stacklevel=4)

    def gate(self, factors: Sequence[Factor], estimates: Estimates, pose: int) -> None:
        """Before the update at ``pose``: a new reading beyond any noise at the prediction (``estimates``: the
        values of the keys asked, in one call) is named."""
        readings = [f for f in factors if _is_landmark_reading(f)]
        residuals = fits(readings, estimates)
        s, f = _worst(residuals, readings)
        self._absurd = {id(readings[i]) for i in np.flatnonzero(residuals > self.limit)} if s > self.limit else set()
        if f is not None and s > self.limit:
            self._found(
                f"update at pose {pose}: {describe(f)} is {s:.3g} sigmas from the prediction, beyond any "
                f"plausible noise (> {self.limit:g}): "
                + (
                    "an absurd reading, or another landmark's"
                    if self.diverged_at is None
                    else f"the estimate has been diverging since the update at pose {self.diverged_at}, which may be why"
                )
            )

    def fit(self, factors: Sequence[Factor], estimates: Estimates, pose: int) -> None:
        """After the update at ``pose``: the estimate not fitting a new factor within any noise is diverging
        (the readings the gate found absurd left out: an estimate that does not follow them is right)."""
        s, f = worst_fit([f for f in factors if id(f) not in self._absurd], estimates)
        if f is not None and s > self.limit:
            self.diverged_at = pose if self.diverged_at is None else self.diverged_at
            self._found(
                f"update at pose {pose}: the estimate is diverging: it misses {describe(f)} by {s:.3g} sigmas "
                f"(> {self.limit:g}) right after the update that added it"
            )
