"""Fixed-lag smoothing: memory and time per update that stay flat, and what the lag costs.

Every run is ``steam-ref run ... --json`` in a fresh Python process (the command itself, called in the
child, which also keeps each update's wall time), with the environment as the user has it: no BLAS or
OpenMP thread variable is set, so the figures are what a user gets (steam_ref runs its solvers at one BLAS
thread by itself, ``$STEAM_REF_BLAS_THREADS`` to change it: :mod:`steam_ref.linear.threads`). One JSON line
per run, then one line of targets:

- ``synthetic``, ``--steps 2000`` and ``--steps 20000`` with ``--lag 30`` (and ``--steps 2000`` without a
  lag, for reference): peak RSS (MB) of the whole process (its scores and output included), update time medians
  of the first and the last 1,000 updates, RMSE, states marginalized, peak window;
- ``plaza`` BTGP/1 without a lag, with ``--lag 60`` (60 s of the file's stamps, about 300 poses 0.2 s apart,
  whatever clock the preset's GP prior runs on), and with ``--lag 60 --lag-history`` (the forgotten states'
  conditionals kept and the past smoothed from the final window at the end: ``rmse_m`` is then the smoothed
  trajectory's, ``rmse_lagged_m`` the estimates' as they left the window; its ``total_s`` includes the backward
  pass): RMSE and total time; and ``plaza, full smoother read
  at the lag``: the full smoother's estimate of each state taken when it is 60 s old (by the data's stamps) (what any smoother that
  reports a state as it leaves a 60 s window can at best give), which separates the cost of reporting lagged
  estimates from the cost of marginalization (first-estimate Jacobians);
- ``targets``: peak memory 20,000 / 2,000 steps ≤ 1.1 once what the user asked for is taken out of both
  (``memory_ratio_less_asked``; ``memory_ratio`` is the raw one). ``asked_mb`` is the bytes of the arrays of what the
  user asked for, which grows with the run by design (``asked_parts_mb``): ``input``, the data set and the readings
  made from it; ``output``, the run's result (the trajectory at every pose, the landmarks, per-step timings);
  ``lagged``, the estimate each forgotten state and landmark left the window with (what a lagged run reports of it);
  ``history``, with ``--lag-history``, the kept conditionals. Array bytes only, so a lower bound of what was asked
  for: everything else (the window, every record and temporary) is counted, and is what must stay flat; last / first
  1,000 updates' median ≤ 1.2 (both within
  the 20,000-step run), Plaza's RMSE with the lag (its past smoothed at the end) within 2 cm of the full
  smoother's (the estimates as they left the window are reported beside it, ``plaza_lagged_rmse_gap_m``), and
  the lagged runs' time no higher
  (ratios of medians over ``--repeat`` runs; the machine is shared, so single runs are noisy).

Plot: benchmarks/out/fixed_lag.png (update time along the run, rolling median; peak memory by run).

    python benchmarks/fixed_lag.py [--repeat 1] [--long 20000] [--short 2000] [--no-plaza] [--batch 0]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parent / "out"
TARGET_MEMORY, TARGET_FLAT, TARGET_RMSE_M = 1.1, 1.2, 0.02

_LAGGED_READ = r"""
import json, sys
import numpy as np
from steam_ref.datasets import load_dataset
from steam_ref.paper.online import StreamingEstimator
from steam_ref.paper.options import StreamOptions
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.readings import Readings
from steam_ref.variables import X
lag = float(sys.argv[1])
data, setup = load_dataset("plaza"), PaperSetup.plaza()
readings = Readings.from_dataset(data, setup)
est, read, t = StreamingEstimator(readings, setup, StreamOptions()), {}, readings.times
while not est.done:
    est.step()
    solved = est.states[: est.n_solved]
    for i in (i for i in solved if i not in read and t[i] < t[solved[-1]] - lag) if solved else ():
        read[i] = est.solver.estimate_of(X(i))[:2].copy()
xy = np.array([read.get(i, est.solver.estimate_of(X(i))[:2]) for i in est.states])
truth = data.ground_truth[est.states, 1:3]
print(json.dumps({"rmse_m": float(np.sqrt(np.mean(np.sum((xy - truth) ** 2, axis=1)))), "n_poses": len(est.states)}))
"""

_CHILD = r"""
import json, sys
import numpy as np
import steam_ref.cli.commands as cli
import steam_ref.cli.run as command
from steam_ref.paper.online import StreamingEstimator
kept = {}
run, dataset = StreamingEstimator.run, command._run_dataset
def arrays(obj, seen):
    # bytes of the NumPy arrays an object holds, through its fields, dicts, lists and tuples (each object once)
    if id(obj) in seen:
        return 0
    seen[id(obj)] = obj
    if isinstance(obj, np.ndarray):
        return obj.nbytes
    if isinstance(obj, dict):
        return sum(arrays(v, seen) for v in obj.values())
    if isinstance(obj, (list, tuple)):
        return sum(arrays(v, seen) for v in obj)
    return sum(arrays(v, seen) for v in vars(obj).values()) if hasattr(obj, "__dict__") else 0
def read(args):
    kept["data"] = data = dataset(args)
    return data
def spy(self, *args, **kwargs):
    kept["result"] = result = run(self, *args, **kwargs)
    seen, solver = {}, vars(self.solver)  # what the user asked for, growing with the run by design (MB):
    asked = {
        "input": arrays(kept["data"], seen) + arrays(self.readings, seen),  # the data set, its readings
        "output": arrays(vars(result), seen)  # the trajectory at every pose, landmarks, per-step timings
        + sum(a.itemsize * len(a) for a in (self.step_seconds, self.update_steps, self.update_seconds)),
        # the estimates each forgotten variable left the window with: what a lagged run reports of it
        "lagged": sum(arrays(solver.get(name), seen) for name in ("_states", "_retired_states", "_landmarks")),
        "history": arrays(getattr(self.solver.inner, "history", None), seen),  # --lag-history's conditionals
    }
    kept["asked"] = {k: round(v / 1e6, 3) for k, v in asked.items()}
    return result
StreamingEstimator.run, command._run_dataset = spy, read
code = cli.main(json.loads(sys.argv[1]))
np.save(sys.argv[2], kept["result"].update_seconds)
import resource
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # the whole process's, scores and output included
print(json.dumps({"asked_mb": round(sum(kept["asked"].values()), 3), "asked_parts_mb": kept["asked"], "peak_rss_mb": peak}))
sys.exit(code)
"""


def run(argv: list[str]) -> tuple[dict, np.ndarray]:
    """``steam-ref run <argv> --json`` in a fresh process: its JSON line and each update's seconds."""
    with tempfile.TemporaryDirectory() as tmp:
        times = Path(tmp) / "updates.npy"
        proc = subprocess.run(
            [sys.executable, "-c", _CHILD, json.dumps(["run", *argv, "--json"]), str(times)],
            capture_output=True,
            text=True,
        )
        if proc.returncode != 0:
            raise RuntimeError(f"steam-ref run {' '.join(argv)} failed: {proc.stderr.strip()[-400:]}")
        lines = proc.stdout.strip().splitlines()
        return json.loads(lines[-2]) | json.loads(lines[-1]), np.load(times)


def lagged_read(lag: float) -> dict:
    """The full smoother on Plaza, each state's estimate read when it is ``lag`` seconds old (fresh process)."""
    proc = subprocess.run([sys.executable, "-c", _LAGGED_READ, f"{lag:g}"], capture_output=True, text=True)
    if proc.returncode != 0:
        raise RuntimeError(f"the lagged read of the full smoother failed: {proc.stderr.strip()[-400:]}")
    out = {"row": "plaza, full smoother read at the lag", "lag_s": lag} | json.loads(
        proc.stdout.strip().splitlines()[-1]
    )
    print(json.dumps(out), flush=True)
    return out


def row(name: str, argv: list[str], repeat: int) -> tuple[dict, np.ndarray]:
    """Medians over ``repeat`` runs of one command; the update times of the first run."""
    runs = [run(argv) for _ in range(repeat)]
    first, updates = runs[0]
    out = {"row": name, "command": "steam-ref run " + " ".join(argv)}
    for key in ("n_poses", "rmse_m", "rmse_lagged_m", "n_marginalized", "peak_window", "lag_s"):
        out[key] = first.get(key)
    for key in ("peak_rss_mb", "update_s_median"):
        out[key] = statistics.median(r[key] for r, _ in runs)
    out["asked_mb"] = statistics.median(r.get("asked_mb", 0.0) for r, _ in runs)  # input, output, lagged, history
    out["asked_parts_mb"] = first.get("asked_parts_mb")
    # with --lag-history the backward pass runs after the stream, outside total_s: it is counted here
    out["total_s"] = statistics.median(r["total_s"] + (r.get("history_smoothing_s") or 0.0) for r, _ in runs)
    if len(updates) >= 2000:
        out["update_s_median_first_1000"] = statistics.median(float(np.median(u[:1000])) for _, u in runs)
        out["update_s_median_last_1000"] = statistics.median(float(np.median(u[-1000:])) for _, u in runs)
    print(json.dumps(out), flush=True)
    return out, updates


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=1, help="runs per row (medians reported)")
    p.add_argument("--long", type=int, default=20000, help="steps of the long generated run")
    p.add_argument("--short", type=int, default=2000, help="steps of the short generated run")
    p.add_argument("--lag", type=float, default=30.0, help="lag of the generated runs, seconds")
    p.add_argument("--plaza-lag", type=float, default=60.0, help="lag of the Plaza run, seconds")
    p.add_argument("--batch", type=float, default=0.0, help="--lag-batch of every lagged run, seconds (0: none)")
    p.add_argument("--no-plaza", action="store_true", help="skip Plaza (needs the paper's data)")
    a = p.parse_args(argv)
    lag = ["--lag", f"{a.lag:g}", "--lag-batch", f"{a.batch:g}"]
    short, short_u = row("synthetic", ["--steps", str(a.short), *lag], a.repeat)
    long, long_u = row("synthetic", ["--steps", str(a.long), *lag], a.repeat)
    full, full_u = row("synthetic, no lag", ["--steps", str(a.short)], a.repeat)
    targets: dict = {
        "row": "targets",
        "memory_ratio": round(long["peak_rss_mb"] / short["peak_rss_mb"], 3),
        # what the user asked for (the data read, the output: trajectory, per-step timings...) taken out of both
        "memory_ratio_less_asked": round(
            (long["peak_rss_mb"] - long["asked_mb"]) / (short["peak_rss_mb"] - short["asked_mb"]), 3
        ),
        "update_time_ratio_last_first": None,  # needs 2,000 updates or more
    }
    if "update_s_median_first_1000" in long:
        ratio = long["update_s_median_last_1000"] / long["update_s_median_first_1000"]
        targets["update_time_ratio_last_first"] = round(ratio, 3)
        targets["flat_meets"] = ratio <= TARGET_FLAT
    targets["memory_meets"] = targets["memory_ratio_less_asked"] <= TARGET_MEMORY
    plaza_rows = []
    if not a.no_plaza:
        base = ["--dataset", "plaza", "--method", "btgp", "--every", "1"]
        plaza_full, _ = row("plaza", base, a.repeat)
        plaza_lag, _ = row("plaza", [*base, "--lag", f"{a.plaza_lag:g}", "--lag-batch", f"{a.batch:g}"], a.repeat)
        hist = [*base, "--lag", f"{a.plaza_lag:g}", "--lag-batch", f"{a.batch:g}", "--lag-history"]
        plaza_hist, _ = row("plaza", hist, a.repeat)
        plaza_rows = [plaza_full, plaza_lag, plaza_hist]
        read = lagged_read(a.plaza_lag)
        targets["plaza_full_read_at_lag_rmse_m"] = read["rmse_m"]
        targets["plaza_lagged_rmse_gap_m"] = round(plaza_lag["rmse_m"] - plaza_full["rmse_m"], 6)
        targets["plaza_rmse_gap_m"] = round(plaza_hist["rmse_m"] - plaza_full["rmse_m"], 6)
        targets["plaza_time_ratio"] = round(plaza_lag["total_s"] / plaza_full["total_s"], 3)
        targets["plaza_history_time_ratio"] = round(plaza_hist["total_s"] / plaza_full["total_s"], 3)
        targets["plaza_rmse_meets"] = abs(targets["plaza_rmse_gap_m"]) <= TARGET_RMSE_M
        targets["plaza_time_meets"] = max(targets["plaza_time_ratio"], targets["plaza_history_time_ratio"]) <= 1.0
    print(json.dumps(targets), flush=True)
    plot([(short, short_u), (long, long_u), (full, full_u)], plaza_rows)


def plot(runs: list[tuple[dict, np.ndarray]], plaza: list[dict]) -> None:
    """Update time along each generated run (rolling median of 201) and peak memory by run."""
    import matplotlib as mpl

    mpl.use("Agg")
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 4))
    left, right = fig.subplots(1, 2)
    for info, updates in runs:
        k = min(201, len(updates))
        rolling = np.array([np.median(updates[max(0, i - k // 2) : i + k // 2 + 1]) for i in range(len(updates))])
        lag = info["lag_s"]
        label = f"{info['n_poses']} poses, " + ("no lag" if lag is None else f"lag {lag:g} s")
        left.plot(np.arange(1, len(updates) + 1), 1e3 * rolling, label=label)
    left.set_xlabel("update")
    left.set_ylabel("update time, ms (rolling median of 201)")
    left.set_xscale("log")
    left.legend()
    bars = [
        (f"{i['n_poses']} poses\n" + ("no lag" if i["lag_s"] is None else f"lag {i['lag_s']:g} s"), i) for i, _ in runs
    ]
    bars += [
        (
            "Plaza\n"
            + ("no lag" if i["lag_s"] is None else f"lag {i['lag_s']:g} s")
            + ("\n+ history" if i["rmse_lagged_m"] else ""),
            i,
        )
        for i in plaza
    ]
    right.bar(range(len(bars)), [i["peak_rss_mb"] for _, i in bars])
    right.set_xticks(range(len(bars)), [name for name, _ in bars], fontsize=8)
    right.set_ylabel("peak RSS, MB")
    fig.tight_layout()
    OUT.mkdir(exist_ok=True)
    fig.savefig(OUT / "fixed_lag.png", dpi=110)
    print(f"# plot: {OUT / 'fixed_lag.png'}", file=sys.stderr)


if __name__ == "__main__":
    main()
