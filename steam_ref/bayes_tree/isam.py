"""Incremental updates of the Bayes tree: iSAM2, the paper's Algorithm 1.  [YIB Alg. 1, K12 Alg. 4]

One :meth:`IncrementalSolver.update` is one step of [K12 Alg. 4], and ``_update`` lists its steps in that numbering,
each with its step of [YIB Alg. 1]: (1-2) store the new factors F′ and variables; (3) fluid relinearization
[K12 Alg. 5] of θ_rl, the variables whose δ reached the threshold β, which [YIB] numbers 7, the end of the previous round: iSAM2
collects the candidates while computing δ and moves θ̄ at the start of the next update (every
``relinearize_skip``-th); (4) redo the top of the tree for θ_aff = θ_nf ∪ θ_rl [K12 Alg. 6, YIB steps 2-5]: remove the
cliques holding θ_aff and their ascendants, linearize the factors of the removed part that are new or touch θ_rl (the
others keep their cached linearization), add the orphans' cached marginal factors f(S), order with the variables of F′
last, eliminate, attach back the orphans; (5) partial back-substitution, descending only where δ changes by at least
the wildfire threshold α [K12 Alg. 7, YIB step 6]; (6) the estimate θ̄ ⊕ δ, formed lazily when asked for.

Every step costs time in proportion to the removed part and the cliques back-substitution visits: nothing walks the
whole tree. Each update returns an :class:`UpdateReport` (the affected top of the tree [K12 Fig. 3-4], the phases'
times, the fill). Every store lives in one :class:`~.state.SolverState`, whose undo log records each change before
it is made: a failed or interrupted update leaves the solver as it was.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Iterator, Mapping
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from .. import covariance
from ..arguments import flag, real_array
from ..errors import ShapeError, SteamError, UnderdeterminedError, UnknownVariableError
from ..factors import Factor, check_factors, kinds_of, wrong_size
from ..linear.ordering import check_constrained, min_degree_keys
from ..linear.system import linearize
from ..linear.threads import limit
from ..manifold import Manifold, by_kind
from ..variables import Key, Values, check_key, check_new_values, key_list
from .backsolve import backsubstitute
from .dot import tree_nnz
from .marginalization import MarginalizationReport, marginalize_keys
from .params import ISAM2Params
from .state import SolverState
from .tree import BayesTree, Clique, eliminate
from .undo import UndoLog

__all__ = ["IncrementalSolver", "UpdateReport", "marginalize"]


class PhaseTimer:
    """Wall time of each phase of one update: ``with timer("remove"): ...`` writes ``seconds["remove"]``."""

    def __init__(self) -> None:
        self.start = time.perf_counter()  # when the update began
        self.seconds: dict[str, float] = {}  # phase → seconds

    @contextmanager
    def __call__(self, phase: str) -> Iterator[None]:
        t = time.perf_counter()
        yield
        self.seconds[phase] = time.perf_counter() - t

    def total(self) -> float:
        """Seconds since the update began."""
        return time.perf_counter() - self.start


@dataclass(frozen=True, kw_only=True)
class UpdateReport:
    """What one update did, so a notebook can show the affected top of the tree (built by keyword only); its repr
    leaves out the six tuples of ids and keys, as long as the tree on a first update (read them by name)."""

    step: int  # number of this update, from 1
    removed_cliques: tuple[int, ...] = field(repr=False)  # ids of the cliques taken off the top (of the tree before)
    new_cliques: tuple[int, ...] = field(repr=False)  # ids of the cliques made by re-elimination
    orphans: tuple[int, ...] = field(repr=False)  # ids of the subtrees kept and reattached
    relinearized: tuple[Key, ...] = field(repr=False)  # θ_rl: variables whose linearization point moved
    reeliminated: tuple[Key, ...] = field(repr=False)  # eliminated anew, in order (frontals of the new cliques)
    updated: tuple[Key, ...] = field(repr=False)  # variables whose increment δ (hence estimate) was recomputed
    linearized_factors: int  # factors linearized in this update (the new ones included)
    backsubstituted_cliques: int  # cliques whose conditional was solved
    time_s: float  # wall time of the whole update
    timings: dict[str, float] = field(default_factory=dict)  # seconds per phase (check, add, ..., backsubstitute)
    tree_nnz: int = 0  # nonzeros of R after the update, counted as GTSAM's ISAM2::treeNnz (bayes_tree/dot.py)


class IncrementalSolver:
    """iSAM2 on the Bayes tree: BTGP's incremental solver.  [YIB Alg. 1, K12 Alg. 4]

    ``params`` (default :class:`ISAM2Params`, GTSAM's defaults) sets the relinearization and wildfire thresholds;
    keyword ``changes`` override its fields, so ``IncrementalSolver(relinearize_skip=1, wildfire_threshold=0)`` works.
    """

    def __init__(self, params: ISAM2Params | None = None, **changes: object) -> None:
        params = ISAM2Params() if params is None else params
        if not isinstance(params, ISAM2Params):
            raise SteamError(f"params must be an ISAM2Params or None, got params={params!r}")
        self.params = params.replace(**changes) if changes else params  # the settings, validated
        self.state = SolverState()  # every store, the Bayes tree and the undo log (state.py)

    @property
    def tree(self) -> BayesTree:
        """The current Bayes tree."""
        return self.state.tree

    # --- queries ----------------------------------------------------------------------------

    def estimate(self) -> Values:
        """The current estimate θ̄ ⊕ δ of every variable (a snapshot; the arrays are read-only); only the variables
        whose δ changed since the last call are recomputed."""
        return Values.adopt(self.state.all_estimates(), self.state.kinds)  # the arrays are never written in place

    def estimate_of(self, key: Key) -> NDArray:
        """The current estimate θ̄ ⊕ δ of one variable (read-only)."""
        return self.estimates_of([check_key("key", key)])[key]

    def estimates_of(self, keys: Iterable[Key]) -> dict[Key, NDArray]:
        """The current estimate of each of ``keys`` (read-only), those whose δ moved formed in one call per kind; a key
        named twice is refused (the answer, a mapping by key, would hold it once)."""
        try:
            return self.state.estimates_of(key_list("keys", keys, distinct=True))
        except KeyError as exc:
            raise UnknownVariableError(f"variable {exc.args[0]!r} is not in the solver") from None

    @property
    def factors(self) -> tuple[Factor, ...]:
        """Every factor so far, in the order added (a tuple: the solver's caches are indexed by position); the slot
        of a factor :meth:`marginalize_leaves` dropped holds None."""
        return self.state.factor_slots()  # type: ignore[return-value]  # a dropped slot is None (docstring)

    @property
    def linearization_point(self) -> Values:
        """θ̄: where each factor of the tree was linearized (a copy)."""
        return self.state.values().copy()

    def delta(self) -> dict[Key, NDArray]:
        """The current increments δ (a copy), in the tangent space at :attr:`linearization_point`."""
        return {k: v.copy() for k, v in self.state.delta.items()}

    def holds(self, key: Key) -> bool:
        """True when ``key`` is a variable of the solver."""
        return key in self.state.dims

    def kind_of(self, key: Key) -> Manifold:
        """How one variable moves (:mod:`steam_ref.manifold`), the kind its factors gave it."""
        if not self.holds(check_key("key", key)):
            raise UnknownVariableError(f"variable {key!r} is not in the solver")
        return self.state.kinds[key]

    def marginal_covariance(self, key: Key) -> NDArray:
        """Cov(δθ_key) (d, d) of the current linear system, from the Bayes tree, in the tangent at
        :attr:`linearization_point` θ̄, not at the estimate θ̄ ⊕ δ (an SE(2) state's pose block in its body frame at θ̄:
        :mod:`steam_ref.covariance`). A query changes nothing the solver holds.  [K11 Sec. 3]"""
        return covariance.tree_marginal_covariance(self.tree, check_key("key", key))

    def marginal_covariances(self, keys: Iterable[Key] | None = None) -> dict[Key, NDArray]:
        """Marginal covariance (dₖ, dₖ) of each of ``keys`` (every variable when None), in one pass down the tree; a
        key named twice is refused (the answer, a mapping by key, would hold it once)."""
        return covariance.tree_marginal_covariances(self.tree, None if keys is None else key_list("keys", keys))

    def joint_covariance(self, keys: Iterable[Key]) -> NDArray:
        """Joint covariance (Σdₖ, Σdₖ) of several variables, stacked in the order given, from the tree."""
        return covariance.tree_joint_covariance(self.tree, key_list("keys", keys))

    def joint_covariances(self, groups: Iterable[Iterable[Key]]) -> list[NDArray]:
        """Joint covariance of each group of variables (stacked in the order given), from the tree."""
        return covariance.tree_joint_covariances(self.tree, covariance.key_groups(groups))

    def __len__(self) -> int:
        return len(self.state.dims)

    def __repr__(self) -> str:  # what it holds; its settings are ``params``
        held = f"{len(self)} variables, {self.state.n_factors} factors, {len(self.tree)} cliques"
        return f"<IncrementalSolver after {self.state.steps} updates: {held}>"

    # --- the update -------------------------------------------------------------------------

    def update(
        self,
        new_factors: Factor | Iterable[Factor] = (),
        new_values: Mapping[Key, NDArray] | None = None,
        *,
        relinearize: bool = True,
        constrained: Mapping[Key, float] | None = None,
    ) -> UpdateReport:
        """Add factors and variables, and update the tree and the estimate.  [YIB Alg. 1, K12 Alg. 4]

        Each new variable is of the kind its factors declare (``new_values`` may be a plain mapping). ``relinearize``
        False skips this update's fluid relinearization; ``constrained`` (GTSAM's ``constrainedKeys``): keys to
        eliminate first, by increasing number (:func:`~steam_ref.linear.ordering.min_degree_keys`); as in GTSAM, a key
        this update does not re-eliminate, held or not, is ignored (one ranking of all states serves every update). Raises
        :class:`SteamError` subclasses on bad input (a new value for a held variable, a factor naming a variable with
        no value, a variable left unconstrained, a :class:`~steam_ref.errors.KindError`...), the solver as it was."""
        timer = PhaseTimer()
        with timer("check"):
            flag("relinearize", relinearize)
            check_constrained(constrained)
            F_new = check_factors("new_factors", new_factors)
            check_new_values(new_values, self.state.dims)
            theta_new, kinds = self._checked_update(F_new, {} if new_values is None else new_values)
        # an error, or Ctrl-C (KeyboardInterrupt) at any point: all undone; the BLAS limit is left inside the transaction
        with self.state.transaction(), limit():
            return self._update(F_new, theta_new, kinds, relinearize, constrained, timer)

    def transaction(self) -> AbstractContextManager[UndoLog]:
        """Changes as one: all undone if anything inside raises (Ctrl-C too), the caller's recorded in the log yielded."""
        return self.state.transaction()

    def marginalize_leaves(
        self, keys: Iterable[Key], *, constrained: Mapping[Key, float] | None = None, keep_conditionals: bool = False
    ) -> MarginalizationReport:
        """Marginalize ``keys`` out of the tree and the factors (GTSAM's ``marginalizeLeaves``; keys not in leaf
        cliques are re-eliminated first, ``constrained`` as in :meth:`update`): :mod:`.marginalization`. The solver
        then holds the marginal of the other variables (for a linear problem, their estimate and covariances are the
        whole problem's, to rounding). ``keep_conditionals``: the report carries each key's P(v | S)
        (:class:`~.history.ForgottenConditional`). :class:`UnknownVariableError` for a key not held, :class:`SteamError` for
        a ``constrained`` that is no mapping or a ``keep_conditionals`` that is no bool, the solver as it was."""
        return marginalize_keys(self.state, keys, self.params.wildfire_threshold, constrained, keep_conditionals)

    def _update(
        self,
        F_new: list[Factor],
        theta_new: dict[Key, NDArray],
        kinds: Mapping[Key, Manifold],
        relinearize: bool,
        constrained: Mapping[Key, float] | None,
        timer: PhaseTimer,
    ) -> UpdateReport:
        """One step of iSAM2, numbered as [K12 Alg. 4], with the steps of [YIB Alg. 1] (module docstring)."""
        state = self.state
        state.steps += 1
        # 1-2. F ← F ∪ F′, Θ ← Θ ∪ Θ′ (θ̄ = initial value, δ = 0); θ_nf: the variables of F′.   [YIB step 1]
        with timer("add"):
            new_ids = state.append_factors(F_new)
            for k, x in theta_new.items():
                state.add_variable(k, x, kinds[k], self.params.threshold_for(k.symbol))
            theta_nf = list(dict.fromkeys(k for f in F_new for k in f.keys))
        # 3. Fluid relinearization, θ̄ ← θ̄ ⊕ δ for θ_rl, with the δ of the last update: [YIB] step 7
        #    of the previous round, which iSAM2 does here, every relinearize_skip-th update. [K12 Alg. 5]
        with timer("relinearize"):
            due = relinearize and state.steps % self.params.relinearize_skip == 0
            theta_rl = self._fluid_relinearization() if due else []
        # 4. Redo the top of the tree for θ_aff = θ_nf ∪ θ_rl.                  [K12 Alg. 6; YIB steps 2-5]
        # 4a. Remove the cliques of θ_aff and their ascendants; the orphans stay. [YIB step 2]
        with timer("remove"):
            removed, orphans = self._remove_top(theta_nf, theta_rl)
        # 4b. Linearize the factors of the removed part that are new or touch θ_rl. [YIB step 3, Eq. 9, 29]
        with timer("linearize"):
            fids = [j for c in removed.values() for j in c.factors] + new_ids
            n_linearized = self._relinearize(fids, set(theta_rl))
        # 4c. Add the cached marginal factors f(S) of the orphans.                [YIB step 4]
        # 4d. Order the removed part by constrained minimum degree, θ_nf last.    [K12 Sec. 4.2]
        with timer("order"):
            linear = [state.cached(j) for j in fids] + [self.tree.cliques[o].marginal for o in orphans]
            variables = [k for c in removed.values() for k in c.frontals] + list(theta_new)
            order = min_degree_keys(variables, state.dims, [f.keys for f in linear], theta_nf, constrained)
        # 4e. Eliminate into new cliques and attach back the orphans.   [YIB step 5, Eq. 24-25]
        with timer("eliminate"):
            ids, zeros = fids + [None] * len(orphans), self.params.amalgamation_zeros
            cliques, parents, owner = eliminate(order, linear, state.dims, ids, zeros)
            new_cids = self.tree.insert_eliminated(cliques, parents, orphans, owner[len(fids) :])
        # 5. Partial back-substitution from the root, stopping below α.  [K12 Alg. 7; YIB step 6]
        with timer("backsubstitute"):
            updated, visited = backsubstitute(state, set(new_cids), self.params.wildfire_threshold)
        state.tree_nnz += tree_nnz(cliques) - tree_nnz(removed.values())
        return UpdateReport(
            step=state.steps, removed_cliques=tuple(removed), new_cliques=tuple(new_cids), orphans=tuple(orphans),
            relinearized=tuple(theta_rl), reeliminated=tuple(order), updated=tuple(updated),
            linearized_factors=n_linearized, backsubstituted_cliques=visited, time_s=timer.total(),
            timings=timer.seconds, tree_nnz=state.tree_nnz,
        )  # fmt: skip

    def _checked_update(
        self, new_factors: list[Factor], new_values: Mapping[Key, NDArray]
    ) -> tuple[dict[Key, NDArray], Mapping[Key, Manifold]]:
        """Validate an update before anything changes: the new values as float vectors, and the kind of each
        variable the new factors name, from their declarations (refused when one contradicts another, the solver or
        a kind given in ``Values(kinds=)``), each new value checked against its kind."""
        values: dict[Key, NDArray] = {}
        for k, v in new_values.items():
            if not isinstance(k, Key):
                raise SteamError(
                    f"new_values has the key {k!r}, which is not a variable key (make one with X(i) or L(j))"
                )
            x = real_array(f"new_values[{k!r}]", v)
            if x.ndim != 1 or x.shape[0] == 0:
                raise ShapeError(f"new_values[{k!r}] must be a non-empty 1-D vector, got shape {x.shape}")
            if not np.all(np.isfinite(x)):
                raise ShapeError(f"new value of {k!r} is not finite: {x}")
            self.params.threshold_for(k.symbol)  # a dict of thresholds must name every symbol
            self.params.blocks_of(k.symbol, x.shape[0])  # relinearization blocks must fit the variable
            values[k] = x
        for f in new_factors:
            for k, dim in zip(f.keys, f.key_dims, strict=True):
                have = values[k].shape[0] if k in values else self.state.dims.get(k)
                if have is None:
                    raise UnknownVariableError(
                        f"{type(f).__name__} names {k!r}, which has no value: give it one in new_values"
                    )
                if have != dim:
                    raise wrong_size(f, k, dim, have)
        named = {k for f in new_factors for k in f.keys}
        for k in values:
            if k not in named:
                raise UnderdeterminedError(f"new variable {k!r} is named by no new factor, so nothing constrains it")
        kinds = kinds_of(new_factors, self.state.kinds)
        if isinstance(new_values, Values):
            new_values.check_kinds(kinds, "its factors")
        for k, x in values.items():
            kinds[k].check(f"new_values[{k!r}]", x)
        return values, kinds

    def _fluid_relinearization(self) -> list[Key]:
        """θ̄ ← θ̄ ⊕ δ, δ ← 0 for θ_rl, the variables whose max abs(δ) ≥ β; returns θ_rl.  [K12 Alg. 5]

        With ``relinearize_blocks``, only a vector's blocks whose own max abs(δ) ≥ β move (another kind moves
        whole: :meth:`~steam_ref.manifold.Manifold.rebase_many`, one call per kind; the estimate is unchanged).
        Back-substitution keeps the candidates ([YIB Alg. 1 step 7]: collect them into θ_rl)."""
        state = self.state
        theta_rl = list(state.candidates)
        moves = {k: self.params.blocks_to_move(k.symbol, state.delta[k], state.beta[k]) for k in theta_rl}  # (d,) bool
        state.candidates.clear()  # the transaction kept them whole
        for kind, keys in by_kind(theta_rl, state.kinds):
            thetas, deltas = kind.rebase_many(
                [state.theta_bar[k] for k in keys], [state.delta[k] for k in keys], [moves[k] for k in keys]
            )
            for k, theta_bar, delta in zip(keys, thetas, deltas, strict=True):
                state.move(k, theta_bar, delta)
        return theta_rl

    def _remove_top(self, theta_nf: list[Key], theta_rl: list[Key]) -> tuple[dict[int, Clique], list[int]]:
        """Remove the cliques of θ_aff = θ_nf ∪ θ_rl and their ascendants: ``(removed, orphans)``.  [K12 Alg. 6]
        A variable of θ_nf affects the clique where it is frontal (a new one is in none yet); a relinearized one
        every clique holding it, whose conditionals were computed at its old θ̄."""
        start = [self.tree.frontal_of[k] for k in theta_nf if k in self.tree.frontal_of]
        for k in theta_rl:
            start.extend(self.tree.cliques_involving(k))
        return self.tree.remove_top(start)  # recorded in the state's undo log

    def _relinearize(self, fids: list[int], theta_rl: set[Key]) -> int:
        """Linearize, at θ̄, the factors among ``fids`` that are new or touch θ_rl; returns how many.  [YIB Eq. 9]"""
        state = self.state
        linear, factors = state.linear, state.factors
        need = [j for j in fids if linear[j] is None or (theta_rl and not theta_rl.isdisjoint(factors[j].keys))]
        if need:
            for group in linearize([factors[j] for j in need], state.values()):
                for i, gf in zip(group.factor_ids, group.gaussian_factors(), strict=True):
                    state.set_linear(need[i], gf)
        return len(need)


def marginalize(
    solver: IncrementalSolver, keys: Iterable[Key], *, keep_conditionals: bool = False
) -> MarginalizationReport:
    """:meth:`IncrementalSolver.marginalize_leaves` (a FixedLagSmoother is none: it forgets by its timestamps)."""
    if not isinstance(solver, IncrementalSolver):
        raise SteamError(f"marginalize: solver must be an IncrementalSolver, got {type(solver).__name__}")
    return solver.marginalize_leaves(keys, keep_conditionals=keep_conditionals)
