"""The conventions the kit's numbers follow, written once: into ``index.json`` and the exported README."""

from __future__ import annotations

__all__ = ["CONVENTIONS", "RESULTS_LAYOUT", "EXPORT_README"]

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
    "whitened error W e, whitened Jacobian W H; for the GP prior Sigma = Q(dt)",
    "cost": "cost = 1/2 sum_i ||W_i e_i||^2 (the factor graph's negative log density up to a constant, [YIB Eq. 21]); "
    "a robust factor contributes rho(||W e||) instead; [YIB Eq. 6] writes the sum without the 1/2",
    "robust": "iteratively reweighted least squares as GTSAM's noiseModel::Robust: s = ||W e||, weight w = rho'(s)/s, "
    "linearized rows sqrt(w) W H and b = -sqrt(w) W e. Huber(k): rho = s^2/2 for s <= k, k s - k^2/2 beyond; "
    "w = 1, k/s. Tukey(c): rho = c^2/6 (1 - (1 - (s/c)^2)^3) for s <= c, c^2/6 beyond; w = (1 - (s/c)^2)^2, 0",
    "jacobians": "H_k = de/dx_k in the vector space of the variables (theta is a plain coordinate: no manifold); "
    "A_k = sqrt(w) W H_k; k counts the factor's keys in order",
    "angles": "bearing errors are wrapped to [-pi, pi); nothing else is wrapped (headings in states are continuous)",
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
    "incremental": "iSAM2 as GTSAM 4.3: new factors and values per update; relinearization "
    "(threshold beta on max |delta|, checked every relinearize_skip updates) happens at the start of an update "
    "with the previous delta; wildfire threshold 0 is a full back-substitution; 'inf' means never relinearize",
    "floats": "JSON numbers are the shortest decimal that reads back to the same IEEE-754 double "
    "(at most 17 significant digits, so reading with strtod is exact); no NaN or inf. "
    "Arrays are nested lists, row-major",
    "tolerance": "a numeric quantity passes when max|got - expected| <= atol + rtol * max|expected| over its entries "
    "(normwise; an object's leaves one by one); 'exact' quantities must be equal",
    "independent": "true: the expected values come from a computation that shares no code with steam_ref's (a dense "
    "oracle, complex-step derivatives, quadrature, or the authors' own saved runs); false: produced by "
    "steam_ref itself, to catch drift and to pin down choices the paper leaves open",
}

RESULTS_LAYOUT = (
    'RESULTS_DIR/<suite>/results.json = {"cases": {"<case name>": {"<quantity>": value, ...}, ...}}: '
    "the quantities of each case named as in its 'tolerance', values shaped as in its 'expected'"
)

EXPORT_README = """# steam_ref conformance kit, version {version}

Golden inputs and expected outputs for checking an implementation of "Incremental Sparse GP
Regression for Continuous-time Trajectory Estimation & Mapping" (Yan, Indelman, Boots) against
steam_ref. Any language that reads JSON can use it; `*/expected.npz` repeats the arrays for NumPy.

- `index.json`: kit version, what generated it, the conventions every number follows, the suites,
  which cases are independent of steam_ref, and the sha256 of every file.
- `<suite>/cases.json`: the suite's cases, each with `inputs`, `expected` (quantity -> value),
  `tolerance` (quantity -> {{atol, rtol}} or "exact"), `equation` ([YIB Eq. n]), `independent` and `source`.

To check your implementation, for every case you support read its `inputs`, compute each quantity
named in its `tolerance`, and write

    RESULTS_DIR/<suite>/results.json = {{"cases": {{"<case name>": {{"<quantity>": value, ...}}}}}}

with values shaped like `expected` (numbers, nested lists, objects). Then

    steam-ref conformance check RESULTS_DIR [--suite NAME]

prints one line per failing case (suite, case, quantity, worst difference against its tolerance)
and `N passed, N failed`; it exits 0 only when none failed. Cases you leave out are listed as not
run. docs/conformance.md in steam_ref explains the conventions and has minimal readers in C++,
Rust and JAX.
"""
