"""Kit v2's new problem cases: a zero increment, a GP heading jump, a bushy tree's joint marginals,
partial relinearization, and the fill of R per update."""

from __future__ import annotations

from .base import EXACT, ORACLE_DENSE, Case, tol
from .graphs import LINEAR_TOL, MARK, STATE, gp_prior_between, range_reading, trajectory_stream, velocity_reading

__all__ = ["linear_cases_v2", "batch_cases_v2", "bayes_tree_cases_v2", "incremental_cases_v2"]

# Every factor holds exactly at these values (all sums and products exact in binary): b = 0, so δ = 0.
AT_OPTIMUM = {
    "variables": {"x0": STATE, "x1": STATE, "l0": MARK},
    "times": {"x0": 0.0, "x1": 0.5},
    "factors": [
        {"type": "prior", "keys": ["x0"], "mean": [0.0, 0.0, 0.0, 1.0, 0.0, 0.0], "sigmas": [0.1] * 6},
        gp_prior_between("x0", "x1"),
        velocity_reading("x1", [1.0, 0.0, 0.0]),
        range_reading("x1", "l0", 5.0),
        {"type": "prior", "keys": ["l0"], "mean": [3.5, 4.0], "sigmas": [0.5, 0.5]},
    ],
    "values": {"x0": [0.0, 0.0, 0.0, 1.0, 0.0, 0.0], "x1": [0.5, 0.0, 0.0, 1.0, 0.0, 0.0], "l0": [3.5, 4.0]},
}

# The second state's heading is stored 2π below the first's (-3.1 vs 3.0): the GP prior's heading error is
# -3.1 - (3.0 + 0.5·0.4) = -6.3, not wrapped (headings are continuous coordinates); wrapped it would be -0.017.
HEADING_JUMP = {
    "variables": {"x0": STATE, "x1": STATE},
    "times": {"x0": 0.0, "x1": 0.5},
    "factors": [
        {"type": "prior", "keys": ["x0"], "mean": [0.0, 0.0, 3.0, -1.0, 0.1, 0.4], "sigmas": [0.1] * 6},
        gp_prior_between("x0", "x1"),
        velocity_reading("x1", [1.0, 0.0, 0.4]),
    ],
    "values": {"x0": [0.0, 0.0, 3.0, -1.0, 0.1, 0.4], "x1": [-0.5, 0.06, -3.1, -1.0, 0.12, 0.38]},
}

# Three states, five landmarks each seen from one state: eliminated landmarks first, the root {x1, x2}
# has four children (x0, l2, l3, l4) and x0's clique two (l0, l1).
BUSHY_SEEN = {"l0": "x0", "l1": "x0", "l2": "x1", "l3": "x2", "l4": "x2"}
BUSHY_AT = {"l0": [2.0, 3.0], "l1": [-1.0, 2.5], "l2": [3.0, -1.5], "l3": [0.5, 4.0], "l4": [4.0, 1.0]}
BUSHY = {
    "variables": {"x0": STATE, "x1": STATE, "x2": STATE, **dict.fromkeys(BUSHY_SEEN, MARK)},
    "times": {"x0": 0.0, "x1": 0.5, "x2": 1.0},
    "factors": [
        {"type": "prior", "keys": ["x0"], "mean": [0.0, 0.0, 0.1, 1.0, 0.1, 0.05], "sigmas": [0.05] * 6},
        gp_prior_between("x0", "x1"),
        gp_prior_between("x1", "x2"),
        velocity_reading("x2", [0.97, 0.0, 0.05]),
        *[
            range_reading(x, lm, r)
            for (lm, x), r in zip(BUSHY_SEEN.items(), (3.58, 2.65, 2.95, 3.65, 2.9), strict=True)
        ],
        *[{"type": "prior", "keys": [lm], "mean": m, "sigmas": [0.4, 0.4]} for lm, m in BUSHY_AT.items()],
    ],
    "values": {
        "x0": [0.0, 0.0, 0.1, 1.0, 0.1, 0.05],
        "x1": [0.5, 0.06, 0.12, 0.98, 0.15, 0.05],
        "x2": [0.98, 0.14, 0.15, 0.95, 0.2, 0.06],
        **BUSHY_AT,
    },
}
BUSHY_ORDER = ["l0", "l1", "l2", "l3", "l4", "x0", "x1", "x2"]
BUSHY_GROUPS = [["l0", "l3"], ["l1", "l2", "l4"], ["l0", "x2", "l4"], ["l4", "l3", "l2", "l1", "l0"], ["x0", "l3"]]


def linear_cases_v2() -> list[Case]:
    return [
        Case(
            "at_optimum_zero_increment",
            "[YIB Eq. 9-11, 21]",
            "a state pair and a landmark whose values satisfy every factor exactly (sums and products exact in "
            "binary): b = 0, Aᵀb = 0, d = 0 and the step δ = 0 (compared with atol only: max|expected| is 0)",
            {"problem": AT_OPTIMUM, "ordering": ["x0", "x1", "l0"]},
            dict(LINEAR_TOL),
            True,
            ORACLE_DENSE,
        ),
        Case(
            "gp_heading_jump",
            "[YIB Eq. 9-11, 22]",
            "two states whose headings are stored 3.0 and -3.1 (2π apart, less 0.18): the GP prior's heading "
            "error is -6.3 (not wrapped: headings are continuous coordinates), so b holds it; a port that wraps "
            "the GP prior's heading fails b, d and δ",
            {"problem": HEADING_JUMP, "ordering": ["x0", "x1"]},
            dict(LINEAR_TOL),
            True,
            ORACLE_DENSE,
        ),
    ]


def batch_cases_v2() -> list[Case]:
    return [
        Case(
            "at_optimum_gauss_newton",
            "[YIB Eq. 6-11]",
            "Gauss-Newton started at the exact optimum: every step is zero, the iterates stay, every cost is 0",
            {"problem": AT_OPTIMUM, "ordering": ["x0", "x1", "l0"], "iterations": 2},
            {"iterates": tol(1e-8, 1e-12), "costs": tol(1e-9, 1e-20)},
            True,
            "oracle: dense Gauss-Newton on the oracle's factors",
        )
    ]


def bayes_tree_cases_v2() -> list[Case]:
    inputs = {"problem": BUSHY, "ordering": BUSHY_ORDER}
    what = (
        "a bushy tree: three states, five landmarks each seen from one state, eliminated landmarks first "
        "(the root {x1, x2} has four children, x0's clique two)"
    )
    return [
        Case(
            "bushy_cliques",
            "[YIB Sec. III-A, Eq. 24-25]",
            f"{what}: the cliques",
            inputs,
            {"cliques": EXACT},
            True,
            "oracle: the elimination game and GTSAM's clique rule, written a second time",
        ),
        Case(
            "bushy_conditionals",
            "[YIB Eq. 24-25]",
            f"{what}: each clique's conditional R, S, d",
            inputs,
            {"conditionals": tol(1e-9, 1e-12)},
            True,
            "oracle: the rows of the dense R of 𝓘 and of d = R⁻ᵀAᵀb",
        ),
        Case(
            "bushy_joint_covariances",
            "[YIB Eq. 11]",
            f"{what}: joint covariances of groups of two to five variables from different branches, each stacked "
            "in the order listed (not the elimination order)",
            {**inputs, "groups": BUSHY_GROUPS},
            {"covariances": tol(1e-9, 1e-13)},
            True,
            "oracle: blocks of the dense inverse of 𝓘",
        ),
    ]


PARTIAL = {"relinearize_threshold": 0.05, "relinearize_skip": 1, "wildfire_threshold": 0.0}
PARTIAL_SKIP2 = {"relinearize_threshold": 0.05, "relinearize_skip": 2, "wildfire_threshold": 0.0}
EVERY = {"relinearize_threshold": 0.0, "relinearize_skip": 1, "wildfire_threshold": 0.0}
ORDER_RULE = (
    "Depends on the elimination order of the removed part (the tree-edit ordering rule of the conventions, "
    "'tree_edits'); nnz_k counts R as GTSAM's ISAM2::treeNnz does"
)


def incremental_cases_v2() -> list[Case]:
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
            "oracle: per variable linearization points, dense linearization and solve per update",
        ),
        Case(
            "partial_relinearization_skip2_estimates",
            "[YIB Alg. 1, Eq. 9-11]",
            f"the same with the check every second update (relinearize_skip 2: at updates 2 and 4): {partial}",
            {"stream": stream, "isam2": PARTIAL_SKIP2},
            {**moved, **est},
            True,
            "oracle: per variable linearization points, dense linearization and solve per update",
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
