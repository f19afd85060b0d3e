"""steam_ref.evaluate and steam_ref.trajectory on the inputs a user passes that the main tests do not: a
trajectory whose first state is not pose 0, NaN and strings, a reflection in a KITTI file, a quaternion
with qw < 0, a missing file, an RPE delta longer than the trajectory. Each answer is checked against the
dense GP posterior, evo reading the same file, or a hand computation."""

import os
import re

import numpy as np
import pytest
import scipy.stats
from requirements import optional_import
from test_trajectory import POSE_TIMES, STATES, DenseSolver, dense  # noqa: F401 - the dense GP posterior fixture

from steam_ref.errors import DataError, SteamError
from steam_ref.evaluate import (
    Alignment,
    Statistics,
    align_planar,
    alignment_defect,
    chi2_quantile,
    nees,
    pose_errors,
    read_kitti,
    read_tum,
    rpe,
    rpe_pairs,
    states_at,
    trajectory_figures,
    verdict,
    write_tum,
)
from steam_ref.trajectory import Trajectory
from steam_ref.variables import X

TRUTH = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.1], [2.0, 1.0, 0.5], [3.0, 1.0, 3.1]])


class WholeSolver(DenseSolver):
    """The dense posterior read the way ``at_every_pose`` and ``covariances`` read a solver."""

    def estimate(self):
        return self.mean

    def marginal_covariances(self, keys):
        return {k: self.joint_covariance([k]) for k in keys}

    def joint_covariances(self, pairs):
        return [self.joint_covariance(list(p)) for p in pairs]


# -- a trajectory whose first state is not pose 0 --


def test_every_pose_of_a_span_starting_after_pose_0_is_the_dense_posterior(dense):  # noqa: F811 - the fixture
    """States at poses 2, 3, 5: the span is poses 2..5, each the dense GP posterior (pose 4 by [YIB Eq. 18]);
    poses 0 and 1, before the first state, have no estimate and must not be returned."""
    qc, solver, posterior = dense
    solver = WholeSolver(solver.mean, solver.cov, solver.index)
    trajectory = Trajectory(solver, STATES[1:], POSE_TIMES, qc)
    times, states = trajectory.at_every_pose()
    np.testing.assert_array_equal(times, POSE_TIMES[2:6])
    covariances = trajectory.covariances([])
    assert states.shape == (4, 6) and covariances.pose.shape == (4, 3, 3) == covariances.velocity.shape
    for k, t in enumerate(times):
        mean, cov = posterior(t)
        np.testing.assert_allclose(states[k], mean, rtol=1e-7, atol=1e-9 * np.abs(mean).max())
        np.testing.assert_allclose(covariances.pose[k], cov[:3, :3], rtol=1e-7, atol=1e-9 * np.abs(cov).max())
        np.testing.assert_allclose(covariances.velocity[k], cov[3:, 3:], rtol=1e-7, atol=1e-9 * np.abs(cov).max())


# -- states_at --


def test_states_at_refuses_times_that_are_not_a_list_of_times(dense):  # noqa: F811 - the fixture
    qc, solver, _ = dense
    trajectory = Trajectory(solver, STATES, POSE_TIMES, qc)
    with pytest.raises(SteamError, match=r"times must be .*1-d.*\(2, 2\)"):
        states_at(trajectory, [[0.5, 1.0], [1.5, 2.0]])
    with pytest.raises(SteamError, match="times"):
        states_at(trajectory, "0.5")
    with pytest.raises(SteamError, match="times"):
        states_at(trajectory, [True, False])


# -- NEES and its verdict --


@pytest.mark.parametrize("anees", [float("nan"), float("inf"), -1.0, "1.0", None])
def test_verdict_refuses_an_anees_that_is_not_a_number(anees):
    with pytest.raises(SteamError, match="anees"):
        verdict(anees, (0.5, 1.5))


def test_verdict_refuses_a_band_upside_down():
    with pytest.raises(SteamError, match="band"):
        verdict(1.0, (1.5, 0.5))
    assert verdict(1.0, (0.5, 1.5)) == "consistent"  # the band by hand: 0.5 ≤ 1 ≤ 1.5


def test_pose_errors_and_nees_refuse_what_is_not_a_finite_array():
    with pytest.raises(SteamError, match=r"estimate.*nan|estimate.*finite"):
        pose_errors([[np.nan, 0.0, 0.0]], [[0.0, 0.0, 0.0]])
    with pytest.raises(SteamError, match="estimate"):
        pose_errors("a", [[0.0, 0.0, 0.0]])
    with pytest.raises(SteamError, match="errors"):
        nees("a", [np.eye(3)])
    # and a heading error across ±π by hand: 3.1 - (-3.1) = 6.2 wraps to 6.2 - 2π
    e = pose_errors([[0.0, 0.0, 3.1]], [[0.0, 0.0, -3.1]])
    assert e[0, 2] == pytest.approx(6.2 - 2 * np.pi, abs=1e-15)


# -- alignment --


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_alignment_refuses_points_not_finite(bad):
    with pytest.raises(SteamError, match=r"estimate\[1, 0\] = (nan|inf)"):
        align_planar([[0.0, 0.0], [bad, 1.0], [2.0, 0.0]], [[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]])
    with pytest.raises(SteamError, match=r"truth\[1, 0\] = (nan|inf)"):
        align_planar([[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]], [[0.0, 0.0], [bad, 1.0], [2.0, 0.0]])


def test_alignment_refuses_a_string():
    with pytest.raises(SteamError, match="estimate"):
        align_planar("ab", [[0.0, 0.0], [1.0, 1.0]])


# -- RPE --


@pytest.mark.parametrize("tolerance", [-0.1, float("nan"), "0.1"])
def test_rpe_pairs_refuses_a_tolerance_that_is_not_a_number_at_least_0(tolerance):
    with pytest.raises(SteamError, match="relative_tolerance"):
        rpe_pairs(TRUTH, 1.0, unit="m", all_pairs=True, relative_tolerance=tolerance)


def test_rpe_pairs_refuses_all_pairs_that_is_not_a_bool():
    with pytest.raises(SteamError, match="all_pairs"):
        rpe_pairs(TRUTH, 1, all_pairs="no")


def test_an_rpe_longer_than_the_trajectory_names_delta_at_once():
    with pytest.raises(SteamError, match=r"delta=10.*4 poses"):
        rpe(TRUTH, TRUTH + 0.01, 10)
    with pytest.raises(SteamError, match=r"delta=100\.0.*4 poses"):
        rpe(TRUTH, TRUTH + 0.01, 100.0, unit="m")


def test_trajectory_figures_refuses_an_rpe_delta_that_is_not_a_positive_integer():
    for delta in ("a", 0, 1.5, None):
        with pytest.raises(SteamError, match="rpe_delta"):
            trajectory_figures(TRUTH, TRUTH + 0.01, rpe_delta=delta)


# -- files --


def test_a_kitti_reflection_is_refused(tmp_path):
    """diag(1, -1, 1) is orthogonal, in the plane, with det -1: a mirror, not a rotation about z."""
    (tmp_path / "mirror.kitti").write_text("1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 1 0 -1 0 2 0 0 1 0\n")
    with pytest.raises(DataError, match="line 2: not a planar pose"):
        read_kitti(tmp_path / "mirror.kitti")


def test_a_missing_file_is_a_data_error_naming_it(tmp_path):
    for reader in (read_tum, read_kitti):
        with pytest.raises(DataError, match=r"nowhere\.txt: cannot read it"):
            reader(tmp_path / "nowhere.txt")
        with pytest.raises(DataError, match=re.escape(f"{tmp_path}: not a file (a folder)")):
            reader(tmp_path)  # a directory


def test_a_number_with_an_underscore_is_not_read_as_another_number(tmp_path):
    """Python's float() reads '1_0' as 10 and a full-width '１' as 1; a trajectory file's number is plain ASCII."""
    (tmp_path / "a.txt").write_text("1 1_0 0 0 0 0 0 1\n")
    with pytest.raises(DataError, match="line 1: not a number"):
        read_tum(tmp_path / "a.txt")
    (tmp_path / "b.txt").write_text("1 \uff11 0 0 0 0 0 1\n", encoding="utf-8")  # a full-width digit one
    with pytest.raises(DataError, match="line 1: byte 0xef is not ASCII"):
        read_tum(tmp_path / "b.txt")


def test_a_tum_heading_comes_back_in_minus_pi_to_pi(tmp_path):
    """q and -q are one rotation; θ = 3.0 written as -q (qw < 0), and θ = 7.0 written by write_tum, come back
    as the heading in [-π, π): 3.0 and 7.0 - 2π (by hand)."""
    h = 1.5
    (tmp_path / "neg.txt").write_text(f"1 0 0 0 0 0 {-np.sin(h):.17g} {-np.cos(h):.17g}\n")
    _, poses = read_tum(tmp_path / "neg.txt")
    assert poses[0, 2] == pytest.approx(3.0, abs=1e-15)
    write_tum(tmp_path / "big.txt", [1.0], [[0.0, 0.0, 7.0]])
    _, poses = read_tum(tmp_path / "big.txt")
    assert poses[0, 2] == pytest.approx(7.0 - 2 * np.pi, abs=1e-14)


def test_a_tum_file_with_crlf_and_comments_reads_as_evo_reads_it(tmp_path):
    """Windows line endings and a comment, read by evo too; blank lines (which evo refuses) change nothing. The last
    line ends with its line end, as every data file's must (a file cut inside its last number is refused:
    test_readers_refuse_bad_files.py)."""
    file_interface = optional_import("evo.tools.file_interface", "evo")
    lines = ["# timestamp tx ty tz qx qy qz qw", "1.5 1e6 -2e6 0 0 0 0.6 0.8", "2.5 3 4 0 0 0 -0.6 0.8"]
    (tmp_path / "w.txt").write_bytes("\r\n".join(lines).encode() + b"\r\n")
    times, poses = read_tum(tmp_path / "w.txt")
    theirs = file_interface.read_tum_trajectory_file(tmp_path / "w.txt")
    np.testing.assert_array_equal(times, theirs.timestamps)
    np.testing.assert_array_equal(poses[:, :2], theirs.positions_xyz[:, :2])
    yaw = np.array([np.arctan2(m[1, 0], m[0, 0]) for m in theirs.poses_se3])
    np.testing.assert_allclose(poses[:, 2], yaw, atol=1e-15)
    (tmp_path / "blank.txt").write_bytes("\r\n\r\n".join(lines).encode() + b"\r\n\r\n")
    blank_times, blank_poses = read_tum(tmp_path / "blank.txt")
    np.testing.assert_array_equal(blank_times, times)
    np.testing.assert_array_equal(blank_poses, poses)


def test_write_tum_refuses_times_that_are_not_numbers(tmp_path):
    with pytest.raises(SteamError, match="times"):
        write_tum(tmp_path / "a.txt", "abcd", TRUTH)


def test_a_pose_at_the_time_of_a_state_is_that_state(dense):  # noqa: F811 - the fixture
    """Times need only not decrease: pose 1 shares state 0's time and pose 4 state 5's. The GP at those times is
    the dense posterior there, which is the state's own (the query ``at`` already says so)."""
    qc, solver, posterior = dense
    solver = WholeSolver(solver.mean, solver.cov, solver.index)
    times = POSE_TIMES.copy()
    times[1], times[4] = times[0], times[5]
    trajectory = Trajectory(solver, STATES, times, qc)
    got_times, states = trajectory.at_every_pose()
    covariances = trajectory.covariances([])
    np.testing.assert_array_equal(got_times, times[:6])
    for pose in (1, 4):
        mean, cov = posterior(times[pose])
        np.testing.assert_allclose(states[pose], mean, rtol=1e-12, atol=1e-12 * np.abs(mean).max())
        np.testing.assert_allclose(covariances.pose[pose], cov[:3, :3], rtol=1e-12, atol=1e-12 * np.abs(cov).max())
        np.testing.assert_allclose(covariances.velocity[pose], cov[3:, 3:], rtol=1e-12, atol=1e-12 * np.abs(cov).max())


def test_nees_refuses_a_covariance_that_is_not_symmetric():
    """A Cholesky factorisation reads one triangle only: [[1, 5], [0, 1]] would pass as the identity (NEES 2)."""
    with pytest.raises(SteamError, match=r"covariances\[0\] must be symmetric"):
        nees([[1.0, 1.0]], [[[1.0, 5.0], [0.0, 1.0]]])
    P = np.array([[2.0, 0.5], [0.5, 1.0]])  # and a symmetric one by hand: eᵀ P⁻¹ e, P⁻¹ = [[1, -.5], [-.5, 2]] / 1.75
    assert nees([[1.0, 1.0]], [P])[0] == pytest.approx((1.0 - 1.0 + 2.0) / 1.75, rel=1e-14)


def test_statistics_refuse_errors_that_are_not_a_finite_list():
    with pytest.raises(SteamError, match=r"errors\[0\] = nan"):
        Statistics.of([np.nan, 1.0])
    with pytest.raises(SteamError, match="errors"):
        Statistics.of("ab")
    with pytest.raises(SteamError, match=r"errors must be a 1-d array.*\(2, 2\)"):
        Statistics.of([[1.0, 2.0], [3.0, 4.0]])
    s = Statistics.of([3.0, 4.0, 0.0])  # by hand: √(25/3), 7/3, 3, 4
    assert (s.rmse, s.mean, s.median, s.max, s.n) == pytest.approx((np.sqrt(25 / 3), 7 / 3, 3.0, 4.0, 3), rel=1e-15)


def test_neighbours_refuses_a_time_that_is_not_a_number(dense):  # noqa: F811 - the fixture
    qc, solver, _ = dense
    trajectory = Trajectory(solver, STATES, POSE_TIMES, qc)
    with pytest.raises(SteamError, match="t must be a real number"):
        trajectory.neighbours("1.0")
    assert trajectory.neighbours(1.1) == 2 and trajectory.neighbours(2.0) == (3, 5)  # by hand from POSE_TIMES


def test_an_alignment_refuses_what_it_cannot_apply():
    with pytest.raises(SteamError, match="angle must be a finite number"):
        Alignment(float("nan"), np.zeros(2))
    with pytest.raises(SteamError, match=r"translation must be a finite \(2,\) vector"):
        Alignment(0.0, np.zeros(3))
    with pytest.raises(SteamError, match="scale must be a finite number > 0"):
        Alignment(0.0, np.zeros(2), -1.0)
    with pytest.raises(SteamError, match=r"poses must be an \(n, 3\) array"):
        Alignment(0.5, [1.0, 2.0]).apply([[1.0, 2.0]])
    with pytest.raises(SteamError, match=r"poses\[0, 0\] = nan"):
        Alignment(0.5, [1.0, 2.0]).apply([[np.nan, 0.0, 0.0]])
    # by hand: p = (1, 0), θ = 3 turned by π/2, scaled by 2, moved by (1, 2): (1, 4), heading 3 + π/2 - 2π
    moved = Alignment(np.pi / 2, [1.0, 2.0], 2.0).apply([[1.0, 0.0, 3.0]])
    np.testing.assert_allclose(moved, [[1.0, 4.0, 3.0 + np.pi / 2 - 2 * np.pi]], atol=1e-15)


def test_covariances_of_a_prior_not_over_planar_poses_are_refused():
    """With Qc 2 × 2 the state is [x, y, ẋ, ẏ]: its first 3 × 3 block is not the covariance of [x, y, θ]."""
    keys = {X(0): np.zeros(4), X(1): np.ones(4)}
    solver = WholeSolver(keys, np.eye(8), {X(0): np.arange(4), X(1): 4 + np.arange(4)})
    trajectory = Trajectory(solver, [0, 1], [0.0, 1.0], np.eye(2))
    with pytest.raises(SteamError, match=r"\[x, y, θ\].*d = 2"):
        trajectory.covariances([])


@pytest.mark.parametrize(("p", "dof"), [(1.5, 3), (-0.1, 3), (float("nan"), 3), (0.5, 0), (0.5, -2), ("0.5", 3)])
def test_chi2_quantile_refuses_a_probability_or_dof_out_of_range(p, dof):
    """SciPy's gammaincinv answers NaN for these; the quantile must say why instead."""
    with pytest.raises(SteamError, match=r"^(p|dof) must be"):
        chi2_quantile(p, dof)


def test_chi2_quantile_equals_scipys_chi2_ppf():
    for p, dof in [(0.025, 1), (0.975, 30), (0.5, 2.5), (0.0, 4), (0.999, 300)]:
        assert chi2_quantile(p, dof) == pytest.approx(scipy.stats.chi2.ppf(p, dof), rel=1e-12)


def test_states_at_refuses_times_after_the_estimate_unless_asked_to_predict(dense):  # noqa: F811 - the fixture
    """Truth stamped on another clock (all after the last state) was silently compared with the prior's predictions;
    a time after the last state is refused naming it and the span, and ``extrapolate=True`` gives the dense GP's
    posterior there (the prior's prediction from the last state)."""
    qc, solver, posterior = dense
    trajectory = Trajectory(solver, STATES, POSE_TIMES, qc)
    with pytest.raises(SteamError, match=r"times\[1\] = 6\.0 is after the last estimated state at t=3"):
        states_at(trajectory, [1.1, 6.0])
    mean = states_at(trajectory, [1.1, 6.0], extrapolate=True)[1]
    expected, _ = posterior(6.0)
    np.testing.assert_allclose(mean, expected, rtol=1e-7, atol=1e-9 * np.abs(expected).max())


# -- statistics without overflow, poses that are numbers, nees of nothing, files that are not files --


def test_statistics_of_huge_errors_do_not_overflow():
    """e * e overflows past 1e154: rmse was inf for errors of 1e200 (and the JSON line then carried Infinity).
    By hand: rmse of (1, 2, 3) · 1e200 is 1e200 √(14/3), mean 2e200, median 2e200."""
    s = Statistics.of(np.array([1e200, 2e200, 3e200]))
    assert s.rmse == pytest.approx(1e200 * np.sqrt(14 / 3), rel=1e-15)
    assert (s.mean, s.median, s.max) == (pytest.approx(2e200, rel=1e-15), pytest.approx(2e200, rel=1e-15), 3e200)
    s = Statistics.of(np.array([1e308, 1.7e308]))  # their mean and median overflow a plain sum
    assert np.isfinite([s.rmse, s.mean, s.median]).all() and s.mean == pytest.approx(1.35e308, rel=1e-15)


def test_statistics_of_tiny_errors_do_not_underflow():
    """5e-324 squared is 0: rmse was 0, below the mean 5e-324, which no set of errors has (rmse >= |mean|)."""
    s = Statistics.of(np.array([5e-324, 5e-324]))
    assert s.rmse == s.mean == s.median == s.max == 5e-324
    s = Statistics.of(np.array([3e-200, 4e-200]))
    assert s.rmse == pytest.approx(np.sqrt(12.5) * 1e-200, rel=1e-15)


def test_trajectory_figures_far_from_the_origin_are_finite():
    truth = TRUTH * 1e200
    estimate = truth + np.array([1e199, 0.0, 0.0])
    figures = trajectory_figures(truth, estimate)
    assert figures["ape"]["translation_m"]["rmse"] == pytest.approx(1e199, rel=1e-12)
    assert figures["ape_se2"]["translation_m"]["rmse"] == pytest.approx(0.0, abs=1e186)  # a translation aligns it


@pytest.mark.parametrize("poses", [[[True, False, True]], np.array([[1 + 2j, 0.0, 0.0]]), [["1", "0", "0"]]])
def test_poses_that_are_not_real_numbers_are_refused(poses):
    with pytest.raises(SteamError, match="truth"):
        trajectory_figures(poses, [[0.0, 0.0, 0.0]])


def test_nees_of_a_state_of_no_dimension_is_refused():
    with pytest.raises(SteamError, match=r"d >= 1.*\(2, 0\)"):
        nees(np.zeros((2, 0)), np.zeros((2, 0, 0)))


def test_read_tum_refuses_a_named_pipe_and_a_device_without_reading(tmp_path):
    import signal

    fifo = tmp_path / "t.txt"
    os.mkfifo(fifo)
    previous = signal.signal(signal.SIGALRM, lambda *_: pytest.fail("read_tum blocked on a named pipe"))
    signal.alarm(10)
    try:
        with pytest.raises(DataError, match=r"t\.txt: not a file \(a FIFO\)"):
            read_tum(fifo)
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)
    with pytest.raises(DataError, match=r"/dev/zero: not a file \(a device\)"):
        read_tum("/dev/zero")  # it was read to a MemoryError


def test_write_tum_names_the_time_that_does_not_increase(tmp_path):
    with pytest.raises(DataError, match=r"times\[2\] = 1\.0 follows times\[1\] = 1\.0"):
        write_tum(tmp_path / "t.txt", [0.0, 1.0, 1.0, 2.0], TRUTH)
    with pytest.raises(DataError, match=r"times\[3\] = inf"):
        write_tum(tmp_path / "t.txt", [0.0, 1.0, 2.0, np.inf], TRUTH)
    assert not (tmp_path / "t.txt").exists()


# -- alignment where none is defined --


def test_a_truth_that_does_not_move_has_no_alignment_even_to_rounding():
    """Equal points centre to a few ulps, not to zero (0.1 · 3 / 3 != 0.1); a rotation fitted to those ulps
    came out as an SE(2) angle of noise and a Sim(2) scale of 1e-33, in silence."""
    truth = np.full((3, 2), 0.1)
    assert np.any(truth - truth.mean(axis=0) != 0)  # the rounding this is about
    estimate = TRUTH[:3, :2]
    reason = alignment_defect(estimate, truth)
    assert reason is not None and "truth's positions all coincide" in reason
    for with_scale in (False, True):
        with pytest.raises(SteamError, match="truth's positions all coincide"):
            align_planar(estimate, truth, with_scale=with_scale)
    assert alignment_defect(truth, estimate) == (
        "alignment is undefined: the estimate's positions all coincide, no rotation is determined"
    )
    assert alignment_defect(estimate, estimate + 1e-9) is None  # a tiny offset of a moving path aligns


def test_alignment_of_points_far_from_the_origin_is_the_rotation_by_hand():
    """Umeyama on points 1e200 away: Σ x̃ᵢ·ỹᵢ overflowed. The truth is the estimate turned by 0.3 rad."""
    estimate = TRUTH[:, :2] * 1e200
    c, s = np.cos(0.3), np.sin(0.3)
    truth = estimate @ np.array([[c, -s], [s, c]]).T
    found = align_planar(estimate, truth, with_scale=True)
    assert found.angle == pytest.approx(0.3, abs=1e-14) and found.scale == pytest.approx(1.0, abs=1e-14)


@pytest.mark.parametrize("errors", [[], [1.0, np.nan], np.zeros((2, 2))])
def test_the_rmse_alone_checks_its_errors_as_the_statistics_do(errors):
    with pytest.raises(SteamError) as alone:
        Statistics.rmse_of(errors)
    with pytest.raises(SteamError) as whole:
        Statistics.of(errors)
    assert str(alone.value) == str(whole.value)


def test_the_rmse_alone_is_the_statistics_rmse():
    e = np.array([3.0, 4.0, 1e-300])
    assert Statistics.rmse_of(e) == Statistics.of(e).rmse == Statistics.rmse_of(e.tolist())
