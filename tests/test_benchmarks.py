"""The benchmarks of the issues closed last still start and print what they promise, in miniature.

A benchmark is not a timed test (its figures are read by people, in docs/experiments.md); but one that
fails on start, as benchmarks/fixed_lag.py once did when the CLI stopped calling the function it spied
on, is a broken README command. Each runs here on a tiny task; the checks are on what it prints.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

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
