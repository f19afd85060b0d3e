"""The benchmarks of the issues closed last still start and print what they promise, in miniature.

A benchmark is not a timed test (its figures are read by people, in docs/experiments.md); but one that
fails on start, as benchmarks/fixed_lag.py once did when the CLI stopped calling the function it spied
on, is a broken README command. Each runs here on a tiny task; the checks are on what it prints.
"""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"


def _rows(script: str, *argv: str, cwd: Path) -> list[dict]:
    proc = subprocess.run(
        [sys.executable, str(BENCH / script), *argv], capture_output=True, text=True, cwd=cwd, timeout=300
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    return [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]


def test_fixed_lag_benchmark_reports_the_window(tmp_path):
    rows = _rows("fixed_lag.py", "--short", "40", "--long", "80", "--lag", "5", "--no-plaza", cwd=tmp_path)
    short, long, full, targets = rows
    assert short["n_poses"] == 41 and long["n_poses"] == 81 and full["lag_s"] is None
    assert long["n_marginalized"] > 0 and long["peak_window"] < 40 and full["n_marginalized"] is None
    assert targets["row"] == "targets" and targets["memory_ratio"] > 0
    assert targets["update_time_ratio_last_first"] is None  # fewer than 2,000 updates: no flatness figure


def test_consistency_benchmark_gives_the_same_figures_in_parallel(tmp_path):
    rows = _rows("consistency.py", "--seeds", "4", "--jobs", "2", "--plot", str(tmp_path / "c.png"), cwd=tmp_path)
    sitting, last = rows
    assert sitting["seeds"] == 4 and sitting["same_figures"] is True and sitting["ratio"] > 0
    assert set(last["anees"]) >= {"batch", "btgp/1", "btgp/10"} and (tmp_path / "c.png").stat().st_size > 0


def test_fixed_lag_benchmark_counts_the_backward_pass_in_a_history_row(capsys, monkeypatch):
    """The Plaza rows' --lag-history path, on the generated task; and its total is step time plus the backward pass."""
    spec = importlib.util.spec_from_file_location("fixed_lag_benchmark", BENCH / "fixed_lag.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    out, updates = bench.row("synthetic", ["--steps", "60", "--lag", "5", "--lag-history"], 1)
    assert out["rmse_lagged_m"] is not None and out["rmse_lagged_m"] != out["rmse_m"] and len(updates) == 60
    assert json.loads(capsys.readouterr().out.splitlines()[-1])["command"].endswith("--lag-history")
    line = {"total_s": 2.0, "peak_rss_mb": 100.0, "update_s_median": 0.01, "rmse_m": 0.1, "rmse_lagged_m": 0.2}
    monkeypatch.setattr(bench, "run", lambda argv: (line | {"history_smoothing_s": 0.25}, np.zeros(10)))
    assert bench.row("history", [], 1)[0]["total_s"] == 2.25
    monkeypatch.setattr(bench, "run", lambda argv: (line, np.zeros(10)))
    assert bench.row("no history", [], 1)[0]["total_s"] == 2.0


def test_vs_gtsam_benchmark_reports_the_backsubstitution_share(shared_data):
    """Ours' row carries the seconds its updates spent in back-substitution, which the phases add up to."""
    spec = importlib.util.spec_from_file_location("vs_gtsam_benchmark", BENCH / "vs_gtsam.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    out = bench.child("steam", "paper-synthetic", 1, 40)
    assert out["n_updates"] == 39 and out["clique_solves"] >= out["n_updates"]  # at least the new root each update
    assert out["backsub_s"] == out["phase_s"]["backsubstitute"] > 0
    assert 0 < sum(out["phase_s"].values()) <= out["wall_s"]  # the phases are inside the stream's time
    assert bench.phases(None) == {"phase_s": None, "backsub_s": None, "clique_solves": None}  # a GTSAM run has none


def test_against_commit_benchmark_runs_both_trees_and_finds_the_same_estimate(shared_data, tmp_path):
    """The earlier commit is extracted from git and run beside this tree: both give the same RMSE on a prefix."""
    (row,) = _rows(
        "against_commit.py", "--pairs", "1", "--dataset", "paper-synthetic", "--max-poses", "60", cwd=tmp_path
    )
    assert row["ref"] == "a80dcd0" and len(row["runs"]["ref"]) == len(row["runs"]["now"]) == 1
    assert len(row["rmse_m"]) == 1  # the bookkeeping since then changed no estimate
    assert all(row["ratio_now_over_ref"][k] > 0 for k in ("total_s", "update_s_median", "peak_rss_mb"))
