"""The paper's set-up as its scripts run it: range attachment, the affine range correction, the front
end's initial guesses and landmark priors. Oracles are line-by-line transliterations of the authors'
MATLAB loops (``plaza_isam2.m``, ``range_measure_fit.m``), written here with their 1-based indices."""

from __future__ import annotations

import numpy as np
import pytest

from steam_ref.datasets import RangeDataset, generate_synthetic, load_cmu_mat
from steam_ref.dead_reckoning import compose
from steam_ref.errors import DataError, SteamError
from steam_ref.factors import PriorFactor, RangeFactor
from steam_ref.paper.frontend import FrontEnd, Layout
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.readings import Readings, attach_ranges, range_correction
from steam_ref.variables import L, X


def scripts_scan(pose_times: np.ndarray, range_times: np.ndarray) -> np.ndarray:
    """``while k<=K && t>=TD(k,1)`` at every pose i, in file order. The scripts loop from pose 1 (the
    synthetic one attaches TD's first row to pose 0 by hand); starting at pose 0 is the same on both
    files, whose first reading is not later than pose 0 (synthetic) or later than pose 1 (Plaza)."""
    out, k = np.full(len(range_times), -1), 0
    for i, t in enumerate(pose_times):
        while k < len(range_times) and t >= range_times[k]:
            out[k] = i
            k += 1
    return out


def scripts_range_fit(data: RangeDataset, n: int) -> tuple[float, float]:
    """range_measure_fit.m, 1-based: pair each range with GT row i-1 or i, whichever is nearer in time."""
    T, TD = data.ground_truth[:n, 0], data.ranges
    pairs, v, i = [], 1, 1
    t = TD[v - 1, 0]
    while i <= n:
        if T[i - 1] >= t:
            row = i - 1 if abs(T[i - 2] - t) <= abs(T[i - 1] - t) else i
            pairs.append((row, v))
            v += 1
            t = TD[v - 1, 0]
        else:
            i += 1
    marks = {int(r[0]): r[1:] for r in data.landmarks}
    true = [np.linalg.norm(data.ground_truth[row - 1, 1:3] - marks[int(TD[v - 1, 2])]) for row, v in pairs]
    A = np.column_stack([[TD[v - 1, 3] for _, v in pairs], np.ones(len(pairs))])
    a, b = np.linalg.lstsq(A, np.array(true), rcond=None)[0]
    return float(a), float(b)


def with_backward_ranges(seed: int = 4) -> RangeDataset:
    """A generated set whose range rows go back in time twice (as Plaza's file does)."""
    ds = generate_synthetic(n_steps=80, n_landmarks=6, seed=seed)
    td = ds.ranges.copy()
    td[30:36, 0] -= 7.5  # a block stamped 7.5 s earlier than its place in the file
    td[60:62, 0] -= 20.0
    td[:-1, 0] += 0.25  # between poses, so "nearer in time" has two candidates
    return RangeDataset("jumps", ds.ground_truth, ds.odometry, ds.dead_reckoning, ds.landmarks, td, "test")


def test_file_order_attachment_is_the_scripts_scan():
    ds = with_backward_ranges()
    got = attach_ranges(ds.times, ds.ranges[:, 0], "file-order")
    np.testing.assert_array_equal(got, scripts_scan(ds.times, ds.ranges[:, 0]))
    by_time = attach_ranges(ds.times, ds.ranges[:, 0], "time")
    late = got != by_time
    assert late.any() and np.all(got[late] > by_time[late])  # rows going back are taken late, never early
    np.testing.assert_array_equal(by_time, [np.argmax(ds.times >= t) for t in ds.ranges[:, 0]])


def test_plaza_attachment_and_correction_follow_the_scripts(shared_data):
    plaza = load_cmu_mat(shared_data / "Plaza1_thrown_away_some_range.mat")
    got = attach_ranges(plaza.times, plaza.ranges[:, 0])
    np.testing.assert_array_equal(got, scripts_scan(plaza.times, plaza.ranges[:, 0]))
    assert np.all(np.diff(got) >= 0)
    np.testing.assert_allclose(range_correction(plaza, 3000), scripts_range_fit(plaza, 3000), rtol=1e-12)


def test_range_correction_is_the_scripts_fit():
    ds = with_backward_ranges()
    np.testing.assert_allclose(range_correction(ds, 50), scripts_range_fit(ds, 50), rtol=1e-12)


def test_a_range_after_the_last_pose_is_an_error():
    with pytest.raises(DataError, match=r"range row 2 at t=9\.5"):
        attach_ranges(np.arange(5.0), np.array([1.0, 2.0, 9.5]))
    with pytest.raises(SteamError, match="'sorted'"):
        attach_ranges(np.arange(5.0), np.array([1.0]), "sorted")
    with pytest.raises(SteamError, match="range_attachment"):
        PaperSetup.plaza().replace(range_attachment="sorted")


def test_readings_list_ranges_by_pose_in_file_order():
    ds = with_backward_ranges()
    r = Readings.from_dataset(ds, PaperSetup.synthetic())
    np.testing.assert_array_equal(r.range_pose, scripts_scan(ds.times, ds.ranges[:, 0]))
    np.testing.assert_array_equal(r.range_value, ds.ranges[:, 3])
    t = Readings.from_dataset(ds, PaperSetup.synthetic().replace(range_attachment="time"))
    pose = [int(np.argmax(ds.times >= t)) for t in ds.ranges[:, 0]]
    order = np.array(sorted(range(len(pose)), key=lambda k: (pose[k], ds.ranges[k, 0])))  # by pose, then time
    np.testing.assert_array_equal(t.range_value, ds.ranges[order, 3])
    np.testing.assert_array_equal(t.range_pose, np.sort(attach_ranges(ds.times, ds.ranges[:, 0], "time")))
    assert not np.array_equal(order, np.arange(len(order)))  # the file's order is not the time order


# --- the front end's initial guesses and landmarks ----------------------------------------------


def _first_steps(setup: PaperSetup, data: RangeDataset, n: int):
    front = FrontEnd(Readings.from_dataset(data, setup), setup, Layout())
    return front, [front.step() for _ in range(n)]


def test_plaza_landmarks_enter_up_front_synthetic_at_first_sighting():
    ds = generate_synthetic(n_steps=30, n_landmarks=6, seed=2)
    setup = PaperSetup.plaza().replace(range_correction_steps=0)
    _, steps = _first_steps(setup, ds, 1)
    priors = {f.keys[0] for f in steps[0].factors if isinstance(f, PriorFactor)}
    assert priors == {X(0)} | {L(int(i)) for i in ds.landmarks[:, 0]}
    assert set(steps[0].values) == priors
    front, steps = _first_steps(PaperSetup.synthetic(), ds, 31)
    for s in steps:
        seen = {f.keys[1] for f in s.factors if isinstance(f, RangeFactor)}
        new = {f.keys[0] for f in s.factors if isinstance(f, PriorFactor) and f.keys[0].symbol == "l"}
        assert new <= seen  # a landmark's prior comes with a range to it
    assert front.landmarks == set(np.unique(ds.ranges[:, 2]).astype(int).tolist())


def test_initial_velocity_is_the_backward_difference_with_the_scripts_pose2_heading():
    ds = generate_synthetic(n_steps=12, n_landmarks=3, seed=1)
    gt = ds.ground_truth.copy()
    gt[0, 3] = np.pi - 0.01  # the first heading sits just below π
    dr = ds.odometry.copy()
    dr[:, 2] = 0.004  # turning left: the heading crosses π at the third step
    ds = RangeDataset("turn", gt, dr, ds.dead_reckoning, ds.landmarks, ds.ranges, "test")
    for scripts in (True, False):
        setup = PaperSetup.synthetic().replace(pose2_heading_rate_guess=scripts)
        _, steps = _first_steps(setup, ds, 6)
        pose = gt[0, 1:4]
        for i in range(1, 6):
            new = compose(pose, dr[i - 1, 1], dr[i - 1, 2])
            guess = steps[i].values[X(i)]
            np.testing.assert_allclose(guess[:3], new, rtol=0, atol=1e-12)
            np.testing.assert_allclose(guess[3:5], new[:2] - pose[:2], rtol=0, atol=1e-12)
            crossed = new[2] > np.pi >= pose[2]
            expected = 0.004 - 2 * np.pi if scripts and crossed else 0.004
            assert guess[5] == pytest.approx(expected, abs=1e-12), (scripts, i)
            pose = new


def test_rebase_composes_the_next_guess_from_the_estimate():
    ds = generate_synthetic(n_steps=10, n_landmarks=3, seed=1)
    front, _ = _first_steps(PaperSetup.synthetic(), ds, 3)
    estimate = np.array([4.0, -2.0, 0.3, 0.0, 0.0, 0.0])
    front.rebase(estimate)
    step = front.step()
    np.testing.assert_allclose(
        step.values[X(3)][:3], compose(estimate[:3], ds.odometry[2, 1], ds.odometry[2, 2]), atol=1e-12
    )


def test_departures_are_named_and_change_only_their_fields():
    from steam_ref.paper.presets import DEPARTURES

    base = PaperSetup.plaza()
    for name, changes in DEPARTURES.items():
        departed = base.departing(name)
        for field, value in changes.items():
            assert getattr(departed, field) == value != getattr(base, field), (name, field)
    both = base.departing("time-attachment", "landmarks-at-sighting")
    assert both.range_attachment == "time" and not both.landmarks_up_front and both.relinearize_blocks == (3, 3)
    with pytest.raises(SteamError, match="'sorted-ranges'"):
        base.departing("sorted-ranges")
