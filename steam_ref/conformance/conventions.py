"""The conventions the kit's numbers follow, written once: into ``index.json`` and the exported README.

Each quantity of a case is either convention-invariant (cost, 𝓘 = AᵀA, Aᵀb, R, d, δ, marginals,
estimates) or depends on named conventions (:func:`depends_on`): ``residual`` (the sign of an
error), ``whitening`` (which W with WᵀW = Σ⁻¹) and (kit v5) ``half_turn`` (SE(2)'s angle at ±π). For those, the kit also stores the values under
the documented alternatives (:data:`CONVENTION_ALTERNATIVES`), which ``check --conventions`` accepts.
"""

from __future__ import annotations

from .kitio import KIT_VERSION

__all__ = ["CONVENTIONS", "CONVENTION_ALTERNATIVES", "RESULTS_LAYOUT", "TREE_EDIT_EXAMPLE", "depends_on"]

CONVENTIONS = {
    "state": "x = [x, y, theta, x_dot, y_dot, theta_dot]: p = [x, y, theta] then its rate "
    "(x = [p; p_dot], [YIB Eq. 30]); WNOJ and Singer cases use x = [p; p_dot; p_ddot]; a landmark is l = [x, y]",
    "keys": "'x<i>' names trajectory state i, 'l<j>' landmark j; a problem lists its variables and their sizes "
    "in 'variables'",
    "units": "time in seconds, distances in metres, angles in radians; Qc is the power spectral density of w(t) "
    "(units of p squared per cubic second)",
    "gp_prior": "zero-mean white noise on acceleration: x_dot = A x + F w, A = [[0, I], [0, 0]], F = [0; I], "
    "w ~ GP(0, Qc delta(t - t')) [YIB Eq. 30-31]; Phi(dt) = [[I, dt I], [0, I]], "
    "Q(dt) = [[dt^3/3 Qc, dt^2/2 Qc], [dt^2/2 Qc, dt Qc]] [YIB Eq. 16-17]",
    "residual": "e = h(theta) - y: prediction minus measurement; a prior e = theta - mean; the GP prior "
    "e = x_i - Phi(t_i, t_{i-1}) x_{i-1} - v_i, which is the negative of the expression inside [YIB Eq. 22] "
    "(the sign leaves the cost unchanged and flips H and b); GTSAM 4.3's WnoaMotionFactor uses this same sign",
    "whitening": "W is the upper-triangular factor with positive diagonal of the information: W^T W = Sigma^-1; "
    "whitened error W e, whitened Jacobian W H; for the GP prior Sigma = Q(dt). whitened_error is W e without "
    "the robust weight, also for a robust factor (A and b carry sqrt(w))",
    "cost": "cost = 1/2 sum_i ||W_i e_i||^2 (the factor graph's negative log density up to a constant, [YIB Eq. 21]); "
    "a robust factor contributes rho(||W e||) instead; [YIB Eq. 6] writes the sum without the 1/2",
    "robust": "iteratively reweighted least squares as GTSAM's noiseModel::Robust: s = ||W e||, weight w = rho'(s)/s, "
    "linearized rows sqrt(w) W H and b = -sqrt(w) W e. Huber(k): rho = s^2/2 for s <= k, k s - k^2/2 beyond; "
    "w = 1, k/s. Tukey(c): rho = c^2/6 (1 - (1 - (s/c)^2)^3) for s <= c, c^2/6 beyond; w = (1 - (s/c)^2)^2, 0",
    "jacobians": "H_k = de/dx_k in the vector space of the variables (theta is a plain coordinate: no manifold); "
    "A_k = sqrt(w) W H_k; k counts the factor's keys in order",
    "angles": "bearing errors are wrapped to [-pi, pi); nothing else is wrapped: headings in states are continuous "
    "coordinates, and the GP prior's heading error is used as computed even beyond pi (a heading stored 2 pi "
    "lower is a different state)",
    "linear_system": "minimize ||A delta - b||^2: A stacks each factor's rows A_k in factor order, columns in "
    "the case's ordering, one block per variable; b = -sqrt(w) W e; information I = A^T A, rhs = A^T b, "
    "delta = I^-1 A^T b, and the new estimate is theta + delta [YIB Eq. 9-11]",
    "R_factor": "R is upper triangular with positive diagonal and R^T R = I in the case's ordering (unique); "
    "d = R^-T A^T b, so R delta = d [YIB Eq. 21]",
    "cliques": "eliminating in a given order: each variable's separator by the elimination game; walking the order "
    "backwards, a variable whose separator equals all variables of its parent's clique joins it, any other "
    "starts a child clique (GTSAM's rule). Frontals and separators are listed in elimination order; the "
    "parent is named by its first frontal; clique lists are unordered",
    "conditionals": "a clique is P(F | S) with density exp(-1/2 ||R delta_F + S delta_S - d||^2), rows scaled so that "
    "diag R > 0: the rows of the R factor (and d) that belong to F [YIB Eq. 25]",
    "covariances": "blocks of I^-1 at the case's linearization point; a group 'k1,k2' is the joint covariance of the "
    "stacked variables [YIB Eq. 11]",
    "incremental": "iSAM2 as GTSAM 4.3: new factors and values per update; relinearization happens at the start "
    "of every relinearize_skip-th update (updates counted from 1: skip 2 checks at updates 2, 4, ...): each "
    "variable whose last delta has max |delta_j| >= beta (relinearize_threshold) moves its linearization point "
    "by delta_j, and every factor touching it is linearized again there; a new variable starts at its given value "
    "with delta 0; wildfire threshold 0 is a full back-substitution (delta is the exact solution of the system); "
    "'inf' means never relinearize. relinearized_k lists the variables moved at update k (sorted names)",
    "tree_edits": "which cliques an update removes and orphans, and the fill of R, depend on the order the removed "
    "part is eliminated in; the kit's is steam_ref's rule (GTSAM orders with CCOLAMD, so its trees can differ). "
    "(1) The list: the frontal variables of the removed cliques, clique by clique in the order they were removed, "
    "each clique's frontals in elimination order (that order is not sorted: 'sorted' in this kit applies to "
    "lists of cliques and of names, such as relinearized_k and update_k, never to the frontals inside a clique), "
    "then the update's new variables in the order its 'values' lists "
    "them. A clique is removed when first reached walking up to the root from the clique of each variable the "
    "update's factors name (in order of first appearance, factor by factor, keys in order), then from every "
    "clique holding a relinearized variable, as a frontal or in its separator (the clique where it is frontal and "
    "every clique below it holding it in its separator: their conditionals all used its old linearization "
    "point). (2) The graph: two variables are adjacent when one factor of the "
    "removed part (the factors eliminated in removed cliques, and the new ones) or one orphan's separator holds "
    "both. (3) Repeatedly eliminate the variable of least degree (its number of adjacent variables not yet "
    "eliminated; eliminating v makes all its neighbours adjacent: fill counts), taking the variables that no new "
    "factor names before any that one does; ties go to the variable earlier in the list of (1). (4) Cliques by the "
    "rule of 'cliques'; each orphan hangs under the new clique where the first variable of its separator (in "
    "elimination order) is frontal. nnz_k = sum over cliques of n_f (n_f + 1)/2 + n_f n_s (frontal and separator "
    "sizes): GTSAM's ISAM2::treeNnz. With relinearization, the relinearized variables are taken in the order "
    "steam_ref's back-substitution found them over beta: those cases pin steam_ref's behaviour",
    "fixed_lag": "a stream's updates carry timestamps (seconds): an update may stamp any variable, a new one or a "
    "held one (the new time replaces the old; a landmark stamped with the time it was last seen is forgotten a lag "
    "after that, as steam_ref's streams do). After each update (its relinearization and solve, as 'incremental'), "
    "every timed variable with t < t_newest - lag (t_newest the latest timestamp so far) is marginalized: strictly "
    "less, so one with t = t_newest - lag exactly stays (GTSAM's rule); a variable never stamped never is. A "
    "marginalized variable given a value again (a landmark seen again) is a new variable: its old factors and "
    "estimate are gone, and what was learnt of it lives on only in the marginal factor. Marginalizing D: the "
    "factors adjacent to D (earlier marginal factors too), linearized at the current linearization points "
    "theta_bar, have information H = A^T A and vector g = A^T b over D and its separator S (the other variables of "
    "those factors); they are replaced by the marginal factor Lambda = H_SS - H_SD H_DD^-1 H_DS, eta = g_S - H_SD "
    "H_DD^-1 g_D (the Schur complement; unique, whatever the elimination order or the tree), i.e. 1/2 d^T Lambda d "
    "- eta^T d with d = theta_S - theta0_S, theta0_S = theta_bar_S at that moment. It is frozen there "
    "(first-estimate Jacobians): at a later linearization point theta_bar' it contributes Lambda and eta - Lambda "
    "(theta_bar'_S - theta0_S) to the system. Lambda is positive semi-definite and may be SINGULAR (README, "
    "'Fixed-lag smoothing'): store it as computed, or as any square root (the rows A_m of the QR of the dropped "
    "block, an LDL^T, an eigendecomposition), never by an unpivoted Cholesky factorization, and never invert it "
    "alone; the window's information, which adds the other factors, is positive definite. S and marginalized_k "
    "list names in the order of the stream's 'variables'; marginal_point_k is theta0_S stacked in that order. "
    "estimate_k is theta_bar + delta of every variable left after update k and its marginalization; covariances_k "
    "the diagonal blocks of the inverse of the window's information (the same before and after marginalizing)",
    "range_at_landmark": "a range evaluated with the robot's position exactly at the landmark (distance 0): the "
    "error is 0 - r (the distance has a value there), but the distance has no derivative (its slope is 1 in every "
    "direction), so H_k, and with them A_k, are zero rows by convention (gpslam's and STEAM's; steam_ref warns); "
    "b = -sqrt(w) W e as always. A bearing there has no value and is refused",
    "se2": "the se2 suite (kit v4) alone: tangent order [rho; phi] (translation, then angle); a state is "
    "[x, y, theta, vx, vy, w], a pose and its body twist; right retraction x + d = (T Exp(d[:3]), w + d[3:]), every "
    "Jacobian and covariance in that d; Log's angle in (-pi, pi], +pi at the half turn (a stored -pi gives +pi); "
    "headings of poses and states in (-pi, pi]; both WNOA residuals, 'local-variable' [xi - dt w1; J_r(xi)^-1 w2 - "
    "w1] and 'simplified' [xi - dt w1; w2 - w1], xi = Log(T1^-1 T2) (README 'SE(2)'). The 'state', 'jacobians' and "
    "'angles' conventions above are the vector-space suites'",
    "half_turn": "the se2 suite's Exp and Log (kit v5 names it): Log's angle and the heading of every pose Exp returns "
    "lie in (-pi, pi], and the double nearest pi, +-3.141592653589793, is the half turn, +pi (Exp([rho; "
    "-3.141592653589793]) has theta = +pi; Log of a pose stored with theta = -3.141592653589793 has phi = +pi and rho = "
    "V(pi)^-1 t). That double lies 1.2e-16 inside pi, so an implementation that reads angles as atan2(sin, cos) keeps "
    "its sign (gtsam.Pose2's Rot2: -3.141592653589793 stays negative); it declares so with the alternative "
    "'signed-half-turn'",
    "floats": "JSON numbers are the shortest decimal that reads back to the same IEEE-754 double "
    "(at most 17 significant digits, so reading with strtod is exact); no NaN or inf. "
    "Arrays are nested lists, row-major",
    "tolerance": "a numeric quantity passes when max|got - expected| <= atol + rtol * max|expected| over its entries "
    "(normwise; an object's leaves one by one); 'exact' quantities must be equal",
    "independent": "true: the expected values come from a computation that shares no code with steam_ref's (a dense "
    "oracle, complex-step derivatives, quadrature, or the authors' own saved runs); false: produced by "
    "steam_ref itself, to catch drift and to pin down choices the paper leaves open",
}

CONVENTION_ALTERNATIVES = {
    "paper-sign": "residual: the GP prior's error as written in [YIB Eq. 22], e = Phi x_{i-1} + v_i - x_i (the "
    "negative of the kit's); flips error, whitened_error, H_k, A_k and b of GP prior factors and the GP prior "
    "rows of A and b; measurement errors keep h(theta) - y",
    "symmetric-whitener": "whitening: W = Sigma^(-1/2), the symmetric positive-definite square root of the "
    "information (W = U W_kit for an orthogonal U): changes whitened_error, A_k, b, the gp W and the rows of A "
    "and b of factors with a non-diagonal Sigma",
    "paper-sign+symmetric-whitener": "both of the above",
    "signed-half-turn": "half_turn (kit v5): SE(2)'s angle at the half turn as atan2 computes it, +-3.141592653589793 "
    "keeping its sign (gtsam.Pose2's): Exp([rho; -3.141592653589793]) has theta = -3.141592653589793, a pose stored "
    "with theta = -3.141592653589793 logs to phi = -3.141592653589793 and rho = V(phi)^-1 t, one stored with "
    "+3.141592653589793 to +pi; changes exp, log_of_exp, log and exp_of_log of the se2 suite's Exp and Log cases "
    "(those rows; a case stores the whole quantity). It combines with no other alternative (no case depends on both)",
}

_DEPENDS = {
    "residual": {"error", "whitened_error", "H", "A", "b"},
    "whitening": {"whitened_error", "A", "b", "W"},
}


# Suite → convention → the quantities of the suite that depend on it (kit v5: the se2 suite's Exp and Log cases).
SUITE_CONVENTIONS = {"se2": {"half_turn": ("exp", "log", "log_of_exp", "exp_of_log")}}


def depends_on(suite: str, quantity: str) -> list[str]:
    """The conventions a quantity of a suite depends on ([] when invariant): 'residual', 'whitening', 'half_turn'."""
    named = [name for name, quantities in SUITE_CONVENTIONS.get(suite, {}).items() if quantity in quantities]
    if named:
        return named
    if suite not in ("gp", "factors", "linear"):
        return []
    base = quantity.split("_")[0] if quantity[:2] in ("H_", "A_") else quantity
    if suite == "gp":
        return ["whitening"] if base == "W" else []
    return [name for name, quantities in _DEPENDS.items() if base in quantities and base != "W"]


RESULTS_LAYOUT = (
    f'RESULTS_DIR/<suite>/results.json = {{"kit_version": {KIT_VERSION}, "cases": {{"<case name>": {{"<quantity>": '
    "value, ...}}}: the quantities of each case named as in its 'tolerance', values shaped as in its 'expected'; "
    "every case of every suite but paper (the data-free suites; paper too with check --paper) must have a result "
    "unless check is given --only SUITE... or --allow-missing; a check in which no case passed fails"
)

TREE_EDIT_EXAMPLE = """The stream of the incremental suite, relinearization off. After update 2 the tree is one clique
{x0, l0, x1}. Update 3 brings x2 and l1 (values listed x2, l1) and the factors gp_prior(x1, x2),
prior(l1), range(x2, l1), bearing(x2, l0).

(1) The factors name x1, x2, l1, l0 (first appearances). The clique of x1 is the root, so the
    removed part is that clique; the list is its frontals x0, l0, x1, then the new x2, l1:
    [x0, l0, x1, x2, l1]. No factor of the update names x0; every other variable is named.
(2) Adjacent: x0-l0, x0-x1, x1-l0 (the removed clique's factors), x1-x2, x2-l1, x2-l0 (the new ones).
(3) x0 goes first (the only variable no new factor names; eliminating it joins l0 and x1, already
    adjacent). Then the degrees are l0 2 (x1, x2), x1 2 (l0, x2), x2 3 (x1, l1, l0), l1 1 (x2): l1.
    Then l0, x1 and x2 all have degree 2: the tie goes to l0, earliest in the list; then x1, x2.
    Order: x0, l1, l0, x1, x2.
(4) Walking back: x2 starts the root; x1 (separator {x2}) and l0 (separator {x1, x2}) join it;
    l1 (separator {x2}) starts a child; x0 (separator {l0, x1}) starts another. The tree after
    update 3: root {l0, x1, x2}, children {l1 : x2} and {x0 : l0, x1}. With 6-dimensional states and
    2-dimensional landmarks, nnz_3 = 14·15/2 + (2·3/2 + 2·6) + (6·7/2 + 6·8) = 105 + 15 + 69 = 189.
"""
