"""steam_ref's BTGP against GTSAM 4.3's ISAM2 (C++) on the same stream.

For each data set (paper-synthetic, plaza) and schedule (/1, /10), the same front end feeds the same
readings to three solvers, each run in a fresh Python process with the environment as the user has it (no
BLAS or OpenMP thread variable set: steam_ref limits its solvers to one BLAS thread by itself,
:mod:`steam_ref.linear.threads`; GTSAM runs with its own defaults), the three alternating, ``--repeat`` times
(medians reported):

- ``steam``: steam_ref's BTGP (the preset's iSAM2 settings; back-substitution by the per-clique loop, the default);
- (a) ``custom``: GTSAM's ISAM2 (its defaults) with our factors as ``gtsam.CustomFactor``s calling our
  errors and Jacobians from Python (the same model; ``gtsam_callback_s`` is the time inside those calls);
- (b) ``native``: GTSAM's ISAM2 with built-in C++ factors only (``WnoaMotionFactorPose2``,
  ``PriorFactorVector`` on the body velocity, ``RangeFactor2D`` with Tukey, ``PriorFactorPoint2``): the
  SE(2) motion prior, not the paper's, so a yardstick of the machinery rather than the same model.

Every solver is asked for the newest state only after each update (the front end predicts from it);
the RMSE is taken once at the end over every state. One JSON line per (data set, schedule, setup):
``steam_*`` and ``gtsam_*`` wall and CPU seconds of the stream (front end included, imports not),
RMSE, peak memory (ru_maxrss of the child), ``ratio_wall`` / ``ratio_cpu`` = GTSAM's / ours (above 1:
ours is faster), and ours's median update time over the first and the last 1,000 updates (is the
per-update cost flat?). Ours also gives ``steam_backsub_s``, the seconds its updates spent in partial
back-substitution (``UpdateReport.timings``), with its clique solves, and ``ratio_wall_if_backsub_free``:
GTSAM's wall time over ours less that share, the ratio even a free back-substitution could not beat
(docs/experiments.md, "What the targets would need"). The machine may be shared: the ratios, measured in the same sitting, are the
figures to read; CPU seconds are less disturbed by other load than wall seconds.

    python benchmarks/vs_gtsam.py [--repeat 3] [--datasets paper-synthetic,plaza] [--every 1,10]
                                  [--setups custom,native] [--max-poses N] [--quick]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
QUICK_POSES = 300  # --quick: this prefix of every run
KEYS = ("wall_s", "cpu_s", "rmse_m", "peak_rss_mb", "callback_s", "update_first_median_s", "update_last_median_s")
OURS = ("backsub_s", "clique_solves")  # ours only: the back-substitution's share (``phases``)


def child(solver: str, dataset: str, every: int, max_poses: int | None) -> dict:
    """One stream in this process (called in a fresh one): its figures."""
    import numpy as np

    from steam_ref.datasets import load_dataset
    from steam_ref.paper.online import StreamingEstimator
    from steam_ref.paper.options import StreamOptions
    from steam_ref.paper.presets import PaperSetup
    from steam_ref.paper.readings import Readings
    from steam_ref.paper.results import peak_rss_mb, position_rmse
    from steam_ref.variables import X

    setup = PaperSetup.plaza() if dataset == "plaza" else PaperSetup.synthetic()
    data = load_dataset(dataset)
    readings = Readings.from_dataset(data, setup)
    instance = None
    if solver != "steam":
        sys.path.insert(0, str(HERE))
        import gtsam_replica

        instance = gtsam_replica.CustomISAM2() if solver == "custom" else gtsam_replica.NativeISAM2(np.diag(setup.qc))
    options = StreamOptions(method="btgp", max_poses=max_poses)
    est = StreamingEstimator(readings, setup.with_schedule(every=every), options, solver=instance)
    wall, cpu = time.perf_counter(), time.process_time()
    while not est.done:
        est.step()
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    states = est.states[: est.n_solved]
    if solver == "native":
        positions = instance.positions(states)
    else:
        final = est.solver.estimate()
        positions = np.array([final[X(i)][:2] for i in states])
    truth = np.asarray(data.ground_truth)[states, 1:3]
    updates = est.update_seconds
    return phases(est.solver if solver == "steam" else None) | {
        "wall_s": wall,
        "cpu_s": cpu,
        "rmse_m": position_rmse(positions, truth),
        "peak_rss_mb": peak_rss_mb(),
        "callback_s": gtsam_replica.CALLBACK_SECONDS[0] if solver == "custom" else None,
        "n_updates": len(updates),
        "n_poses": est.n_poses,
        "update_first_median_s": statistics.median(updates[:1000]) if updates else None,
        "update_last_median_s": statistics.median(updates[-1000:]) if updates else None,
    }


def phases(solver: object | None) -> dict:
    """Our run's seconds per phase of the iSAM2 update, summed over its updates (the stream's ``phase_seconds``), and
    its clique solves: what a faster back-substitution could save at most (empty for a GTSAM run)."""
    if solver is None:
        return {"phase_s": None, "backsub_s": None, "clique_solves": None}
    totals = dict(solver.phase_seconds)  # type: ignore[attr-defined]
    solves = solver.clique_solves  # type: ignore[attr-defined]
    return {"phase_s": totals, "backsub_s": totals.get("backsubstitute", 0.0), "clique_solves": solves}


def run_child(solver: str, dataset: str, every: int, max_poses: int | None) -> dict:
    args = [sys.executable, __file__, "--child", solver, "--datasets", dataset, "--every", str(every)]
    args += [] if max_poses is None else ["--max-poses", str(max_poses)]
    proc = subprocess.run(args, capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"{solver} on {dataset}/{every} failed: {proc.stderr.strip()[-2000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _median(rows: list[dict], key: str):
    values = [r[key] for r in rows if r[key] is not None]
    return statistics.median(values) if values else None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--datasets", default="paper-synthetic,plaza")
    parser.add_argument("--every", default="1,10")
    parser.add_argument("--setups", default="custom,native", help="GTSAM set-ups: custom (a), native (b)")
    parser.add_argument("--max-poses", type=int, default=None)
    parser.add_argument("--quick", action="store_true", help=f"the first {QUICK_POSES} poses, one repeat")
    parser.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child is not None:
        print(json.dumps(child(args.child, args.datasets, int(args.every), args.max_poses)))
        return
    repeat, max_poses = (1, QUICK_POSES) if args.quick else (args.repeat, args.max_poses)
    setups = args.setups.split(",")
    for dataset in args.datasets.split(","):
        for every in (int(e) for e in args.every.split(",")):
            runs: dict[str, list[dict]] = {s: [] for s in ["steam", *setups]}
            for _ in range(repeat):  # alternating, so that a change of load hits every solver alike
                for solver in runs:
                    runs[solver].append(run_child(solver, dataset, every, max_poses))
            ours = {k: _median(runs["steam"], k) for k in KEYS + OURS}
            without = statistics.median(r["wall_s"] - r["backsub_s"] for r in runs["steam"])
            ours_phases = {
                k: statistics.median(r["phase_s"][k] for r in runs["steam"]) for k in runs["steam"][0]["phase_s"]
            }
            for setup in setups:
                theirs = {k: _median(runs[setup], k) for k in KEYS}
                row = {"dataset": dataset, "every": every, "setup": setup, "repeat": repeat, "max_poses": max_poses}
                row |= {"n_poses": runs["steam"][0]["n_poses"], "n_updates": runs["steam"][0]["n_updates"]}
                row |= {f"steam_{k}": ours[k] for k in KEYS if k != "callback_s"}
                row |= {f"gtsam_{k}": theirs[k] for k in KEYS}
                row["ratio_wall"] = theirs["wall_s"] / ours["wall_s"]
                row["ratio_cpu"] = theirs["cpu_s"] / ours["cpu_s"]
                row |= {"steam_backsub_s": ours["backsub_s"], "steam_clique_solves": ours["clique_solves"]}
                row["steam_phase_s"] = ours_phases
                row["steam_wall_without_backsub_s"] = without  # the stream with back-substitution free
                row["ratio_wall_if_backsub_free"] = theirs["wall_s"] / without  # the most a faster one could reach
                print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
