"""Fixed-lag smoothing: iSAM2 that forgets the variables older than a lag, and keeps a map.  [K12, derivations §10]

:class:`FixedLagSmoother` holds an :class:`~steam_ref.bayes_tree.IncrementalSolver` and the timestamps of its
variables, as GTSAM's ``IncrementalFixedLagSmoother`` holds an ISAM2. **What ages:** a variable stamped older than
the newest minus the lag (``t < t_newest - lag``, GTSAM's rule) is marginalized after the update, eliminated first
so that it is a leaf (``marginalize_leaves``): its factors go, a :class:`MarginalFactor` on its separator (a kept
landmark too) stays, frozen at θ̄ of the moment. **What never ages:** a variable never stamped, and one ``keep=``
names (``"l"``, symbols: every landmark; or a predicate on a key): a map, refined by every later sighting while
the states age out. A timestamp given again restarts a variable's clock. **An aged variable is gone:** a factor,
timestamp or query naming it raises :class:`UnknownVariableError` naming the update that forgot it (as GTSAM);
given a value again, it enters as a new variable. ``keep_history=True`` keeps each one's conditional
(:mod:`.history`): :meth:`FixedLagSmoother.smoothed_history` gives the forgotten variables all the data so far.
**A kept map is not the batch's:** exact at a fixed θ̄, it keeps each marginal factor's θ̄ of the moment, and with
``relinearize_skip=10`` a state may leave still linearized where it entered: on a figure-eight with 1-rad turns, up
to 14 of the batch's σ away; ``relinearize_skip=1`` gave at most 0.7 σ, or full iSAM2's own gap (docs/experiments.md).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping

from numpy.typing import NDArray

from ..arguments import flag, number
from ..covariance import key_groups
from ..errors import SteamError, UnknownVariableError
from ..factors import Factor, check_factors
from ..linear.ordering import KeysBelow
from ..linear.threads import limit
from ..manifold import Manifold
from ..variables import Key, Values, check_key, check_new_values, key_list
from .history import History, Marginalized
from .isam import IncrementalSolver, UpdateReport
from .marginalization import MarginalizationReport, cuttable, marginalize_keys
from .params import ISAM2Params
from .undo import UndoLog

__all__ = ["FixedLagSmoother"]


class FixedLagSmoother:
    """iSAM2 over a window of ``lag`` seconds: an :class:`IncrementalSolver` (:attr:`solver`) whose variables stamped
    older than the lag (``update(..., timestamps={key: t})``) are marginalized after each update, but for those
    ``keep`` names (``keep="l"``: every landmark), which never age (module docstring). Its queries are the solver's."""

    def __init__(
        self,
        lag: float,
        params: ISAM2Params | None = None,
        *,
        keep: str | Callable[[Key], bool] | None = None,
        keep_history: bool = False,
        batch: float = 0.0,
        **changes: object,
    ) -> None:
        lag, batch, keep_history = number("lag", lag), number("batch", batch), flag("keep_history", keep_history)
        if not lag > 0:
            raise SteamError(f"lag must be a number of seconds > 0, got lag={lag!r}")
        if not (keep is None or callable(keep) or (isinstance(keep, str) and keep.isalpha())):
            raise SteamError(f"keep must be key symbols such as 'l', or a predicate on a key, got keep={keep!r}")
        if not 0 <= batch < math.inf:
            raise SteamError(f"batch must be a number of seconds >= 0, got batch={batch!r}")
        self.keeps = (lambda k: k.symbol in keep) if isinstance(keep, str) else keep or (lambda _: False)  # never ages
        self.solver = IncrementalSolver(params, **changes)  # the window's iSAM2
        self.lag = float(lag)  # seconds of history kept
        self.batch = float(batch)  # seconds more the window may hold, to marginalize in batches (0: at every update)
        self._times: dict[Key, float] = {}  # timestamp of each timed variable in the window, kept ones excepted
        self._gone = Marginalized()  # the update that marginalized each key (any id a Key holds)
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

        Raises :class:`UnknownVariableError` for a factor or timestamp naming a marginalized variable. Update,
        marginalization and their record are one transaction: a failure or a Ctrl-C leaves the smoother as it was."""
        check_new_values(new_values)  # before anything reads it as a mapping
        times = self._checked_times(timestamps, new_values)
        factors = check_factors("new_factors", new_factors)
        fresh = () if new_values is None else new_values
        for k in dict.fromkeys(k for f in factors for k in f.keys if k not in fresh):
            self._held("a new factor names", k)
        with self.solver.transaction() as log, limit():  # the limit is left inside: an interrupt there undoes all
            report = self.solver.update(factors, new_values, relinearize=relinearize, constrained=self._leaving())
            self._forget_old(log, report.step, fresh, times)
        return report

    def _leaving(self) -> KeysBelow | None:
        """To eliminate first: the timed keys older than the newest, once one was forgotten (before: plain iSAM2)."""
        return KeysBelow(self._times, self.newest) if self.n_marginalized else None

    def _forget_old(self, log: UndoLog, step: int, fresh: Iterable[Key], times: dict[Key, float]) -> None:
        """After update ``step``: record its timestamps, marginalize what fell behind the lag (each change in ``log``)."""
        for name in ("newest", "n_marginalized", "peak_window", "last_marginalization"):
            log.record(setattr, self, name, getattr(self, name))
        log.keep(self._times)  # ordered: the next marginalization's order follows it
        for k in fresh:
            if self._gone.get(k):
                self._gone.set(log, k, 0)  # a marginalized variable given anew is a new variable
        self.newest = max(self.newest, *times.values()) if times else self.newest
        self._times.update((k, t) for k, t in times.items() if not self.keeps(k))
        self.peak_window = max(self.peak_window, len(self.solver))
        cutoff = self.newest - self.lag
        old = [k for k, t in self._times.items() if t < cutoff]
        self.last_marginalization = None
        if self.batch and old:  # once one is older than lag + batch: the whole subtrees, or all if one would stay
            due = min(self._times[k] for k in old) < (late := cutoff - self.batch)
            cut = {k for c in cuttable(self.tree, old) for k in self.tree.cliques[c].frontals} if due else set()
            stays = [k for k in old if k not in cut and self._times[k] < late]
            old = old if stays else [k for k in old if k in cut]
        if old:
            alpha, keep = self.solver.params.wildfire_threshold, self.history is not None  # as marginalize_leaves
            done = marginalize_keys(self.solver.state, old, alpha, self._leaving(), keep, self.batch > 0)
            if self.history is not None:
                log.extend(self.history.conditionals, list(done.conditionals))
            for k in done.keys:
                self._gone.set(log, k, step)
                del self._times[k]
            self.n_marginalized += len(done.keys)
            self.last_marginalization = done

    def _checked_times(
        self, timestamps: Mapping[Key, float] | None, new_values: Mapping[Key, NDArray] | None
    ) -> dict[Key, float]:
        """The timestamps as floats; each names a held variable or a new one."""
        if timestamps is None:
            return {}
        if not isinstance(timestamps, Mapping):
            raise SteamError(f"timestamps must be a mapping key -> seconds (or None), got {timestamps!r}")
        out, new = {}, () if new_values is None else new_values
        for k, t in timestamps.items():
            if not isinstance(k, Key):
                raise SteamError(
                    f"timestamps has the key {k!r:.80}, which is not a variable key (make one with X(i) or L(j))"
                )
            if k not in new:
                self._held("timestamps names", k)
                if not self.solver.holds(k):
                    raise UnknownVariableError(f"timestamps names {k!r}, which is neither held nor in new_values")
            out[k] = number(f"timestamps[{k!r}]", t)
        return out

    def _held(self, what: str, key: Key) -> None:
        """UnknownVariableError when ``key`` was marginalized, saying when."""
        gone = self._gone.get(key)
        if gone:
            raise UnknownVariableError(
                f"{what} {key!r}, which was marginalized at update {gone} "
                f"(its timestamp fell more than the lag, {self.lag:g} s, behind the newest; keep= keeps a map)"
            )

    def smoothed_history(self) -> dict[Key, NDArray]:
        """Every marginalized variable's estimate given all the data so far (:meth:`.History.smooth`; needs
        ``keep_history=True``), through the conditionals frozen at marginalization [derivations Eq. 10.5]: for a
        linear problem, the batch optimum (:mod:`.history`). A landmark forgotten and back in the window appears here
        as its *previous* incarnation, under the same key: merged over :meth:`estimate`, it would hide the live one."""
        if self.history is None:
            raise SteamError("smoothed_history needs the conditionals: make the smoother with keep_history=True")
        return self.history.smooth(self.estimate_of)

    def was_marginalized(self, key: Key) -> bool:
        """True when ``key`` was held once and has been marginalized."""
        return bool(self._gone.get(key))

    @property
    def timestamps(self) -> dict[Key, float]:
        """The timestamp of each variable of the window that ages (a copy; no kept one)."""
        return dict(self._times)

    # --- the solver's queries ---------------------------------------------------------------------------------

    tree = property(lambda self: self.solver.tree, doc="The window's Bayes tree.")
    factors = property(lambda self: self.solver.factors, doc="Every factor (a marginalized one's slot None).")
    linearization_point = property(lambda self: self.solver.linearization_point, doc="θ̄ of the window (a copy).")
    __len__ = lambda self: len(self.solver)  # the variables in the window

    def kind_of(self, key: Key) -> Manifold:
        """How one variable of the window moves, as ``IncrementalSolver.kind_of``; a forgotten one is named so."""
        return self.solver.kind_of(self._known([check_key("key", key)], "the kind of")[0])

    def __repr__(self) -> str:
        return f"<FixedLagSmoother of lag {self.lag:g} s, {self.n_marginalized} marginalized: {self.solver!r}>"

    def holds(self, key: Key) -> bool:
        """True when ``key`` is in the window."""
        return self.solver.holds(key)

    def estimate(self) -> Values:
        """The window's estimate θ̄ ⊕ δ (a snapshot)."""
        return self.solver.estimate()

    def estimate_of(self, key: Key) -> NDArray:
        """The estimate of one variable of the window (read-only)."""
        return self.solver.estimate_of(self._known([check_key("key", key)], "the estimate of")[0])

    def marginal_covariance(self, key: Key) -> NDArray:
        """:meth:`IncrementalSolver.marginal_covariance` of a variable of the window."""
        return self.solver.marginal_covariance(self._known([check_key("key", key)])[0])

    def marginal_covariances(self, keys: Iterable[Key] | None = None) -> dict[Key, NDArray]:
        """:meth:`IncrementalSolver.marginal_covariances` of variables of the window (all of them when None)."""
        return self.solver.marginal_covariances(None if keys is None else self._known(key_list("keys", keys)))

    def joint_covariance(self, keys: Iterable[Key]) -> NDArray:
        """:meth:`IncrementalSolver.joint_covariance` of variables of the window."""
        return self.solver.joint_covariance(self._known(key_list("keys", keys)))

    def joint_covariances(self, groups: Iterable[Iterable[Key]]) -> list[NDArray]:
        """:meth:`IncrementalSolver.joint_covariances` of groups of variables of the window."""
        checked = key_groups(groups)
        self._known([k for g in checked for k in g])
        return self.solver.joint_covariances(checked)

    def _known(self, keys: list[Key], what: str = "the covariance of") -> list[Key]:
        """``keys``, after UnknownVariableError for one that was marginalized, saying when."""
        for k in keys:
            self._held(what, k)
        return keys
