"""The marginal factor a marginalization leaves: linear, frozen at a linearization point.  [derivations Eq. 10.4]

Made by :mod:`steam_ref.bayes_tree.marginalization` from the Schur complement of the variables it forgets,
GTSAM's ``LinearContainerFactor``: e(θ) = A (θ ⊖ θ₀) - b, with the Jacobian A at every θ.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass
from typing import ClassVar, Protocol

import numpy as np
from numpy.typing import NDArray

from ..manifold import VECTOR, Manifold
from ..variables import Key
from .base import Factor

__all__ = ["MarginalFactor"]


class LinearFactor(Protocol):
    """‖Σ blocks[i] δ_keys[i] - rhs‖²: what :meth:`MarginalFactor.frozen_at` reads of a linear factor."""

    @property
    def keys(self) -> tuple[Key, ...]: ...
    @property
    def blocks(self) -> tuple[NDArray, ...]: ...
    @property
    def rhs(self) -> NDArray: ...


@dataclass(frozen=True, eq=False)
class MarginalFactor(Factor):
    """A linear factor frozen at a linearization point: e(θ) = A (θ ⊖ θ₀) - b.  [derivations Eq. 10.4]

    Made from a Schur complement ‖A δ_S - b‖² computed at θ̄_S = θ₀. Its whitened Jacobian is A at every
    θ (first-estimate Jacobians) and its right-hand side at θ̄' is b - A (θ̄' ⊖ θ₀). ``keys`` lists
    the separator variables, ``dims`` their sizes, ``kinds`` how each moves (empty: all vectors); A is
    (m, Σ dims), already whitened.
    """

    A: NDArray  # (m, n), whitened: sqrt_information is the identity
    b: NDArray  # (m,)
    theta0: NDArray  # (n,) the frozen linearization point, the keys' θ̄ stacked
    dims: tuple[int, ...] = ()  # size of each key
    kinds: tuple[Manifold, ...] = ()  # how each key moves; empty when every key is a vector

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "A", "b", "theta0")
    _shared: ClassVar[tuple[str, ...]] = ("dims", "kinds")  # equal within a batch: batch_signature holds them

    @classmethod
    def frozen_at(
        cls, gf: LinearFactor, theta_bar: Mapping[Key, NDArray], kinds: Mapping[Key, Manifold] | None = None
    ) -> MarginalFactor:
        """The linear factor ``gf`` = ‖A δ - b‖² (a :class:`~steam_ref.linear.system.GaussianFactor`), δ about
        ``theta_bar`` of its keys, as a factor of θ."""
        A = np.hstack(gf.blocks) if gf.blocks else np.zeros((len(gf.rhs), 0))
        theta0 = np.concatenate([np.asarray(theta_bar[k], dtype=float) for k in gf.keys])
        dims = tuple(block.shape[1] for block in gf.blocks)
        of = tuple((kinds or {}).get(k, VECTOR) for k in gf.keys)
        return cls(
            gf.keys, np.eye(len(gf.rhs)), A=A, b=gf.rhs.copy(), theta0=theta0, dims=dims,
            kinds=of if any(m is not VECTOR for m in of) else (),
        )  # fmt: skip

    @property
    def key_dims(self) -> tuple[int, ...]:  # type: ignore[override]
        return self.dims

    def batch_signature(self) -> tuple:
        return super().batch_signature() + (self.dims, self.kinds)

    def error(self, *xs: NDArray) -> NDArray:
        if not self.kinds:  # every key a vector: θ - θ₀
            step = np.concatenate(xs, axis=-1) - self.theta0
        else:  # θ ⊖ θ₀ key by key, one variable at a time
            bounds = np.cumsum((0, *self.dims))
            parts = []
            for x, kind, a, z in zip(xs, self.kinds, bounds[:-1], bounds[1:], strict=True):
                t0 = np.broadcast_to(self.theta0[..., a:z], x.shape)
                flat = [kind.local(t, v) for t, v in zip(t0.reshape(-1, z - a), x.reshape(-1, z - a), strict=True)]
                parts.append(np.reshape(flat, x.shape))
            step = np.concatenate(parts, axis=-1)
        return np.einsum("...ij,...j->...i", self.A, step) - self.b  # [derivations Eq. 10.4]

    def jacobians(self, *xs: NDArray) -> tuple[NDArray, ...]:
        bounds = np.cumsum((0, *self.dims))
        shape = xs[0].shape[:-1] + self.A.shape[-2:]
        A = np.broadcast_to(self.A, shape)
        return tuple(A[..., :, a:z] for a, z in itertools.pairwise(bounds))
