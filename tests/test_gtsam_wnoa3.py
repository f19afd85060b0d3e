"""The SE(3) WNOA prior against GTSAM 4.3's ``WnoaMotionFactorPose3``: the same residual (the local-variable one,
e = [ξ - Δt ϖ₁; J_r(ξ)⁻¹ ϖ₂ - ϖ₁]) and cost to 1e-12, and the Jacobians: ours within 1e-9 of 8th-order differences
at |φ| = 0.1, 0.3, 1, 2 while GTSAM's (a truncated series for ∂(J_r(ξ)⁻¹ϖ₂)/∂ξ) are off by more than 1e-2 at 1.

GTSAM's Pose3 puts the rotation first ([ω; v], its velocity too); ours translation first: every comparison permutes.
"""

from __future__ import annotations

import numpy as np
import pytest
from finite_differences import jacobian8
from requirements import optional_import

from steam_ref.lie import SE3, GroupState
from steam_ref.motion import LieGroupWnoa
from steam_ref.variables import X

gtsam = optional_import("gtsam", "gtsam")

PERM = np.r_[3:6, 0:3]  # ours [ρ; φ] -> GTSAM's [ω; v]
STATE = GroupState(SE3)
QC = np.diag([0.5, 0.8, 1.1, 0.05, 0.07, 0.09])
DT = 0.7


def _theirs(x1, x2):
    """GTSAM's error and whitened-or-not Jacobians [∂e/∂δ₁ ∂e/∂δ₂], permuted to our order (12, 12) each."""
    factor = gtsam.WnoaMotionFactorPose3(gtsam.StateData(1, 2, 0.0), gtsam.StateData(3, 4, DT), np.diag(QC)[PERM])
    H = [np.zeros((12, 6), order="F") for _ in range(4)]
    args = []
    for x in (x1, x2):
        args += [gtsam.Pose3(SE3.matrix(x[:12])), x[12:][PERM]]
    e = np.asarray(factor.evaluateError(*args, *H))
    rows = np.r_[PERM, 6 + PERM]
    back = np.argsort(rows)
    J1, J2 = np.hstack(H[:2]), np.hstack(H[2:])
    cols = np.argsort(np.r_[PERM, 6 + PERM])
    return e[back], J1[back][:, cols], J2[back][:, cols], factor, args


def _case(angle, seed=3):
    rng = np.random.default_rng(seed)
    xi = rng.standard_normal(6)
    xi[3:] *= angle / np.linalg.norm(xi[3:])
    T1 = SE3.exp(rng.standard_normal(6))
    return np.r_[T1, rng.standard_normal(6)], np.r_[SE3.compose(T1, SE3.exp(xi)), rng.standard_normal(6)]


ERRORS: dict[float, tuple[float, float]] = {}


@pytest.mark.parametrize("angle", [0.1, 0.3, 1.0, 2.0])
def test_residual_and_cost_agree_and_only_our_jacobians_are_exact(angle):
    x1, x2 = _case(angle)
    ours = LieGroupWnoa(SE3, QC).prior_factor(X(0), X(1), DT)  # on poses [t; R], GTSAM's matrices
    e, G1, G2, factor, args = _theirs(x1, x2)
    np.testing.assert_allclose(ours.error(x1, x2), e, rtol=0, atol=1e-12 * max(1.0, np.max(np.abs(e))))
    values = gtsam.Values()
    for key, value in zip((1, 2, 3, 4), args, strict=True):
        values.insert(key, value)
    cost = 0.5 * np.sum(ours.whitened_error(x1, x2) ** 2)
    assert factor.error(values) == pytest.approx(cost, rel=1e-12)
    A, B = ours.jacobians(x1, x2)
    nA = jacobian8(lambda d: ours.error(STATE.retract(x1, d), x2), 12)
    nB = jacobian8(lambda d: ours.error(x1, STATE.retract(x2, d)), 12)
    W = ours.sqrt_information
    ours_off = max(np.max(np.abs(W @ (A - nA))), np.max(np.abs(W @ (B - nB))))
    theirs_off = max(np.max(np.abs(W @ (G1 - nA))), np.max(np.abs(W @ (G2 - nB))))
    ERRORS[angle] = (ours_off, theirs_off)
    assert ours_off < 1e-9 * max(1.0, np.max(np.abs(W @ nA)))
    if angle >= 1.0:  # GTSAM's truncation: the issue measured 0.11 at 1 and 0.57 at 2 (its wheel, whitened)
        assert theirs_off > 1e-2
    print(f"|phi| = {angle}: whitened Jacobian error, ours {ours_off:.1e}, GTSAM's {theirs_off:.1e}")
