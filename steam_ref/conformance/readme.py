"""The exported kit's README: everything an implementer needs, without steam_ref's docs.

``steam-ref conformance export DIR`` writes it beside the kit: the files, how to write results and
check them, every convention (with the alternatives ``check --conventions`` accepts), the inputs of
each suite, every factor's error, Jacobian convention, inputs and outputs, the tree-edit ordering
rule with a worked example, the fixed-lag marginal factor derived (the cases cite it, so it is here,
not in steam_ref's docs/derivations.md), the motion priors and the GP's interpolation and prediction written out (sections
"Motion priors", "Interpolation and prediction", :mod:`.readme_gp`), the Lie groups of the se2 and se3 suites written
out (sections "SE(2)", "SE(3)", :mod:`.readme_rigid`), and the paper suite's set-up and procedure.
"""

from __future__ import annotations

from .conventions import CONVENTION_ALTERNATIVES, CONVENTIONS, RESULTS_LAYOUT, TREE_EDIT_EXAMPLE
from .kitio import KIT_VERSION, SUITES
from .paper_spec import PROCEDURE, SETUP_FIELDS
from .readme_gp import GP_INTERPOLATION, GP_MODELS
from .readme_rigid import EXACT_TIER, RIGID

__all__ = [
    "export_readme",
    "FACTOR_TABLE",
    "QUANTITIES",
    "SUITE_INPUTS",
    "FIXED_LAG",
    "LIE_GROUP",
    "GP_INTERPOLATION",
    "GP_MODELS",
]

FACTOR_TABLE = [  # type, keys, fields, error e (prediction minus measurement)
    ("gp_prior", "x1, x2", "dt, qc", "x2 - Phi(dt) x1, Sigma = Q(dt) [YIB Eq. 22, 30-31]"),
    ("prior", "k", "mean, noise", "theta_k - mean [YIB Eq. 4-5]"),
    ("odometry", "x", "measured [v, w], noise", "[cos(th) x_dot + sin(th) y_dot - v, th_dot - w] [YIB Eq. 32]"),
    (
        "velocity",
        "x",
        "measured [v, v_lat, w] (forward, lateral, yaw rate; v_lat is any number), noise",
        "[cos(th) x_dot + sin(th) y_dot - v, -sin(th) x_dot + cos(th) y_dot - v_lat, th_dot - w]",
    ),
    (
        "range",
        "x, l",
        "measured r, noise",
        "sqrt((lx - x)^2 + (ly - y)^2) - r [YIB Eq. 33]; at distance 0, -r with zero H rows (conventions)",
    ),
    ("bearing", "x, l", "measured b, noise", "wrap(atan2(ly - y, lx - x) - th - b) to [-pi, pi)"),
    ("bearing_range", "x, l", "measured [b, r], noise", "[bearing error, range error]"),
    (
        "interpolated",
        "x1, x2 (, l)",
        "t1, t2, tau, qc, inner (a measurement spec without keys)",
        "the inner error at x(tau) = Lambda(tau) x1 + Psi(tau) x2 (WNOA with qc) [YIB Eq. 16, 18, 29]",
    ),
]

QUANTITIES = {
    "factors": "error e (m,); whitened_error W e (m,), without the robust weight even for a robust factor; "
    "H_k = de/dx_k (m, n_k) for each key k in order, counted from 0 (H_0 the first key), in the vector space of the "
    "variables; A_k = sqrt(w) W H_k (A_k the same k); "
    "b = -sqrt(w) W e; cost = 1/2 ||W e||^2 or rho(||W e||); weight w = rho'(s)/s (robust factors only)",
    "gp": "Phi, Q, Qinv, W (W^T W = Q^-1, upper), v_i; Lambda, Psi, x_tau; cov_tau; x_t, cov_t (prediction)",
    "linear": "A (rows in factor order, columns in the ordering), b, information = A^T A, rhs = A^T b, R, d, delta",
    "batch": "iterates: key -> (iterations + 1, n) every iterate from the start; costs (iterations + 1,)",
    "bayes_tree": "cliques: [{frontals, separator, parent}] (unordered list; parent named by its first frontal, "
    "null for a root); conditionals: first frontal -> {R, S, d}; covariances: 'k1,k2' -> joint block",
    "incremental": "k counts the updates from 1 (estimate_1 after the first), in every quantity named _k of a stream "
    "(incremental, fixed_lag, the se2 and se3 streams); estimate_k: key -> vector after update k; relinearized_k: sorted names moved at update k; "
    "update_k: {removed, orphans}, each a sorted list of cliques (compared unordered), each clique named by the "
    "list of its frontals in elimination order (not sorted); nnz_k: the fill of R",
    "fixed_lag": "for each update k: marginalized_k (names, in the order of 'variables'); when any, separator_k "
    "(names, same order), marginal_point_k (theta0 of the separator, stacked), marginal_information_k (Lambda) and "
    "marginal_vector_k (eta) over the separator stacked in that order; estimate_k: key -> vector of the window; "
    "covariances_k: key -> its marginal covariance (conventions, fixed_lag)",
    "se3": "exp, log_of_exp (n, 9) SO(3) / (n, 12) SE(3); Jr, Jr_inv (n, 3, 3) / (n, 6, 6); between (12,), H_a, H_b, "
    "Ad_a (6, 6); error (12,) or WNOJ (18,), H_0, H_1 (12, 12) or (18, 18), cost; x_tau (18,) or (24,), J_1, J_2, "
    "cov_tau in the right tangent at x_tau; x_t, J_1, cov_t (prediction); iterates (key -> (iterations + 1, 18)), "
    "costs; relinearized_k, estimate_k (key -> 18 numbers [t; R; w])",
    "se2": "exp, log_of_exp (n, 3); log, exp_of_log (n, 3); Jr, Jr_inv (n, 3, 3); between (3,), H_a, H_b, Ad_a (3, 3) "
    "(Ad_a = Ad(T_a), section 'SE(2)'); "
    "error (6,), H_0, H_1 (6, 6) in right tangents, cost; x_tau (6,), J_1, J_2 (6, 6), cov_tau (6, 6) in the right "
    "tangent at x_tau; iterates (key -> (iterations + 1, n)), costs; relinearized_k, estimate_k (as incremental); "
    "(v5) a reading's error, whitened_error, H_k, A_k, b, cost (as the factors suite's, H_k in right tangents); "
    "retract, local (n, 6); x_t (6,), J_1 (6, 6), cov_t (6, 6) (prediction); fixed_lag's quantities (as that suite's)",
    "paper": "poses, velocities at the state_poses; landmarks by id; rmse_m",
}

SUITE_INPUTS = {
    "gp": "kind: 'wnoa' (dt, qc), 'lti' (A, F, qc, v, dt: the SDE x_dot = A x + v + F w with a constant input v, "
    "whose v_i = integral_0^dt Phi(dt, s) v ds [YIB Eq. 14, 23]), 'wnoj', 'singer' (alpha: p''' = -alpha p'' + w), "
    "'interpolation' / 'singer_interpolation' (t1, t2, tau, qc, x1, x2), 'interpolation_covariance' (joint_cov: "
    "the covariance of [x(t1); x(t2)]), 'extrapolation' (t1, t, x1, cov1)",
    "factors": "factor (a factor spec) and values (key -> vector)",
    "linear, batch, bayes_tree": "problem = {variables (key -> size), times (key -> time stamp of each state: "
    "for reading only, every factor carries its own dt or t1, t2, tau), factors (specs), values (the "
    "linearization point, or the start of batch)}, ordering (keys), iterations (batch) or groups (covariances)",
    "incremental": "stream = {variables, updates: [{values (new variables only), factors (new ones)}]} and isam2 = "
    "{relinearize_threshold (a number or 'inf'), relinearize_skip, wildfire_threshold}",
    "fixed_lag": "stream = {variables, updates: [{values (new variables only, or one marginalized earlier and seen "
    "again: it enters anew), timestamps (variable -> seconds: a new variable's, or a held one's new time, such as a "
    "landmark's when it is seen again; a variable never stamped is never marginalized), factors (new ones)}]}, lag "
    "(seconds) and isam2 as for incremental",
    "se2": "kind: 'exp' (xi: rows [rho1, rho2, phi]), 'log' (poses: rows [x, y, theta]), 'jacobians' (xi), 'between' (a, b "
    "poses), 'prior' (model, x1, x2 SE(2) states, dt, qc 3x3 on the body twist), 'state_prior' (mean, x), "
    "'interpolation' (model, x1, x2, t1, t2, tau, qc, and joint_cov 12x12 for the covariance case), 'batch' (problem "
    "= {variables, factors, values}, iterations), 'incremental' (stream, isam2 as for the incremental suite). Factor "
    "specs of batch and incremental: se2_prior {keys [x1, x2], dt, qc, model}, se2_state_prior {keys [x], mean, "
    "sigmas (6)}, se2_range {keys [x, l], measured, sigma}, prior {keys [l], mean, sigmas (2)}. Kit v5: 'reading' "
    "(factor, values: as the factors suite's), 'retract' (x, delta: rows of 6), 'extrapolation' (model, x1, t1, t, qc, "
    "cov1), 'fixed_lag' (stream, lag, isam2 as for the fixed_lag suite); specs se2_bearing {keys [x, l], measured, "
    "noise}, se2_bearing_range {keys [x, l], measured [b, r], noise}, se2_velocity {keys [x], measured [vx, vy, w], "
    "noise}, se2_interpolated {keys [x1, x2(, l)], t1, t2, tau, qc, model, inner (a reading spec without keys)}, "
    "se2_range with any noise",
    "se3": "kind: 'so3_exp' (phi: rows of 3), 'so3_jacobians' (phi), 'exp' (xi: rows [rho; phi] of 6), 'jacobians' "
    "(xi), 'between' (a, b poses of 12), 'prior' (model, x1, x2 SE(3) states of 18, dt, qc 6x6), 'wnoj_prior' (x1, x2 "
    "of 24, dt, qc on the jerk), 'state_prior' (mean, x), 'interpolation' (model, x1, x2, t1, t2, tau, qc, and joint_cov "
    "24x24 for a covariance case), 'wnoj_interpolation' (x1, x2 of 24, t1, t2, tau, qc), 'extrapolation' (x1 of 18 or "
    "24, t1, t, qc, cov1), 'batch' (problem, iterations) and 'incremental' (stream, isam2) (as the se2 suite's; specs "
    "se3_prior {keys [x1, x2], dt, qc, model}, se3_state_prior {keys [x], mean (18), sigmas (12)}, se3_velocity {keys "
    "[x], measured (6), sigmas (6)}; values of 18 numbers, 'variables' gives each state's tangent size, 12)",
    "paper": "dataset, file and sha256 of the paper's data file, authors_file and authors_sha256 of the authors' run, "
    "method, every, setup (fields below), setup_fields and procedure (the texts below), state_poses (the poses whose "
    "states are compared) and state_poses_total (the run's number of states)",
}


FIXED_LAG = """What the `fixed_lag` cases compute, derived here so that nothing outside the kit is needed.

**The rule.** After each update, every variable with a timestamp t < t_newest - lag is marginalized:
strictly less; at t = t_newest - lag exactly it stays (the case `timestamp_at_the_boundary`). Any
variable may be stamped, by any update, a held one too (its new time replaces the old): a landmark
stamped with the time it was last seen is forgotten a lag after that (`landmark_forgotten_and_seen_again`);
a variable never stamped is never forgotten. A forgotten variable given a value again is a new variable.

**The marginal factor.** Linearized at theta_bar the problem is ||A delta - b||^2 [YIB Eq. 9-11, 21]. Split the
variables into D (to forget), S (the other variables of the factors adjacent to D, earlier marginal factors
included) and the rest T. Only the factors adjacent to D have columns in D:

    ||A delta - b||^2 = ||A_D delta_D + A_S delta_S - b1||^2 + ||A2 [delta_S; delta_T] - b2||^2        (F.1)

A QR of the first block, [A_D A_S | b1] = Q [[R_D, S_D, d_D], [0, A_m, b_m]] (one elimination step,
[YIB Eq. 24-25]), keeps its norm:

    ||A_D delta_D + A_S delta_S - b1||^2 = ||R_D delta_D + S_D delta_S - d_D||^2 + ||A_m delta_S - b_m||^2 + c   (F.2)

Integrating delta_D out of exp(-1/2 ||A delta - b||^2), the first term of (F.2) integrates to a constant whatever
delta_S is, so the marginal of (S, T) is the factors not touching D plus one new factor ||A_m delta_S - b_m||^2.
With H = [A_D A_S]^T [A_D A_S] and g = [A_D A_S]^T b1, its information form is the Schur complement

    Lambda = A_m^T A_m = H_SS - H_SD H_DD^-1 H_DS,      eta = A_m^T b_m = g_S - H_SD H_DD^-1 g_D           (F.3)

(marginal_information_k, marginal_vector_k). It is unique: neither the elimination order nor the tree changes it.

**Frozen.** delta_S = theta_S - theta0_S is about the linearization point of the moment, theta0_S =
marginal_point_k, and A_m holds the dropped factors' Jacobians there; D is gone, so they can never be evaluated
again. At a later linearization point theta_bar' the factor is the same function of theta_S, rewritten about it:

    ||A_m (theta_S - theta0_S) - b_m||^2 = ||A_m delta' - (b_m - A_m (theta_bar'_S - theta0_S))||^2         (F.4)

so it adds Lambda to the information and eta - Lambda (theta_bar'_S - theta0_S) to the right-hand side.

**Lambda may be singular.** Lambda is positive semi-definite, and positive definite only when the dropped factors
alone fix every direction of S. They often do not: in 6 of the 13 marginalizations of kit v3's cases, and 3 of
the 5 that kit v4 adds, Lambda has a null direction. Dropping the state x_i, the factors adjacent to it are its
GP priors (or the marginal factor of the states before it), its velocity reading and its ranges; the GP prior to
x_(i+1) fixes all of x_(i+1), but a landmark in S that those factors see through a single range (from x_i) has
only its distance from x_i fixed, nothing across the line of sight: the null vector of Lambda is that landmark's
direction perpendicular to x_i -> landmark (its prior is not adjacent to D, so it is not in Lambda). The window's
information, Lambda plus the other factors (that prior, the other ranges), is positive definite. So:

- store Lambda as computed (a symmetric matrix), or a square root of it: A_m from the QR (F.2) (rows = its rank),
  an LDL^T with pivoting, or an eigendecomposition U diag(s) U^T (A_m = diag(sqrt(s)) U^T over s > 0);
- never an unpivoted Cholesky factorization of Lambda alone (it fails at the zero pivot), and never Lambda^-1;
- a covariance of S from Lambda alone does not exist; covariances_k come from the whole window's information.

The cases compare Lambda and eta, which every one of these forms gives.
"""

LIE_GROUP = """What the `se2` cases compute (kit v4), written out so that nothing outside the kit is needed.

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

**between and its Jacobians.** between(T_a, T_b) = B = T_a^-1 T_b. Its Jacobians are taken in right tangents, of
the value read in its own right tangent: H_a = d Log(B^-1 (T_a Exp(d))^-1 T_b) / dd and H_b = d Log(B^-1 T_a^-1 T_b
Exp(d)) / dd at d = 0, so H_a = -Ad(B^-1) and H_b = I (case `between_across_half_turn`; the se3 suite's `between`
alike).

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
vector-space WNOA interpolation matrices [YIB Eq. 16, 18] (section 'Interpolation and prediction') of the model's
g2; then x(tau) = (T1 Exp(xi(tau)),
J_r(xi(tau)) xi_dot(tau)) ('simplified': w(tau) = xi_dot(tau)). J_k = d x(tau) / d d_k, x(tau) read in its own right
tangent. The covariance (case `interpolation_covariance_local_variable`) is first order: with P = joint_cov the
covariance of [d1; d2], N = d x(tau) / d g(tau) and Q_tau the local GP's conditional covariance of g(tau) given g1,
g2 (the vector-space one of the gp suite's interpolation_covariance with a zero joint_cov),
cov_tau = [J_1 J_2] P [J_1 J_2]^T + N Q_tau N^T.

**Batch and incremental.** As the batch and incremental suites, with x <- x + d the right retraction for the
states and vector addition for landmarks; relinearization moves theta_bar <- theta_bar + d by the retraction; the
range error is |l - p| - r with p the state's position.

**Readings of a state (kit v5).** A range, bearing or bearing-range reads the pose [x, y, theta] exactly as the
factors suite reads a vector state's first three numbers (bearing = atan2(ly - py, lx - px) - theta, its error
wrapped to [-pi, pi)); a body-twist reading is e = w - z. Their Jacobians are in the right tangent (to first order
x + d moves the position by R(theta) d[:2] and the heading by d[2], so H = dh/d[p; theta] diag(R(theta), 1) for the
pose readings and [0 I] for the twist). `se2_interpolated` reads its inner reading at x(tau), the local GP's mean
of its model between its two states (above), e = e_inner(x(tau), ...), with H_k = H_inner J_k.

**The retraction (kit v5).** `retract_across_pi` checks x + d and x' - x as defined above on rows that cross +-pi,
translate only, turn by 1e-9 and by 3.5 (beyond pi, so Log gives back 3.5 - 2 pi and another rho).

**The prediction (kit v5).** After the last state (t > t1), g(t) = Phi(t - t1) [0; w1] = [(t - t1) w1; w1] and
x(t) = (T1 Exp((t - t1) w1), w1) under either model (J_r(s w) w = w); J_1 = dx(t)/d d1, and cov_t = J_1 P1 J_1^T +
N Q(t - t1) N^T, where N = dx(t)/dg(t) is the model's: 'local-variable' maps xi_dot through J_r(xi), so N's twist
rows hold d(J_r(xi) xi_dot)/dxi and J_r(xi); 'simplified' takes the twist as xi_dot, N = [[J_r(xi), 0], [0, I]]
(`extrapolation_local_variable`, `extrapolation_simplified`).

**Fixed-lag smoothing on SE(2) (kit v5).** The fixed_lag suite's rule and quantities (section 'Fixed-lag
smoothing'), with theta_bar moved by the right retraction, Lambda and eta in the right tangents, and a frozen
marginal factor contributing eta - Lambda (theta_bar'_S - theta0_S) where theta_bar' - theta0 is the right tangent
step x' - x above, state by state: `fixed_lag_through_the_half_turn` freezes a state at heading 3.05 whose next
linearization point lies past pi (stored -3.13), where subtracting stored headings is 2 pi off.

**The half turn, and its alternative.** The kit's Log and Exp return the half turn as +pi (the double
3.141592653589793 and its negative both read as +pi). That double lies 1.2e-16 inside pi, so an implementation that
takes atan2(sin, cos) of it keeps its sign (gtsam.Pose2: Exp([rho; -3.141592653589793]) has theta =
-3.141592653589793, and a pose stored at -3.141592653589793 logs to that angle with rho = V(phi)^-1 t): it passes
`exp_near_half_turn` and `log_near_half_turn` with `check --conventions signed-half-turn`, whose values the cases
store under `alternatives`.
"""


def _bullets(items) -> str:
    return "\n".join(f"- **{k}**: {v}" for k, v in items)


def export_readme(version: int = KIT_VERSION) -> str:
    """The README of an exported kit of ``version`` (the conventions are written once, in conventions.py)."""
    factors = "\n".join(f"| `{t}` | {k} | {f} | {e} |" for t, k, f, e in FACTOR_TABLE)
    procedure = "\n".join(f"{i}. {step}" for i, step in enumerate(PROCEDURE, start=1))
    return f"""# steam_ref conformance kit, version {version}

Golden inputs and expected outputs for checking an implementation of "Incremental Sparse GP
Regression for Continuous-time Trajectory Estimation & Mapping" (Yan, Indelman, Boots) against
steam_ref. Any language that reads JSON can use it; `*/expected.npz` repeats the expected arrays for
NumPy. This README writes out every definition the cases compute from: the conventions, the motion priors' Phi, Q,
Q^-1, W and v_i (section 'Motion priors': WNOA, WNOJ, Singer, a general LTI SDE), the GP's interpolation and
prediction (section 'Interpolation and prediction'), the fixed-lag marginal factor (section 'Fixed-lag smoothing'),
the groups SE(2), SO(3), SE(3) and their GP priors (sections 'SE(2)', 'SE(3)': the local-variable GP, both
residuals, WNOJ, the interpolated mean and covariance). Why those formulas, Jacobians and covariances are what they
are is derived in steam_ref's docs/derivations.md (§1 and §6 the priors in closed form, §3 interpolation, §7
prediction, §10 fixed lag, §11 the GP on a Lie group, §14 WNOJ on a group), which
this kit does not hold and a port does not need: every Jacobian of the kit is the derivative of a function defined
here, in the retraction defined here.

## Files

- `index.json`: kit version, what generated it, the conventions, their alternatives, the suites
  ({", ".join(SUITES)}), which cases are independent of steam_ref, and the sha256 of every file.
- `<suite>/cases.json`: the suite's cases, each with `inputs`, `quantities` (in computation order,
  each with the conventions it `depends_on`; [] means invariant), `tolerance` (quantity ->
  {{atol, rtol}} or "exact"), `expected`, `alternatives` (expected values of the dependent quantities
  under each alternative convention), `equation` ([YIB Eq. n]), `independent` and `source`.

## Checking

For every case read its `inputs`, compute each quantity named in its `tolerance`, and write

    {RESULTS_LAYOUT}

Then

    steam-ref conformance check RESULTS_DIR [--paper] [--only SUITE...] [--allow-missing] [--conventions NAME...] [--kit DIR]

The gate is every suite but `paper` (the data-free suites: any port can compute them); `--paper` adds the paper
suite, which needs the paper's data files; `--only SUITE...` checks the suites named; `--kit DIR` checks against
this exported folder instead of the installed steam_ref's own copy of the kit the results name.
A numeric quantity passes when max|got - expected| <= atol + rtol * max|expected| over its entries;
an exact one must be equal (lists of cliques unordered; JSON has one number type, so a count written 189.0 is
189). {EXACT_TIER} Every failing quantity is printed with its
worst entries (index, expected, got), and said to be 2 pi k off, minus the expected value (a flipped sign), the
expected square matrix transposed (a transposed Jacobian or W), the
expected entries, columns or rows in another order (the permutation given), a square matrix's rows and columns
both in another order by the same permutation p, got = expected[p][:, p] (a state stacked in another order, as
axis by axis: Phi, Q, Q^-1, W or a covariance; p given), the failing entries all the expected ones times one
factor (a wrong constant or power of dt; the factor given), every entry a float32 value (single precision
somewhere), or another quantity's expected value (Lambda for Psi, H_0 for H_1)
when it is; the first failing quantity in computation order is flagged as
the likely cause; a structure that differs is printed item by item. Exit 0: every case of the gate
passed; 1: a case failed or has no result (unless `--allow-missing`), or no case passed at all (even with
`--allow-missing`: nothing was shown to conform); 2: bad input (a malformed file, a NaN or an Infinity among
the results included: one line names the file, case and quantity, and nothing else is checked). A quantity
a case does not have, or a key of a results file other than kit_version and cases, is a warning line, not an
error: the rest is checked.

## Conventions

{_bullets(CONVENTIONS.items())}

Alternatives that `check --conventions NAME...` accepts for the quantities that depend on them:

{_bullets(CONVENTION_ALTERNATIVES.items())}

`paper-sign` covers the vector-space GP prior (`gp_prior` factors, their rows in the linear suite). The se2 and
se3 suites' priors have no sign alternative: their error is e = g2 - Phi(dt) g1 as the sections 'SE(2)' and
'SE(3)' define it, and their quantities depend on no convention but half_turn.

## Inputs

{_bullets(SUITE_INPUTS.items())}

Keys: 'x<i>' is trajectory state i (6 numbers, [x, y, theta, x_dot, y_dot, theta_dot]; in the se2 suite
[x, y, theta, vx, vy, w], a pose and its body twist, README 'SE(2)'), 'l<j>' landmark j
([x, y]). Noise is `sigma` (scalar), `sigmas` (one per error entry, Sigma = diag(sigmas^2)) or `covariance`
(a matrix); a measurement may carry `loss`: {{"type": "huber", "k": k}} or {{"type": "tukey", "c": c}}.

## Factors

| type | keys | fields | error e |
|---|---|---|---|
{factors}

Jacobians H_k = de/dx_k are taken in the vector space of the variables (theta a plain coordinate, no
manifold; the se2 suite alone takes them in the right tangent of SE(2) states, README 'SE(2)'), one
block per key in the spec's key order; for `interpolated`, the chain rule through Lambda, Psi.
W is the upper-triangular square root of Sigma^-1 (conventions, whitening).

## Motion priors

{GP_MODELS}
## Interpolation and prediction

{GP_INTERPOLATION}
## Outputs

{_bullets(QUANTITIES.items())}

## The ordering rule for tree edits, with a worked example

{CONVENTIONS["tree_edits"]}

{TREE_EDIT_EXAMPLE}
## Fixed-lag smoothing

{FIXED_LAG}
## SE(2)

{LIE_GROUP}
## SE(3)

{RIGID}

## The paper suite: set-up and procedure

Fields of `setup`:

{_bullets(SETUP_FIELDS.items())}

The run (BTGP/1):

{procedure}
"""
