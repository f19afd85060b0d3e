"""GTSAM 4.3 as the oracle of the SE(2) prior: the same Plaza stream through GTSAM's ISAM2 with its built-in
``WnoaMotionFactorPose2`` and through steam_ref's BTGP with the local-variable residual.  [derivations §11]

Both streams take the factors of ``PaperSetup.plaza().replace(prior="se2")`` from the same front end
(``gtsam_replica.NativeISAM2(se2=True)`` turns each into GTSAM's built-in factors: the WNOA prior,
``PriorFactorVector`` on the body twist, ``RangeFactor2D`` with the same Tukey loss, ``PriorFactorPose2``,
``PriorFactorPoint2``), the same noise, priors and schedule (the preset's: a batch LM start after 50 ranges,
an update at every range), GTSAM's ISAM2 defaults on both sides (relinearize at 0.1, every 10th update, pose
and velocity apart). Each front end predicts from its own solver's estimate. Printed, one JSON line:

- ``residuals``: at GTSAM's final estimate, every factor's unwhitened error from both (ours against the GTSAM
  factors that stand for it), the largest difference, and that of every factor but the WNOA prior; for the 20
  WNOA residuals that differ most, each side against J_r(ξ)⁻¹ϖ₂ evaluated to 40 digits (mpmath): GTSAM's
  ``Pose2::LogmapDerivative`` loses digits to cancellation at small angles (4e-9 at φ = 2e-3, 2e-6 at
  φ = 3e-4), and Plaza turns by milliradians a step; ``cost``: both graphs' costs there (Tukey included) and
  their relative difference, with and without the WNOA factors;
- ``distance``: our final estimate against GTSAM's, pose by pose (position m, heading rad), median and max;
- ``gradient``: the largest entry of the exact gradient of the common cost (our Jacobians, checked
  against complex step) at each final estimate, and each estimate's distance to the exact batch optimum
  (Gauss-Newton from ours): what GTSAM's truncated pose Jacobians (a series in ξ) leave, beside what both
  iSAM2s' lazy relinearization leaves;
- ``rmse_m`` of both against the ground truth, and the seconds of each stream.

    python benchmarks/se2_vs_gtsam.py [--max-poses N]      (N: a prefix; default all 9,658 poses)
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def _jr_inverse_times(xi, w):
    """J_r(ξ)⁻¹ w to 40 digits (mpmath): J_r = Σ (-ad ξ)ᵏ / (k + 1)!, inverted, rounded at the end."""
    import mpmath as mp

    with mp.workdps(40):
        r1, r2, phi = (mp.mpf(float(v)) for v in xi)
        ad = mp.matrix([[0, -phi, r2], [phi, 0, -r1], [0, 0, 0]])
        J, term = mp.zeros(3, 3), mp.eye(3)
        for k in range(60):
            J += term / mp.factorial(k + 1)
            term = term * (-ad)
        out = J**-1 * mp.matrix([mp.mpf(float(v)) for v in w])
        return np.array([float(out[i]) for i in range(3)])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-poses", type=int, default=None)
    args = parser.parse_args()
    sys.path.insert(0, str(HERE))
    import gtsam
    import gtsam_replica

    from steam_ref.batch import gauss_newton
    from steam_ref.datasets import load_dataset
    from steam_ref.factors.lie_prior import LiePriorFactor
    from steam_ref.graph import FactorGraph
    from steam_ref.lie import SE2, SE2_STATE
    from steam_ref.linear.system import linearize
    from steam_ref.paper.online import StreamingEstimator
    from steam_ref.paper.options import StreamOptions
    from steam_ref.paper.presets import PaperSetup
    from steam_ref.paper.readings import Readings
    from steam_ref.variables import L, Values, X

    setup = PaperSetup.plaza().replace(prior="se2", se2_residual="local-variable")
    data = load_dataset("plaza")
    readings = Readings.from_dataset(data, setup)
    options = StreamOptions(method="btgp", max_poses=args.max_poses)
    runs, seconds = {}, {}
    for name in ("steam", "gtsam"):
        solver = gtsam_replica.NativeISAM2(np.diag(setup.qc), se2=True) if name == "gtsam" else None
        est = StreamingEstimator(readings, setup, options, solver=solver)
        start = time.perf_counter()
        while not est.done:
            est.step()
        seconds[name] = time.perf_counter() - start
        runs[name] = est
    ours, theirs = runs["steam"], runs["gtsam"]
    replica = theirs.solver
    states = ours.states[: ours.n_solved]
    factors = [f for f, _ in replica.pairs]
    # GTSAM's final estimate as our values (SE(2) states), and GTSAM's own graph of the same factors
    final = replica.isam.calculateEstimate()
    keys = {k for f in factors for k in f.keys}
    at = Values({k: replica.estimate_of(k) for k in keys}, kinds={k: SE2_STATE for k in keys if k.symbol == "x"})
    graph = gtsam.NonlinearFactorGraph()
    worst, others, wnoa = 0.0, 0.0, []
    for f, built in replica.pairs:
        mine = np.asarray(f.error(*[at[k] for k in f.keys]), dtype=float)
        theirs_e = np.concatenate([g.unwhitenedError(final) for g in built])
        diff = float(np.abs(mine - theirs_e).max())
        worst = max(worst, diff)
        if isinstance(f, LiePriorFactor):
            wnoa.append((diff, f, mine, theirs_e))
        else:
            others = max(others, diff)
        for g in built:
            graph.add(g)
    our_cost, their_cost = FactorGraph(factors).error(at), graph.error(final)
    rest = [f for f, _ in replica.pairs if not isinstance(f, LiePriorFactor)]
    rest_graph = gtsam.NonlinearFactorGraph()
    for f, built in replica.pairs:
        if not isinstance(f, LiePriorFactor):
            for g in built:
                rest_graph.add(g)
    rest_cost = (FactorGraph(rest).error(at), rest_graph.error(final))
    # the WNOA residuals that differ most, against J_r(ξ)⁻¹ ϖ₂ evaluated to 40 digits (ξ from our Log)
    exact_ours, exact_gtsam = 0.0, 0.0
    for _, f, mine, theirs_e in sorted(wnoa, key=lambda w: -w[0])[:20]:
        x1, x2 = at[f.keys[0]], at[f.keys[1]]
        xi = SE2.log(SE2.between(x1[:3], x2[:3]))
        e = np.r_[xi - f.phi[0, 3] * x1[3:], _jr_inverse_times(xi, x2[3:]) - x1[3:]]
        exact_ours, exact_gtsam = (
            max(exact_ours, float(np.abs(mine - e).max())),
            max(exact_gtsam, float(np.abs(theirs_e - e).max())),
        )

    def gradient(values: Values) -> float:
        n = {k: len(values[k]) for k in values}
        g = {k: np.zeros(d) for k, d in n.items()}
        for group in linearize(factors, values):
            for row, ks in enumerate(group.keys):
                for k, J in zip(ks, group.jacobians, strict=True):
                    g[k] -= J[row].T @ group.rhs[row]
        return float(max(np.abs(v).max() for v in g.values()))

    mine_final = ours.solver.estimate()
    ours_values = Values({k: mine_final[k] for k in keys}, kinds=at.kinds())
    optimum = gauss_newton(FactorGraph(factors), ours_values, relative_tolerance=1e-14, step_tolerance=1e-12).values

    def apart(a: Values, b: Values) -> dict:
        d = np.array([SE2_STATE.local(a[X(i)], b[X(i)])[:3] for i in states])
        t, h = np.hypot(d[:, 0], d[:, 1]), np.abs(d[:, 2])
        return {"translation_m": {"median": float(np.median(t)), "max": float(t.max())},
                "heading_rad": {"median": float(np.median(h)), "max": float(h.max())}}  # fmt: skip

    truth = np.asarray(data.ground_truth)[states, 1:3]

    def rmse(v: Values) -> float:
        p = np.array([v[X(i)][:2] for i in states])
        return float(np.sqrt(np.mean(np.sum((p - truth) ** 2, axis=1))))

    print(json.dumps({
        "n_poses": ours.n_poses, "n_states": len(states), "n_landmarks": len([k for k in keys if k.symbol == "l"]),
        "n_factors": len(factors),
        "residuals": {"max_abs_difference": worst, "max_abs_difference_but_wnoa": others,
                      "wnoa_against_40_digits": {"steam": exact_ours, "gtsam": exact_gtsam}},
        "cost": {"steam": our_cost, "gtsam": their_cost, "relative_difference": abs(our_cost - their_cost) / their_cost,
                 "relative_difference_but_wnoa": abs(rest_cost[0] - rest_cost[1]) / rest_cost[1]},
        "distance": apart(ours_values, at),
        "gradient": {"steam": gradient(ours_values), "gtsam": gradient(at), "optimum": gradient(optimum)},
        "to_optimum": {"steam": apart(optimum, ours_values), "gtsam": apart(optimum, at)},
        "rmse_m": {"steam": rmse(ours_values), "gtsam": rmse(at), "optimum": rmse(optimum)},
        "seconds": seconds,
        "landmarks": [L(j).index for j in sorted(k.index for k in keys if k.symbol == "l")],
    }))  # fmt: skip


if __name__ == "__main__":
    main()
