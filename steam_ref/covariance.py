"""Covariance recovery: blocks of 𝓘⁻¹, the covariance of the Gauss-Newton step.  [YIB Eq. 11, K11 Sec. 3]

cov δθ* = 𝓘⁻¹ = (AᵀA)⁻¹ [YIB Eq. 11]: a covariance of the increment, so it lives in each variable's tangent
space at the point θ̄ where A was linearized (θ = θ̄ ⊕ δ, δ ~ N(0, Σ); :mod:`steam_ref.manifold`), which for a
vector is the space itself. For a batch result θ̄ is its estimate; for the Bayes tree it is the solver's
``linearization_point``, which differs from its estimate θ̄ ⊕ δ by the δ not yet relinearized (below the threshold
β): the tree answers for its current linear system, as GTSAM's ``ISAM2.marginalCovariance`` does, and never
relinearizes to answer. For an SE(2) state (``lie.SE2_STATE``, retracted on the right) the pose block is in the
*body frame* at θ̄; ``lie.world_position_covariance`` turns its position block to the world frame. Two sources:

- the sparse system: :func:`marginal_covariances` and :func:`sparse_joint_covariance` factor 𝓘
  by sparse Cholesky and solve with unit columns;
- the Bayes tree: each clique is P(F | S) ∝ exp(-½ ‖R δ_F + S δ_S - d‖²), so from Σ_SS (a block
  of its parent's joint covariance) [K11 Sec. 3]

      Cov(F, S) = -R⁻¹S Σ_SS,    Cov(F, F) = R⁻¹R⁻ᵀ + R⁻¹S Σ_SS (R⁻¹S)ᵀ,

  and a walk down from the root gives any clique's joint covariance. :func:`tree_marginal_covariances`
  does every clique in one such walk. :func:`tree_joint_covariance` serves any set of variables, in
  cliques however far apart, by one walk down their root paths: F is independent of every variable
  outside its clique's subtree given S, so Cov(F, C) = -R⁻¹S Σ_SC for any C already visited, and
  the walk carries the joint of only the variables still needed. Nothing of size n × n is formed.

One vocabulary, GTSAM's (``marginalCovariance``, ``jointMarginalCovariance``), here and on every
solver (``IncrementalSolver``, the stream solvers of :mod:`steam_ref.paper.solvers`):

- ``marginal_covariance(key)``: the (d, d) block of one variable;
- ``marginal_covariances(keys)``: that block for each of several variables, as a dict (a key named twice is
  refused, naming it: a dict cannot hold it twice);
- ``joint_covariance(keys)``: the joint (Σdₖ, Σdₖ) block of several variables, stacked in the order given (a
  key named twice repeats its rows and columns, as any selection of rows would);
- ``joint_covariances(groups)``: the joint block of each group of variables, as a list.

The functions below prefix them with their source: ``sparse_`` (factors linearized at an estimate),
``tree_`` (a Bayes tree); :func:`marginal_covariances` reads a built :class:`LinearSystem`.
:class:`SparseCovariances` gives a batch result (:class:`~steam_ref.batch.BatchResult`) the four
queries, from its factors linearized at its estimate.

Nothing here imports the Bayes tree package (which builds on this module); a tree is anything with
the :class:`~steam_ref.bayes_tree.tree.BayesTree` attributes used below.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Sequence
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import lapack

from .errors import SteamError, UnknownVariableError
from .factors import Factor, check_factors
from .linear.cholesky import SparseCholesky, check_system
from .linear.conditional import Conditional
from .linear.ordering import Ordering, make_ordering
from .linear.system import LinearSystem
from .linear.threads import limited
from .manifold import Manifold
from .variables import Key, Values, as_values, check_key, key_list

if TYPE_CHECKING:
    from .bayes_tree.tree import BayesTree

__all__ = [
    "SparseCovariances",
    "key_groups",
    "marginal_covariances",
    "sparse_joint_covariance",
    "sparse_marginal_covariances",
    "sparse_joint_covariances",
    "tree_marginal_covariance",
    "tree_joint_covariance",
    "tree_marginal_covariances",
    "tree_joint_covariances",
]

Index = dict[Key, tuple[int, int]]  # variable → (first row, size) in a joint covariance


# --- from the sparse system ---------------------------------------------------------------------


def _unit_columns(ordering: Ordering, keys: Sequence[Key]) -> tuple[NDArray, NDArray]:
    """The scalar columns of ``keys`` (stacked in the order given), and E (n, Σdₖ) with ones there."""
    for k in keys:
        if k not in ordering.offset_of:
            raise UnknownVariableError(f"variable {k!r} is not in the system")
    cols = np.concatenate(
        [ordering.offset_of[k] + np.arange(ordering.dims[ordering.position[k]]) for k in keys] or [np.zeros(0, int)]
    )
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


def _blocks_of_inverse(
    chol: SparseCholesky, ordering: Ordering, groups: Sequence[Sequence[Key]], max_entries: int = 4_000_000
) -> list[NDArray]:
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


@limited
def marginal_covariances(system: LinearSystem, keys: list[Key], backend: str | None = None) -> dict[Key, NDArray]:
    """Marginal covariance blocks (𝓘⁻¹)ₖₖ (dₖ, dₖ) of chosen variables.  [YIB Eq. 11: cov δθ* = 𝓘⁻¹]"""
    check_system(system)
    keys = key_list("keys", keys, distinct=True)
    info, _ = system.information()
    chol = SparseCholesky.factor(info, system.ordering, backend, check_symmetry=False)  # AᵀA
    return dict(zip(keys, _blocks_of_inverse(chol, system.ordering, [[k] for k in keys]), strict=True))


def _factor_at(factors: Sequence[Factor], values: Values, backend: str | None) -> tuple[Ordering, SparseCholesky]:
    """𝓘 of ``factors`` linearized at ``values`` (a Values or a mapping), factored in AMD order."""
    factors, values = check_factors("factors", factors), as_values("values", values)
    variables = list(dict.fromkeys(k for f in factors for k in f.keys))  # first-seen order
    dims = {k: values.dim(k) for k in variables}
    order = make_ordering("amd", variables, dims, (f.keys for f in factors), backend)
    info, _ = LinearSystem.build(factors, values, order).information()
    return order, SparseCholesky.factor(info, order, backend, check_symmetry=False)  # AᵀA


@limited
def sparse_joint_covariance(
    factors: Sequence[Factor], values: Values, keys: Sequence[Key], backend: str | None = None
) -> NDArray:
    """Joint block of 𝓘⁻¹ for ``keys`` (Σdₖ, Σdₖ), stacked in the order given, linearized at ``values``.

    One sparse Cholesky factorization (AMD order) and one solve with Σdₖ right-hand sides.
    [YIB Eq. 11: cov δθ* = 𝓘⁻¹]
    """
    keys = key_list("keys", keys)
    order, chol = _factor_at(factors, values, backend)
    cols, E = _unit_columns(order, keys)
    block = np.asarray(chol.solve(E))[cols]
    return 0.5 * (block + block.T)


@limited
def sparse_marginal_covariances(
    factors: Sequence[Factor], values: Values, keys: Sequence[Key], backend: str | None = None
) -> dict[Key, NDArray]:
    """Marginal covariance (dₖ, dₖ) of each of ``keys``, linearized at ``values``: one factorization."""
    keys = key_list("keys", keys, distinct=True)
    order, chol = _factor_at(factors, values, backend)
    return dict(zip(keys, _blocks_of_inverse(chol, order, [[k] for k in keys]), strict=True))


@limited
def sparse_joint_covariances(
    factors: Sequence[Factor], values: Values, groups: Sequence[Sequence[Key]], backend: str | None = None
) -> list[NDArray]:
    """Joint covariance of each group of ``keys`` (stacked in the order given), linearized at ``values``:
    one factorization for all groups."""
    groups = key_groups(groups)
    order, chol = _factor_at(factors, values, backend)
    return _blocks_of_inverse(chol, order, groups)


class SparseCovariances:
    """The four covariance queries of an estimate θ̄ and the factors it was solved with: blocks of 𝓘⁻¹,
    𝓘 = AᵀA with every factor linearized at θ̄ (the final linearization).  [YIB Eq. 11]

    A class that mixes this in has ``values`` (θ̄) and ``factors`` (a tuple; empty: none kept). Each query
    factors 𝓘 once (sparse Cholesky, AMD order); ask for several variables in one call to share it.
    """

    values: Values
    factors: tuple[Factor, ...]

    def estimate(self) -> Values:
        """The estimate θ̄ (a copy), as a solver's ``estimate()``: what a ``Trajectory`` reads."""
        return self.values.copy()

    def estimate_of(self, key: Key) -> NDArray:
        """The estimate of one variable (read-only), as a solver's ``estimate_of(key)``."""
        out = self.values[check_key("key", key)].view()
        out.flags.writeable = False
        return out

    def kind_of(self, key: Key) -> Manifold:
        """How one variable's estimate moves (:mod:`steam_ref.manifold`), as a solver's ``kind_of(key)``."""
        return self.values.kind(check_key("key", key))

    def _kept(self) -> tuple[Factor, ...]:
        if not self.factors:
            raise SteamError(f"this {type(self).__name__} keeps no factors, so it has no covariance to give")
        return self.factors

    def marginal_covariance(self, key: Key) -> NDArray:
        """Cov(δθ_key) = (𝓘⁻¹)_key,key (d, d) at the estimate.  [YIB Eq. 11]"""
        return sparse_joint_covariance(self._kept(), self.values, [check_key("key", key)])

    def marginal_covariances(self, keys: Iterable[Key]) -> dict[Key, NDArray]:
        """Marginal covariance (dₖ, dₖ) of each of ``keys``, from one factorization."""
        return sparse_marginal_covariances(self._kept(), self.values, key_list("keys", keys))

    def joint_covariance(self, keys: Iterable[Key]) -> NDArray:
        """Joint covariance (Σdₖ, Σdₖ) of ``keys``, stacked in the order given."""
        return sparse_joint_covariance(self._kept(), self.values, key_list("keys", keys))

    def joint_covariances(self, groups: Iterable[Iterable[Key]]) -> list[NDArray]:
        """Joint covariance of each group of keys (stacked in the order given), from one factorization."""
        return sparse_joint_covariances(self._kept(), self.values, key_groups(groups))


def key_groups(groups: object) -> list[list[Key]]:
    """Each group of keys as a list; a group that is a single key (not a list of keys) is an error."""
    if isinstance(groups, (str, bytes, Key)) or not isinstance(groups, Iterable):
        raise SteamError(f"groups must be a list of lists of keys, got groups={groups!r}")
    return [key_list(f"groups[{g}]", keys) for g, keys in enumerate(groups)]


# --- from the Bayes tree ------------------------------------------------------------------------


def _extend(clique: Conditional, joint: NDArray, index: Index, keep: set[Key] | None = None) -> tuple[NDArray, Index]:
    """Joint covariance of the carried variables (those of ``keep``; all when None) and the clique's
    frontals, from the joint of the carried ones, which must hold the clique's separator.  [K11 Sec. 3]

    The carried variables lie outside the clique's subtree, so given S they are independent of F:
    Cov(F, C) = -R⁻¹S Σ_SC for every carried C, and Cov(F, F) = R⁻¹R⁻ᵀ + R⁻¹S Σ_SS (R⁻¹S)ᵀ.
    Returns the carried block first, then the frontals.
    """
    Rinv = lapack.dtrtri(clique.R)[0]  # R⁻¹; not dtrtrs(R, I), which OpenBLAS threads: ~50× slower on a busy machine
    RinvS = Rinv @ clique.S
    s = _indices(index, clique.separator)
    cov_FC = -RinvS @ joint[s]  # (n_f, carried)
    cov_FF = Rinv @ Rinv.T - cov_FC[:, s] @ RinvS.T
    kept = [k for k in index if keep is None or k in keep]
    c = _indices(index, kept)
    m, nf = len(c), clique.R.shape[0]
    out = np.empty((m + nf, m + nf))
    out[:m, :m] = joint[np.ix_(c, c)]
    out[m:, :m] = cov_FC[:, c]
    out[:m, m:] = out[m:, :m].T
    out[m:, m:] = cov_FF
    new_index, o = {}, 0
    for k, dim in zip(
        kept + list(clique.frontals), [index[k][1] for k in kept] + list(clique.frontal_dims), strict=True
    ):
        new_index[k] = (o, dim)
        o += dim
    return out, new_index


def _clique_covariance(clique: Conditional, Sigma_SS: NDArray) -> tuple[NDArray, Index]:
    """Joint covariance (n_s + n_f, n_s + n_f) of the clique's variables, S then F, from Σ_SS.  [K11 Sec. 3]"""
    index, o = {}, 0
    for k, dim in zip(clique.separator, clique.separator_dims, strict=True):
        index[k] = (o, dim)
        o += dim
    return _extend(clique, Sigma_SS, index)


def _indices(index: Index, keys: Iterable[Key]) -> NDArray:
    """The scalar rows of ``keys`` (stacked in the order given) in a joint covariance."""
    sel = [np.arange(o, o + dim) for o, dim in (index[k] for k in keys)]
    return np.concatenate(sel) if sel else np.zeros(0, int)


def _block(joint: NDArray, index: Index, keys: Iterable[Key]) -> NDArray:
    """The rows and columns of ``keys`` (stacked in the order given) of a joint covariance."""
    idx = _indices(index, keys)
    return joint[np.ix_(idx, idx)]


def _symmetric(block: NDArray) -> NDArray:
    return 0.5 * (block + block.T)


@limited
def tree_marginal_covariance(tree: BayesTree, key: Key) -> NDArray:
    """Cov(δθ_key) = (𝓘⁻¹)_key,key (d, d) from the tree, walking down from the root.  [K11 Sec. 3]

    Costs one small dense step per clique on the path from the root to the variable's clique.
    """
    return tree_joint_covariance(tree, [check_key("key", key)])


@limited
def tree_joint_covariance(tree: BayesTree, keys: Iterable[Key]) -> NDArray:
    """Joint covariance of several variables (Σdₖ, Σdₖ), stacked in the order given, from the tree.

    One walk down the cliques on the variables' root paths [K11 Sec. 3], carrying the joint
    covariance of only the variables still needed: the requested ones met so far and the
    separators of the cliques still to visit (:func:`_extend`). Time is one small dense step per
    clique on those paths; memory is the carried joint, whose size depends on the number of
    requested variables and the separators' sizes, not on how far apart the variables are.
    """
    keys = key_list("keys", keys)
    wanted = set(keys)
    needed = _cliques_on_root_paths(tree, keys)  # names an unknown key
    joint, index = np.zeros((0, 0)), Index()
    stack = [r for r in tree.roots if r in needed]
    while stack:
        c = stack.pop()
        stack.extend(ch for ch in tree.children[c] if ch in needed)
        keep = wanted.union(*(tree.cliques[p].separator for p in stack))
        joint, index = _extend(tree.cliques[c], joint, index, keep)
    return _symmetric(_block(joint, index, keys))


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


@limited
def tree_marginal_covariances(tree: BayesTree, keys: Iterable[Key] | None = None) -> dict[Key, NDArray]:
    """Marginal covariance (dₖ, dₖ) of every variable in ``keys`` (all when None), in one pass.  [K11 Sec. 3]

    The frontal blocks of each clique's joint covariance (:func:`_walk_down`) are the marginals. Only
    the cliques on the root paths of ``keys`` are visited: O(cliques), not O(variables × depth) as one
    :func:`tree_marginal_covariance` per variable would cost.
    """
    wanted = None if keys is None else key_list("keys", keys, distinct=True)
    needed = None if wanted is None else _cliques_on_root_paths(tree, wanted)
    out: dict[Key, NDArray] = {}
    for c, joint, index in _walk_down(tree, needed):
        for k in tree.cliques[c].frontals:
            out[k] = _symmetric(_block(joint, index, [k]))
    return out if wanted is None else {k: out[k] for k in wanted}


@limited
def tree_joint_covariances(tree: BayesTree, groups: Iterable[Iterable[Key]]) -> list[NDArray]:
    """Joint covariance of each group of variables (stacked in the order given), from the tree.

    A group that one clique holds whole (two consecutive states of a trajectory, say) is cut from that
    clique's joint in one walk down the tree (:func:`_walk_down`); any other group goes through
    :func:`tree_joint_covariance`.
    """
    groups = key_groups(groups)
    home: dict[int, list[int]] = {}  # clique id → the groups it holds whole
    out: list[NDArray | None] = [None] * len(groups)
    for g, keys in enumerate(groups):
        holders = (tree.clique_containing(k) for k in keys)
        c = next(
            (c for c in holders if set(keys) <= set(tree.cliques[c].frontals) | set(tree.cliques[c].separator)), None
        )
        if c is None:
            out[g] = tree_joint_covariance(tree, keys)
        else:
            home.setdefault(c, []).append(g)
    needed = _cliques_on_root_paths(tree, (tree.cliques[c].frontals[0] for c in home))
    for c, joint, index in _walk_down(tree, needed):
        for g in home.get(c, ()):
            out[g] = _symmetric(_block(joint, index, groups[g]))
    return out  # type: ignore[return-value]
