"""The past a fixed-lag smoother forgot, kept small, and smoothed once the run is over.  [derivations §10.5]

Marginalizing D out of the tree (:func:`~steam_ref.bayes_tree.marginalization.marginalize`) splits the
linearized problem into the conditional P(D | S), one variable v at a time [YIB Eq. 24-25],

    R_v δ_v + S_v δ_S = d_v,

and the marginal on the rest. A fixed-lag smoother drops the conditional; the window keeps the marginal. Kept instead,
the conditionals are a Bayes net of the forgotten variables given the ones after them: the whole run's posterior is

    p(everything) = p(window at the end) · Π_v P(v | S_v),

so once the run is over one pass from the newest conditional to the oldest gives every forgotten
variable its estimate given all the data, as a Rauch-Tung-Striebel backward pass does:

    x_v = θ̄_v ⊕ R_v⁻¹ (d_v - S_v (x_S ⊖ θ̄_S)),       (derivations Eq. 10.5)

(⊕, ⊖ by each variable's kind: + and - for a vector), θ̄ the linearization point when v was marginalized (the
conditional is frozen there, as the marginal factor), x_S the final estimate of each separator variable: the window's,
or one this pass has already computed. For a linear problem the result is the batch optimum of every factor ever given,
to rounding (tests/test_fixed_lag_history.py); for a nonlinear one, the optimum of the linearizations frozen at each
marginalization, off by how far the separator moved since, and not always closer to the truth than the lagged
estimates (figures: docs/experiments.md).

Each conditional is kept in solved form, x_v = m_v + K_v (x_S - θ̄_S) with m_v = θ̄_v + R_v⁻¹ d_v and K_v = -R_v⁻¹ S_v
(θ̄_v ⊕ (R_v⁻¹ d_v + K_v (x_S ⊖ θ̄_S)) for other kinds): memory grows with the run again, by a fraction of what the
whole tree would hold; the window's does not.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import solve_triangular

from ..manifold import VECTOR, Manifold
from ..variables import Key
from .tree import Clique

__all__ = ["ForgottenConditional", "History"]


@dataclass(frozen=True, eq=False)
class ForgottenConditional:
    """P(v | S) of a marginalized variable, solved: x_v = mean + gain (x_S - θ̄_S).  [derivations Eq. 10.5]"""

    key: Key
    separator: tuple[Key, ...]
    separator_dims: tuple[int, ...]
    mean: NDArray  # (n_v,) θ̄_v + R⁻¹ d: x_v when every separator variable sits at its θ̄
    gain: NDArray  # (n_v, n_S) -R⁻¹ S
    theta_separator: NDArray  # (n_S,) θ̄_S stacked, the linearization point when v was marginalized
    # Only when v or a separator variable is not a vector: θ̄_v (``mean`` is then R⁻¹d, a tangent step), and
    # the kind of v and of each separator variable.
    theta: NDArray | None = None
    kinds: tuple[Manifold, ...] = ()  # (v's, then each separator variable's)

    @classmethod
    def of(
        cls, clique: Clique, theta_bar: Mapping[Key, NDArray], kinds: Mapping[Key, Manifold] | None = None
    ) -> ForgottenConditional:
        """The solved form of the one-variable conditional ``clique`` linearized at ``theta_bar``."""
        (key,) = clique.frontals
        ns = clique.S.shape[1]
        RinvS = solve_triangular(clique.R, clique.S) if ns else np.zeros((clique.R.shape[0], 0))
        theta_s = np.concatenate([theta_bar[k] for k in clique.separator]) if clique.separator else np.zeros(0)
        of = tuple((kinds or {}).get(k, VECTOR) for k in (key, *clique.separator))
        step = solve_triangular(clique.R, clique.d)
        if all(m is VECTOR for m in of):
            return cls(
                key, clique.separator, clique.separator_dims, np.asarray(theta_bar[key], float) + step, -RinvS, theta_s
            )
        theta = np.asarray(theta_bar[key], dtype=float)
        return cls(key, clique.separator, clique.separator_dims, step, -RinvS, theta_s, theta, of)

    def value(self, separator_values: NDArray) -> NDArray:
        """x_v given the stacked final estimates of the separator (n_S,).  [derivations Eq. 10.5]"""
        if self.theta is None:  # every variable a vector
            if not self.separator:
                return self.mean.copy()
            return self.mean + self.gain @ (separator_values - self.theta_separator)
        local, o = [], 0
        for kind, d in zip(self.kinds[1:], self.separator_dims, strict=True):
            local.append(kind.local(self.theta_separator[o : o + d], separator_values[o : o + d]))  # x_S ⊖ θ̄_S
            o += d
        step = self.mean + self.gain @ np.concatenate(local) if local else self.mean
        return np.asarray(self.kinds[0].retract(self.theta, step), dtype=float)


class History:
    """The conditionals of every marginalized variable, in the order they were eliminated."""

    def __init__(self) -> None:
        self.conditionals: list[ForgottenConditional] = []

    def __len__(self) -> int:
        return len(self.conditionals)

    def smooth(self, window: Callable[[Key], NDArray]) -> dict[Key, NDArray]:
        """Every forgotten variable's estimate given all the data, through the conditionals frozen when it was
        forgotten: the backward pass of the module docstring.

        ``window(key)`` is the final estimate of a variable still held. Conditionals are solved newest first,
        so each one's separator is either in the window or solved already. A variable forgotten twice (a
        landmark seen again after it left the window enters as a new variable) is solved for each
        incarnation in turn, each older conditional seeing the incarnation it was made with; the returned
        dict holds the latest incarnation forgotten.
        """
        solved: dict[Key, NDArray] = {}  # the incarnation the conditionals solved so far name
        latest: dict[Key, NDArray] = {}
        for c in reversed(self.conditionals):
            parts = [solved[k] if k in solved else window(k) for k in c.separator]
            solved[c.key] = c.value(np.concatenate(parts) if parts else np.zeros(0))
            latest.setdefault(c.key, solved[c.key])
        return latest
