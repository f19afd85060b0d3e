"""steam_ref's FixedLagSmoother against GTSAM 4.3's IncrementalFixedLagSmoother and BatchFixedLagSmoother.

The same stream goes to all three: a vector-space WNOA trajectory in 3-D (GTSAM's
``WnoaMotionFactorPoint3`` on position and velocity keys; here ``GPPriorFactor.wnoa`` on one
[p; ṗ] state, [YIB Eq. 22, 30-31]), priors on the first state, position fixes every other state.
After every update the newest state's mean and 6 x 6 covariance agree within 1e-9 (GTSAM's
covariances from ``Marginals`` on each smoother's own factors, its LinearContainerFactors
included), and the three hold the same states.
"""

from __future__ import annotations

import numpy as np
import pytest
from requirements import optional_import

gtsam = optional_import("gtsam", "gtsam")  # skips here, fails in CI (STEAM_REF_REQUIRE_OPTIONAL=1)

from test_fixed_lag import PositionFix  # noqa: E402

from steam_ref.bayes_tree import FixedLagSmoother  # noqa: E402
from steam_ref.factors import GPPriorFactor, PriorFactor  # noqa: E402
from steam_ref.gp import process_noise, transition  # noqa: E402
from steam_ref.variables import X  # noqa: E402

QC = np.array([0.3, 0.2, 0.1])


def P(i: int) -> int:
    return gtsam.symbol("p", i)


def V(i: int) -> int:
    return gtsam.symbol("v", i)


def gtsam_smoothers(lag: float):
    isam = gtsam.ISAM2Params()
    isam.setRelinearizeThreshold(0.0)
    isam.relinearizeSkip = 1
    isam.setOptimizationParams(gtsam.ISAM2GaussNewtonParams(0.0))  # full back-substitution
    lm = gtsam.LevenbergMarquardtParams()
    lm.setRelativeErrorTol(0.0)
    lm.setAbsoluteErrorTol(0.0)
    lm.setErrorTol(0.0)
    lm.setMaxIterations(50)
    return {
        "incremental": gtsam.IncrementalFixedLagSmoother(lag, isam),
        "batch": gtsam.BatchFixedLagSmoother(lag, lm),
    }


def newest(smoother, i: int) -> tuple[np.ndarray, np.ndarray, int]:
    """GTSAM's mean and covariance of [p_i; v_i], and how many states it holds."""
    est = smoother.calculateEstimate()
    mean = np.concatenate([est.atPoint3(P(i)), est.atPoint3(V(i))])
    marginals = gtsam.Marginals(smoother.getFactors(), est)
    cov = marginals.jointMarginalCovariance(gtsam.KeyVector([P(i), V(i)])).fullMatrix()
    return mean, cov, est.size() // 2


@pytest.mark.parametrize(("seed", "lag"), [(0, 3.0), (1, 1.2), (2, 5.5)])
def test_newest_state_as_gtsam_fixed_lag_smoothers(seed, lag):
    rng = np.random.default_rng(seed)
    theirs = gtsam_smoothers(lag)
    ours = FixedLagSmoother(lag, relinearize_skip=1, wildfire_threshold=0.0)
    x, t = np.array([0.0, 0.0, 0.0, 1.0, 0.5, -0.2]), 0.0
    mean0, init = x + rng.normal(size=6) * 0.1, x + rng.normal(size=6)
    graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
    graph.add(gtsam.PriorFactorPoint3(P(0), mean0[:3], gtsam.noiseModel.Isotropic.Sigma(3, 0.1)))
    graph.add(gtsam.PriorFactorPoint3(V(0), mean0[3:], gtsam.noiseModel.Isotropic.Sigma(3, 0.1)))
    values.insert(P(0), init[:3])
    values.insert(V(0), init[3:])
    for s in theirs.values():
        s.update(graph, values, {P(0): 0.0, V(0): 0.0})
    ours.update([PriorFactor.create(X(0), mean0, 0.1)], {X(0): init}, timestamps={X(0): 0.0})
    for i in range(1, 16):
        dt = float(rng.uniform(0.5, 1.5))
        x = transition(dt, 3) @ x + np.linalg.cholesky(process_noise(dt, np.diag(QC))) @ rng.normal(size=6)
        init = x + rng.normal(size=6)
        graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        graph.add(
            gtsam.WnoaMotionFactorPoint3(
                gtsam.StateData(P(i - 1), V(i - 1), t), gtsam.StateData(P(i), V(i), t + dt), QC
            )
        )
        factors = [GPPriorFactor.wnoa(X(i - 1), X(i), dt, np.diag(QC))]
        t += dt
        if i % 2 == 0:
            z = x[:3] + rng.normal(size=3) * 0.2
            graph.add(gtsam.PriorFactorPoint3(P(i), z, gtsam.noiseModel.Isotropic.Sigma(3, 0.2)))
            factors.append(PositionFix((X(i),), np.eye(3) / 0.2, z=z))
        values.insert(P(i), init[:3])
        values.insert(V(i), init[3:])
        for s in theirs.values():
            s.update(graph, values, {P(i): t, V(i): t})
        ours.update(factors, {X(i): init}, timestamps={X(i): t})
        for name, s in theirs.items():
            mean, cov, held = newest(s, i)
            np.testing.assert_allclose(ours.estimate_of(X(i)), mean, rtol=0, atol=1e-9, err_msg=f"{name}, step {i}")
            np.testing.assert_allclose(
                ours.marginal_covariance(X(i)), cov, rtol=0, atol=1e-9, err_msg=f"{name}, step {i}"
            )
            assert len(ours) == held, f"{name} holds {held} states, steam_ref {len(ours)}, step {i}"
    assert ours.n_marginalized > 0
