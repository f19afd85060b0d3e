"""Central finite differences: the oracle for every analytic Jacobian (the 8th-order stencil is the package's,
:mod:`steam_ref.conformance.differences`, which the benchmarks use too)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

from steam_ref.conformance.differences import jacobian8, jacobian8_stacked

__all__ = ["numerical_jacobians", "jacobian8", "jacobian8_stacked"]


def numerical_jacobians(f: Callable[..., NDArray], *xs: NDArray, eps: float = 1e-6) -> list[NDArray]:
    """∂f/∂xₖ for each argument by central differences: each (m, dₖ)."""
    out = []
    for k, x in enumerate(xs):
        cols = []
        for i in range(len(x)):
            plus = [np.array(y, dtype=float) for y in xs]
            minus = [np.array(y, dtype=float) for y in xs]
            plus[k][i] += eps
            minus[k][i] -= eps
            cols.append((np.asarray(f(*plus)) - np.asarray(f(*minus))) / (2 * eps))
        out.append(np.stack(cols, axis=-1))
    return out
