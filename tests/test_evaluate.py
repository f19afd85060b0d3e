"""steam_ref.evaluate: APE and RPE against evo on the same TUM files (to 1e-9), the alignment against a
known transform and against Umeyama's SVD written out densely, TUM/KITTI round trips (the CLI's
--save-trajectory too), the estimate at the truth's times against the dense GP posterior, bad files."""

import copy
import json

import numpy as np
import pytest
from requirements import optional_import
from test_trajectory import POSE_TIMES, STATES, dense  # noqa: F401 - the dense GP posterior fixture

from steam_ref.cli.commands import main
from steam_ref.datasets import generate_synthetic, load_dataset
from steam_ref.errors import DataError, ShapeError, SteamError
from steam_ref.evaluate import (
    align_planar,
    ape,
    read_kitti,
    read_tum,
    rpe,
    rpe_pairs,
    states_at,
    write_kitti,
    write_tum,
)
from steam_ref.paper.online import run_online
from steam_ref.paper.options import StreamOptions
from steam_ref.paper.presets import PaperSetup
from steam_ref.trajectory import Trajectory


def _walk(rng, n=60):
    """A planar path with turns: poses (n, 3), headings unwrapped beyond ±π."""
    theta = np.cumsum(rng.normal(0.0, 0.3, n)) + 2.5
    xy = np.cumsum(np.column_stack([np.cos(theta), np.sin(theta)]) * rng.uniform(0.5, 1.5, (n, 1)), axis=0)
    return np.column_stack([xy, theta])


def _moved(poses, angle, t, s=1.0):
    c, si = np.cos(angle), np.sin(angle)
    xy = s * poses[:, :2] @ np.array([[c, -si], [si, c]]).T + t
    return np.column_stack([xy, poses[:, 2] + angle])


# -- alignment --


@pytest.mark.parametrize("with_scale", [False, True])
def test_alignment_recovers_a_known_transform(rng, with_scale):
    truth = _walk(rng)
    angle, t, s = 2.7, np.array([-4.0, 11.5]), (0.37 if with_scale else 1.0)
    # the estimate is the truth moved by the inverse transform: p = R(-φ)(y - t)/s, θ - φ
    c, si = np.cos(-angle), np.sin(-angle)
    xy = (truth[:, :2] - t) @ np.array([[c, -si], [si, c]]).T / s
    inverse = np.column_stack([xy, truth[:, 2] - angle])
    found = align_planar(inverse[:, :2], truth[:, :2], with_scale=with_scale)
    assert found.angle == pytest.approx(angle, abs=1e-12)
    np.testing.assert_allclose(found.translation, t, atol=1e-10)
    assert found.scale == pytest.approx(s, rel=1e-12)
    err = ape(truth, inverse, align="sim2" if with_scale else "se2")
    assert err.translation.max() < 1e-10 and err.heading.max() < 1e-12


def _umeyama_svd(x, y, with_scale):
    """Umeyama (1991) as written there: SVD of the cross-covariance, S fixing the determinant (dense oracle)."""
    mx, my = x.mean(0), y.mean(0)
    sigma = (y - my).T @ (x - mx) / len(x)
    U, D, Vt = np.linalg.svd(sigma)
    S = np.diag([1.0, np.sign(np.linalg.det(U) * np.linalg.det(Vt))])
    R = U @ S @ Vt
    c = np.trace(np.diag(D) @ S) / np.mean(np.sum((x - mx) ** 2, axis=1)) if with_scale else 1.0
    return R, my - c * R @ mx, c


@pytest.mark.parametrize("with_scale", [False, True])
def test_alignment_equals_umeyamas_svd_on_noisy_points(rng, with_scale):
    truth = _walk(rng)[:, :2]
    estimate = _moved(np.column_stack([truth, np.zeros(len(truth))]), -1.1, [3.0, -2.0], 1.3)[:, :2]
    estimate += rng.normal(0, 0.5, estimate.shape)
    R, t, c = _umeyama_svd(estimate, truth, with_scale)
    found = align_planar(estimate, truth, with_scale=with_scale)
    np.testing.assert_allclose(found.rotation, R, atol=1e-12)
    np.testing.assert_allclose(found.translation, t, atol=1e-10)
    assert found.scale == pytest.approx(c, rel=1e-12)


def test_alignment_refuses_degenerate_points():
    with pytest.raises(SteamError, match="coincide"):
        align_planar(np.ones((5, 2)), np.arange(10.0).reshape(5, 2))
    with pytest.raises(SteamError, match="n >= 2"):
        align_planar(np.ones((1, 2)), np.ones((1, 2)))


# -- APE and RPE by brute force --


def test_ape_and_rpe_equal_brute_force_se2_products(rng):
    truth, estimate = _walk(rng), _walk(rng)

    def se2(p):
        c, s = np.cos(p[2]), np.sin(p[2])
        return np.array([[c, -s, p[0]], [s, c, p[1]], [0, 0, 1]])

    def angle(m):
        return abs(np.arctan2(m[1, 0], m[0, 0]))

    err = ape(truth, estimate)
    for k in range(len(truth)):
        e = np.linalg.inv(se2(truth[k])) @ se2(estimate[k])
        assert err.heading[k] == pytest.approx(angle(e), abs=1e-12)
        assert err.translation[k] == pytest.approx(np.hypot(*(estimate[k, :2] - truth[k, :2])), abs=1e-12)
    for delta, all_pairs in ((1, False), (4, False), (3, True)):
        r = rpe(truth, estimate, delta, all_pairs=all_pairs)
        pairs = rpe_pairs(truth, delta, all_pairs=all_pairs)
        assert len(pairs) == len(r.translation) == (len(truth) - delta if all_pairs else (len(truth) - 1) // delta)
        for (i, j), t_err, h_err in zip(pairs, r.translation, r.heading, strict=True):
            q = np.linalg.inv(se2(truth[i])) @ se2(truth[j])
            p = np.linalg.inv(se2(estimate[i])) @ se2(estimate[j])
            e = np.linalg.inv(q) @ p
            assert t_err == pytest.approx(np.hypot(e[0, 2], e[1, 2]), abs=1e-12)
            assert h_err == pytest.approx(angle(e), abs=1e-12)
    stats = err.translation_stats
    assert stats.rmse == pytest.approx(np.sqrt(np.mean(err.translation**2)))
    assert (stats.median, stats.max, stats.n) == (np.median(err.translation), err.translation.max(), len(truth))


def test_bad_input_names_the_argument():
    with pytest.raises(ShapeError, match="truth and estimate must hold the same poses"):
        ape(np.zeros((3, 3)), np.zeros((4, 3)))
    with pytest.raises(ShapeError, match=r"estimate must be an \(n, 3\)"):
        ape(np.zeros((3, 3)), np.zeros((3, 2)))
    with pytest.raises(SteamError, match=r"truth\[1\] is not finite"):
        ape([[0, 0, 0], [np.nan, 0, 0]], np.zeros((2, 3)))
    with pytest.raises(SteamError, match="align must be one of"):
        ape(np.zeros((3, 3)), np.zeros((3, 3)), align="se3")
    with pytest.raises(SteamError, match="positive integer, got 0"):
        rpe(np.zeros((3, 3)), np.zeros((3, 3)), 0)
    with pytest.raises(SteamError, match="unit must be"):
        rpe(np.zeros((3, 3)), np.zeros((3, 3)), 1, unit="s")


# -- files --


def test_tum_and_kitti_round_trip(tmp_path, rng):
    poses = _walk(rng)
    times = 1.7e9 + np.cumsum(rng.uniform(0.01, 0.2, len(poses)))
    write_tum(tmp_path / "a.txt", times, poses)
    t, back = read_tum(tmp_path / "a.txt")
    np.testing.assert_array_equal(t, times)
    np.testing.assert_array_equal(back[:, :2], poses[:, :2])  # 17 digits: the same floats
    np.testing.assert_allclose(np.angle(np.exp(1j * (back[:, 2] - poses[:, 2]))), 0, atol=1e-14)
    write_kitti(tmp_path / "a.kitti", poses)
    back = read_kitti(tmp_path / "a.kitti")
    np.testing.assert_array_equal(back[:, :2], poses[:, :2])
    np.testing.assert_allclose(np.angle(np.exp(1j * (back[:, 2] - poses[:, 2]))), 0, atol=1e-14)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("# only a comment\n", "no poses"),
        ("1 0 0 0 0 0 0 1\n2 0 0 0.5 0 0 0 1\n", "line 2: not a planar pose"),
        ("1 0 0 0 0.1 0 0 0.99\n", "line 1: not a planar pose"),
        ("1 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 1\n", "line 2: timestamp 1.0 does not increase"),
        ("1 0 0 0 0 0 1\n", "line 1: a TUM line has 8 numbers, this one 7"),
        ("1 0 0 0 0 0 x 1\n", "line 1: not a number"),
        ("1 0 nan 0 0 0 0 1\n", "line 1: not finite"),
    ],
)
def test_a_bad_tum_file_is_refused_naming_the_line(tmp_path, text, message):
    (tmp_path / "bad.txt").write_text(text)
    with pytest.raises(DataError, match=message):
        read_tum(tmp_path / "bad.txt")


def test_a_kitti_pose_out_of_the_plane_is_refused(tmp_path):
    (tmp_path / "bad.kitti").write_text("1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 0 -1 0 0 1 0 0\n")
    with pytest.raises(DataError, match="line 2: not a planar pose"):
        read_kitti(tmp_path / "bad.kitti")


def test_save_trajectory_round_trips_through_the_cli(tmp_path, capsys):
    tum, npz, kitti = tmp_path / "est.txt", tmp_path / "est.npz", tmp_path / "est.kitti"
    args = ["run", "--max-poses", "60", "--json", "--save-trajectory", str(tum), "--save-estimates", str(npz)]
    assert main(args) == 0
    summary = json.loads(capsys.readouterr().out)
    saved = np.load(npz)
    times, poses = read_tum(tum)
    np.testing.assert_array_equal(poses[:, :2], np.column_stack([saved["x"], saved["y"]]))
    np.testing.assert_allclose(np.angle(np.exp(1j * (poses[:, 2] - saved["theta"]))), 0, atol=1e-14)
    truth = generate_synthetic(seed=0).ground_truth[:60]
    np.testing.assert_array_equal(times, truth[:, 0])
    # the run's JSON carries APE beside the RMSE, and they agree (the RMSE is the unaligned APE's)
    assert summary["evaluation"]["ape"]["translation_m"]["rmse"] == pytest.approx(summary["rmse_m"], abs=1e-6)
    assert main([*args[:4], "--save-trajectory", str(kitti), "--trajectory-format", "kitti"]) == 0
    np.testing.assert_allclose(read_kitti(kitti), poses, atol=1e-12)


# -- evo, the field's tool, on the same files --


def evo_metrics(ref, est, *, align=None, delta=None, unit="frames", all_pairs=False, from_reference=False) -> list:
    """evo's APE (or RPE with ``delta``) of the translation and of the rotation angle, each metric processed, for two
    of evo's trajectories (``est`` aligned on a copy when ``align`` is given: evo's SE(3), or Sim(3) for 'sim2')."""
    metrics = optional_import("evo.core.metrics", "evo")
    if align is not None:
        est = copy.deepcopy(est)
        est.align(ref, correct_scale=align == "sim2")
    out = []
    for relation in (metrics.PoseRelation.translation_part, metrics.PoseRelation.rotation_angle_rad):
        if delta is None:
            metric = metrics.APE(relation)
        else:
            metric = metrics.RPE(
                relation, delta, metrics.Unit(unit), all_pairs=all_pairs, pairs_from_reference=from_reference
            )
        metric.process_data((ref, est))
        out.append(metric)
    return out


def _evo_figures(ref_path, est_path, **options):
    """evo's APE (or RPE with ``delta``) translation and heading statistics of two TUM files (:func:`evo_metrics`)."""
    file_interface = optional_import("evo.tools.file_interface", "evo")
    ref, est = file_interface.read_tum_trajectory_file(ref_path), file_interface.read_tum_trajectory_file(est_path)
    stats = [m.get_all_statistics() for m in evo_metrics(ref, est, **options)]
    return [{k: s[k] for k in ("rmse", "mean", "median", "max")} for s in stats]


def _ours(err):
    return [
        {k: getattr(err.translation_stats, k) for k in ("rmse", "mean", "median", "max")},
        {k: getattr(err.heading_stats, k) for k in ("rmse", "mean", "median", "max")},
    ]


def _compare_with_evo(tmp_path, times, truth, estimate):
    write_tum(tmp_path / "truth.txt", times, truth)
    write_tum(tmp_path / "estimate.txt", times, estimate)
    _, truth = read_tum(tmp_path / "truth.txt")  # the numbers evo reads
    _, estimate = read_tum(tmp_path / "estimate.txt")
    files = (tmp_path / "truth.txt", tmp_path / "estimate.txt")
    cases = [
        (ape(truth, estimate), _evo_figures(*files)),
        (ape(truth, estimate, align="se2"), _evo_figures(*files, align="se3")),  # SE(3) Umeyama on planar data
        (ape(truth, estimate, align="sim2"), _evo_figures(*files, align="sim2")),
        (rpe(truth, estimate, 1, pairs_from="estimate"), _evo_figures(*files, delta=1)),
        (rpe(truth, estimate, 10, pairs_from="estimate"), _evo_figures(*files, delta=10)),
        (rpe(truth, estimate, 7, all_pairs=True), _evo_figures(*files, delta=7, all_pairs=True)),
        (rpe(truth, estimate, 2.0, unit="m"), _evo_figures(*files, delta=2.0, unit="m", from_reference=True)),
        (
            rpe(truth, estimate, 2.0, unit="m", pairs_from="estimate", all_pairs=True),
            _evo_figures(*files, delta=2.0, unit="m", all_pairs=True),
        ),
    ]
    return [
        (k, mine[k], evo_stats[k])
        for ours, theirs in cases
        for mine, evo_stats in zip(_ours(ours), theirs, strict=True)
        for k in mine
    ]


def _differing(figures: list[tuple[str, float, float]]) -> list[tuple[str, float, float]]:
    return [f for f in figures if f[1] != pytest.approx(f[2], abs=1e-9, rel=1e-9)]


def test_ape_and_rpe_equal_evos_on_a_synthetic_run(tmp_path):
    data = generate_synthetic(150, 30, seed=3)
    run = run_online(data, PaperSetup.synthetic())
    figures = _compare_with_evo(tmp_path, data.times, data.ground_truth[:, 1:4], run.trajectory[:, :3])
    assert len(figures) == 8 * 2 * 4 and all(v > 0 for k, v, _ in figures if k == "rmse")  # a real error, compared
    assert not _differing(figures)


@pytest.mark.needs_data
def test_ape_and_rpe_equal_evos_on_a_plaza_run(tmp_path, shared_data):
    data = load_dataset("plaza", data_dir=shared_data)
    run = run_online(data, PaperSetup.plaza(), StreamOptions(max_poses=600))
    n = len(run.times)
    figures = _compare_with_evo(tmp_path, data.times[:n], data.ground_truth[:n, 1:4], run.trajectory[:, :3])
    assert len(figures) == 8 * 2 * 4 and all(v > 0 for k, v, _ in figures if k == "rmse")
    assert not _differing(figures)


# -- the estimate at the truth's times --


def test_states_at_equals_the_dense_gp_posterior(dense):  # noqa: F811 - the fixture
    qc, solver, posterior = dense
    trajectory = Trajectory(solver, STATES, POSE_TIMES, qc)
    times = np.array([0.0, 0.8, 1.1, 3.7, 6.0])  # at a state, between states, after the last
    means, covs = states_at(trajectory, times, covariance=True, extrapolate=True)
    for t, mean, cov in zip(times, means, covs, strict=True):
        expected_mean, expected_cov = posterior(t)
        np.testing.assert_allclose(mean, expected_mean, rtol=1e-7, atol=1e-9 * np.abs(expected_mean).max())
        np.testing.assert_allclose(cov, expected_cov, rtol=1e-7, atol=1e-9 * np.abs(expected_cov).max())
    np.testing.assert_array_equal(states_at(trajectory, times, extrapolate=True), means)


def test_batch_reports_ape_beside_its_rmse_and_saves_its_trajectory(tmp_path, capsys):
    import scipy.io

    data = generate_synthetic(n_steps=60, n_landmarks=10, seed=2, range_sigma=0.3)
    scipy.io.savemat(tmp_path / "small.mat", data.to_cmu_arrays())
    tum = tmp_path / "batch.txt"
    args = ["batch", "--dataset", str(tmp_path / "small.mat"), "--preset", "synthetic", "--json"]
    assert main([*args, "--save-trajectory", str(tum)]) == 0
    row = json.loads(capsys.readouterr().out)
    times, poses = read_tum(tum)
    np.testing.assert_array_equal(times, data.times)
    truth = data.ground_truth[:, 1:4]
    assert row["evaluation"]["ape"]["translation_m"]["rmse"] == pytest.approx(row["rmse_m"], abs=1e-6)
    assert row["evaluation"]["ape_se2"]["translation_m"]["rmse"] == pytest.approx(
        ape(truth, poses, align="se2").translation_stats.rmse, rel=1e-12
    )
    assert row["evaluation"]["ape_se2"]["translation_m"]["rmse"] <= row["evaluation"]["ape"]["translation_m"]["rmse"]
