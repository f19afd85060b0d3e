"""The bad-input corpus ("never silently wrong"): data files, set-ups and options.

Every bad input either loads the same data (equal arrays) or raises the project's DataError naming
the place (the file, and the row or line and column where there is one); never another exception
type, never a NaN in a result. The corpus is made here from one small valid data set: its files cut
at every byte offset, NaN and inf in each column, each table transposed, rows shuffled, unknown
ids, negative ranges, a one-pose set; then random corruption (hypothesis: byte flips, deletions,
insertions, cuts). Text tables are compared with an oracle that reads the documented rule
(:data:`steam_ref.datasets.cmu.TEXT_TABLE_RULE`) with regular expressions: what the rule reads, the
loader must return, and what it refuses, the loader must refuse. The CLI's side is in
``test_bad_cli.py``.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import scipy.io
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from steam_ref.datasets import RangeDataset, generate_synthetic, load_cmu_mat, load_cmu_text
from steam_ref.errors import DataError

FIELDS = ("ground_truth", "odometry", "dead_reckoning", "landmarks", "ranges")
CMU = {"GT": "ground_truth", "DR": "odometry", "DRp": "dead_reckoning", "TL": "landmarks", "TD": "ranges"}
COLUMNS = {
    "GT": ("time", "x", "y", "heading"),
    "DR": ("time", "distance", "heading change"),
    "DRp": ("time", "x", "y", "heading"),
    "TL": ("id", "x", "y"),
    "TD": ("time", "sender id", "landmark id", "range"),
}
# 5 poses, 4 odometry rows, 2 landmarks, 5 ranges: no table is square, so a transposed one never fits.
SMALL = generate_synthetic(n_steps=4, n_landmarks=2, seed=3, range_sigma=0.3)
FAST = settings(
    max_examples=60, deadline=None, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)


def _save(path: Path, compress: bool = False, **tables: np.ndarray) -> Path:
    scipy.io.savemat(path, tables, do_compression=compress)
    return path


def _text_set(folder: Path, copies: bool) -> Path:
    """SMALL as the CMU text release: T_DR.txt, T_TD.txt, and T_.mat with GT and TL (and, with
    ``copies``, DR and TD too, as the Plaza files have them). Numbers written to round-trip exactly."""
    folder.mkdir(parents=True, exist_ok=True)
    np.savetxt(folder / "T_DR.txt", SMALL.odometry, fmt="%.17g", delimiter="\t")
    np.savetxt(folder / "T_TD.txt", SMALL.ranges, fmt="%.17g", delimiter="\t")
    extra = dict(DR=np.array(SMALL.odometry), TD=np.array(SMALL.ranges)) if copies else {}
    _save(folder / "T_.mat", GT=np.array(SMALL.ground_truth), TL=np.array(SMALL.landmarks), **extra)
    return folder


def _assert_same(ds: RangeDataset, fields=FIELDS) -> None:
    for name in fields:
        np.testing.assert_array_equal(getattr(ds, name), getattr(SMALL, name), err_msg=name)


def _assert_finite(ds: RangeDataset) -> None:
    for name in FIELDS:
        assert np.all(np.isfinite(getattr(ds, name))), name


# ---------------------------------------------------------------------------------------------
# The oracle: what the text rule reads
# ---------------------------------------------------------------------------------------------

_NUM = r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?"


def _oracle(raw: bytes, n_columns: int) -> np.ndarray | None:
    """The (n, n_columns) table the documented rule reads from ``raw``, or None when it refuses it."""
    if any(b > 127 for b in raw):
        return None
    *lines, tail = raw.decode("ascii").split("\n")
    if not re.fullmatch(r"[ \t\r]*", tail):
        return None  # the last line has no newline
    row = re.compile(rf"[ \t]*({_NUM})" + rf"[ \t]+({_NUM})" * (n_columns - 1) + r"[ \t]*\r?")
    rows = []
    for line in lines:
        if re.fullmatch(r"[ \t]*\r?", line):
            continue
        match = row.fullmatch(line)
        if match is None:
            return None
        values = [float(v) for v in match.groups()]
        if not np.all(np.isfinite(values)):
            return None
        rows.append(values)
    return np.array(rows) if rows else None


def _check_text_file(folder: Path, which: str, raw: bytes) -> None:
    """Write ``raw`` as T_<which>.txt in ``folder`` and hold the loader to the oracle."""
    path = folder / f"T_{which}.txt"
    path.write_bytes(raw)
    expected = _oracle(raw, len(COLUMNS[which]))
    try:
        loaded = load_cmu_text(folder)
    except DataError as err:
        assert str(path) in str(err), str(err)
        if expected is not None:  # the rule reads the file, so the data set's own checks must refuse it
            tables = dict(
                GT=np.array(SMALL.ground_truth),
                TL=np.array(SMALL.landmarks),
                DR=np.array(SMALL.odometry),
                TD=np.array(SMALL.ranges),
            )
            tables[which] = expected
            with pytest.raises(DataError):
                load_cmu_mat(_save(folder.parent / "cross-check.mat", **tables))
        return
    assert expected is not None, f"loaded a file the rule refuses: {raw!r}"
    np.testing.assert_array_equal(getattr(loaded, CMU[which]), expected)
    other = [f for f in ("ground_truth", "odometry", "landmarks", "ranges") if f != CMU[which]]
    _assert_same(loaded, other)
    _assert_finite(loaded)


# ---------------------------------------------------------------------------------------------
# Cut files
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("copies", [True, False], ids=["mat-has-copies", "text-only"])
@pytest.mark.parametrize("which", ["DR", "TD"])
def test_a_text_table_cut_at_every_byte(tmp_path: Path, which: str, copies: bool) -> None:
    """Cut inside a line: DataError naming the file and line (the last line has no newline). Cut at a
    line end: whole rows are gone, which DR's count against GT's and the .mat's copy of TD catch; a
    TD with no copy loads exactly the whole lines left (a shorter file; documented in cmu.py)."""
    folder = _text_set(tmp_path / "set", copies)
    path = folder / f"T_{which}.txt"
    whole = path.read_bytes()
    for k in range(len(whole) + 1):
        cut = whole[:k]
        path.write_bytes(cut)
        if k == len(whole):
            _assert_same(load_cmu_text(folder), ("ground_truth", "odometry", "landmarks", "ranges"))
        elif cut.endswith(b"\n") and which == "TD" and not copies:
            kept = cut.count(b"\n")
            np.testing.assert_array_equal(load_cmu_text(folder).ranges, SMALL.ranges[:kept])
        elif k == 0:
            with pytest.raises(DataError, match=rf"{re.escape(str(path))}: the file holds no rows"):
                load_cmu_text(folder)
        elif cut.endswith(b"\n"):
            with pytest.raises(DataError, match=re.escape(str(folder))):
                load_cmu_text(folder)
        else:
            line = cut.count(b"\n") + 1
            with pytest.raises(
                DataError, match=rf"{re.escape(str(path))} line {line}: the last line does not end with a newline"
            ):
                load_cmu_text(folder)


def test_the_cut_inside_the_last_number_that_used_to_load(tmp_path: Path) -> None:
    """The finding: '5.29560000000000031e+01' cut after '5.2956' read as 5.2956."""
    folder = _text_set(tmp_path / "set", copies=False)
    path = folder / "T_TD.txt"
    text = path.read_text()
    last = text.rstrip("\n").split("\t")[-1]
    path.write_text(text.rstrip("\n")[: -len(last) + 3])  # keeps the field count, drops digits
    with pytest.raises(DataError, match=rf"T_TD\.txt line {SMALL.n_ranges}: the last line does not end with a newline"):
        load_cmu_text(folder)


@pytest.mark.parametrize("compress", [False, True], ids=["plain", "compressed"])
def test_a_mat_file_cut_at_every_byte(tmp_path: Path, compress: bool) -> None:
    whole = _save(tmp_path / "whole.mat", compress, **SMALL.to_cmu_arrays()).read_bytes()
    path = tmp_path / "cut.mat"
    for k in range(len(whole) + 1):
        path.write_bytes(whole[:k])
        try:
            _assert_same(load_cmu_mat(path))
        except DataError as err:
            assert str(path) in str(err)
            assert k < len(whole)


# ---------------------------------------------------------------------------------------------
# NaN, inf, transposed tables, shuffled rows, ids, negative ranges, one pose
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("table", list(CMU))
def test_nan_or_inf_in_each_column_of_each_mat_table(tmp_path: Path, table: str, bad: float) -> None:
    for column, name in enumerate(COLUMNS[table]):
        arrays = SMALL.to_cmu_arrays()
        row = len(arrays[table]) - 1
        arrays[table][row, column] = bad
        path = _save(tmp_path / f"{table}{column}.mat", **arrays)
        with pytest.raises(DataError, match=rf"{re.escape(str(path))}: {table}\[{row}, {column}\] \({name}\) is {bad}"):
            load_cmu_mat(path)


@pytest.mark.parametrize("token", ["nan", "NaN", "inf", "-inf", "Infinity", "1e999", "1_0", "0x1p3", "\u0661"])
@pytest.mark.parametrize("which", ["DR", "TD"])
def test_nan_inf_and_odd_numbers_in_each_column_of_each_text_table(tmp_path: Path, which: str, token: str) -> None:
    """Not a finite plain decimal: nan, inf, an overflow, Python's '1_0', hex, a non-ASCII digit."""
    folder = _text_set(tmp_path / "set", copies=False)
    path = folder / f"T_{which}.txt"
    lines = path.read_text().splitlines()
    for column, name in enumerate(COLUMNS[which]):
        fields = lines[2].split("\t")
        fields[column] = token
        path.write_text("\n".join(lines[:2] + ["\t".join(fields)] + lines[3:]) + "\n", encoding="utf-8")
        where = f"line 3, column {column + 1} \\({name}\\): '{token}' is not a finite decimal number"
        if not token.isascii():
            where = "line 3: byte 0xd9 is not ASCII"
        with pytest.raises(DataError, match=rf"{re.escape(str(path))} {where}"):
            load_cmu_text(folder)


def test_the_plaza_text_style_loads(tmp_path: Path) -> None:
    """The gtsam Plaza files: leading spaces, a tab after every number, CRLF line ends; blank lines skipped."""
    folder = _text_set(tmp_path / "set", copies=True)
    for which, table in (("DR", SMALL.odometry), ("TD", SMALL.ranges)):
        rows = ["".join(f"  {float(v)!r}\t" for v in row) + "\r\n" for row in table]
        (folder / f"T_{which}.txt").write_text("".join(rows[:2]) + " \t\r\n\n" + "".join(rows[2:]), newline="")
    _assert_same(load_cmu_text(folder), ("ground_truth", "odometry", "landmarks", "ranges"))


@pytest.mark.parametrize("table", list(CMU))
def test_a_logical_mat_table_is_refused_not_read_as_zeros_and_ones(tmp_path: Path, table: str) -> None:
    """A MATLAB logical matrix (a table saved as a comparison, ``TD > 0``) was read as the numbers 0 and 1; an array
    of booleans is no array of numbers (steam_ref.arguments), so it is refused naming the file and the table."""
    arrays = SMALL.to_cmu_arrays()
    arrays[table] = arrays[table] > 0
    path = _save(tmp_path / f"{table}.mat", **arrays)
    with pytest.raises(
        DataError, match=rf"{re.escape(str(path))}: {table} is not a numeric matrix \(got an array of bool\)"
    ):
        load_cmu_mat(path)


@pytest.mark.parametrize("table", list(CMU))
def test_each_mat_table_transposed(tmp_path: Path, table: str) -> None:
    arrays = SMALL.to_cmu_arrays()
    arrays[table] = arrays[table].T
    path = _save(tmp_path / "t.mat", **arrays)
    shape = re.escape(str(arrays[table].shape))
    with pytest.raises(
        DataError, match=rf"{re.escape(str(path))}: {table} must have shape \(n, {len(COLUMNS[table])}\).*{shape}"
    ):
        load_cmu_mat(path)


@pytest.mark.parametrize("which", ["DR", "TD"])
def test_each_text_table_transposed(tmp_path: Path, which: str) -> None:
    folder = _text_set(tmp_path / "set", copies=False)
    np.savetxt(folder / f"T_{which}.txt", getattr(SMALL, CMU[which]).T, fmt="%.17g", delimiter="\t")
    n = len(COLUMNS[which])
    with pytest.raises(
        DataError, match=rf"T_{which}\.txt line 1: expected {n} numbers .*got {len(getattr(SMALL, CMU[which]))}"
    ):
        load_cmu_text(folder)


def test_shuffled_rows(tmp_path: Path) -> None:
    """Poses, odometry and dead reckoning out of order are refused; ranges are kept in file order
    and their going back noted (the scripts read them so); landmarks may come in any order."""
    order = [0, 2, 1, 3, 4]
    expect = {
        "GT": r"ground_truth row 2 has t=2\.0 after t=3\.0",
        "DR": r"odometry row 0 has t=3\.0 but pose 1 has t=2\.0",
        "DRp": r"dead_reckoning row 2 has t=2\.0 after t=3\.0",
    }
    for table, message in expect.items():
        arrays = SMALL.to_cmu_arrays()
        arrays[table] = arrays[table][order[: len(arrays[table])]] if table != "DR" else arrays[table][[1, 0, 2, 3]]
        path = _save(tmp_path / f"{table}.mat", **arrays)
        with pytest.raises(DataError, match=rf"{re.escape(str(path))}: .*{message}"):
            load_cmu_mat(path)
    arrays = SMALL.to_cmu_arrays()
    arrays["TD"], arrays["TL"] = arrays["TD"][order], arrays["TL"][::-1]
    loaded = load_cmu_mat(_save(tmp_path / "td.mat", **arrays))
    np.testing.assert_array_equal(loaded.ranges, SMALL.ranges[order])
    assert loaded.source.endswith("TD kept in file order: row(s) 2 go back in time")
    np.testing.assert_array_equal(loaded.landmarks[loaded.landmark_rows([1, 2])], SMALL.landmarks)


@pytest.mark.parametrize(
    ("table", "row", "column", "value", "message"),
    [
        (
            "TD",
            3,
            2,
            99.0,
            r"ranges row 3 \(t=4\.0\) names landmark id 99, which is not in landmarks; known ids: \[1, 2\]",
        ),
        ("TD", 1, 2, 1.5, r"ranges\[1, 2\] \(landmark id\) = 1\.5 is not an integer"),
        ("TD", 4, 1, 0.25, r"ranges\[4, 1\] \(sender id\) = 0\.25 is not an integer"),
        ("TL", 1, 0, 1.0, r"landmark id 1 appears twice, in landmarks rows 0 and 1"),
        ("TD", 2, 3, -0.5, r"ranges\[2, 3\] \(range\) = -0\.5 at t=3\.0 is negative"),
    ],
)
def test_bad_ids_and_negative_ranges_in_a_mat(tmp_path: Path, table, row, column, value, message) -> None:
    arrays = SMALL.to_cmu_arrays()
    arrays[table][row, column] = value
    path = _save(tmp_path / "bad.mat", **arrays)
    with pytest.raises(DataError, match=rf"{re.escape(str(path))}: {message}"):
        load_cmu_mat(path)


def test_a_negative_range_in_a_text_file_names_file_row_and_value(tmp_path: Path) -> None:
    folder = _text_set(tmp_path / "set", copies=False)
    ranges = np.array(SMALL.ranges)
    ranges[3, 3] = -2.0
    np.savetxt(folder / "T_TD.txt", ranges, fmt="%.17g", delimiter="\t")
    with pytest.raises(DataError, match=r"T_TD\.txt.*: ranges\[3, 3\] \(range\) = -2\.0 at t=4\.0 is negative"):
        load_cmu_text(folder)


@pytest.mark.parametrize("n_poses", [0, 1])
def test_a_set_needs_two_poses(tmp_path: Path, n_poses: int) -> None:
    arrays = SMALL.to_cmu_arrays()
    arrays.update(
        GT=arrays["GT"][:n_poses], DR=arrays["DR"][:0], DRp=arrays["DRp"][:n_poses], TD=arrays["TD"][:n_poses]
    )
    path = _save(tmp_path / "few.mat", **arrays)
    with pytest.raises(
        DataError, match=rf"few\.mat: ground_truth has {n_poses} row\(s\): a data set needs at least two poses"
    ):
        load_cmu_mat(path)
    with pytest.raises(DataError, match=r"at least two poses"):
        RangeDataset("few", arrays["GT"], arrays["DR"], arrays["DRp"], arrays["TL"], arrays["TD"])


def test_a_short_dead_reckoning_is_refused_not_recomputed(tmp_path: Path) -> None:
    arrays = SMALL.to_cmu_arrays()
    arrays["DRp"] = arrays["DRp"][:-1]
    with pytest.raises(DataError, match=r"DRp has 4 rows but GT has 5"):
        load_cmu_mat(_save(tmp_path / "short.mat", **arrays))


# ---------------------------------------------------------------------------------------------
# Random corruption
# ---------------------------------------------------------------------------------------------

_EDIT = st.one_of(
    st.tuples(st.just("cut"), st.integers(0, 10**6), st.none()),
    st.tuples(st.just("flip"), st.integers(0, 10**6), st.integers(1, 255)),
    st.tuples(st.just("delete"), st.integers(0, 10**6), st.integers(1, 6)),
    st.tuples(
        st.just("insert"),
        st.integers(0, 10**6),
        st.binary(min_size=1, max_size=3)
        | st.sampled_from([b"nan", b"inf", b"-", b".", b"e", b"\n", b"\t", b" ", b"\r", b"1_0", b"0x1"]),
    ),
)


def _corrupt(raw: bytes, edits) -> bytes:
    data = bytearray(raw)
    for kind, where, what in edits:
        k = where % (len(data) + (kind == "insert")) if data or kind == "insert" else 0
        if kind == "flip" and data:
            data[k] ^= what
        elif kind == "cut":
            del data[k:]
        elif kind == "delete":
            del data[k : k + what]
        elif kind == "insert":
            data[k:k] = what
    return bytes(data)


@FAST
@given(which=st.sampled_from(["DR", "TD"]), edits=st.lists(_EDIT, min_size=1, max_size=3))
def test_random_corruption_of_a_text_table(tmp_path_factory, which: str, edits) -> None:
    folder = _text_set(tmp_path_factory.mktemp("text") / "set", copies=False)
    _check_text_file(folder, which, _corrupt((folder / f"T_{which}.txt").read_bytes(), edits))


@FAST
@given(edits=st.lists(_EDIT, min_size=1, max_size=3))
def test_random_corruption_of_a_compressed_mat(tmp_path_factory, edits) -> None:
    """Compressed, as the paper's files are: zlib's checksum covers the numbers, so a corrupted
    file loads the same data (a byte of the header text) or raises DataError naming it."""
    folder = tmp_path_factory.mktemp("mat")
    whole = _save(folder / "whole.mat", True, **SMALL.to_cmu_arrays()).read_bytes()
    path = folder / "bad.mat"
    path.write_bytes(_corrupt(whole, edits))
    try:
        _assert_same(load_cmu_mat(path))
    except DataError as err:
        assert str(path) in str(err)


@FAST
@given(edits=st.lists(_EDIT, min_size=1, max_size=3))
def test_random_corruption_of_an_uncompressed_mat(tmp_path_factory, edits) -> None:
    """Uncompressed, a flipped byte inside a number reads as another number: nothing can tell. The
    file still never crashes the reader (a flipped tag did: matfile.py), and what loads passes every
    check of the data set (finite, shapes, times, ids, ranges)."""
    folder = tmp_path_factory.mktemp("mat")
    whole = _save(folder / "whole.mat", False, **SMALL.to_cmu_arrays()).read_bytes()
    path = folder / "bad.mat"
    path.write_bytes(_corrupt(whole, edits))
    try:
        loaded = load_cmu_mat(path)
    except DataError as err:
        assert str(path) in str(err)
        return
    _assert_finite(loaded)
    assert loaded.n_poses >= 2 and np.all(loaded.ranges[:, 3] >= 0)
