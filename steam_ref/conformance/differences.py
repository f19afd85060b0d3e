"""The 8th-order central-difference stencil: the oracle the tests and benchmarks hold an analytic Jacobian to.

NumPy only, like the kit's oracles (the kit's own Jacobians are Romberg tables of central differences,
:func:`.oracle_rigid.derivative`). ``f`` takes a step δ in a tangent (δ = 0: the point itself), so one stencil
serves vector states, Lie-group states through any retraction, and their factors.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

__all__ = ["jacobian8", "jacobian8_stacked"]

_C8 = (1 / 280, -4 / 105, 1 / 5, -4 / 5, 0.0, 4 / 5, -1 / 5, 4 / 105, -1 / 280)  # 8th-order central stencil


def jacobian8(f: Callable[[NDArray], NDArray], n: int, h: float = 2.0**-7) -> NDArray:
    """∂f/∂δ at δ = 0 (m, n) by the 8th-order central stencil with step h (truncation h⁸ max abs(f⁽⁹⁾) / 630,
    rounding about 6e-14 max abs(f) at h = 2⁻⁷; tests/test_lie_groups.py): f takes a step δ (n,) in a tangent."""
    cols = []
    for j in range(n):
        e = np.zeros(n)
        e[j] = h
        cols.append(sum(c * np.asarray(f((k - 4) * e)) for k, c in enumerate(_C8) if c) / h)
    return np.stack(cols, axis=-1)


def jacobian8_stacked(f: Callable[[NDArray], NDArray], n: int, h: float = 2.0**-7) -> NDArray:
    """:func:`jacobian8` for an ``f`` that broadcasts over a leading axis: one call of f on the 8n steps (8n, n)
    stacked, the same stencil, step and sum (the same numbers up to the last bits a batched matrix product may
    round differently), without 8n calls' overhead."""
    ks = [k for k, c in enumerate(_C8) if c]
    steps = np.zeros((n, len(ks), n))
    for j in range(n):
        steps[j, :, j] = [(k - 4) * h for k in ks]
    values = np.asarray(f(steps.reshape(-1, n)))
    values = values.reshape((n, len(ks)) + values.shape[1:])
    cols = [sum(_C8[k] * values[j, i] for i, k in enumerate(ks)) / h for j in range(n)]
    return np.stack(cols, axis=-1)
