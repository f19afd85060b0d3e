"""steam_ref.datasets.read_mat: a .mat file's structure is walked before scipy reads it.

The corrupt files here each crashed scipy 1.17's reader (SIGBUS, SIGSEGV) or made it allocate
gigabytes, before :mod:`steam_ref.datasets.matfile` checked the tags; every one must now raise
DataError naming the file. (If the check regressed, the test process itself would die: loudly.)
Valid files of every kind must read exactly as scipy reads them.
"""

from __future__ import annotations

import re
import struct
from pathlib import Path

import numpy as np
import pytest
import scipy.io
import scipy.sparse

from steam_ref.datasets import generate_synthetic, load_cmu_mat, read_mat
from steam_ref.errors import DataError

SMALL = generate_synthetic(n_steps=4, n_landmarks=2, seed=3, range_sigma=0.3)


def _plain_mat(path: Path, **arrays) -> bytearray:
    scipy.io.savemat(path, arrays, do_compression=False)
    return bytearray(path.read_bytes())


def _top_level(raw: bytes) -> dict[str, int]:
    """Offset of each top-level array (uncompressed file, names of at most 4 characters)."""
    found, off = {}, 128
    while off < len(raw):
        kind, size = struct.unpack_from("<II", raw, off)
        assert kind == 14
        name_tag = struct.unpack_from("<I", raw, off + 40)[0]  # tag, flags, dims (2), then the name
        found[bytes(raw[off + 44 : off + 44 + (name_tag >> 16)]).decode()] = off
        off += 8 + size
    return found


def _refusal(path: Path, raw: bytes) -> str:
    """The DataError message read_mat gives for ``raw`` written to ``path`` ('' if it reads the file or its
    message does not name the file); load_cmu_mat must refuse it too, naming the file."""
    path.write_bytes(bytes(raw))
    try:
        read_mat(path)
    except DataError as err:
        message = str(err)
    else:
        message = ""
    with pytest.raises(DataError, match=re.escape(str(path))):
        load_cmu_mat(path)
    return message if str(path) in message else ""  # a refusal must name the file


def test_an_unknown_data_type_code(tmp_path: Path) -> None:
    """TD's data tag miDOUBLE (9) with one byte flipped to 0xf509: scipy died with a bus error."""
    raw = _plain_mat(tmp_path / "ok.mat", **SMALL.to_cmu_arrays())
    data_tag = _top_level(raw)["TD"] + 48
    raw[data_tag + 1] ^= 0xF5
    assert re.search(rf"unknown MAT data type {0xF509} at byte {data_tag}", _refusal(tmp_path / "bad.mat", raw)), (
        "read_mat must refuse it, naming the fault"
    )


def test_the_complex_flag_on_a_real_array(tmp_path: Path) -> None:
    """GT flagged complex with no imaginary part: scipy read past the array and crashed."""
    raw = _plain_mat(tmp_path / "ok.mat", **SMALL.to_cmu_arrays())
    at = _top_level(raw)["GT"]
    raw[at + 17] ^= 0x08  # bit 0x0800 of the flags word
    assert re.search(
        rf"array at byte {at} \(class 6, complex.*not what its class", _refusal(tmp_path / "bad.mat", raw)
    ), "read_mat must refuse it, naming the fault"


def test_a_sparse_class_on_dense_data(tmp_path: Path) -> None:
    raw = _plain_mat(tmp_path / "ok.mat", **SMALL.to_cmu_arrays())
    at = _top_level(raw)["TL"]
    raw[at + 16] = 5  # mxSPARSE_CLASS
    assert re.search(rf"array at byte {at} \(class 5", _refusal(tmp_path / "bad.mat", raw)), (
        "read_mat must refuse it, naming the fault"
    )


def test_dimensions_that_do_not_match_the_data(tmp_path: Path) -> None:
    """A cell array claiming 10⁹ entries made scipy allocate 8 GB before reading any; a numeric
    array whose dimensions disagree with its data is refused too."""
    cells = np.empty((1, 2), dtype=object)
    cells[0, 0], cells[0, 1] = np.ones(3), np.zeros((2, 2))
    raw = _plain_mat(tmp_path / "ok.mat", C=cells, GT=np.array(SMALL.ground_truth))
    at = _top_level(raw)
    bad = bytearray(raw)
    struct.pack_into("<i", bad, at["C"] + 36, 10**9)
    assert re.search(r"class 1, dimensions \(1, 1000000000\)", _refusal(tmp_path / "cells.mat", bad)), (
        "read_mat must refuse it, naming the fault"
    )
    bad = bytearray(raw)
    struct.pack_into("<i", bad, at["GT"] + 32, 6)  # 6 rows of GT, data for 5
    assert re.search(r"class 6, dimensions \(6, 4\)", _refusal(tmp_path / "rows.mat", bad)), (
        "read_mat must refuse it, naming the fault"
    )


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda raw: raw[:100], r"100 bytes, shorter than a MATLAB v5 header"),
        (lambda raw: raw[:126] + b"XX" + raw[128:], r"no endian mark"),
        (lambda raw: raw[:124] + b"\x00\x02" + raw[126:], r"version 0x0200 .*v7\.3"),
        (lambda raw: raw[:-3], r"claims \d+ bytes, only \d+ follow"),
        (lambda raw: raw + b"\x00\x00\x00", r"element tag cut short"),
    ],
    ids=["short", "no-mark", "v7.3", "cut", "trailing"],
)
def test_broken_containers(tmp_path: Path, edit, message) -> None:
    raw = _plain_mat(tmp_path / "ok.mat", **SMALL.to_cmu_arrays())
    assert re.search(message, _refusal(tmp_path / "bad.mat", edit(bytes(raw)))), (
        "read_mat must refuse it, naming the fault"
    )


def test_a_corrupted_compressed_element(tmp_path: Path) -> None:
    path = tmp_path / "ok.mat"
    scipy.io.savemat(path, SMALL.to_cmu_arrays(), do_compression=True)
    raw = bytearray(path.read_bytes())
    raw[128 + 8 + 20] ^= 0x40  # inside the first compressed stream
    assert re.search(r"compressed element at byte 128", _refusal(tmp_path / "bad.mat", raw)), (
        "read_mat must refuse it, naming the fault"
    )


def test_missing_and_folder(tmp_path: Path) -> None:
    with pytest.raises(DataError, match=r"absent\.mat: no such file"):
        read_mat(tmp_path / "absent.mat")
    (tmp_path / "dir.mat").mkdir()
    with pytest.raises(DataError, match=r"dir\.mat: not a file"):
        read_mat(tmp_path / "dir.mat")


@pytest.mark.parametrize("compress", [False, True], ids=["plain", "compressed"])
def test_valid_files_of_every_kind_read_as_scipy_reads_them(tmp_path: Path, compress: bool) -> None:
    structs = np.zeros((2, 3), dtype=[("a", "O"), ("b", "O")])
    for i in range(2):
        for j in range(3):
            structs[i, j]["a"], structs[i, j]["b"] = np.arange(i + j, dtype=float), "x" * j
    cells = np.empty((1, 3), dtype=object)
    cells[0, 0], cells[0, 1], cells[0, 2] = np.zeros((0, 0)), "é ü", np.empty((0, 1), dtype=object)
    arrays = dict(
        sparse=scipy.sparse.random(5, 4, density=0.3, format="csc", random_state=1),
        csparse=scipy.sparse.random(5, 4, density=0.3, format="csc", random_state=2) * (1 + 2j),
        esparse=scipy.sparse.csc_matrix((3, 0)),
        chars=np.array(["ab", "cd"]),
        empty_text="",
        text="naïve ☃",
        cplx=np.array([[1 + 2j, 3]]),
        st=structs,
        es=np.zeros((0, 0), dtype=[("a", "O")]),
        cells=cells,
        empty=np.zeros((0, 0)),
        cube=np.arange(24.0).reshape(2, 3, 4),
        i8=np.int8([1, -2]),
        u64=np.uint64([2**63]),
        f32=np.float32([1.5]),
        flag=True,
        **SMALL.to_cmu_arrays(),
    )
    path = tmp_path / "kinds.mat"
    scipy.io.savemat(path, arrays, do_compression=compress)
    ours, theirs = read_mat(path), scipy.io.loadmat(path)
    assert sorted(ours) == sorted(arrays)
    for name in ("sparse", "csparse", "esparse"):
        assert (ours[name] != theirs[name]).nnz == 0 and ours[name].shape == theirs[name].shape
    for name in ("chars", "cplx", "empty", "cube", "i8", "u64", "f32", "flag", "GT", "TD"):
        np.testing.assert_array_equal(ours[name], theirs[name], err_msg=name)
    assert ours["st"].shape == (2, 3) and ours["cells"][0, 1] == "é ü" and ours["text"] == "naïve ☃"
