"""GTSAM 4.3 as the oracle of the SE(3) prior in a stream: the same generated 3-D task through GTSAM's ISAM2 with
its own factors and through steam_ref's BTGP, pose by pose.  [derivations §11, §15]

The task is ``datasets.rigid.sample_rigid_task`` (a vehicle turning and climbing, drawn from the SE(3) WNOA model:
a gyro reading, a range and a body-frame point of the nearest landmark at every state, a position fix every fifth,
landmarks surveyed). GTSAM's graph holds, state by state, what ``paper.rigid.steps`` gives ours:
``WnoaMotionFactorPose3`` between states (the local-variable residual; Qc diagonal), ``PriorFactorPose3`` and
``PriorFactorVector6`` on the first state, ``GPSFactor`` for a fix, ``RangeFactor3D`` for a range,
``PriorFactorPoint3`` for a landmark's survey, ``PriorFactorVector6`` with zero precision on the linear part for
a gyro reading (its Jacobian's rows there are zero: the gyro reads ω only), and, GTSAM having no factor for a
landmark's position in the body frame, a ``CustomFactor`` around ``Pose3.transformTo`` and its Jacobians. Both
solvers run iSAM2 at GTSAM's defaults (relinearize at 0.1, every 10th update), one update per state, each new
state predicted from its own solver's estimate of the one before (T Exp(Δt ϖ), ϖ). Printed, one JSON line:

- ``residuals``: at GTSAM's final estimate, the WNOA priors' residuals from both (the largest difference, and
  relative to the largest residual) and both graphs' costs;
- ``btgp_vs_isam2``: our final estimate against GTSAM's, pose by pose (translation m, rotation rad): median, max;
- ``vs_batch``: each against the exact batch optimum (Gauss-Newton from BTGP's estimate, our exact Jacobians),
  and GTSAM's own Gauss-Newton (its Jacobians, from its ISAM2 estimate, relative tolerance 1e-12) against it:
  where GTSAM's truncated Jacobians put the fixed point (J̃ᵀ W e = 0, not Jᵀ W e = 0);
- ``costs``: the common cost at each estimate (ours, exact), and the seconds of each stream.

    python benchmarks/se3_vs_gtsam.py [--steps 40] [--landmarks 8] [--seed 0] [--full --settle 5]
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np

from steam_ref.batch import gauss_newton
from steam_ref.bayes_tree import IncrementalSolver
from steam_ref.datasets.rigid import sample_rigid_task
from steam_ref.graph import FactorGraph
from steam_ref.lie import SE3V
from steam_ref.motion import motion_prior
from steam_ref.paper.rigid import steps
from steam_ref.variables import Values, X

PERM = np.r_[3:6, 0:3]  # ours [ρ; φ] -> GTSAM's [ω; v], both ways
QC = np.diag([0.02, 0.005, 0.005, 0.001, 0.001, 0.002])  # the NEES study's (docs/experiments.md, SE(3))
_AT = 1e-9


def _gtsam():
    import gtsam

    return gtsam


def keys():
    """GTSAM's keys: pose x(i), twist v(i), landmark l(j)."""
    g = _gtsam()
    return (lambda i: g.symbol("x", i)), (lambda i: g.symbol("v", i)), (lambda j: g.symbol("l", j))


def to_gtsam(state: np.ndarray):
    """An SE3V state [t; φ; ϖ] as GTSAM's (Pose3, twist [ω; v])."""
    return _gtsam().Pose3(SE3V.matrix(state[:6])), np.asarray(state[6:12][PERM])


def from_gtsam(pose, twist: np.ndarray) -> np.ndarray:
    g = _gtsam()
    return np.r_[pose.translation(), g.Rot3.Logmap(pose.rotation()), np.asarray(twist)[PERM]]


def _point_factor(pose_key: int, landmark_key: int, measured: np.ndarray, sigma: float):
    """A landmark's position in the body frame, T⁻¹ p - q, with ``Pose3.transformTo``'s Jacobians."""
    g = _gtsam()

    def error(this, values, H):
        pose, point = values.atPose3(this.keys()[0]), values.atPoint3(this.keys()[1])
        if H is None:
            return pose.transformTo(point) - measured
        H1, H2 = np.zeros((3, 6), order="F"), np.zeros((3, 3), order="F")
        e = pose.transformTo(point, H1, H2) - measured
        H[0], H[1] = H1, H2
        return e

    return g.CustomFactor(g.noiseModel.Isotropic.Sigma(3, sigma), [pose_key, landmark_key], error)


def gtsam_steps(data):
    """GTSAM's factors and first values state by state: a list of (i, NonlinearFactorGraph, new landmarks {j: p})."""
    g = _gtsam()
    xk, vk, lk = keys()
    t, sig = data.state_times, data.sigmas
    qc = np.diag(QC)[PERM]
    iso = g.noiseModel.Isotropic.Sigma
    survey = {int(r[0]): r[1:] for r in data.landmarks}
    seen: set[int] = set()
    out = []
    for i in range(len(t)):
        graph, new = g.NonlinearFactorGraph(), {}
        if i == 0:
            pose, twist = to_gtsam(data.first_state)
            graph.add(g.PriorFactorPose3(xk(0), pose, iso(6, sig["first_pose"])))
            graph.add(g.PriorFactorVector6(vk(0), twist, iso(6, sig["first_twist"])))
        else:
            graph.add(
                g.WnoaMotionFactorPose3(
                    g.StateData(xk(i - 1), vk(i - 1), t[i - 1]), g.StateData(xk(i), vk(i), t[i]), qc
                )
            )
        for row in data.positions[np.abs(data.positions[:, 0] - t[i]) < _AT]:
            graph.add(g.GPSFactor(xk(i), row[1:4], iso(3, sig["position"])))
        gyro = g.noiseModel.Diagonal.Precisions(np.r_[np.full(3, sig["gyro"] ** -2), np.zeros(3)])
        for row in data.gyro[np.abs(data.gyro[:, 0] - t[i]) < _AT]:
            graph.add(g.PriorFactorVector6(vk(i), np.r_[row[1:4], np.zeros(3)], gyro))
        for table in ("ranges", "points"):
            for row in getattr(data, table)[np.abs(getattr(data, table)[:, 0] - t[i]) < _AT]:
                j = int(row[1])
                if j not in seen:
                    seen.add(j)
                    new[j] = survey[j]
                    graph.add(g.PriorFactorPoint3(lk(j), survey[j], iso(3, sig["landmark"])))
                if table == "ranges":
                    graph.add(g.RangeFactor3D(xk(i), lk(j), float(row[2]), iso(1, sig["range"])))
                else:
                    graph.add(_point_factor(xk(i), lk(j), row[2:5], sig["point"]))
        out.append((i, graph, new))
    n_between = sum(
        int(np.sum(np.min(np.abs(tb[:, :1] - t[None]), axis=1) > _AT)) for tb in (data.positions, data.gyro)
    )
    if n_between:
        raise ValueError(f"{n_between} readings between states: this comparison reads readings at states only")
    return out


def run_btgp(data, prior, full: bool = False, settle: int = 0) -> np.ndarray:
    """Our iSAM2, one update per state, as ``paper.rigid.solve_rigid``'s 'btgp' (GTSAM's defaults), or with
    ``full`` relinearization (every variable at every update, full back-substitution); then ``settle`` updates with
    nothing new. The states' final estimates (n, 12)."""
    options = {"relinearize_threshold": 0.0, "relinearize_skip": 1, "wildfire_threshold": 0.0} if full else {}
    solver = IncrementalSolver(**options)
    data = data.on(prior.kind)
    last = None
    for step in steps(data, prior):
        gap = data.state_times[step.index] - data.state_times[step.index - 1] if step.index else 0.0
        value = step.value if step.index == 0 else prior.predict(last, gap)
        solver.update(step.factors, {X(step.index): value, **step.landmarks})
        last = solver.estimate()[X(step.index)]
    for _ in range(settle):
        solver.update()
    estimate = solver.estimate()
    return np.array([estimate[X(i)] for i in range(len(data.state_times))])


def run_isam2(data, prior, full: bool = False, settle: int = 0):
    """GTSAM's ISAM2, one update per state, at its defaults or with ``full`` relinearization (threshold 0, every
    update, wildfire 0), then ``settle`` empty updates; the states' final estimates (n, 12), the graph, the Values."""
    g = _gtsam()
    xk, vk, lk = keys()
    params = g.ISAM2Params()
    if full:
        params.setRelinearizeThreshold(0.0)
        params.relinearizeSkip = 1
        gauss_newton_params = g.ISAM2GaussNewtonParams()
        gauss_newton_params.setWildfireThreshold(0.0)
        params.setOptimizationParams(gauss_newton_params)
    isam, whole, last = g.ISAM2(params), g.NonlinearFactorGraph(), None
    for i, graph, new in gtsam_steps(data):
        values = g.Values()
        state = data.first_state if i == 0 else prior.predict(last, data.state_times[i] - data.state_times[i - 1])
        pose, twist = to_gtsam(state)
        values.insert(xk(i), pose)
        values.insert(vk(i), twist)
        for j, p in new.items():
            values.insert(lk(j), np.asarray(p, dtype=float))
        isam.update(graph, values)
        whole.push_back(graph)
        estimate = isam.calculateEstimate()
        last = from_gtsam(estimate.atPose3(xk(i)), estimate.atVector6(vk(i)))
    for _ in range(settle):
        isam.update()
    estimate = isam.calculateEstimate()
    return _states(estimate, len(data.state_times)), whole, estimate


def _states(values, n: int) -> np.ndarray:
    xk, vk, _ = keys()
    return np.array([from_gtsam(values.atPose3(xk(i)), values.atVector6(vk(i))) for i in range(n)])


def distances(a: np.ndarray, b: np.ndarray) -> dict[str, float]:
    """Pose by pose: translation (m) and rotation angle (rad) between two estimates' poses, median and max."""
    dt = np.linalg.norm(a[:, :3] - b[:, :3], axis=1)  # SE3V poses are [t; φ]: t is the position
    dr = np.linalg.norm(SE3V.between(a[:, :6], b[:, :6])[:, 3:], axis=1)  # the angle of R_aᵀ R_b
    return {
        "translation_median_m": float(np.median(dt)),
        "translation_max_m": float(np.max(dt)),
        "rotation_median_rad": float(np.median(dr)),
        "rotation_max_rad": float(np.max(dr)),
    }


def compare(n_steps: int = 40, n_landmarks: int = 8, seed: int = 0, full: bool = False, settle: int = 0) -> dict:
    """Both streams on one drawn task (module docstring); ``full``, ``settle`` as :func:`run_btgp`."""
    g = _gtsam()
    lk = keys()[2]
    prior = motion_prior("se3", QC)
    data = sample_rigid_task(prior, n_steps, n_landmarks, seed).data
    start = time.perf_counter()
    ours = run_btgp(data, prior, full, settle)
    ours_s = time.perf_counter() - start
    start = time.perf_counter()
    theirs, whole, estimate = run_isam2(data, prior, full, settle)
    theirs_s = time.perf_counter() - start
    # our graph, and the exact batch optimum from BTGP's estimate
    graph, values = FactorGraph(), {}
    for step in steps(data.on(prior.kind), prior, ours):
        graph.add(step.factors)
        values[X(step.index)] = step.value
        values.update(step.landmarks)
    batch = gauss_newton(graph, graph.with_kinds(Values(values)), max_iterations=50)
    optimum = np.array([batch.values[X(i)] for i in range(len(ours))])
    # GTSAM's own Gauss-Newton (its Jacobians) from its ISAM2 estimate
    params = g.GaussNewtonParams()
    params.setRelativeErrorTol(1e-14)
    params.setAbsoluteErrorTol(1e-14)
    params.setMaxIterations(100)
    gn = g.GaussNewtonOptimizer(whole, estimate, params).optimize()
    gtsam_batch = _states(gn, len(ours))

    def at(states: np.ndarray, landmarks) -> Values:
        v = {X(i): s for i, s in enumerate(states)}
        v.update({k: val for k, val in batch.values.items() if k.symbol == "l"} if landmarks is None else landmarks)
        return graph.with_kinds(Values(v))

    def their_landmarks(values) -> dict:
        return {k: values.atPoint3(lk(k.index)) for k in batch.values if k.symbol == "l"}

    # the WNOA residuals at GTSAM's final estimate, both sides
    motion = [f for f in graph if type(f).__name__ == "LiePriorFactor"]
    wnoa = [f for f in (whole.at(i) for i in range(whole.size())) if isinstance(f, g.WnoaMotionFactorPose3)]
    ours_e = np.array([f.error(theirs[f.keys[0].index], theirs[f.keys[1].index]) for f in motion])
    theirs_e = np.array([np.asarray(f.unwhitenedError(estimate))[np.r_[PERM, 6 + PERM]] for f in wnoa])
    diff = float(np.max(np.abs(ours_e - theirs_e)))
    mine = at(theirs, their_landmarks(estimate))
    return {
        "task": {"steps": n_steps, "landmarks": n_landmarks, "seed": seed, "factors": len(graph)},
        "isam2": {"relinearization": "every variable, every update" if full else "defaults", "settle": settle},
        "residuals": {
            "wnoa_priors": len(motion),
            "max_abs_difference": diff,
            "relative": diff / float(np.max(np.abs(ours_e))),
            "cost_ours": float(graph.error(mine)),
            "cost_gtsam": float(whole.error(estimate)),
        },
        "btgp_vs_isam2": distances(ours, theirs),
        "vs_batch": {
            "batch_converged": bool(batch.converged),
            "btgp": distances(ours, optimum),
            "isam2": distances(theirs, optimum),
            "gtsam_gauss_newton": distances(gtsam_batch, optimum),
            "isam2_vs_gtsam_gauss_newton": distances(theirs, gtsam_batch),
        },
        "costs": {
            "batch_optimum": float(graph.error(at(optimum, None))),
            "btgp": float(graph.error(at(ours, None))),
            "isam2": float(graph.error(mine)),
            "gtsam_gauss_newton": float(graph.error(at(gtsam_batch, their_landmarks(gn)))),
        },
        "seconds": {"btgp": ours_s, "isam2": theirs_s},
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=40)
    parser.add_argument("--landmarks", type=int, default=8)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--full", action="store_true", help="relinearize every variable at every update")
    parser.add_argument("--settle", type=int, default=0, help="updates with nothing new after the last state")
    args = parser.parse_args()
    print(json.dumps(compare(args.steps, args.landmarks, args.seed, args.full, args.settle)))


if __name__ == "__main__":
    main()
