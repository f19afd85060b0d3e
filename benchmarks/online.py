"""Streamed runs of BTGP, PB and PBVR on the paper's data sets.  [YIB Sec. IV, Fig. 3/4]

Prints one JSON line per (dataset, method, every, skip, interpolate) with the keys of
``steam-ref run --json`` (dataset, method, every, skip, interpolate, n_estimated_states, rmse_m,
total_s, update_s_median, update_s_p95, peak_rss_mb, ...), where total_s and the update times are
medians over ``--repeat`` runs (each run in a fresh process, so peak_rss_mb is per run).

``speedup_vs_btgp`` is PB's (PBVR's) time over BTGP's. With ``--max-poses N`` every method runs
the same N-pose prefix ``--repeat`` times and the ratio is of the median totals. Otherwise PB and
PBVR run once under ``--batch-budget`` seconds (completed: false, n_poses = the prefix they
covered) and the ratio is over the steps both covered. The median cumulative times are drawn in
benchmarks/out/online_<dataset>.png.

    python benchmarks/online.py [--datasets paper-synthetic plaza synthetic] [--repeat 3]
                                [--methods btgp pb pbvr] [--every 1 10] [--skips 1]
                                [--no-interpolate] [--range-states] [--max-poses N] [--batch-budget S]

The speed-up figures of docs/experiments.md:

    python benchmarks/online.py --datasets paper-synthetic --methods btgp pb --max-poses 600
    python benchmarks/online.py --datasets plaza --methods btgp pb --max-poses 4000
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parent / "out"

_CHILD = r"""
import json, sys
import numpy as np
from steam_ref.datasets import load_dataset
from steam_ref.paper.online import run_online
from steam_ref.paper.options import StreamOptions
from steam_ref.paper.presets import PaperSetup
name, preset, kw = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
data = load_dataset(name)
setup = PaperSetup.named(preset).with_schedule(every=kw.pop("every"))
result = run_online(data, setup, StreamOptions(**kw))
row = result.summary(name)
row["step_seconds"] = result.step_seconds.tolist()
print(json.dumps(row))
"""

PRESET = {"synthetic": "synthetic", "paper-synthetic": "synthetic", "plaza": "plaza"}


def run_once(dataset: str, options: dict) -> dict:
    """One streamed run in a fresh Python process (clean peak memory); its summary with step times."""
    proc = subprocess.run(
        [sys.executable, "-c", _CHILD, dataset, PRESET[dataset], json.dumps(options)], capture_output=True, text=True
    )
    if proc.returncode != 0:
        raise RuntimeError(f"{dataset} {options}: {proc.stderr.strip().splitlines()[-1] if proc.stderr else 'failed'}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def median_run(dataset: str, options: dict, repeat: int) -> dict:
    """Median timing figures of ``repeat`` runs (the estimate is deterministic)."""
    runs = [run_once(dataset, options) for _ in range(repeat)]
    row = dict(runs[0])
    for key in ("total_s", "update_s_median", "update_s_p95", "peak_rss_mb"):
        row[key] = statistics.median(r[key] for r in runs)
    row["repeat"] = repeat
    row["step_seconds"] = np.median(
        np.array([r["step_seconds"] for r in runs if len(r["step_seconds"]) == len(runs[0]["step_seconds"])]), axis=0
    ).tolist()
    return row


def _plot(dataset: str, curves: list[tuple[str, list[float]]]) -> Path:
    """Cumulative time against time step for every run of one data set (Fig. 3/4 left)."""
    import matplotlib as mpl

    mpl.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for label, steps in curves:
        ax.plot(np.cumsum(steps), label=label)
    ax.set(xlabel="time step", ylabel="cumulative time [s]", title=f"{dataset}: median step times", yscale="log")
    ax.legend()
    OUT.mkdir(exist_ok=True)
    path = OUT / f"online_{dataset}.png"
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
    return path


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--datasets", nargs="+", default=["paper-synthetic", "plaza"])
    parser.add_argument("--methods", nargs="+", default=["btgp", "pb", "pbvr"])
    parser.add_argument("--every", nargs="+", type=int, default=[1])
    parser.add_argument("--skips", nargs="+", type=int, default=[1])
    parser.add_argument("--no-interpolate", action="store_true", help="also run each skip > 1 without interpolation")
    parser.add_argument(
        "--range-states",
        action="store_true",
        help="also a state at every range reading (the paper's Plaza layout with --skips 5)",
    )
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument(
        "--max-poses", type=int, default=None, help="run every method on this prefix (PB/PBVR then repeat too)"
    )
    parser.add_argument(
        "--batch-budget",
        type=float,
        default=None,
        help="seconds per PB/PBVR run (default: 60 without --max-poses, none with it)",
    )
    args = parser.parse_args()
    budget = args.batch_budget if args.batch_budget is not None or args.max_poses else 60.0
    layouts = [
        (skip, interp)
        for skip in args.skips
        for interp in ([True, False] if args.no_interpolate and skip > 1 else [True])
    ]
    runs = [(method, every) for method in sorted(args.methods, key=lambda m: m != "btgp") for every in args.every]
    for dataset in args.datasets:
        curves = []
        for skip, interpolate in layouts:
            btgp = None  # (row, step times) of the BTGP run the others are compared with
            for method, every in runs:
                options = dict(
                    method=method, every=every, skip=skip, interpolate=interpolate, range_states=args.range_states
                )
                if args.max_poses:
                    options["max_poses"] = args.max_poses
                repeat = args.repeat
                if method != "btgp" and budget is not None:
                    options["time_budget_s"] = budget
                    repeat = 1  # budget-bound: one run
                row = median_run(dataset, options, repeat)
                steps = row.pop("step_seconds")
                curves.append((f"{method.upper()}/{every} skip {skip}{'' if interpolate else ' no interp.'}", steps))
                if method == "btgp" and every == args.every[0]:
                    btgp = (row, steps)
                elif btgp is not None:
                    row["speedup_vs_btgp"], row["prefix_steps"] = speedup(row, steps, *btgp)
                print(json.dumps(row), flush=True)
        print(f"# plot: {_plot(dataset, curves)}", file=sys.stderr)


def speedup(row: dict, steps: list[float], btgp_row: dict, btgp_steps: list[float]) -> tuple[float, int]:
    """(time ratio to BTGP, steps compared): of the median totals when both covered the same steps,
    else of the step times over the prefix both covered (a budget cut the slower run)."""
    if len(steps) == len(btgp_steps):
        return round(row["total_s"] / btgp_row["total_s"], 1), len(steps)
    n = min(len(steps), len(btgp_steps))
    return round(sum(steps[:n]) / sum(btgp_steps[:n]), 1), n


if __name__ == "__main__":
    main()
