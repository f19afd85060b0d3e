"""The factor graph: the factors f_i(θ_i) whose product is the joint density.  [YIB Eq. 20]

A :class:`FactorGraph` is a list of factors; its variables are the keys the factors name
(:mod:`steam_ref.variables`), and its cost at an estimate is the sum of the factors' costs,
evaluated by the linearization layer (:func:`steam_ref.linear.system.linearize`).
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator

from .errors import ShapeError, SteamError
from .factors import Factor
from .linear.system import linearize
from .variables import Key, Values

__all__ = ["FactorGraph"]


class FactorGraph:
    """A list of factors; the variables are the keys the factors name.  [YIB Eq. 20]"""

    def __init__(self, factors: Iterable[Factor] = ()):
        self.factors: list[Factor] = []
        self.add(factors)

    def add(self, factors: Factor | Iterable[Factor]) -> None:
        """Append one factor or several."""
        if isinstance(factors, Factor):
            factors = [factors]
        for f in factors:
            if not isinstance(f, Factor):
                raise SteamError(f"FactorGraph.add expects factors, got {type(f).__name__}")
            self.factors.append(f)

    def __len__(self) -> int:
        return len(self.factors)

    def __iter__(self) -> Iterator[Factor]:
        return iter(self.factors)

    def __getitem__(self, i: int) -> Factor:
        return self.factors[i]

    def keys(self) -> list[Key]:
        """Every variable some factor names, in first-seen order."""
        seen: dict[Key, None] = {}
        for f in self.factors:
            for k in f.keys:
                seen.setdefault(k)
        return list(seen)

    def check_values(self, values: Values) -> None:
        """Raise if a factor names a variable without an estimate, or of the wrong size."""
        for f in self.factors:
            for k, d in zip(f.keys, f.key_dims):
                if values.dim(k) != d:
                    raise ShapeError(f"{type(f).__name__} expects {k} of size {d}, estimate has {values.dim(k)}")

    def error(self, values: Values) -> float:
        """The cost Σ ρᵢ(‖Wᵢeᵢ‖) of Eq. 6 at the given estimates: ρ(s) = s²/2 for a plain factor,
        its robust loss otherwise (GTSAM's convention)."""
        return sum(group.cost for group in linearize(self.factors, values, jacobians=False))

    def __repr__(self) -> str:
        return f"FactorGraph({len(self)} factors)"
