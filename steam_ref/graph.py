"""The factor graph: the factors f_i(θ_i) whose product is the joint density.  [YIB Eq. 20]

A :class:`FactorGraph` is a list of factors; its variables are the keys the factors name
(:mod:`steam_ref.variables`), each of the kind its factors declare (:attr:`~steam_ref.factors.Factor.key_kinds`,
checked as factors are added), and its cost at an estimate is the sum of the factors' costs,
evaluated by the linearization layer (:func:`steam_ref.linear.system.linearize`).
"""

from __future__ import annotations

import operator
from collections.abc import Iterable, Iterator

from .errors import UnknownVariableError
from .factors import Factor, check_factors, kinds_of, wrong_size
from .linear.system import Batches
from .manifold import Manifold
from .variables import Key, Values, as_values

__all__ = ["FactorGraph"]


class FactorGraph:
    """A list of factors; the variables are the keys the factors name.  [YIB Eq. 20]"""

    def __init__(self, factors: Iterable[Factor] = ()):
        self.factors: list[Factor] = []  # add factors with :meth:`add`, which keeps the kinds
        self._kinds: dict[Key, Manifold] = {}  # the kind of each variable, as its factors declare it
        self._batches: Batches | None = None  # the factors grouped and stacked, when last asked (batches())
        self.add(factors)

    def add(self, factors: Factor | Iterable[Factor]) -> None:
        """Append one factor or several (any iterable of factors); nothing is added if one is not a factor, or
        declares a variable's kind other than the graph's factors do (:class:`~steam_ref.errors.KindError`)."""
        new = check_factors("factors", factors)
        self._kinds.update(kinds_of(new, self._kinds, "the graph's factors"))
        self.factors.extend(new)

    def copy(self) -> FactorGraph:
        """Another graph of the same factors (the factors themselves are shared: they never change), which
        :meth:`add` extends without changing this one."""
        out = FactorGraph()
        out.factors, out._kinds, out._batches = list(self.factors), dict(self._kinds), self._batches
        return out

    def kinds(self) -> dict[Key, Manifold]:
        """The kind of every variable, as its factors declare it (a copy)."""
        return dict(self._kinds)

    def with_kinds(self, values: Values) -> Values:
        """A copy of ``values`` whose variables have the kinds their factors declare, each value checked
        against its kind; :class:`~steam_ref.errors.KindError` for a kind given to a value otherwise."""
        return values.with_kinds(self._kinds, "its factors")

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
        """Raise if a factor names a variable without an estimate, or of the wrong size.

        ``values``: a Values or any mapping key → vector.
        """
        values = as_values("values", values)
        for i, f in enumerate(self.factors):
            for k, d in zip(f.keys, f.key_dims, strict=True):
                if k not in values:
                    raise UnknownVariableError(f"factor {i} ({type(f).__name__}) names {k!r}, which has no estimate")
                if values.dim(k) != d:
                    raise wrong_size(f, k, d, values.dim(k), "estimate")

    def error(self, values: Values) -> float:
        """The cost Σ ρᵢ(‖Wᵢeᵢ‖) of Eq. 6 at the given estimates: ρ(s) = s²/2 for a plain factor,
        its robust loss otherwise (GTSAM's convention). ``values``: a Values or any mapping key → vector."""
        return self.batches().cost(values)

    def batches(self) -> Batches:
        """The factors grouped by type and stacked (:class:`~steam_ref.linear.system.Batches`), what every
        linearization of them reads: made again only when the factors are no longer those it was made of (one
        object for one), so that a batch solve's iterations and costs group them once."""
        made = self._batches
        if (
            made is None
            or len(made.factors) != len(self.factors)
            or not all(map(operator.is_, made.factors, self.factors))
        ):
            made = self._batches = Batches(self.factors)
        return made

    def __repr__(self) -> str:
        return f"FactorGraph({len(self)} factors)"
