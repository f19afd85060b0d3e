"""STEAM's SE(2) constant-velocity (WNOA) prior, its closed forms ported as facts onto our 'se2' prior.

The source is STEAM (Anderson, Barfoot, Lisus et al., BSD licence), repository ``utiasASRL/steam``: its SE(2) prior
has no test of its own, so its closed forms are ported from ``include/steam/trajectory/const_vel_se2/helper.hpp``
(``getTran``, ``getQ``, ``getQinv``, ``getJacKnot1``, ``getJacKnot2``; commit db7d1ec8),
``src/trajectory/const_vel_se2/prior_factor.cpp`` (the error, ``value``; commit b75756d6) and
``src/trajectory/const_vel_se2/pose_interpolator.cpp`` (the interpolation coefficients and the pose; commit
db7d1ec8). Each test names its file and function. Only formulas and properties carry over; lgmath's SE(2) (its
``vec2jacinv``, ``curlyhat``) is read as in ``test_se2_against_lgmath_cases``: ``curlyhat`` is our ``ad``, its Jacobian
the left one, J_l(ξ) = J_r(-ξ).

**The conversion** (as for STEAM's SE(3) prior, ``test_se3_priors_against_steam_cases``; every step uses only the
group's operations, so it holds on SE(2) unchanged). STEAM's state is T_k0 (world to body), perturbed on the left,
with the twist ϖ of Ṫ_k0 = ϖ^ T_k0; ours is T = T_k0⁻¹, perturbed on the right, with the body twist v of Ṫ = T v^.
So v = -ϖ; STEAM's ξ₂₁ = Log(T₂ T₁⁻¹) (its T) is Log(T₂⁻¹ T₁) = -ξ (ours ξ = Log(T₁⁻¹ T₂)); J_l(-ξ)⁻¹ (-v₂) =
-J_r(ξ)⁻¹ v₂: every local variable of STEAM's is minus ours, so its error is minus ours, e_s = -e, and a left step
δ of STEAM's is our right step -δ, so its Jacobians and ours are the same matrices.

**Where STEAM approximates** (documented, not a bug of either): ``getJacKnot1``/``getJacKnot2`` write
∂(J⁻¹ϖ₂)/∂ξ as its first-order term ½ ϖ₂⋏ (converted: -½ ad(v₂)); ours is exact. The test asserts our Jacobians
against the 8th-order stencil, STEAM's exact blocks (the pose rows, the twist columns) against ours, and records the
first-order block's deviation at the same point.

**Oracle.** The trajectory T(t) = T₁ Exp(ξ(t)), ξ(t) = A t + B t²/2, whose states come from the block-Toeplitz
``expm`` of [[X, Ẋ], [0, X]] (X = ξ(t)^: its first block row holds Exp(ξ) and d/dt Exp(ξ)), no Jacobian of ours: its
local variables at Δt are exactly [ξ(Δt); ξ̇(Δt)], at 0 [0; A].
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from finite_differences import jacobian8

from steam_ref import X
from steam_ref.gp import interpolation_matrices, process_noise, process_noise_inverse, transition
from steam_ref.lie import SE2, GroupState
from steam_ref.motion.lie_group import LieGroupWnoa

QC_DIAG = np.array([0.1, 0.2, 0.3])  # STEAM's SE(2) priors take a diagonal Qc
D = 3
STATE = GroupState(SE2)

T1 = np.array([0.4, -0.3, 0.7])
A = np.array([0.9, -0.5, 0.6])  # ξ(t) = A t + B t²/2 in the frame of T₁
B = np.array([0.4, 0.8, -0.7])
DT = 0.8


def true_state(t):
    """[T; v] of T(t) = T₁ Exp(ξ(t)) from the matrix exponential alone (module docstring): v^ = E⁻¹ Ė."""
    xi, rate = A * t + B * t * t / 2, A + B * t
    M = scipy.linalg.expm(np.block([[SE2.hat(xi), SE2.hat(rate)], [np.zeros((3, 3)), SE2.hat(xi)]]))
    E, Ed = M[:3, :3], M[:3, 3:]
    v = SE2.vee(np.linalg.inv(E) @ Ed)
    pose = SE2.compose(T1, np.array([E[0, 2], E[1, 2], np.arctan2(E[1, 0], E[0, 0])]))
    return np.concatenate([pose, v])


# --- helper.hpp: getTran, getQ, getQinv -------------------------------------------------------------------------------


@pytest.mark.parametrize("dt", [0.1, 0.8, 3.0])
def test_transition_and_noise_are_steams(dt):
    """helper.hpp, getTran: Φ = [[I, Δt I], [0, I]]; getQ: Q = [[Δt³/3, Δt²/2], [Δt²/2, Δt]] ⊗ diag(Qc);
    getQinv: Q⁻¹ = [[12/Δt³, -6/Δt²], [-6/Δt², 4/Δt]] ⊗ diag(Qc)⁻¹ (STEAM fills the diagonals of its 3 × 3 blocks).
    Ours: ``gp.transition`` exactly, ``process_noise`` and ``process_noise_inverse`` to 1e-14 relative, and WᵀW of
    the 'se2' prior factor to 1e-12 of the largest entry."""
    qc = np.diag(QC_DIAG)
    np.testing.assert_array_equal(transition(dt, D), np.kron([[1, dt], [0, 1]], np.eye(D)))
    np.testing.assert_allclose(
        process_noise(dt, qc), np.kron([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]], qc), rtol=1e-14, atol=0
    )
    qinv = np.kron([[12 / dt**3, -6 / dt**2], [-6 / dt**2, 4 / dt]], np.diag(1 / QC_DIAG))
    np.testing.assert_allclose(process_noise_inverse(dt, qc), qinv, rtol=1e-14, atol=0)
    W = LieGroupWnoa(SE2, qc).prior_factor(X(0), X(1), dt).sqrt_information
    np.testing.assert_allclose(W.T @ W, qinv, rtol=0, atol=1e-12 * np.max(np.abs(qinv)))


# --- prior_factor.cpp (value) and helper.hpp (getJacKnot1, getJacKnot2) ----------------------------------------------


def test_prior_error_and_jacobians():
    """prior_factor.cpp, ``value``: e_s = [ξ₂₁ - Δt ϖ₁; J⁻¹(ξ₂₁) ϖ₂ - ϖ₁], exact; converted e = -e_s = [ξ - Δt v₁;
    J_r(ξ)⁻¹ v₂ - v₁]. Oracle: the states of the known trajectory at 0 and Δt = 0.8 (``true_state``), where
    e = [ξ(Δt) - Δt A; ξ̇(Δt) - A] = [B Δt²/2; B Δt], to 1e-12. helper.hpp, getJacKnot1 and getJacKnot2, converted
    (the same matrices): ∂e/∂δT₁ pose rows -J_r(ξ)⁻¹ Ad(Exp(-ξ)), ∂e/∂δT₂ pose rows J_r(ξ)⁻¹, ∂e/∂ϖ₁ = [-Δt I; -I],
    ∂e/∂ϖ₂ = [0; J_r(ξ)⁻¹]: ours to 1e-14; all of ours against the 8th-order stencil to 1e-9. STEAM's twist row of
    ∂e/∂δT₂, ½ ϖ₂⋏ J⁻¹ converted -½ ad(v₂) J_r(ξ)⁻¹, is first order: 0.0498 off the exact block here (max entry,
    the exact block's largest 0.61), recorded; with A, B halved 0.0124, quartered 0.0031 (second order in the size of
    the motion, as the dropped terms are; measured when this was written)."""
    factor = LieGroupWnoa(SE2, np.diag(QC_DIAG)).prior_factor(X(0), X(1), DT)
    x1, x2 = true_state(0.0), true_state(DT)
    np.testing.assert_allclose(x1[3:], A, rtol=0, atol=1e-14)
    np.testing.assert_allclose(factor.error(x1, x2), np.r_[B * DT**2 / 2, B * DT], rtol=0, atol=1e-12)
    J1, J2 = factor.jacobians(x1, x2)
    n1 = jacobian8(lambda d: factor.error(STATE.retract(x1, d), x2), 2 * D)
    n2 = jacobian8(lambda d: factor.error(x1, STATE.retract(x2, d)), 2 * D)
    np.testing.assert_allclose(J1, n1, rtol=0, atol=1e-9)
    np.testing.assert_allclose(J2, n2, rtol=0, atol=1e-9)
    xi = SE2.log(SE2.between(x1[:3], x2[:3]))
    jinv, eye, zero = SE2.right_jacobian_inverse(xi), np.eye(D), np.zeros((D, D))
    np.testing.assert_allclose(J1[:D, :D], -jinv @ SE2.adjoint(SE2.exp(-xi)), rtol=0, atol=1e-14)
    np.testing.assert_allclose(J2[:D, :D], jinv, rtol=0, atol=1e-14)
    np.testing.assert_allclose(J1[:, D:], np.vstack([-DT * eye, -eye]), rtol=0, atol=0)
    np.testing.assert_allclose(J2[:, D:], np.vstack([zero, jinv]), rtol=0, atol=1e-14)
    steam_block = -0.5 * SE2.ad(x2[3:]) @ jinv  # STEAM's getJacKnot2 twist row, converted
    deviation = float(np.max(np.abs(steam_block - J2[D:, :D])))
    assert 0.0497 < deviation < 0.0498, deviation  # recorded in the docstring


def test_prior_error_sign_conversion():
    """prior_factor.cpp, ``value``, at STEAM's own variables: with T_s = T⁻¹ and ϖ_s = -v (module docstring), STEAM's
    error computed here from its formula (ξ₂₁ = Log(T₂_s T₁_s⁻¹), lgmath's ``vec2jacinv`` = J_r(-ξ)⁻¹) is minus ours,
    to 1e-14, at the known trajectory's states."""
    factor = LieGroupWnoa(SE2, np.diag(QC_DIAG)).prior_factor(X(0), X(1), DT)
    x1, x2 = true_state(0.0), true_state(DT)
    T1s, T2s, w1s, w2s = SE2.inverse(x1[:3]), SE2.inverse(x2[:3]), -x1[3:], -x2[3:]
    xi21 = SE2.log(SE2.compose(T2s, SE2.inverse(T1s)))
    e_steam = np.r_[xi21 - DT * w1s, SE2.right_jacobian_inverse(-xi21) @ w2s - w1s]
    np.testing.assert_allclose(e_steam, -factor.error(x1, x2), rtol=0, atol=1e-14)


# --- pose_interpolator.cpp ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize("ratio", [0.1, 0.25, 0.5, 0.9])
def test_interpolation_coefficients_and_pose(ratio):
    """pose_interpolator.cpp, the constructor: r = τ/T, ψ₁₁ = 3r² - 2r³, ψ₁₂ = τ(r² - r), ψ₂₁ = 6(r - r²)/T,
    ψ₂₂ = 3r² - 2r, λ₁₁ = 1 - ψ₁₁, λ₁₂ = τ - Tψ₁₁ - ψ₁₂, λ₂₁ = -ψ₂₁, λ₂₂ = 1 - Tψ₂₁ - ψ₂₂: the per-axis entries of
    ours Λ(τ), Ψ(τ) (``gp.interpolation_matrices``, any Qc), to 1e-14. ``value``: T_τ = Exp(λ₁₂ ϖ₁ + ψ₁₁ ξ₂₁ +
    ψ₁₂ J⁻¹ϖ₂) T₁, converted T₁ Exp(λ₁₂ v₁ + ψ₁₁ ξ + ψ₁₂ J_r(ξ)⁻¹ v₂): ours (the 'se2' prior's interpolated pose) at
    the known trajectory's states, to 1e-14."""
    T = DT
    tau = ratio * T
    psi11, psi12 = 3 * ratio**2 - 2 * ratio**3, tau * (ratio**2 - ratio)
    psi21, psi22 = 6 * (ratio - ratio**2) / T, 3 * ratio**2 - 2 * ratio
    lam11, lam12, lam21, lam22 = 1 - psi11, tau - T * psi11 - psi12, -psi21, 1 - T * psi21 - psi22
    lam, psi = interpolation_matrices(0.0, T, tau, np.diag(QC_DIAG))
    eye = np.eye(D)
    np.testing.assert_allclose(lam, np.block([[lam11 * eye, lam12 * eye], [lam21 * eye, lam22 * eye]]), atol=1e-14)
    np.testing.assert_allclose(psi, np.block([[psi11 * eye, psi12 * eye], [psi21 * eye, psi22 * eye]]), atol=1e-14)
    x1, x2 = true_state(0.0), true_state(T)
    xi = SE2.log(SE2.between(x1[:3], x2[:3]))
    local = lam12 * x1[3:] + psi11 * xi + psi12 * SE2.right_jacobian_inverse(xi) @ x2[3:]
    x = LieGroupWnoa(SE2, np.diag(QC_DIAG)).interpolate(0.0, x1, T, x2, tau)
    np.testing.assert_allclose(x[:3], SE2.compose(x1[:3], SE2.exp(local)), rtol=0, atol=1e-14)
