"""The past a fixed-lag smoother forgot, kept small, and smoothed once the run is over.  [derivations §10.5]

Marginalizing D out of the tree (:mod:`~steam_ref.bayes_tree.marginalization`) splits the
linearized problem into the conditional P(D | S), one variable v at a time [YIB Eq. 24-25],

    R_v δ_v + S_v δ_S = d_v,

and the marginal on the rest. A fixed-lag smoother drops the conditional; the window keeps the marginal. Kept instead,
the conditionals are a Bayes net of the forgotten variables given the ones after them: the whole run's posterior is

    p(everything) = p(window at the end) · Π_v P(v | S_v),

so once the run is over one pass from the newest conditional to the oldest gives every forgotten
variable its estimate given all the data, as a Rauch-Tung-Striebel backward pass does:

    x_v = θ̄_v ⊕ R_v⁻¹ (d_v - S_v (x_S ⊖ θ̄_S)),       (derivations Eq. 10.5)

(⊕, ⊖ by each variable's kind), θ̄ the linearization point when v was marginalized (the conditional is frozen there,
as the marginal factor), x_S the final estimate of each separator variable: the window's, or one this pass has already
computed. For a linear problem the result is the batch optimum of every factor ever given, to rounding
(tests/test_fixed_lag_history.py); for a nonlinear one, the optimum of the linearizations frozen at each
marginalization, and not always closer to the truth than the lagged estimates (figures: docs/experiments.md).

Each conditional is kept solved, x_v = θ̄_v ⊕ (R_v⁻¹ d_v + K_v (x_S ⊖ θ̄_S)), K_v = -R_v⁻¹ S_v (``Manifold.retract_sum``):
memory grows with the run again, by a fraction of what the whole tree would hold; the window's does not.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import solve_triangular

from ..manifold import Manifold
from ..variables import Key
from .tree import Clique
from .undo import UndoLog

__all__ = ["ForgottenConditional", "History", "Marginalized"]


@dataclass(frozen=True, eq=False)
class ForgottenConditional:
    """P(v | S) of a marginalized variable, solved: x_v = θ̄_v ⊕ (step + gain (x_S ⊖ θ̄_S)).  [derivations Eq. 10.5]"""

    key: Key
    separator: tuple[Key, ...]
    separator_dims: tuple[int, ...]
    theta: NDArray  # (n_v,) θ̄_v, the linearization point when v was marginalized
    step: NDArray  # (n_v,) R⁻¹ d: v's step when every separator variable sits at its θ̄
    gain: NDArray  # (n_v, n_S) -R⁻¹ S
    theta_separator: NDArray  # (n_S,) θ̄_S stacked
    kinds: tuple[Manifold, ...]  # the kind of v, then of each separator variable

    @classmethod
    def of(
        cls, clique: Clique, theta_bar: Mapping[Key, NDArray], kinds: Mapping[Key, Manifold], i: int = 0
    ) -> ForgottenConditional:
        """The solved form of P(v | S_v) of the ``i``-th frontal v of ``clique`` linearized at ``theta_bar``: its rows
        of [R S | d] (R upper triangular), so S_v is the frontals after v and the clique's separator [YIB Eq. 25]."""
        o, key = sum(clique.frontal_dims[:i]), clique.frontals[i]
        rows = slice(o, o + clique.frontal_dims[i])
        R, S = clique.R[rows, rows], np.hstack([clique.R[rows, rows.stop :], clique.S[rows]])
        separator = clique.frontals[i + 1 :] + clique.separator
        dims = clique.frontal_dims[i + 1 :] + clique.separator_dims
        RinvS = solve_triangular(R, S) if S.shape[1] else np.zeros((R.shape[0], 0))
        theta_s = np.concatenate([theta_bar[k] for k in separator]) if separator else np.zeros(0)
        step, of = solve_triangular(R, clique.d[rows]), tuple(kinds[k] for k in (key, *separator))
        return cls(key, separator, dims, np.asarray(theta_bar[key], dtype=float), step, -RinvS, theta_s, of)

    def value(self, separator_values: NDArray) -> NDArray:
        """x_v given the stacked final estimates of the separator (n_S,).  [derivations Eq. 10.5]"""
        if not self.separator:
            return self.kinds[0].retract_sum(self.theta, self.step, None)
        local, o = [], 0
        for kind, d in zip(self.kinds[1:], self.separator_dims, strict=True):
            local.append(kind.local(self.theta_separator[o : o + d], separator_values[o : o + d]))  # x_S ⊖ θ̄_S
            o += d
        return self.kinds[0].retract_sum(self.theta, self.step, self.gain @ np.concatenate(local))


class History:
    """The conditionals of every marginalized variable, in the order they were eliminated."""

    def __init__(self) -> None:
        self.conditionals: list[ForgottenConditional] = []

    def __len__(self) -> int:
        return len(self.conditionals)

    def smooth(self, window: Callable[[Key], NDArray]) -> dict[Key, NDArray]:
        """Every forgotten variable's estimate given all the data: the backward pass of the module docstring.

        ``window(key)`` is the final estimate of a variable still held. Conditionals are solved newest first, so each
        one's separator is in the window or solved already. A variable forgotten twice (a landmark seen again enters
        as a new variable) is solved for each incarnation in turn, each older conditional seeing the incarnation it
        was made with; the returned dict holds the latest incarnation forgotten."""
        solved: dict[Key, NDArray] = {}  # the incarnation the conditionals solved so far name
        latest: dict[Key, NDArray] = {}
        for c in reversed(self.conditionals):
            parts = [solved[k] if k in solved else window(k) for k in c.separator]
            solved[c.key] = c.value(np.concatenate(parts) if parts else np.zeros(0))
            latest.setdefault(c.key, solved[c.key])
        return latest


class Marginalized:
    """The update that marginalized each key (0: none, or given anew since): an int32 array per symbol by index, 4 bytes
    an index rather than a dict entry and a key each; an index the array would not reach, or a later update, in a dict."""

    def __init__(self) -> None:
        self.steps: dict[str, np.ndarray] = {}  # symbol → the update that marginalized each index
        self.other: dict[Key, int] = {}  # keys of a negative index, or one far past the others

    def get(self, key: Key) -> int:
        steps = self.steps.get(key.symbol, ())
        return self.other.get(key, int(steps[key.index]) if 0 <= key.index < len(steps) else 0)

    def set(self, log: UndoLog, key: Key, step: int) -> None:
        """Record ``step`` for ``key`` in the undo ``log`` (an array grown by doubling comes back whole on undo)."""
        steps = self.steps.get(key.symbol, np.zeros(0, dtype=np.int32))
        if key in self.other or not 0 <= key.index < 2 * len(steps) + 1024 or not 0 <= step < 2**31:
            log.set(self.other, key, step)
            return
        if key.index >= len(steps):  # doubled, or to reach the index, by at least 1,024
            steps = np.concatenate([steps, np.zeros(max(len(steps), key.index + 1 - len(steps), 1024), dtype=np.int32)])
            log.set(self.steps, key.symbol, steps)
        log.set(steps, key.index, step)
