"""Relaxed amalgamation: which cliques of an elimination to merge into their parents.  [AG89]

A clique with n_f frontal and n_s separator numbers holds the dense rows [R S] of R: n_f(n_f + 1)/2 + n_f·n_s
entries (GTSAM's ``treeNnz`` count, :mod:`steam_ref.bayes_tree.dot`). Merging a child into its parent makes one clique
of both frontal sets over the parent's separator (the child's separator lies within the parent's variables); its rows
are dense, so every entry the two cliques did not hold is an explicit zero. Ashcraft & Grimes merge while the merged
clique holds at most a fraction z of explicit zeros (CHOLMOD's ``zrelax``): fewer, larger cliques, so fewer
per-clique costs, for some arithmetic on zeros. The merged clique's conditional is the unmerged cliques' rows
stacked, so R's product RᵀR = 𝓘 and the solution are the same, to rounding [YIB Eq. 21, 25]. With z = 0 nothing
merges: a clique the rule of [K12 Alg. 2] leaves apart always adds a zero.

[AG89]: docs/references.md.
"""

from __future__ import annotations

from collections.abc import Sequence

from ..arguments import number
from ..errors import SteamError

__all__ = ["amalgamate", "zero_fraction"]


def zero_fraction(value: object) -> float:
    """``amalgamation_zeros`` as a float in [0, 1); SteamError naming the value otherwise."""
    try:
        z = number("amalgamation_zeros", value)
    except SteamError:
        z = -1.0
    if not 0 <= z < 1:
        raise SteamError(f"amalgamation_zeros must be a fraction in [0, 1), got {value!r}")
    return z


def amalgamate(
    frontals: list[list[int]],
    separators: Sequence[Sequence[int]],
    parents: Sequence[int | None],
    sizes: Sequence[int],
    zeros: float,
) -> list[int]:
    """Merge cliques into their parents while a merged clique holds at most the fraction ``zeros`` of explicit zeros.

    The cliques are numbered parents first (``parents[c] < c``), each given by its list of frontal variables, in
    reverse elimination order, and its separator, every variable as its place in the elimination order; ``sizes`` is
    the size of each place. Each clique is tried once, after all its children, so a merged clique may merge on up. A
    merged clique's frontals are appended to its parent's list (so they come first in elimination order). Returns the
    clique each clique is now part of (itself when kept)."""
    size = sizes.__getitem__
    nf, ns = [sum(map(size, f)) for f in frontals], [sum(map(size, s)) for s in separators]
    nnz = [f * (f + 1) // 2 + f * s for f, s in zip(nf, ns, strict=True)]  # entries the unmerged cliques hold
    home = list(range(len(nf)))
    for c in reversed(range(len(nf))):
        p = parents[c]
        if p is not None:
            f = nf[c] + nf[p]
            entries = f * (f + 1) // 2 + f * ns[p]  # the merged clique, over the parent's separator
            if entries - nnz[c] - nnz[p] <= zeros * entries:
                home[c], nf[p], nnz[p] = p, f, nnz[p] + nnz[c]
                frontals[p].extend(frontals[c])
    for c in range(len(home)):  # parents first: the parent's home is known
        home[c] = home[home[c]]
    return home
