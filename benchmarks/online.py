"""Streamed runs of BTGP, PB and PBVR on the paper's data sets.  [YIB Sec. IV, Fig. 3/4]

Prints one JSON line per (dataset, method, every, skip, interpolate) with the keys of
``steam-ref run --json`` (dataset, method, every, skip, interpolate, n_estimated_states, rmse_m,
total_s, update_s_median, update_s_p95, peak_rss_mb, ...), where total_s and the update times are
medians over ``--repeat`` runs (each run in a fresh process, so peak_rss_mb is per run). PB and
PBVR run under ``--batch-budget`` seconds (completed: false, n_poses = the prefix they covered);
``speedup_vs_btgp`` is then the ratio of their time to BTGP's over that same prefix.

    python benchmarks/online.py [--datasets paper-synthetic plaza synthetic] [--repeat 3]
                                [--methods btgp pb pbvr] [--every 1 10] [--skips 1]
                                [--no-interpolate] [--batch-budget 60]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys

import numpy as np

_CHILD = r"""
import json, sys
import numpy as np
from steam_ref.datasets import load_dataset
from steam_ref.online import default_options, run_online
from steam_ref.problem import PaperSetup
name, preset, kw = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
data = load_dataset(name)
setup = PaperSetup.named(preset)
result = run_online(data, setup, default_options(setup, **kw))
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
    row["step_seconds"] = np.median(np.array([r["step_seconds"] for r in runs if len(r["step_seconds"]) == len(runs[0]["step_seconds"])]), axis=0).tolist()
    return row


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--datasets", nargs="+", default=["paper-synthetic", "plaza"])
    parser.add_argument("--methods", nargs="+", default=["btgp", "pb", "pbvr"])
    parser.add_argument("--every", nargs="+", type=int, default=[1])
    parser.add_argument("--skips", nargs="+", type=int, default=[1])
    parser.add_argument("--no-interpolate", action="store_true", help="also run each skip > 1 without interpolation")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--batch-budget", type=float, default=60.0, help="seconds per PB/PBVR run")
    args = parser.parse_args()
    for dataset in args.datasets:
        for skip in args.skips:
            for interpolate in ([True, False] if args.no_interpolate and skip > 1 else [True]):
                btgp_steps = None
                for method in sorted(args.methods, key=lambda m: m != "btgp"):
                    for every in args.every:
                        options = dict(method=method, every=every, skip=skip, interpolate=interpolate)
                        repeat = args.repeat
                        if method != "btgp":
                            options["time_budget_s"] = args.batch_budget
                            repeat = 1  # budget-bound: one run
                        row = median_run(dataset, options, repeat)
                        steps = row.pop("step_seconds")
                        if method == "btgp" and every == args.every[0]:
                            btgp_steps = steps
                        elif btgp_steps is not None:
                            n = min(len(steps), len(btgp_steps))
                            row["speedup_vs_btgp"] = round(sum(steps[:n]) / sum(btgp_steps[:n]), 1)
                            row["prefix_steps"] = n
                        print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
