"""The ``incremental`` suite: the trajectory problem given to iSAM2 over five updates (:func:`.problems.trajectory_stream`),
relinearizing at every update or never (kit v1), or partially, with the tree edits and the fill of R (kit v2)."""

from __future__ import annotations

from .base import EXACT, Case, tol
from .problems import trajectory_stream

__all__ = ["incremental_cases"]

PARTIAL = {"relinearize_threshold": 0.05, "relinearize_skip": 1, "wildfire_threshold": 0.0}
PARTIAL_SKIP2 = {"relinearize_threshold": 0.05, "relinearize_skip": 2, "wildfire_threshold": 0.0}
EVERY = {"relinearize_threshold": 0.0, "relinearize_skip": 1, "wildfire_threshold": 0.0}
NEVER = {"relinearize_threshold": "inf", "relinearize_skip": 1, "wildfire_threshold": 0.0}
ORACLE_REPLAY = "oracle: per variable linearization points, dense linearization and solve per update"
ORDER_RULE = (
    "Depends on the elimination order of the removed part (the tree-edit ordering rule of the conventions, "
    "'tree_edits'); nnz_k counts R as GTSAM's ISAM2::treeNnz does"
)


def incremental_cases() -> list[Case]:
    stream = trajectory_stream()
    n = len(stream["updates"])
    est = {f"estimate_{k}": tol(1e-8, 1e-12) for k in range(1, n + 1)}
    return [
        Case(
            "relinearize_every_update_estimates",
            "[YIB Alg. 1, Eq. 9-11]",
            "five updates of iSAM2 with relinearization threshold 0 checked every update and full back-substitution "
            "(wildfire 0): each update is one Gauss-Newton step on every factor so far; the estimate after each",
            {"stream": stream, "isam2": EVERY},
            est,
            True,
            "oracle: one dense Gauss-Newton step per update",
        ),
        Case(
            "no_relinearization_estimates",
            "[YIB Alg. 1, Eq. 9-11]",
            "the same stream with relinearization off (threshold inf) and wildfire 0: every factor stays linearized "
            "at the values first given; the estimate after each update",
            {"stream": stream, "isam2": NEVER},
            est,
            True,
            "oracle: the dense linear solve at the first linearization point",
        ),
        Case(
            "no_relinearization_tree_edits",
            "[YIB Alg. 1 steps 2-5]",
            "the same run: after each update, the cliques removed from the top of the tree and the orphaned subtrees "
            "reattached, each named by its frontal variables. Depends on the elimination order of the removed part "
            "(the tree-edit ordering rule of the conventions, 'tree_edits'); nnz_k is the fill of R after update k, "
            "counted as GTSAM's ISAM2::treeNnz does",
            {"stream": stream, "isam2": NEVER},
            {**{f"update_{k}": EXACT for k in range(1, n + 1)}, **{f"nnz_{k}": EXACT for k in range(1, n + 1)}},
            False,
            "produced by steam_ref",
        ),
        *_partial_cases(),
        _tie_case(),
    ]


def _tie_case() -> Case:  # kit v5
    def prior(k: str, first: float) -> dict:
        return {"type": "prior", "keys": [k], "mean": [first, 0.0, 0.0, 0.0, 0.0, 0.0], "sigmas": [1.0] * 6}

    zero = [0.0] * 6
    stream = {
        "variables": {"x0": 6, "x1": 6, "x2": 6},
        "updates": [
            {"values": {"x0": zero}, "factors": [prior("x0", 0.25)]},
            {"values": {"x1": zero}, "factors": [prior("x1", 0.125)]},
            {"values": {"x2": zero}, "factors": [prior("x2", 0.25)]},
        ],
    }
    isam2 = {"relinearize_threshold": 0.25, "relinearize_skip": 1, "wildfire_threshold": 0.0}
    return Case(
        "relinearize_on_the_tie",
        "[YIB Alg. 1, Eq. 9-11]",
        "three updates whose variables each have a unit prior, every step exact in binary: after update 1, x0's delta "
        "is 0.25 exactly, the threshold beta = 0.25. Relinearization moves a variable whose max|delta| >= beta, so x0 "
        "is relinearized at update 2 (relinearized_2 = [x0]; a port testing max|delta| > beta relinearizes nothing); "
        "x1's delta 0.125 stays below",
        {"stream": stream, "isam2": isam2},
        {**{f"relinearized_{k}": EXACT for k in (1, 2, 3)}, **{f"estimate_{k}": tol(1e-12, 1e-14) for k in (1, 2, 3)}},
        True,
        "oracle: per-variable linearization points, a dense linearization and solve per update",
    )


def _partial_cases() -> list[Case]:  # kit v2
    stream = trajectory_stream()
    n = len(stream["updates"])
    est = {f"estimate_{k}": tol(1e-8, 1e-12) for k in range(1, n + 1)}
    moved = {f"relinearized_{k}": EXACT for k in range(1, n + 1)}
    edits = {**{f"update_{k}": EXACT for k in range(1, n + 1)}, **{f"nnz_{k}": EXACT for k in range(1, n + 1)}}
    partial = (
        "iSAM2 with relinearization threshold β = 0.05 on max|δ| of each variable, full back-substitution "
        "(wildfire 0): at the start of an update the variables whose last δ has max|δ| ≥ β (and only they) move "
        "their linearization point by δ; the factors are linearized at the linearization points"
    )
    return [
        Case(
            "partial_relinearization_estimates",
            "[YIB Alg. 1, Eq. 9-11]",
            f"the stream of five updates, {partial}, checked every update: the estimate after each, and which "
            "variables were relinearized at each (some, not all)",
            {"stream": stream, "isam2": PARTIAL},
            {**moved, **est},
            True,
            ORACLE_REPLAY,
        ),
        Case(
            "partial_relinearization_skip2_estimates",
            "[YIB Alg. 1, Eq. 9-11]",
            f"the same with the check every second update (relinearize_skip 2: at updates 2 and 4): {partial}",
            {"stream": stream, "isam2": PARTIAL_SKIP2},
            {**moved, **est},
            True,
            ORACLE_REPLAY,
        ),
        Case(
            "partial_relinearization_tree_edits",
            "[YIB Alg. 1 steps 2-5]",
            "the partial relinearization run: after each update the cliques removed and the orphans (each named by "
            f"its frontal variables), and the fill nnz_k of R after it. {ORDER_RULE}",
            {"stream": stream, "isam2": PARTIAL},
            edits,
            False,
            "produced by steam_ref",
        ),
        Case(
            "relinearize_every_update_tree_edits",
            "[YIB Alg. 1 steps 2-5]",
            "relinearization at every update (threshold 0, skip 1): the cliques removed, the orphans and the fill "
            f"nnz_k of R after each update. {ORDER_RULE}",
            {"stream": stream, "isam2": EVERY},
            edits,
            False,
            "produced by steam_ref",
        ),
    ]
