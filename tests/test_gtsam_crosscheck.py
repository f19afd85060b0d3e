"""steam_ref against GTSAM, an independent implementation (the optional ``gtsam`` extra; CI requires it).

1. Batch: the paper's problem on a small generated data set is built twice: by ``build_problem``,
   and here, straight from the readings, as a GTSAM graph whose errors are written out in this file
   ([YIB Eq. 22, 29, 32-33]), with Φ, Q by quadrature, Λ and Ψ from the dense GP kernel, and
   Jacobians by central differences. Both optimizers must reach the same estimate and cost.
2. Incremental: one stream is fed both to our Bayes tree and to GTSAM's ISAM2 (each with
   relinearization of every variable at every update and full back-substitution); after every
   update the two estimates must agree.
"""

from __future__ import annotations

import itertools
import sys
from functools import partial
from pathlib import Path

import numpy as np
import pytest
from requirements import optional_import

gtsam = optional_import("gtsam", "gtsam")  # skips here, fails in CI (STEAM_REF_REQUIRE_OPTIONAL=1)

from finite_differences import numerical_jacobians  # noqa: E402
from oracles import gp_kernel, sde_process_noise, sde_transition  # noqa: E402

from steam_ref.batch import gauss_newton  # noqa: E402
from steam_ref.bayes_tree import ISAM2Params  # noqa: E402
from steam_ref.datasets import generate_synthetic  # noqa: E402
from steam_ref.gp import LinearSDE  # noqa: E402
from steam_ref.paper.online import StreamingEstimator  # noqa: E402
from steam_ref.paper.options import StreamOptions  # noqa: E402
from steam_ref.paper.presets import PaperSetup  # noqa: E402
from steam_ref.paper.problem import build_problem  # noqa: E402
from steam_ref.paper.readings import Readings  # noqa: E402
from steam_ref.paper.solvers import BayesTreeSolver  # noqa: E402
from steam_ref.variables import L, Values, X  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from gtsam_replica import custom_factor, gkey, isam2_params  # noqa: E402  (the one home of GTSAM replicas)

SETUP = PaperSetup.synthetic()
SKIP = 3


@pytest.fixture(scope="module")
def data():
    return generate_synthetic(n_steps=31, n_landmarks=6, seed=11, range_sigma=0.2)


# --- 1. batch, with the errors written out here --------------------------------------------------


def projected_velocity(x):
    """[cos θ ẋ + sin θ ẏ, -sin θ ẋ + cos θ ẏ, θ̇]: the body-frame velocity odometry measures."""
    c, s = np.cos(x[2]), np.sin(x[2])
    return np.array([c * x[3] + s * x[4], -s * x[3] + c * x[4], x[5]])


def gp_prior_error(phi, x1, x2):
    return x2 - phi @ x1  # [YIB Eq. 22], zero-mean prior


def velocity_error(measured, x):
    return projected_velocity(x) - measured


def range_error(measured, x, l):
    return np.atleast_1d(np.hypot(*(x[:2] - l)) - measured)  # [YIB Eq. 33]


def prior_error(mean, x):
    return x - mean


def interpolated(error, lam, psi, x1, x2, *rest):
    return error(lam @ x1 + psi @ x2, *rest)  # [YIB Eq. 18, 29]


def error_factor(noise, keys, error):
    """A GTSAM factor from an error function of vector variables; Jacobians by central differences."""

    def evaluate(this, values, H):
        xs = [values.atVector(k) for k in this.keys()]
        if H is not None:
            for i, J in enumerate(numerical_jacobians(error, *xs)):
                H[i] = J
        return error(*xs)

    return gtsam.CustomFactor(noise, [gkey(k) for k in keys], evaluate)


def lam_psi(sde, t1, tau, t2):
    """[Λ Ψ] = K(τ, [t₁ t₂]) K([t₁ t₂])⁻¹ from the dense kernel (any P0: x(τ) | x₁, x₂ is Markov)."""
    K = gp_kernel(np.array([t1, tau, t2]), sde, np.eye(6))
    idx = np.r_[0:6, 12:18]
    G = np.linalg.solve(K[np.ix_(idx, idx)], K[np.ix_(idx, np.r_[6:12])]).T
    return G[:, :6], G[:, 6:]


def gtsam_problem(data):
    """The paper's batch problem (every SKIP-th pose estimated, readings between interpolated)."""
    r = Readings.from_dataset(data, SETUP)
    sde = LinearSDE.wnoa(SETUP.qc)
    n = r.n_poses
    states = sorted(set(range(0, n, SKIP)) | {n - 1})
    sigmas = gtsam.noiseModel.Diagonal.Sigmas
    tukey = gtsam.noiseModel.mEstimator.Tukey.Create(SETUP.tukey_c)
    range_noise = gtsam.noiseModel.Robust.Create(tukey, gtsam.noiseModel.Isotropic.Sigma(1, SETUP.range_sigma))
    graph = gtsam.NonlinearFactorGraph()
    prior_mean = np.concatenate([r.first_pose, SETUP.first_velocity])
    prior_sigmas = np.concatenate([SETUP.first_pose_sigmas, SETUP.first_velocity_sigmas])
    graph.add(error_factor(sigmas(prior_sigmas), [X(0)], partial(prior_error, prior_mean)))
    for a, b in itertools.pairwise(states):
        dt = r.model_times[b] - r.model_times[a]
        noise = gtsam.noiseModel.Gaussian.Covariance(sde_process_noise(sde, dt))
        graph.add(error_factor(noise, [X(a), X(b)], partial(gp_prior_error, sde_transition(sde, dt))))
    for lid in sorted(set(r.range_landmark.tolist())):
        graph.add(
            error_factor(
                sigmas(np.full(2, SETUP.landmark_prior_sigma)), [L(lid)], partial(prior_error, r.landmarks[lid])
            )
        )

    def add(pose, error, noise, others=()):
        if pose in states:
            graph.add(error_factor(noise, [X(pose), *others], error))
            return
        j = np.searchsorted(states, pose)
        a, b = states[j - 1], states[j]
        lam, psi = lam_psi(sde, r.model_times[a], r.model_times[pose], r.model_times[b])
        graph.add(error_factor(noise, [X(a), X(b), *others], partial(interpolated, error, lam, psi)))

    for p in range(1, n):
        vel_sigmas = SETUP.velocity_sigmas if p in states else SETUP.interpolated_velocity_sigmas
        add(p, partial(velocity_error, r.velocity[p]), sigmas(vel_sigmas))
    for p, lid, rng in zip(r.range_pose, r.range_landmark, r.range_value, strict=True):
        add(int(p), partial(range_error, rng), range_noise, [L(int(lid))])
    return graph, states


def to_gtsam(values: Values):
    out = gtsam.Values()
    for k in values:
        out.insert(gkey(k), np.asarray(values[k], dtype=float))
    return out


def test_batch_optimum_equals_gtsam(data):
    problem = build_problem(data, SETUP, skip=SKIP)
    graph, states = gtsam_problem(data)
    assert problem.states.tolist() == states
    assert graph.size() == len(problem.graph)
    # the same cost at the starting point: the same factors, whitening and Tukey loss
    start = to_gtsam(problem.initial)
    np.testing.assert_allclose(problem.graph.error(problem.initial), graph.error(start), rtol=1e-7)

    ours = gauss_newton(
        problem.graph,
        problem.initial,
        relative_tolerance=1e-15,
        absolute_tolerance=0,
        step_tolerance=1e-11,
        max_iterations=100,
    )
    params = gtsam.LevenbergMarquardtParams()
    params.setRelativeErrorTol(1e-15)
    params.setAbsoluteErrorTol(0.0)
    params.setMaxIterations(200)
    theirs = gtsam.LevenbergMarquardtOptimizer(graph, start, params).optimize()
    for k in ours.values:
        np.testing.assert_allclose(ours.values[k], theirs.atVector(gkey(k)), rtol=0, atol=1e-6, err_msg=str(k))
    np.testing.assert_allclose(problem.graph.error(ours.values), graph.error(theirs), rtol=1e-9)


# --- 2. incremental: our Bayes tree against GTSAM's ISAM2 on one stream ---------------------------


class BothSolvers(BayesTreeSolver):
    """Our Bayes tree, with GTSAM's ISAM2 fed the same updates alongside."""

    def __init__(self):
        super().__init__(ISAM2Params(relinearize_threshold=0.0, relinearize_skip=1, wildfire_threshold=0.0))
        self.isam = gtsam.ISAM2(isam2_params(0.0, 1, 0.0))
        self.largest_gap = 0.0

    def update(self, factors, values):
        super().update(factors, values)
        graph = gtsam.NonlinearFactorGraph()
        for f in factors:
            graph.add(custom_factor(f))  # our error and Jacobians: the solvers are what is compared
        self.isam.update(graph, to_gtsam(values))
        theirs = self.isam.calculateEstimate()
        ours = self.estimate()
        for k in ours:
            self.largest_gap = max(self.largest_gap, float(np.max(np.abs(ours[k] - theirs.atVector(gkey(k))))))


@pytest.mark.parametrize("every", [1, 10])
def test_bayes_tree_equals_gtsam_isam2_on_a_stream(data, every):
    solver = BothSolvers()
    est = StreamingEstimator(
        Readings.from_dataset(data, SETUP), SETUP.with_schedule(every=every), StreamOptions(skip=2), solver=solver
    )
    while not est.done:
        est.step()
    assert len(solver.reports) > (1 if every == 10 else 10)
    assert solver.largest_gap < 1e-7, solver.largest_gap
