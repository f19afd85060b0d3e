"""Linearization and the sparse least-squares system of Eq. 10-11.  [YIB Eq. 7-11, 21]

``linearize`` evaluates factors in batches of one type and returns whitened Jacobian blocks and
right-hand sides: each factor i contributes ‖Aᵢ δθᵢ - bᵢ‖² with Aᵢ = √wᵢ Wᵢ Hᵢ and bᵢ = -√wᵢ Wᵢ eᵢ
(W the whitening, w the robust weight). ``LinearSystem`` stacks them into the sparse A and b of
Eq. 21 under a variable ordering: the errors stacked as h(θ) is in Eq. 7, each whitened by its own
noise as R = diag(R₁, …, R_N) of Eq. 8 allows. I = AᵀA is the information matrix of Eq. 11 and Aᵀb its
right-hand side (with the prior written as factors, P⁻¹ (η - θ̄) and Hᵀ R⁻¹ (y - h̄) both live in Aᵀb;
Eq. 11 as printed drops the P⁻¹, which setting the gradient of Eq. 10 to zero gives).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray

from ..errors import NumericalError, ShapeError, SteamError, UnknownVariableError
from ..factors import Factor, check_factors, wrong_size
from ..variables import Key, Values, as_values
from .ordering import Ordering

__all__ = ["LinearizedGroup", "Batches", "linearize", "whitened_norms", "LinearSystem", "GaussianFactor"]


@dataclass(frozen=True)
class GaussianFactor:
    """One linearized factor: ‖Σₖ Aₖ δθₖ - b‖².  [YIB Eq. 21]"""

    keys: tuple[Key, ...]  # variables, in the factor's own order
    blocks: tuple[NDArray, ...]  # Aₖ, each (m, dₖ)
    rhs: NDArray  # b, (m,)


@dataclass(frozen=True)
class LinearizedGroup:
    """Factors of one type linearized together."""

    factor_ids: NDArray  # (n,) positions in the list given to ``linearize``
    keys: list[tuple[Key, ...]]  # keys of each factor
    jacobians: tuple[NDArray, ...] | None  # per key slot: (n, m, dₖ), whitened and robust-weighted; may be read-only
    rhs: NDArray  # (n, m): b = -√w W e
    costs: NDArray  # (n,): ½‖We‖², or ρ(‖We‖) for a robust factor

    @property
    def cost(self) -> float:
        """Sum of the factors' costs."""
        return float(self.costs.sum())

    def jacobian_blocks(self) -> tuple[NDArray, ...]:
        """``jacobians``; SteamError for a group linearized with ``jacobians=False``, which has none."""
        if self.jacobians is None:
            raise SteamError("this group was linearized with jacobians=False: it has costs but no Jacobians")
        return self.jacobians

    def gaussian_factors(self) -> list[GaussianFactor]:
        """The group as one GaussianFactor per factor."""
        blocks = self.jacobian_blocks()
        return [GaussianFactor(keys, tuple([J[i] for J in blocks]), self.rhs[i]) for i, keys in enumerate(self.keys)]


def _group_by_type(factors: Sequence[Factor]) -> list[list[int]]:
    """Positions of ``factors`` by batch signature, groups in the order of their first factor."""
    groups: dict[tuple, list[int]] = {}
    try:
        for i, f in enumerate(factors):
            groups.setdefault(f.batch_signature(), []).append(i)
    except AttributeError:  # checked only on failure, so a batch linearization pays nothing for it
        check_factors("factors", factors)
        raise
    return list(groups.values())


def _slot_keys(group: list[Factor]) -> tuple[list[Key], ...]:
    """The keys of each key slot of a group of factors of one signature, factor by factor (what :func:`_variables`
    stacks)."""
    return tuple([f.keys[slot] for f in group] for slot in range(len(group[0].keys)))


def _variables(values: Values, group: list[Factor], slot_keys: tuple[list[Key], ...]) -> list[NDArray]:
    """The estimates each key slot of a group of factors reads, as (n, dₖ) arrays (a group of one: views);
    ``slot_keys[k]`` the keys of slot k, factor by factor."""
    if len(group) == 1:  # a view costs a tenth of a copy; a size that differs is named below
        xs = [values[k][None] for k in group[0].keys]
        for one, d in zip(xs, group[0].key_dims, strict=True):
            if one.shape[1] != d:
                break
        else:
            return xs
    xs = []
    for keys, dim in zip(slot_keys, group[0].key_dims, strict=True):
        try:
            x = values.stack(keys)
        except ValueError:  # estimates of different sizes
            x = None
        if x is None or x.shape[1] != dim:
            bad = next(k for k in keys if values.dim(k) != dim)
            raise wrong_size(group[0], bad, dim, values.dim(bad), "estimate")
        xs.append(x)
    return xs


def _total(a: NDArray) -> float:
    """Σ a, finite only if every number is (or the sum overflowed)."""
    return float(np.add.reduce(a, axis=None))


def _first_non_finite(e: NDArray, costs: NDArray, Js: tuple[NDArray, ...] | None) -> tuple[int, str] | None:
    """(row in the group, what) of the first factor whose error, cost or a Jacobian is NaN or inf."""
    bad = {"error": ~np.isfinite(e).all(axis=1) | ~np.isfinite(costs)}
    for slot, J in enumerate(Js or ()):
        bad[f"Jacobian for its key {slot}"] = ~np.isfinite(J).all(axis=(1, 2))
    hits = [(int(np.argmax(b)), what) for what, b in bad.items() if b.any()]
    return min(hits) if hits else None


def _whitened(batch: Factor, e: NDArray) -> NDArray:
    """(n, m) whitened errors Σ^-½ e of a stacked batch's errors e: ‖e‖²_Σ = ‖Σ^-½ e‖².  [YIB Eq. 6, 21]"""
    return np.einsum("nij,nj->ni", batch.sqrt_information, e)


def whitened_norms(factors: Sequence[Factor], values: Values) -> NDArray:
    """(n,) ‖W e‖ of each of ``factors`` at ``values``, in the order given (inf where it is not finite): the
    residual before any robust loss, evaluated in batches of one type as :func:`linearize` evaluates them, without
    Jacobians (a type with one factor by its own ``whitened_error``); the divergence check of a stream
    (:mod:`steam_ref.paper.divergence`).  [YIB Eq. 6]"""
    values = as_values("values", values)
    out = [0.0] * len(factors)  # floats, made one array at the end
    with np.errstate(all="ignore"):  # a residual that overflows is inf: beyond any noise, not an error here
        for ids in _group_by_type(factors):
            if len(ids) == 1:  # a type with one factor: its own evaluation, which costs less than a stack of one
                f = factors[ids[0]]
                w = f.whitened_error(*[values[k] for k in f.keys]).ravel()
                out[ids[0]] = math.sqrt(w.dot(w))  # np.linalg.norm(w), without its checks and dispatch
                continue
            group = [factors[i] for i in ids]
            batch = type(group[0]).stack(group)
            slot_keys = _slot_keys(group)
            e = _whitened(batch, batch.error(*_variables(values, group, slot_keys)))
            for i, norm in zip(ids, np.sqrt(np.add.reduce(e * e, axis=1)).tolist(), strict=True):
                out[i] = norm  # np.linalg.norm(e, axis=1)
    return np.array([norm if norm == norm else math.inf for norm in out])  # a norm is ≥ 0, inf or NaN (read as inf)


class Batches:
    """``factors`` grouped by batch signature, each group stacked into one factor: the part of :func:`linearize`
    that does not depend on the estimates. Made once, it serves every linearization of the same factors (a batch
    solve's iterations and their costs), each then one evaluation per group; the factors are read when it is made,
    so a Batches is of the factors as they were then."""

    def __init__(self, factors: Sequence[Factor]):
        self.factors = list(factors)  # in the order given: a failure names a factor by its position here
        # (positions, the factors, stacked, the keys of each slot factor by factor), one per signature
        self.groups: list[tuple[NDArray, list[Factor], Factor, tuple[list[Key], ...]]] = []
        for ids in _group_by_type(self.factors):
            group = [self.factors[i] for i in ids]
            slot_keys = _slot_keys(group)
            self.groups.append((np.asarray(ids), group, type(group[0]).stack(group), slot_keys))

    def cost(self, values: Values) -> float:
        """The cost Σ ρᵢ(‖Wᵢeᵢ‖) of Eq. 6 at ``values`` (:meth:`linearize` without Jacobians)."""
        return sum(group.cost for group in self.linearize(values, jacobians=False))

    def linearize(self, values: Values, *, jacobians: bool = True) -> list[LinearizedGroup]:
        """:func:`linearize` of the factors at ``values``."""
        values = as_values("values", values)
        out, failures = [], []
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # checked group by group, just below
            for ids, group, batch, slot_keys in self.groups:
                xs = _variables(values, group, slot_keys)
                fixed = group[0].whitened_jacobians() if jacobians and len(ids) == 1 else None  # a linear factor's
                if fixed is None:
                    error, H = batch.error_and_jacobians(*xs) if jacobians else (batch.error(*xs), None)
                    WH = None if H is None else tuple([batch.sqrt_information @ J for J in H])  # Σ^-½ H_i
                else:  # made once, finite
                    error, WH = batch.error(*xs), tuple([A[None] for A in fixed])
                e = _whitened(batch, error)
                s = np.sqrt(np.add.reduce(e * e, axis=1))  # ‖e‖ row by row, as np.linalg.norm(e, axis=1) sums it
                if batch.loss is None:  # √w = 1: A_i = Σ^-½ H_i, b_i = -Σ^-½ e, the products by 1 left out
                    costs = 0.5 * s**2
                    Js = WH
                    rhs = -e
                else:
                    weight, costs = batch.loss.weight_and_rho(s)
                    scale = np.sqrt(weight)
                    Js = None if WH is None else tuple([scale[:, None, None] * A for A in WH])  # A_i = √w Σ^-½ H_i
                    rhs = -scale[:, None] * e  # b_i = -√w Σ^-½ e(θ̄): ‖A_i δθ - b_i‖² is the term  [YIB Eq. 9-10, 21]
                # one sum is finite only if every number in it is (or it overflowed: then the search finds nothing);
                # without a loss, ½‖e‖² is finite only if e is, and blocks made once are finite
                checked = () if Js is None or (fixed is not None and batch.loss is None) else Js
                total = (0.0 if batch.loss is None else _total(e)) + _total(costs)
                for J in checked:
                    total += _total(J)
                if not math.isfinite(total):
                    hit = _first_non_finite(e, costs, Js)
                    if hit is not None:
                        failures.append((int(ids[hit[0]]), hit[1]))
                out.append(LinearizedGroup(ids, [f.keys for f in group], Js, rhs, costs))
        if failures:
            i, what = min(failures)
            f = self.factors[i]
            at = ", ".join(f"{k!r} = {values[k].tolist()}" for k in f.keys)
            raise NumericalError(
                f"factor {i} ({type(f).__name__} on {', '.join(map(repr, f.keys))}) has a non-finite {what} at {at}"
            )
        return out


def linearize(factors: Sequence[Factor], values: Values, *, jacobians: bool = True) -> list[LinearizedGroup]:
    """Whitened Jacobians and right-hand sides of ``factors`` at ``values``.  [YIB Eq. 9, 21]

    A type with one factor is a batch of one read through views; a linear factor alone gives its whitened
    Jacobians made once (:meth:`~steam_ref.factors.Factor.whitened_jacobians`, the GP prior's W(-Φ) and W).
    Raises :class:`~steam_ref.errors.NumericalError` naming the first factor (in the order given)
    whose error or Jacobian is NaN or inf at ``values``: an overflowing reading, say. A solve linearizing the
    same factors again and again groups and stacks them once (:class:`Batches`).
    """
    values = as_values("values", values)  # refused before the factors are grouped, as it always was
    return Batches(factors).linearize(values, jacobians=jacobians)


@dataclass(frozen=True)
class LinearSystem:
    """The stacked, whitened system ‖A δθ - b‖² under a variable ordering.  [YIB Eq. 7-8, 10, 21]"""

    A: sp.csr_matrix  # (rows, n) sparse whitened Jacobian; column blocks follow ``ordering``
    b: NDArray  # (rows,)
    ordering: Ordering  # variable order of the columns

    @classmethod
    def from_groups(cls, groups: list[LinearizedGroup], ordering: Ordering) -> LinearSystem:
        """Assemble the sparse A, b from linearized groups (vectorized per group and key slot)."""
        if not isinstance(ordering, Ordering):
            raise SteamError(
                f"ordering must be an Ordering (see steam_ref.linear.make_ordering), got ordering={ordering!r}"
            )
        rows, cols, data, rhs = [], [], [], []
        row0 = 0
        for g in groups:
            n, m = g.rhs.shape
            starts = row0 + m * np.arange(n)
            for slot, J in enumerate(g.jacobian_blocks()):
                try:
                    at = np.array([ordering.position[keys[slot]] for keys in g.keys], dtype=int)
                except KeyError as exc:
                    raise UnknownVariableError(f"variable {exc.args[0]!r} is not in the ordering") from None
                d = J.shape[2]
                if np.any(ordering.dim_array[at] != d):  # else the blocks would overlap their neighbours'
                    k = g.keys[int(np.flatnonzero(ordering.dim_array[at] != d)[0])][slot]
                    raise ShapeError(
                        f"the ordering gives variable {k!r} size {ordering.dims[ordering.position[k]]}, "
                        f"its factors' blocks have {d} columns"
                    )
                col_starts = ordering.offsets[at]
                rows.append(np.broadcast_to(starts[:, None, None] + np.arange(m)[None, :, None], J.shape).ravel())
                cols.append(np.broadcast_to(col_starts[:, None, None] + np.arange(d)[None, None, :], J.shape).ravel())
                data.append(J.ravel())
            rhs.append(g.rhs.ravel())
            row0 += n * m
        shape = (row0, ordering.total_dim)
        if not data:  # no factors: an empty system
            return cls(sp.csr_matrix(shape), np.zeros(0), ordering)
        A = sp.csr_matrix((np.concatenate(data), (np.concatenate(rows), np.concatenate(cols))), shape=shape)
        return cls(A, np.concatenate(rhs), ordering)

    @classmethod
    def build(cls, factors: Sequence[Factor], values: Values, ordering: Ordering) -> LinearSystem:
        """Linearize ``factors`` at ``values`` and assemble them under ``ordering``."""
        if not isinstance(ordering, Ordering):
            raise SteamError(
                f"ordering must be an Ordering (see steam_ref.linear.make_ordering), got ordering={ordering!r}"
            )
        return cls.from_groups(linearize(check_factors("factors", factors), values), ordering)

    def information(self) -> tuple[sp.csc_matrix, NDArray]:
        """The information matrix 𝓘 = AᵀA and right-hand side Aᵀb of Eq. 11."""
        At = self.A.T.tocsr()
        return (At @ self.A).tocsc(), At @ self.b  # 𝓘 = AᵀA, Aᵀb  [YIB Eq. 11, 21]

    def to_dense(self) -> tuple[NDArray, NDArray]:
        """Dense A and b, for checking small problems with numpy.linalg."""
        return self.A.toarray(), self.b.copy()

    def split(self, x: NDArray) -> dict[Key, NDArray]:
        """A stacked solution vector as key → block."""
        return {
            k: x[o : o + d]
            for k, o, d in zip(self.ordering.keys, self.ordering.offsets, self.ordering.dims, strict=True)
        }
