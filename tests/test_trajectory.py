"""Trajectory.at against the dense GP posterior: at a state, between states [YIB Eq. 18] and after the
last state (the prior's prediction); before the first state it is an error."""

import numpy as np
import pytest
from oracles import condition_gaussian, gp_kernel, gp_mean, random_spd

from steam_ref.errors import ClockError, SteamError
from steam_ref.gp import LinearSDE
from steam_ref.trajectory import Trajectory
from steam_ref.variables import X

POSE_TIMES = np.array([0.0, 0.5, 1.1, 1.6, 2.4, 3.0, 3.3, 4.1])
STATES = [0, 2, 3, 5]  # poses 1 and 4 lie between states, 6 and 7 after the last one


class DenseSolver:
    """A stand-in for a solver: the dense posterior of the states, read the way Trajectory reads a solver."""

    def __init__(self, mean: dict, cov: np.ndarray, index: dict):
        self.mean, self.cov, self.index = mean, cov, index  # key → (6,); dense cov; key → its rows

    def estimate_of(self, key):
        return self.mean[key]

    def estimate(self):
        return dict(self.mean)

    def joint_covariance(self, keys):
        rows = np.concatenate([self.index[k] for k in keys])
        return self.cov[np.ix_(rows, rows)]


@pytest.fixture(scope="module")
def dense():
    """The WNOA GP over the pose times and extra query times, conditioned on linear measurements of the states."""
    rng = np.random.default_rng(2024)  # module-scoped: the quadrature-built kernel is made once
    qc = random_spd(rng, 3)
    extra = np.array([0.8, 3.7, 6.0])
    all_times = np.union1d(POSE_TIMES, extra)
    sde = LinearSDE.wnoa(qc)  # the oracle reads only its A, F, Qc
    K, mu = gp_kernel(all_times, sde, random_spd(rng, 6)), gp_mean(all_times, sde, rng.normal(size=6))

    def rows(t):
        return int(np.searchsorted(all_times, t)) * 6 + np.arange(6)

    state_rows = np.concatenate([rows(POSE_TIMES[i]) for i in STATES])
    H = np.zeros((15, K.shape[0]))
    H[:, state_rows] = rng.normal(size=(15, state_rows.size))  # measurements of the states only
    post_mean, post_cov = condition_gaussian(mu, K, H, random_spd(rng, 15, scale=0.2), rng.normal(size=15))
    index = {X(i): rows(POSE_TIMES[i]) for i in STATES}
    solver = DenseSolver({k: post_mean[r] for k, r in index.items()}, post_cov, index)
    return qc, solver, lambda t: (post_mean[rows(t)], post_cov[np.ix_(rows(t), rows(t))])


@pytest.mark.parametrize("t", [1.1, 0.8, 2.4, 3.0, 3.3, 3.7, 4.1, 6.0])
def test_query_equals_dense_posterior(dense, t):
    qc, solver, posterior = dense
    mean, cov = Trajectory(solver, STATES, POSE_TIMES, qc).at(t, covariance=True)
    expected_mean, expected_cov = posterior(t)
    np.testing.assert_allclose(mean, expected_mean, rtol=1e-7, atol=1e-9 * np.abs(expected_mean).max())
    np.testing.assert_allclose(cov, expected_cov, rtol=1e-7, atol=1e-9 * np.abs(expected_cov).max())
    np.testing.assert_array_equal(Trajectory(solver, STATES, POSE_TIMES, qc).at(t), mean)


def test_covariance_grows_after_the_last_state(dense):
    """Prediction only adds process noise: Cov x(t) - Cov x(t_N) is positive definite in the velocity."""
    qc, solver, _ = dense
    traj = Trajectory(solver, STATES, POSE_TIMES, qc)
    _, c1 = traj.at(3.3, covariance=True)
    _, c2 = traj.at(6.0, covariance=True)
    assert np.all(np.linalg.eigvalsh(c2[3:, 3:] - c1[3:, 3:]) > 0)


def test_query_before_the_first_state_names_t_and_the_range(dense):
    qc, solver, _ = dense
    traj = Trajectory(solver, STATES[1:], POSE_TIMES, qc)  # first state at t = 1.1
    for t in (0.5, -3.0):  # a ClockError, as steam_ref.evaluate.states_at's: sr.ClockError catches either
        with pytest.raises(ClockError, match=rf"t={t}.*t >= 1\.1"):
            traj.at(t)
        with pytest.raises(ClockError, match=rf"t={t} is outside the estimated span \[1\.1, 3\]"):
            traj.neighbours(t)
    with pytest.raises(SteamError, match="no solved state yet"):
        Trajectory(solver, [], POSE_TIMES, qc).at(1.0)
    with pytest.raises(SteamError, match="t=nan"):
        traj.at(float("nan"))
