"""steam_ref.evaluate against independent oracles on the paths that break evaluations: APE and RPE pose by pose
against evo (far from the origin, headings and errors near half a turn, whole turns, identical paths, one pose),
the RPE far from the origin against mpmath, the alignment against Umeyama's SVD written out densely where evo's
SE(3) one is degenerate (two poses, collinear poses) or leaves the plane (a mirror image), SE(3) APE near a half
turn against evo, and TUM stamps float64 cannot tell apart."""

import logging

import mpmath
import numpy as np
import pytest
from requirements import optional_import
from test_evaluate import evo_metrics

from steam_ref.errors import DataError, SteamError
from steam_ref.evaluate import align_planar, ape, group_ape, read_kitti, read_tum, rpe
from steam_ref.lie.se3 import SE3

EPS = np.finfo(float).eps


def _evo():
    logging.getLogger("evo").setLevel(logging.ERROR)  # evo logs each RPE's pair count
    return optional_import("evo.core.metrics", "evo"), optional_import("evo.core.trajectory", "evo")


def _evo_path(poses):
    """Planar poses (n, 3) as evo's trajectory: (x, y, 0) and the rotation about z, q = (cos θ/2, 0, 0, sin θ/2)."""
    _, trajectory = _evo()
    half = poses[:, 2] / 2
    zero = np.zeros(len(poses))
    return trajectory.PoseTrajectory3D(
        positions_xyz=np.column_stack([poses[:, :2], zero]),
        orientations_quat_wxyz=np.column_stack([np.cos(half), zero, zero, np.sin(half)]),
        timestamps=np.arange(len(poses), dtype=float),
    )


def _evo_errors(truth, estimate, *, align=None, delta=None, unit="frames", all_pairs=False, from_truth=False):
    """evo's translation and rotation-angle errors, pose by pose (APE) or pair by pair (RPE with ``delta``)."""
    _evo()  # evo's logging quieted
    found = evo_metrics(
        _evo_path(truth),
        _evo_path(estimate),
        align=align,
        delta=delta,
        unit=unit,
        all_pairs=all_pairs,
        from_reference=from_truth,
    )
    return [np.asarray(m.error) for m in found]


def _walk(rng, n=50):
    theta = np.cumsum(rng.normal(0.0, 0.3, n)) + 2.5
    xy = np.cumsum(np.column_stack([np.cos(theta), np.sin(theta)]) * rng.uniform(0.5, 1.5, (n, 1)), axis=0)
    return np.column_stack([xy, theta])


def _noisy(rng, poses, position=0.2, heading=0.1):
    return poses + np.column_stack([rng.normal(0, position, (len(poses), 2)), rng.normal(0, heading, len(poses))])


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def _case(name, rng):
    truth = _walk(rng)
    if name == "random":
        return truth, _noisy(rng, truth)
    if name == "utm_5e6":  # a UTM easting and northing: 1 ulp is 1e-9 m, a millimetre is 1e6 ulps
        truth[:, :2] += [5e5, 5e6]
        return truth, _noisy(rng, truth, 1e-3, 1e-3)
    if name == "headings_near_pi":  # truth just below +π, estimate just above -π: an error of 1e-9 rad, not 2π
        truth[:, 2] = np.pi - 1e-9 * rng.uniform(size=len(truth))
        estimate = _noisy(rng, truth, 0.1, 0.0)
        estimate[:, 2] = -np.pi + 1e-9 * rng.uniform(size=len(truth))
        return truth, estimate
    if name == "errors_near_pi":  # every heading half a turn off, to 1e-12 rad, either way
        estimate = _noisy(rng, truth, 0.1, 0.0)
        estimate[:, 2] = truth[:, 2] + rng.choice([-1, 1], len(truth)) * (np.pi - 1e-12)
        return truth, estimate
    if name == "whole_turns":  # headings off by whole turns and 1e-10 rad
        estimate = _noisy(rng, truth, 0.1, 0.0)
        estimate[:, 2] = truth[:, 2] + 2 * np.pi * rng.integers(-3, 4, len(truth)) + 1e-10
        return truth, estimate
    assert name == "identical"
    return truth, truth.copy()


def _cross_covariance_det(truth, estimate):
    x, y = estimate[:, :2] - estimate[:, :2].mean(0), truth[:, :2] - truth[:, :2].mean(0)
    return float(np.linalg.det(y.T @ x))


@pytest.mark.parametrize(
    "name", ["random", "utm_5e6", "headings_near_pi", "errors_near_pi", "whole_turns", "identical"]
)
def test_ape_and_rpe_equal_evos_pose_by_pose_on_hard_paths(rng, name):
    truth, estimate = _case(name, rng)
    # evo's own rounding: it forms Qᵢ⁻¹ Pᵢ and Pᵢ⁻¹ Pⱼ with the positions, a few ulps of the largest coordinate
    # (test_rpe_far_from_the_origin_equals_mpmath shows it is evo's, not ours)
    metres = 8 * EPS * (1 + np.abs(truth[:, :2]).max())
    cases = [(ape(truth, estimate), _evo_errors(truth, estimate))]
    assert _cross_covariance_det(truth, estimate) > 0  # where evo's SE(3) alignment stays in the plane
    cases += [
        (ape(truth, estimate, align="se2"), _evo_errors(truth, estimate, align="se3")),
        (ape(truth, estimate, align="sim2"), _evo_errors(truth, estimate, align="sim2")),
    ]
    for delta, unit, evo_unit in ((1, "poses", "frames"), (7, "poses", "frames"), (4.0, "m", "m")):
        for all_pairs in (False, True):
            for pairs_from in ("truth", "estimate"):
                ours = rpe(truth, estimate, delta, unit=unit, all_pairs=all_pairs, pairs_from=pairs_from)
                theirs = _evo_errors(
                    truth, estimate, delta=delta, unit=evo_unit, all_pairs=all_pairs, from_truth=pairs_from == "truth"
                )
                cases.append((ours, theirs))
    aligned = 4 * metres if name == "utm_5e6" else metres  # the aligned poses s R p + t, formed at 5e6 m by both
    for k, (ours, (translation, rotation)) in enumerate(cases):
        assert ours.translation.shape == translation.shape and ours.heading.shape == rotation.shape
        tolerance = aligned if k in (1, 2) else metres
        np.testing.assert_allclose(ours.translation, translation, rtol=0, atol=tolerance, err_msg=f"case {k}")
        np.testing.assert_allclose(ours.heading, rotation, rtol=0, atol=1e-12, err_msg=f"case {k}")
    if name in ("headings_near_pi", "whole_turns"):
        assert ape(truth, estimate).heading.max() < 1e-8  # not 2π
    if name == "errors_near_pi":
        np.testing.assert_allclose(ape(truth, estimate).heading, np.pi - 1e-12, rtol=0, atol=1e-12)


def test_rpe_far_from_the_origin_equals_mpmath(rng):
    """Pᵢ⁻¹Pⱼ at 4.5e8 m (1 ulp is 6e-8 m): the step pⱼ - pᵢ is formed first, so no digit of it is lost."""
    truth = _walk(rng)
    truth[:, :2] += [4.5e8, 2.25e8]
    estimate = _noisy(rng, truth, 1e-3, 1e-3)
    ours = rpe(truth, estimate, 1, all_pairs=True).translation
    mpmath.mp.dps = 50

    def motion(p, i, j):
        c, s = mpmath.cos(mpmath.mpf(p[i, 2])), mpmath.sin(mpmath.mpf(p[i, 2]))
        dx, dy = mpmath.mpf(p[j, 0]) - mpmath.mpf(p[i, 0]), mpmath.mpf(p[j, 1]) - mpmath.mpf(p[i, 1])
        return c * dx + s * dy, c * dy - s * dx

    exact = []
    for i in range(len(truth) - 1):
        (a, b), (c, d) = motion(truth, i, i + 1), motion(estimate, i, i + 1)
        exact.append(float(mpmath.sqrt((c - a) ** 2 + (d - b) ** 2)))
    np.testing.assert_allclose(ours, exact, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("offset", [[5e5, 5e6], [4.5e8, -3e8]])
def test_alignment_far_from_the_origin_equals_mpmath(rng, offset):
    """The rotation of points 0.1-10 m apart, 5e6 and 4.5e8 m from the origin, against φ = atan2(b, a) of the
    centred points in 50 digits [U91 Eq. 39-40]: the points' own digits are all used (dividing them by their
    largest coordinate before centring turned it by up to 1e-7 rad at 4.5e8 m)."""
    mpmath.mp.dps = 50
    worst = 0.0
    for _ in range(40):
        n = int(rng.integers(2, 30))
        estimate = rng.normal(size=(n, 2)) * 10 ** rng.uniform(-1, 1) + offset
        c, s = np.cos(2.0), np.sin(2.0)
        truth = estimate @ np.array([[c, -s], [s, c]]).T + [1.0, -2.0] + rng.normal(scale=1e-3, size=(n, 2))
        x = [[mpmath.mpf(v) for v in row] for row in estimate]
        y = [[mpmath.mpf(v) for v in row] for row in truth]
        mx, my = ([sum(r[d] for r in pts) / n for d in (0, 1)] for pts in (x, y))
        dx, dy = [(r[0] - mx[0], r[1] - mx[1]) for r in x], [(r[0] - my[0], r[1] - my[1]) for r in y]
        a = sum(u[0] * v[0] + u[1] * v[1] for u, v in zip(dx, dy, strict=True))
        b = sum(u[0] * v[1] - u[1] * v[0] for u, v in zip(dx, dy, strict=True))
        worst = max(worst, abs(align_planar(estimate, truth).angle - float(mpmath.atan2(b, a))))
    assert worst < 1e-12


def _dense_alignment(estimate, truth, with_scale):
    """Umeyama's SVD [U91 Eq. 38-42] in the plane, S = diag(1, det U det V): the best rotation, never a reflection."""
    mx, my = estimate.mean(0), truth.mean(0)
    u, d, vt = np.linalg.svd((truth - my).T @ (estimate - mx) / len(truth))
    S = np.diag([1.0, np.sign(np.linalg.det(u) * np.linalg.det(vt))])
    R = u @ S @ vt
    s = float(np.trace(np.diag(d) @ S) / (np.sum((estimate - mx) ** 2) / len(truth))) if with_scale else 1.0
    return R, s, my - s * R @ mx


def _assert_dense(estimate, truth, with_scale):
    R, s, t = _dense_alignment(estimate, truth, with_scale)
    found = align_planar(estimate, truth, with_scale=with_scale)
    assert np.linalg.det(found.rotation) == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(found.rotation, R, rtol=0, atol=1e-12)
    assert found.scale == pytest.approx(s, rel=1e-12)
    # t = μy - s R μx: a difference of numbers as large as the coordinates, by both to a few of their ulps
    np.testing.assert_allclose(found.translation, t, rtol=0, atol=8 * EPS * max(1.0, np.abs(truth).max()))


@pytest.mark.parametrize("with_scale", [False, True])
def test_se2_alignment_stays_about_z_where_evo_turns_a_mirror_image_upside_down(rng, with_scale):
    geometry = optional_import("evo.core.geometry", "evo")
    estimate = rng.normal(size=(6, 2)) * [3.0, 1.0]
    truth = estimate * [1.0, -1.0] + rng.normal(scale=0.2, size=(6, 2))  # nearer a mirror image than a turned copy
    assert _cross_covariance_det(np.column_stack([truth, np.zeros(6)]), np.column_stack([estimate, np.zeros(6)])) < 0
    _assert_dense(estimate, truth, with_scale)
    lift = np.vstack([estimate.T, np.zeros(6)]), np.vstack([truth.T, np.zeros(6)])
    r, _, _ = geometry.umeyama_alignment(*lift, with_scale=with_scale)
    assert r[2, 2] == pytest.approx(-1.0)  # evo's SE(3): a half turn about an axis in the plane


@pytest.mark.parametrize("with_scale", [False, True])
@pytest.mark.parametrize("shape", ["two poses", "collinear"])
def test_alignment_of_two_poses_and_of_collinear_poses_is_the_dense_svd(rng, with_scale, shape):
    """In the plane a line determines a rotation; evo's SE(3) Umeyama refuses two poses (rank 1 < 2), and a line
    but for the rounding of its points."""
    geometry = optional_import("evo.core.geometry", "evo")
    n = 2 if shape == "two poses" else 30
    estimate = np.column_stack([np.arange(n) * 0.7, np.arange(n) * 0.3]) + [5e5, 5e6]
    c, s = np.cos(2.0), np.sin(2.0)
    truth = estimate @ np.array([[c, -s], [s, c]]).T * (1.3 if with_scale else 1.0) + [1.0, -2.0]
    truth += rng.normal(scale=1e-3, size=truth.shape) * [1.0, 0.0]
    _assert_dense(estimate, truth, with_scale)
    if n > 2:
        return
    with pytest.raises(geometry.GeometryException):
        geometry.umeyama_alignment(np.vstack([estimate.T, np.zeros(n)]), np.vstack([truth.T, np.zeros(n)]))


def test_a_mirror_image_of_a_symmetric_set_is_refused_as_uncorrelated_and_right_angles_are_a_quarter_turn():
    estimate = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
    mirror = estimate * [1.0, -1.0]  # every rotation fits it equally well
    for with_scale in (False, True):
        with pytest.raises(SteamError, match="uncorrelated with the truth's") as raised:
            align_planar(estimate, mirror, with_scale=with_scale)
        assert "right angles" not in str(raised.value)
    quarter = estimate @ np.array([[0.0, -1.0], [1.0, 0.0]]).T  # each position at right angles to its own
    assert align_planar(estimate, quarter).angle == pytest.approx(np.pi / 2, abs=1e-15)


def test_one_pose_has_evos_ape_and_no_alignment_or_rpe(rng):
    truth, estimate = _case("random", rng)
    truth, estimate = truth[:1], estimate[:1]
    translation, rotation = _evo_errors(truth, estimate)
    ours = ape(truth, estimate)
    np.testing.assert_allclose(ours.translation, translation, rtol=0, atol=1e-15)
    np.testing.assert_allclose(ours.heading, rotation, rtol=0, atol=1e-15)
    with pytest.raises(SteamError, match="n >= 2"):
        ape(truth, estimate, align="se2")
    with pytest.raises(SteamError, match="delta=1"):
        rpe(truth, estimate, 1)


def test_se3_ape_equals_evos_near_a_half_turn_and_far_from_the_origin(rng):
    metrics, trajectory = _evo()
    rotation = pytest.importorskip("scipy.spatial.transform").Rotation
    n = 100
    R1 = rotation.random(n, random_state=1).as_matrix()
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    R2 = R1 @ rotation.from_rotvec(axis * (np.pi - 10 ** rng.uniform(-12, -3, (n, 1)))).as_matrix()
    t1 = rng.normal(size=(n, 3)) * 5e6
    t2 = t1 + rng.normal(size=(n, 3)) * 0.1
    ours = group_ape(
        SE3, np.concatenate([t1, R1.reshape(n, 9)], axis=1), np.concatenate([t2, R2.reshape(n, 9)], axis=1)
    )

    def path(t, R):
        return trajectory.PosePath3D(poses_se3=[np.block([[R[k], t[k][:, None]], [0, 0, 0, 1]]) for k in range(n)])

    for relation, mine in (
        (metrics.PoseRelation.translation_part, ours.translation),
        (metrics.PoseRelation.rotation_angle_rad, ours.heading),
    ):
        metric = metrics.APE(relation)
        metric.process_data((path(t1, R1), path(t2, R2)))
        np.testing.assert_allclose(mine, metric.error, rtol=0, atol=1e-12)
    assert ours.heading.min() > np.pi - 1.1e-3


@pytest.mark.parametrize(
    ("first", "second"),
    [
        ("1700000000123456789", "1700000000123456790"),  # nanoseconds since the epoch
        ("1700000000.123456789", "1700000000.123456790"),  # seconds with 9 decimals
    ],
)
def test_tum_stamps_one_number_in_float64_are_refused_showing_both_as_written(tmp_path, first, second):
    path = tmp_path / "stamps.txt"
    path.write_text(f"# t x y z qx qy qz qw\n{first} 0 0 0 0 0 0 1\n{second} 1 0 0 0 0 0 1\n")
    assert float(first) == float(second)
    with pytest.raises(DataError, match="line 3") as refused:
        read_tum(path)
    message = str(refused.value)
    assert first in message and second in message and "float64" in message


@pytest.mark.parametrize(("entry", "read"), [("1.0000001", True), ("1.000002", False)])
def test_a_kitti_rotation_is_read_to_its_stated_tolerance_and_refused_past_it(tmp_path, entry, read):
    """R orthonormal to ROTATION_TOLERANCE (1e-6, the module docstring's): within it the heading is atan2(R10, R00)."""
    path = tmp_path / "poses.txt"
    path.write_text(f"1 0 0 5 0 1 0 6 0 0 1 0\n{entry} 0 0 5 0 1 0 6 0 0 1 0\n")
    if read:
        np.testing.assert_array_equal(read_kitti(path), [[5.0, 6.0, 0.0], [5.0, 6.0, 0.0]])
    else:
        with pytest.raises(DataError, match="line 2: not a planar pose"):
            read_kitti(path)
