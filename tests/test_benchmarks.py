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
import pytest
from requirements import optional_import

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
    """The earlier commit is extracted from git and run beside this tree: both solve the same problem on a prefix,
    to within the wildfire threshold's tolerance (the presets now merge cliques, ``PAPER_AMALGAMATION_ZEROS``)."""
    (row,) = _rows(
        "against_commit.py", "--pairs", "1", "--dataset", "paper-synthetic", "--max-poses", "60", cwd=tmp_path
    )
    assert row["ref"] == "a80dcd0" and len(row["runs"]["ref"]) == len(row["runs"]["now"]) == 1
    rmse = {run["rmse_m"] for runs in row["runs"].values() for run in runs}
    assert row["rmse_m"] == sorted(rmse) and max(rmse) - min(rmse) < 1e-3  # α = 10⁻³: what a merged clique refreshes
    assert all(row["ratio_now_over_ref"][k] > 0 for k in ("total_s", "update_s_median", "peak_rss_mb"))


def _vs_gtsam():
    spec = importlib.util.spec_from_file_location("vs_gtsam_benchmark", BENCH / "vs_gtsam.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    return bench


def test_vs_gtsam_default_rows_are_the_targets_and_an_se2_row_reads_the_vector_run():
    """One run holds the paper's three rows, the whole-Plaza SE(2) row and a fixed-lag row; an SE(2) row divides its
    CPU by the vector-space run of the same schedule, each alternating pair too; a failed run makes a row saying so."""
    bench = _vs_gtsam()
    rows = bench.parse_rows(bench.ROWS)
    assert rows == [
        ("plaza", "wnoa", 1, "native", None),
        ("plaza", "wnoa", 10, "native", None),
        ("paper-synthetic", "wnoa", 1, "custom", None),
        ("plaza", "se2", 1, "native", None),
        ("plaza", "wnoa", 10, "native", 60.0),
    ]
    run = dict.fromkeys(bench.KEYS + bench.OURS, 1.0) | {
        "n_poses": 9,
        "n_updates": 3,
        "phase_s": {"backsubstitute": 0.5},
    }
    run |= {"backsub_s": 0.5, "wall_s": 2.0, "n_marginalized": None}
    runs = {
        ("steam", "plaza", "se2", 1, None): [run | {"cpu_s": 3.0}, run | {"cpu_s": 5.0}],
        ("steam", "plaza", "wnoa", 1, None): [run | {"cpu_s": 2.0}, run | {"cpu_s": 4.0}],
        ("native", "plaza", "se2", 1, None): [run | {"cpu_s": 6.0}, run | {"cpu_s": 4.0}],
        ("native", "plaza", "wnoa", 10, 60.0): [{"failed": "IndexError: V415"}],
        ("steam", "plaza", "wnoa", 10, 60.0): [run],
    }
    se2 = bench.row_of(runs, "plaza", "se2", 1, "native", None, 2, None, "last-seen")
    assert se2["ratio_cpu_over_vector"] == 4.0 / 3.0 and se2["ratio_cpu_over_vector_pairs"] == [1.5, 1.25]
    assert se2["ratio_cpu"] == 1.25 and se2["ratio_cpu_pairs"] == [2.0, 0.8]
    lagged = bench.row_of(runs, "plaza", "wnoa", 10, "native", 60.0, 1, None, "unstamped")
    assert (
        lagged["failed"] == "IndexError: V415"
        and lagged["gtsam_landmarks"] == "unstamped"
        and "ratio_cpu" not in lagged
    )


def test_gtsam_fixed_lag_smoother_runs_the_plaza_stream_with_landmarks_stamped_when_last_seen(shared_data):
    """GTSAM's IncrementalFixedLagSmoother behind the stream (landmarks stamped as ours stamps them) forgets states and
    answers for them as they left; so does ours, on the same prefix."""
    optional_import("gtsam", "gtsam")  # skips here, fails in CI (STEAM_REF_REQUIRE_OPTIONAL=1)
    bench = _vs_gtsam()
    theirs = bench.child("native", "plaza", 10, 600, lag=20.0)
    ours = bench.child("steam", "plaza", 10, 600, lag=20.0)
    assert theirs["n_marginalized"] > 0 and ours["n_marginalized"] > 0
    assert theirs["rmse_m"] < 1.0 and ours["rmse_m"] < 1.0 and theirs["n_poses"] == ours["n_poses"] == 600


def test_phases_benchmark_profiles_both_trees_phase_by_phase(tmp_path):
    """Each phase of the update has its medians at both trees and their ratio; the phases lie inside the updates,
    the updates inside the stream; a child run against a tree its steam_ref does not come from refuses to run."""
    (row,) = _rows("phases.py", "--quick", "--max-poses", "40", "--rows", "synthetic/1", "--ref", "HEAD", cwd=tmp_path)
    assert row["row"] == "synthetic/1" and row["ref"] == "HEAD" and row["repeat"] == 1 and row["n_poses"] == 40
    assert row["clock"] == "cpu"  # the phases in CPU seconds by default
    phases = {"check", "add", "relinearize", "remove", "linearize", "order", "eliminate", "backsubstitute", "sum"}
    assert set(row["phase_s"]) == phases
    for figure in [*row["phase_s"].values(), row["update_rest_s"], row["outside_updates_s"], row["wall_s"]]:
        assert figure["ref"] >= 0 and figure["here"] >= 0
    assert 0 < row["phase_s"]["sum"]["here"] < row["cpu_s"]["here"] and row["outside_updates_s"]["here"] > 0
    assert row["ratio_wall"] > 0 and row["ratio_cpu"] > 0 and len(row["ratio_cpu_pairs"]) == 1
    (updates,) = row["n_updates"]["here"]
    assert updates == 39 and row["cliques_solved"]["here"][0] >= updates  # at least the new root each update
    assert row["cliques_eliminated"]["here"][0] >= updates and len(row["rmse_m"]["here"]) == 1

    spec = importlib.util.spec_from_file_location("phases_benchmark", BENCH / "phases.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    with pytest.raises(SystemExit, match="not from the tree"):
        bench.child("synthetic", 1, 10, tmp_path)


def test_tree_fill_benchmark_builds_gtsams_cliques_when_told(shared_data, tmp_path):
    """docs/conformance.md quotes the fill of both trees: the preset's merged cliques (the default) and GTSAM's
    (``--amalgamation-zeros 0``), whose count is ISAM2::treeNnz's. Merging fewer, larger cliques stores zeros."""
    (merged,) = _rows("tree_fill.py", "--datasets", "paper-synthetic", cwd=tmp_path)
    (gtsams,) = _rows("tree_fill.py", "--datasets", "paper-synthetic", "--amalgamation-zeros", "0", cwd=tmp_path)
    assert merged["amalgamation_zeros"] == 0.3 and gtsams["amalgamation_zeros"] == 0.0
    assert merged["updates"] == gtsams["updates"] and merged["states"] == gtsams["states"] == 1501
    assert gtsams["cliques_final"] > merged["cliques_final"] and gtsams["nnz_final"] < merged["nnz_final"]
