"""Every text reader of ``steam_ref.datasets`` either reads the numbers written, or refuses the file naming its line.

Readers: the KITTI GPS and IMU files (:func:`load_kitti`), GTSAM's planar text (:func:`load_gtsam_2d`), the CMU text
release (:func:`load_cmu_text`), and :func:`load_dataset` given a path. What each must refuse, naming the file and the
line: a file cut inside its last number (the cut number still parses, so the missing final newline is the only
sign), a byte that is not ASCII (a BOM, Latin-1). What each must refuse without reading, and without waiting on it:
a FIFO, a device. The oracle of a file read is the array the test wrote it from (numbers written with 17
significant digits, so they read back exactly). Cases the older tests assert (NaN, wrong column counts, times going
back, the CMU files cut at every byte) are not repeated here.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
from pathlib import Path

import numpy as np
import pytest
import scipy.io
from cli_runs import runner

from steam_ref.datasets import load_cmu_text, load_dataset, load_gtsam_2d
from steam_ref.datasets.kitti import GPS_FILE, HOLD_OUT_EVERY, IMU_FILE, load_kitti
from steam_ref.errors import DataError
from steam_ref.evaluate.files import read_kitti, read_tum, write_kitti, write_tum
from steam_ref.lie import SE3V

# 12 GPS fixes on a parabola, 30 IMU rows: small files written with every digit.
GPS = np.column_stack([np.arange(12.0), np.arange(12.0), 0.1 * np.arange(12.0) ** 2, np.zeros(12)])
IMU = np.column_stack(
    [0.37 * np.arange(30.0), np.full(30, 0.01), np.ones((30, 3)), 1e-3 * np.arange(90.0).reshape(30, 3)]
)
GPS_TEXT = "Time,X,Y,Z\n" + "".join(",".join(f"{v:.17g}" for v in row) + "\n" for row in GPS)
IMU_TEXT = "Time dt accelX accelY accelZ omegaX omegaY omegaZ\n" + "".join(
    " ".join(f"{v:.17g}" for v in row) + "\n" for row in IMU
)
VICTORIA = (
    "ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\n"
    "ODOMETRY 1 2 1 0 0.1 1 0 0 1 0 1\n"
    "LANDMARK 1 100 3 4 0.01 0 0.01\n"
    "LANDMARK 2 100 2.5 4 0.01 0 0.01\n"
)


def _kitti(folder: Path, gps: bytes | None = None, imu: bytes | None = None) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / GPS_FILE).write_bytes(GPS_TEXT.encode() if gps is None else gps)
    (folder / IMU_FILE).write_bytes(IMU_TEXT.encode() if imu is None else imu)
    return folder


def _lines(text: str) -> int:
    return text.count("\n")


@contextlib.contextmanager
def _within(seconds: int):
    """Fail, instead of hanging, when the block takes longer than ``seconds`` (a read waiting on a FIFO)."""

    def late(*_):
        raise TimeoutError(f"still waiting after {seconds} s: the reader opened a FIFO")

    before = signal.signal(signal.SIGALRM, late)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, before)


# --- KITTI ------------------------------------------------------------------------------------------------------


def test_the_small_kitti_files_read_the_numbers_written(tmp_path: Path) -> None:
    data = load_kitti(_kitti(tmp_path), group=SE3V)
    held = np.arange(len(GPS)) % HOLD_OUT_EVERY == HOLD_OUT_EVERY - 1
    np.testing.assert_array_equal(data.positions, GPS[~held])
    np.testing.assert_array_equal(data.held_out, GPS[held])
    np.testing.assert_array_equal(data.gyro, IMU[:, [0, 5, 6, 7]])


@pytest.mark.parametrize("which", [GPS_FILE, IMU_FILE])
def test_a_kitti_file_cut_inside_its_last_number_is_refused_naming_the_line(tmp_path: Path, which: str) -> None:
    """``...,0`` cut from ``...,0.5`` still has its fields and parses: only the missing newline shows the cut."""
    text = GPS_TEXT if which == GPS_FILE else IMU_TEXT
    cut = text.encode()[:-4]  # the newline and the last three characters of the last number
    folder = _kitti(tmp_path, **{"gps" if which == GPS_FILE else "imu": cut})
    with pytest.raises(
        DataError, match=rf"{re.escape(which)},? line {_lines(text)}: the last line does not end with a newline"
    ):
        load_kitti(folder, group=SE3V)


def _ended(text: str, ending: str) -> bytes:
    """``text`` with every line after the header ended by ``ending``, and the header by a newline (a header
    must be the header: "Time,X,Y,Z " is refused, naming line 1)."""
    header, body = text.split("\n", 1)
    return (header + ("\r\n" if ending == "\r\n" else "\n") + body.replace("\n", ending)).encode()


@pytest.mark.parametrize("ending", ["\r\n", " \t\n"], ids=["windows line ends", "trailing blanks"])
def test_kitti_files_with_windows_line_ends_or_trailing_blanks_read_the_same(tmp_path: Path, ending: str) -> None:
    data = load_kitti(_kitti(tmp_path, gps=_ended(GPS_TEXT, ending), imu=_ended(IMU_TEXT, ending)), group=SE3V)
    np.testing.assert_array_equal(np.sort(np.concatenate([data.positions, data.held_out]), axis=0), GPS)
    np.testing.assert_array_equal(data.gyro, IMU[:, [0, 5, 6, 7]])


@pytest.mark.parametrize(("which", "line"), [(GPS_FILE, 4), (IMU_FILE, 7)])
def test_a_non_ascii_byte_in_a_kitti_file_is_named_by_its_line(tmp_path: Path, which: str, line: int) -> None:
    text = (GPS_TEXT if which == GPS_FILE else IMU_TEXT).encode()
    rows = text.split(b"\n")
    rows[line - 1] = rows[line - 1][:5] + b"\xe9" + rows[line - 1][5:]  # Latin-1 é inside a number
    folder = _kitti(tmp_path, **{"gps" if which == GPS_FILE else "imu": b"\n".join(rows)})
    with pytest.raises(DataError, match=rf"{re.escape(which)},? line {line}: byte 0xe9 is not ASCII"):
        load_kitti(folder, group=SE3V)


# --- GTSAM planar text ------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("raw", "line", "byte"),
    [(b"\xef\xbb\xbf" + VICTORIA.encode(), 1, "0xef"), (VICTORIA.encode().replace(b"3 4", b"3\xe9 4"), 3, "0xe9")],
    ids=["a BOM", "Latin-1"],
)
def test_a_non_ascii_byte_in_a_gtsam_file_is_named_by_its_line(
    tmp_path: Path, raw: bytes, line: int, byte: str
) -> None:
    path = tmp_path / "v.txt"
    path.write_bytes(raw)
    with pytest.raises(DataError, match=rf"v\.txt line {line}: byte {byte} is not ASCII"):
        load_gtsam_2d(path)


def test_a_gtsam_file_with_windows_line_ends_reads_the_rows_written(tmp_path: Path) -> None:
    """Oracle: the sighting (x, y) = (3, 4) seen from pose 1 with v = 0.01: bearing atan2(4, 3), range 5, sigmas as
    load2D's: sqrt(v / 10) rad, sqrt(v) m."""
    path = tmp_path / "v.txt"
    path.write_bytes(VICTORIA.replace("\n", "\r\n").encode())
    data = load_gtsam_2d(path)
    np.testing.assert_array_equal(data.bearing_ranges[0], [1, 100, np.arctan2(4, 3), 5, np.sqrt(0.001), 0.1])
    np.testing.assert_array_equal(data.odometry, [[1, 1, 0, 0], [2, 1, 0, 0.1]])


# --- what is not a regular file ---------------------------------------------------------------------------------


@pytest.mark.parametrize("reader", ["gtsam", "kitti", "cmu text"])
def test_a_fifo_given_to_a_reader_is_refused_without_waiting_on_it(tmp_path: Path, reader: str) -> None:
    if reader == "gtsam":
        os.mkfifo(tmp_path / "v.txt")
        call, named = (lambda: load_gtsam_2d(tmp_path / "v.txt")), "v.txt"
    elif reader == "kitti":
        _kitti(tmp_path)
        (tmp_path / GPS_FILE).unlink()
        os.mkfifo(tmp_path / GPS_FILE)
        call, named = (lambda: load_kitti(tmp_path, group=SE3V)), GPS_FILE
    else:
        (tmp_path / "T_.mat").write_bytes(b"")
        (tmp_path / "T_TD.txt").write_text("0 1 1 1\n")
        os.mkfifo(tmp_path / "T_DR.txt")
        call, named = (lambda: load_cmu_text(tmp_path, "T")), "T_DR.txt"
    with _within(5), pytest.raises(DataError, match=rf"{re.escape(named)}: not a file"):
        call()


@pytest.mark.parametrize("kind", ["FIFO", "device"])
def test_load_dataset_names_a_path_that_is_there_but_is_not_a_file(tmp_path: Path, kind: str) -> None:
    """Not "not found, fetch it with `steam-ref data fetch /dev/null`": the path is there, and is no file."""
    if kind == "FIFO":
        path = tmp_path / "ranges.txt"
        os.mkfifo(path)
    else:
        path = Path("/dev/null")
    with _within(5), pytest.raises(DataError, match=rf"^{re.escape(str(path))}: not a file \(a {kind}\)") as err:
        load_dataset(path)
    assert "not found" not in str(err.value) and "data fetch" not in str(err.value)


def test_the_command_names_a_dataset_path_that_is_not_a_file_in_one_line(capsys: pytest.CaptureFixture) -> None:
    code, out, err = runner("run")(capsys, "--dataset", "/dev/null", "--preset", "synthetic")
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and "/dev/null: not a file (a device)" in err, err


# --- trajectory files (TUM, KITTI poses) --------------------------------------------------------------------------


@pytest.mark.parametrize("fmt", ["tum", "kitti"])
def test_a_trajectory_file_cut_inside_its_last_number_is_refused_naming_the_line(tmp_path: Path, fmt: str) -> None:
    """TUM's last field is qw: cut from 0.9210609940028851 to 0.92106099400288 the quaternion is still within 1e-3 of
    unit norm, so the file used to read, its last heading moved. (A KITTI pose file ends in t_z = 0, so this cut
    drops a field and was refused already; it is held to the same rule.) Only the missing newline shows the cut."""
    path = tmp_path / f"path.{fmt}"
    poses = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.3], [2.0, 0.5, 0.8]])
    if fmt == "tum":
        write_tum(path, [0.0, 1.0, 2.0], poses)
    else:
        write_kitti(path, poses)
    raw = path.read_bytes()
    path.write_bytes(raw[:-3])
    read = read_tum if fmt == "tum" else read_kitti
    line = raw.count(b"\n")
    with pytest.raises(DataError, match=rf"path\.{fmt},? line {line}: the last line does not end with a newline"):
        read(path)


def test_a_tum_file_with_windows_line_ends_and_comments_reads_the_poses_written(tmp_path: Path) -> None:
    """Oracle: the numbers written (x, y, and θ from its quaternion (0, 0, sin θ/2, cos θ/2))."""
    rows = [[0.5, 1.0, 2.0, 0.0, 0.0, 0.0, np.sin(0.15), np.cos(0.15)], [1.5, 3.0, 4.0, 0.0, 0.0, 0.0, 0.0, 1.0]]
    text = "# timestamp tx ty tz qx qy qz qw\r\n" + "".join(" ".join(f"{v:.17g}" for v in r) + " \r\n" for r in rows)
    (tmp_path / "t.txt").write_bytes(text.encode())
    t, poses = read_tum(tmp_path / "t.txt")
    np.testing.assert_array_equal(t, [0.5, 1.5])
    np.testing.assert_allclose(poses, [[1.0, 2.0, 0.3], [3.0, 4.0, 0.0]], rtol=0, atol=1e-15)


def test_a_folder_of_two_cmu_text_sets_is_refused_naming_a_file_the_command_can_be_given(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    """ "pass prefix=" is Python's answer; the command has no --prefix, but reads a ``*_DR.txt`` path given."""
    for prefix in ("A", "B"):
        (tmp_path / f"{prefix}_DR.txt").write_text("1 1 0\n")
    code, out, err = runner("run")(capsys, "--dataset", tmp_path, "--preset", "plaza")
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1, err
    assert f"found several (A, B): give the one to read, e.g. {tmp_path / 'A_DR.txt'}" in err, err


# --- .mat integers --------------------------------------------------------------------------------------------------


def test_an_integer_in_a_mat_that_float64_cannot_hold_is_refused_not_rounded(tmp_path: Path) -> None:
    """A landmark id stored as int64 2^53 + 1 read as float64 is 2^53: another id, in silence. Oracle: the int64
    written; 2^53 itself (every integer up to it is exact) still reads as written."""
    from steam_ref.datasets import generate_synthetic, load_cmu_mat

    small = generate_synthetic(n_steps=4, n_landmarks=2, seed=3)
    arrays = small.to_cmu_arrays()
    arrays["TD"] = arrays["TD"][:0]  # no range names the landmark whose id changes
    for value, refused in ((2**53 + 1, True), (2**53, False)):
        tl = arrays["TL"].astype(np.int64)
        tl[0, 0] = value
        scipy.io.savemat(tmp_path / "ids.mat", {**arrays, "TL": tl})
        if refused:
            with pytest.raises(DataError, match=rf"ids\.mat: TL\[0, 0\] = {value} is an integer float64 cannot hold"):
                load_cmu_mat(tmp_path / "ids.mat")
        else:
            assert int(load_cmu_mat(tmp_path / "ids.mat").landmarks[0, 0]) == value
