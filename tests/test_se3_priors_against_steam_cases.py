"""STEAM's cases of its SE(3) trajectory priors (const_vel = WNOA, const_acc = WNOJ, Singer), ported as facts.

The source is STEAM (Anderson, Barfoot, Tang, Yoon et al., BSD licence), repository ``utiasASRL/steam`` at commit
d6e83d93: its one test file of the priors, ``tests/jacobian_test.cpp`` (the interpolators' values at a constant
acceleration and their Jacobians against differences), and the closed forms its priors use, in
``include/steam/trajectory/{const_vel,const_acc,singer}/helper.hpp``, ``src/trajectory/{const_vel,const_acc}/prior_factor.cpp``
and ``include/steam/trajectory/singer/prior_factor.hpp``.
(Its Python port ``utiasASRL/pysteam`` has no test of the priors: ``tests/`` holds autograd and a transform error.)
Each test names its file and its test or function. Only inputs, expected outputs and properties carry over.

**The conversion.** STEAM's state is T_k0 (world to body k), perturbed on the left, T ← Exp(δ) T, with the twist ϖ
defined by Ṫ_k0 = ϖ^ T_k0 (lgmath's [ρ; φ] order, as ours). Ours is the pose T = T_k0⁻¹ (body to world), perturbed on
the right, T ← T Exp(δ), with the body twist v of Ṫ = T v^. So, for the same motion:

- T = T_s⁻¹, and Exp(δ) T_s = (T Exp(-δ))⁻¹: a left step δ of STEAM is our right step -δ;
- Ṫ = -T_s⁻¹ Ṫ_s T_s⁻¹ = -T ϖ^, so v = -ϖ and v̇ = -ϖ̇ (a step δ of ϖ is our step -δ of v);
- STEAM's local variable ξ_s = Log(T2_s T1_s⁻¹) = Log(T2⁻¹ T1) = -ξ, ξ = Log(T1⁻¹ T2) ours, and its J_l(ξ_s)⁻¹ ϖ₂ =
  J_r(ξ)⁻¹(-v₂) = -ξ̇: each of STEAM's local variables is minus ours, so its prior error is minus ours, e_s = -e;
- a Jacobian ∂e_s/∂δ_s = ∂(-e)/∂(-δ) = ∂e/∂δ: STEAM's prior Jacobians and ours are the same matrices.

**Where STEAM approximates** (documented differences, not bugs of either): STEAM's WNOJ and Singer prior error writes
ξ̈ as its first-order term, -½ (J⁻¹ϖ₂)⋏ ϖ₂ + J⁻¹ϖ̇₂, ours ½ ad(ξ̇) v₂ + J_r⁻¹ v̇₂ after the conversion, where steam_ref
keeps the exact G(ξ, v₂) ξ̇ + J_r⁻¹ v̇₂ (``lie.gp_accel``); and its WNOA prior Jacobian writes ∂(J⁻¹ϖ₂)/∂ξ as
½ ϖ₂⋏ (ours -½ ad(v₂)), steam_ref keeps it exact. Those tests assert our values against an independent oracle (the
exact derivatives of a known trajectory: the block-triangular ``expm`` gives d/dt and d²/dt² of Exp(ξ(t)) without
differences; 8th-order central differences for Jacobians) and record STEAM's deviation at the same point.

**A bug of STEAM's found by the port** (``include/steam/trajectory/singer/helper.hpp``, ``getQ`` and ``getTran``, the
branch for α < 1): its Taylor series use C++ integer divisions, (1 / 6), (1 / 3), (2 / 3), (1 / 24), (1 / 120),
(1 / 720), each 0, so at α = 0.5, Δt = 0.1 its Q_pa is 2.25e-7 (exact 1.586e-4), its Q_vv -1.22e-5 (exact 3.211e-4:
the matrix is not positive definite), Q_aa off by 0.17 % and Φ_pa by 1.7 %; its other coefficients carry 6 figures
(relative errors of 1e-8). The test of that branch asserts ours against 30-digit closed forms.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from finite_differences import jacobian8
from requirements import optional_import

from steam_ref import X
from steam_ref.gp import LinearSDE, wnoj_process_noise_inverse
from steam_ref.gp.interpolate import interpolation_matrices, interpolation_terms
from steam_ref.gp.prior import process_noise_inverse
from steam_ref.lie import SE3, GroupState, gp_accel
from steam_ref.lie import gp as lie_gp
from steam_ref.motion.lie_accel import LieGroupAccelPrior
from steam_ref.motion.lie_group import LieGroupWnoa

mp = optional_import("mpmath", "test")

QC_DIAG = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6])  # STEAM's priors take a diagonal Qc
D = 6

# A generic point for the priors' errors and Jacobians (STEAM's own test knots are at zero, T₁ = I, ϖ₁ = 0, where a
# wrong term can vanish; its knots are used for the interpolators' values below, as STEAM uses them).
T1 = SE3.exp([0.3, -0.2, 0.5, 0.4, -0.3, 0.2])
A = np.array([0.8, -0.4, 0.3, 0.5, 0.2, -0.6])  # ξ(t) = A t + B t²/2 + C t³/6 in the frame of T₁
B = np.array([0.2, 0.5, -0.3, -0.4, 0.3, 0.1])
C = np.array([-0.5, 0.3, 0.2, 0.3, -0.2, 0.4])
DT = 0.7


# --- the oracle: the exact state of T(t) = T₁ Exp(ξ(t)) ------------------------------------------------------------------


def true_state(t, accel=True):
    """[T; v; v̇] of T(t) = T₁ Exp(ξ(t)) from the matrix exponential alone: for X(t) = ξ(t)^, the block-Toeplitz
    expm([[X, Ẋ, Ẍ/2], [0, X, Ẋ], [0, 0, X]]) holds E = Exp(ξ), Ė and Ë/2 in its first block row, so v^ = E⁻¹Ė and
    v̇^ = E⁻¹(Ë - Ė v^) (from Ė = E v^). No Jacobian of ours enters."""
    xi, rate, acc = A * t + B * t * t / 2 + C * t**3 / 6, A + B * t + C * t * t / 2, B + C * t
    X, Xd, Xdd = SE3.hat(xi), SE3.hat(rate), SE3.hat(acc)
    Z = np.zeros((4, 4))
    M = scipy.linalg.expm(np.block([[X, Xd, Xdd / 2], [Z, X, Xd], [Z, Z, X]]))
    E, Ed, Edd = M[:4, :4], M[:4, 4:8], 2 * M[:4, 8:]
    Einv = np.linalg.inv(E)
    v = SE3.vee(Einv @ Ed)
    vd = SE3.vee(Einv @ (Edd - Ed @ SE3.hat(v)))
    T = SE3.compose(T1, np.concatenate([E[:3, 3], E[:3, :3].ravel()]))
    return np.concatenate([T, v, vd] if accel else [T, v])


def local_gamma(t):
    """The exact local state [ξ; ξ̇; ξ̈] at t of the trajectory above."""
    return np.concatenate([A * t + B * t * t / 2 + C * t**3 / 6, A + B * t + C * t * t / 2, B + C * t])


def right_jacobians(f, x1, x2, kind):
    """∂f/∂δ₁, ∂f/∂δ₂ by the 8th-order stencil, each state stepped on the right (``kind.retract``)."""
    n = 2 * D if kind.derivatives == 1 else 3 * D
    return (
        jacobian8(lambda d: f(kind.retract(x1, d), x2), n),
        jacobian8(lambda d: f(x1, kind.retract(x2, d)), n),
    )


# --- Φ, Q and Q⁻¹: STEAM's helper.hpp closed forms -----------------------------------------------------------------------


@pytest.mark.parametrize("dt", [0.1, 0.7, 3.0])
def test_wnoa_transition_and_noise_are_steams_const_vel(dt):
    """STEAM include/steam/trajectory/const_vel/helper.hpp, getTran, getQ, getQinv: Φ = [[I, Δt I], [0, I]],
    Q = [[Δt³/3, Δt²/2], [Δt²/2, Δt]] ⊗ Qc, Q⁻¹ = [[12/Δt³, -6/Δt²], [-6/Δt², 4/Δt]] ⊗ Qc⁻¹, to 1e-14 relative (STEAM
    evaluates the same monomials); ours: ``gp.prior.process_noise_inverse`` to 1e-14, and WᵀW of the prior factor's
    square-root information to 1e-12."""
    sde, Qc, Qci = LinearSDE.wnoa(np.diag(QC_DIAG)), np.diag(QC_DIAG), np.diag(1 / QC_DIAG)
    np.testing.assert_allclose(sde.transition(dt), np.kron([[1, dt], [0, 1]], np.eye(D)), rtol=1e-15, atol=0)
    Q = np.kron([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]], Qc)
    np.testing.assert_allclose(sde.process_noise(dt), Q, rtol=1e-14, atol=0)
    Qinv = np.kron([[12 / dt**3, -6 / dt**2], [-6 / dt**2, 4 / dt]], Qci)
    np.testing.assert_allclose(process_noise_inverse(dt, Qc), Qinv, rtol=1e-14, atol=0)
    W = LieGroupWnoa(SE3, Qc).prior_factor(X(0), X(1), dt).sqrt_information
    np.testing.assert_allclose(W.T @ W, Qinv, rtol=1e-12, atol=1e-12 * np.max(np.abs(Qinv)))


@pytest.mark.parametrize("dt", [0.1, 0.7, 3.0])
def test_wnoj_transition_and_noise_are_steams_const_acc(dt):
    """STEAM include/steam/trajectory/const_acc/helper.hpp, getTran, getQ, getQinv: Φ = [[I, Δt, Δt²/2], [0, I, Δt],
    [0, 0, I]], Q = [[Δt⁵/20, Δt⁴/8, Δt³/6], [Δt⁴/8, Δt³/3, Δt²/2], [Δt³/6, Δt²/2, Δt]] ⊗ Qc, Q⁻¹ = [[720/Δt⁵, -360/Δt⁴,
    60/Δt³], [-360/Δt⁴, 192/Δt³, -36/Δt²], [60/Δt³, -36/Δt², 9/Δt]] ⊗ Qc⁻¹ (ours: ``gp.wnoj_process_noise_inverse`` to
    1e-14, and WᵀW of the prior factor to 1e-10)."""
    sde, Qc, Qci = LinearSDE.wnoj(np.diag(QC_DIAG)), np.diag(QC_DIAG), np.diag(1 / QC_DIAG)
    phi = np.kron([[1, dt, dt**2 / 2], [0, 1, dt], [0, 0, 1]], np.eye(D))
    np.testing.assert_allclose(sde.transition(dt), phi, rtol=1e-15, atol=0)
    q = [[dt**5 / 20, dt**4 / 8, dt**3 / 6], [dt**4 / 8, dt**3 / 3, dt**2 / 2], [dt**3 / 6, dt**2 / 2, dt]]
    np.testing.assert_allclose(sde.process_noise(dt), np.kron(q, Qc), rtol=1e-14, atol=0)
    qi = [
        [720 / dt**5, -360 / dt**4, 60 / dt**3],
        [-360 / dt**4, 192 / dt**3, -36 / dt**2],
        [60 / dt**3, -36 / dt**2, 9 / dt],
    ]
    W = LieGroupAccelPrior.wnoj(SE3, Qc).prior_factor(X(0), X(1), dt).sqrt_information
    Qinv = np.kron(qi, Qci)
    np.testing.assert_allclose(wnoj_process_noise_inverse(dt, Qc), Qinv, rtol=1e-14, atol=0)
    np.testing.assert_allclose(W.T @ W, Qinv, rtol=1e-10, atol=1e-11 * np.max(np.abs(Qinv)))


def steam_singer_closed_forms(alpha, dt):
    """STEAM's Singer Φ and Q (per axis, qc = 1) from its closed forms for α ≥ 1 (singer/helper.hpp), at 30 digits:
    Φ_pa = (αΔt - 1 + e^{-αΔt})/α², Φ_va = (1 - e^{-αΔt})/α, Φ_aa = e^{-αΔt}; with x = αΔt, E = e^{-x}:
    Q_pp = ½α⁻⁵(1 - E² + 2x + ⅔x³ - 2x² - 4xE), Q_pv = ½α⁻⁴(E² + 1 - 2E + 2xE - 2x + x²), Q_pa = ½α⁻³(1 - E² - 2xE),
    Q_vv = ½α⁻³(4E - 3 - E² + 2x), Q_va = ½α⁻²(E² + 1 - 2E), Q_aa = ½α⁻¹(1 - E²)."""
    with mp.workdps(30):
        a, t = mp.mpf(alpha), mp.mpf(dt)
        x = a * t
        E = mp.exp(-x)
        phi = [[1, t, (x - 1 + E) / a**2], [0, 1, (1 - E) / a], [0, 0, E]]
        pp = (1 - E**2 + 2 * x + mp.mpf(2) / 3 * x**3 - 2 * x**2 - 4 * x * E) / (2 * a**5)
        pv = (E**2 + 1 - 2 * E + 2 * x * E - 2 * x + x**2) / (2 * a**4)
        pa = (1 - E**2 - 2 * x * E) / (2 * a**3)
        vv = (4 * E - 3 - E**2 + 2 * x) / (2 * a**3)
        va = (E**2 + 1 - 2 * E) / (2 * a**2)
        aa = (1 - E**2) / (2 * a)
        q = [[pp, pv, pa], [pv, vv, va], [pa, va, aa]]
        return np.array(phi, dtype=float), np.array([[float(v) for v in row] for row in q])


@pytest.mark.parametrize(("alpha", "dt"), [(1.0, 0.1), (1.0, 0.7), (2.5, 0.1), (2.5, 3.0), (0.5, 0.1), (0.2, 0.7)])
def test_singer_transition_and_noise_are_steams_closed_forms(alpha, dt):
    """STEAM include/steam/trajectory/singer/helper.hpp, getTran and getQ (the Singer model ϖ̈ = -α ϖ̇ + w, its α
    STEAM's ``ad``): Φ and Q of :func:`steam_singer_closed_forms` ⊗ I and ⊗ Qc, to 1e-12 relative of each block's
    scale. STEAM takes these closed forms for α ≥ 1 only; below it sums a series whose integer divisions vanish
    (module docstring: STEAM's bug, its Q not positive definite at α = 0.5, Δt = 0.1): here α = 0.5, 0.2 are checked
    against the same closed forms at 30 digits, which have no cancellation there."""
    sde = LinearSDE.singer(np.diag(QC_DIAG), alpha=alpha)
    phi, q = steam_singer_closed_forms(alpha, dt)
    np.testing.assert_allclose(sde.transition(dt), np.kron(phi, np.eye(D)), rtol=1e-13, atol=1e-16)
    expected = np.kron(q, np.diag(QC_DIAG))
    scale = np.sqrt(np.outer(np.diag(expected), np.diag(expected)))  # each entry against its row's and column's size
    np.testing.assert_array_less(np.abs(sde.process_noise(dt) - expected), 1e-12 * scale + 1e-300)


# --- the interpolators: STEAM tests/jacobian_test.cpp ------------------------------------------------------------------


def steam_knots(dt=0.1):
    """STEAM's knots of its const_acc and Singer tests, converted (module docstring): T₁ = I, ϖ₁ = 0, ϖ̇₁ = ϖ̇₂ = -1 (each
    entry), ϖ₂ = ϖ̇ Δt, T₂ = Exp(½ϖ̇Δt²) T₁ (STEAM's Magnus expansion, its ϖ₁ = 0 zeroing every commutator term), Δt = 0.1,
    τ = Δt/2. Ours: v = -ϖ, so v₁ = 0, v̇ = 1, v₂ = v̇ Δt, and T₂ = (Exp(½ϖ̇Δt²))⁻¹ = Exp(½v̇Δt²)."""
    acc = np.ones(D)
    x1 = np.concatenate([SE3.identity(), np.zeros(D), acc])
    x2 = np.concatenate([SE3.exp(0.5 * acc * dt * dt), acc * dt, acc])
    return x1, x2, acc


@pytest.mark.parametrize("model", ["wnoj", "singer-alpha-0"])
def test_constant_acceleration_is_interpolated_exactly(model):
    """STEAM tests/jacobian_test.cpp, ConstAcc.PoseInterpolator, ConstAcc.VelocityInterpolator,
    ConstAcc.AccelerationInterpolator, and Singer.PoseInterpolator, Singer.VelocityInterpolator,
    Singer.AccelerationInterpolator (whose values STEAM checks at α = 0, where Singer's model is WNOJ): at τ = Δt/2 the
    pose is Exp(½ϖ̇τ²) T₁, the twist ϖ̇τ, the acceleration ϖ̇ (STEAM: 1e-6 in norm). Converted: T(τ) = Exp(½v̇τ²),
    v(τ) = v̇τ, v̇(τ) = v̇. Ours has α > 0: the Singer case is α = 1e-9 (time constant 1e9 s), whose interpolation differs
    from WNOJ's by O(αΔt), within STEAM's 1e-6; WNOJ's is exact (ξ(t) = ½v̇t² along one axis: every J_r and its
    derivatives act as the identity on it), here to 1e-14."""
    x1, x2, acc = steam_knots()
    qc = np.diag(QC_DIAG)
    if model == "wnoj":
        prior, tol = LieGroupAccelPrior.wnoj(SE3, qc), 1e-14
    else:
        prior, tol = LieGroupAccelPrior.singer(SE3, qc, time_constant=1e9), 1e-6
    tau = 0.05
    x = prior.interpolate(0.0, x1, 0.1, x2, tau)
    expected = np.concatenate([SE3.exp(0.5 * acc * tau * tau), acc * tau, acc])
    np.testing.assert_allclose(x, expected, rtol=0, atol=tol)


@pytest.mark.parametrize("alpha", [None, 1.0])
def test_wnoj_and_singer_interpolation_jacobians_at_steams_knots(alpha):
    """STEAM tests/jacobian_test.cpp, ConstAcc.{Pose,Velocity,Acceleration}Interpolator and
    Singer.{Pose,Velocity,Acceleration}Interpolator (α = ``ad`` = 1 there), the Jacobians of x(τ) with respect to each
    of T₁, ϖ₁, ϖ̇₁, T₂, ϖ₂, ϖ̇₂ against central differences with step 1e-5 (STEAM: 2 % relative, or 1e-2 absolute for an
    entry below 1e-2). At the converted knots (``steam_knots``), right steps of ours (a left step of STEAM's is our
    right step negated, which leaves a Jacobian as it is: module docstring), x(τ) compared in its right tangent; ours
    against the 8th-order stencil, to 1e-9."""
    x1, x2, _ = steam_knots()
    sde = LinearSDE.wnoj(np.diag(QC_DIAG)) if alpha is None else LinearSDE.singer(np.diag(QC_DIAG), alpha=alpha)
    lam, psi, offset = interpolation_terms(sde, 0.0, 0.1, 0.05)
    kind = GroupState(SE3, 2)

    def at(a, b):
        return gp_accel.interpolate(a, b, lam, psi, offset, group=SE3, jacobians=False)

    x, J1, J2 = gp_accel.interpolate(x1, x2, lam, psi, offset, group=SE3)
    n1, n2 = right_jacobians(lambda a, b: kind.local(x, at(a, b)), x1, x2, kind)
    np.testing.assert_allclose(J1, n1, rtol=0, atol=1e-9)
    np.testing.assert_allclose(J2, n2, rtol=0, atol=1e-9)


def test_constant_velocity_interpolation_value_and_jacobians():
    """STEAM tests/jacobian_test.cpp, ConstVel.VelocityInterpolator: knots T₁ = I, ϖ₁ = ϖ₂ = 1 (each entry), Δt = 0.1,
    T₂ = Exp(ϖΔt) T₁ (its acceleration (ϖ₂ - ϖ₁)/Δt = 0); at τ = Δt/2 the twist is ϖ₁ (STEAM: 1e-6 in norm), and its
    Jacobians match differences (STEAM: 2 %). Converted: v = -1, T₂ = Exp(vΔt); ours: v(τ) = v to 1e-14, and (a fact
    STEAM's test implies, a constant twist's arc) T(τ) = Exp(vτ) to 1e-14; the Jacobians against the 8th-order stencil,
    to 1e-9."""
    v = -np.ones(D)
    x1 = np.concatenate([SE3.identity(), v])
    x2 = np.concatenate([SE3.exp(v * 0.1), v])
    prior = LieGroupWnoa(SE3, np.diag(QC_DIAG))
    x = prior.interpolate(0.0, x1, 0.1, x2, 0.05)
    np.testing.assert_allclose(x[12:], v, rtol=0, atol=1e-14)
    np.testing.assert_allclose(x[:12], SE3.exp(v * 0.05), rtol=0, atol=1e-14)
    lam, psi = interpolation_matrices(0.0, 0.1, 0.05, np.diag(QC_DIAG))
    kind = GroupState(SE3)

    def at(a, b):
        return lie_gp.interpolate(a, b, lam, psi, group=SE3, jacobians=False)

    _, J1, J2 = lie_gp.interpolate(x1, x2, lam, psi, group=SE3)
    n1, n2 = right_jacobians(lambda a, b: kind.local(x, at(a, b)), x1, x2, kind)
    np.testing.assert_allclose(J1, n1, rtol=0, atol=1e-9)
    np.testing.assert_allclose(J2, n2, rtol=0, atol=1e-9)


# --- the prior factors' errors and Jacobians: STEAM prior_factor.cpp / .hpp, helper.hpp -----------------------------------


def test_wnoa_prior_error_and_jacobians():
    """STEAM src/trajectory/const_vel/prior_factor.cpp (value: e = [ξ₂₁ - Δt ϖ₁; J⁻¹(ξ₂₁) ϖ₂ - ϖ₁], exact) and
    include/steam/trajectory/const_vel/helper.hpp (getJacKnot1, getJacKnot2). Converted, e_s = -e (module docstring).
    Oracle: the states [T; v] of T(t) = T₁ Exp(ξ(t)), ξ(t) = At + Bt²/2 + Ct³/6, at 0 and Δt = 0.7 (``true_state``),
    whose local variables are exactly [ξ(Δt); ξ̇(Δt)] and [0; A]: e = [ξ(Δt) - ΔtA; ξ̇(Δt) - A], to 1e-12.
    Jacobians: ours against the 8th-order stencil, to 1e-9. STEAM's ∂(J⁻¹ϖ₂)/∂ξ is its first-order term: its
    ∂e/∂δT₂ velocity block, converted -½ ad(v₂) J_r⁻¹(ξ), differs from the exact one here by 0.0281 (max entry;
    the exact block's largest entry 0.397), asserted as recorded; the error of a first-order term, O(abs(ξ) abs(v₂)):
    with A, B, C halved it is 0.00714, quartered 0.00179 (measured when this was written)."""
    qc = np.diag(QC_DIAG)
    factor = LieGroupWnoa(SE3, qc).prior_factor(X(0), X(1), DT)
    x1, x2 = true_state(0.0, accel=False), true_state(DT, accel=False)
    gamma = local_gamma(DT)
    expected = np.concatenate([gamma[:D] - DT * A, gamma[D : 2 * D] - A])
    np.testing.assert_allclose(factor.error(x1, x2), expected, rtol=0, atol=1e-12)
    J1, J2 = factor.jacobians(x1, x2)
    n1, n2 = right_jacobians(factor.error, x1, x2, GroupState(SE3))
    np.testing.assert_allclose(J1, n1, rtol=0, atol=1e-9)
    np.testing.assert_allclose(J2, n2, rtol=0, atol=1e-9)
    xi = gamma[:D]
    steam_block = -0.5 * SE3.ad(x2[12:]) @ SE3.right_jacobian_inverse(xi)  # STEAM's, converted
    deviation = float(np.max(np.abs(steam_block - J2[D:, :D])))
    assert 0.028 < deviation < 0.0282, deviation  # recorded in the docstring


def test_wnoj_and_singer_prior_errors_and_jacobians():
    """STEAM src/trajectory/const_acc/prior_factor.cpp and include/steam/trajectory/singer/prior_factor.hpp (Singer's
    inherits const_acc's error with its own Φ) (value:
    e = γ₂ - Φ γ₁, γ₁ = [0; ϖ₁; ϖ̇₁], γ₂ = [ξ₂₁; J⁻¹ϖ₂; -½(J⁻¹ϖ₂)⋏ϖ₂ + J⁻¹ϖ̇₂]) and their helper.hpp getJacKnot1/2.
    Oracle: the states of T(t) = T₁ Exp(At + Bt²/2 + Ct³/6) at 0 and Δt = 0.7 from ``true_state`` (matrix exponentials
    only), whose local variables are exactly γ₂ = [ξ(Δt); ξ̇(Δt); ξ̈(Δt)], γ₁ = [0; A; B]: e = γ₂ - Φγ₁, to 1e-11,
    Φ WNOJ's or Singer's (α = 1; Φ from ``scipy.linalg.expm`` of the model's A Δt, written here). STEAM's third block
    is the first-order ξ̈; converted, ½ ad(ξ̇) v₂ + J_r⁻¹ v̇₂, it differs from the exact ξ̈ here by 0.00643 (max
    entry, of ξ̈'s 0.71), asserted as recorded (with A, B, C halved 7.9e-4, quartered 9.5e-5: third order, as the
    dropped terms are). Jacobians: ours against the 8th-order stencil, to 1e-8 (STEAM's differentiate its
    approximate error)."""
    x1, x2 = true_state(0.0), true_state(DT)
    gamma2, gamma1 = local_gamma(DT), np.concatenate([np.zeros(D), A, B])
    for alpha in (0.0, 1.0):
        model = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -alpha]])  # per axis: p⃛ = -α p̈ + w
        phi = np.kron(scipy.linalg.expm(model * DT), np.eye(D))
        prior = (
            LieGroupAccelPrior.wnoj(SE3, np.diag(QC_DIAG))
            if alpha == 0.0
            else LieGroupAccelPrior.singer(SE3, np.diag(QC_DIAG), time_constant=1 / alpha)
        )
        factor = prior.prior_factor(X(0), X(1), DT)
        np.testing.assert_allclose(factor.error(x1, x2), gamma2 - phi @ gamma1, rtol=0, atol=1e-11)
        J1, J2 = factor.jacobians(x1, x2)
        n1, n2 = right_jacobians(factor.error, x1, x2, GroupState(SE3, 2))
        np.testing.assert_allclose(J1, n1, rtol=0, atol=1e-8)
        np.testing.assert_allclose(J2, n2, rtol=0, atol=1e-8)
    xi, rate = gamma2[:D], gamma2[D : 2 * D]
    steam_third = 0.5 * SE3.ad(rate) @ x2[12:18] + SE3.right_jacobian_inverse(xi) @ x2[18:]  # STEAM's, converted
    deviation = float(np.max(np.abs(steam_third - gamma2[2 * D :])))
    assert 0.0064 < deviation < 0.00645, deviation  # recorded in the docstring
