"""The settings of iSAM2, in one place.  [K12 Sec. 5, Alg. 5, Alg. 7]

The defaults are GTSAM's ``ISAM2Params`` defaults (relinearization threshold 0.1, checked every
10th update, wildfire threshold 0.001), which the paper's scripts use [YIB Sec. IV].
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..arguments import integer, is_integer, number, replace_fields
from ..choices import GTSAM_RELINEARIZE_SKIP, GTSAM_RELINEARIZE_THRESHOLD
from ..errors import ShapeError, SteamError
from ..linear.amalgamation import zero_fraction
from ..variables import check_symbol

__all__ = ["ISAM2Params"]


def _blocks(symbol: str, sizes: object) -> tuple[int, ...]:
    """Block sizes as a tuple of positive ints; SteamError naming them otherwise."""
    check_symbol(symbol, "a key of relinearize_blocks (a key's symbol, such as 'x' or 'l')")
    bad = SteamError(f"relinearize_blocks[{symbol!r}] must be positive integer block sizes, got {sizes!r}")
    if isinstance(sizes, (str, bytes)) or not isinstance(sizes, (tuple, list, np.ndarray)) or not len(sizes):
        raise bad
    try:
        return tuple(integer("a block size", n, minimum=1) for n in sizes)
    except SteamError:
        raise bad from None


def _threshold(value: object, name: str) -> float:
    """``value`` as a float ≥ 0 (inf allowed); SteamError naming it otherwise (bool, string, NaN, < 0)."""
    try:
        t = number(name, value, finite=False)
    except SteamError:
        raise SteamError(f"{name} must be a number >= 0, got {value!r}") from None
    if t < 0:
        raise SteamError(f"{name} must be >= 0, got {value!r}")
    return t


@dataclass(frozen=True)
class ISAM2Params:
    """How an :class:`~steam_ref.bayes_tree.IncrementalSolver` relinearizes and back-substitutes.

    With both thresholds 0 and skip 1, each update is one Gauss-Newton step on all factors so far.
    """

    # β of [K12 Alg. 5]: relinearize a variable when max |δ| ≥ β; one float, or one per symbol {'x': 0.1, 'l': 0.5}
    relinearize_threshold: float | Mapping[str, float] = GTSAM_RELINEARIZE_THRESHOLD
    # check for relinearization every k-th update only (GTSAM's relinearizeSkip)
    relinearize_skip: int = GTSAM_RELINEARIZE_SKIP
    # α of [K12 Alg. 7]: back-substitution descends only where δ changed by at least α (0: full)
    wildfire_threshold: float = 1e-3
    # symbol → block sizes: relinearize each block of such a variable on its own, as GTSAM would if it
    # held the blocks as separate variables (the paper's scripts hold a state as pose P and velocity
    # V: {'x': (3, 3)}); None: every variable is one block
    relinearize_blocks: Mapping[str, tuple[int, ...]] | None = None
    # merge a clique into its parent while the merged clique's rows of R hold at most this fraction of explicit
    # zeros (relaxed amalgamation [AG89], CHOLMOD's zrelax: linear/amalgamation.py); 0: [K12 Alg. 2]'s cliques
    amalgamation_zeros: float = 0.0

    def __post_init__(self) -> None:
        t = self.relinearize_threshold
        if isinstance(t, Mapping):
            t = {
                check_symbol(symbol, "a key of relinearize_threshold (a key's symbol, such as 'x' or 'l')"): _threshold(
                    v, f"relinearize_threshold[{symbol!r}]"
                )
                for symbol, v in t.items()
            }
        else:
            t = _threshold(t, "relinearize_threshold")
        object.__setattr__(self, "relinearize_threshold", t)
        skip: object = self.relinearize_skip  # as given: checked here
        if not is_integer(skip) or skip < 1:
            raise SteamError(f"relinearize_skip must be a positive integer, got {skip!r}")
        object.__setattr__(self, "relinearize_skip", int(skip))
        object.__setattr__(self, "wildfire_threshold", _threshold(self.wildfire_threshold, "wildfire_threshold"))
        object.__setattr__(self, "amalgamation_zeros", zero_fraction(self.amalgamation_zeros))
        if self.relinearize_blocks is not None:
            if not isinstance(self.relinearize_blocks, Mapping):
                raise SteamError(
                    "relinearize_blocks must map a key's symbol to block sizes, e.g. {'x': (3, 3)}; "
                    f"got {self.relinearize_blocks!r}"
                )
            object.__setattr__(
                self, "relinearize_blocks", {k: _blocks(k, v) for k, v in self.relinearize_blocks.items()}
            )

    def blocks_of(self, symbol: str, size: int) -> tuple[int, ...]:
        """Block sizes of a variable of ``symbol`` and ``size``; ShapeError when its blocks do not fit it."""
        sizes = (self.relinearize_blocks or {}).get(symbol, (size,))
        if sum(sizes) != size:
            raise ShapeError(f"relinearize_blocks {sizes} for symbol {symbol!r} do not add up to its size {size}")
        return sizes

    def blocks_to_move(self, symbol: str, delta: NDArray, threshold: float) -> NDArray:
        """(d,) bool: the entries of a variable of ``symbol`` whose block has max abs(δ) ≥ ``threshold``."""
        sizes = self.blocks_of(symbol, len(delta))
        bounds = np.cumsum((0, *sizes))
        return np.repeat([np.abs(delta[a:b]).max() >= threshold for a, b in itertools.pairwise(bounds)], sizes)

    def threshold_for(self, symbol: str) -> float:
        """β for variables of ``symbol`` ('x', 'l', ...); SteamError when a per-symbol dict lacks it."""
        t = self.relinearize_threshold
        if not isinstance(t, Mapping):  # a dict after __post_init__
            return t
        try:
            return t[symbol]
        except KeyError:
            raise SteamError(f"relinearize_threshold {t!r} has no entry for variables of symbol {symbol!r}") from None

    def replace(self, **changes: Any) -> ISAM2Params:
        """A copy with some fields changed (validated again); SteamError names an unknown field
        (:func:`~steam_ref.arguments.replace_fields`)."""
        return replace_fields(self, changes)
