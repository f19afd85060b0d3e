"""Every public covariance query against oracles that share none of its code.  [YIB Eq. 11, K11 Sec. 3]

- A key named twice in a ``marginal_covariances`` (whose answer, a dict by key, cannot hold it twice) is refused
  naming it, on every entry: the sparse functions, the tree's, a batch result's, an incremental solver's, a
  fixed-lag smoother's, the stream solvers' and a trajectory's landmarks.
- After incremental updates with fluid relinearization, wildfire (α > 0) and merged cliques, the tree answers for
  its current linear system: every query equals the dense inverse of AᵀA, A by finite differences through each
  variable's retraction at the solver's ``linearization_point`` θ̄, and not the one at its estimate θ̄ ⊕ δ (the
  δ not yet relinearized is large enough to tell them apart); keys in any order, far apart, repeated in a joint.
- On SE(2) states the pose block is in the body frame, as GTSAM's ``Marginals`` gives for a Pose2 (right
  retraction, tangent [x, y, θ]), for the batch result and the tree alike, at headings where the world frame
  would differ; on SE(3) states it is GTSAM's Pose3 block with its tangent [ω; v] permuted to ours [ρ; φ].
- A query, even one interrupted by Ctrl-C in the middle of its walk, changes nothing the solver holds (every
  store, byte for byte).
"""

from __future__ import annotations

import numpy as np
import pytest
from requirements import optional_import
from test_bad_interrupt import state
from test_se2_covariance_and_lm_against_differences import _dense_covariance, _problem

import steam_ref as sr
from steam_ref import covariance
from steam_ref.bayes_tree import FixedLagSmoother, IncrementalSolver
from steam_ref.factors.lie_prior import LieStatePrior
from steam_ref.factors.lie_readings import PoseReading
from steam_ref.factors.point_readings import RangeReading
from steam_ref.lie import SE2, SE3V
from steam_ref.linear import LinearSystem, natural_ordering
from steam_ref.paper.solvers import BayesTreeSolver, PeriodicBatchSolver
from steam_ref.variables import L, Values, X

gtsam = optional_import("gtsam", "gtsam")


def _incremental(seed: int, **params) -> tuple[IncrementalSolver, list, dict]:
    """The SE(2) problem of 8 states and 3 landmarks fed a state at a time from a perturbed start, then 3 empty
    updates: (solver, factors, the keys in the problem's order → start)."""
    factors, near = _problem(seed, n=8)
    rng = np.random.default_rng(seed + 1)
    start = {
        k: v + (np.r_[rng.normal(size=3) * 0.1, 0, 0, 0] if len(v) == 6 else rng.normal(size=2) * 0.3)
        for k, v in near.items()
    }
    by_state: dict = {}
    for f in factors:
        newest = max((k.index for k in f.keys if k.symbol == "x"), default=0)
        by_state.setdefault(newest, []).append(f)
    solver, added = IncrementalSolver(**params), set()
    for i in range(8):
        values = {k: start[k] for f in by_state[i] for k in f.keys if k not in added}
        added |= set(values)
        solver.update(by_state[i], values)
    for _ in range(3):
        solver.update([])
    return solver, factors, start


def _rows(at: dict, keys) -> np.ndarray:
    return np.concatenate([np.arange(at[k].start, at[k].stop) for k in keys])


# --- a key named twice -------------------------------------------------------------------------------


def _two_states():
    factors = [
        sr.PriorFactor.create(X(0), np.zeros(6), 1.0),
        sr.GPPriorFactor.wnoa(X(0), X(1), 1.0, np.eye(3)),
        sr.RangeFactor.create(X(1), L(0), 2.0, 0.3),
        sr.PriorFactor.create(L(0), [2.0, 1.0], 1.0),
    ]
    values = {X(0): np.zeros(6), X(1): np.r_[1.0, 0, 0, 1, 0, 0], L(0): np.array([2.0, 1.0])}
    return factors, values


def _entries():
    factors, values = _two_states()
    solver = IncrementalSolver()
    solver.update(factors, values)
    smoother = FixedLagSmoother(lag=10.0)
    smoother.update(factors, values, timestamps={X(0): 0.0, X(1): 1.0, L(0): 1.0})
    batch = sr.gauss_newton(factors, values)
    pb = PeriodicBatchSolver()
    pb.update(factors, Values(values))
    bt = BayesTreeSolver()
    bt.update(factors, Values(values))
    order = natural_ordering(list(values), {k: len(v) for k, v in values.items()})
    system = LinearSystem.build(factors, Values(values), order)
    return {
        "marginal_covariances(system)": lambda keys: covariance.marginal_covariances(system, keys),
        "sparse_marginal_covariances": lambda keys: covariance.sparse_marginal_covariances(factors, values, keys),
        "tree_marginal_covariances": lambda keys: covariance.tree_marginal_covariances(solver.tree, keys),
        "BatchResult": batch.marginal_covariances,
        "IncrementalSolver": solver.marginal_covariances,
        "FixedLagSmoother": smoother.marginal_covariances,
        "PeriodicBatchSolver": pb.marginal_covariances,
        "BayesTreeSolver": bt.marginal_covariances,
    }


@pytest.mark.parametrize("entry", list(_entries()))
def test_marginal_covariances_refuse_a_key_named_twice(entry):
    """The answer is a dict by key: it used to hold the key once, silently; now the key is named."""
    query = _entries()[entry]
    assert list(query([X(1), L(0)])) == [X(1), L(0)]  # distinct keys: one entry each, in the order given
    with pytest.raises(sr.SteamError, match=r"keys names x1 twice \(keys\[0\] and keys\[2\]\)"):
        query([X(1), L(0), X(1)])


def test_a_trajectorys_covariances_refuse_a_landmark_named_twice():
    factors, values = _two_states()
    solver = IncrementalSolver()
    solver.update(factors, values)
    trajectory = sr.Trajectory(solver, [0, 1], [0.0, 1.0], np.eye(3))
    assert trajectory.covariances([L(0)]).landmark_ids == (0,)
    with pytest.raises(sr.SteamError, match=r"landmarks names l0 twice"):
        trajectory.covariances([L(0), L(0)])


# --- the tree's current linear system ----------------------------------------------------------------


@pytest.mark.parametrize("zeros", [0.0, 0.3])
def test_tree_queries_after_relinearization_and_wildfire_are_those_of_its_linear_system(zeros):
    """Every query equals (AᵀA)⁻¹ at θ̄ (differences through the retraction), not at θ̄ ⊕ δ: the stale δ that the
    wildfire threshold leaves, and the δ below β, are not folded in."""
    solver, factors, start = _incremental(
        3, relinearize_threshold=0.02, relinearize_skip=1, wildfire_threshold=0.05, amalgamation_zeros=zeros
    )
    order = list(start)
    theta = solver.linearization_point
    assert any(not np.array_equal(theta[k], start[k]) for k in order)  # relinearized
    dense, at = _dense_covariance(factors, theta, order)
    at_estimate, _ = _dense_covariance(factors, solver.estimate(), order)
    tol = 1e-9 * np.abs(dense).max()
    marginals = solver.marginal_covariances()
    assert set(marginals) == set(order)
    for k in order:
        np.testing.assert_allclose(marginals[k], dense[at[k], at[k]], rtol=0, atol=tol)
        np.testing.assert_allclose(solver.marginal_covariance(k), dense[at[k], at[k]], rtol=0, atol=tol)
    assert max(np.abs(marginals[k] - at_estimate[at[k], at[k]]).max() for k in order) > 1e3 * tol
    some = [L(2), X(6), X(0)]
    assert list(solver.marginal_covariances(some)) == some
    groups = [[X(7), L(1), X(0)], [X(0), X(7)], [X(3), X(2)], [L(0)], [X(5), X(5)], list(reversed(order)), []]
    joints = solver.joint_covariances(groups)
    for group, joint in zip(groups, joints, strict=True):
        idx = _rows(at, group) if group else np.zeros(0, int)
        np.testing.assert_allclose(joint, dense[np.ix_(idx, idx)], rtol=0, atol=tol)
        np.testing.assert_allclose(solver.joint_covariance(group), dense[np.ix_(idx, idx)], rtol=0, atol=tol)


# --- SE(2): the body frame, as GTSAM's Pose2 -----------------------------------------------------------


def _se2_against_gtsam(seed: int):
    """States (pose and twist) with a prior each and bearing-range readings of shared landmarks: the twists are
    independent of everything, so the pose blocks are those of a Pose2 problem GTSAM can solve."""
    rng = np.random.default_rng(seed)
    n, m = 4, 3
    poses = [np.array([1.5 * i, 0.5 * i, 0.9 + 0.6 * i]) for i in range(n)]
    landmarks = [rng.normal(size=2) * 4 + [2.0, 1.0] for _ in range(m)]
    pose_sigmas, twist_sigmas, reading_sigmas = np.array([0.4, 0.3, 0.2]), np.ones(3), np.array([0.05, 0.1])
    factors: list = []
    graph = gtsam.NonlinearFactorGraph()
    values, initial = {}, gtsam.Values()
    for i, p in enumerate(poses):
        x = np.r_[p, 0.5, 0.0, 0.1]
        values[X(i)] = x
        factors.append(
            LieStatePrior.create(X(i), x + np.r_[0.1, -0.1, 0.05, 0, 0, 0], np.r_[pose_sigmas, twist_sigmas], group=SE2)
        )
        graph.add(
            gtsam.PriorFactorPose2(
                X(i).index, gtsam.Pose2(*(p + [0.1, -0.1, 0.05])), gtsam.noiseModel.Diagonal.Sigmas(pose_sigmas)
            )
        )
        initial.insert(X(i).index, gtsam.Pose2(*p))
    for j, lm in enumerate(landmarks):
        key = 1000 + j
        values[L(j)] = lm
        factors.append(sr.PriorFactor.create(L(j), lm + 0.2, 3.0))
        graph.add(gtsam.PriorFactorPoint2(key, lm + 0.2, gtsam.noiseModel.Isotropic.Sigma(2, 3.0)))
        initial.insert(key, lm)
        for i, p in enumerate(poses):
            d = lm - p[:2]
            bearing, distance = np.arctan2(d[1], d[0]) - p[2] + 0.02 * (-1) ** i, np.hypot(*d) + 0.05
            factors.append(PoseReading.bearing_range(X(i), L(j), bearing, distance, reading_sigmas, group=SE2))
            graph.add(
                gtsam.BearingRangeFactor2D(
                    X(i).index, key, gtsam.Rot2(bearing), distance, gtsam.noiseModel.Diagonal.Sigmas(reading_sigmas)
                )
            )
    return factors, values, graph, initial


def test_se2_pose_blocks_are_in_the_body_frame_as_gtsams_pose2_marginals():
    factors, values, graph, initial = _se2_against_gtsam(7)
    marginals = gtsam.Marginals(graph, initial)  # linearized at the same point as ours
    batch = sr.BatchResult(Values(values), 0.0, factors=tuple(factors))
    solver = IncrementalSolver(relinearize_threshold=1e9)  # never relinearized: its θ̄ is ``values``
    solver.update(factors, values)
    query = [X(3), X(0), L(1)]
    expected = marginals.jointMarginalCovariance([3, 0, 1001]).fullMatrix()
    for source in (batch, solver):
        joint = source.joint_covariance(query)
        pose_rows = np.r_[0:3, 6:9, 12:14]  # the two poses' [x, y, θ] and the landmark, twists left out
        np.testing.assert_allclose(joint[np.ix_(pose_rows, pose_rows)], expected, rtol=1e-8, atol=1e-12)
        for i in range(4):
            block = source.marginal_covariance(X(i))
            np.testing.assert_allclose(block[:3, :3], marginals.marginalCovariance(i), rtol=1e-8, atol=1e-12)
            np.testing.assert_allclose(block[:3, 3:], 0, atol=1e-12)  # the twist is independent of the pose
    heading = values[X(2)][2]  # 2.1 rad: the world-frame block is another matrix
    c, s = np.cos(heading), np.sin(heading)
    world = np.array([[c, -s], [s, c]]) @ solver.marginal_covariance(X(2))[:2, :2] @ np.array([[c, s], [-s, c]])
    assert np.abs(world - marginals.marginalCovariance(2)[:2, :2]).max() > 1e-3
    np.testing.assert_allclose(
        sr.lie.world_position_covariance(values[X(2)], solver.marginal_covariance(X(2))), world, rtol=1e-12
    )


def test_se3_pose_blocks_are_gtsams_pose3_marginals_permuted():
    """States on SE(3) (``SE3V``: a state of as many numbers as its tangent, as the solvers take) with a correlated
    prior on each pose (at the linearization point, where both errors are 0 and their Jacobians the identity,
    whatever GTSAM's Pose3 chart) and ranges to shared landmarks: GTSAM's Pose3 block in [ω; v] is ours in [ρ; φ]
    after the permutation, for the batch result and the tree."""
    rng = np.random.default_rng(11)
    perm = np.r_[3:6, 0:3]  # GTSAM's [ω; v] from ours [ρ; φ]
    graph, initial, factors, values = gtsam.NonlinearFactorGraph(), gtsam.Values(), [], {}
    poses = [SE3V.exp(np.r_[rng.normal(size=3) * 2, rng.normal(size=3)]) for _ in range(3)]
    for i, T in enumerate(poses):
        B = rng.normal(size=(6, 6)) * 0.2
        cov = B @ B.T + 0.01 * np.eye(6)
        x = np.r_[T, rng.normal(size=6)]
        values[X(i)] = x
        factors.append(
            LieStatePrior.create(
                X(i), x, np.block([[cov, np.zeros((6, 6))], [np.zeros((6, 6)), np.eye(6)]]), group=SE3V
            )
        )
        pose3 = gtsam.Pose3(SE3V.matrix(T))
        graph.add(gtsam.PriorFactorPose3(i, pose3, gtsam.noiseModel.Gaussian.Covariance(cov[np.ix_(perm, perm)])))
        initial.insert(i, pose3)
    for j in range(4):
        lm = rng.normal(size=3) * 3
        values[L(j)] = lm
        factors.append(sr.PriorFactor.create(L(j), lm, 5.0))
        graph.add(gtsam.PriorFactorPoint3(100 + j, lm, gtsam.noiseModel.Isotropic.Sigma(3, 5.0)))
        initial.insert(100 + j, lm)
        for i, T in enumerate(poses):
            r = np.linalg.norm(lm - SE3V.matrix(T)[:3, 3]) + 0.03
            factors.append(RangeReading.create(X(i), L(j), r, 0.05, group=SE3V))
            graph.add(gtsam.RangeFactor3D(i, 100 + j, r, gtsam.noiseModel.Isotropic.Sigma(1, 0.05)))
    marginals = gtsam.Marginals(graph, initial)
    expected = marginals.jointMarginalCovariance([2, 0]).fullMatrix()
    batch = sr.BatchResult(Values(values), 0.0, factors=tuple(factors))
    solver = IncrementalSolver(relinearize_threshold=1e9)
    solver.update(factors, values)
    rows = np.r_[perm, 12 + perm]  # each pose's rows in GTSAM's order, the twists left out
    for source in (batch, solver):
        joint = source.joint_covariance([X(2), X(0)])
        np.testing.assert_allclose(joint[np.ix_(rows, rows)], expected, rtol=1e-7, atol=1e-12)
        assert np.abs(joint[:6, 12:18]).max() > 1e-6  # the ranges to shared landmarks correlate the poses
        assert np.abs(joint[:6, :6] - expected[:6, :6]).max() > 1e-3  # unpermuted, it would not match
        for i in range(3):
            block = source.marginal_covariance(X(i))[np.ix_(perm, perm)]
            np.testing.assert_allclose(block, marginals.marginalCovariance(i), rtol=1e-7, atol=1e-12)


# --- a query changes nothing ---------------------------------------------------------------------------


def test_queries_even_interrupted_change_nothing_the_solver_holds(monkeypatch):
    solver, _factors, start = _incremental(5, relinearize_threshold=0.02, relinearize_skip=1, wildfire_threshold=0.05)
    keys = list(start)
    before = state(solver)
    answers = [
        solver.marginal_covariances(),
        solver.marginal_covariances(keys[::-1]),
        solver.marginal_covariance(X(0)),
        solver.joint_covariance([X(0), X(7), L(2)]),
        solver.joint_covariances([[X(0), X(7)], [X(4), X(3)]]),
    ]
    assert state(solver) == before
    extend, calls = covariance._extend, []

    def interrupted(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return extend(*args, **kwargs)

    monkeypatch.setattr(covariance, "_extend", interrupted)
    queries = [
        lambda: solver.marginal_covariances(),
        lambda: solver.joint_covariance([X(0), X(7), L(2)]),
        lambda: solver.joint_covariances([[X(0), X(7)], [X(4), X(3)]]),
    ]
    for query in queries:
        calls.clear()
        with pytest.raises(KeyboardInterrupt):
            query()
        assert state(solver) == before
    monkeypatch.setattr(covariance, "_extend", extend)
    again = solver.marginal_covariances()
    for k in keys:
        np.testing.assert_array_equal(again[k], answers[0][k])
    np.testing.assert_array_equal(solver.joint_covariance([X(0), X(7), L(2)]), answers[3])
