"""Which variables a fixed-lag window keeps, against GTSAM 4.3's IncrementalFixedLagSmoother, at the boundary.

The rule (docs/bayes_tree.md): a variable stamped t < t_newest - lag, in floating point, is marginalized; one exactly
at the boundary stays; a timestamp given again replaces the old one. States 0.1 s apart, their times i * 0.1 or
summed 0.1 at a time, put the boundary on a state's time, or a rounding error either side of it (1.0 - 0.7 is
0.30000000000000004, 3 * 0.1 is too; summed, 0.1 three times is, but ten times is 0.9999999999999999). After every
update the two smoothers hold the same states, with the same estimates; a state restamped older leaves at once,
one restamped newer stays longer, and a restamp of a state already forgotten is refused by both, each leaving its
smoother as it was. tests/test_fixed_lag_gtsam.py compares covariances on steps that never land on
the boundary.
"""

from __future__ import annotations

import numpy as np
import pytest
from requirements import optional_import

gtsam = optional_import("gtsam", "gtsam")  # skips here, fails in CI (STEAM_REF_REQUIRE_OPTIONAL=1)

from steam_ref.bayes_tree import FixedLagSmoother  # noqa: E402
from steam_ref.errors import UnknownVariableError  # noqa: E402
from steam_ref.factors import GPPriorFactor, PriorFactor  # noqa: E402
from steam_ref.variables import X  # noqa: E402

QC = np.array([0.3, 0.2, 0.1])
STEPS = 14
TIMES = {"i*0.1": [i * 0.1 for i in range(STEPS + 1)], "summed": list(np.cumsum([0.0] + [0.1] * STEPS))}
RESTAMPS = {"none": {}, "older": {6: {3: -1.0}}, "newer": {6: {3: 0.55}, 9: {7: 0.95}}}  # update → {state: time}


def P(i: int) -> int:
    return gtsam.symbol("p", i)


def V(i: int) -> int:
    return gtsam.symbol("v", i)


@pytest.mark.parametrize("restamp", list(RESTAMPS))
@pytest.mark.parametrize("times", list(TIMES))
@pytest.mark.parametrize("lag", [0.1, 0.2, 0.3, 0.7, 1.1])
def test_the_window_holds_what_gtsam_holds_at_the_boundary(lag, times, restamp):
    t, restamps = TIMES[times], RESTAMPS[restamp]
    params = gtsam.ISAM2Params()
    params.setRelinearizeThreshold(0.0)
    params.relinearizeSkip = 1
    params.setOptimizationParams(gtsam.ISAM2GaussNewtonParams(0.0))  # full back-substitution
    theirs = gtsam.IncrementalFixedLagSmoother(lag, params)
    ours = FixedLagSmoother(lag, relinearize_skip=1, wildfire_threshold=0.0)
    rng = np.random.default_rng(0)
    mean = rng.normal(size=6)
    graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
    graph.add(gtsam.PriorFactorPoint3(P(0), mean[:3], gtsam.noiseModel.Isotropic.Sigma(3, 0.1)))
    graph.add(gtsam.PriorFactorPoint3(V(0), mean[3:], gtsam.noiseModel.Isotropic.Sigma(3, 0.1)))
    values.insert(P(0), mean[:3])
    values.insert(V(0), mean[3:])
    theirs.update(graph, values, {P(0): t[0], V(0): t[0]})
    ours.update([PriorFactor.create(X(0), mean, 0.1)], {X(0): mean}, timestamps={X(0): t[0]})
    left = 0
    for i in range(1, STEPS + 1):
        init = rng.normal(size=6)
        graph, values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        graph.add(gtsam.WnoaMotionFactorPoint3(gtsam.StateData(P(i - 1), V(i - 1), t[i - 1]),
                                               gtsam.StateData(P(i), V(i), t[i]), QC))  # fmt: skip
        values.insert(P(i), init[:3])
        values.insert(V(i), init[3:])
        stamps = {i: t[i]} | restamps.get(i, {})
        gone = [j for j in stamps if ours.was_marginalized(X(j))]
        if gone:  # a restamp of a state already forgotten: both refuse the whole update, changing nothing
            with pytest.raises(ValueError, match=f"timestamp supplied for key 'p{gone[0]}', but no value exists"):
                theirs.update(graph, values, {key(j): s for j, s in stamps.items() for key in (P, V)})
            with pytest.raises(UnknownVariableError, match=f"timestamps names x{gone[0]}, which was marginalized"):
                ours.update([GPPriorFactor.wnoa(X(i - 1), X(i), t[i] - t[i - 1], np.diag(QC))], {X(i): init},
                            timestamps={X(j): s for j, s in stamps.items()})  # fmt: skip
            stamps = {j: s for j, s in stamps.items() if j not in gone}
        theirs.update(graph, values, {key(j): s for j, s in stamps.items() for key in (P, V)})
        ours.update([GPPriorFactor.wnoa(X(i - 1), X(i), t[i] - t[i - 1], np.diag(QC))], {X(i): init},
                    timestamps={X(j): s for j, s in stamps.items()})  # fmt: skip
        estimate = theirs.calculateEstimate()
        held = sorted(gtsam.Symbol(k).index() for k in estimate.keys() if gtsam.Symbol(k).chr() == ord("p"))
        assert sorted(k.index for k in ours.estimate()) == held, f"update {i}"
        for j in held:
            want = np.concatenate([estimate.atPoint3(P(j)), estimate.atPoint3(V(j))])
            np.testing.assert_allclose(ours.estimate_of(X(j)), want, rtol=0, atol=1e-9, err_msg=f"x{j}, update {i}")
        left = max(left, ours.n_marginalized)
    assert left > 0
