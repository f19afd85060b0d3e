"""Fixed-lag smoothing in a stream and on the command line: StreamOptions(lag=…), steam-ref run --lag.

A lag longer than the run changes nothing (the same trajectory, bit for bit); a short one keeps the
window to about lag / Δt states however long the run, reports what it forgot, lets landmarks leave
and enter again, and keeps the lagged estimate close to the full smoother's. Bad combinations are
refused before anything runs.
"""

from __future__ import annotations

import json
import os
import re

import numpy as np
import pytest
from cli_runs import run_module

from steam_ref.cli import commands as cli
from steam_ref.datasets import generate_synthetic, load_dataset
from steam_ref.errors import SteamError, UnknownVariableError
from steam_ref.paper.online import StreamingEstimator, run_online
from steam_ref.paper.online_solver import OnlineSolver
from steam_ref.paper.options import StreamOptions
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.readings import Readings
from steam_ref.paper.solvers import FixedLagTreeSolver, make_solver
from steam_ref.variables import X

SETUP = PaperSetup.synthetic()


@pytest.fixture(scope="module")
def data():
    return generate_synthetic(n_steps=120, n_landmarks=24, seed=5)


def test_a_lag_longer_than_the_run_changes_nothing(data):
    full = run_online(data, SETUP, StreamOptions())
    lagged = run_online(data, SETUP, StreamOptions(lag=1e6))
    np.testing.assert_array_equal(lagged.trajectory, full.trajectory)
    assert lagged.n_marginalized == 0 and lagged.peak_window == len(full.state_poses) + len(full.landmarks)
    assert full.lag_summary() == {} and lagged.lag_summary()["n_marginalized"] == 0


def test_plazas_lag_of_60_s_holds_the_poses_of_the_last_60_s_of_its_stamps(shared_data):
    """Plaza's preset runs the GP prior on the pose index (the scripts' dt = 1), but a lag is in the file's
    seconds: after 1,200 poses (about 240 s) the window holds every pose stamped within 60 s of the newest state,
    about 300 poses 0.2 s apart (on the pose-index clock it held 61)."""
    plaza, setup = load_dataset("plaza"), PaperSetup.plaza()
    stream = StreamingEstimator(Readings.from_dataset(plaza, setup), setup, StreamOptions(lag=60.0, max_poses=1200))
    stream.run()
    smoother, t = stream.solver.inner, plaza.times
    held = sorted(k.index for k in smoother.estimate() if k.symbol == "x")
    assert t[held[-1]] == smoother.newest
    assert held == [i for i in range(held[-1] + 1) if t[i] >= smoother.newest - 60.0]  # GTSAM's rule, by the stamps
    assert 250 < len(held) < 350, len(held)


def test_a_short_lag_keeps_the_window_small_and_the_estimate_close(data):
    full = run_online(data, SETUP, StreamOptions())
    stream = StreamingEstimator(Readings.from_dataset(data, SETUP), SETUP, StreamOptions(lag=10.0))
    result = stream.run(data.ground_truth)
    smoother = stream.solver.inner
    assert isinstance(stream.solver, FixedLagTreeSolver)
    held_states = [k for k in smoother.estimate() if k.symbol == "x"]
    assert len(held_states) <= 12  # Δt = 1 s: t > t_newest - 10 s, and the newest
    assert result.n_marginalized >= len(result.state_poses) - 12
    assert result.peak_window < 40 and smoother.tree.problems() == []
    assert abs(result.rmse_m - full.rmse_m) < 0.05, (result.rmse_m, full.rmse_m)
    with pytest.raises(UnknownVariableError, match="x0, which was marginalized at update"):
        smoother.marginal_covariance(X(0))
    np.testing.assert_array_equal(stream.solver.estimate_of(X(0)), stream.solver.retired(X(0)))
    assert len(stream.solver.reports) <= 100
    summary = result.lag_summary()
    assert summary["lag_s"] == 10.0 and summary["n_marginalized"] == result.n_marginalized


def test_a_kept_history_changes_nothing_online_and_smooths_the_past(data):
    lagged = run_online(data, SETUP, StreamOptions(lag=10.0))
    stream = StreamingEstimator(Readings.from_dataset(data, SETUP), SETUP, StreamOptions(lag=10.0, lag_history=True))
    kept = stream.run(data.ground_truth)
    assert kept.rmse_lagged_m == lagged.rmse_m  # the same online computation: the history is only kept
    past = stream.solver.inner.smoothed_history()
    retired = sorted(i for i in kept.state_poses if X(int(i)) in past)
    assert len(retired) >= len(kept.state_poses) - 12
    for i in retired:  # the run's trajectory is the smoothed past (derivations Eq. 10.5)
        np.testing.assert_array_equal(kept.trajectory[i], past[X(int(i))])
    assert not np.array_equal(kept.trajectory[retired], lagged.trajectory[retired])  # later readings reached them
    # (how close the smoothed past comes to the full smoother depends on how far the separators moved from where
    # the conditionals were frozen: tests/test_fixed_lag_history.py checks it where nothing moved; Plaza: RMSE
    # 2.1 mm below the full smoother's, a median 9 mm from it pose by pose)
    summary = kept.lag_summary()
    assert summary["lag_history"] is True and summary["rmse_lagged_m"] == round(lagged.rmse_m, 6)
    assert kept.history_smoothing_s is not None and 0 <= kept.history_smoothing_s < kept.total_s
    assert "lag_history" not in lagged.lag_summary()


def test_result_twice_or_mid_run_keeps_the_lagged_and_the_smoothed_apart(data):
    """result() smooths the past for its own figures; a second call, or stepping on after it, must not take
    the smoothed estimates for the lagged ones."""
    options = StreamOptions(lag=10.0, lag_history=True)
    whole = run_online(data, SETUP, options)
    stream = StreamingEstimator(Readings.from_dataset(data, SETUP), SETUP, options)
    for _ in range(60):
        stream.step()
    stream.result(data.ground_truth)  # mid-run
    while not stream.done:
        stream.step()
    first, second = stream.result(data.ground_truth), stream.result(data.ground_truth)
    assert first.rmse_lagged_m == second.rmse_lagged_m == whole.rmse_lagged_m != first.rmse_m
    assert first.rmse_m == second.rmse_m == whole.rmse_m
    np.testing.assert_array_equal(second.trajectory, whole.trajectory)


def test_the_past_is_read_as_asked_and_result_changes_no_later_query(data):
    """The lagged and the smoothed past are two readings of one solver, chosen by an argument: result() reads the
    smoothed one for its figures and leaves every later query as it was."""
    stream = StreamingEstimator(Readings.from_dataset(data, SETUP), SETUP, StreamOptions(lag=10.0, lag_history=True))
    while not stream.done:
        stream.step()
    lagged = stream.trajectory()[1]
    t0 = float(data.times[0])
    result = stream.result(data.ground_truth)
    np.testing.assert_array_equal(stream.trajectory()[1], lagged)  # result() switched nothing
    np.testing.assert_array_equal(stream.trajectory(past="lagged")[1], lagged)
    np.testing.assert_array_equal(stream.trajectory(past="smoothed")[1], result.trajectory)
    np.testing.assert_array_equal(stream.estimate_at(t0, past="smoothed"), result.trajectory[0])
    np.testing.assert_array_equal(stream.estimate_at(t0), lagged[0])
    past = stream.solver.inner.smoothed_history()  # the oracle: the smoother's own backward pass
    np.testing.assert_array_equal(stream.solver.estimate_of(X(0), past="smoothed"), past[X(0)])
    assert not np.array_equal(past[X(0)], lagged[0])  # the two readings differ, so the checks above mean something
    truth = data.ground_truth[:, 1:3]
    assert result.rmse_lagged_m == pytest.approx(np.sqrt(np.mean(np.sum((lagged[:, :2] - truth) ** 2, axis=1))))
    with pytest.raises(SteamError, match="past must be one of 'lagged', 'smoothed', got past='recent'"):
        stream.estimate_at(t0, past="recent")


def test_the_smoothed_past_of_a_lag_without_its_history_is_refused_even_before_anything_is_forgotten(data):
    stream = StreamingEstimator(Readings.from_dataset(data, SETUP), SETUP, StreamOptions(lag=10.0, max_poses=3))
    stream.run()
    assert stream.solver.n_marginalized == 0
    with pytest.raises(SteamError, match=r"past='smoothed' needs the forgotten conditionals.*keep_history=True"):
        stream.trajectory(past="smoothed")
    stream.trajectory()  # the lagged past is there


class Forwarding(OnlineSolver):
    """A solver the run loop has never heard of, forgetting as the fixed-lag one does (it forwards to one)."""

    def __init__(self, inner: OnlineSolver):
        self.inner = inner

    def update(self, factors, values):
        self.inner.update(factors, values)

    def estimate_of(self, key, *, past="lagged"):
        return self.inner.estimate_of(key, past=past)

    def estimate(self, *, past="lagged"):
        return self.inner.estimate(past=past)

    def forgotten(self):
        return self.inner.forgotten()

    n_marginalized = property(lambda self: self.inner.n_marginalized)
    peak_window = property(lambda self: self.inner.peak_window)


def test_the_run_loop_asks_any_solver_the_same_questions():
    """No switch on the solver's type: a solver passed in that forgets landmarks has them enter again, and its
    window's figures reach the result, exactly as with the loop's own fixed-lag solver."""
    data = generate_synthetic(n_steps=150, n_landmarks=10, seed=2)  # few landmarks: each forgotten, then seen again
    readings = Readings.from_dataset(data, SETUP)
    own = run_online(readings, SETUP, StreamOptions(lag=4.0))
    solver = Forwarding(make_solver("btgp", isam2=SETUP.isam2_params(), lag=4.0, times=readings.times))
    passed = StreamingEstimator(readings, SETUP, StreamOptions(), solver=solver).run()
    assert own.n_marginalized > len(own.landmarks)  # landmarks were forgotten (and states)
    np.testing.assert_array_equal(passed.trajectory, own.trajectory)
    assert (passed.n_marginalized, passed.peak_window) == (own.n_marginalized, own.peak_window)


def test_make_solver_refuses_a_lag_it_cannot_keep():
    with pytest.raises(SteamError, match=r"lag=5\.0.*method='btgp'.*method='pb'"):
        make_solver("pb", lag=5.0, times=np.arange(3.0))
    with pytest.raises(SteamError, match="poses' times"):
        make_solver("btgp", lag=5.0)
    with pytest.raises(SteamError, match="keep_history keeps what a lag forgets"):
        make_solver("btgp", keep_history=True)


def test_landmarks_leave_the_window_and_enter_again():
    data = generate_synthetic(n_steps=150, n_landmarks=10, seed=2)  # few landmarks: each seen again and again
    stream = StreamingEstimator(Readings.from_dataset(data, SETUP), SETUP, StreamOptions(lag=4.0))
    left: set = set()  # landmarks that have left the window at some point
    entered_again: set = set()
    while not stream.done:
        stream.step()
        held = {k for k in stream.solver.inner.estimate() if k.symbol == "l"}
        entered_again |= held & left
        left |= {k for k in stream.solver.forgotten() if k.symbol == "l"}
    assert entered_again and stream.solver.inner.tree.problems() == []


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        (dict(method="pb", lag=5.0), "lag .*BTGP only.*PB re-solves"),
        (dict(method="pbvr", lag=5.0), "BTGP only"),
        (dict(lag=0.0), "lag must be a finite number of seconds > 0"),
        (dict(lag=float("inf")), "lag must be"),
        (dict(lag=True), "lag must be"),
        (dict(lag=3.0, converge_at_end=True), "lag and converge_at_end"),
        (dict(lag_history=True), "lag_history keeps what a lag forgets: give a lag"),
        (dict(lag=3.0, lag_history=1), "lag_history must be True or False"),
        (dict(lag_batch=2.0), "lag_batch=2.0 batches what a lag forgets: give a lag"),
        (dict(lag=3.0, lag_batch=-1.0), "lag_batch must be a finite number of seconds >= 0"),
        (dict(lag=3.0, lag_batch=float("nan")), "lag_batch must be"),
    ],
)
def test_bad_lag_options_are_refused(changes, message):
    with pytest.raises(SteamError, match=message):
        StreamOptions(**changes)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["run", "--lag", "5", "--method", "pb"], "BTGP only"),
        (["run", "--lag", "0"], "--lag"),
        (["run", "--lag", "-2"], "--lag"),
        (["run", "--steps", "0"], "--steps"),
        (["run", "--steps", "50", "--dataset", "plaza"], "--steps generates the synthetic task"),
        (["run", "--lag", "5", "--save-estimates", "out.npz"], "--save-estimates .* --lag"),
        (["run", "--lag-history"], "give a lag too"),
        (["run", "--lag-batch", "3"], "give a lag too"),
        (["run", "--lag", "5", "--lag-batch", "-1"], "--lag-batch"),
    ],
)
def test_the_cli_refuses_bad_lag_and_steps_in_one_line(argv, message, capsys, monkeypatch, tmp_path):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(StreamingEstimator, "run", lambda *a, **k: pytest.fail("the run started"))
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert re.search(message, err), err


def test_run_with_steps_and_lag_reports_the_window(capsys):
    assert cli.main(["run", "--steps", "60", "--lag", "8", "--json"]) == 0
    row = json.loads(capsys.readouterr().out)
    assert row["n_poses"] == 61 and row["lag_s"] == 8.0
    assert row["n_marginalized"] >= 61 - 10 and 0 < row["peak_window"] < 30


def test_a_batched_lag_holds_at_most_lag_plus_batch_and_forgets_as_much(capsys):
    assert cli.main(["run", "--steps", "60", "--lag", "8", "--json"]) == 0
    every = json.loads(capsys.readouterr().out)
    assert cli.main(["run", "--steps", "60", "--lag", "8", "--lag-batch", "4", "--json"]) == 0
    batched = json.loads(capsys.readouterr().out)
    assert every["peak_window"] < batched["peak_window"] <= every["peak_window"] + 4 * 2  # a state and ~1 landmark a s
    assert batched["n_marginalized"] >= 61 - 14 and abs(batched["rmse_m"] - every["rmse_m"]) < 0.02


def test_run_text_says_which_rmse_is_which(capsys):
    assert cli.main(["run", "--steps", "60", "--lag", "8", "--lag-history", "--no-progress"]) == 0
    lagged_text = capsys.readouterr().out
    assert cli.main(["run", "--steps", "60", "--lag", "8", "--json"]) == 0
    lagged = json.loads(capsys.readouterr().out)
    line = next(x for x in lagged_text.splitlines() if x.strip().startswith("lag 8 s:"))
    assert "the past smoothed from the final window" in line
    assert line.endswith(f"as each state left the window it was {lagged['rmse_m']} m")


def test_a_lagged_plaza_run_is_the_same_to_the_last_bit_whatever_pythons_hash_seed(shared_data, tmp_path):
    """Marginalization reads the keys it drops in their order, never a set's: a set's order follows
    PYTHONHASHSEED, and with it the order of the cliques' sums (it moved the trajectory by ~5e-14 before)."""
    runs = []
    for seed in ("1", "2"):
        out = tmp_path / f"lag_{seed}.txt"
        proc = run_module(
            "run", "--dataset", "plaza", "--every", "1", "--lag", "60", "--max-poses", "600", "--save-trajectory", out,
            env={**os.environ, "PYTHONHASHSEED": seed},
        )  # fmt: skip
        assert proc.returncode == 0, proc.stderr
        runs.append(out.read_bytes())
    assert runs[0] == runs[1]
