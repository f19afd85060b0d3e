"""Covariance recovery: blocks of 𝓘⁻¹, the covariance of the Gauss-Newton step.  [YIB Eq. 11, K11 Sec. 3]

cov δθ* = 𝓘⁻¹ = (AᵀA)⁻¹ [YIB Eq. 11]. Two sources:

- the sparse system: :func:`marginal_covariances` and :func:`sparse_joint_covariance` factor 𝓘
  by sparse Cholesky and solve with unit columns;
- the Bayes tree: each clique is P(F | S) ∝ exp(-½ ‖R δ_F + S δ_S - d‖²), so from Σ_SS (a block
  of its parent's joint covariance) [K11 Sec. 3]

      Cov(F, S) = -R⁻¹S Σ_SS,    Cov(F, F) = R⁻¹R⁻ᵀ + R⁻¹S Σ_SS (R⁻¹S)ᵀ,

  and a walk down from the root gives any clique's joint covariance. :func:`tree_marginals` does
  every clique in one such walk; :func:`tree_joint_covariance` serves variables of different
  cliques from the conditionals of their root paths.

Nothing here imports the Bayes tree package (which builds on this module); a tree is anything with
the :class:`~steam_ref.bayes_tree.tree.BayesTree` attributes used below.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from typing import TYPE_CHECKING

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.typing import NDArray
from scipy.linalg import lapack

from .errors import UnknownVariableError
from .factors import Factor
from .linear.conditional import Conditional, assemble_sqrt_information
from .linear.ordering import Ordering, make_ordering
from .linear.solve import SparseCholesky
from .linear.system import LinearSystem
from .variables import Key, Values

if TYPE_CHECKING:
    from .bayes_tree.tree import BayesTree

__all__ = [
    "marginal_covariances",
    "sparse_joint_covariance",
    "sparse_marginals",
    "sparse_joint_marginals",
    "tree_marginal_covariance",
    "tree_joint_covariance",
    "tree_marginals",
    "tree_joint_marginals",
]

Index = dict[Key, tuple[int, int]]  # variable → (first row, size) in a joint covariance


# --- from the sparse system ---------------------------------------------------------------------


def _unit_columns(ordering: Ordering, keys: Sequence[Key]) -> tuple[NDArray, NDArray]:
    """The scalar columns of ``keys`` (stacked in the order given), and E (n, Σdₖ) with ones there."""
    for k in keys:
        if k not in ordering.offset_of:
            raise UnknownVariableError(f"variable {k!r} is not in the system")
    cols = np.concatenate([ordering.offset_of[k] + np.arange(ordering.dims[ordering.position[k]]) for k in keys])
    E = np.zeros((ordering.total_dim, len(cols)))
    E[cols, np.arange(len(cols))] = 1.0
    return cols, E


def _chunks(ordering: Ordering, groups: Sequence[Sequence[Key]], columns: int) -> Iterator[list[int]]:
    """Indices of ``groups`` in consecutive runs of at most ``columns`` scalar columns (one group at least)."""
    chunk: list[int] = []
    width = 0
    for g, keys in enumerate(groups):
        d = sum(ordering.dims[ordering.position[k]] for k in keys if k in ordering.position)  # unknown: named later
        if chunk and width + d > columns:
            yield chunk
            chunk, width = [], 0
        chunk.append(g)
        width += d
    if chunk:
        yield chunk


def _blocks_of_inverse(chol: SparseCholesky, ordering: Ordering, groups: Sequence[Sequence[Key]], max_entries: int = 4_000_000) -> list[NDArray]:
    """The block of 𝓘⁻¹ of each group of keys, from one factorization, solving for as many groups at a
    time as keep the dense right-hand side within ``max_entries`` numbers (32 MB by default)."""
    out: list[NDArray] = []
    for chunk in _chunks(ordering, groups, max(max_entries // max(ordering.total_dim, 1), 1)):
        cols, E = _unit_columns(ordering, [k for g in chunk for k in groups[g]])
        X, o = np.asarray(chol.solve(E))[cols], 0
        for g in chunk:
            d = sum(ordering.dims[ordering.position[k]] for k in groups[g])
            out.append(_symmetric(X[o : o + d, o : o + d]))
            o += d
    return out


def marginal_covariances(system: LinearSystem, keys: list[Key], backend: str | None = None) -> dict[Key, NDArray]:
    """Marginal covariance blocks (𝓘⁻¹)ₖₖ (dₖ, dₖ) of chosen variables.  [YIB Eq. 11: cov δθ* = 𝓘⁻¹]"""
    info, _ = system.information()
    chol = SparseCholesky.factor(info, system.ordering, backend)
    return dict(zip(keys, _blocks_of_inverse(chol, system.ordering, [[k] for k in keys])))


def _factor_at(factors: Sequence[Factor], values: Values, backend: str | None) -> tuple[Ordering, SparseCholesky]:
    """𝓘 of ``factors`` linearized at ``values``, factored in AMD order."""
    variables = list(dict.fromkeys(k for f in factors for k in f.keys))  # first-seen order
    dims = {k: values.dim(k) for k in variables}
    order = make_ordering("amd", variables, dims, (f.keys for f in factors), backend)
    info, _ = LinearSystem.build(factors, values, order).information()
    return order, SparseCholesky.factor(info, order, backend)


def sparse_joint_covariance(
    factors: Sequence[Factor], values: Values, keys: Sequence[Key], backend: str | None = None
) -> NDArray:
    """Joint block of 𝓘⁻¹ for ``keys`` (Σdₖ, Σdₖ), stacked in the order given, linearized at ``values``.

    One sparse Cholesky factorization (AMD order) and one solve with Σdₖ right-hand sides.
    [YIB Eq. 11: cov δθ* = 𝓘⁻¹]
    """
    order, chol = _factor_at(factors, values, backend)
    cols, E = _unit_columns(order, keys)
    block = np.asarray(chol.solve(E))[cols]
    return 0.5 * (block + block.T)


def sparse_marginals(
    factors: Sequence[Factor], values: Values, keys: Sequence[Key], backend: str | None = None
) -> dict[Key, NDArray]:
    """Marginal covariance (dₖ, dₖ) of each of ``keys``, linearized at ``values``: one factorization."""
    order, chol = _factor_at(factors, values, backend)
    keys = list(keys)
    return dict(zip(keys, _blocks_of_inverse(chol, order, [[k] for k in keys])))


def sparse_joint_marginals(
    factors: Sequence[Factor], values: Values, groups: Sequence[Sequence[Key]], backend: str | None = None
) -> list[NDArray]:
    """Joint covariance of each group of ``keys`` (stacked in the order given), linearized at ``values``:
    one factorization for all groups."""
    order, chol = _factor_at(factors, values, backend)
    return _blocks_of_inverse(chol, order, [list(g) for g in groups])


# --- from the Bayes tree ------------------------------------------------------------------------


def _clique_covariance(clique: Conditional, Sigma_SS: NDArray) -> tuple[NDArray, Index]:
    """Joint covariance (n_f + n_s, n_f + n_s) of the clique's variables, F then S, from Σ_SS.  [K11 Sec. 3]"""
    nf = clique.R.shape[0]
    Rinv = lapack.dtrtrs(clique.R, np.eye(nf))[0]  # R⁻¹ by triangular solves
    RinvS = Rinv @ clique.S
    cov_FS = -RinvS @ Sigma_SS
    cov_FF = Rinv @ Rinv.T - cov_FS @ RinvS.T
    joint = np.block([[cov_FF, cov_FS], [cov_FS.T, Sigma_SS]])
    index, o = {}, 0
    for k, dim in zip(clique.frontals + clique.separator, clique.frontal_dims + clique.separator_dims):
        index[k] = (o, dim)
        o += dim
    return joint, index


def _block(joint: NDArray, index: Index, keys: Iterable[Key]) -> NDArray:
    """The rows and columns of ``keys`` (stacked in the order given) of a joint covariance."""
    sel = [np.arange(o, o + dim) for o, dim in (index[k] for k in keys)]
    idx = np.concatenate(sel) if sel else np.zeros(0, int)
    return joint[np.ix_(idx, idx)]


def _symmetric(block: NDArray) -> NDArray:
    return 0.5 * (block + block.T)


def _path_covariance(tree: BayesTree, cid: int) -> tuple[NDArray, Index]:
    """Joint covariance of clique ``cid``'s variables (F then S), walking down from its root."""
    joint, index = np.zeros((0, 0)), {}
    for c in tree.path_to_root(cid)[::-1]:
        clique = tree.cliques[c]
        joint, index = _clique_covariance(clique, _block(joint, index, clique.separator))
    return joint, index


def tree_marginal_covariance(tree: BayesTree, key: Key) -> NDArray:
    """Cov(δθ_key) = (𝓘⁻¹)_key,key (d, d) from the tree, walking down from the root.  [K11 Sec. 3]

    Costs one small dense step per clique on the path from the root to the variable's clique.
    """
    joint, index = _path_covariance(tree, tree.clique_containing(key))
    return _symmetric(_block(joint, index, [key]))


def tree_joint_covariance(tree: BayesTree, keys: Sequence[Key]) -> NDArray:
    """Joint covariance of several variables (Σdₖ, Σdₖ), stacked in the order given, from the tree.

    When one clique holds them all, its joint covariance from the root walk is used. Otherwise:
    the cliques on the paths from the variables to the root are closed under taking parents, so
    their conditionals alone are the joint density of their variables [K11 Sec. 3], and the
    covariance is (R_Uᵀ R_U)⁻¹ restricted to ``keys``, found by two sparse triangular solves.
    """
    keys = list(keys)
    for k in keys:
        clique = tree.cliques[tree.clique_containing(k)]
        if set(keys) <= set(clique.frontals) | set(clique.separator):
            joint, index = _path_covariance(tree, tree.frontal_of[k])
            return _symmetric(_block(joint, index, keys))
    return _upper_closed_covariance(tree, keys)


def _upper_closed_covariance(tree: BayesTree, keys: list[Key]) -> NDArray:
    """Cov of ``keys`` from R_U of the cliques on their root paths (sparse triangular solves)."""
    depth: dict[int, int] = {}
    for k in keys:
        path = tree.path_to_root(tree.clique_containing(k))
        for i, c in enumerate(path):
            depth[c] = len(path) - 1 - i
    cids = sorted(depth, key=lambda c: -depth[c])  # children before parents
    order = [v for c in cids for v in tree.cliques[c].frontals]
    dims = {v: d for c in cids for v, d in zip(tree.cliques[c].frontals, tree.cliques[c].frontal_dims)}
    ordering = Ordering(tuple(order), tuple(dims[v] for v in order))
    Rs = sp.csr_matrix(assemble_sqrt_information(ordering, [tree.cliques[c] for c in cids]))
    cols, E = _unit_columns(ordering, keys)
    Y = spla.spsolve_triangular(Rs.T.tocsr(), E, lower=True)  # Rᵀ Y = E
    X = spla.spsolve_triangular(Rs, Y, lower=False)  # R X = Y: X = (RᵀR)⁻¹ E
    return _symmetric(X[cols])


def _cliques_on_root_paths(tree: BayesTree, keys: Iterable[Key]) -> set[int]:
    """Ids of the cliques on the paths from the variables' cliques up to their roots (each visited once)."""
    needed: set[int] = set()
    for k in keys:
        c: int | None = tree.clique_containing(k)
        while c is not None and c not in needed:
            needed.add(c)
            c = tree.parent[c]
    return needed


def _walk_down(tree: BayesTree, needed: set[int] | None) -> Iterator[tuple[int, NDArray, Index]]:
    """Each clique of ``needed`` (all when None), parents first, with its joint covariance of F ∪ S.

    One walk down the tree [K11 Sec. 3]: a clique's joint follows from Σ_SS, the block of its parent's
    joint; the stack holds, for each clique still to visit, only its Σ_SS.
    """
    stack = [(r, np.zeros((0, 0))) for r in tree.roots if needed is None or r in needed]
    while stack:
        c, Sigma_SS = stack.pop()
        joint, index = _clique_covariance(tree.cliques[c], Sigma_SS)
        yield c, joint, index
        for ch in tree.children[c]:
            if needed is None or ch in needed:
                stack.append((ch, _block(joint, index, tree.cliques[ch].separator)))


def tree_marginals(tree: BayesTree, keys: Iterable[Key] | None = None) -> dict[Key, NDArray]:
    """Marginal covariance (dₖ, dₖ) of every variable in ``keys`` (all when None), in one pass.  [K11 Sec. 3]

    The frontal blocks of each clique's joint covariance (:func:`_walk_down`) are the marginals. Only
    the cliques on the root paths of ``keys`` are visited: O(cliques), not O(variables × depth) as one
    :func:`tree_marginal_covariance` per variable would cost.
    """
    wanted = None if keys is None else list(dict.fromkeys(keys))
    needed = None if wanted is None else _cliques_on_root_paths(tree, wanted)
    out: dict[Key, NDArray] = {}
    for c, joint, index in _walk_down(tree, needed):
        for k in tree.cliques[c].frontals:
            out[k] = _symmetric(_block(joint, index, [k]))
    return out if wanted is None else {k: out[k] for k in wanted}


def tree_joint_marginals(tree: BayesTree, groups: Sequence[Sequence[Key]]) -> list[NDArray]:
    """Joint covariance of each group of variables (stacked in the order given), from the tree.

    A group that one clique holds whole (two consecutive states of a trajectory, say) is cut from that
    clique's joint in one walk down the tree (:func:`_walk_down`); any other group goes through
    :func:`tree_joint_covariance`.
    """
    home: dict[int, list[int]] = {}  # clique id → the groups it holds whole
    out: list[NDArray | None] = [None] * len(groups)
    for g, keys in enumerate(groups):
        holders = (tree.clique_containing(k) for k in keys)
        c = next((c for c in holders if set(keys) <= set(tree.cliques[c].frontals) | set(tree.cliques[c].separator)), None)
        if c is None:
            out[g] = tree_joint_covariance(tree, keys)
        else:
            home.setdefault(c, []).append(g)
    needed = _cliques_on_root_paths(tree, (tree.cliques[c].frontals[0] for c in home))
    for c, joint, index in _walk_down(tree, needed):
        for g in home.get(c, ()):
            out[g] = _symmetric(_block(joint, index, groups[g]))
    return out  # type: ignore[return-value]
