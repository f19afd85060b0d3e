"""The WNOJ and Singer priors through the whole pipeline: front end, batch, BTGP, time queries."""

from __future__ import annotations

import numpy as np
import pytest
from oracles import gp_kernel

from steam_ref.batch import gauss_newton
from steam_ref.bayes_tree import ISAM2Params
from steam_ref.datasets import generate_synthetic
from steam_ref.errors import SteamError
from steam_ref.gp import LinearSDE
from steam_ref.motion import VectorPrior
from steam_ref.paper.online import StreamingEstimator
from steam_ref.paper.options import StreamOptions
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.problem import build_problem
from steam_ref.paper.readings import Readings
from steam_ref.variables import X

SETUPS = {p: PaperSetup.synthetic().replace(prior=p, singer_time_constant=2.0) for p in ("wnoj", "singer")}


@pytest.fixture(scope="module")
def data():
    return generate_synthetic(n_steps=30, n_landmarks=6, seed=5, range_sigma=0.3)


def stream(data, setup, **options):
    est = StreamingEstimator(Readings.from_dataset(data, setup), setup, StreamOptions(**options))
    while not est.done:
        est.step()
    return est


@pytest.mark.parametrize("prior", sorted(SETUPS))
def test_the_batch_problem_has_nine_number_states_and_the_priors_factors(data, prior):
    setup = SETUPS[prior]
    problem = build_problem(data, setup, skip=3)
    assert {problem.initial.dim(k) for k in problem.initial.states()} == {9}
    assert all(problem.initial[k][6:].tolist() == [0.0, 0.0, 0.0] for k in problem.initial.states())
    gp = [f for f in problem.graph if type(f).__name__ == "GPPriorFactor"]
    a, b = gp[0].keys
    dt = problem.model_times[b.index] - problem.model_times[a.index]
    K = gp_kernel(np.array([0.0, dt]), setup.motion_prior().sde, 1e-300 * np.eye(9))  # quadrature oracle
    W = gp[0].sqrt_information
    np.testing.assert_allclose(W.T @ W, np.linalg.inv(K[9:, 9:]), rtol=1e-7)
    result = gauss_newton(problem.graph, problem.initial)
    assert result.converged, result.reason


@pytest.mark.parametrize("prior", sorted(SETUPS))
def test_btgp_with_zero_thresholds_reaches_the_batch_optimum(data, prior):
    setup = SETUPS[prior]
    params = ISAM2Params(relinearize_threshold=0.0, relinearize_skip=1, wildfire_threshold=0.0)
    bt = stream(data, setup.with_schedule(final_updates=40).replace(isam2=params), method="btgp", skip=3)
    problem = build_problem(data, setup, skip=3)
    optimum = gauss_newton(problem.graph, bt.solver.estimate(), relative_tolerance=1e-14, step_tolerance=0.0).values
    for k in optimum:
        np.testing.assert_allclose(bt.solver.estimate_of(k), optimum[k], rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("prior", sorted(SETUPS))
def test_time_queries_use_the_setups_prior(data, prior):
    setup = SETUPS[prior]
    est = stream(data, setup, method="pb", skip=3)
    traj = est.solved()
    a, b = est.states[1], est.states[2]
    t = 0.5 * (est.readings.model_times[a] + est.readings.model_times[b])
    xa, xb = est.solver.estimate_of(X(a)), est.solver.estimate_of(X(b))
    ta, tb = est.readings.model_times[a], est.readings.model_times[b]
    K = gp_kernel(np.array([ta, t, tb]), setup.motion_prior().sde, np.eye(9))  # the dense GP, zero mean
    ends, mid = np.r_[0:9, 18:27], np.arange(9, 18)
    expected = K[np.ix_(mid, ends)] @ np.linalg.solve(K[np.ix_(ends, ends)], np.r_[xa, xb])
    at = float(est.readings.clock.to_seconds(t))  # a query is in the data's seconds; the GP runs on the model's time
    np.testing.assert_allclose(traj.at(at), expected, rtol=1e-7, atol=1e-9)
    assert traj.at_every_pose()[1].shape[1] == 9


def test_relinearization_blocks_follow_the_state():
    assert SETUPS["wnoj"].isam2_params().relinearize_blocks == {"x": (3, 3, 3)}
    assert PaperSetup.synthetic().isam2_params().relinearize_blocks == {"x": (3, 3)}


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        (dict(prior="cv"), "prior must be one of"),
        (dict(prior="singer", singer_time_constant=0.0), "time_constant"),
        (dict(prior="singer", singer_time_constant=float("nan")), "time_constant"),
    ],
)
def test_bad_prior_settings_are_named(changes, message):
    with pytest.raises(SteamError, match=message):
        PaperSetup.synthetic().replace(**changes)


def test_singer_setup_is_the_singer_sde():
    prior = SETUPS["singer"].motion_prior()
    sde = prior.sde
    assert isinstance(prior, VectorPrior) and prior.name == "singer" and prior.state_dim == 9
    assert isinstance(sde, LinearSDE) and sde.n == 9
    np.testing.assert_allclose(np.asarray(sde.A)[6:, 6:], -0.5 * np.eye(3))  # α = 1 / time constant
