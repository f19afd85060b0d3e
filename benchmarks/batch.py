"""Batch sparse GP regression on the paper's data sets: PB (XL ordering) against PBVR (AMD).  [YIB Sec. II]

Prints one JSON line per data set:
  dataset, n_states, n_landmarks, n_factors,
  linearize_s            median of 5: linearize every factor and assemble the sparse A, b (Eq. 10, 21)
  solve_s {xl, amd}      median of 5: form 𝓘 = AᵀA, factor it and solve Eq. 11 under each ordering
  ordering_s             median of 5: computing the AMD ordering (done once per batch)
  gn_step_s              linearize_s + solve_s.amd: one full Gauss-Newton step
  factor_nnz {xl, amd}   nonzeros of the Cholesky factor 𝓛 under each ordering (Fig. 3's fill-in)
  backend                sparse Cholesky used (cholmod or superlu)
  rmse_m                 position RMSE against ground truth of the converged batch on all the data
  batch_s, iterations    wall time and Gauss-Newton iterations of that converged solve

The converged batch starts from dead reckoning extended chunk by chunk (steam_ref.paper.problem.sequential_batch):
plain dead reckoning is about 21 m off on the synthetic set and Gauss-Newton from it stops in a local minimum.
Plots of estimate against ground truth go to benchmarks/out/.

    python benchmarks/batch.py [--datasets paper-synthetic plaza] [--repeat 5] [--backend cholmod|superlu]
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

import numpy as np

import steam_ref as sr
from steam_ref.datasets import load_dataset
from steam_ref.linear import LinearSystem, SparseCholesky, linearize, sparse_backend
from steam_ref.linear.ordering import make_ordering
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.problem import build_problem, sequential_batch
from steam_ref.paper.results import position_rmse

OUT = Path(__file__).resolve().parent / "out"


def median_time(fn, repeat: int) -> tuple[float, object]:
    times, result = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), result


def measure(name: str, repeat: int, backend: str) -> dict:
    data = load_dataset(name)
    setup = PaperSetup.synthetic() if "synthetic" in name else PaperSetup.plaza()
    problem = build_problem(data, setup)
    graph, values = problem.graph, problem.initial
    orders = {"xl": make_ordering("xl", graph.keys(), values.dims(), [f.keys for f in graph])}
    ordering_s, orders["amd"] = median_time(
        lambda: make_ordering("amd", graph.keys(), values.dims(), [f.keys for f in graph], backend), repeat
    )
    linearize_s, _ = median_time(
        lambda: LinearSystem.from_groups(linearize(graph.factors, values), orders["xl"]), repeat
    )
    solve_s, nnz = {}, {}
    for key, order in orders.items():
        system = LinearSystem.from_groups(linearize(graph.factors, values), order)

        def factor_and_solve(system=system, order=order):
            info, rhs = system.information()
            chol = SparseCholesky.factor(info, order, backend)
            chol.solve(rhs)
            return chol

        solve_s[key], chol = median_time(factor_and_solve, repeat)
        nnz[key] = chol.nnz
    t0 = time.perf_counter()
    result = sequential_batch(problem, chunk=100 if "synthetic" in name else 500, backend=backend)
    batch_s = time.perf_counter() - t0
    positions = np.array([result.values[sr.X(i)][:2] for i in range(data.n_poses)])
    plot(name, data, positions, problem)
    return {
        "dataset": name,
        "n_states": len(problem.states),
        "n_landmarks": len(values.landmarks()),
        "n_factors": len(graph),
        "linearize_s": round(linearize_s, 4),
        "solve_s": {k: round(v, 4) for k, v in solve_s.items()},
        "ordering_s": round(ordering_s, 4),
        "gn_step_s": round(linearize_s + solve_s["amd"], 4),
        "factor_nnz": nnz,
        "backend": backend,
        "rmse_m": round(position_rmse(positions, data.ground_truth[:, 1:3]), 5),
        "batch_s": round(batch_s, 2),
        "iterations": len(result.iterations),
    }


def plot(name: str, data, positions: np.ndarray, problem) -> None:
    import matplotlib as mpl

    mpl.use("Agg")
    import matplotlib.pyplot as plt

    OUT.mkdir(exist_ok=True)
    fig, ax = plt.subplots(figsize=(6, 6))
    ax.plot(*data.ground_truth[:, 1:3].T, "g-", lw=1, label="ground truth")
    dr = np.array([problem.initial[sr.X(i)][:2] for i in problem.states])
    ax.plot(*dr.T, ":", color="gray", lw=1, label="dead reckoning")
    ax.plot(*positions.T, "b-", lw=0.8, label="batch estimate")
    ax.plot(*data.landmarks[:, 1:3].T, "g*", label="landmarks")
    ax.set_aspect("equal")
    ax.set_title(f"{name}: batch sparse GP regression")
    ax.legend(loc="best", fontsize=8)
    fig.savefig(OUT / f"batch_{name}.png", dpi=120, bbox_inches="tight")
    plt.close(fig)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--datasets", nargs="+", default=["paper-synthetic", "plaza"])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--backend", default=None, help="cholmod or superlu (default: cholmod if installed)")
    args = parser.parse_args()
    backend = sparse_backend(args.backend)
    for name in args.datasets:
        print(json.dumps(measure(name, args.repeat, backend)), flush=True)


if __name__ == "__main__":
    main()
