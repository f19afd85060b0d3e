"""The ``fixed_lag`` suite (kit v3; v4 adds a timestamp exactly at the boundary and a forgotten landmark):
streams of timed updates with a lag, and after each update which variables were marginalized, the
marginal factor they leave on their separator (information form, convention-free), and the window's
estimate and marginal covariances.

Every input is a literal number. The quantities of a case depend on which updates marginalize
something, which :func:`drop_steps` reads off the timestamps and the lag by the suite's rule
(a timed variable goes after the update at which ``t < t_newest - lag``; at ``t = t_newest - lag``
it stays). An update's ``timestamps`` may stamp any variable, a held one too (kit v4): a landmark
stamped with the time it was last seen is forgotten a lag after that, as in steam_ref's streams.
"""

from __future__ import annotations

from collections.abc import Mapping

from .base import EXACT, Case, tol
from .problems import MARK, STATE, gp_prior_between, range_reading, velocity_reading

__all__ = ["fixed_lag_cases", "drop_steps", "tolerances", "EVERY", "EQUATION"]

EVERY = {"relinearize_threshold": 0.0, "relinearize_skip": 1, "wildfire_threshold": 0.0}
NEVER = {"relinearize_threshold": "inf", "relinearize_skip": 1, "wildfire_threshold": 0.0}
ORACLE_LAG = (
    "oracle: the stream replayed densely: per-variable linearization points, every factor and every earlier "
    "marginal factor (frozen at its θ̄⁰_S: Λ and η − Λ (θ̄′_S − θ̄⁰_S) at a later θ̄′) in one dense information "
    "matrix per update, solved; the variables D past the lag dropped by the dense Schur complement of the "
    "information of the factors adjacent to them, Λ = H_SS − H_SD H_DD⁻¹ H_DS, η = g_S − H_SD H_DD⁻¹ g_D; the "
    "window's covariances as blocks of the inverse of the window's information"
)
# The case's 'equation': the paper's, and where the rest is written out in the kit itself (no outside document).
EQUATION = "[YIB Alg. 1, Eq. 9-11, 24]; the marginal factor: README 'Fixed-lag smoothing' (conventions, fixed_lag)"


def _fix(x: str, mean: list[float], sigmas: list[float] | None = None) -> dict:
    """A state fix: a prior on the whole state (linear)."""
    return {"type": "prior", "keys": [x], "mean": mean, "sigmas": sigmas or [0.2, 0.2, 0.1, 0.5, 0.5, 0.3]}


# A linear-Gaussian stream: six states 0.5 s apart, GP priors, state fixes; x4 and x5 arrive together.
LINEAR = {
    "variables": {f"x{i}": STATE for i in range(6)},
    "updates": [
        {
            "values": {"x0": [0.05, -0.05, 0.12, 0.9, 0.0, 0.0]},
            "timestamps": {"x0": 0.0},
            "factors": [_fix("x0", [0.0, 0.0, 0.1, 1.0, 0.1, 0.05], [0.01, 0.01, 0.01, 0.1, 0.1, 0.1])],
        },
        {
            "values": {"x1": [0.6, 0.0, 0.1, 0.9, 0.1, 0.1]},
            "timestamps": {"x1": 0.5},
            "factors": [gp_prior_between("x0", "x1")],
        },
        {
            "values": {"x2": [1.1, 0.1, 0.2, 0.9, 0.2, 0.0]},
            "timestamps": {"x2": 1.0},
            "factors": [gp_prior_between("x1", "x2"), _fix("x2", [1.01, 0.18, 0.16, 0.95, 0.25, 0.04])],
        },
        {
            "values": {"x3": [1.6, 0.2, 0.25, 0.85, 0.2, 0.1]},
            "timestamps": {"x3": 1.5},
            "factors": [gp_prior_between("x2", "x3")],
        },
        {
            "values": {"x4": [1.9, 0.45, 0.2, 0.9, 0.3, 0.05], "x5": [2.4, 0.6, 0.25, 0.9, 0.35, 0.1]},
            "timestamps": {"x4": 2.0, "x5": 2.5},
            "factors": [
                gp_prior_between("x3", "x4"),
                gp_prior_between("x4", "x5"),
                _fix("x5", [2.38, 0.66, 0.27, 0.88, 0.33, 0.06]),
            ],
        },
        {"values": {}, "timestamps": {}, "factors": [_fix("x4", [1.93, 0.49, 0.22, 0.9, 0.31, 0.06])]},
    ],
}


def _landmark_prior(lm: str, mean: list[float]) -> dict:
    return {"type": "prior", "keys": [lm], "mean": mean, "sigmas": [0.5, 0.5]}


# A nonlinear stream: five states 0.5 s apart, two landmarks with priors (no timestamps: they stay),
# ranges from the states to them, velocity readings.
LANDMARKS: dict = {
    "variables": {**{f"x{i}": STATE for i in range(5)}, "l0": MARK, "l1": MARK},
    "updates": [
        {
            "values": {"x0": [0.05, -0.05, 0.12, 0.9, 0.0, 0.0], "l0": [2.3, 2.7]},
            "timestamps": {"x0": 0.0},
            "factors": [
                _fix("x0", [0.0, 0.0, 0.1, 1.0, 0.1, 0.05], [0.01, 0.01, 0.01, 0.1, 0.1, 0.1]),
                _landmark_prior("l0", [2.05, 2.95]),
                range_reading("x0", "l0", 3.62),
                velocity_reading("x0", [1.0, 0.0, 0.05]),
            ],
        },
        {
            "values": {"x1": [0.6, 0.0, 0.1, 0.9, 0.1, 0.1]},
            "timestamps": {"x1": 0.5},
            "factors": [
                gp_prior_between("x0", "x1"),
                velocity_reading("x1", [1.0, 0.0, 0.06]),
                range_reading("x1", "l0", 3.3),
            ],
        },
        {
            "values": {"x2": [1.1, 0.1, 0.2, 0.9, 0.2, 0.0], "l1": [-0.7, 2.8]},
            "timestamps": {"x2": 1.0},
            "factors": [
                gp_prior_between("x1", "x2"),
                _landmark_prior("l1", [-0.9, 2.6]),
                range_reading("x2", "l1", 3.05),
                range_reading("x2", "l0", 2.95),
            ],
        },
        {
            "values": {"x3": [1.6, 0.2, 0.25, 0.85, 0.2, 0.1]},
            "timestamps": {"x3": 1.5},
            "factors": [
                gp_prior_between("x2", "x3"),
                velocity_reading("x3", [0.95, 0.0, 0.07]),
                range_reading("x3", "l1", 3.45),
            ],
        },
        {
            "values": {"x4": [2.0, 0.4, 0.3, 0.85, 0.3, 0.05]},
            "timestamps": {"x4": 2.0},
            "factors": [gp_prior_between("x3", "x4"), range_reading("x4", "l0", 2.55), range_reading("x4", "l1", 3.75)],
        },
    ],
}


def _stamped(u: dict) -> dict:
    """An update whose timestamps also stamp each landmark its factors name with the update's newest time."""
    t = max(u["timestamps"].values())
    marks = sorted({k for f in u["factors"] for k in f["keys"] if k.startswith("l")})
    return {**u, "timestamps": {**u["timestamps"], **dict.fromkeys(marks, t)}}


# A nonlinear stream whose landmarks carry the time they were last seen (kit v4): l0 is seen at 0 and 0.5 s, not
# again until 2 s, so a lag of 0.8 s forgets it after update 4 (with x1); at update 5 it is seen again and enters
# anew, with a new value and its survey prior again (the rule of steam_ref's streams).
FORGET = {
    "variables": LANDMARKS["variables"],
    "updates": [
        _stamped(LANDMARKS["updates"][0]),
        {
            "values": {"x1": [0.6, 0.0, 0.1, 0.9, 0.1, 0.1]},
            "timestamps": {"x1": 0.5, "l0": 0.5},
            "factors": [
                gp_prior_between("x0", "x1"),
                velocity_reading("x1", [1.0, 0.0, 0.06]),
                range_reading("x1", "l0", 3.3),
            ],
        },
        {
            "values": {"x2": [1.1, 0.1, 0.2, 0.9, 0.2, 0.0], "l1": [-0.7, 2.8]},
            "timestamps": {"x2": 1.0, "l1": 1.0},
            "factors": [
                gp_prior_between("x1", "x2"),
                _landmark_prior("l1", [-0.9, 2.6]),
                range_reading("x2", "l1", 3.05),
            ],
        },
        _stamped(LANDMARKS["updates"][3]),
        {
            "values": {"x4": [2.0, 0.4, 0.3, 0.85, 0.3, 0.05], "l0": [2.2, 2.85]},
            "timestamps": {"x4": 2.0, "l0": 2.0, "l1": 2.0},
            "factors": [
                gp_prior_between("x3", "x4"),
                _landmark_prior("l0", [2.05, 2.95]),
                range_reading("x4", "l0", 2.55),
                range_reading("x4", "l1", 3.75),
            ],
        },
    ],
}


def drop_steps(stream: Mapping, lag: float) -> dict[int, list[str]]:
    """Update (from 1) → the variables marginalized after it, in the order of 'variables' (the suite's rule)."""
    times: dict[str, float] = {}
    newest = float("-inf")
    out = {}
    for k, u in enumerate(stream["updates"], start=1):
        times.update(u["timestamps"])
        newest = max([newest, *u["timestamps"].values()])
        gone = [v for v in stream["variables"] if v in times and times[v] < newest - lag]
        for v in gone:
            del times[v]
        if gone:
            out[k] = gone
    return out


def tolerances(stream: Mapping, lag: float) -> dict:
    """The quantities of each update in computation order: what goes, the marginal factor, then the window."""
    drops = drop_steps(stream, lag)
    out: dict = {}
    for k in range(1, len(stream["updates"]) + 1):
        out[f"marginalized_{k}"] = EXACT
        if k in drops:
            out[f"separator_{k}"] = EXACT
            out[f"marginal_point_{k}"] = tol(1e-8, 1e-12)
            out[f"marginal_information_{k}"] = tol(1e-9)
            out[f"marginal_vector_{k}"] = tol(1e-8, 1e-10)
        out[f"estimate_{k}"] = tol(1e-8, 1e-12)
        out[f"covariances_{k}"] = tol(1e-9, 1e-13)
    return out


def _case(name: str, what: str, stream: dict, lag: float, isam2: dict, notes: dict | None = None) -> Case:
    return Case(
        name,
        EQUATION,
        f"{what} (lag {lag:g} s). After each update k: marginalized_k (the variables with t < t_newest - lag, in the "
        "order of 'variables'; one with t = t_newest - lag stays); when any, separator_k (the other variables of the factors adjacent to them, same "
        "order), the marginal factor they leave in information form at the linearization point "
        "marginal_point_k (θ̄ of the separator, stacked): marginal_information_k = Λ, marginal_vector_k = η; "
        "then the window's estimate_k (θ̄ + δ) and covariances_k (each variable's marginal covariance)",
        {"stream": stream, "lag": lag, "isam2": isam2},
        tolerances(stream, lag),
        True,
        ORACLE_LAG,
        notes or {},
    )


def fixed_lag_cases() -> list[Case]:
    linear = "a linear-Gaussian stream: six states 0.5 s apart with GP priors and state fixes, x4 and x5 in one update"
    marks = (
        "a nonlinear stream: five states 0.5 s apart, GP priors, velocity readings, ranges to two landmarks with "
        "priors (landmarks carry no timestamp and stay)"
    )
    return [
        _case(
            "linear_two_at_once",
            f"{linear}; x0 goes after update 4, x1 and x2 together after update 5; relinearization off, so "
            "every factor is linearized at the values first given (for a linear problem the estimate does not depend "
            "on it, η does). The window's estimate and marginals equal the dense batch posterior's over every factor "
            "ever given",
            LINEAR,
            1.2,
            NEVER,
        ),
        _case(
            "landmarks_stay_relinearize_every_update",
            f"{marks}; relinearized at every update, so each marginal factor is frozen at the θ̄ of its update "
            "(first-estimate Jacobians) while the other factors move on",
            LANDMARKS,
            0.8,
            EVERY,
        ),
        _case(
            "mid_clique_relinearize_every_update",
            f"{marks}; a short lag: each state goes one update after the next arrives, while it still shares its "
            "clique with the landmark and the newer state (after update 2, x0 is a frontal of iSAM2's root clique "
            "beside l0 and x1: not a leaf)",
            LANDMARKS,
            0.4,
            EVERY,
        ),
        _case(
            "mid_clique_no_relinearization",
            f"{marks}; the short lag, relinearization off: every factor, marginal ones too, stays linearized at "
            "the values first given",
            LANDMARKS,
            0.4,
            NEVER,
        ),
        _case(  # kit v4
            "timestamp_at_the_boundary",
            f"{marks}; lag 1 s, relinearization off: after updates 3, 4 and 5 a state's timestamp is exactly "
            "t_newest - lag (0 = 1 - 1, 0.5 = 1.5 - 1, 1 = 2 - 1, exact in binary) and it stays; it goes one update "
            "later. A port that forgets at t <= t_newest - lag drops x0, x1, x2 one update early",
            LANDMARKS,
            1.0,
            NEVER,
        ),
        _case(  # kit v4
            "landmark_forgotten_and_seen_again",
            "a nonlinear stream: five states 0.5 s apart, GP priors, velocity readings, ranges to two landmarks with "
            "priors; each update's timestamps stamp the landmarks it sees with its time (a held variable's timestamp "
            "is replaced). l0, last seen at 0.5 s, goes with x1 after update 4; at update 5 it is seen again and "
            "enters as a new variable (a new value, its prior again); relinearized at every update",
            FORGET,
            0.8,
            EVERY,
        ),
    ]
