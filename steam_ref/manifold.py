"""How a variable's estimate moves: x ⊕ δ and x ⊖ x₀, one rule per kind of variable.

An estimate is a flat 1-D float64 array whose tangent has as many numbers as the array, so every
size and offset in the solvers is the same for every kind. The base class is the vector space
(x ⊕ δ = x + δ, x ⊖ x₀ = x - x₀); a kind on a Lie group (``steam_ref.lie.SE2_STATE``) subclasses it.
Methods take one variable at a time. The rule all kinds keep: retract(x₀, local(x₀, x)) == x.
"""

from __future__ import annotations

from numpy.typing import NDArray

__all__ = ["Manifold", "VECTOR"]


class Manifold:
    """How a variable's estimate moves: x ⊕ δ and x ⊖ x0. The base class is a vector space."""

    name = "vector"

    def retract(self, x: NDArray, delta: NDArray) -> NDArray:
        """x ⊕ δ (vector: x + δ)."""
        return x + delta

    def local(self, x0: NDArray, x: NDArray) -> NDArray:
        """x ⊖ x0 (vector: x - x0); retract(x0, local(x0, x)) == x."""
        return x - x0


VECTOR = Manifold()
