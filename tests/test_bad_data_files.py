"""Data files that lie about their size or their ids.

- **GTSAM text ids** are read as integers, never through a float: any two ids the file writes
  differently stay two landmarks, ids up to 2^53 are kept exactly, larger ones (which the data set's
  float64 columns cannot hold) and ids not written in digits are refused naming line and field.
- **A .mat decompression bomb** is refused before it is inflated: a compressed variable declaring
  more than the limit (256 MiB by default; ``read_mat(max_bytes=...)``, ``$STEAM_REF_MAX_MAT_MB``), and
  one inflating past what it declared, are refused, and memory stays bounded while refusing.
"""

from __future__ import annotations

import struct
import tracemalloc
import zlib
from pathlib import Path

import numpy as np
import pytest
import scipy.io
from hypothesis import given, settings
from hypothesis import strategies as st

from steam_ref.cli import commands as cli
from steam_ref.datasets import load_gtsam_2d
from steam_ref.datasets.matfile import MAX_BYTES, MAX_BYTES_ENV, max_mat_bytes, read_mat
from steam_ref.errors import DataError

# --- GTSAM ids ---------------------------------------------------------------------------------

ODOMETRY = "ODOMETRY 0 1 1.0 0 0 0.01 0 0 0.01 0 0.001\nODOMETRY 1 2 1.0 0 0 0.01 0 0 0.01 0 0.001\n"


def _gtsam(tmp_path: Path, ids: list[str]) -> Path:
    rows = "".join(f"LANDMARK 1 {j} {5.0 + k} 2.0 0.4 0 0.4\n" for k, j in enumerate(ids))
    path = tmp_path / "ids.txt"
    path.write_text(ODOMETRY + rows)
    return path


@settings(max_examples=60, deadline=None, database=None)
@given(ids=st.lists(st.integers(3, 2**64) | st.integers(2**53 - 3, 2**53 + 3), min_size=1, max_size=4, unique=True))
def test_landmark_ids_stay_as_many_as_the_file_writes(tmp_path_factory, ids: list[int]) -> None:
    path = _gtsam(tmp_path_factory.mktemp("ids"), [str(j) for j in ids])
    if max(ids) > 2**53:
        with pytest.raises(DataError, match=r"line \d, field 3: id \d+ is above 2\^53"):
            load_gtsam_2d(path)
    else:
        data = load_gtsam_2d(path)
        assert [int(j) for j in data.landmark_ids] == ids  # exactly, in the order of first sighting
        assert [int(j) for j in data.bearing_ranges[:, 1]] == ids


def test_the_two_ids_next_to_2_to_the_53_stay_two(tmp_path: Path) -> None:
    data = load_gtsam_2d(_gtsam(tmp_path, [str(2**53 - 1), str(2**53)]))
    assert data.n_landmarks == 2 and [int(j) for j in data.landmark_ids] == [2**53 - 1, 2**53]


@pytest.mark.parametrize("text", ["5.0", "5e0", "-5", "+5", "0x5", "5.5", "5_0", "1e20", "0b1"])
@pytest.mark.parametrize("field", [1, 2])
def test_an_id_not_written_in_digits_is_refused(tmp_path: Path, text: str, field: int) -> None:
    path = tmp_path / "odd.txt"
    row = ["LANDMARK", "1", "7", "5.0", "2.0", "0.4", "0", "0.4"]
    row[field] = text
    path.write_text(ODOMETRY + " ".join(row) + "\n")
    with pytest.raises(
        DataError, match=rf"line 3, field {field + 1}: id .* is not a non-negative integer written in digits"
    ):
        load_gtsam_2d(path)


def test_a_pose_id_above_2_to_the_53_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "poses.txt"
    path.write_text(f"ODOMETRY 0 {2**53 + 1} 1.0 0 0 0.01 0 0 0.01 0 0.001\n")
    with pytest.raises(DataError, match=r"line 1, field 3: id 9007199254740993 is above 2\^53"):
        load_gtsam_2d(path)


# --- .mat bombs --------------------------------------------------------------------------------


def _header() -> bytes:
    return b"MATLAB 5.0 MAT-file, a test".ljust(116, b" ") + b"\0" * 8 + struct.pack("<H", 0x0100) + b"IM"


def _bomb(path: Path, declared: int, inflated: int) -> Path:
    """A .mat file of one compressed element whose inner tag declares ``declared`` bytes and whose
    stream inflates to ``inflated`` bytes of zeros, compressed a MiB at a time (never held whole)."""
    deflate = zlib.compressobj(9)
    parts = [deflate.compress(struct.pack("<II", 14, declared))]
    left = inflated - 8
    zeros = bytes(2**20)
    while left > 0:
        parts.append(deflate.compress(zeros[: min(left, len(zeros))]))
        left -= len(zeros)
    parts.append(deflate.flush())
    body = b"".join(parts)
    path.write_bytes(_header() + struct.pack("<II", 15, len(body)) + body)
    return path


def test_the_default_limit_is_256_mib(monkeypatch) -> None:
    monkeypatch.delenv(MAX_BYTES_ENV, raising=False)
    assert max_mat_bytes() == MAX_BYTES == 256 * 2**20


@pytest.mark.parametrize("text", ["0", "-1", "nan", "inf", "many"])
def test_a_bad_limit_in_the_environment_is_named(monkeypatch, text: str) -> None:
    monkeypatch.setenv(MAX_BYTES_ENV, text)
    with pytest.raises(DataError, match=MAX_BYTES_ENV):
        max_mat_bytes()


def test_a_bomb_is_refused_on_its_declared_size_without_inflating_it(tmp_path: Path) -> None:
    path = _bomb(tmp_path / "bomb.mat", declared=64 * 2**20, inflated=64 * 2**20)
    assert path.stat().st_size < 2**20  # the bomb: under a MiB on disk
    tracemalloc.start()
    try:
        with pytest.raises(DataError, match=r"declares 67,108,872 bytes once inflated, more than the"):
            read_mat(path, max_bytes=2**20)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 4 * 2**20


def test_a_bomb_that_lies_about_its_size_is_stopped_at_the_size_it_declared(tmp_path: Path) -> None:
    path = _bomb(tmp_path / "liar.mat", declared=1000, inflated=64 * 2**20)
    tracemalloc.start()
    try:
        with pytest.raises(DataError, match=r"inflates to more than its declared 1,008 bytes"):
            read_mat(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 4 * 2**20


def test_many_variables_under_the_limit_each_are_bounded_together(tmp_path: Path) -> None:
    path = tmp_path / "many.mat"
    scipy.io.savemat(path, {f"a{i}": np.zeros(40_000) for i in range(8)}, do_compression=True)  # 8 x 320 kB
    assert set(read_mat(path, max_bytes=4 * 2**20)) == {f"a{i}" for i in range(8)}
    with pytest.raises(DataError, match="more than the"):
        read_mat(path, max_bytes=2**20)


def test_the_cli_names_the_bomb_and_the_setting(tmp_path: Path, monkeypatch, capsys) -> None:
    path = _bomb(tmp_path / "bomb.mat", declared=8 * 2**20, inflated=8 * 2**20)
    monkeypatch.setenv(MAX_BYTES_ENV, "1")
    code = cli.main(["run", "--dataset", str(path), "--preset", "plaza"])
    _, err = capsys.readouterr()
    assert code == 2 and len(err.splitlines()) == 1 and "bomb.mat" in err and MAX_BYTES_ENV in err
