"""Fixed-lag smoothing: iSAM2 that forgets the variables older than a lag.  [K12, derivations §10]

:class:`FixedLagSmoother` is an :class:`~steam_ref.bayes_tree.IncrementalSolver` whose updates carry
timestamps. After each update every variable whose timestamp is older than the newest one minus the
lag (``t < t_newest - lag``, GTSAM's rule) is marginalized out of the Bayes tree by
:func:`~steam_ref.bayes_tree.marginalization.marginalize`: its factors go, a :class:`MarginalFactor` on
its separator stays, frozen at the linearization point of the moment. The tree, the factors and
the estimate then hold only the window, so memory and time per update stay flat however long the
run.

A variable without a timestamp (a landmark, unless the caller gives one) is never marginalized; a
timestamp may be refreshed (give a landmark the time it was last seen, and it is forgotten a lag
after that). A marginalized variable given a value again (a landmark seen again) enters as a new
variable: what was learnt of it before lives on only in the marginal factor on the window. The
smoother decides what to forget from the timestamps alone (:func:`marginalize` refuses it: its
timestamps and history would not know); give a variable an old timestamp instead.

Queries of a marginalized variable raise :class:`UnknownVariableError` naming the update that
marginalized it; its estimate at that moment is in :attr:`FixedLagSmoother.last_marginalization`.
``keep_history=True`` keeps each marginalized variable's conditional (:mod:`.history`), and
:meth:`FixedLagSmoother.smoothed_history` gives every forgotten variable its estimate given all the data so
far, by one backward pass from the window (derivations §10.5).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

from numpy.typing import NDArray

from ..arguments import number
from ..errors import SteamError, UnknownVariableError
from ..factors import Factor, check_factors
from ..linear.threads import limit
from ..variables import Key
from .history import History
from .isam import IncrementalSolver, UpdateReport, check_new_values
from .marginalization import MarginalizationReport, marginalize_keys
from .params import ISAM2Params

__all__ = ["FixedLagSmoother"]


class FixedLagSmoother(IncrementalSolver):
    """iSAM2 over a sliding window of ``lag`` seconds: older variables are marginalized after each update.

    ``update(..., timestamps={key: t})`` gives new (or refreshed) timestamps in seconds.
    """

    forgets_by_time = True  # :func:`marginalize` refuses it: what it forgets, it records

    def __init__(
        self, lag: float, params: ISAM2Params | None = None, *, keep_history: bool = False, **changes: object
    ) -> None:
        lag = number("lag", lag)
        if not lag > 0:
            raise SteamError(f"lag must be a number of seconds > 0, got lag={lag!r}")
        super().__init__(params, **changes)
        self.lag = float(lag)  # seconds of history kept
        self._times: dict[Key, float] = {}  # timestamp of each timed variable in the window
        self._gone: dict[Key, int] = {}  # marginalized key → the update that marginalized it (any id a Key holds)
        self.newest = -math.inf  # the latest timestamp seen
        self.n_marginalized = 0  # variables marginalized so far
        self.peak_window = 0  # most variables held at once (measured after each update, before marginalizing)
        self.history: History | None = History() if keep_history else None  # the forgotten conditionals, if kept
        self.last_marginalization: MarginalizationReport | None = None  # what the last update forgot

    def update(
        self,
        new_factors: Factor | Iterable[Factor] = (),
        new_values: Mapping[Key, NDArray] | None = None,
        *,
        timestamps: Mapping[Key, float] | None = None,
        relinearize: bool = True,
    ) -> UpdateReport:
        """:meth:`IncrementalSolver.update`, then marginalize the variables older than the lag.

        Raises :class:`UnknownVariableError` for a factor or timestamp naming a marginalized variable. The
        update, the marginalization and the record of what it forgot are one transaction of the solver's undo
        log: a failure or an interruption (Ctrl-C) anywhere leaves the smoother exactly as before the call.
        """
        check_new_values(new_values)  # before anything reads it as a mapping
        times = self._checked_times(timestamps, new_values)
        factors = check_factors("new_factors", new_factors)
        fresh = () if new_values is None else new_values
        for f in factors:
            for k in f.keys:
                if k not in fresh:
                    self._held("a new factor names", k)
        with self.state.transaction(), limit():  # the limit is left inside: an interrupt there undoes all
            report = super().update(factors, new_values, relinearize=relinearize)
            self._forget_old(fresh, times)
        return report

    def _forget_old(self, fresh: Iterable[Key], times: dict[Key, float]) -> None:
        """After an update: record its timestamps, marginalize what fell behind the lag, and record that."""
        log = self.state.log
        for name in ("newest", "n_marginalized", "peak_window", "last_marginalization"):
            log.record(setattr, self, name, getattr(self, name))
        log.keep(self._times)  # ordered: the next marginalization's order follows it
        for k in fresh:
            if k in self._gone:
                log.delete(self._gone, k)  # a marginalized variable given anew is a new variable
        self._times.update(times)
        self.newest = max(self.newest, *times.values()) if times else self.newest
        self.peak_window = max(self.peak_window, len(self))
        cutoff = self.newest - self.lag
        old = [k for k, t in self._times.items() if t < cutoff]
        self.last_marginalization = None
        if old:
            done = marginalize_keys(self, old, keep_conditionals=self.history is not None)
            if self.history is not None:
                log.extend(self.history.conditionals, list(done.conditionals))
            for k in done.keys:
                log.set(self._gone, k, self.state.steps)
                del self._times[k]
            self.n_marginalized += len(done.keys)
            self.last_marginalization = done

    def elimination_order(self, variables: list[Key], factor_keys: list, last: list[Key]) -> list[Key]:
        """Once the window is full: the timed variables older than the newest timestamp first, oldest first, then
        minimum degree with ``last`` last [K12 Sec. 5], so the states next to leave sit in leaf cliques, cut off with
        no re-elimination (as GTSAM's fixed-lag smoother orders the keys to marginalize first)."""
        if not self.n_marginalized:  # the window is not full yet: iSAM2's own order, as without a lag
            return super().elimination_order(variables, factor_keys, last)
        cutoff, times = self.newest, self._times
        old = sorted(
            (k for k in variables if times.get(k, math.inf) < cutoff and k not in last), key=lambda k: times[k]
        )
        if not old:
            return super().elimination_order(variables, factor_keys, last)
        groups = [set(keys) for keys in factor_keys]
        for v in old:  # the elimination game on the keys [K12 Alg. 1]: v's factors become one on its neighbours
            touching = [g for g in groups if v in g]
            groups = [g for g in groups if v not in g] + [set().union(*touching) - {v}]
        gone = set(old)
        rest = [k for k in variables if k not in gone]
        return old + super().elimination_order(rest, [tuple(g) for g in groups if g], last)

    def _checked_times(
        self, timestamps: Mapping[Key, float] | None, new_values: Mapping[Key, NDArray] | None
    ) -> dict[Key, float]:
        """The timestamps as floats; each names a held variable or a new one."""
        if timestamps is None:
            return {}
        if not isinstance(timestamps, Mapping):
            raise SteamError(f"timestamps must be a mapping key -> seconds (or None), got {timestamps!r}")
        out = {}
        new = () if new_values is None else new_values
        for k, t in timestamps.items():
            if not isinstance(k, Key):
                raise SteamError(
                    f"timestamps has the key {k!r:.80}, which is not a variable key (make one with X(i) or L(j))"
                )
            if k not in new:
                self._held("timestamps names", k)
            if not self.holds(k) and k not in new:
                raise UnknownVariableError(f"timestamps names {k!r}, which is neither held nor in new_values")
            out[k] = number(f"timestamps[{k!r}]", t)
        return out

    def _held(self, what: str, key: Key) -> None:
        """UnknownVariableError when ``key`` was marginalized, saying when."""
        gone = self._gone.get(key)
        if gone:
            raise UnknownVariableError(
                f"{what} {key!r}, which was marginalized at update {gone} "
                f"(its timestamp fell more than the lag, {self.lag:g} s, behind the newest)"
            )

    def smoothed_history(self) -> dict[Key, NDArray]:
        """Every marginalized variable's estimate given all the data so far (:meth:`.History.smooth`).

        Needs ``keep_history=True``. Each is an affine function of the window's current estimate through the
        conditionals frozen at marginalization [derivations Eq. 10.5]; for a linear problem, the batch optimum;
        for a nonlinear one, the optimum of those frozen linearizations (:mod:`.history`). A landmark forgotten
        and back in the window appears here as its *previous* incarnation, under the same key: merging this
        dict over :meth:`estimate` would overwrite the live estimate with the stale one.
        """
        if self.history is None:
            raise SteamError("smoothed_history needs the conditionals: make the smoother with keep_history=True")
        return self.history.smooth(self.estimate_of)

    def was_marginalized(self, key: Key) -> bool:
        """True when ``key`` was held once and has been marginalized."""
        return bool(self._gone.get(key))

    @property
    def timestamps(self) -> dict[Key, float]:
        """The timestamp of each timed variable in the window (a copy)."""
        return dict(self._times)

    def _known(self, what: str, keys: list[Key]) -> list[Key]:
        """UnknownVariableError for a key that was marginalized, saying when (the queries' check)."""
        for k in keys:
            self._held(what, k)
        return keys
