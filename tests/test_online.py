"""The streaming front end: the same stream gives the batch answer, interpolation and schedules
behave, and the time query is Eq. 18 and the dense GP posterior."""

from __future__ import annotations

import itertools
from types import SimpleNamespace

import numpy as np
import pytest

import steam_ref.paper.online as online
import steam_ref.paper.solvers as online_solvers
from steam_ref.batch import gauss_newton
from steam_ref.bayes_tree import ISAM2Params
from steam_ref.bayes_tree.dot import tree_nnz
from steam_ref.covariance import sparse_joint_covariance as joint_covariance
from steam_ref.datasets import generate_synthetic
from steam_ref.errors import SteamError
from steam_ref.factors import GPPriorFactor, InterpolatedFactor, RangeFactor, VelocityFactor
from steam_ref.gp.interpolate import interpolate_covariance, interpolation_matrices
from steam_ref.graph import FactorGraph
from steam_ref.paper.frontend import Layout
from steam_ref.paper.online import StreamingEstimator, run_online
from steam_ref.paper.options import StreamOptions
from steam_ref.paper.presets import PaperSetup, Schedule
from steam_ref.paper.problem import build_problem
from steam_ref.paper.readings import Readings
from steam_ref.variables import Values, X

SETUP = PaperSetup.synthetic()


@pytest.fixture(scope="module")
def data():
    return generate_synthetic(n_steps=40, n_landmarks=8, seed=3, range_sigma=0.3)


SCHEDULE_FIELDS = ("every", "start_after_ranges", "initial_batch", "final_updates")


def _stream(data, setup: PaperSetup = SETUP, **options) -> StreamingEstimator:
    """A whole stream; schedule fields and ``isam2`` go to the set-up (their one owner), the rest to StreamOptions."""
    schedule = {k: options.pop(k) for k in SCHEDULE_FIELDS if k in options}
    if schedule:
        setup = setup.with_schedule(**schedule)
    if "isam2" in options:
        setup = setup.replace(isam2=options.pop("isam2"))
    est = StreamingEstimator(Readings.from_dataset(data, setup), setup, StreamOptions(**options))
    while not est.done:
        est.step()
    return est


def _batch_optimum(data, skip: int, interpolate: bool) -> tuple[Values, np.ndarray]:
    """Gauss-Newton to convergence on build_problem's graph, started from a converged stream."""
    problem = build_problem(data, SETUP, skip=skip, interpolate=interpolate)
    warm = _stream(
        data, method="pb", skip=skip, interpolate=interpolate, pb_relative_tolerance=1e-12, final_updates=0
    ).solver.estimate()
    result = gauss_newton(problem.graph, warm, ordering="amd", relative_tolerance=1e-14, step_tolerance=1e-12)
    return result.values, problem.states


@pytest.mark.parametrize(
    ("skip", "interpolate", "range_states"),
    [(1, True, False), (3, True, False), (3, False, False), (5, False, True), (4, True, True)],
)
def test_the_solver_receives_every_factor_of_the_batch_problem(data, skip, interpolate, range_states):
    """Both come from the one front end; the run loop (schedule, pending factors, first solve) must hand
    the solver all of them: the solver's graph has the batch problem's cost at any point."""
    est = _stream(data, method="pb", skip=skip, interpolate=interpolate, range_states=range_states)
    problem = build_problem(data, SETUP, skip=skip, interpolate=interpolate, range_states=range_states)
    assert est.states.tolist() == problem.states.tolist()
    values = est.solver.estimate().copy()
    rng = np.random.default_rng(0)
    for k in values:
        values.insert(k, values[k] + 0.1 * rng.normal(size=values.dim(k)))
    assert len(est.solver.graph) == len(problem.graph)
    np.testing.assert_allclose(est.solver.graph.error(values), problem.graph.error(values), rtol=1e-12)


def test_pb_stream_reaches_the_batch_optimum(data):
    est = _stream(data, method="pb", skip=2, pb_relative_tolerance=1e-12, final_updates=3)
    optimum, states = _batch_optimum(data, 2, True)
    for i in states:
        np.testing.assert_allclose(est.solver.estimate_of(X(i)), optimum[X(i)], rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("every", [1, 10])
def test_btgp_with_zero_thresholds_equals_pb(data, every):
    """Same stream, thresholds 0: BTGP (after a few empty updates) and PB agree to ~1e-6.

    Gauss-Newton converges only linearly here (large residuals, and the Tukey weights are not
    differentiated), so a cost-based stopping rule ends ~1e-5 short: PB stops on its step norm
    instead, and BTGP gets 60 empty updates (each one Gauss-Newton step with these thresholds)."""
    common = dict(skip=2, every=every, final_updates=60)
    bt = _stream(
        data,
        method="btgp",
        isam2=ISAM2Params(relinearize_threshold=0.0, relinearize_skip=1, wildfire_threshold=0.0),
        **common,
    )
    pb = _stream(data, method="pb", pb_relative_tolerance=0.0, **common)
    assert bt.update_steps == pb.update_steps
    a, b = bt.solver.estimate(), pb.solver.estimate()
    assert set(a) == set(b)
    for k in a:
        np.testing.assert_allclose(a[k], b[k], rtol=1e-6, atol=1e-6)


def test_interpolation_off_drops_readings_between_states(data):
    on = _stream(data, method="pb", skip=4, interpolate=True)
    off = _stream(data, method="pb", skip=4, interpolate=False)
    interp = [f for f in on.solver.graph if isinstance(f, InterpolatedFactor)]
    assert not any(isinstance(f, InterpolatedFactor) for f in off.solver.graph)
    n_states = len(on.states)
    n_missing = on.n_poses - n_states
    # each missing pose has one velocity reading and (synthetic) one range reading
    assert len(interp) == 2 * n_missing
    assert {type(f.inner) for f in interp} == {VelocityFactor, RangeFactor}
    assert sum(isinstance(f, RangeFactor) for f in off.solver.graph) == n_states


def test_skip_and_range_states_choose_the_estimated_poses(data):
    est = _stream(data, method="pb", skip=7, range_states=False)
    n = est.n_poses
    assert est.states.tolist() == sorted(set(range(0, n, 7)) | {n - 1})
    readings = Readings.from_dataset(data, SETUP)
    thin = generate_synthetic(n_steps=40, n_landmarks=8, seed=3)
    with_ranges = _stream(thin, method="pb", skip=7, range_states=True)
    assert set(readings.range_pose.tolist()) <= set(with_ranges.states)


@pytest.mark.parametrize("every", [1, 3, 10])
def test_update_schedule_counts_range_readings(data, every):
    est = _stream(data, method="pb", every=every)
    n = est.n_poses
    ranges = Readings.from_dataset(data, SETUP).range_pose
    counts = np.array([np.count_nonzero(ranges <= i) for i in est.update_steps])
    assert est.update_steps[-1] == n - 1
    assert np.all(np.diff(counts[:-1]) == every)  # exactly `every` new ranges between updates
    assert counts[0] >= every


def test_the_schedule_is_the_set_ups(data):
    """One owner for a schedule: the set-up's, and the result reports the one that ran."""
    setup = SETUP.with_schedule(every=3)
    est = StreamingEstimator(Readings.from_dataset(data, setup), setup, StreamOptions(method="pb"))
    while not est.done:
        est.step()
    assert est.result().schedule.every == 3 and est.result().summary()["every"] == 3
    assert est.update_steps != _stream(data, method="pb", every=1).update_steps
    assert not hasattr(StreamOptions(), "every") and not hasattr(StreamOptions(), "isam2")


def test_an_initial_batch_runs_only_when_the_schedule_says_so(data, monkeypatch):
    """start_after_ranges defers the first update and nothing more; initial_batch is its own switch."""
    from steam_ref.paper import online

    calls = []
    real = online.levenberg_marquardt
    monkeypatch.setattr(online, "levenberg_marquardt", lambda *a, **k: calls.append(k) or real(*a, **k))
    _stream(data, method="pb", start_after_ranges=15)
    assert calls == []
    _stream(data, method="pb", start_after_ranges=15, initial_batch=True)
    assert calls == [dict(ordering="amd", relative_tolerance=1e-5, absolute_tolerance=1e-5)]
    assert PaperSetup.plaza().schedule.initial_batch and not PaperSetup.synthetic().schedule.initial_batch


def test_run_online_takes_readings_as_well_as_a_data_set(data):
    from_data = run_online(data, SETUP, method="pb")
    from_readings = run_online(Readings.from_dataset(data, SETUP), SETUP, method="pb")
    np.testing.assert_array_equal(from_readings.trajectory, from_data.trajectory)
    assert np.isnan(from_readings.rmse_m) and from_data.rmse_m < 0.5  # readings carry no ground truth
    with pytest.raises(SteamError, match="expected a RangeDataset or LandmarkDataset, got dict"):
        run_online({"poses": []}, SETUP)


def test_start_after_ranges_defers_the_first_update(data):
    est = _stream(data, method="pb", start_after_ranges=15)
    ranges = Readings.from_dataset(data, SETUP).range_pose
    first = est.update_steps[0]
    assert np.count_nonzero(ranges <= first) >= 15
    assert np.count_nonzero(ranges <= first - 1) < 15


def test_time_query_is_eq18_with_the_interpolated_covariance(data):
    est = _stream(data, method="pb", skip=4, pb_relative_tolerance=1e-12)
    values = est.solver.estimate()
    t1, t2, tau = 8.0, 12.0, 9.5
    lam, psi = interpolation_matrices(t1, t2, tau, SETUP.qc)
    mean, cov = est.estimate_at(_seconds(est, tau), covariance=True)
    np.testing.assert_allclose(mean, lam @ values[X(8)] + psi @ values[X(12)], rtol=1e-12, atol=1e-12)
    # oracle: dense inverse of the information matrix, joint block of the neighbours
    joint = _dense_joint(est.solver.graph, values, [X(8), X(12)])
    np.testing.assert_allclose(cov, interpolate_covariance(t1, t2, tau, SETUP.qc, joint), rtol=1e-8, atol=1e-12)
    mean8, cov8 = est.estimate_at(_seconds(est, 8.0), covariance=True)
    np.testing.assert_allclose(mean8, values[X(8)])
    np.testing.assert_allclose(cov8, _dense_joint(est.solver.graph, values, [X(8)]), rtol=1e-8, atol=1e-12)


def _seconds(est: StreamingEstimator, model_time: float) -> float:
    """The data's stamp [s] at a time on the prior's clock: a query is in seconds (the synthetic set starts at 1 s)."""
    return float(est.readings.clock.to_seconds(model_time))


def _dense_joint(graph: FactorGraph, values: Values, keys) -> np.ndarray:
    from steam_ref.linear.ordering import make_ordering
    from steam_ref.linear.system import LinearSystem

    order = make_ordering("xl", graph.keys(), values.dims(), [f.keys for f in graph])
    A, _ = LinearSystem.build(graph.factors, values, order).to_dense()
    cov = np.linalg.inv(A.T @ A)
    idx = np.concatenate([order.offset_of[k] + np.arange(6) for k in keys])
    return cov[np.ix_(idx, idx)]


def test_time_query_matches_the_dense_gp_posterior_with_a_linear_measurement():
    """With linear measurements only, Eq. 18 + the covariance are the exact GP posterior at τ:
    check against the same problem with the state at τ estimated explicitly."""
    from steam_ref.factors import GPPriorFactor, PriorFactor

    qc = SETUP.qc
    coarse = FactorGraph(
        [
            PriorFactor.create(X(0), np.zeros(6), 1.0),
            GPPriorFactor.wnoa(X(0), X(4), 4.0, qc),
            PriorFactor.create(X(4), np.arange(6.0), 0.5),
        ]
    )
    fine = FactorGraph(
        [
            PriorFactor.create(X(0), np.zeros(6), 1.0),
            GPPriorFactor.wnoa(X(0), X(1), 1.5, qc),
            GPPriorFactor.wnoa(X(1), X(4), 2.5, qc),
            PriorFactor.create(X(4), np.arange(6.0), 0.5),
        ]
    )
    v0 = Values({X(0): np.zeros(6), X(4): np.zeros(6)})
    sol = gauss_newton(coarse, v0).values
    joint = joint_covariance(coarse.factors, sol, [X(0), X(4)])
    lam, psi = interpolation_matrices(0.0, 4.0, 1.5, qc)
    fsol = gauss_newton(fine, Values({**dict(v0.items()), X(1): np.zeros(6)})).values
    np.testing.assert_allclose(lam @ sol[X(0)] + psi @ sol[X(4)], fsol[X(1)], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(
        interpolate_covariance(0.0, 4.0, 1.5, qc, joint),
        joint_covariance(fine.factors, fsol, [X(1)]),
        rtol=1e-7,
        atol=1e-10,
    )


def test_run_result_figures(data):
    result = run_online(data, SETUP, StreamOptions(method="pbvr", skip=3))
    n = data.n_poses
    assert result.trajectory.shape == (n, 6) and len(result.times) == n
    assert result.n_states == len(range(0, n, 3)) + (0 if (n - 1) % 3 == 0 else 1)
    truth = data.ground_truth[:, 1:3]
    assert result.rmse_m == pytest.approx(np.sqrt(np.mean(np.sum((result.trajectory[:, :2] - truth) ** 2, axis=1))))
    assert result.rmse_m < 0.5  # the stream converges to a good estimate, far below dead reckoning's
    assert len(result.step_seconds) == n and np.all(np.diff(result.cumulative_s) >= 0)
    assert set(result.landmarks) == set(np.unique(data.ranges[:, 2]).astype(int))
    assert result.completed


def test_time_budget_stops_early_and_says_so(monkeypatch):
    """The run's clock is replaced by one that advances 0.1 s per reading of it, so each pose "takes" a
    known time whatever the machine's load: the run must stop after the first pose that takes the total
    past the budget, and not before."""
    ticks = itertools.count()
    monkeypatch.setattr(online, "time", SimpleNamespace(perf_counter=lambda: 0.1 * next(ticks)))
    data = generate_synthetic(n_steps=300, n_landmarks=30, seed=1)
    result = run_online(data, SETUP, StreamOptions(method="pb", time_budget_s=0.95))
    assert not result.completed
    spent = np.cumsum(result.step_seconds)
    assert len(spent) == result.n_steps_processed < data.n_poses
    assert spent[-1] > 0.95 and (len(spent) == 1 or spent[-2] <= 0.95)  # stopped at the first pose past it
    assert np.all(result.step_seconds >= 0.1 - 1e-12)  # each pose read the fake clock at least twice
    assert len(result.times) <= result.n_steps_processed


def test_bad_options_raise_steam_errors():
    with pytest.raises(SteamError, match="skip"):
        StreamOptions(skip=0)
    with pytest.raises(SteamError, match="'nope'"):
        StreamOptions(method="nope")
    with pytest.raises(SteamError, match=r"Schedule.every.*2\.5"):
        Schedule(every=2.5)
    with pytest.raises(SteamError, match="initial_batch"):
        Schedule(initial_batch=1)
    with pytest.raises(SteamError, match="Schedule has no field 'evrey'"):
        Schedule().replace(evrey=2)


def test_query_before_the_first_state_names_the_time_and_the_range(data):
    est = _stream(data, method="pb", max_poses=10)
    assert data.times[0] == 1.0  # the first state's stamp
    with pytest.raises(SteamError, match=r"t=-1.5.*t >= 1\b"):
        est.estimate_at(-1.5)


def test_query_after_the_last_state_is_a_state_with_only_its_gp_prior(data):
    """Oracle: add an explicit state at t > t_N joined to x_N by the GP prior factor alone and solve the
    whole problem again; its estimate and marginal are what estimate_at predicts."""
    est = _stream(data, method="pb", max_poses=10, pb_relative_tolerance=1e-12)
    assert est.states[-1] == 9
    t, new = 11.7, X(1000)
    graph = FactorGraph(list(est.solver.graph.factors) + [GPPriorFactor.wnoa(X(9), new, t - 9.0, SETUP.qc)])
    start = est.solver.estimate().copy()
    start.insert(new, np.zeros(6))
    sol = gauss_newton(graph, start, ordering="amd", relative_tolerance=1e-14, step_tolerance=1e-12).values
    mean, cov = est.estimate_at(_seconds(est, t), covariance=True)
    np.testing.assert_allclose(mean, sol[new], rtol=1e-8, atol=1e-8)
    np.testing.assert_allclose(cov, _dense_joint(graph, sol, [new]), rtol=1e-6, atol=1e-10)


def test_btgp_time_query_covariance_matches_the_sparse_solve(data):
    """BTGP's joint covariance (from the tree) equals a sparse solve of all its factors at θ̄."""
    est = _stream(data, method="btgp", skip=4)
    inner = est.solver.inner
    keys = [X(8), X(12)]
    reference = joint_covariance(list(inner.factors), inner.linearization_point, keys)
    np.testing.assert_allclose(est.solver.joint_covariance(keys), reference, rtol=1e-8, atol=1e-12)
    _, cov = est.estimate_at(_seconds(est, 9.5), covariance=True)
    np.testing.assert_allclose(cov, interpolate_covariance(8.0, 12.0, 9.5, SETUP.qc, reference), rtol=1e-8, atol=1e-12)


@pytest.mark.parametrize("skip", [1, 2, 5, 7])
def test_estimated_poses_follow_the_papers_rule(rng, skip):
    """Pose 0, the last pose and every range pose are states; consecutive states are at most skip
    apart, and a state that is none of those comes exactly skip after the previous one."""
    n = 60
    range_poses = np.unique(rng.integers(1, n, size=12))
    states = Layout(skip, range_states=True).state_poses(n, range_poses)
    assert states[0] == 0 and states[-1] == n - 1
    assert set(range_poses.tolist()) <= set(states.tolist())
    gaps = np.diff(states)
    assert np.all((gaps >= 1) & (gaps <= skip))
    forced = set(range_poses.tolist()) | {n - 1}
    assert all(gap == skip for s, gap in zip(states[1:], gaps, strict=True) if s not in forced)
    # no range poses: plain every-skip-th pose, the time-step difference of Fig. 3/4
    np.testing.assert_array_equal(Layout(skip).state_poses(n), sorted(set(range(0, n, skip)) | {n - 1}))


def test_layout_rejects_a_bad_skip():
    for bad in (0, -2, 1.5, True):
        with pytest.raises(SteamError, match="skip"):
            Layout(bad)


def test_pose_0_goes_to_the_solver_with_pose_1(data):
    """As in the scripts, whose loop runs over odometry rows: no update at pose 0, even with a range there."""
    est = _stream(data, method="pb")
    assert Readings.from_dataset(data, SETUP).range_pose[0] == 0
    assert est.update_steps[0] == 1
    assert est.solver.iterations and len(est.update_steps) == data.n_poses - 1


def test_schedule_updates_at_states_after_every_ranges_and_at_the_last_pose():
    """The rule of online.ScheduleClock, step by step: (pose, is_state, ranges) → update?"""
    from steam_ref.paper.frontend import NewStep
    from steam_ref.paper.online import ScheduleClock

    schedule = ScheduleClock(Schedule(every=2, start_after_ranges=3), last_pose=9)
    steps = [
        (0, True, 1, False),
        (1, True, 1, False),
        (2, False, 1, False),
        (3, True, 0, True),
        (4, True, 1, False),
        (5, True, 1, True),
        (6, False, 5, False),
        (7, True, 0, True),
        (9, True, 0, True),
    ]
    for pose, is_state, n_readings, expected in steps:
        due = schedule.due(NewStep(pose, is_state, [], {}, n_readings))
        assert due == expected, pose
        if due:
            schedule.updated()
    assert schedule.released == 10


def test_bad_stream_inputs_raise_steam_errors(data):
    from steam_ref.paper.frontend import FrontEnd
    from steam_ref.paper.solvers import make_solver

    for bad, needle in [
        (dict(max_poses="10"), "max_poses"),
        (dict(max_poses=2.5), "max_poses"),
    ]:
        with pytest.raises(SteamError, match=needle):
            StreamOptions(**bad)
    for bad, needle in [
        (dict(final_updates=-3), "final_updates"),
        (dict(start_after_ranges="1"), "start_after_ranges"),
    ]:
        with pytest.raises(SteamError, match=needle):
            Schedule(**bad)
    with pytest.raises(SteamError, match=r"PaperSetup\.isam2 must be an ISAM2Params"):
        SETUP.replace(isam2={})
    readings = Readings.from_dataset(data, SETUP)
    for n in (0, -1, "x"):
        with pytest.raises(SteamError, match="n_poses"):
            FrontEnd(readings, SETUP, Layout(), n)
    for skip in (None, "a", 2.5):
        with pytest.raises(SteamError, match="skip"):
            Layout(skip)
    with pytest.raises(SteamError, match="range poses"):
        Layout().state_poses(5, [7])
    with pytest.raises(SteamError, match="'bogus'"):
        make_solver("bogus")


@pytest.mark.parametrize("method", ["pb", "pbvr", "btgp"])
def test_every_solver_answers_the_same_four_covariance_queries(data, method):
    """One vocabulary on every solver (GTSAM's marginalCovariance / jointMarginalCovariance): the four
    queries agree with a sparse solve of the solver's own factors at its linearization point."""
    solver = _stream(data, method=method, skip=4, max_poses=20).solver
    if method == "btgp":
        factors, point = list(solver.inner.factors), solver.inner.linearization_point
    else:
        factors, point = solver.graph.factors, solver.values
    a, b = X(4), X(8)
    reference = joint_covariance(factors, point, [a, b])  # oracle: (Σdₖ, Σdₖ) block of 𝓘⁻¹
    tol = dict(rtol=1e-8, atol=1e-12 * np.abs(reference).max())
    np.testing.assert_allclose(solver.joint_covariance([a, b]), reference, **tol)
    joint_ab, joint_b = solver.joint_covariances([[a, b], [b]])
    np.testing.assert_allclose(joint_ab, reference, **tol)
    np.testing.assert_allclose(joint_b, reference[6:, 6:], **tol)
    np.testing.assert_allclose(solver.marginal_covariance(b), reference[6:, 6:], **tol)
    np.testing.assert_allclose(solver.marginal_covariances([a, b])[a], reference[:6, :6], **tol)
    for owner in [solver] + ([solver.inner] if method == "btgp" else []):
        for old in ("marginals", "joint_marginals", "joint_marginal_covariance"):
            assert not hasattr(owner, old), (owner, old)  # renamed, no alias left behind


@pytest.mark.parametrize("method", ["pb", "pbvr", "btgp"])
def test_a_solver_that_forgets_nothing_answers_the_run_loops_questions_so(data, method):
    """The questions the run loop asks every solver: nothing forgotten, no window, no backward pass, and one
    past, the estimate, whichever is asked for."""
    solver = _stream(data, method=method, max_poses=20).solver
    assert list(solver.forgotten()) == [] and solver.n_marginalized is None and solver.peak_window is None
    assert solver.smoothing_seconds is None
    lagged, smoothed = solver.estimate(past="lagged"), solver.estimate(past="smoothed")
    assert list(smoothed) == list(lagged) and len(lagged) > 0
    for k in lagged:
        np.testing.assert_array_equal(smoothed[k], lagged[k])
        np.testing.assert_array_equal(solver.estimate_of(k, past="smoothed"), lagged[k])
    with pytest.raises(SteamError, match="past must be one of 'lagged', 'smoothed', got past='recent'"):
        solver.estimate_of(X(0), past="recent")
    with pytest.raises(SteamError, match="got past=None"):
        solver.estimate(past=None)


def test_a_btgp_stream_keeps_the_latest_reports_and_every_updates_figures(data, monkeypatch):
    # A long run kept every UpdateReport (11.5 MB on Plaza, each naming every variable it touched); now the latest
    # KEPT_REPORTS, with the fill after every update and the phase and clique totals kept as numbers.
    monkeypatch.setattr(online_solvers, "KEPT_REPORTS", 5)
    stream = StreamingEstimator(Readings.from_dataset(data, SETUP), SETUP, StreamOptions(method="btgp"))
    seen = []
    inner_update = stream.solver.inner.update
    monkeypatch.setattr(stream.solver.inner, "update", lambda *a, **k: seen.append(inner_update(*a, **k)) or seen[-1])
    while not stream.done:
        stream.step()
    solver = stream.solver
    assert len(seen) >= len(stream.update_steps) > 5 and solver.reports == seen[-5:]  # (and the final updates)
    assert solver.tree_nnz.tolist() == [r.tree_nnz for r in seen]
    assert solver.tree_nnz[-1] == tree_nnz(solver.inner.tree.cliques.values())  # counted again from the tree
    assert solver.clique_solves == sum(r.backsubstituted_cliques for r in seen)
    for phase in seen[0].timings:
        assert solver.phase_seconds[phase] == pytest.approx(sum(r.timings[phase] for r in seen), rel=1e-12)
