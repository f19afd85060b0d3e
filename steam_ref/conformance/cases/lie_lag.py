"""Fixed-lag smoothing on SE(2) states in the ``se2`` suite (kit v5): the fixed_lag suite's quantities (what is
marginalized, the marginal factor in information form at the point it is frozen at, the window's estimate and
covariances) for a stream of turning SE(2) states whose headings cross ±π. A marginal factor frozen at θ̄⁰ contributes
η − Λ (θ̄′ ⊖ θ̄⁰) at a later θ̄′, ⊖ the right tangent step of each state (a port that subtracts stored headings is 2π
off when one crosses ±π). Independent: :mod:`steam_ref.conformance.oracle_lag` replaying the stream in
``oracle_lie.LIE``.
"""

from __future__ import annotations

from .base import Case
from .fixed_lag import EQUATION as LAG_EQUATION
from .fixed_lag import EVERY, tolerances
from .lie_groups import QC

__all__ = ["lag_cases"]

ORACLE_LAG = (
    "oracle: the stream replayed densely on SE(2) states: per-variable linearization points moved by the right "
    "retraction, every factor linearized there by central differences (Romberg) and every earlier marginal factor "
    "frozen at its theta0_S (Lambda and eta - Lambda (theta'_S - theta0_S) with - the right tangent step), one dense "
    "information matrix per update, solved; the variables past the lag dropped by the dense Schur complement of the "
    "factors adjacent to them; covariances as blocks of the inverse of the window's information"
)
EQUATION = LAG_EQUATION + "; SE(2) states: README 'SE(2)'"

STATES = [  # a turn at ~1 rad/s through the half turn: headings ~2.65, ~3.16 (stored -3.13), -2.63, ...
    [0.027, -0.024, 2.67, 0.95, 0.05, 1.05],
    [-0.46, 0.19, 3.05, 1.05, 0.0, 0.95],  # given on the + side of pi; its estimate lies past it
    [-0.97, -0.04, -2.7, 1.0, -0.05, 1.02],
    [-1.32, -0.29, -2.2, 0.98, 0.03, 1.0],
    [-1.46, -0.84, -1.63, 1.02, 0.0, 0.97],
]
RANGES = [1.83, 1.8, 1.76, 1.52, 1.28]  # from each state to l0


def _range(k: int) -> dict:
    return {"type": "se2_range", "keys": [f"x{k}", "l0"], "measured": RANGES[k], "sigma": 0.05}


def _twist(k: int) -> dict:
    return {"type": "se2_velocity", "keys": [f"x{k}"], "measured": [1.0, 0.0, 1.0], "sigmas": [0.05, 0.05, 0.02]}


def _prior(k: int) -> dict:
    return {"type": "se2_prior", "keys": [f"x{k - 1}", f"x{k}"], "dt": 0.5, "qc": QC, "model": "local-variable"}


STREAM = {
    "variables": {**{f"x{k}": 6 for k in range(5)}, "l0": 2},
    "updates": [
        {
            "values": {"x0": STATES[0], "l0": [-0.56, -1.64]},
            "timestamps": {"x0": 0.0},
            "factors": [
                {
                    "type": "se2_state_prior",
                    "keys": ["x0"],
                    "mean": [0.0, 0.0, 2.65, 1.0, 0.0, 1.0],
                    "sigmas": [0.05, 0.05, 0.02, 0.1, 0.1, 0.1],
                },
                {"type": "prior", "keys": ["l0"], "mean": [-0.598, -1.701], "sigmas": [0.3, 0.3]},
                _range(0),
            ],
        },
        *(
            {
                "values": {f"x{k}": STATES[k]},
                "timestamps": {f"x{k}": 0.5 * k},
                "factors": [_prior(k), _twist(k), _range(k)],
            }
            for k in range(1, 5)
        ),
    ],
}


def lag_cases() -> list[Case]:
    lag = 0.4
    return [
        Case(
            "fixed_lag_through_the_half_turn",
            EQUATION,
            "fixed_lag on SE(2) states (the fixed_lag suite's rule and quantities, lag 0.8 s): five states 0.5 s "
            "apart turning through +-pi (headings 2.4 to -1.9 stored in (-pi, pi]), local-variable WNOA priors, a "
            "state prior on x0, body-twist readings, ranges to a landmark with a prior (no timestamp: it stays); "
            "relinearized at every update (threshold 0), so each separator state moves after its marginal factor is "
            "frozen. After each update k: marginalized_k, separator_k, marginal_point_k (theta_bar of the separator "
            "as stored), marginal_information_k = Lambda and marginal_vector_k = eta in the right tangents, "
            "estimate_k (theta_bar + delta, the right retraction) and covariances_k (right tangents)",
            {"kind": "fixed_lag", "stream": STREAM, "lag": lag, "isam2": EVERY},
            tolerances(STREAM, lag),
            True,
            ORACLE_LAG,
        )
    ]
