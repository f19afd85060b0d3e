"""The ``linear``, ``batch`` and ``bayes_tree`` suites: the problems of :mod:`.problems` linearized, solved by
Gauss-Newton and eliminated into Bayes trees (kit v1; kit v2 adds a zero increment, a GP heading jump and a bushy
tree)."""

from __future__ import annotations

from .base import EXACT, ORACLE_DENSE, Case, tol
from .problems import (
    AT_OPTIMUM,
    BEACON_START,
    BUSHY,
    BUSHY_GROUPS,
    BUSHY_ORDER,
    HEADING_JUMP,
    ORDERINGS,
    PROBLEM_DOCS,
    PROBLEMS,
    TRAJ_START,
)

__all__ = ["linear_cases", "batch_cases", "bayes_tree_cases"]

LINEAR_TOL = {
    "A": tol(1e-9, 1e-13),
    "b": tol(1e-10, 1e-13),
    "information": tol(1e-9),
    "rhs": tol(1e-9, 1e-12),
    "R": tol(1e-9),
    "d": tol(1e-9, 1e-12),
    "delta": tol(1e-8, 1e-12),
}


def linear_cases() -> list[Case]:
    out = []
    for p, o in (("trajectory", "xl"), ("trajectory", "landmarks_first"), ("beacons", "natural")):
        out.append(
            Case(
                f"{p}_{o}",
                "[YIB Eq. 9-11, 21, 25]",
                f"{PROBLEM_DOCS[p]}; ordering {o}: A, b (rows in factor order), 𝓘 = AᵀA, Aᵀb, R (RᵀR = 𝓘), d, δ",
                {"problem": PROBLEMS[p], "ordering": ORDERINGS[p][o]},
                dict(LINEAR_TOL),
                True,
                ORACLE_DENSE,
            )
        )
    return out + [
        Case(  # kit v2
            "at_optimum_zero_increment",
            "[YIB Eq. 9-11, 21]",
            "a state pair and a landmark whose values satisfy every factor exactly (sums and products exact in "
            "binary): b = 0, Aᵀb = 0, d = 0 and the step δ = 0 (compared with atol only: max|expected| is 0)",
            {"problem": AT_OPTIMUM, "ordering": ["x0", "x1", "l0"]},
            dict(LINEAR_TOL),
            True,
            ORACLE_DENSE,
        ),
        Case(  # kit v2
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


def batch_cases() -> list[Case]:
    out = []
    for p, start, order in (("trajectory", TRAJ_START, "xl"), ("beacons", BEACON_START, "natural")):
        problem = {**PROBLEMS[p], "values": start}
        out.append(
            Case(
                f"{p}_gauss_newton",
                "[YIB Eq. 6-11]",
                f"{PROBLEM_DOCS[p]}: 5 Gauss-Newton iterations from a given start; every iterate and the cost at each",
                {"problem": problem, "ordering": ORDERINGS[p][order], "iterations": 5},
                {"iterates": tol(1e-8, 1e-12), "costs": tol(1e-9)},
                True,
                "oracle: dense Gauss-Newton on the oracle's factors",
            )
        )
    return out + [
        Case(  # kit v2
            "at_optimum_gauss_newton",
            "[YIB Eq. 6-11]",
            "Gauss-Newton started at the exact optimum: every step is zero, the iterates stay, every cost is 0",
            {"problem": AT_OPTIMUM, "ordering": ["x0", "x1", "l0"], "iterations": 2},
            {"iterates": tol(1e-8, 1e-12), "costs": tol(1e-9, 1e-20)},
            True,
            "oracle: dense Gauss-Newton on the oracle's factors",
        )
    ]


def bayes_tree_cases() -> list[Case]:
    out = []
    for p, o in (("trajectory", "xl"), ("trajectory", "interleaved"), ("beacons", "states_first")):
        inputs = {"problem": PROBLEMS[p], "ordering": ORDERINGS[p][o]}
        what = f"{PROBLEM_DOCS[p]}, linearized at its values, eliminated in the ordering {o}"
        out.append(
            Case(
                f"{p}_{o}_cliques",
                "[YIB Sec. III-A, Eq. 24-25]",
                f"{what}: the cliques (frontals, separator, parent)",
                inputs,
                {"cliques": EXACT},
                True,
                "oracle: the elimination game and GTSAM's clique rule, written a second time "
                "(matches GTSAM 4.3's eliminateMultifrontal)",
            )
        )
        out.append(
            Case(
                f"{p}_{o}_conditionals",
                "[YIB Eq. 24-25]",
                f"{what}: each clique's conditional R, S, d (positive diagonal), by first frontal",
                inputs,
                {"conditionals": tol(1e-9, 1e-12)},
                True,
                "oracle: the rows of the dense R of 𝓘 and of d = R⁻ᵀAᵀb",
            )
        )
        groups = [[k] for k in inputs["ordering"]] + [["x0", "l1"] if p == "trajectory" else ["x0", "l2"], ["l0", "x1"]]
        out.append(
            Case(
                f"{p}_{o}_covariances",
                "[YIB Eq. 11]",
                f"{what}: marginal covariances and joint covariances of pairs, blocks of 𝓘⁻¹",
                {**inputs, "groups": groups},
                {"covariances": tol(1e-9, 1e-13)},
                True,
                "oracle: blocks of the dense inverse of 𝓘",
            )
        )
    return out + _bushy_cases()


def _bushy_cases() -> list[Case]:  # kit v2
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
