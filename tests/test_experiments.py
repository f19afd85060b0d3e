"""The experiments of Fig. 3/4 and their results table, on a small generated task.  [YIB Sec. IV]

The figures in the table are checked against the runs they summarise, recomputed here from the
runs' own step times and estimates; the published-layout run against a direct streamed run.
"""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from steam_ref.datasets import generate_synthetic
from steam_ref.paper.experiments import (
    SKIPS,
    TIMING_RUNS,
    Experiment,
    published_run_experiment,
    reproduce,
    results_table,
    speedup_on_prefix,
)
from steam_ref.paper.online import run_online
from steam_ref.paper.options import StreamOptions
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.results import position_rmse

SETUP = PaperSetup.synthetic()


@pytest.fixture(scope="module")
def small():
    return generate_synthetic(n_steps=45, n_landmarks=10, seed=5, range_sigma=0.2)


@pytest.fixture(scope="module")
def reproduced(small, tmp_path_factory):
    out = tmp_path_factory.mktemp("reproduce")
    table = reproduce(out, progress=False, data_sets=[("small", small, SETUP)])
    return out, table


def test_reproduce_writes_plots_runs_and_table(reproduced):
    out, table = reproduced
    for name in ("fig3.png", "fig3_trajectory.png", "results.md"):
        assert (out / name).stat().st_size > 0, name
    assert (out / "results.md").read_text() == table
    runs = [json.loads(line) for line in (out / "runs.jsonl").read_text().splitlines()]
    assert len(runs) == len(TIMING_RUNS) + 2 * len(SKIPS) + 1  # timing, with/without interpolation, published
    assert {(r["method"], r["every"]) for r in runs} >= set(TIMING_RUNS)
    # every run covered the whole stream (no budget was hit) and scored its own RMSE
    assert all(r["completed"] and r["n_poses"] == 46 and np.isfinite(r["rmse_m"]) for r in runs)
    for method, every in TIMING_RUNS:
        assert re.search(rf"\| small \| {method.upper()}/{every} \| 46 \| ", table), (method, every)
    for skip in SKIPS:
        assert re.search(rf"\| small \| {skip} \| ", table), skip


def test_an_interrupted_reproduce_leaves_the_files_of_the_last_one_whole(small, tmp_path, monkeypatch):
    """Ctrl-C in the runs (hours of them) leaves the folder's runs.jsonl and results.md as they were (the log was once
    opened, and emptied, before the first run): each is replaced whole once made; none is left behind."""
    for name in ("runs.jsonl", "results.md"):
        (tmp_path / name).write_text(f"yesterday's {name}\n")

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr("steam_ref.paper.experiments.interpolation_experiment", interrupted)
    with pytest.raises(KeyboardInterrupt):
        reproduce(tmp_path, progress=False, data_sets=[("small", small, SETUP)])
    assert sorted(p.name for p in tmp_path.iterdir()) == ["results.md", "runs.jsonl"]
    for name in ("runs.jsonl", "results.md"):
        assert (tmp_path / name).read_text() == f"yesterday's {name}\n"


def test_table_figures_match_the_runs(small):
    """Speed ratios, interpolated fractions, time saved and RMSE changes recomputed from the runs."""
    exp = Experiment("small", small, SETUP)
    for label, (method, every) in (("PB/1", ("pb", 1)), ("BTGP/1", ("btgp", 1))):
        exp.timing[label] = run_online(small, SETUP.with_schedule(every=every), StreamOptions(method=method))
    for skip in (1, 5):
        exp.with_interp[skip] = run_online(small, SETUP, StreamOptions(skip=skip))
    table = results_table([exp])
    pb, bt = exp.timing["PB/1"], exp.timing["BTGP/1"]
    ratio = pb.step_seconds.sum() / bt.step_seconds.sum()  # both covered all 46 steps
    assert speedup_on_prefix(pb, bt) == (pytest.approx(ratio), 46)
    assert f"| small | BTGP/1 vs PB/1 | far faster | {ratio:.0f}× faster over the first 46 steps |" in table
    base, coarse = exp.with_interp[1], exp.with_interp[5]
    assert coarse.n_states == 10  # poses 0, 5, ..., 45
    frac, saved = 1 - 10 / 46, 1 - coarse.total_s / base.total_s
    drmse = 100 * (coarse.rmse_m - base.rmse_m)
    row = f"| small | interpolation, skip 5 ({frac:.0%} of states interpolated) |"
    line = next(ln for ln in table.splitlines() if ln.startswith(row))
    assert line.endswith(f"time saved {saved:.0%}, RMSE {coarse.rmse_m:.3f} m ({drmse:+.1f} cm) |")
    # the RMSE a run reports is the RMSE of its estimates against ground truth
    np.testing.assert_allclose(coarse.rmse_m, position_rmse(coarse.trajectory[:, :2], small.ground_truth[:, 1:3]))


def test_budget_cut_is_reported_as_such(small):
    exp = Experiment("small", small, SETUP)
    exp.timing["PB/1"] = run_online(small, SETUP, StreamOptions(method="pb", time_budget_s=1e-9))
    r = exp.timing["PB/1"]
    assert not r.completed and r.n_steps_processed < 46
    assert f"(time budget: {r.n_steps_processed} of 46 steps)" in results_table([exp])


def test_published_run_is_btgp1_with_every_pose_a_state_and_its_marginals(small):
    """The accuracy run is the authors' set-up: BTGP/1, every pose a state, final marginals; with no
    saved authors' run for this data set the row gives our RMSE and says why there is no comparison."""
    exp = Experiment("small", small, SETUP)
    published_run_experiment(exp)
    direct = run_online(small, SETUP, StreamOptions())
    np.testing.assert_array_equal(exp.published.state_poses, np.arange(small.n_poses))
    np.testing.assert_allclose(exp.published.trajectory, direct.trajectory, rtol=0, atol=0)
    cov = exp.published.covariances
    assert cov.pose.shape == (small.n_poses, 3, 3) and cov.landmark.shape == (len(exp.published.landmarks), 2, 2)
    assert exp.fidelity is None and "no saved authors' run" in exp.note
    rmse = position_rmse(direct.trajectory[:, :2], small.ground_truth[:, 1:3])
    assert f"| {rmse:.5f} m (no saved authors' run" in results_table([exp])


def test_published_row_compares_with_the_authors_saved_run(shared_data):
    """On the paper's synthetic set the row sets our RMSE beside the authors' saved run's."""
    from steam_ref.datasets import load_cmu_mat
    from steam_ref.paper.fidelity import compare, load_authors_run

    data = load_cmu_mat(shared_data / "Syn_theta_Plaza.mat")
    exp = Experiment("paper-synthetic", data, SETUP)
    published_run_experiment(exp)
    fid, _ = compare(exp.published, load_authors_run("paper-synthetic", data), data.ground_truth)
    assert exp.fidelity == fid
    row = results_table([exp])
    assert f"| {fid.authors_rmse_m:.5f} m | {fid.rmse_m:.5f} m; within {1000 * fid.pose_max_m:.1f} mm" in row


def test_published_row_of_a_prefix_says_so(small):
    exp = Experiment("small", small, SETUP)
    published_run_experiment(exp, max_poses=20)
    assert "first 20 steps only, not comparable" in results_table([exp])


def test_interpolation_sweep_runs_with_its_documented_set_up(small):
    """Each sweep run is the set-up with the plain heading-rate guess, at its skip, with and without
    interpolation: the same estimate as a direct run of that set-up, not of the preset."""
    from steam_ref.paper.experiments import INTERPOLATION_DEPARTURES, interpolation_experiment

    assert INTERPOLATION_DEPARTURES == ("plain-heading-rate",)
    exp = Experiment("small", small, SETUP)
    interpolation_experiment(exp, skips=(3,))
    setup = SETUP.replace(pose2_heading_rate_guess=False)
    for interpolate, store in ((True, exp.with_interp), (False, exp.without_interp)):
        direct = run_online(small, setup, StreamOptions(skip=3, interpolate=interpolate))
        np.testing.assert_array_equal(store[3].trajectory, direct.trajectory)


def test_reproduce_with_jobs_gives_the_serial_accuracy_and_says_how_it_timed(small, reproduced, tmp_path):
    """--jobs 2: the interpolation sweep in parallel gives the serial runs' figures; timing runs ran alone."""
    table = reproduce(tmp_path, progress=False, data_sets=[("small", small, SETUP)], jobs=2)
    assert "every timing run (PB, PBVR, BTGP) ran alone, one after another, each in a fresh process" in table
    serial = [json.loads(line) for line in (reproduced[0] / "runs.jsonl").read_text().splitlines()]
    parallel = [json.loads(line) for line in (tmp_path / "runs.jsonl").read_text().splitlines()]
    assert len(parallel) == len(serial)
    for a, b in zip(serial, parallel, strict=True):
        assert (a["method"], a["every"], a["skip"], a["interpolate"]) == (
            b["method"],
            b["every"],
            b["skip"],
            b["interpolate"],
        )
        assert a["rmse_m"] == b["rmse_m"] and a["n_estimated_states"] == b["n_estimated_states"]
