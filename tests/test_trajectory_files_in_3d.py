"""TUM and KITTI trajectory files of poses in 3-D (``write_tum``/``read_tum``/``write_kitti``/``read_kitti`` with
``group=``): a 3-D run's states could not be written at all (the four were planar only, and a pose off the plane was
refused), so a 3-D estimator could not be compared with steam_ref's through evo or any tool of the field.

Oracles: evo 1.x (it reads what we write and writes what we read: its quaternions are w-first inside, x-first in a
TUM file), SciPy's rotations (a quaternion's order and sign, at known turns about each axis and near π), and the
round trip itself (times and translations bit for bit, rotations to rounding).
"""

from __future__ import annotations

import numpy as np
import pytest
from requirements import optional_import
from scipy.spatial.transform import Rotation

from steam_ref.errors import DataError, ShapeError, SteamError
from steam_ref.evaluate import read_kitti, read_tum, write_kitti, write_tum
from steam_ref.lie import SE2, SE3, SE3V

EPS = np.finfo(float).eps


def _poses(group, n: int = 30, seed: int = 0) -> np.ndarray:
    """``n`` poses of ``group``: random turns up to π (the last ones within 1e-9 of it, and at it), a few km away."""
    rng = np.random.default_rng(seed)
    axis = rng.standard_normal((n, 3))
    axis /= np.linalg.norm(axis, axis=1, keepdims=True)
    angle = rng.uniform(0, np.pi, n)
    angle[-3:] = [np.pi - 1e-9, np.pi, 0.0]
    R = Rotation.from_rotvec(axis * angle[:, None]).as_matrix()
    M = np.zeros((n, 4, 4))
    M[:, :3, :3], M[:, :3, 3], M[:, 3, 3] = R, rng.uniform(-3000, 3000, (n, 3)), 1.0
    return group.from_matrix(M)


@pytest.mark.parametrize("group", [SE3V, SE3], ids=["se3v", "se3"])
def test_a_tum_and_a_kitti_file_give_back_the_poses_written(tmp_path, group):
    poses = _poses(group)
    times = 1.6e9 + np.cumsum(np.full(len(poses), 0.1))
    write_tum(tmp_path / "a.txt", times, poses, group=group)
    write_kitti(tmp_path / "b.txt", poses, group=group)
    t, tum = read_tum(tmp_path / "a.txt", group=group)
    kitti = read_kitti(tmp_path / "b.txt", group=group)
    np.testing.assert_array_equal(t, times)
    for back in (tum, kitti):
        M, N = group.matrix(back), group.matrix(poses)
        np.testing.assert_array_equal(M[:, :3, 3], N[:, :3, 3])
        np.testing.assert_allclose(M[:, :3, :3], N[:, :3, :3], rtol=0, atol=8 * EPS)


def test_the_tum_quaternion_is_qx_qy_qz_qw_with_qw_not_negative(tmp_path):
    """A quarter turn about x, y, z, and half a turn about z: the line holds (sin π/4) on the turn's axis, in the
    order x, y, z, then qw = cos(θ/2) >= 0 (SciPy's scalar-last quaternion, canonical)."""
    turns = [[np.pi / 2, 0, 0], [0, np.pi / 2, 0], [0, 0, np.pi / 2], [0, 0, np.pi], [0.3, -1.2, 2.0]]
    M = np.tile(np.eye(4), (len(turns), 1, 1))
    M[:, :3, :3] = Rotation.from_rotvec(turns).as_matrix()
    M[:, :3, 3] = [[1, 2, 3]] * len(turns)
    write_tum(tmp_path / "q.txt", np.arange(len(turns)), SE3V.from_matrix(M), group=SE3V)
    rows = np.loadtxt(tmp_path / "q.txt")
    np.testing.assert_array_equal(rows[:, 1:4], M[:, :3, 3])
    want = Rotation.from_rotvec(turns).as_quat(canonical=True)  # [x, y, z, w]
    np.testing.assert_allclose(rows[:, 4:], want, rtol=0, atol=4 * EPS)
    assert np.all(rows[:, 7] >= 0)


@pytest.mark.parametrize("group", [SE3V, SE3], ids=["se3v", "se3"])
def test_evo_reads_our_files_as_the_same_poses(tmp_path, group):
    file_interface = optional_import("evo.tools.file_interface", "evo")
    poses = _poses(group, seed=1)
    times = np.arange(len(poses)) * 0.5 + 10.0
    write_tum(tmp_path / "a.txt", times, poses, group=group)
    write_kitti(tmp_path / "b.txt", poses, group=group)
    tum = file_interface.read_tum_trajectory_file(str(tmp_path / "a.txt"))
    kitti = file_interface.read_kitti_poses_file(str(tmp_path / "b.txt"))
    np.testing.assert_array_equal(tum.timestamps, times)
    for theirs in (tum, kitti):
        np.testing.assert_allclose(np.array(theirs.poses_se3), group.matrix(poses), rtol=0, atol=8 * EPS * 3000)
        np.testing.assert_allclose(
            np.array(theirs.poses_se3)[:, :3, :3], group.matrix(poses)[:, :3, :3], rtol=0, atol=8 * EPS
        )


@pytest.mark.parametrize("group", [SE3V, SE3], ids=["se3v", "se3"])
def test_files_evo_writes_read_as_evos_poses(tmp_path, group):
    """evo's trajectory from positions and w-first quaternions (a quarter turn about x first: w = x = √½), written
    by evo, reads as those rotations (SciPy's, from the same turns) and positions."""
    file_interface = optional_import("evo.tools.file_interface", "evo")
    trajectory = optional_import("evo.core.trajectory", "evo")
    rng = np.random.default_rng(2)
    turns = np.vstack([[np.pi / 2, 0, 0], rng.standard_normal((9, 3))])
    xyzw = Rotation.from_rotvec(turns).as_quat()
    wxyz = np.column_stack([xyzw[:, 3], xyzw[:, :3]])
    xyz = rng.uniform(-50, 50, (10, 3))
    times = 100.0 + np.arange(10) * 0.25
    traj = trajectory.PoseTrajectory3D(positions_xyz=xyz, orientations_quat_wxyz=wxyz, timestamps=times)
    file_interface.write_tum_trajectory_file(str(tmp_path / "a.txt"), traj)
    file_interface.write_kitti_poses_file(str(tmp_path / "b.txt"), traj)
    t, tum = read_tum(tmp_path / "a.txt", group=group)
    kitti = read_kitti(tmp_path / "b.txt", group=group)
    np.testing.assert_array_equal(t, times)
    R = Rotation.from_rotvec(turns).as_matrix()
    for ours in (tum, kitti):
        M = group.matrix(ours)
        np.testing.assert_allclose(M[:, :3, 3], xyz, rtol=0, atol=1e-12)
        np.testing.assert_allclose(M[:, :3, :3], R, rtol=0, atol=1e-12)
    np.testing.assert_allclose(group.matrix(tum)[0, :3, :3], [[1, 0, 0], [0, 0, -1], [0, 1, 0]], atol=1e-15)


def test_a_3d_file_refuses_what_is_no_pose_naming_the_line(tmp_path):
    (tmp_path / "q.txt").write_text("# t x y z qx qy qz qw\n0 1 2 3 0 0 0 1\n1 1 2 3 0 0 0 2\n")
    with pytest.raises(DataError, match=r"q\.txt, line 3: the quaternion .* not a rotation"):
        read_tum(tmp_path / "q.txt", group=SE3V)
    (tmp_path / "k.txt").write_text("1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 -1 0\n")  # a mirror
    with pytest.raises(DataError, match=r"k\.txt, line 2: R is not a rotation"):
        read_kitti(tmp_path / "k.txt", group=SE3V)


def test_a_3d_file_needs_a_group_in_3d_and_poses_of_it(tmp_path):
    with pytest.raises(SteamError, match="SE2"):
        write_tum(tmp_path / "a.txt", [0.0], np.zeros((1, 3)), group=SE2)
    with pytest.raises(ShapeError, match=r"poses must be \(n, 6\) elements of SE3V"):
        write_tum(tmp_path / "a.txt", [0.0], np.zeros((1, 12)), group=SE3V)
    with pytest.raises(SteamError, match=r"poses\[0\]: not a rotation"):
        write_kitti(tmp_path / "a.txt", np.r_[0, 0, 0, 2 * np.eye(3).ravel()][None], group=SE3)


def test_a_planar_file_is_read_and_written_as_before(tmp_path):
    """Without ``group`` nothing changed: planar poses, and a pose off the plane refused."""
    write_tum(tmp_path / "p.txt", [0.0, 1.0], [[1.0, 2.0, 0.5], [2.0, 3.0, -3.0]])
    _, poses = read_tum(tmp_path / "p.txt")
    np.testing.assert_allclose(poses, [[1.0, 2.0, 0.5], [2.0, 3.0, -3.0]], rtol=0, atol=1e-15)
    write_tum(tmp_path / "s.txt", [0.0], _poses(SE3V, 4, seed=5)[:1], group=SE3V)
    with pytest.raises(DataError, match="not a planar pose"):
        read_tum(tmp_path / "s.txt")
