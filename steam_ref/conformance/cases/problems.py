"""The problems and the stream that the ``linear``, ``batch``, ``bayes_tree``, ``incremental`` and ``fixed_lag``
suites share, and the factor specs they are made of: a trajectory with landmarks, a pair of states among beacons
(kit v1); a problem at its exact optimum, a GP prior across a 2π heading jump and a bushy tree (kit v2)."""

from __future__ import annotations

from .base import QC_DIAG

__all__ = [
    "STATE",
    "MARK",
    "range_reading",
    "velocity_reading",
    "gp_prior_between",
    "TRAJECTORY",
    "BEACONS",
    "ORDERINGS",
    "PROBLEMS",
    "PROBLEM_DOCS",
    "AT_OPTIMUM",
    "HEADING_JUMP",
    "BUSHY",
    "BUSHY_ORDER",
    "BUSHY_GROUPS",
    "trajectory_stream",
]

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
