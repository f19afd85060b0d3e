"""Dead reckoning and angle wrapping: the one home in steam_ref.dead_reckoning."""

from __future__ import annotations

import numpy as np
from requirements import optional_import

from steam_ref.dead_reckoning import compose, integrate_odometry, transform_from, wrap_angle


def test_integrate_odometry_equals_composing_row_by_row(rng):
    start = np.array([3.0, 1.0, -2.0, 3.0])  # time, x, y, heading near π: the sum crosses it
    odometry = np.column_stack([4.0 + np.arange(50.0), rng.uniform(0, 2, 50), rng.normal(0, 0.3, 50)])
    path = integrate_odometry(start, odometry)
    pose = start[1:]
    for k in range(50):
        pose = compose(pose, odometry[k, 1], odometry[k, 2])
        np.testing.assert_allclose(path[k + 1, 1:], pose, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(path[:, 0], np.concatenate([[3.0], odometry[:, 0]]))


def test_compose_moves_along_the_heading_before_the_turn():
    np.testing.assert_allclose(compose([1.0, 2.0, np.pi / 2], 3.0, 0.5), [1.0, 5.0, np.pi / 2 + 0.5], atol=1e-15)


def test_wrap_angle_maps_into_minus_pi_to_pi():
    a = np.array([-7.0, -np.pi, 0.0, np.pi, 4.0, 10.0])
    w = wrap_angle(a)
    assert np.all((w >= -np.pi) & (w < np.pi))
    np.testing.assert_allclose(np.cos(w), np.cos(a), atol=1e-12)
    np.testing.assert_allclose(np.sin(w), np.sin(a), atol=1e-12)


def test_compose_with_a_sideways_part_and_transform_from_are_gtsams_pose2(rng):
    """pose ⊕ Pose2(dx, dy, dθ) and a point of the pose's frame in the world, against gtsam.Pose2."""
    gtsam = optional_import("gtsam", "gtsam")
    for _ in range(20):
        pose, (dx, dy, turn), point = rng.normal(size=3) * [5, 5, 3], rng.normal(size=3), rng.normal(size=2) * 10
        theirs = gtsam.Pose2(*pose).compose(gtsam.Pose2(dx, dy, turn))
        ours = compose(pose, dx, turn, dy)
        np.testing.assert_allclose(ours[:2], [theirs.x(), theirs.y()], rtol=0, atol=1e-13)
        assert ours[2] == pose[2] + turn  # not wrapped
        assert abs(wrap_angle(ours[2] - theirs.theta())) < 1e-13
        np.testing.assert_allclose(
            transform_from(pose, point), gtsam.Pose2(*pose).transformFrom(point), rtol=0, atol=1e-12
        )


def test_integrate_odometry_with_a_sideways_part_equals_composing_row_by_row(rng):
    start = np.array([0.0, 1.0, -2.0, 3.0])
    odometry = np.column_stack(
        [1.0 + np.arange(40.0), rng.uniform(0, 2, 40), rng.normal(0, 0.2, 40), rng.normal(0, 0.3, 40)]
    )
    path = integrate_odometry(start, odometry)
    pose = start[1:]
    for k in range(40):
        pose = compose(pose, odometry[k, 1], odometry[k, 3], odometry[k, 2])
        np.testing.assert_allclose(path[k + 1, 1:], pose, rtol=0, atol=1e-12)
