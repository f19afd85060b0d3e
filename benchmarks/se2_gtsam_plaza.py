"""The SE(2) WNOA prior on Plaza, GTSAM 4.3 as the oracle: the same stream through GTSAM's ISAM2 and ours.

One stream of Plaza readings (``PaperSetup.plaza()``: its noise, range correction, Tukey threshold, landmark
and first-state priors, schedule and iSAM2 settings; the GP prior on the scripts' pose-index clock) is fed
in lockstep to

- **gtsam**: GTSAM 4.3's ISAM2 with built-in factors only: ``WnoaMotionFactorPose2`` between consecutive
  ``Pose2`` / body-velocity keys, ``PriorFactorVector`` on a body-velocity reading, ``RangeFactor2D`` with
  GTSAM's Tukey, ``PriorFactorPoint2`` on a landmark, ``PriorFactorPose2`` + ``PriorFactorVector`` on the
  first state; ``ISAM2Params`` relinearizeThreshold 0.1, relinearizeSkip 10, wildfire 1e-3 (each Pose2,
  velocity and landmark its own variable);
- **steam**: steam_ref's ``IncrementalSolver`` on SE(2) states with ``LiePriorFactor(model="local-variable")``,
  ``BodyVelocityFactor``, ``PoseReading.range`` with ``Tukey``, ``PriorFactor`` on a landmark,
  ``LieStatePrior`` on the first state; ``ISAM2Params`` with the same thresholds and a state relinearized as
  two blocks (pose, velocity), as GTSAM holds it;
- **steam-gtsam-jacobians** (``--jacobians``): the same as steam, but every motion prior's Jacobians are
  GTSAM's own (:class:`GtsamJacobianPrior`, a benchmark-only factor that calls GTSAM for them): the run
  that shows how much of the gap GTSAM's truncated pose Jacobians explain.

Qc is the preset's 0.05·diag(1, 1, 2), read on the body twist [vx, vy, ω]; its x and y entries are equal, so
reading it in the body or the world frame is the same PSD. Both solvers get the same initial values: a new
state is predicted from GTSAM's newest estimate by the body-velocity reading, T Exp(Δt ϖ); the first update
starts from one batch Levenberg-Marquardt solve (steam_ref's, exact Jacobians) of everything so far, as the
paper's front end does; the update schedule is the front end's own rule (``ScheduleClock``).

One JSON line: the agreement of every factor's residual and cost at a common point (GTSAM's final
estimate), the per-pose distance between the two final estimates (median, max; m and rad), each run's
position RMSE against the ground truth, each solver's wall seconds (its update and query calls only).

    python benchmarks/se2_gtsam_plaza.py [--max-poses 1000] [--variants exact,gtsam-jacobians,gtsam-factor,simplified]
                                         [--full-steps] [--plot distances.png]
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import dataclass
from typing import ClassVar

import gtsam
import numpy as np
from numpy.typing import NDArray

from steam_ref.batch import gauss_newton, levenberg_marquardt
from steam_ref.bayes_tree import IncrementalSolver
from steam_ref.datasets import load_dataset
from steam_ref.factors import PriorFactor
from steam_ref.factors.lie_prior import LiePriorFactor, LieStatePrior
from steam_ref.factors.lie_readings import BodyVelocityFactor, PoseReading
from steam_ref.graph import FactorGraph
from steam_ref.lie import SE2, SE2_STATE
from steam_ref.linear.system import linearize
from steam_ref.paper.online import ScheduleClock
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.readings import Readings
from steam_ref.paper.results import position_rmse
from steam_ref.robust import Tukey
from steam_ref.variables import L, Values, X

VEL_VECTOR_VS_RMSE = 0.338  # m, the vector-space WNOA prior's BTGP/1 RMSE on Plaza (docs/experiments.md)


def P(i: int) -> int:
    return gtsam.symbol("p", i)


def V(i: int) -> int:
    return gtsam.symbol("v", i)


def G(j: int) -> int:
    return gtsam.symbol("l", j)


def gtsam_wnoa(dt: float, qc: NDArray, i: int = 0, j: int = 1) -> gtsam.WnoaMotionFactorPose2:
    """GTSAM's SE(2) WNOA prior between states i (at 0) and j (at dt); ``qc`` (3, 3) diagonal (GTSAM takes its diagonal)."""
    if np.any(qc - np.diag(np.diag(qc))):
        raise ValueError(f"GTSAM's WnoaMotionFactorPose2 takes a diagonal Qc, got {qc.tolist()}")
    s1, s2 = gtsam.StateData(P(i), V(i), 0.0), gtsam.StateData(P(j), V(j), dt)
    return gtsam.WnoaMotionFactorPose2(s1, s2, np.diag(qc))


def gtsam_jacobians(g: gtsam.WnoaMotionFactorPose2, x1: NDArray, x2: NDArray) -> tuple[NDArray, NDArray, NDArray]:
    """GTSAM's error and its Jacobians [∂e/∂δ₁ ∂e/∂δ₂] (6, 6) each, pose then velocity columns."""
    H = [np.zeros((6, 3), order="F") for _ in range(4)]
    e = g.evaluateError(gtsam.Pose2(*x1[:3]), x1[3:], gtsam.Pose2(*x2[:3]), x2[3:], *H)
    return np.asarray(e), np.hstack(H[:2]), np.hstack(H[2:])


@dataclass(frozen=True, eq=False)
class GtsamPrior(LiePriorFactor):
    """Benchmark only: ``LiePriorFactor`` (local-variable) with GTSAM's Jacobians in place of the exact ones
    (``residual`` 'exact'), or GTSAM's residual too ('gtsam'): GTSAM's factor behind our interface."""

    qc: NDArray = None  # type: ignore[assignment]  # (3, 3), GTSAM's factor needs it
    residual: str = "exact"

    _shared: ClassVar[tuple[str, ...]] = LiePriorFactor._shared + ("qc", "residual")

    def _gtsam(self, x1: NDArray, x2: NDArray) -> list:
        a, b = np.reshape(x1, (-1, 6)), np.reshape(x2, (-1, 6))
        dts = np.broadcast_to(self.phi, a.shape[:1] + (6, 6))[:, 0, 3]  # Φ = [[I, Δt I], [0, I]]
        return [gtsam_jacobians(gtsam_wnoa(float(dt), self.qc), u, w) for dt, u, w in zip(dts, a, b, strict=True)]

    def error(self, x1: NDArray, x2: NDArray) -> NDArray:
        if self.residual == "exact":
            return super().error(x1, x2)
        return np.reshape([g[0] for g in self._gtsam(x1, x2)], np.shape(x1))

    def jacobians(self, x1: NDArray, x2: NDArray) -> tuple[NDArray, NDArray]:
        out, shape = self._gtsam(x1, x2), np.shape(x1)[:-1] + (6, 6)
        return np.reshape([g[1] for g in out], shape), np.reshape([g[2] for g in out], shape)


# ours; with GTSAM's Jacobians; with its residual too; the simplified residual (a different model)
VARIANTS = ("exact", "gtsam-jacobians", "gtsam-factor", "simplified")
SMALL_TURN = 0.05  # rad: below this |Δθ| of a motion prior, GTSAM's J_r⁻¹(ξ)ϖ₂ loses digits (docs/experiments.md)


def velocity_rows_reference(x1: NDArray, x2: NDArray) -> NDArray:
    """J_r(ξ)⁻¹ϖ₂ - ϖ₁ (the residual's velocity rows) in 40-digit arithmetic: J_r = Σ (-ad ξ)ᵏ/(k+1)!, solved
    by mpmath; ξ = Log(T₁⁻¹T₂) in float64 (both sides take the same).  [DER 11.11]"""
    import mpmath as mp

    with mp.workdps(40):
        rx, ry, th = (mp.mpf(float(v)) for v in SE2.log(SE2.between(x1[:3], x2[:3])))
        ad = mp.matrix([[0, -th, ry], [th, 0, -rx], [0, 0, 0]])
        jr, term = mp.zeros(3, 3), mp.eye(3)
        for k in range(80):
            jr += term / mp.factorial(k + 1)
            term = term * (-ad)
        v = mp.lu_solve(jr, mp.matrix([mp.mpf(float(w)) for w in x2[3:]]))
        return np.array([float(v[i] - mp.mpf(float(x1[3 + i]))) for i in range(3)])


@dataclass
class Item:
    """One reading of the stream in plain numbers; :meth:`ours` and :meth:`theirs` are its factor(s)."""

    kind: str  # 'first', 'landmark', 'motion', 'velocity', 'range'
    keys: tuple[int, ...]
    value: NDArray
    sigmas: NDArray
    dt: float = 0.0

    def ours(self, setup: PaperSetup, variant: str = "exact"):
        k, c = self.keys, setup.tukey_c
        if self.kind == "first":
            return LieStatePrior.create(X(k[0]), self.value, self.sigmas, group=SE2)
        if self.kind == "landmark":
            return PriorFactor.create(L(k[0]), self.value, self.sigmas)
        if self.kind == "motion":
            if variant == "simplified":
                return LiePriorFactor.create(X(k[0]), X(k[1]), self.dt, setup.qc, "simplified", group=SE2)
            if variant != "exact":
                f = LiePriorFactor.create(X(k[0]), X(k[1]), self.dt, setup.qc, group=SE2)
                residual = "gtsam" if variant == "gtsam-factor" else "exact"
                return GtsamPrior(f.keys, f.sqrt_information, phi=f.phi, qc=setup.qc, residual=residual, group=f.group)
            return LiePriorFactor.create(X(k[0]), X(k[1]), self.dt, setup.qc, "local-variable", group=SE2)
        if self.kind == "velocity":
            return BodyVelocityFactor.create(X(k[0]), self.value, self.sigmas, group=SE2)
        loss = None if c is None else Tukey(c)
        return PoseReading.range(X(k[0]), L(k[1]), float(self.value[0]), float(self.sigmas[0]), loss=loss, group=SE2)

    def theirs(self, setup: PaperSetup) -> list:
        k, c = self.keys, setup.tukey_c
        if self.kind == "first":
            pose = gtsam.noiseModel.Diagonal.Sigmas(self.sigmas[:3])
            vel = gtsam.noiseModel.Diagonal.Sigmas(self.sigmas[3:])
            return [
                gtsam.PriorFactorPose2(P(k[0]), gtsam.Pose2(*self.value[:3]), pose),
                gtsam.PriorFactorVector(V(k[0]), self.value[3:], vel),
            ]
        if self.kind == "landmark":
            return [gtsam.PriorFactorPoint2(G(k[0]), self.value, gtsam.noiseModel.Isotropic.Sigma(2, self.sigmas))]
        if self.kind == "motion":
            return [gtsam_wnoa(self.dt, setup.qc, *k)]
        if self.kind == "velocity":
            return [gtsam.PriorFactorVector(V(k[0]), self.value, gtsam.noiseModel.Diagonal.Sigmas(self.sigmas))]
        noise = gtsam.noiseModel.Isotropic.Sigma(1, float(self.sigmas[0]))
        if c is not None:
            noise = gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Tukey.Create(c), noise)
        return [gtsam.RangeFactor2D(P(k[0]), G(k[1]), float(self.value[0]), noise)]


def pose_items(readings: Readings, setup: PaperSetup, i: int, rows: NDArray) -> list[Item]:
    """The readings that pose i releases: its priors (pose 0: the first state's, every landmark's), its
    motion prior from pose i - 1, its body-velocity reading, its ranges."""
    out = []
    if i == 0:
        first = np.r_[readings.first_pose, setup.first_velocity]
        first[2] = np.angle(np.exp(1j * first[2]))  # the data's heading wrapped to (-π, π], as SE(2) holds it
        out.append(Item("first", (0,), first, np.r_[setup.first_pose_sigmas, setup.first_velocity_sigmas]))
        for j, pos in readings.landmarks.items():  # landmarks_up_front: every landmark and its prior at pose 0
            out.append(Item("landmark", (j,), pos, np.array(setup.landmark_prior_sigma)))
    else:
        dt = float(readings.model_times[i] - readings.model_times[i - 1])
        out.append(Item("motion", (i - 1, i), np.zeros(0), np.zeros(0), dt))
        out.append(Item("velocity", (i,), readings.velocity[i], setup.velocity_sigmas))
    for r in range(rows[i], rows[i + 1]):
        j, value = int(readings.range_landmark[r]), readings.range_value[r]
        out.append(Item("range", (i, j), np.array([value]), np.array([setup.range_sigma])))
    return out


@dataclass
class Step:  # what ScheduleClock.due reads of a pose
    pose: int
    n_landmark_readings: int
    is_state: bool = True


def to_gtsam_values(values: dict) -> gtsam.Values:
    out = gtsam.Values()
    for k, v in values.items():
        if k.symbol == "x":
            out.insert(P(k.index), gtsam.Pose2(*v[:3]))
            out.insert(V(k.index), np.asarray(v[3:], dtype=float))
        else:
            out.insert(G(k.index), gtsam.Point2(*v))
    return out


def from_gtsam(est: gtsam.Values, states: range, landmarks) -> dict:
    out = {}
    for i in states:
        p = est.atPose2(P(i))
        out[X(i)] = np.r_[p.x(), p.y(), p.theta(), est.atVector(V(i))]
    for j in landmarks:
        out[L(j)] = np.asarray(est.atPoint2(G(j)), dtype=float)
    return out


def run(max_poses: int | None = None, variant: str = "exact", setup: PaperSetup | None = None) -> dict:
    """Stream Plaza (its first ``max_poses`` poses) through both solvers; the figures (module docstring)."""
    setup = PaperSetup.plaza() if setup is None else setup
    readings = Readings.from_dataset(load_dataset("plaza"), setup)
    n = readings.n_poses if max_poses is None else max_poses
    if not 2 <= n <= readings.n_poses:
        raise SystemExit(f"--max-poses must be 2 to {readings.n_poses} (Plaza's poses), got {max_poses}")
    rows = readings.range_rows()
    isam2 = setup.isam2.replace(relinearize_blocks={"x": setup.relinearize_blocks})
    gparams = gtsam.ISAM2Params()
    gparams.setRelinearizeThreshold(isam2.relinearize_threshold)
    gparams.relinearizeSkip = isam2.relinearize_skip
    gn = gtsam.ISAM2GaussNewtonParams()
    gn.setWildfireThreshold(isam2.wildfire_threshold)
    gparams.setOptimizationParams(gn)
    theirs, ours = gtsam.ISAM2(gparams), IncrementalSolver(isam2)
    clock = ScheduleClock(setup.schedule, n - 1)
    wall = {"gtsam": 0.0, "steam": 0.0}
    items: list[Item] = []
    everything = gtsam.NonlinearFactorGraph()  # every GTSAM factor so far, for the converged comparison
    pending_items: list[Item] = []
    pending: dict = {}  # initial values not yet given to the solvers
    newest: NDArray | None = None  # the newest state's value: GTSAM's estimate, or the pending prediction
    batch_s = 0.0
    for i in range(n):
        new = pose_items(readings, setup, i, rows)
        if i == 0:
            newest = new[0].value.copy()
            pending |= {L(j): pos.copy() for j, pos in readings.landmarks.items()}
        else:
            dt, w = new[0].dt, readings.velocity[i]
            newest = np.r_[SE2.compose(newest[:3], SE2.exp(dt * w)), w]  # T Exp(Δt ϖ)
        pending[X(i)] = newest
        pending_items += new
        if not clock.due(Step(i, sum(it.kind == "range" for it in new))):
            continue
        if not clock.started and setup.schedule.initial_batch:
            start = time.perf_counter()
            tol = setup.schedule.initial_batch_tolerance
            kinds = {k: SE2_STATE for k in pending if k.symbol == "x"}
            graph = FactorGraph([it.ours(setup) for it in pending_items])
            pending = dict(
                levenberg_marquardt(
                    graph, Values(pending, kinds=kinds), ordering="amd", relative_tolerance=tol, absolute_tolerance=tol
                ).values.items()
            )
            batch_s += time.perf_counter() - start
        graph = gtsam.NonlinearFactorGraph()
        for it in pending_items:
            for g in it.theirs(setup):
                graph.add(g)
        everything.push_back(graph)
        start = time.perf_counter()
        theirs.update(graph, to_gtsam_values(pending))
        p, v = theirs.calculateEstimatePose2(P(i)), theirs.calculateEstimateVector(V(i))
        wall["gtsam"] += time.perf_counter() - start
        factors = [it.ours(setup, variant) for it in pending_items]
        values = Values(pending, kinds={k: SE2_STATE for k in pending if k.symbol == "x"})
        start = time.perf_counter()
        ours.update(factors, values)
        ours.estimate_of(X(i))
        wall["steam"] += time.perf_counter() - start
        newest = np.r_[p.x(), p.y(), p.theta(), v]
        clock.updated()
        items += pending_items
        pending_items, pending = [], {}
    start = time.perf_counter()
    estimate_g = theirs.calculateEstimate()
    final_g = from_gtsam(estimate_g, range(n), readings.landmarks)
    wall["gtsam"] += time.perf_counter() - start
    start = time.perf_counter()
    final_s = ours.estimate()
    wall["steam"] += time.perf_counter() - start
    row = report(setup, items, final_g, final_s, n, wall, batch_s, variant)
    # Both iSAM2 estimates carried to their Gauss-Newton fixed points: GTSAM's with its Jacobians, ours with ours
    gn = gtsam.GaussNewtonParams()
    gn.setRelativeErrorTol(1e-14)
    gn.setAbsoluteErrorTol(0.0)
    gn.setMaxIterations(30)
    optimizer = gtsam.GaussNewtonOptimizer(everything, estimate_g, gn)
    fixed_g = from_gtsam(optimizer.optimize(), range(n), readings.landmarks)
    graph = FactorGraph([it.ours(setup, variant) for it in items])
    result = gauss_newton(
        graph, final_s, max_iterations=30, relative_tolerance=1e-14, absolute_tolerance=0.0, step_tolerance=1e-13
    )
    fixed_s = result.values
    row |= {"converged_gtsam_iterations": optimizer.iterations(), "converged_steam_reason": result.reason}
    exact = FactorGraph([it.ours(setup) for it in items])
    kinds = {k: SE2_STATE for k in fixed_g if k.symbol == "x"}
    row |= {"converged_cost_gtsam_point": float(exact.error(Values(fixed_g, kinds=kinds)))}
    row |= {"converged_cost_steam_point": float(exact.error(fixed_s))}
    d, h = distances(fixed_g, fixed_s, n)
    row |= {"converged_distance_m_median": float(np.median(d)), "converged_distance_m_max": float(d.max())}
    row |= {"converged_heading_rad_median": float(np.median(h)), "converged_heading_rad_max": float(h.max())}
    return row


def agreement(setup: PaperSetup, items: list[Item], at: dict) -> dict:
    """Every factor's residual and cost, ours against GTSAM's, at the values ``at`` (GTSAM's estimate)."""
    factors = [it.ours(setup) for it in items]
    values = Values(at, kinds={k: SE2_STATE for k in at if k.symbol == "x"})
    costs = np.zeros(len(factors))
    for group in linearize(factors, values, jacobians=False):
        costs[group.factor_ids] = group.costs
    gv = to_gtsam_values(at)
    worst: dict[str, list[float]] = {}
    motion_worst = (-1.0, None)  # the motion prior where the two residuals part most, and its states
    jac = 0.0  # the largest departure of GTSAM's Jacobians from ours (exact: tests/test_se2_factors.py)
    for it, f, cost in zip(items, factors, costs, strict=True):
        gs = it.theirs(setup)
        e_ours = f.error(*(np.asarray(values[k]) for k in f.keys))
        e_theirs = np.concatenate([np.asarray(g.unwhitenedError(gv)) for g in gs])
        c_theirs = sum(g.error(gv) for g in gs)
        kind = it.kind
        if kind == "motion":  # GTSAM's J_r⁻¹(ξ)ϖ₂ loses digits at small turns: the two sides apart
            x1, x2 = at[X(it.keys[0])], at[X(it.keys[1])]
            turn = abs(SE2.log(SE2.between(x1[:3], x2[:3]))[2])
            kind = f"motion |dtheta| >= {SMALL_TURN}" if turn >= SMALL_TURN else f"motion |dtheta| < {SMALL_TURN}"
            _, H1, H2 = gtsam_jacobians(gs[0], x1, x2)
            J1, J2 = f.jacobians(x1, x2)
            jac = max(jac, float(max(np.abs(H1 - J1).max(), np.abs(H2 - J2).max())))
            apart = float(np.abs(e_ours - e_theirs).max())
            if apart > motion_worst[0]:
                motion_worst = (apart, (x1, x2, e_ours, e_theirs))
        w = worst.setdefault(kind, [0, 0.0, 0.0])
        w[0] += 1
        w[1] = max(w[1], float(np.abs(e_ours - e_theirs).max()))
        w[2] = max(w[2], abs(cost - c_theirs) / max(1.0, abs(c_theirs)))
    out: dict = {k: {"n": v[0], "residual_max_abs": v[1], "cost_max_rel": v[2]} for k, v in sorted(worst.items())}
    out["motion jacobians"] = {"gtsam_minus_exact_max_abs": jac}
    if motion_worst[1] is not None:  # who is right where they part most: 40-digit arithmetic says
        x1, x2, e_ours, e_theirs = motion_worst[1]
        ref = velocity_rows_reference(x1, x2)
        out["motion worst vs 40 digits"] = {
            "dtheta": float(SE2.log(SE2.between(x1[:3], x2[:3]))[2]),
            "steam_minus_reference": float(np.abs(e_ours[3:] - ref).max()),
            "gtsam_minus_reference": float(np.abs(e_theirs[3:] - ref).max()),
        }
    return out


def distances(a: dict, b: dict, n: int) -> tuple[NDArray, NDArray]:
    """Per pose: the position distance (m) and the heading difference (rad) between two estimates."""
    pa, pb = np.array([a[X(i)][:3] for i in range(n)]), np.array([np.asarray(b[X(i)])[:3] for i in range(n)])
    d = np.hypot(*(pa[:, :2] - pb[:, :2]).T)
    h = np.abs(np.angle(np.exp(1j * (pa[:, 2] - pb[:, 2]))))
    return d, h


def report(setup, items, final_g, final_s, n, wall, batch_s, variant) -> dict:
    truth = np.asarray(load_dataset("plaza").ground_truth)[:n, 1:3]
    d, h = distances(final_g, final_s, n)
    row = {
        "benchmark": "se2_gtsam_plaza",
        "n_poses": n,
        "steam_prior": variant,
        "qc_body": np.diag(setup.qc).tolist(),
        "agreement": agreement(setup, items, final_g),
        "distance_m_median": float(np.median(d)),
        "distance_m_max": float(d.max()),
        "heading_rad_median": float(np.median(h)),
        "heading_rad_max": float(h.max()),
        "gtsam_rmse_m": position_rmse(np.array([final_g[X(i)][:2] for i in range(n)]), truth),
        "steam_rmse_m": position_rmse(np.array([np.asarray(final_s[X(i)])[:2] for i in range(n)]), truth),
        "vector_space_rmse_m_full_plaza": VEL_VECTOR_VS_RMSE,
        "gtsam_wall_s": wall["gtsam"],
        "steam_wall_s": wall["steam"],
        "initial_batch_s": batch_s,
    }
    row["_distances"] = (d, h)
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-poses", type=int, default=None, help="a prefix of Plaza (default: all 9,658 poses)")
    parser.add_argument(
        "--variants",
        default="exact",
        help=f"comma-separated, of {', '.join(VARIANTS)}: our prior, or GTSAM's parts in it",
    )
    parser.add_argument(
        "--full-steps",
        action="store_true",
        help="both iSAM2s relinearize everything every update and back-substitute fully (threshold 0, skip 1, "
        "wildfire 0): the iSAM2 path taken out of the gap",
    )
    parser.add_argument("--plot", default=None, help="write the per-pose distances to this PNG")
    args = parser.parse_args()
    setup = PaperSetup.plaza()
    if args.full_steps:
        setup = setup.with_isam2(relinearize_threshold=0.0, relinearize_skip=1, wildfire_threshold=0.0)
    rows = [run(args.max_poses, variant, setup) for variant in args.variants.split(",")]
    for row in rows:
        row["full_steps"] = args.full_steps
    for row in rows:
        print(json.dumps({k: v for k, v in row.items() if not k.startswith("_")}), flush=True)
    if args.plot:
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(2, 1, sharex=True, figsize=(8, 5))
        for row in rows:
            d, h = row["_distances"]
            label = f"steam_ref ({row['steam_prior']}) vs GTSAM"
            ax[0].semilogy(np.maximum(d, 1e-16), lw=0.7, label=label)
            ax[1].semilogy(np.maximum(h, 1e-16), lw=0.7, label=label)
        ax[0].set_ylabel("position distance [m]")
        ax[1].set_ylabel("heading difference [rad]")
        ax[1].set_xlabel("pose")
        ax[0].legend()
        fig.tight_layout()
        fig.savefig(args.plot, dpi=120)


if __name__ == "__main__":
    main()
