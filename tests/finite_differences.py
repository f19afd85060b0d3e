"""Central finite differences: the oracle for every analytic Jacobian."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray


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
