"""How a variable's estimate moves: the retraction x ⊕ δ and its inverse x ⊖ x₀.  [YIB Eq. 11; derivations §1]

Gauss-Newton solves for an increment δ in the tangent space at the linearization point θ̄ and moves the
estimate by θ̄ ⊕ δ [YIB Eq. 11]. For a vector state ⊕ is +; a state holding a rotation moves along the
group instead (an SE(2) pose: T ← T·Exp(δ)). Every solver (batch Gauss-Newton and Levenberg-Marquardt,
the Bayes tree's iSAM2, its marginalization, the fixed-lag smoother's kept history) moves a variable
through the :class:`Manifold` of its kind and never with ``+``/``-`` on estimates, so a new kind of state
is one subclass here and nothing in the solvers.

Rules of the seam: an estimate is a flat 1-D float64 array whose tangent has as many entries as it has
(so every size and offset in the solvers is the array's length); ``local`` inverts ``retract``:
``retract(x0, local(x0, x)) == x``. Each method takes one variable at a time; the solvers keep a
vectorized path for :data:`VECTOR` keys, the same arithmetic as ``x + δ``.
"""

from __future__ import annotations

from numpy.typing import NDArray

__all__ = ["Manifold", "VECTOR"]


class Manifold:
    """The space a variable lives in; this base class is a vector space (⊕ is +, ⊖ is -)."""

    name = "vector"

    def retract(self, x: NDArray, delta: NDArray) -> NDArray:
        """x ⊕ δ: the estimate moved by the tangent increment ``delta`` (a new array)."""
        return x + delta

    def local(self, x0: NDArray, x: NDArray) -> NDArray:
        """x ⊖ x₀: the tangent increment that moves ``x0`` to ``x`` (a new array)."""
        return x - x0

    def __repr__(self) -> str:
        return f"<manifold {self.name}>"


VECTOR = Manifold()  # the kind of every variable nobody says otherwise of: the paper's states and landmarks
