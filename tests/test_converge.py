"""converge.py: the batch optimum when a weak prior is all that fixes the map's orientation.

Oracles: dense linear algebra for Anderson acceleration; the cost's own invariance for the turn; and,
on Victoria Park's first 300 poses, descents from far-apart starts that must meet, against plain
Gauss-Newton, which does not get there."""

from __future__ import annotations

import numpy as np
import pytest
from requirements import optional_import

from steam_ref.batch import gauss_newton
from steam_ref.datasets import load_dataset
from steam_ref.errors import ConvergenceWarning, SteamError
from steam_ref.factors import GPPriorFactor, PriorFactor
from steam_ref.paper.converge import Anderson, anchored_factors, converge, rotated
from steam_ref.paper.online import StreamingEstimator, run_online
from steam_ref.paper.options import StreamOptions
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.problem import build_problem, converged_batch
from steam_ref.paper.readings import Readings
from steam_ref.paper.solvers import make_solver
from steam_ref.variables import X

VP = PaperSetup.victoria_park()
N = 300


@pytest.fixture(scope="module")
def prefix():
    optional_import("gtsam", "gtsam")  # Victoria Park ships in gtsam's Data/ folder
    readings = Readings.from_dataset(load_dataset("victoria-park"), VP).prefix(N)
    return readings, build_problem(readings, VP)


def _xy(values, states):
    return np.array([values[X(int(i))][:2] for i in states])


def test_anderson_solves_a_linear_fixed_point_in_n_plus_one_steps():
    """On x ← Mx + c, Anderson with memory ≥ n is GMRES on (I − M): exact after n + 1 steps, while the
    plain iteration (spectral radius 0.99) is still far."""
    rng = np.random.default_rng(4)
    n = 6
    Q = np.linalg.qr(rng.standard_normal((n, n)))[0]
    M = Q @ np.diag([0.99, 0.9, 0.5, -0.3, 0.2, 0.0]) @ Q.T
    c = rng.standard_normal(n)
    fixed = np.linalg.solve(np.eye(n) - M, c)
    mixer, x, plain = Anderson(n), np.zeros(n), np.zeros(n)
    for _ in range(n + 1):
        g = M @ x + c
        x = mixer.next(g, g - x)
        plain = M @ plain + c
    assert np.linalg.norm(x - fixed) < 1e-9 * np.linalg.norm(fixed)
    assert np.linalg.norm(plain - fixed) > 0.5 * np.linalg.norm(fixed)
    with pytest.raises(SteamError, match="memory"):
        Anderson(0)


def test_only_the_prior_on_pose_0_sees_the_turn(prefix):
    """Every factor but the prior on pose 0 keeps its cost when the map turns about the origin (Qc is
    the same in x and y); with Qc anisotropic in x, y the GP priors see it too."""
    readings, problem = prefix
    anchored = anchored_factors(problem.graph, problem.initial)
    assert len(anchored) == 1 and isinstance(anchored[0], PriorFactor) and anchored[0].keys == (X(0),)
    for angle in (0.3, -2.0):
        turned = rotated(problem.initial, angle)
        rest = [f for f in problem.graph if f is not anchored[0]]
        before = sum(np.sum(f.whitened_error(*[problem.initial[k] for k in f.keys]) ** 2) for f in rest)
        after = sum(np.sum(f.whitened_error(*[turned[k] for k in f.keys]) ** 2) for f in rest)
        assert after == pytest.approx(before, rel=1e-10)
    skewed = build_problem(readings.prefix(40), VP.replace(qc=0.01 * np.diag([1.0, 3.0, 2.0])))
    kinds = {type(f) for f in anchored_factors(skewed.graph, skewed.initial)}
    assert kinds == {PriorFactor, GPPriorFactor}


def test_gauss_newton_turns_the_map_back_by_the_fraction_of_derivations_9(prefix):
    """docs/derivations.md §9: one Gauss-Newton step from the optimum turned by 1e-3 rad goes back about
    (1/π²) / (Σ‖W e⊥‖² + 1/π²) of the way, Gauss-Newton's model curvature along the turn against the
    heading prior's; 'about' because other factors touch pose 0 (within a factor 1.5 on this prefix)."""
    _, problem = prefix
    best = converged_batch(problem).values
    curvature = 0.0
    for f in problem.graph:
        if isinstance(f, GPPriorFactor):
            e = f.error(*[best[k] for k in f.keys])
            turned = e.copy()
            turned[0::3], turned[1::3] = -e[1::3], e[0::3]  # every [x, y] pair turned by 90°
            curvature += float(np.sum((f.sqrt_information @ turned) ** 2))
    predicted = (1 / np.pi**2) / (curvature + 1 / np.pi**2)
    phi = 1e-3
    start = rotated(best, phi)
    step = gauss_newton(
        problem.graph,
        start,
        max_iterations=1,
        relative_tolerance=0,
        absolute_tolerance=0,
        step_tolerance=0,
        check=False,
    ).values
    back = -np.mean([step[X(int(i))][2] - start[X(int(i))][2] for i in problem.states]) / phi
    assert predicted < 2e-3 and predicted / 1.5 < back < predicted * 1.5


def test_descents_from_starts_half_a_radian_apart_meet(prefix):
    """From the sequential batch and from its estimate turned by 0.5 rad, converge ends at one minimum
    (stationary by the batch's check) within 0.1 mm at every pose; plain Gauss-Newton from the turned
    start stops, by its rule on the cost, metres away."""
    _, problem = prefix
    best = converged_batch(problem)
    assert best.converged, best.reason
    start = rotated(best.values, 0.5)
    again = converge(problem.graph, start)
    assert again.converged, again.reason
    states = problem.states
    np.testing.assert_allclose(_xy(again.values, states), _xy(best.values, states), rtol=0, atol=1e-4)
    plain = gauss_newton(problem.graph, start, check=False)
    assert np.max(np.hypot(*(_xy(plain.values, states) - _xy(best.values, states)).T)) > 1.0
    for angle in (-1e-3, 1e-3):  # and the minimum is one along the turn
        assert problem.graph.error(rotated(again.values, angle)) > again.cost


def test_converge_at_end_gives_the_stream_the_batch_optimum(prefix):
    """BTGP/10 with the scripts' iSAM2 ends metres from the optimum on 300 poses; with converge_at_end its
    estimate (from a solver rebuilt at the optimum) is the optimum to 0.1 mm, and the run says so."""
    readings, problem = prefix
    best = converged_batch(problem)
    plain = run_online(readings, VP)
    done = run_online(readings, VP, StreamOptions(converge_at_end=True))
    states = problem.states
    far = np.hypot(*(plain.trajectory[states, :2] - _xy(best.values, states)).T)
    near = np.hypot(*(done.trajectory[states, :2] - _xy(best.values, states)).T)
    assert np.median(far) > 0.1 and np.max(near) < 1e-4
    row = done.summary("victoria-park")
    assert row["converged_at_end"] is True and 0 < row["convergence_s"] <= row["total_s"]
    assert "converged_at_end" not in plain.summary("victoria-park")


def test_a_descent_cut_short_is_not_converged_and_the_stream_says_so(prefix, monkeypatch):
    """One iteration from a start 0.5 rad away is not a minimum: ``converged`` is False with the reason,
    and a stream whose convergence fails warns and reports ``converged_at_end: false``."""
    readings, problem = prefix
    short = converge(problem.graph, rotated(problem.initial, 0.5), max_iterations=1)
    assert not short.converged and "max_iterations" in short.reason
    monkeypatch.setattr(
        "steam_ref.paper.online.converge", lambda graph, values: converge(graph, rotated(values, 0.5), max_iterations=1)
    )
    with pytest.warns(ConvergenceWarning, match="converge_at_end: max_iterations"):
        done = run_online(readings.prefix(60), VP, converge_at_end=True)
    assert done.converged_at_end is False and done.summary()["converged_at_end"] is False


def test_a_run_cut_short_before_the_end_reports_no_convergence(prefix):
    """converge_at_end runs after the last pose only: a run the time budget stops says it did not run
    (``converged_at_end: None``), not that it converged; and a solver passed in cannot be finished."""
    readings, _ = prefix
    cut = run_online(readings, VP, converge_at_end=True, time_budget_s=1e-9)
    assert not cut.completed and cut.converged_at_end is None
    assert cut.summary()["converged_at_end"] is None and cut.summary()["convergence_s"] is None
    with pytest.raises(SteamError, match="converge_at_end rebuilds"):
        StreamingEstimator(readings, VP, StreamOptions(converge_at_end=True), solver=make_solver("btgp"))


def test_bad_options_are_named(prefix):
    _, problem = prefix
    for bad in ({"step_tolerance": 0.0}, {"step_tolerance": float("nan")}, {"max_iterations": 0}, {"memory": 1.5}):
        with pytest.raises(SteamError, match=next(iter(bad))):
            converge(problem.graph, problem.initial, **bad)
    with pytest.raises(SteamError, match="converge_at_end"):
        StreamOptions(converge_at_end="yes")
