"""CMU range data ran on a pose-index clock, silently: a clock with units.

The CMU readers' times were thrown away for ``arange(n)``, so (a) a lag in seconds counted poses: the same
file with its stamps ×0.2 or ×10 gave the identical ``--lag 5`` run; (b) the estimate queried at the
truth's own stamps read the pose index (Plaza's 3857-4257 s fell inside its 0-9657 poses); (c)
``--save-estimates`` wrote times 0, 1, 2, ... where ``--save-trajectory`` wrote the file's 1, 2, 3, ....

Now a data set carries its seconds and says where they come from; the scripts' pose-index clock is the
CMU presets' named choice (``PaperSetup.clock``), related to the seconds by one ``Clock``. The oracles:
the arithmetic of the stamps (a window of L seconds on poses Δt apart holds the poses within L of the
newest), the run on the unscaled file (a file ×c with a lag L·c is the same run), and the file's own
stamps.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
import scipy.io
from cli_runs import runner

from steam_ref.datasets import RangeDataset, generate_synthetic, load_dataset
from steam_ref.errors import ClockError, SteamError
from steam_ref.evaluate import read_tum, states_at
from steam_ref.gp.clock import Clock
from steam_ref.paper.online import StreamingEstimator, run_online
from steam_ref.paper.options import StreamOptions
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.readings import Readings

SETUP = PaperSetup.synthetic()


@pytest.fixture(scope="module")
def data():
    return generate_synthetic(n_steps=120, n_landmarks=24, seed=5)  # stamped 1, 2, ..., 121 s


def restamped(data: RangeDataset, times) -> RangeDataset:
    """``data`` with pose i stamped ``times[i]`` and each range at its pose's new stamp (the file's layout)."""
    old, new = data.times, np.asarray(times, dtype=float)
    gt, dr, drp, td = (np.array(a) for a in (data.ground_truth, data.odometry, data.dead_reckoning, data.ranges))
    gt[:, 0], dr[:, 0], drp[:, 0] = new, new[1:], new
    td[:, 0] = np.interp(td[:, 0], old, new)
    return RangeDataset(data.name, gt, dr, drp, data.landmarks, td, data.source, time_origin="file")


def scaled_file(tmp_path, data: RangeDataset, factor: float):
    """A CMU .mat copy of ``data`` with every stamp times ``factor``."""
    path = tmp_path / f"scaled_{factor:g}.mat"
    scipy.io.savemat(path, restamped(data, data.times * factor).to_cmu_arrays())
    return path


_cli = runner("run")


def run_json(capsys, *argv) -> dict:
    """The figures of ``steam-ref run ARGV --json``, which must succeed."""
    code, out, err = _cli(capsys, *argv, "--json", "--no-progress")
    assert code == 0, err
    return json.loads(out.strip().splitlines()[-1])


# -- (a) a lag is in the data's seconds ------------------------------------------------------------


def test_a_lag_in_seconds_scales_with_the_files_stamps(tmp_path, capsys, data):
    runs = {
        f: run_json(capsys, "--dataset", scaled_file(tmp_path, data, f), "--preset", "synthetic", "--lag", 5)
        for f in (0.2, 1.0, 10.0)
    }
    window = {f: r["peak_window"] for f, r in runs.items()}
    # 5 s on poses 0.2 s apart is 26 poses, on poses 1 s apart 6, on poses 10 s apart the newest alone:
    # the window must shrink as the poses spread (a pose-index clock gave the same window for all three)
    assert window[0.2] > window[1.0] > window[10.0], window
    # a file ×c with a lag of 5c s is the unscaled file's run with 5 s, to the bit (the prior's clock is the
    # pose index in both; c = 1/4 keeps the stamps' arithmetic exact, so no pose sits on the window's edge by rounding)
    same = run_json(capsys, "--dataset", scaled_file(tmp_path, data, 0.25), "--preset", "synthetic", "--lag", 1.25)
    assert same["peak_window"] == window[1.0] and same["rmse_m"] == runs[1.0]["rmse_m"]
    assert same["n_marginalized"] == runs[1.0]["n_marginalized"]


def test_the_api_lag_holds_the_poses_of_its_seconds(data):
    # Plaza-like stamps: 0.17 to 0.23 s apart from 3856.86 s; a lag of 6 s holds about 30 poses, not 6
    rng = np.random.default_rng(3)
    stamps = 3856.857 + np.concatenate([[0.0], np.cumsum(rng.uniform(0.17, 0.23, data.n_poses - 1))])
    plaza_like = restamped(data, stamps)
    stream = StreamingEstimator(Readings.from_dataset(plaza_like, SETUP), SETUP, StreamOptions(lag=6.0))
    stream.run(plaza_like.ground_truth)
    held = sorted(k.index for k in stream.solver.inner.estimate() if k.symbol == "x")
    newest = stamps[held[-1]]
    expected = [i for i in range(held[-1] + 1) if stamps[i] >= newest - 6.0]  # the arithmetic of the stamps
    assert held == expected and len(held) > 20, (len(held), len(expected))


# -- (b) evaluation at the truth's own stamps -------------------------------------------------------


def test_the_estimate_at_the_truths_own_stamps_is_the_pose_by_pose_estimate(data):
    # stamps 100 s + 0.3 s per pose: inside the pose range 0-120, so the pose-index clock read them as poses
    plaza_like = restamped(data, 100.0 + 0.3 * np.arange(data.n_poses))
    stream = StreamingEstimator(Readings.from_dataset(plaza_like, SETUP), SETUP, StreamOptions())
    result = stream.run(plaza_like.ground_truth)
    at_truth = states_at(stream.solved(), plaza_like.ground_truth[:, 0])
    np.testing.assert_array_equal(at_truth, result.trajectory)
    np.testing.assert_array_equal(result.times, plaza_like.times)


def test_pose_indices_against_a_trajectory_in_seconds_are_refused(data):
    plaza_like = restamped(data, 100.0 + 0.3 * np.arange(data.n_poses))
    stream = StreamingEstimator(Readings.from_dataset(plaza_like, SETUP), SETUP, StreamOptions())
    stream.run()
    with pytest.raises(ClockError, match=r"times\[0\] = 0.0 is before the first estimated state at t=100.*pose-index"):
        states_at(stream.solved(), np.arange(data.n_poses, dtype=float))
    with pytest.raises(ClockError, match=r"after the last estimated state"):
        states_at(stream.solved(), [200.0])


# -- (c) every file a run writes uses one clock ------------------------------------------------------


def test_save_estimates_and_save_trajectory_write_the_files_stamps(tmp_path, capsys, data):
    path = scaled_file(tmp_path, data, 0.2)
    est, tum = tmp_path / "est.npz", tmp_path / "traj.tum"
    run_json(capsys, "--dataset", path, "--preset", "synthetic", "--save-estimates", est, "--save-trajectory", tum)
    stamps = load_dataset(str(path)).times
    with np.load(est) as saved:
        np.testing.assert_array_equal(saved["times"], stamps)
    np.testing.assert_allclose(read_tum(tum)[0], stamps, rtol=0, atol=1e-9)  # TUM keeps 9 decimals


# -- where the times come from, and the clock the prior runs on ---------------------------------------


def test_a_data_set_says_where_its_seconds_come_from(data, shared_data):
    assert load_dataset("paper-synthetic").time_origin == "file"
    assert data.time_origin == "generated"
    given = dataclasses.replace(data, time_origin="given")
    assert given.time_origin == "given" and "time_origin='given'" in repr(given)
    with pytest.raises(SteamError, match=r"time_origin must be one of file, generated, given.*'stamps'"):
        dataclasses.replace(data, time_origin="stamps")


def test_the_cmu_presets_name_the_scripts_pose_index_clock():
    assert PaperSetup.synthetic().clock == PaperSetup.plaza().clock == "pose-index"
    assert PaperSetup.victoria_park().clock == "seconds"
    with pytest.raises(SteamError, match=r"PaperSetup.clock must be one of seconds, pose-index, got 'poses'"):
        PaperSetup.plaza().replace(clock="poses")


def test_the_clock_maps_seconds_to_the_priors_time_pose_by_pose():
    clock = Clock.of([3856.86, 3857.05, 3857.25, 3857.45], "pose-index", "file")
    np.testing.assert_array_equal(clock.to_model(clock.seconds), [0.0, 1.0, 2.0, 3.0])  # exact at the poses
    np.testing.assert_allclose(clock.to_model(3856.86 + 0.095), 0.5)  # linear between them
    np.testing.assert_allclose(clock.to_model(3857.65), 4.0)  # the last step's rate after the last pose
    np.testing.assert_allclose(clock.to_seconds(clock.to_model([3857.0, 3857.3])), [3857.0, 3857.3])
    with pytest.raises(SteamError, match=r"increase strictly.*times\[1\] = 1.0 and times\[2\] = 1.0"):
        Clock.of([0.0, 1.0, 1.0], "pose-index")


def test_the_priors_clock_is_the_setups_choice(data):
    # the same file on a seconds clock: the prior's Δt is the stamps' 0.3 s, not 1; a pose-index clock ignores them
    plaza_like = restamped(data, 100.0 + 0.3 * np.arange(data.n_poses))
    poses = Readings.from_dataset(plaza_like, SETUP)
    seconds = Readings.from_dataset(plaza_like, SETUP.replace(clock="seconds"))
    np.testing.assert_array_equal(poses.model_times, np.arange(data.n_poses))
    np.testing.assert_array_equal(seconds.model_times, plaza_like.times)
    np.testing.assert_allclose(seconds.velocity[1:, 0] * 0.3, poses.velocity[1:, 0])  # distance over each Δt
    a = run_online(plaza_like, SETUP, StreamOptions(max_poses=30))
    b = run_online(restamped(data, data.times), SETUP, StreamOptions(max_poses=30))
    np.testing.assert_array_equal(a.trajectory, b.trajectory)  # pose-index: the stamps do not reach the prior


def test_a_clock_of_no_pose_is_refused():
    with pytest.raises(SteamError, match="times is empty: a clock needs the time of one pose at least"):
        Clock.of([])
    with pytest.raises(SteamError, match="times is empty"):
        Clock.of(np.array([]), "pose-index")
    assert Clock.of([5.0]).to_model(6.0) == 6.0  # one pose is a clock: the map is a shift


@pytest.mark.parametrize("basis", ["seconds", "pose-index"])
@pytest.mark.parametrize("bad", [float("nan"), float("inf"), -float("inf"), [0.1, float("nan")], "0.3"])
def test_the_clock_refuses_a_time_that_is_not_a_finite_number_naming_it(basis, bad):
    """Clock.to_model and to_seconds map finite times: NaN or ±inf is a SteamError naming it (it mapped NaN to NaN,
    inf to inf), a string too (it was NumPy's ValueError)."""
    clock = Clock.of([0.0, 0.2, 0.5, 0.6], basis)
    for name, mapping in (("t", clock.to_model), ("m", clock.to_seconds)):
        with pytest.raises(SteamError, match=rf"\b{name}\b"):
            mapping(bad)
