"""The ``linear``, ``batch``, ``bayes_tree`` and ``incremental`` suites: two small problems (a
trajectory with landmarks, a pair of states among beacons) and a stream of updates."""

from __future__ import annotations

from .base import EXACT, ORACLE_DENSE, QC_DIAG, Case, tol

__all__ = ["linear_cases", "batch_cases", "bayes_tree_cases", "incremental_cases"]

STATE, MARK = 6, 2
TRAJ_VALUES = {
    "x0": [0.0, 0.0, 0.1, 1.0, 0.1, 0.05],
    "x1": [0.52, 0.07, 0.13, 0.98, 0.18, 0.06],
    "x2": [1.01, 0.18, 0.16, 0.95, 0.25, 0.04],
    "x3": [1.47, 0.33, 0.19, 0.9, 0.31, 0.07],
    "l0": [2.0, 3.0],
    "l1": [-1.0, 2.5],
}
TRAJ_START = {
    "x0": [0.05, -0.05, 0.12, 0.9, 0.0, 0.0],
    "x1": [0.6, 0.0, 0.1, 0.9, 0.1, 0.1],
    "x2": [1.1, 0.1, 0.2, 0.9, 0.2, 0.0],
    "x3": [1.6, 0.2, 0.25, 0.85, 0.2, 0.1],
    "l0": [2.3, 2.7],
    "l1": [-0.7, 2.8],
}


def range_reading(x: str, l: str, measured: float, sigma: float = 0.1, **extra) -> dict:
    """A range factor of a case, as the kit writes it: state ``x``, landmark ``l``, the reading and its sigma."""
    return {"type": "range", "keys": [x, l], "measured": measured, "sigma": sigma, **extra}


def velocity_reading(x: str, measured: list[float]) -> dict:
    """A velocity factor of a case on state ``x``: [forward, lateral, yaw rate] and the cases' sigmas."""
    return {"type": "velocity", "keys": [x], "measured": measured, "sigmas": [0.05, 0.05, 0.02]}


def gp_prior_between(a: str, b: str, dt: float = 0.5) -> dict:
    """The WNOA prior factor of a case between states ``a`` and ``b``, ``dt`` apart, with the cases' Qc."""
    return {"type": "gp_prior", "keys": [a, b], "dt": dt, "qc": QC_DIAG}


TRAJ_FACTORS = [
    {
        "type": "prior",
        "keys": ["x0"],
        "mean": [0.0, 0.0, 0.1, 1.0, 0.1, 0.05],
        "sigmas": [0.01, 0.01, 0.01, 0.1, 0.1, 0.1],
    },
    gp_prior_between("x0", "x1"),
    gp_prior_between("x1", "x2"),
    gp_prior_between("x2", "x3"),
    velocity_reading("x1", [1.0, 0.0, 0.06]),
    velocity_reading("x3", [0.95, 0.0, 0.07]),
    range_reading("x0", "l0", 3.62),
    range_reading("x1", "l0", 3.3),
    range_reading("x2", "l1", 3.05),
    range_reading("x3", "l1", 3.45, loss={"type": "huber", "k": 1.345}),
    range_reading("x3", "l0", 2.7),
    {"type": "bearing", "keys": ["x2", "l0"], "measured": 1.08, "sigma": 0.02},
    {
        "type": "interpolated",
        "keys": ["x2", "x3", "l1"],
        "t1": 1.0,
        "t2": 1.5,
        "tau": 1.2,
        "qc": QC_DIAG,
        "inner": {"type": "range", "measured": 3.15, "sigma": 0.1},
    },
    {"type": "prior", "keys": ["l0"], "mean": [2.05, 2.95], "sigmas": [0.5, 0.5]},
    {"type": "prior", "keys": ["l1"], "mean": [-0.9, 2.6], "sigmas": [0.5, 0.5]},
]
TRAJECTORY = {
    "variables": {"x0": STATE, "x1": STATE, "x2": STATE, "x3": STATE, "l0": MARK, "l1": MARK},
    "times": {"x0": 0.0, "x1": 0.5, "x2": 1.0, "x3": 1.5},
    "factors": TRAJ_FACTORS,
    "values": TRAJ_VALUES,
}

BEACON_TRUE = {"l0": [3.0, 0.0], "l1": [0.0, 3.0], "l2": [-3.0, 0.0], "l3": [0.0, -3.0]}
BEACONS = {
    "variables": {"l0": MARK, "l1": MARK, "l2": MARK, "l3": MARK, "x0": STATE, "x1": STATE},
    "times": {"x0": 0.0, "x1": 1.0},
    "factors": [
        {
            "type": "prior",
            "keys": ["x0"],
            "mean": [0.0, 0.0, 0.0, 0.5, 0.0, 0.0],
            "sigmas": [0.1, 0.1, 0.05, 0.2, 0.2, 0.1],
        },
        gp_prior_between("x0", "x1", 1.0),
        velocity_reading("x1", [0.5, 0.0, 0.02]),
        *[{"type": "prior", "keys": [k], "mean": m, "sigmas": [0.3, 0.3]} for k, m in BEACON_TRUE.items()],
        range_reading("x0", "l0", 3.02, 0.05),
        range_reading("x0", "l1", 2.97, 0.05),
        range_reading("x0", "l2", 3.01, 0.05),
        range_reading("x0", "l3", 3.0, 0.05),
        range_reading("x1", "l0", 2.52, 0.05),
        range_reading("x1", "l1", 2.93, 0.05, loss={"type": "tukey", "c": 4.685}),
        range_reading("x1", "l2", 3.49, 0.05),
        range_reading("x1", "l3", 3.1, 0.05),
    ],
    "values": {
        "l0": [3.1, 0.1],
        "l1": [0.1, 2.9],
        "l2": [-2.95, -0.1],
        "l3": [0.05, -3.05],
        "x0": [0.0, 0.0, 0.0, 0.5, 0.0, 0.0],
        "x1": [0.5, 0.05, 0.02, 0.5, 0.05, 0.02],
    },
}
BEACON_START = {
    "l0": [2.6, 0.4],
    "l1": [0.4, 2.5],
    "l2": [-2.5, 0.4],
    "l3": [0.4, -2.6],
    "x0": [0.1, 0.1, 0.05, 0.4, 0.1, 0.0],
    "x1": [0.7, 0.2, 0.0, 0.4, 0.1, 0.0],
}

ORDERINGS = {
    "trajectory": {
        "xl": ["x0", "x1", "x2", "x3", "l0", "l1"],
        "landmarks_first": ["l0", "l1", "x0", "x1", "x2", "x3"],
        "interleaved": ["x3", "l1", "x0", "l0", "x2", "x1"],
    },
    "beacons": {"natural": ["l0", "l1", "l2", "l3", "x0", "x1"], "states_first": ["x0", "x1", "l0", "l1", "l2", "l3"]},
}
PROBLEMS = {"trajectory": TRAJECTORY, "beacons": BEACONS}
PROBLEM_DOCS = {
    "trajectory": "four states at t = 0, 0.5, 1, 1.5 with a prior, GP priors, velocities, ranges (one Huber), "
    "a bearing, an interpolated range and two landmarks with priors",
    "beacons": "two states and four beacons with priors, ranges from each state to each beacon (one Tukey)",
}
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
    return out


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
    return out


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
    return out


def trajectory_stream() -> dict:
    """The incremental cases' stream: the trajectory problem's factors given over five updates."""
    return {
        "variables": {"x0": STATE, "x1": STATE, "x2": STATE, "x3": STATE, "l0": MARK, "l1": MARK},
        "updates": [
            {
                "values": {"x0": TRAJ_START["x0"], "l0": TRAJ_START["l0"]},
                "factors": [
                    TRAJ_FACTORS[0],
                    TRAJ_FACTORS[13],
                    TRAJ_FACTORS[6],
                    velocity_reading("x0", [1.0, 0.0, 0.05]),
                ],
            },
            {"values": {"x1": TRAJ_START["x1"]}, "factors": [TRAJ_FACTORS[1], TRAJ_FACTORS[4], TRAJ_FACTORS[7]]},
            {
                "values": {"x2": TRAJ_START["x2"], "l1": TRAJ_START["l1"]},
                "factors": [TRAJ_FACTORS[2], TRAJ_FACTORS[14], TRAJ_FACTORS[8], TRAJ_FACTORS[11]],
            },
            {
                "values": {"x3": TRAJ_START["x3"]},
                "factors": [TRAJ_FACTORS[3], TRAJ_FACTORS[5], TRAJ_FACTORS[9], TRAJ_FACTORS[10], TRAJ_FACTORS[12]],
            },
            {"values": {}, "factors": [range_reading("x1", "l1", 2.95)]},
        ],
    }


def incremental_cases() -> list[Case]:
    stream = trajectory_stream()
    n = len(stream["updates"])
    est = {f"estimate_{k}": tol(1e-8, 1e-12) for k in range(1, n + 1)}
    every = {"relinearize_threshold": 0.0, "relinearize_skip": 1, "wildfire_threshold": 0.0}
    never = {"relinearize_threshold": "inf", "relinearize_skip": 1, "wildfire_threshold": 0.0}
    return [
        Case(
            "relinearize_every_update_estimates",
            "[YIB Alg. 1, Eq. 9-11]",
            "five updates of iSAM2 with relinearization threshold 0 checked every update and full back-substitution "
            "(wildfire 0): each update is one Gauss-Newton step on every factor so far; the estimate after each",
            {"stream": stream, "isam2": every},
            est,
            True,
            "oracle: one dense Gauss-Newton step per update",
        ),
        Case(
            "no_relinearization_estimates",
            "[YIB Alg. 1, Eq. 9-11]",
            "the same stream with relinearization off (threshold inf) and wildfire 0: every factor stays linearized "
            "at the values first given; the estimate after each update",
            {"stream": stream, "isam2": never},
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
            {"stream": stream, "isam2": never},
            {**{f"update_{k}": EXACT for k in range(1, n + 1)}, **{f"nnz_{k}": EXACT for k in range(1, n + 1)}},
            False,
            "produced by steam_ref",
        ),
    ]
