"""``steam-ref batch``: ``--max-poses`` (run's option: its definition, check and message) and a 3-D set's batch, whose
estimate ``--save-trajectory`` writes as the 3-D run writes BTGP's.

Oracles: a data set cut to N poses by hand in the test (each table's rows up to the N-th pose's time, not
``Readings.prefix`` nor ``RigidReadings.head``), solved through the library's batch; the file read back by our reader
and by evo's; run's own refusal of the same bad value.
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from cli_runs import runner
from requirements import optional_import

import steam_ref.cli.rigid as cli_rigid
from steam_ref.datasets import RangeDataset, load_dataset
from steam_ref.datasets.kitti import GPS_FILE, load_kitti
from steam_ref.datasets.rigid import RigidReadings, generate_rigid
from steam_ref.datasets.search import gtsam_data_dir
from steam_ref.evaluate import read_kitti, read_tum
from steam_ref.lie import SE3V
from steam_ref.motion import motion_prior
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.problem import build_problem, sequential_batch
from steam_ref.paper.rigid import solve_rigid
from steam_ref.variables import X

batch_cli = runner("batch")
run_cli = runner("run")
N = 60  # poses kept


def _cut_planar(data: RangeDataset, n: int) -> RangeDataset:
    """The first ``n`` poses of ``data``: their ground truth and dead reckoning, the n - 1 odometry rows between
    them, the ranges stamped up to the n-th pose's time, every landmark."""
    end = data.ground_truth[n - 1, 0]
    return replace(
        data,
        ground_truth=data.ground_truth[:n],
        odometry=data.odometry[: n - 1],
        dead_reckoning=data.dead_reckoning[:n],
        ranges=data.ranges[data.ranges[:, 0] <= end],
    )


def _cut_rigid(data: RigidReadings, n: int) -> RigidReadings:
    """The first ``n`` states of ``data`` and every reading (and held-out fix) stamped up to the n-th state's time."""
    end = data.state_times[n - 1]
    tables = {t: getattr(data, t)[getattr(data, t)[:, 0] <= end] for t in ("positions", "gyro", "ranges", "points")}
    return replace(
        data,
        state_times=data.state_times[:n],
        held_out=data.held_out[data.held_out[:, 0] <= end],
        initial_states=None if data.initial_states is None else data.initial_states[:n],
        truth=None if data.truth is None else data.truth[:n],
        **tables,
    )


def test_a_batch_over_n_poses_is_the_batch_of_the_data_set_cut_to_n_poses(capsys, tmp_path):
    saved = tmp_path / "estimate.txt"
    code, out, err = batch_cli(capsys, "--dataset", "synthetic", "--max-poses", N, "--json", "--save-trajectory", saved)
    assert code == 0, err
    figures = json.loads(out)
    data = load_dataset("synthetic")
    assert data.n_poses > N
    cut = _cut_planar(data, N)
    result = sequential_batch(build_problem(cut, PaperSetup.named("synthetic")), ordering="amd")
    poses = np.array([result.values[X(i)][:3] for i in range(N)])
    times, written = read_tum(saved)
    np.testing.assert_array_equal(times, cut.ground_truth[:, 0])
    np.testing.assert_allclose(written[:, :2], poses[:, :2], rtol=0, atol=1e-9)
    heading = np.angle(np.exp(1j * (written[:, 2] - poses[:, 2])))
    np.testing.assert_allclose(heading, 0.0, rtol=0, atol=1e-9)
    rmse = np.sqrt(np.mean(np.sum((poses[:, :2] - cut.ground_truth[:, 1:3]) ** 2, axis=1)))
    assert figures["n_states"] == N and figures["rmse_m"] == pytest.approx(rmse, abs=1e-6)
    assert figures["evaluation"]["ape"]["translation_m"]["n"] == N


@pytest.mark.parametrize("value", ["1", "0", "-3", "2.5", "x", "nan", "1e400"])
def test_a_bad_max_poses_is_refused_as_run_refuses_it(capsys, value):
    code, out, err = batch_cli(capsys, "--max-poses", value)
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert "argument --max-poses" in err and repr(value) in err
    code, _, run_err = run_cli(capsys, "--max-poses", value)
    assert code == 2 and err == run_err.replace("steam-ref run --help", "steam-ref batch --help")


@pytest.fixture
def solved(monkeypatch) -> list:
    """Every (method, run) the 3-D command's solve_rigid gives back, in order: the command's estimates in memory."""
    runs: list = []

    def recorded(*args, **kwargs):
        run = solve_rigid(*args, **kwargs)
        runs.append((args[2] if len(args) > 2 else kwargs.get("method", "batch"), run))
        return run

    monkeypatch.setattr(cli_rigid, "solve_rigid", recorded)
    return runs


@pytest.mark.parametrize("form", ["tum", "kitti"])
def test_a_3d_batch_writes_its_estimate_which_reads_back_in_ours_and_evos_readers(capsys, tmp_path, solved, form):
    """synthetic-3d's first 30 states: the file holds the command's batch estimate (to rounding), and that estimate is
    the batch of the set cut to 30 states by hand, started from that cut set's BTGP (a generated set has no first
    values)."""
    file_interface = optional_import("evo.tools.file_interface", "evo")
    n, saved = 30, tmp_path / "batch.txt"
    argv = ["--dataset", "synthetic-3d", "--max-poses", n, "--json", "--save-trajectory", saved]
    code, out, err = batch_cli(capsys, *argv, "--trajectory-format", form)
    assert code == 0, err
    figures = json.loads(out)
    assert figures["states"] == n and "batch" in figures and "btgp" not in figures
    assert [m for m, _ in solved] == ["btgp", "batch"]
    estimate = solved[-1][1].states[:, : SE3V.size]
    cut = _cut_rigid(generate_rigid(), n)
    prior = motion_prior("se3", cut.qc)
    start = solve_rigid(cut, prior, "btgp")
    oracle = solve_rigid(cut, prior, "batch", initial=start.states).states[:, : SE3V.size]
    np.testing.assert_allclose(SE3V.matrix(estimate), SE3V.matrix(oracle), rtol=0, atol=1e-9)
    if form == "tum":
        times, ours = read_tum(saved, group=SE3V)
        theirs = file_interface.read_tum_trajectory_file(str(saved))
        np.testing.assert_array_equal(times, cut.state_times)
        np.testing.assert_array_equal(theirs.timestamps, cut.state_times)
    else:
        ours = read_kitti(saved, group=SE3V)
        theirs = file_interface.read_kitti_poses_file(str(saved))
    M = SE3V.matrix(estimate)
    for back in (SE3V.matrix(ours), np.array(theirs.poses_se3)):
        np.testing.assert_allclose(back[:, :3, 3], M[:, :3, 3], rtol=0, atol=1e-12)
        np.testing.assert_allclose(back[:, :3, :3], M[:, :3, :3], rtol=0, atol=1e-12)


def test_a_3d_batch_refuses_what_does_not_apply_in_one_line(capsys, tmp_path):
    for argv, needle in [
        (["--ordering", "xl"], "--ordering does not apply"),
        (["--plot", tmp_path / "a.png"], "--plot does not apply"),
        (["--progress"], "--progress does not apply"),  # a 3-D run draws no bar: it was ignored
        (["--max-poses", "1"], "argument --max-poses: expected an integer >= 2, got '1'"),
    ]:
        code, out, err = batch_cli(capsys, "--dataset", "synthetic-3d", *argv)
        assert code == 2 and out == "" and err.count("\n") == 1 and needle in err, err


def test_a_kitti_batch_writes_the_batch_of_the_set_cut_by_hand(capsys, tmp_path, solved):
    """KITTI's first 16 states (gtsam's files): the set has first values, so the batch alone descends from them; the
    KITTI file holds the batch of the set cut to 16 states by hand, read back by our reader and evo's."""
    optional_import("gtsam", "gtsam")
    file_interface = optional_import("evo.tools.file_interface", "evo")
    folder = gtsam_data_dir()
    if folder is None or not (folder / GPS_FILE).is_file():
        pytest.skip("gtsam's Data/ has no KITTI files")
    n, saved = 16, tmp_path / "batch.txt"
    argv = ["--dataset", "kitti", "--max-poses", n, "--save-trajectory", saved, "--trajectory-format", "kitti"]
    code, out, err = batch_cli(capsys, *argv)
    assert code == 0, err
    assert f"trajectory written to {saved}" in out and [m for m, _ in solved] == ["batch"]
    cut = _cut_rigid(load_kitti(folder, group=SE3V), n)
    oracle = solve_rigid(cut, motion_prior("se3", cut.qc), "batch").states[:, : SE3V.size]
    M = SE3V.matrix(oracle)
    np.testing.assert_allclose(SE3V.matrix(solved[0][1].states[:, : SE3V.size]), M, rtol=0, atol=1e-9)
    for back in (
        SE3V.matrix(read_kitti(saved, group=SE3V)),
        np.array(file_interface.read_kitti_poses_file(str(saved)).poses_se3),
    ):
        assert back.shape == (n, 4, 4)
        np.testing.assert_allclose(back, M, rtol=0, atol=1e-9)
