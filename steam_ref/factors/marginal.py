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

from ..errors import SteamError
from ..manifold import Manifold
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
    the separator variables, ``dims`` their sizes, ``kinds`` the kind each was held as when it was made (⊖ is
    each one's); A is (m, Σ dims), already whitened.
    """

    A: NDArray  # (m, n), whitened: sqrt_information is the identity
    b: NDArray  # (m,)
    theta0: NDArray  # (n,) the frozen linearization point, the keys' θ̄ stacked
    dims: tuple[int, ...] = ()  # size of each key
    kinds: tuple[Manifold, ...] = ()  # the kind of each key

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "A", "b", "theta0")
    _shared: ClassVar[tuple[str, ...]] = ("dims", "kinds")  # equal within a batch: batch_signature holds them

    def __post_init__(self) -> None:
        super().__post_init__()
        if len(self.kinds) != len(self.keys) or len(self.dims) != len(self.keys):
            raise SteamError(f"MarginalFactor needs a size and a kind for each of its keys {self.keys}")

    @classmethod
    def frozen_at(
        cls, gf: LinearFactor, theta_bar: Mapping[Key, NDArray], kinds: Mapping[Key, Manifold]
    ) -> MarginalFactor:
        """The linear factor ``gf`` = ‖A δ - b‖² (a :class:`~steam_ref.linear.system.GaussianFactor`), δ about
        ``theta_bar`` of its keys, each of its kind in ``kinds``, as a factor of θ."""
        A = np.hstack(gf.blocks) if gf.blocks else np.zeros((len(gf.rhs), 0))
        theta0 = np.concatenate([np.asarray(theta_bar[k], dtype=float) for k in gf.keys])
        dims = tuple(block.shape[1] for block in gf.blocks)
        of = tuple(kinds[k] for k in gf.keys)
        return cls(gf.keys, np.eye(len(gf.rhs)), A=A, b=gf.rhs.copy(), theta0=theta0, dims=dims, kinds=of)

    @property
    def key_dims(self) -> tuple[int, ...]:  # type: ignore[override]
        return self.dims

    @property
    def key_kinds(self) -> tuple[Manifold, ...]:
        return self.kinds

    def batch_signature(self) -> tuple:
        return super().batch_signature() + (self.dims, self.kinds)

    def error(self, *xs: NDArray) -> NDArray:
        bounds = np.cumsum((0, *self.dims))
        steps = [  # θ ⊖ θ₀ key by key, each by its kind over the whole batch
            kind.local(np.broadcast_to(self.theta0[..., a:z], x.shape), x)
            for x, kind, a, z in zip(xs, self.kinds, bounds[:-1], bounds[1:], strict=True)
        ]
        step = np.concatenate(steps, axis=-1)
        return np.einsum("...ij,...j->...i", self.A, step) - self.b  # [derivations Eq. 10.4]

    def jacobians(self, *xs: NDArray) -> tuple[NDArray, ...]:
        bounds = np.cumsum((0, *self.dims))
        shape = xs[0].shape[:-1] + self.A.shape[-2:]
        A = np.broadcast_to(self.A, shape)
        return tuple(A[..., :, a:z] for a, z in itertools.pairwise(bounds))
