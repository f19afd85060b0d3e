"""``IncrementalSolver.marginalize_leaves`` against GTSAM 4.3's ``ISAM2.marginalizeLeaves``, and the updates after it.

The same linear stream goes to both: WNOA states (GTSAM's ``WnoaMotionFactorPoint3`` on position and velocity keys;
here ``GPPriorFactor.wnoa`` on one [p; ṗ] state), a prior on the first, and offsets to two landmarks (GTSAM's
``BetweenFactorPoint3``; here tests/test_fixed_lag.py's ``Offset``), read in turn. The oldest state, a leaf clique
in GTSAM's tree, is marginalized in both; every held variable's mean and covariance blocks agree to 1e-9 right
after, and after updates that read the landmarks its marginal factor names (GTSAM's LinearContainerFactor, here a
MarginalFactor, re-eliminated with new factors). GTSAM's ``marginalizeLeaves`` given a key that is not in a leaf
clique raises nothing and leaves a tree missing variables its estimate still holds (seen with GTSAM 4.3): steam_ref
re-eliminates first, checked against the dense posterior in tests/test_fixed_lag.py.
"""

from __future__ import annotations

import numpy as np
from requirements import optional_import

gtsam = optional_import("gtsam", "gtsam")  # skips here, fails in CI (STEAM_REF_REQUIRE_OPTIONAL=1)

from test_fixed_lag import EXACT, Offset  # noqa: E402
from test_fixed_lag_gtsam import QC, P, V  # noqa: E402  (GTSAM's keys of a state's position and velocity)

from steam_ref.bayes_tree import IncrementalSolver  # noqa: E402
from steam_ref.factors import GPPriorFactor, PriorFactor  # noqa: E402
from steam_ref.variables import L, X  # noqa: E402


def G(j: int) -> int:
    return gtsam.symbol("l", j)


class Twins:
    """The same stream in GTSAM's ISAM2 and steam_ref's IncrementalSolver, both solving in full at every update."""

    def __init__(self, seed: int) -> None:
        self.rng = np.random.default_rng(seed)
        params = gtsam.ISAM2Params()
        params.setRelinearizeThreshold(0.0)
        params.relinearizeSkip = 1
        params.setOptimizationParams(gtsam.ISAM2GaussNewtonParams(0.0))  # full back-substitution
        self.isam, self.ours = gtsam.ISAM2(params), IncrementalSolver(**EXACT)
        self.landmarks, self.seen, self.i = self.rng.normal(size=(2, 3)) * 3, set(), 0
        mean = self.rng.normal(size=6)
        graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        graph.add(gtsam.PriorFactorPoint3(P(0), mean[:3], gtsam.noiseModel.Isotropic.Sigma(3, 0.1)))
        graph.add(gtsam.PriorFactorPoint3(V(0), mean[3:], gtsam.noiseModel.Isotropic.Sigma(3, 0.1)))
        values.insert(P(0), mean[:3])
        values.insert(V(0), mean[3:])
        self.isam.update(graph, values)
        self.ours.update([PriorFactor.create(X(0), mean, 0.1)], {X(0): mean})

    def step(self) -> None:
        """A new state one second on, reading landmark i mod 2 (entering when first read)."""
        i = self.i = self.i + 1
        graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        graph.add(gtsam.WnoaMotionFactorPoint3(gtsam.StateData(P(i - 1), V(i - 1), i - 1.0),
                                               gtsam.StateData(P(i), V(i), float(i)), QC))  # fmt: skip
        init, z, j = self.rng.normal(size=6), self.rng.normal(size=3), i % 2
        values.insert(P(i), init[:3])
        values.insert(V(i), init[3:])
        graph.add(gtsam.BetweenFactorPoint3(P(i), G(j), z, gtsam.noiseModel.Isotropic.Sigma(3, 0.1)))
        factors = [GPPriorFactor.wnoa(X(i - 1), X(i), 1.0, np.diag(QC)), Offset((X(i), L(j)), np.eye(3) / 0.1, z=z)]
        new = {X(i): init}
        if j not in self.seen:
            self.seen.add(j)
            new[L(j)] = self.landmarks[j] + self.rng.normal(size=3)
            values.insert(G(j), new[L(j)])
        self.isam.update(graph, values)
        self.ours.update(factors, new)

    def agree(self, when: str) -> None:
        """Every variable held: the same mean and covariance blocks (GTSAM's position and velocity separately)."""
        estimate = self.isam.calculateEstimate()
        held = sorted(self.ours.state.dims, key=str)
        assert estimate.size() == sum(2 if k.symbol == "x" else 1 for k in held), when
        for k in held:
            parts = [P(k.index), V(k.index)] if k.symbol == "x" else [G(k.index)]
            mean = np.concatenate([estimate.atPoint3(g) for g in parts])
            np.testing.assert_allclose(self.ours.estimate_of(k), mean, rtol=0, atol=1e-9, err_msg=f"{k} {when}")
            cov = self.ours.marginal_covariance(k)
            for n, g in enumerate(parts):
                block = cov[3 * n : 3 * n + 3, 3 * n : 3 * n + 3]
                want = self.isam.marginalCovariance(g)
                np.testing.assert_allclose(block, want, rtol=0, atol=1e-9, err_msg=f"{k} {when}")


def test_the_oldest_state_marginalized_as_gtsam_and_the_updates_after_it():
    twins = Twins(0)
    for _ in range(6):
        twins.step()
    twins.agree("before")
    leaf = gtsam.KeyList()
    leaf.push_back(P(0))
    leaf.push_back(V(0))
    twins.isam.marginalizeLeaves(leaf)
    report = twins.ours.marginalize_leaves([X(0)])
    assert report.leaves and report.marginal_factors
    twins.agree("after marginalizing x0")
    for _ in range(4):
        twins.step()
        twins.agree(f"at update {twins.i}, after marginalizing x0")
