"""The exported kit's README: everything an implementer needs, without steam_ref's docs.

``steam-ref conformance export DIR`` writes it beside the kit: the files, how to write results and
check them, every convention (with the alternatives ``check --conventions`` accepts), the inputs of
each suite, every factor's error, Jacobian convention, inputs and outputs, the tree-edit ordering
rule with a worked example, and the paper suite's set-up and procedure.
"""

from __future__ import annotations

from .conventions import CONVENTION_ALTERNATIVES, CONVENTIONS, RESULTS_LAYOUT, TREE_EDIT_EXAMPLE
from .kitio import KIT_VERSION, SUITES
from .paper_spec import PROCEDURE, SETUP_FIELDS

__all__ = ["export_readme", "FACTOR_TABLE", "QUANTITIES", "SUITE_INPUTS"]

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
    ("range", "x, l", "measured r, noise", "sqrt((lx - x)^2 + (ly - y)^2) - r [YIB Eq. 33]"),
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
    "H_k = de/dx_k (m, n_k) for each key k in order, in the vector space of the variables; A_k = sqrt(w) W H_k; "
    "b = -sqrt(w) W e; cost = 1/2 ||W e||^2 or rho(||W e||); weight w = rho'(s)/s (robust factors only)",
    "gp": "Phi, Q, Qinv, W (W^T W = Q^-1, upper), v_i; Lambda, Psi, x_tau; cov_tau; x_t, cov_t (prediction)",
    "linear": "A (rows in factor order, columns in the ordering), b, information = A^T A, rhs = A^T b, R, d, delta",
    "batch": "iterates: key -> (iterations + 1, n) every iterate from the start; costs (iterations + 1,)",
    "bayes_tree": "cliques: [{frontals, separator, parent}] (unordered list; parent named by its first frontal, "
    "null for a root); conditionals: first frontal -> {R, S, d}; covariances: 'k1,k2' -> joint block",
    "incremental": "estimate_k: key -> vector after update k; relinearized_k: sorted names moved at update k; "
    "update_k: {removed, orphans} (each clique named by its frontals, sorted); nnz_k: the fill of R",
    "fixed_lag": "for each update k: marginalized_k (names, in the order of 'variables'); when any, separator_k "
    "(names, same order), marginal_point_k (theta0 of the separator, stacked), marginal_information_k (Lambda) and "
    "marginal_vector_k (eta) over the separator stacked in that order; estimate_k: key -> vector of the window; "
    "covariances_k: key -> its marginal covariance (conventions, fixed_lag)",
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
    "fixed_lag": "stream = {variables, updates: [{values (new variables only), timestamps (new variable -> "
    "seconds; landmarks have none), factors (new ones)}]}, lag (seconds) and isam2 as for incremental",
    "paper": "dataset, file and sha256 of the paper's data file, the authors' run, method, every, setup (fields "
    "below), setup_fields and procedure (the texts below), state_poses (the poses whose states are compared)",
}


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
NumPy. This README is self-contained: nothing else is needed to implement the cases.

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

    steam-ref conformance check RESULTS_DIR [--only SUITE...] [--allow-missing] [--conventions NAME...]

A numeric quantity passes when max|got - expected| <= atol + rtol * max|expected| over its entries;
an exact one must be equal (lists of cliques unordered). Every failing quantity is printed with its
worst entries (index, expected, got); the first failing quantity in computation order is flagged as
the likely cause; a structure that differs is printed item by item. Exit 0: every case of the kit
(or of the suites `--only` names) passed; 1: a case failed or has no result (unless
`--allow-missing`); 2: bad input (a malformed file, names one line).

## Conventions

{_bullets(CONVENTIONS.items())}

Alternatives that `check --conventions NAME...` accepts for the quantities that depend on them:

{_bullets(CONVENTION_ALTERNATIVES.items())}

## Inputs

{_bullets(SUITE_INPUTS.items())}

Keys: 'x<i>' is trajectory state i (6 numbers, [x, y, theta, x_dot, y_dot, theta_dot]), 'l<j>' landmark j
([x, y]). Noise is `sigma` (scalar), `sigmas` (one per error entry, Sigma = diag(sigmas^2)) or `covariance`
(a matrix); a measurement may carry `loss`: {{"type": "huber", "k": k}} or {{"type": "tukey", "c": c}}.

## Factors

| type | keys | fields | error e |
|---|---|---|---|
{factors}

Jacobians H_k = de/dx_k are taken in the vector space of the variables (theta a plain coordinate, no
manifold), one block per key in the spec's key order; for `interpolated`, the chain rule through
Lambda, Psi. W is the upper-triangular square root of Sigma^-1 (conventions, whitening).

## Outputs

{_bullets(QUANTITIES.items())}

## The ordering rule for tree edits, with a worked example

{CONVENTIONS["tree_edits"]}

{TREE_EDIT_EXAMPLE}
## The paper suite: set-up and procedure

Fields of `setup`:

{_bullets(SETUP_FIELDS.items())}

The run (BTGP/1):

{procedure}
"""
