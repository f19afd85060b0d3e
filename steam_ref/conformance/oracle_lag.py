"""Independent expected values of the ``fixed_lag`` suite: a stream replayed with dense linear algebra.

A fixed-lag smoother forgets the variables older than the lag. Forgetting D exactly is integrating it
out of the linearized posterior: the factors adjacent to D, linearized at the current linearization
point θ̄, have information H and information vector g = Aᵀb over D and its separator S (the other
variables of those factors); what they leave on S is the Schur complement

    Λ = H_SS − H_SD H_DD⁻¹ H_DS,    η = g_S − H_SD H_DD⁻¹ g_D         (derivations Eq. 10.1-10.3)

a linear factor ½ δ_Sᵀ Λ δ_S − ηᵀ δ_S about θ̄⁰_S = θ̄_S of the moment. It is frozen there: D is gone,
so its Jacobians can never be evaluated again; at a later linearization point θ̄′ it contributes Λ
and η − Λ (θ̄′_S ⊖ θ̄⁰_S) (Eq. 10.4, first-estimate Jacobians; ⊖ the space's: a difference of vectors, or the
right tangent step of an SE(2) state).

:func:`fixed_lag` replays a stream: per-variable linearization points moved by the same rule as
:func:`.oracle_graph.stream` (iSAM2 with full back-substitution), all factors of the window and all
marginal factors summed into one dense information matrix per update and solved; then the variables
past the lag are dropped by the Schur complement above, and the window's estimate and covariances
are read off the window's own information (which, the Schur complement being exact, is the same as
before dropping). Only NumPy, :mod:`.oracle` and :mod:`.oracle_graph` are used: none of steam_ref's
linear algebra, trees or solvers.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from .oracle_graph import VECTOR, Problem, Space, dense_system

__all__ = ["Marginal", "information", "schur_complement", "fixed_lag"]


class Marginal:
    """A frozen marginal factor: Λ, η over ``keys`` (stacked in that order) about the point ``theta0``."""

    def __init__(self, keys: Sequence[str], info: NDArray, vector: NDArray, theta0: NDArray):
        self.keys, self.info, self.vector, self.theta0 = list(keys), info, vector, theta0


def _columns(order: Sequence[str], dims: Mapping[str, int], keys: Sequence[str]) -> NDArray:
    off, o = {}, 0
    for k in order:
        off[k], o = o, o + dims[k]
    return np.concatenate([np.arange(off[k], off[k] + dims[k]) for k in keys])


def information(
    specs: Sequence[Mapping],
    marginals: Sequence[Marginal],
    theta: Mapping[str, NDArray],
    order: Sequence[str],
    dims: Mapping[str, int],
    space: Space = VECTOR,
) -> tuple[NDArray, NDArray]:
    """H = Σ AᵢᵀAᵢ + Σ Λ and g = Σ Aᵢᵀbᵢ + Σ (η − Λ (θ̄_S ⊖ θ⁰)) over ``order``, linearized at ``theta`` in
    ``space`` (θ̄_S ⊖ θ⁰ key by key, its ``local``)."""
    n = sum(dims[k] for k in order)
    H, g = np.zeros((n, n)), np.zeros(n)
    if specs:
        problem = Problem({"variables": {k: dims[k] for k in order}, "factors": list(specs)})
        A, b, _ = dense_system(problem, theta, order, space)
        H, g = H + A.T @ A, g + A.T @ b
    for m in marginals:
        idx = _columns(order, dims, m.keys)
        ends = np.cumsum([0] + [len(theta[k]) for k in m.keys])  # each key's stored numbers in θ⁰
        shift = np.concatenate(
            [space.local(m.theta0[a:z], theta[k]) for k, a, z in zip(m.keys, ends[:-1], ends[1:], strict=True)]
        )
        H[np.ix_(idx, idx)] += m.info
        g[idx] += m.vector - m.info @ shift  # [derivations Eq. 10.4]
    return H, g


def schur_complement(H: NDArray, g: NDArray, drop: NDArray, keep: NDArray) -> tuple[NDArray, NDArray]:
    """Λ = H_SS − H_SD H_DD⁻¹ H_DS and η = g_S − H_SD H_DD⁻¹ g_D [derivations Eq. 10.1-10.3]."""
    H_dd, H_sd = H[np.ix_(drop, drop)], H[np.ix_(keep, drop)]
    X = np.linalg.solve(H_dd, np.column_stack([H_sd.T, g[drop]]))
    info = H[np.ix_(keep, keep)] - H_sd @ X[:, :-1]
    return (info + info.T) / 2, g[keep] - H_sd @ X[:, -1]


def _touches(keys: Sequence[str], drop: set[str]) -> bool:
    return not drop.isdisjoint(keys)


def fixed_lag(
    variables: Mapping[str, int],
    updates: Sequence[Mapping],
    lag: float,
    threshold: float,
    skip: int = 1,
    schur: bool = True,
    space: Space = VECTOR,
) -> list[dict]:
    """After each update: the variables marginalized, their marginal factor, the window's estimate and covariances.

    Each update adds its factors and values (and timestamps); at the start of every ``skip``-th update
    each variable whose last δ has max|δ| ≥ ``threshold`` moves θ̄ ← θ̄ + δ; the window is solved at θ̄;
    then every timed variable with t < t_newest − ``lag`` is dropped (:func:`schur_complement` of the
    factors adjacent to it). ``schur=False`` is the wrong answer of a port that leaves out the Schur
    complement's correction, Λ = H_SS and η = g_S (it conditions on D at θ̄ instead of integrating it
    out: overconfident), for tests of the checker. Returns one dict per update: ``marginalized`` (names in
    the order of ``variables``), and when any, ``separator``, ``point`` (θ̄_S stacked), ``information``
    (Λ), ``vector`` (η); then ``estimate`` and ``covariances`` (name → array) of the window. ``space``: how the
    variables move and the factors linearize (:class:`.oracle_graph.Space`; SE(2) states: ``oracle_lie.LIE``).
    """
    dims = {k: int(n) for k, n in variables.items()}
    specs: list[Mapping] = []
    marginals: list[Marginal] = []
    theta: dict[str, NDArray] = {}
    delta: dict[str, NDArray] = {}
    times: dict[str, float] = {}
    newest = -np.inf
    out = []
    for step, u in enumerate(updates, start=1):
        specs.extend(u["factors"])
        if step % skip == 0:
            for k in [k for k in theta if float(np.max(np.abs(delta[k]))) >= threshold]:
                theta[k] = space.retract(theta[k], delta[k])
        for k, v in u["values"].items():
            theta[k] = np.asarray(v, float)
        times.update({k: float(t) for k, t in u.get("timestamps", {}).items()})
        newest = max([newest, *times.values()])
        order = [k for k in variables if k in theta]
        record: dict = {"marginalized": [k for k in order if k in times and times[k] < newest - lag]}
        drop = set(record["marginalized"])
        if drop:
            adjacent = [f for f in specs if _touches(f["keys"], drop)]
            near = [m for m in marginals if _touches(m.keys, drop)]
            named = {k for f in adjacent for k in f["keys"]} | {k for m in near for k in m.keys}
            sep = [k for k in order if k in named and k not in drop]
            local = record["marginalized"] + sep
            H, g = information(adjacent, near, theta, local, dims, space)
            nd = sum(dims[k] for k in drop)
            info, vector = schur_complement(H, g, np.arange(nd), np.arange(nd, len(g)))
            if not schur:
                info, vector = H[nd:, nd:], g[nd:]
            point = np.concatenate([theta[k] for k in sep])
            record.update(separator=sep, point=point, information=info, vector=vector)
            specs = [f for f in specs if not _touches(f["keys"], drop)]
            marginals = [m for m in marginals if not _touches(m.keys, drop)]
            marginals.append(Marginal(sep, info, vector, point))
            for k in drop:
                del theta[k], times[k]
            order = [k for k in order if k not in drop]
        H, g = information(specs, marginals, theta, order, dims, space)
        step_delta = np.linalg.solve(H, g)
        cov = np.linalg.inv(H)
        cov = (cov + cov.T) / 2
        delta = {k: step_delta[_columns(order, dims, [k])] for k in order}
        record["estimate"] = {k: space.retract(theta[k], delta[k]) for k in order}
        record["covariances"] = {k: cov[np.ix_(_columns(order, dims, [k]), _columns(order, dims, [k]))] for k in order}
        out.append(record)
    return out
