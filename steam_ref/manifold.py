"""How a variable's estimate moves: the retraction x ⊕ δ and its inverse x ⊖ x₀.  [YIB Eq. 11; derivations §1]

Gauss-Newton solves for an increment δ in the tangent space at the linearization point θ̄ and moves the
estimate by θ̄ ⊕ δ [YIB Eq. 11]. For a vector state ⊕ is +; a state holding a rotation moves along the
group instead (an SE(2) pose: T ← T·Exp(δ)). The space a variable lives in is its *kind*, a
:class:`Manifold`. Every solver (batch Gauss-Newton and Levenberg-Marquardt, the Bayes tree's iSAM2, its
marginalization and marginal factors, the fixed-lag smoother's kept history) moves every variable through
its kind, and never with ``+``/``-`` on estimates: a new kind of state is one subclass here and nothing in
the solvers. A variable's kind comes from its factors (:attr:`steam_ref.factors.Factor.key_kinds`); a
solver refuses two that disagree (:class:`~steam_ref.errors.KindError`).

Rules of the seam:

- an estimate is a flat 1-D float64 array whose tangent has as many entries as it has (so every size and
  offset in the solvers is the array's length); ``local`` inverts ``retract``: ``retract(x0, local(x0, x)) == x``;
- ``retract`` and ``local`` broadcast over leading axes (a stack of variables, one per row), as every map of
  :mod:`steam_ref.lie` does: a factor batch evaluates them on stacked arrays;
- speed lives here, not in the solvers: a solver groups its variables by kind (:func:`by_kind`) and moves
  each group in one call (:meth:`Manifold.retract_many`, :meth:`Manifold.local_many`, :meth:`Manifold.rebase_many`).
  A kind's default is one call of its map on the stacked arrays; :data:`VECTOR`'s is NumPy's addition
  mapped over the arrays, bit for bit ``x + δ`` (variables of several sizes would have to be concatenated and
  split again to make it one addition, which costs more than it saves).
"""

from __future__ import annotations

from collections.abc import Hashable, Iterable, Mapping, Sequence
from typing import TypeVar

import numpy as np
from numpy.typing import NDArray

from .errors import ShapeError

__all__ = ["Manifold", "VectorSpace", "VECTOR", "by_kind"]

K = TypeVar("K", bound=Hashable)


class Manifold:
    """The space a variable lives in: a subclass gives ``name``, ``size`` and the maps ``retract`` and ``local``
    (each broadcasting over leading axes; module docstring), and may refine ``check``."""

    name = "manifold"
    size: int | None = None  # the size of a value (and of its tangent); None: any size (a vector space)

    def retract(self, x: NDArray, delta: NDArray) -> NDArray:
        """x ⊕ δ: the estimate moved by the tangent increment ``delta`` (a new array)."""
        raise NotImplementedError

    def local(self, x0: NDArray, x: NDArray) -> NDArray:
        """x ⊖ x₀: the tangent increment that moves ``x0`` to ``x`` (a new array)."""
        raise NotImplementedError

    def check(self, name: str, x: NDArray) -> NDArray:
        """``x`` itself, or a :class:`~steam_ref.errors.SteamError` naming ``name`` unless the finite 1-D array ``x``
        is a value of this kind (its size; a subclass adds its own rules, an SE(2) heading in (-π, π])."""
        if self.size is not None and x.shape != (self.size,):
            raise ShapeError(f"{name} has {x.shape[0]} numbers, but a value of kind {self.name} has {self.size}")
        return x

    def retract_many(self, xs: Sequence[NDArray], deltas: Sequence[NDArray]) -> list[NDArray]:
        """x ⊕ δ of many variables of this kind, one call of ``retract`` on the stacked arrays (new arrays)."""
        if not xs:
            return []
        return [row.copy() for row in np.asarray(self.retract(np.array(xs), np.array(deltas)), dtype=float)]

    def local_many(self, x0s: Sequence[NDArray], xs: Sequence[NDArray]) -> list[NDArray]:
        """x ⊖ x₀ of many variables of this kind, one call of ``local`` on the stacked arrays (new arrays)."""
        if not xs:
            return []
        return [row.copy() for row in np.asarray(self.local(np.array(x0s), np.array(xs)), dtype=float)]

    def rebase_many(
        self,
        xs: Sequence[NDArray],
        deltas: Sequence[NDArray],
        moves: Sequence[NDArray],  # noqa: ARG002 - whole: any entry marked moves all
    ) -> tuple[list[NDArray], list[NDArray]]:
        """New linearization points x' and increments δ' for fluid relinearization [K12 Alg. 5], keeping each
        estimate x ⊕ δ: the entries of δ marked in ``moves`` ((d,) bool each) go into x'. A tangent that does
        not split into independent blocks moves whole: x' = x ⊕ δ, δ' = 0 (a vector space moves each block alone)."""
        return self.retract_many(xs, deltas), [np.zeros_like(d) for d in deltas]

    def retract_sum(self, x: NDArray, a: NDArray, b: NDArray | None) -> NDArray:
        """x ⊕ (a + b), two increments in the tangent at x (b None: x ⊕ a): a marginalized variable's solved
        conditional, its step R⁻¹d and the separator's pull (:mod:`steam_ref.bayes_tree.history`)."""
        return np.asarray(self.retract(x, a if b is None else a + b), dtype=float)

    def __repr__(self) -> str:
        return f"<manifold {self.name}>"


class VectorSpace(Manifold):
    """Rⁿ of any n: ⊕ is +, ⊖ is -, bit for bit."""

    name = "vector"

    def retract(self, x: NDArray, delta: NDArray) -> NDArray:
        return x + delta

    def local(self, x0: NDArray, x: NDArray) -> NDArray:
        return x - x0

    def retract_many(self, xs: Sequence[NDArray], deltas: Sequence[NDArray]) -> list[NDArray]:
        """x + δ of each variable: NumPy's addition mapped over the arrays (module docstring)."""
        return list(map(np.add, xs, deltas))

    def local_many(self, x0s: Sequence[NDArray], xs: Sequence[NDArray]) -> list[NDArray]:
        """x - x₀ of each variable."""
        return list(map(np.subtract, xs, x0s))

    def rebase_many(
        self, xs: Sequence[NDArray], deltas: Sequence[NDArray], moves: Sequence[NDArray]
    ) -> tuple[list[NDArray], list[NDArray]]:
        """Each marked block moves alone: x' = x + δ where marked, δ' = δ where not; x' + δ' = x + δ."""
        return (
            [x + np.where(m, d, 0.0) for x, d, m in zip(xs, deltas, moves, strict=True)],
            [np.where(m, 0.0, d) for d, m in zip(deltas, moves, strict=True)],
        )

    def retract_sum(self, x: NDArray, a: NDArray, b: NDArray | None) -> NDArray:
        """(x + a) + b: one addition at a time, as the solved conditionals have always been evaluated."""
        return x + a if b is None else (x + a) + b


VECTOR = VectorSpace()  # the kind of every variable no factor says otherwise of: the paper's states and landmarks


def by_kind(keys: Iterable[K], kinds: Mapping[K, Manifold]) -> list[tuple[Manifold, list[K]]]:
    """``keys`` grouped by their kind in ``kinds`` (:data:`VECTOR` when it has none), each group in the order
    given: one ``retract_many`` per group. Kinds are told apart by identity (one object per kind)."""
    groups: dict[int, tuple[Manifold, list[K]]] = {}
    for k in keys:
        kind = kinds.get(k, VECTOR)
        group = groups.get(id(kind))
        if group is None:
            group = groups[id(kind)] = (kind, [])
        group[1].append(k)
    return list(groups.values())
