"""Never silently wrong: bad factors, overflow, ill-conditioning and false "converged" claims.

Each test builds one failing input found by the bad-input sweep and asserts the named error (or the honest result),
checked against dense linear algebra where a number is claimed.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp
from problems import small_problem

import steam_ref as sr
from steam_ref.batch import MAX_CONDITION, check_stationarity
from steam_ref.covariance import sparse_marginal_covariances
from steam_ref.linear import LinearSystem, Ordering, SparseCholesky
from steam_ref.linear.ordering import make_ordering

QC = np.diag([0.1, 0.2, 0.3])
BACKENDS = ["superlu", pytest.param("cholmod", marks=pytest.mark.needs_cholmod)]


def chain(rng, dt: float, n: int = 8):
    """GP states ``dt`` apart, a prior on the first, three landmarks seen by range from every other state."""
    keys = [sr.X(i) for i in range(n)]
    factors = sr.gp_prior_factors(keys, dt * np.arange(n), QC) + [sr.PriorFactor.create(keys[0], np.zeros(6), 0.1)]
    landmarks = {sr.L(j): rng.normal(size=2) * 5 for j in range(3)}
    for key, position in landmarks.items():
        factors.append(sr.PriorFactor.create(key, position, 0.5))
        factors += [
            sr.RangeFactor.create(k, key, abs(np.linalg.norm(position) + 0.05 * rng.normal()), 0.05) for k in keys[::2]
        ]
    initial = sr.Values({k: 0.3 * rng.normal(size=6) for k in keys} | {k: p + 0.1 for k, p in landmarks.items()})
    return sr.FactorGraph(factors), initial


def dense_scaled_condition(graph, values) -> float:
    """cond₁ of D^-½ 𝓘 D^-½ by dense inversion: the oracle for the solver's estimate."""
    system = LinearSystem.build(
        graph.factors, values, make_ordering("natural", graph.keys(), values.dims(), [f.keys for f in graph])
    )
    A, _ = system.to_dense()
    info = A.T @ A
    s = 1 / np.sqrt(np.diag(info))
    return float(np.linalg.cond(s[:, None] * info * s[None, :], 1))


# --- factors that name a variable twice ----------------------------------------------------------


def test_a_factor_naming_one_variable_twice_is_refused():
    with pytest.raises(sr.SteamError, match="names variable x2 twice"):
        sr.GPPriorFactor.wnoa(sr.X(2), sr.X(2), 1.0, QC)
    with pytest.raises(sr.SteamError, match="x1 is not a landmark key"):  # a neighbour state as its "landmark"
        sr.RangeFactor.create(sr.X(99), sr.X(1), 3.0, 0.5)
    inner = sr.RangeFactor.create(sr.X(-1), sr.L(1), 3.0, 0.5)
    with pytest.raises(sr.SteamError, match="names variable x1 twice"):
        sr.InterpolatedFactor.create(inner, sr.X(1), sr.X(1), 0.0, 1.0, 0.5, QC)
    with pytest.raises(sr.SteamError, match="not a variable key"):
        sr.PriorFactor.create(("x", 1), np.zeros(6), 1.0)


def test_noise_covariance_must_be_symmetric():
    cov = np.array([[1.0, 0.2], [0.3, 1.0]])
    with pytest.raises(sr.SteamError, match=r"not symmetric: entry \(0, 1\) = 0.2 but \(1, 0\) = 0.3"):
        sr.BearingRangeFactor.create(sr.X(0), sr.L(0), 0.1, 2.0, cov)
    symmetric = sr.BearingRangeFactor.create(sr.X(0), sr.L(0), 0.1, 2.0, np.array([[1.0, 0.2], [0.2, 1.0]]))
    W = symmetric.sqrt_information
    np.testing.assert_allclose(W.T @ W, np.linalg.inv([[1.0, 0.2], [0.2, 1.0]]), rtol=1e-12)


@pytest.mark.parametrize(
    "make",
    [
        lambda r: sr.RangeFactor.create(sr.X(0), sr.L(0), r, 0.5),
        lambda r: sr.BearingRangeFactor.create(sr.X(0), sr.L(0), 0.1, r, [0.1, 0.5]),
    ],
)
def test_negative_ranges_are_refused(make):
    with pytest.raises(sr.SteamError, match=r"cannot be negative, got (measured|range)=-0.5"):
        make(-0.5)
    assert make(0.0).measured[-1] == 0.0  # a zero range is a reading (the robot at the landmark)


# --- Values --------------------------------------------------------------------------------------


def test_values_refuse_what_they_would_otherwise_guess():
    with pytest.raises(sr.ShapeError, match=r"1-D vector, got shape \(2, 3\)"):
        sr.Values({sr.X(0): np.zeros((2, 3))})
    with pytest.raises(sr.ShapeError, match=r"got shape \(0,\)"):
        sr.Values({sr.X(0): []})
    with pytest.raises(sr.SteamError, match="two estimates of x0"):
        sr.Values([(sr.X(0), np.zeros(6)), (sr.X(0), np.ones(6))])
    with pytest.raises(sr.SteamError, match="'x0' is not a variable key"):
        sr.Values({"x0": np.zeros(6)})


# --- non-finite numbers ---------------------------------------------------------------------------


def overflowing_problem():
    """A range whose error overflows at the estimate (a reading of 1e200 m with sigma 1 is refused when made,
    since float64 cannot resolve it to its sigma: tests/test_bad_readings.py; an estimate at 1e308 m overflows)."""
    graph = sr.FactorGraph(
        [
            sr.PriorFactor.create(sr.X(0), np.zeros(6), 1.0),
            sr.RangeFactor.create(sr.X(0), sr.L(0), 1.0, 1.0),
            sr.PriorFactor.create(sr.L(0), np.ones(2), 1e150),  # weak: its information 1e-300 is still normal
        ]
    )
    return graph, sr.Values({sr.X(0): np.zeros(6), sr.L(0): np.full(2, 1e308)})


@pytest.mark.parametrize("method", [sr.gauss_newton, sr.levenberg_marquardt])
def test_an_overflowing_reading_is_named(method):
    graph, values = overflowing_problem()
    with pytest.raises(sr.NumericalError, match=r"factor 1 \(RangeFactor on x0, l0\) has a non-finite error"):
        method(graph, values)


def test_isam2_names_the_overflowing_factor_and_rolls_back():
    graph, values = overflowing_problem()
    solver = sr.IncrementalSolver()
    solver.update([graph[0]], sr.Values({sr.X(0): values[sr.X(0)]}))
    before = solver.estimate()[sr.X(0)].copy()
    with pytest.raises(sr.NumericalError, match="RangeFactor on x0, l0"):
        solver.update([graph[1], graph[2]], sr.Values({sr.L(0): values[sr.L(0)]}))
    assert set(solver.estimate()) == {sr.X(0)}
    np.testing.assert_array_equal(solver.estimate()[sr.X(0)], before)


# --- "converged" only where it holds --------------------------------------------------------------


@pytest.mark.parametrize("method", [sr.gauss_newton, sr.levenberg_marquardt])
def test_converged_is_checked_at_the_returned_estimate(rng, method):
    p = small_problem(rng, n_states=10, n_landmarks=3, interpolated=3, robust=False)
    result = method(p.graph, p.initial)
    assert result.converged, result.reason
    found = result.stationarity
    order = make_ordering("natural", p.graph.keys(), result.values.dims(), [f.keys for f in p.graph])
    A, b = LinearSystem.build(p.graph.factors, result.values, order).to_dense()
    g = A.T @ b  # the dense oracle of the check's numbers
    assert found.predicted_decrease == pytest.approx(0.5 * g @ np.linalg.solve(A.T @ A, g), rel=1e-6, abs=1e-15)
    assert found.predicted_decrease <= 1e-8 * found.cost
    assert found.gradient_norm == pytest.approx(np.max(np.abs(g)), rel=1e-6, abs=1e-15)
    assert found.cost == pytest.approx(result.cost, rel=1e-12)


def test_a_stopping_rule_alone_does_not_claim_convergence(rng):
    p = small_problem(rng, n_states=10, n_landmarks=3, robust=False)
    result = sr.gauss_newton(p.graph, p.initial, step_tolerance=1e6)  # stops after one step, wherever it is
    assert len(result.iterations) == 1 and "step norm" in result.reason
    assert not result.converged and "not a stationary point" in result.reason
    assert result.stationarity.predicted_decrease > 1e-8 * result.cost
    unchecked = sr.gauss_newton(p.graph, p.initial, check=False)
    assert not unchecked.converged and "not checked" in unchecked.reason
    with pytest.raises(sr.ConvergenceError, match="GN did not converge: step norm") as stopped:
        sr.batch_solve(p.graph, p.initial, step_tolerance=1e6)
    assert not isinstance(stopped.value, sr.NumericalError)  # nothing overflowed: it stopped short
    assert isinstance(stopped.value, sr.SteamError)


@pytest.mark.parametrize("dt", [1.0, 1e-2])
def test_condition_estimate_matches_the_dense_one(rng, dt):
    graph, values = chain(rng, dt)
    found = check_stationarity(
        graph, values, make_ordering("amd", graph.keys(), values.dims(), [f.keys for f in graph])
    )
    exact = dense_scaled_condition(graph, values)
    assert exact / 3 <= found.condition <= exact * (1 + 1e-9)  # Hager-Higham: a lower bound, rarely off by 3


def test_condition_grows_as_the_cube_of_the_inverse_gap(rng):
    conds = [dense_scaled_condition(*chain(np.random.default_rng(7), dt)) for dt in (1e-2, 1e-3)]
    assert 500 < conds[1] / conds[0] < 2000  # Δt⁻³: docs/derivations.md §8


@pytest.mark.parametrize("method", [sr.gauss_newton, sr.levenberg_marquardt])
def test_tiny_time_gaps_are_refused_not_claimed(rng, method):
    graph, values = chain(rng, 1e-4)
    with pytest.warns(sr.IllConditionedWarning, match="ill-conditioned"):
        result = method(graph, values)
    assert not result.converged
    assert result.stationarity.condition > MAX_CONDITION
    assert dense_scaled_condition(graph, result.values) > MAX_CONDITION  # the claim holds densely too
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", sr.IllConditionedWarning)
        with pytest.raises(sr.UnderdeterminedError, match="too ill-conditioned for float64"):
            method(*chain(rng, 1e-9))


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_positive_definite_matrix_with_a_wide_diagonal_is_factored(backend):
    """Scaling does not make a matrix singular: D 𝓜 D with 𝓜 well conditioned and D spanning 10¹⁶ is
    factored by either backend, and solves as the dense Cholesky does (SuperLU judged its pivots against
    the largest one, and refused it: the fallback install's suite was red on tiny time gaps)."""
    m = np.array([[4.0, 1.0, 0.5], [1.0, 3.0, 0.2], [0.5, 0.2, 2.0]])
    d = np.array([1e8, 1.0, 1e-8])
    info = d[:, None] * m * d[None, :]
    np.linalg.cholesky(info)  # the oracle: positive definite in float64
    order = Ordering((sr.X(0), sr.X(1), sr.X(2)), (1, 1, 1))
    factor = SparseCholesky.factor(sp.csc_matrix(info), order, backend)
    rhs = np.array([1.0, 2.0, 3.0])
    expected = np.linalg.solve(info, rhs)
    np.testing.assert_allclose(factor.solve(rhs), expected, rtol=1e-8)


def test_ci_runs_the_numerical_failures_under_both_backends():
    ci = (Path(__file__).resolve().parents[1] / ".ci" / "run").read_text()
    assert "STEAM_REF_SPARSE_BACKEND=superlu python3 -m pytest -q tests/test_numerical_failures.py" in ci


def test_well_spaced_states_still_converge(rng):
    graph, values = chain(rng, 1e-2)
    with warnings.catch_warnings():
        warnings.simplefilter("error", sr.IllConditionedWarning)
        result = sr.levenberg_marquardt(graph, values)
    assert result.converged and result.stationarity.condition < MAX_CONDITION


# --- singular systems name the free variable ------------------------------------------------------


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("ordering", ["xl", "amd", "natural"])
def test_a_landmark_seen_by_one_range_is_named(rng, backend, ordering):
    graph = sr.FactorGraph(sr.gp_prior_factors([sr.X(0), sr.X(1)], [0.0, 1.0], QC))
    graph.add(sr.PriorFactor.create(sr.X(0), np.zeros(6), np.ones(6)))
    graph.add(sr.RangeFactor.create(sr.X(1), sr.L(5), 3.0, 0.5))  # one range cannot fix a 2-D landmark
    values = sr.Values({sr.X(0): rng.normal(size=6), sr.X(1): rng.normal(size=6), sr.L(5): np.array([3.0, 1.0])})
    with pytest.raises(sr.UnderdeterminedError, match="variable l5"):
        sr.gauss_newton(graph, values, backend=backend, ordering=ordering)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("seed", range(8))
def test_a_landmark_seen_by_one_range_has_no_covariance(seed, backend):
    """Without its prior and with one range, a 2-D landmark is free along one direction: its covariance is
    infinite, so it is refused, not returned as whatever rounding left of the vanishing pivot (CHOLMOD
    took any positive pivot; on half of these seeds it returned a variance of ~1e15)."""
    p = small_problem(np.random.default_rng(seed), n_states=5, n_landmarks=2, robust=False)
    lonely = next(f for f in p.graph.factors if isinstance(f, sr.RangeFactor) and f.keys[1] == sr.L(1))
    factors = [f for f in p.graph.factors if sr.L(1) not in f.keys or f is lonely]  # its prior, other ranges gone
    with pytest.raises(sr.UnderdeterminedError, match="variable l1"):
        sparse_marginal_covariances(factors, p.initial, [sr.L(1)], backend=backend)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("seed", range(20))
def test_a_singular_information_matrix_is_refused_by_every_backend(seed, backend):
    """𝓘 = AᵀA with fewer rows than columns is singular by construction: rounding may leave a tiny positive
    pivot, which must not be taken for information (SuperLU's relative pivot test, now CHOLMOD's too)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 12))
    A = rng.normal(size=(n - 1, n)) * (rng.random((n - 1, n)) < 0.7)
    A[:, rng.integers(n)] *= 10.0 ** rng.integers(-4, 5)  # a column of another scale
    A[np.arange(n - 1), np.arange(n - 1)] += 1.0  # no zero diagonal: the failure is found by elimination
    assert np.linalg.matrix_rank(A) <= n - 1
    order = Ordering(tuple(sr.X(i) for i in range(n)), (1,) * n)
    with pytest.raises(sr.UnderdeterminedError, match=r"variable x\d+"):
        SparseCholesky.factor(sp.csc_matrix(A.T @ A), order, backend)


# --- arguments ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (dict(max_iterations=-1), "max_iterations must be an integer ≥ 0, got -1"),
        (dict(max_iterations=2.5), "max_iterations must be an integer ≥ 0, got 2.5"),
        (dict(max_iterations=True), "max_iterations must be an integer ≥ 0, got True"),
        (dict(relative_tolerance=float("nan")), "relative_tolerance must be a finite number ≥ 0, got nan"),
        (dict(absolute_tolerance=-1e-3), "absolute_tolerance must be a finite number ≥ 0, got -0.001"),
        (dict(step_tolerance="small"), "step_tolerance must be a finite number ≥ 0, got 'small'"),
    ],
)
@pytest.mark.parametrize("method", [sr.gauss_newton, sr.levenberg_marquardt])
def test_solver_options_are_checked(rng, method, options, message):
    p = small_problem(rng, n_states=4, n_landmarks=1)
    with pytest.raises(sr.SteamError, match=message):
        method(p.graph, p.initial, **options)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (dict(initial_damping=-1.0), "initial_damping must be a finite number ≥ 0, got -1.0"),
        (dict(initial_damping=0.0), "initial_damping must be > 0, got 0.0"),
        (dict(damping_factor=1.0), "damping_factor must be > 1, got 1.0"),
        (dict(max_damping=float("inf")), "max_damping must be a finite number ≥ 0, got inf"),
    ],
)
def test_damping_options_are_checked(rng, options, message):
    p = small_problem(rng, n_states=4, n_landmarks=1)
    with pytest.raises(sr.SteamError, match=message):
        sr.levenberg_marquardt(p.graph, p.initial, **options)


def test_an_empty_graph_and_an_unconstrained_value_are_named(rng):
    with pytest.raises(sr.SteamError, match="factor graph is empty"):
        sr.gauss_newton(sr.FactorGraph(), sr.Values())
    p = small_problem(rng, n_states=4, n_landmarks=1)
    extra = p.initial.copy()
    extra.insert(sr.L(42), np.zeros(2))
    with pytest.raises(sr.SteamError, match="l42 has an initial value but no factor names it"):
        sr.gauss_newton(p.graph, extra)
