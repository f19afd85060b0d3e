"""What a failing numeric quantity's pattern points at, named after its count by :mod:`.checker`: a whole number
of turns off, a flipped sign, the transpose, the expected entries (columns, rows) in another order, a square
matrix's rows and columns both in another order by the same permutation, the failing entries all scaled by one
factor, or every entry a float32 value (docs/conformance.md)."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["pattern_hint"]

SYMMETRIC = 30  # largest square matrix searched for expected[p][:, p] (the kits' largest: linear's 28 x 28)
TRIES = 5000  # partial permutations tried at most in that search: a failing check stays fast on any input


def _permutation(expected: np.ndarray, got: np.ndarray, allowed: float) -> list[int] | None:
    """p with got[j] = expected[p[j]] (rows of a 2-D array, entries of a vector) within ``allowed``; None if none."""
    free = list(range(len(expected)))
    p = []
    for row in got:
        j = next((j for j in free if float(np.abs(expected[j] - row).max()) <= allowed), None)
        if j is None:
            return None
        free.remove(j)
        p.append(j)
    return p


def _symmetric_permutation(expected: np.ndarray, got: np.ndarray, allowed: float) -> list[int] | None:
    """p, not the identity, with got[i, k] = expected[p[i], p[k]] for all i, k (got = expected[p][:, p]) within
    ``allowed``; None if there is none, the matrix is not square or larger than ``SYMMETRIC``, or none was found
    within ``TRIES`` partial permutations.

    Backtracking, one row of ``got`` at a time: its candidates are the rows j of ``expected`` whose diagonal entry,
    sorted row and sorted column match its own within ``allowed`` (sorting two vectors brings them no further
    apart entry by entry, so no true p is lost), the rows with fewest candidates first; a candidate must then match every row already
    placed, both ways. A diagonal match alone would do for distinct diagonals, but an isotropic Qc repeats them
    (Φ's is all ones), and a pair of rows can tell apart what their diagonals cannot. The budget bounds the search
    on a matrix with many equal entries, where it is graph isomorphism."""
    n = len(expected) if expected.ndim == 2 else 0
    if got.shape != (n, n) or expected.shape != (n, n) or not 1 < n <= SYMMETRIC:
        return None

    def near(a: np.ndarray, b: np.ndarray) -> bool:
        return float(np.abs(a - b).max()) <= allowed

    rows = (np.sort(got, axis=1), np.sort(expected, axis=1))
    cols = (np.sort(got, axis=0).T, np.sort(expected, axis=0).T)
    candidates = [
        [
            j
            for j in range(n)
            if abs(got[i, i] - expected[j, j]) <= allowed
            and near(rows[0][i], rows[1][j])
            and near(cols[0][i], cols[1][j])
        ]
        for i in range(n)
    ]
    order = sorted(range(n), key=lambda i: len(candidates[i]))
    p = [-1] * n
    free = [True] * n
    tries = TRIES

    def place(depth: int) -> bool:
        nonlocal tries
        if depth == n:
            return True
        i, placed = order[depth], order[:depth]
        at = [p[k] for k in placed]
        for j in candidates[i]:
            if not free[j]:
                continue
            tries -= 1
            if tries < 0:
                return False
            if placed and not (near(got[i, placed], expected[j, at]) and near(got[placed, i], expected[at, j])):
                continue
            p[i], free[j] = j, False
            if place(depth + 1):
                return True
            free[j] = True
        return False

    return p if place(0) and p != list(range(n)) else None


def pattern_hint(expected: np.ndarray, got: np.ndarray, worst: float, allowed: float) -> str:
    """What a failing numeric quantity's pattern points at: a whole number of turns off, a flipped sign, the
    transpose of a square matrix, the expected entries (a vector's entries, a matrix's columns or rows) in another
    order, a square matrix's rows and columns both in another order by the same permutation (Φ, Q, Q⁻¹, W or a
    covariance of a state stacked axis by axis, [x, x_dot, y, ...], against the kit's [x, y, theta, x_dot, ...]), the
    failing entries all the expected ones times one factor, or every entry a float32 value.

    The transpose is tried before the orders: a transposed Jacobian is the commoner port bug, and the transpose of
    a block matrix such as the GP prior's H_0 = -Phi = -[[I, dt I], [0, I]] is also its block rows and columns
    swapped, which the symmetric search would name as a state stacked in another order.

    One axis is tried before both because it is the narrower claim, that one axis is where the kit has it: when a
    matrix fits both (a structured one, e.g. with all rows equal, where A[:, p] = A[p][:, p]), the data cannot tell the two apart and
    the hint should claim the least, and a one-axis order is also what a Jacobian's columns of another state order
    show. A state-by-state matrix of a state stacked in another order has both axes moved, fits no one-axis order,
    and reaches the symmetric hint. The one-axis checks are also cheap, the symmetric one a bounded search."""
    turns = round(worst / (2 * math.pi))
    # only where float64 resolves ``allowed`` at ``worst``: past that (1e308) every value is a whole number of turns
    if turns and math.ulp(worst) <= allowed and abs(worst - turns * 2 * math.pi) <= allowed:
        return f"; {turns} x 2 pi off: an angle brought into another range (README conventions 'angles', 'se2')"
    if float(np.abs(got + expected).max()) <= allowed:
        return (
            "; every entry is minus the expected one: a flipped sign (README conventions 'residual': e = h(theta) - y, "
            "the GP prior's e = x_i - Phi x_(i-1) - v_i; --conventions paper-sign takes [YIB Eq. 22]'s for gp_prior)"
        )
    if got.ndim == 2 and got.shape[0] == got.shape[1] and float(np.abs(got - expected.T).max()) <= allowed:
        return (
            "; it is the expected matrix transposed (got = expected^T): a transposed Jacobian, whitener or R "
            "(README conventions 'jacobians': H_k = de/dx_k has a row per error entry; 'whitening': W upper "
            "triangular; arrays are nested lists, row-major)"
        )
    for axis, what in ((1, "columns"), (0, "rows")) if got.ndim == 2 else ((0, "entries"),) if got.ndim == 1 else ():
        p = _permutation(np.moveaxis(expected, axis, 0), np.moveaxis(got, axis, 0), allowed)
        if p is not None:
            return (
                f"; its {what} are the expected {what} {p} in that order: an ordering differs (README conventions "
                "'state', 'jacobians': a state is [x, y, theta, x_dot, y_dot, theta_dot], H_k for the k-th key)"
            )
    p = _symmetric_permutation(expected, got, allowed)
    if p is not None:
        return (
            f"; its rows and columns are the expected ones in the order p = {p} (the same permutation on both): a "
            "state stacked in another order (README conventions 'state': x = [p; p_dot] block by block, "
            "p = [x, y, theta], not axis by axis)"
        )
    return _common_factor(expected, got, allowed) or _single_precision(expected, got)


def _common_factor(expected: np.ndarray, got: np.ndarray, allowed: float) -> str:
    """The failing entries (two or more, none of them expected near 0) all the expected ones times one factor c,
    c not 1 or -1: a wrong constant or power (Q's dt^3/3 written dt^2/3 scales its position block by 1/dt, a
    covariance where a sigma belongs, a cost without its 1/2)."""
    failing = np.abs(got - expected) > allowed
    exp, g = expected[failing], got[failing]
    if exp.size < 2 or float(np.abs(exp).min()) <= allowed:
        return ""
    c = float(exp @ g / (exp @ exp))
    if not math.isfinite(c) or float(np.abs(g - c * exp).max()) > allowed or min(abs(c - 1), abs(c + 1)) < 1e-6:
        return ""
    every = (
        "every entry is the expected one" if failing.all() else f"the {exp.size} failing entries are the expected ones"
    )
    return (
        f"; {every} times {c:.6g} (one common factor): a wrong constant or power of dt, or a "
        "variance where a sigma belongs"
    )


def _single_precision(expected: np.ndarray, got: np.ndarray) -> str:
    """Every entry got is a float32 number (a double that single precision represents exactly) and the expected
    ones are not all: the result went through float32, whose relative rounding (6e-8) is past the kit's
    tolerances."""
    with np.errstate(over="ignore"):
        exact = bool(np.all(got.astype(np.float32).astype(np.float64) == got))
        kit = bool(np.all(expected.astype(np.float32).astype(np.float64) == expected))
    if not exact or kit:
        return ""
    return (
        "; every entry got is a float32 value: single precision somewhere (rounding 6e-8 relative), and the kit's "
        "tolerances need float64 (README conventions 'floats')"
    )
