"""The kit's cases, one module per idea, inputs written out as literal numbers (no random draws:
the kit stores them): the GP prior (:mod:`.gp`), the factors (:mod:`.factors`), the problems several suites
share (:mod:`.problems`), solving them (:mod:`.graphs`: linear, batch, bayes_tree), iSAM2 (:mod:`.incremental`),
fixed-lag smoothing (:mod:`.fixed_lag`), the GP prior on a Lie group (:mod:`.lie_groups`: the se2 suite, with kit
v5's readings of SE(2) states, :mod:`.lie_readings`, the retraction and the prediction, :mod:`.lie_motion`, and
fixed-lag smoothing, :mod:`.lie_lag`) and on SE(3) (:mod:`.rigid`, :mod:`.rigid_solves`: the se3 suite).
A case added by a later kit version is tagged ``# kit vN``.

Each :class:`Case` says what it computes ([YIB Eq. n]), its inputs, the tolerance of each output
quantity, and whether its expected values come from the independent oracle
(:mod:`steam_ref.conformance.expected`) or from steam_ref itself. The expected values are computed by
:mod:`steam_ref.conformance.build`. The ``paper`` suite's cases are made from the data files by
:mod:`steam_ref.conformance.paper`.
"""

from __future__ import annotations

from .base import EXACT, Case, tol
from .factors import factor_cases
from .fixed_lag import fixed_lag_cases
from .gp import gp_cases
from .graphs import batch_cases, bayes_tree_cases, linear_cases
from .incremental import incremental_cases
from .lie_groups import lie_group_cases
from .lie_lag import lag_cases
from .lie_motion import motion_cases
from .lie_readings import reading_cases
from .rigid import se3_cases

__all__ = ["Case", "tol", "EXACT", "suite_cases", "SUITE_DOCS"]

SUITE_DOCS = {
    "gp": (
        "the GP prior: Φ, Q, Q⁻¹, W of WNOA (and WNOJ, Singer, a general LTI SDE); Λ, Ψ, the mean and covariance "
        "at τ; prediction"
    ),
    "factors": (
        "every factor type at given points: error, whitened error, Jacobians (unwhitened H_k, whitened and "
        "weighted A_k), b, cost, robust weight"
    ),
    "linear": "small problems under given orderings: A, b, 𝓘, Aᵀb, R, d and the Gauss-Newton step δ",
    "batch": "Gauss-Newton iterates and costs from a given start",
    "bayes_tree": "cliques and conditionals of given elimination orders (one a bushy tree); marginal and joint covariances",
    "incremental": (
        "a stream of five iSAM2 updates: the estimate after each (relinearizing every update, never, or partially), "
        "the variables relinearized; the cliques removed, the orphans and the fill of R"
    ),
    "fixed_lag": (
        "streams of timed updates with a lag (kit v3; v4 adds a timestamp exactly at t_newest − lag and a landmark "
        "forgotten and seen again): after each update the variables marginalized, the marginal factor they leave on "
        "their separator (Λ, η at the frozen linearization point; Λ may be singular), the window's estimate and "
        "marginal covariances"
    ),
    "se2": (
        "the GP prior on SE(2) (kit v4): Exp, Log (near 0 and the half turn), J_r, J_r⁻¹, between, the adjoint; both "
        "WNOA residuals ('local-variable', 'simplified') and their Jacobians in the right tangent; the local GP's mean, "
        "Jacobians and covariance; Gauss-Newton and an iSAM2 stream with relinearization on SE(2) states; kit v5: "
        "range, bearing, bearing-range and body-twist readings of SE(2) states, also at τ between two states; the "
        "retraction; the prediction after the last state with its covariance (both models); fixed-lag smoothing "
        "through the half turn"
    ),
    "se3": (
        "SO(3), SE(3) and the GP priors on SE(3) (kit v5): Exp, Log (angles 1e-12 to pi - 1e-9), J_r, J_r⁻¹, between, "
        "the adjoint; the WNOA prior with both residuals ('local-variable', 'simplified') and WNOJ, their Jacobians at "
        "the exact tier; the local GP's mean, Jacobians and covariance (t₁ ≠ 0); extrapolation; Gauss-Newton and an "
        "iSAM2 stream on SE(3) states"
    ),
    "paper": "the paper's runs (BTGP/1 on the synthetic set and on Plaza): final estimates and RMSE",
}


def suite_cases(suite: str) -> list[Case]:
    """The cases of a suite defined here (not 'paper', which needs the data files)."""
    return {
        "gp": gp_cases,
        "factors": factor_cases,
        "linear": linear_cases,
        "batch": batch_cases,
        "bayes_tree": bayes_tree_cases,
        "incremental": incremental_cases,
        "fixed_lag": fixed_lag_cases,
        "se2": lambda: lie_group_cases() + reading_cases() + motion_cases() + lag_cases(),
        "se3": se3_cases,
    }[suite]()
