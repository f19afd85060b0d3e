"""The exported README's section on the ``se2`` suite (kit v4): the group, the state, both residuals and the
local GP written out, so that a port needs nothing outside the kit (the cases cite README 'SE(2)')."""

from __future__ import annotations

__all__ = ["SE2", "SE2_INPUTS", "SE2_QUANTITIES"]

SE2_INPUTS = (
    "kind: 'exp' (xi: rows [rho1, rho2, phi]), 'log' (poses: rows [x, y, theta]), 'jacobians' (xi), 'between' (a, b "
    "poses), 'prior' (model, x1, x2 SE(2) states, dt, qc 3x3 on the body twist), 'state_prior' (mean, x), "
    "'interpolation' (model, x1, x2, t1, t2, tau, qc, and joint_cov 12x12 for the covariance case), 'batch' (problem "
    "= {variables, factors, values}, iterations), 'incremental' (stream, isam2 as for the incremental suite). Factor "
    "specs of batch and incremental: se2_prior {keys [x1, x2], dt, qc, model}, se2_state_prior {keys [x], mean, "
    "sigmas (6)}, se2_range {keys [x, l], measured, sigma}, prior {keys [l], mean, sigmas (2)}"
)
SE2_QUANTITIES = (
    "exp, log_of_exp (n, 3); log, exp_of_log (n, 3); Jr, Jr_inv (n, 3, 3); between (3,), H_a, H_b, Ad_a (3, 3); "
    "error (6,), H_0, H_1 (6, 6) in right tangents, cost; x_tau (6,), J_1, J_2 (6, 6), cov_tau (6, 6) in the right "
    "tangent at x_tau; iterates (key -> (iterations + 1, n)), costs; relinearized_k, estimate_k (as incremental)"
)

SE2 = """What the `se2` cases compute (kit v4), written out so that nothing outside the kit is needed.

**The group.** A pose is stored [x, y, theta] with theta in (-pi, pi]; as a matrix T = [[R(theta), t], [0, 1]].
A tangent is xi = [rho1, rho2, phi]: translation first, then the angle (GTSAM's Pose2 order), and
xi^ = [[0, -phi, rho1], [phi, 0, rho2], [0, 0, 0]]. Exp(xi) = expm(xi^) = [V(phi) rho; phi] with
V = [[sin(phi)/phi, -(1 - cos(phi))/phi], [(1 - cos(phi))/phi, sin(phi)/phi]] (V = I at phi = 0), and its heading
is returned in (-pi, pi]. Log(T) = [V(phi)^-1 t; phi] with phi = theta brought into (-pi, pi]: **+pi at the half
turn** (a stored -pi gives +pi), so Log(Exp(xi)) = xi only for phi in (-pi, pi] (cases `exp_near_half_turn`,
`log_near_half_turn`). Near phi = 0 use series for the coefficients: the closed forms cancel.

**Right Jacobian.** Exp(xi + d) = Exp(xi) Exp(J_r(xi) d) to first order; J_r(xi) = sum_k (-ad_xi)^k / (k+1)!, with
ad_xi = [[0, -phi, rho2], [phi, 0, -rho1], [0, 0, 0]] (ad_xi eta = [xi^, eta^] as a vector). Log(Exp(xi) Exp(d))
= xi + J_r(xi)^-1 d. Ad(T) = [[R, [y, -x]^T], [0, 0, 1]]: T Exp(xi) T^-1 = Exp(Ad(T) xi).

**The state and its retraction.** An SE(2) state is x = [x, y, theta, vx, vy, w]: the pose T and the **body twist**
w = [vx, vy, w] (velocity in the robot's own frame, dT/dt = T w^). Its tangent is 6-D and the retraction is on
the **right**: x + d = (T Exp(d[:3]), w + d[3:]); x2 - x1 = [Log(T1^-1 T2); w2 - w1]. Every Jacobian of the suite
(H_k, J_k, H_a, H_b) is with respect to that d, and every covariance is of that d at the estimate: its pose block
is in the body frame at the estimate (rotate by R(theta) for a world-frame (x, y) covariance). A left retraction
(Exp(d) T) gives other Jacobians and fails the cases.

**The WNOA prior on SE(2)** between x1 at t1 and x2 at t2 = t1 + dt, through the local variable xi(t) =
Log(T1^-1 T(t)), whose rate is J_r(xi)^-1 w. The local state g = [xi; xi_dot] follows the vector-space WNOA prior
(conventions, gp_prior) with Qc on the body twist: g1 = [0; w1], g2 = [xi21; xi_dot2], xi21 = Log(T1^-1 T2), and

    e = g2 - Phi(dt) g1 = [xi21 - dt w1; xi_dot2 - w1],   cost 1/2 e^T Q(dt)^-1 e

- model **'local-variable'** (Anderson & Barfoot 2015; GTSAM 4.3 WnoaMotionFactorPose2, STEAM const_vel_se2):
  xi_dot2 = J_r(xi21)^-1 w2;
- model **'simplified'** (gpslam GaussianProcessPriorPose2, Theseus GPMotionModel): xi_dot2 = w2.

xi21 is the Log of the relative pose, never theta2 - theta1 unwrapped (case `prior_local_variable_across_pi`).
The two models agree when xi21's angle is small and part as it grows (`prior_*_fast`).

**The local GP between two states.** At t1 < tau < t2, g(tau) = Lambda(tau) g1 + Psi(tau) g2 with the
vector-space WNOA interpolation matrices [YIB Eq. 16, 18] of the model's g2; then x(tau) = (T1 Exp(xi(tau)),
J_r(xi(tau)) xi_dot(tau)) ('simplified': w(tau) = xi_dot(tau)). J_k = d x(tau) / d d_k, x(tau) read in its own right
tangent. The covariance (case `interpolation_covariance_local_variable`) is first order: with P = joint_cov the
covariance of [d1; d2], N = d x(tau) / d g(tau) and Q_tau the local GP's conditional covariance of g(tau) given g1,
g2 (the vector-space one of the gp suite's interpolation_covariance with a zero joint_cov),
cov_tau = [J_1 J_2] P [J_1 J_2]^T + N Q_tau N^T.

**Batch and incremental.** As the batch and incremental suites, with x <- x + d the right retraction for the
states and vector addition for landmarks; relinearization moves theta_bar <- theta_bar + d by the retraction; the
range error is |l - p| - r with p the state's position.
"""
