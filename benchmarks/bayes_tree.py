"""Benchmark of the incremental solver (BTGP, [YIB Alg. 1]) on a growing synthetic trajectory.

A robot drives ``--states`` steps along a smooth loop in a bounded field with a handful of range
beacons (the setting of the paper's lawnmower data, where every beacon is heard all along). Each
step adds one state with its GP prior factor [YIB Eq. 22], a projected-velocity reading and one
range reading [YIB Eq. 33], then calls ``IncrementalSolver.update`` once. Prints one JSON line:

    n_states, total_s, update_s_median_first1000, update_s_median_last1000,
    update_s_p95_last1000, reeliminated_mean, max_abs_diff_vs_batch, peak_rss_mb, ...

``max_abs_diff_vs_batch`` compares the tree's solution (full back-substitution) with a batch
sparse solve of the same linear system (all factors, linearized at the solver's θ̄);
``max_abs_diff_estimate_vs_batch`` compares the incrementally kept estimate (partial updates)
with θ̄ + that batch solution. ``--plot`` writes benchmarks/out/bayes_tree.png.
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import time
from pathlib import Path

import numpy as np

import steam_ref as sr
from steam_ref.bayes_tree import IncrementalSolver, ISAM2Params
from steam_ref.gp import transition
from steam_ref.linear import LinearSystem, amd_ordering
from steam_ref.linear.cholesky import solve

QC = np.diag([0.01, 0.01, 0.01])  # Qc of the WNOA prior [YIB Eq. 31]
DT = 0.5  # time between states [s]
VEL_SIGMA = np.array([0.1, 0.1, 0.05])  # projected velocity noise [m/s, m/s, rad/s]
RANGE_SIGMA = 0.1  # range noise [m]
LANDMARK_PRIOR_SIGMA = 0.1  # beacons surveyed to about 10 cm: a prior at the surveyed position [m]
RANGES_PER_STEP = 2  # beacons heard per step (None: all)


def lissajous_trajectory(n: int, dt: float = DT) -> np.ndarray:
    """Ground truth states [x, y, θ, ẋ, ẏ, θ̇] on a Lissajous loop in a 50 m × 40 m field: (n, 6).

    A smooth path that stays in the field (as a mower's does) and keeps a speed of 0.6-1.6 m/s,
    with the heading along the velocity.
    """
    t = np.arange(n) * dt
    w = 0.04
    x, y = 25 * np.sin(w * t), 20 * np.sin(2 * w * t + np.pi / 4)
    xd, yd = 25 * w * np.cos(w * t), 40 * w * np.cos(2 * w * t + np.pi / 4)
    xdd, ydd = -25 * w**2 * np.sin(w * t), -80 * w**2 * np.sin(2 * w * t + np.pi / 4)
    th = np.unwrap(np.arctan2(yd, xd))
    thd = (xd * ydd - yd * xdd) / (xd**2 + yd**2)
    return np.stack([x, y, th, xd, yd, thd], axis=1)


def body_velocity(x: np.ndarray) -> np.ndarray:
    """[forward, lateral, yaw rate] of a state, as VelocityFactor measures it."""
    c, s = np.cos(x[2]), np.sin(x[2])
    return np.array([c * x[3] + s * x[4], -s * x[3] + c * x[4], x[5]])


def make_landmarks(rng: np.random.Generator, m: int) -> np.ndarray:
    """``m`` range beacons around the edge of the field, as on the paper's lawnmower site: (m, 2)."""
    angle = 2 * np.pi * (np.arange(m) + rng.uniform(-0.3, 0.3, size=m)) / m
    radius = rng.uniform(32, 40, size=m)
    return np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)


def step_data(rng, i, xs, landmarks, known, estimate_prev):
    """The factors and new values of step i (state i, its readings, maybe a new landmark)."""
    key = sr.X(i)
    factors, values = [], {}
    if i == 0:
        factors.append(sr.PriorFactor.create(key, xs[0], np.full(6, 1e-3)))
        values[key] = xs[0] + rng.normal(scale=1e-3, size=6)
    else:
        factors.append(sr.GPPriorFactor.wnoa(sr.X(i - 1), key, DT, QC))
        values[key] = transition(DT, 3) @ estimate_prev  # predicted by the prior mean
    factors.append(sr.VelocityFactor.create(key, body_velocity(xs[i]) + rng.normal(size=3) * VEL_SIGMA, VEL_SIGMA))
    for j in (
        range(len(landmarks)) if RANGES_PER_STEP is None else [(i + k) % len(landmarks) for k in range(RANGES_PER_STEP)]
    ):
        lm = sr.L(j)
        if lm not in known:
            guess = landmarks[j] + rng.normal(scale=LANDMARK_PRIOR_SIGMA, size=2)
            values[lm] = guess
            factors.append(sr.PriorFactor.create(lm, guess, LANDMARK_PRIOR_SIGMA))
            known.add(lm)
        r = np.linalg.norm(xs[i, :2] - landmarks[j]) + rng.normal() * RANGE_SIGMA
        factors.append(sr.RangeFactor.create(key, lm, r, RANGE_SIGMA))
    return factors, values


def batch_difference(solver: IncrementalSolver) -> tuple[float, float]:
    """Max |δ_tree - δ_batch| and max |estimate - (θ̄ + δ_batch)| on the same linear system."""
    theta = solver.linearization_point
    keys = list(theta)
    ordering = amd_ordering(keys, {k: theta.dim(k) for k in keys}, (f.keys for f in solver.factors))
    system = LinearSystem.build(solver.factors, theta, ordering)
    x, _ = solve(system)
    batch = system.split(x)
    tree = solver.tree.solve()
    est = solver.estimate()
    d_tree = max(float(np.max(np.abs(tree[k] - batch[k]))) for k in keys)
    d_est = max(float(np.max(np.abs(est[k] - theta[k] - batch[k]))) for k in keys)
    return d_tree, d_est


def run(n_states: int, n_landmarks: int, seed: int, solver_options: dict) -> tuple[dict, np.ndarray]:
    rng = np.random.default_rng(seed)
    xs = lissajous_trajectory(n_states)
    landmarks = make_landmarks(rng, n_landmarks)
    solver = IncrementalSolver(**solver_options)
    known: set = set()
    times, reelim = np.zeros(n_states), np.zeros(n_states)
    start = time.perf_counter()
    prev = None
    for i in range(n_states):
        factors, values = step_data(rng, i, xs, landmarks, known, prev)
        t0 = time.perf_counter()
        report = solver.update(factors, values)
        times[i] = time.perf_counter() - t0
        reelim[i] = len(report.reeliminated)
        prev = solver.estimate_of(sr.X(i))
    total = time.perf_counter() - start
    d_tree, d_est = batch_difference(solver)
    k = min(1000, n_states)
    rmse = float(
        np.sqrt(np.mean([np.sum((solver.estimate_of(sr.X(i))[:2] - xs[i, :2]) ** 2) for i in range(n_states)]))
    )
    out = dict(
        n_states=n_states,
        total_s=round(total, 3),
        update_s_median_first1000=float(np.median(times[:k])),
        update_s_median_last1000=float(np.median(times[-k:])),
        update_s_p95_last1000=float(np.percentile(times[-k:], 95)),
        reeliminated_mean=float(reelim.mean()),
        reeliminated_max_last1000=int(reelim[-k:].max()),
        max_abs_diff_vs_batch=d_tree,
        max_abs_diff_estimate_vs_batch=d_est,
        position_rmse_m=rmse,
        n_landmarks=n_landmarks,
        peak_rss_mb=round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1),
    )
    return out, times


def plot(times: np.ndarray, path: Path) -> None:
    import matplotlib as mpl

    mpl.use("Agg")
    import matplotlib.pyplot as plt

    path.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(7, 3.5))
    ax.semilogy(np.arange(1, len(times) + 1), times * 1e3, ".", ms=1.5)
    ax.set(xlabel="step (states so far)", ylabel="update time [ms]", title="IncrementalSolver.update per new state")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--states", type=int, default=10_000)
    p.add_argument("--landmarks", type=int, default=6)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--relinearize-threshold", type=float, default=ISAM2Params.relinearize_threshold)
    p.add_argument("--relinearize-skip", type=int, default=ISAM2Params.relinearize_skip)
    p.add_argument("--wildfire-threshold", type=float, default=ISAM2Params.wildfire_threshold)
    p.add_argument("--plot", action="store_true", help="write benchmarks/out/bayes_tree.png")
    a = p.parse_args(argv)
    options = dict(
        relinearize_threshold=a.relinearize_threshold,
        relinearize_skip=a.relinearize_skip,
        wildfire_threshold=a.wildfire_threshold,
    )
    out, times = run(a.states, a.landmarks, a.seed, options)
    if a.plot:
        plot(times, Path(__file__).parent / "out" / "bayes_tree.png")
    json.dump(out, sys.stdout)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
