"""The exported README's section "SE(3)" (kit v5): SO(3), SE(3) and the GP priors on SE(3) written out, so that a
port needs nothing outside the kit to compute the se3 suite's cases (the derivations behind them, docs/derivations.md
§11 and §14 of steam_ref's source, explain why; the definitions here are all a port computes from)."""

from __future__ import annotations

__all__ = ["RIGID", "EXACT_TIER"]

EXACT_TIER = """**The exact tier.** Quantities a port computes in closed form (Exp, Log, J_r, errors, and from kit v5 the
Jacobians of the se2 and se3 suites) are held to rtol 1e-12 (values) and 1e-10 (Jacobians, atol 1e-12): about 1e3
times what steam_ref and the oracle differ by (the oracle's Jacobians are Romberg-extrapolated central differences
accurate to ~1e-13). A port that differentiates numerically with forward differences (error ~1e-8) fails that
tier; kit v4's se2 Jacobians were held to 1e-8, which forward differences passed."""

RIGID = """What the `se3` cases compute (kit v5), written out so that nothing outside the kit is needed.

**SO(3).** A rotation is stored as R's 9 entries row-major; its tangent is phi (3,), phi^ = [[0, -p3, p2], [p3, 0,
-p1], [-p2, p1, 0]]. Exp(phi) = expm(phi^). Log(R) = theta u with theta in [0, pi]: read theta = atan2(|s|, (tr R -
1)/2), s = vee(R - R^T)/2, and (near pi, where s vanishes and the axis read off R - R^T loses every digit) the axis u
from the symmetric part (R + R^T)/2 - cos(theta) I = (1 - cos(theta)) u u^T, its sign from s (cases
`so3_exp_near_half_turn`, `exp_near_half_turn`: angles pi - 1e-3, pi - 1e-6, pi - 1e-9). J_r(phi) = sum_k
(-phi^)^k / (k+1)!; J_r^-1 its inverse. Near theta = 0 use series: the closed forms cancel (angles 1e-12, 1e-9).

**SE(3).** A pose is stored as 12 numbers [t; R row-major], T = [[R, t], [0, 1]]; a tangent xi = [rho; phi]
(translation first, as the se2 suite; GTSAM's Pose3 puts the rotation first), xi^ = [[phi^, rho], [0, 0]].
Exp(xi) = expm(xi^) = (Exp(phi), V(phi) rho) with V(phi) = sum_k (phi^)^k / (k+1)!; Log(T) = [V(phi)^-1 t; phi],
phi = Log(R). ad_xi = [[phi^, rho^], [0, phi^]] (ad_xi eta = [xi^, eta^] as a vector); J_r(xi) = sum_k (-ad_xi)^k
/ (k+1)! = [[J_r(phi), Q_r], [0, J_r(phi)]], Exp(xi + d) = Exp(xi) Exp(J_r(xi) d) to first order; J_r(xi)^-1 =
[[J_r(phi)^-1, -J_r^-1 Q_r J_r^-1], [0, J_r(phi)^-1]]. Ad(T) = [[R, t^ R], [0, R]]. `between` and its H_a, H_b
are defined as in the section 'SE(2)'.

**States.** An SE(3) state is [T; w] (18 numbers: the pose and its body twist w = [v; omega], dT/dt = T w^); its
tangent has 12 entries, x + d = (T Exp(d[:6]), w + d[6:]). A WNOJ state is [T; w; w_dot] (24 numbers, tangent 18,
x + d = (T Exp(d[:6]), w + d[6:12], w_dot + d[12:])). Every Jacobian (H_k, J_k, J_1) is with respect to that d, every
covariance of that d at the value (pose block in the body frame). Qc is 6x6 on the body twist (WNOA) or body jerk
(WNOJ).

**The WNOA prior** is the section 'SE(2)''s on SE(3): g1 = [0; w1], g2 = [xi21; xi_dot2], xi21 = Log(T1^-1 T2), e = g2
- Phi(dt) g1 = [xi21 - dt w1; xi_dot2 - w1], cost 1/2 e^T Q(dt)^-1 e with the 12x12 Q(dt) = [[dt^3/3 Qc, dt^2/2 Qc],
[dt^2/2 Qc, dt Qc]]; residual 'local-variable' xi_dot2 = J_r(xi21)^-1 w2 (GTSAM 4.3 WnoaMotionFactorPose3, STEAM
const_vel), 'simplified' xi_dot2 = w2 (gpmp2, Theseus). Each case names its residual in `inputs.model`.

**WNOJ** (Tang, Yoon & Barfoot 2019; STEAM const_acc) writes the local state g = [xi; xi_dot; xi_ddot] with the
exact kinematics of xi(t) = Log(T1^-1 T(t)): xi_dot = J_r(xi)^-1 w, xi_ddot = D(J_r(xi)^-1 w)[xi_dot] + J_r(xi)^-1
w_dot, where D(J_r(xi)^-1 v)[u] = -J_r^-1 (DJ_r(xi)[u]) J_r^-1 v and DJ_r(xi)[u] is the derivative of J_r at xi along
u (STEAM keeps only the first-order term of it: that port fails `wnoj_prior_fast`). So g1 = [0; w1; w_dot1], g2 =
[xi21; J_r(xi21)^-1 w2; D(J_r(xi21)^-1 w2)[xi_dot2] + J_r(xi21)^-1 w_dot2], e = g2 - Phi(dt) g1 with Phi(dt) =
[[I, dt I, dt^2/2 I], [0, I, dt I], [0, 0, I]] and Q(dt) = [[dt^5/20, dt^4/8, dt^3/6], [dt^4/8, dt^3/3, dt^2/2],
[dt^3/6, dt^2/2, dt]] (x) Qc. Back from g: T = T1 Exp(xi), w = J_r(xi) xi_dot, w_dot = DJ_r(xi)[xi_dot] xi_dot +
J_r(xi) xi_ddot.

**Interpolation, its covariance, extrapolation.** As the section 'SE(2)': g(tau) = Lambda g1 + Psi g2 with the
vector-space matrices of the model (WNOA or WNOJ: sections 'Motion priors', 'Interpolation and prediction') **of
tau - t1 and t2 - tau** (the cases have t1 = 2.5: absolute
times in their place fail), mapped back as above; cov_tau = [J_1 J_2] P [J_1 J_2]^T + N Q_tau N^T, N = dx(tau)/dg(tau),
Q_tau the conditional covariance of g(tau) given g1, g2. Both terms are congruences of positive semi-definite
matrices, so cov_tau is positive semi-definite as computed: nothing is clipped (`interpolation_covariance_near_a_state`:
its small eigenvalues are Q_tau's, and a floor or a clip moves them). After the last state (t > t1): x(t) = the state
at g(t) = Phi(t - t1) g1, J_1 = dx(t)/d d1, cov_t = J_1 P1 J_1^T + N Q(t - t1) N^T.

**GTSAM.** GTSAM 4.3's WnoaMotionFactorPose3 computes the local-variable residual and cost exactly (it passes
`prior_local_variable_residual_diagonal_qc`, whose `notes` say so); its own tests hold its SE(3) Jacobians to 1e-4
and interpolation Jacobians to 1e-3 to 1e-2, and its Jacobians (a truncated series for d(J_r(xi)^-1 w2)/dxi) fail
this kit's exact tier, 0.11 off at |xi| = 1."""
