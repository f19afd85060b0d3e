"""Tests of steam_ref.datasets: the CMU loaders, the checks of RangeDataset, the synthetic generator.

Sizes asserted for the reference files are those of the README.md beside the files (``../shared/data/README.md``), data/README.md and the paper
(Table I); every other expected value is computed here by a slow, obvious loop. The reference files
come from the ``shared_data`` fixture (conftest.py: $STEAM_REF_DATA_DIR; skip or fail if absent).
"""

from __future__ import annotations

import re
import warnings
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
import scipy.io
from requirements import optional_import

from steam_ref import datasets
from steam_ref.datasets import (
    RangeDataset,
    default_data_dirs,
    generate_synthetic,
    gtsam_data_dir,
    load_cmu_mat,
    load_cmu_text,
    load_dataset,
    search,
)
from steam_ref.dead_reckoning import integrate_odometry
from steam_ref.errors import DataError, ShapeError, SteamError, SteamWarning, UncleanedDataWarning

SYN_FILE, PLAZA_FILE = "Syn_theta_Plaza.mat", "Plaza1_thrown_away_some_range.mat"
FIELDS = ("ground_truth", "odometry", "dead_reckoning", "landmarks", "ranges")


# ---------------------------------------------------------------------------------------------
# Fixtures and slow oracles
# ---------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def paper_synthetic(shared_data: Path) -> RangeDataset:
    return load_cmu_mat(shared_data / SYN_FILE)


@pytest.fixture(scope="module")
def plaza(shared_data: Path) -> RangeDataset:
    return load_cmu_mat(shared_data / PLAZA_FILE)


@pytest.fixture(scope="module")
def small() -> RangeDataset:
    """A small valid data set whose arrays the validation tests spoil one at a time."""
    return generate_synthetic(n_steps=20, n_landmarks=5, seed=7)


@pytest.fixture
def isolated(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """No gtsam, no $STEAM_REF_DATA_DIR, cwd in an empty folder beside a ../shared/data holding the files."""
    empty = tmp_path / "nothing_here"
    (empty / "cwd").mkdir(parents=True)
    _decoy_shared(empty)
    monkeypatch.setattr(search, "gtsam_data_dir", lambda: None)  # patched where default_data_dirs looks it up
    monkeypatch.delenv(datasets.DATA_DIR_ENV, raising=False)
    monkeypatch.chdir(empty / "cwd")
    return tmp_path


def _decoy_shared(root: Path) -> None:
    """``root/shared/data`` holding both named files: a repository-relative search would find them."""
    (root / "shared" / "data").mkdir(parents=True)
    ds = generate_synthetic(n_steps=5, n_landmarks=2, seed=1)
    for name in (SYN_FILE, PLAZA_FILE):
        _save_mat(root / "shared" / "data" / name, **ds.to_cmu_arrays())


def _fields(ds: RangeDataset) -> dict[str, np.ndarray]:
    return {name: np.array(getattr(ds, name)) for name in FIELDS}


def _rebuild(ds: RangeDataset, **changes: np.ndarray) -> RangeDataset:
    arrays = _fields(ds)
    arrays.update(changes)
    return RangeDataset(name="spoiled", source="test", **arrays)


def _integrate_loop(start: np.ndarray, odometry: np.ndarray) -> np.ndarray:
    """Dead reckoning one step at a time: move along the current heading, then turn."""
    t, x, y, th = start
    rows = [(t, x, y, th)]
    for t, d, dth in odometry:
        x, y, th = x + d * np.cos(th), y + d * np.sin(th), th + dth
        rows.append((t, x, y, th))
    return np.array(rows)


def _rows_going_back_loop(times: np.ndarray) -> list[int]:
    """Rows whose time is earlier than the row before's, one comparison at a time."""
    return [k for k in range(1, len(times)) if times[k] < times[k - 1]]


def _true_ranges_loop(ds: RangeDataset, states: np.ndarray) -> np.ndarray:
    where = {int(i): (x, y) for i, x, y in ds.landmarks}
    return np.array(
        [
            np.hypot(ds.ground_truth[s, 1] - where[int(j)][0], ds.ground_truth[s, 2] - where[int(j)][1])
            for s, j in zip(states, ds.ranges[:, 2], strict=True)
        ]
    )


def _t(value: float) -> str:
    """A time as the messages print it, escaped for a regex."""
    return re.escape(repr(float(value)))


def _wrap(a: np.ndarray) -> np.ndarray:
    return np.arctan2(np.sin(a), np.cos(a))


def _save_mat(path: Path, **arrays: np.ndarray) -> Path:
    scipy.io.savemat(path, arrays)
    return path


def _write_text_set(folder: Path, ds: RangeDataset, prefix: str = "Toy") -> Path:
    """CMU text release of ``ds``: <prefix>_DR.txt, <prefix>_TD.txt, <prefix>_.mat with GT, TL."""
    folder.mkdir(parents=True, exist_ok=True)
    np.savetxt(folder / f"{prefix}_DR.txt", ds.odometry, delimiter="\t", fmt="%.17e")
    np.savetxt(folder / f"{prefix}_TD.txt", ds.ranges, delimiter="\t", fmt="%.17e")
    _save_mat(folder / f"{prefix}_.mat", GT=np.array(ds.ground_truth), TL=np.array(ds.landmarks))
    return folder


def _assert_same_data(a: RangeDataset, b: RangeDataset) -> None:
    for name in FIELDS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)


# ---------------------------------------------------------------------------------------------
# The reference files
# ---------------------------------------------------------------------------------------------


def test_paper_synthetic_has_the_readme_sizes(paper_synthetic: RangeDataset) -> None:
    ds = paper_synthetic
    assert (ds.n_poses, len(ds.odometry), ds.n_landmarks, ds.n_ranges) == (1501, 1500, 298, 1501)
    assert ds.dead_reckoning.shape == (1501, 4)
    assert "Syn_theta_Plaza.mat" in ds.source
    # One range per pose, stamped with the pose's time: nothing goes back, nothing is noted.
    np.testing.assert_array_equal(ds.ranges[:, 0], ds.times)
    assert ds.ranges_going_back().size == 0 and "file order" not in ds.source


def test_plaza_has_the_readme_sizes_and_the_file_content(plaza: RangeDataset, shared_data: Path) -> None:
    assert (plaza.n_poses, len(plaza.odometry), plaza.n_landmarks, plaza.n_ranges) == (9658, 9657, 4, 3363)
    raw = scipy.io.loadmat(shared_data / PLAZA_FILE)
    for field_name, key in (("ground_truth", "GT"), ("odometry", "DR"), ("dead_reckoning", "DRp")):
        np.testing.assert_array_equal(getattr(plaza, field_name), raw[key])
    np.testing.assert_array_equal(plaza.landmarks, raw["TL"])  # TL keeps its (unsorted) order
    assert list(plaza.landmark_ids) == [int(i) for i in raw["TL"][:, 0]]
    # TD is kept exactly as in the file, in file order, as the paper's scripts read it.
    np.testing.assert_array_equal(plaza.ranges, raw["TD"])


def test_plaza_ranges_going_back_are_the_files_backward_jumps(plaza: RangeDataset, shared_data: Path) -> None:
    back = _rows_going_back_loop(scipy.io.loadmat(shared_data / PLAZA_FILE)["TD"][:, 0])
    assert len(back) == 2  # two blocks go back in time (data/README.md)
    assert list(plaza.ranges_going_back()) == back
    rows = ", ".join(str(k) for k in back)
    assert plaza.source.endswith(f"; TD kept in file order: row(s) {rows} go back in time")


@pytest.mark.parametrize("which", ["paper_synthetic", "plaza"])
def test_odometry_row_k_carries_the_time_of_pose_k_plus_1(which: str, request: pytest.FixtureRequest) -> None:
    ds = request.getfixturevalue(which)
    assert np.array_equal(ds.odometry[:, 0], ds.ground_truth[1:, 0])


def test_paper_synthetic_dead_reckoning_is_its_odometry_integrated(paper_synthetic: RangeDataset) -> None:
    ds = paper_synthetic
    oracle = _integrate_loop(ds.ground_truth[0], ds.odometry)
    np.testing.assert_allclose(ds.dead_reckoning, oracle, rtol=0, atol=1e-9)
    np.testing.assert_allclose(integrate_odometry(ds.ground_truth[0], ds.odometry), oracle, rtol=0, atol=1e-9)


def test_gtsam_text_files_hold_all_plaza_ranges(plaza: RangeDataset) -> None:
    optional_import("gtsam", "gtsam")
    folder = gtsam_data_dir()
    assert folder is not None and (folder / "Plaza1_DR.txt").is_file()
    text = load_cmu_text(folder, "Plaza1")
    assert (text.n_poses, len(text.odometry), text.n_landmarks, text.n_ranges) == (9658, 9657, 4, 3529)
    for name in ("ground_truth", "odometry", "dead_reckoning", "landmarks"):
        np.testing.assert_array_equal(getattr(text, name), getattr(plaza, name), err_msg=name)
    raw_td = np.loadtxt(folder / "Plaza1_TD.txt")
    np.testing.assert_array_equal(text.ranges, raw_td)  # in file order
    assert list(text.ranges_going_back()) == _rows_going_back_loop(raw_td[:, 0])
    np.testing.assert_array_equal(text.odometry, np.loadtxt(folder / "Plaza1_DR.txt"))
    # The cleaned file's ranges are a sub-multiset of the originals, row for row, time for time.
    assert not Counter(map(tuple, plaza.ranges)) - Counter(map(tuple, text.ranges))
    assert set(plaza.ranges[:, 0]) <= set(text.ranges[:, 0])


def test_plaza_falls_back_to_the_gtsam_text_files(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    optional_import("gtsam", "gtsam")
    (tmp_path / "cwd").mkdir()
    monkeypatch.delenv(datasets.DATA_DIR_ENV, raising=False)  # hide the cleaned file
    monkeypatch.chdir(tmp_path / "cwd")
    assert datasets.uncleaned_plaza(tmp_path) == gtsam_data_dir()  # said beforehand, as `data list` says it
    with pytest.warns(
        UncleanedDataWarning, match=r"ORIGINAL, uncleaned Plaza1 release in .*steam-ref data fetch plaza"
    ):
        ds = load_dataset("plaza", data_dir=tmp_path)
    assert ds.name == "plaza" and ds.n_ranges == 3529 and "Plaza1_TD.txt" in ds.source
    assert issubclass(UncleanedDataWarning, SteamWarning)


def test_the_cleaned_plaza_file_is_read_without_a_warning(shared_data: Path) -> None:
    assert datasets.uncleaned_plaza(shared_data) is None
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert load_dataset("plaza", data_dir=shared_data).n_ranges < 3529


def test_data_list_says_what_plaza_would_read_in_aligned_columns(tmp_path, monkeypatch, capsys) -> None:
    """With no cleaned file anywhere, `data list` says `--dataset plaza` reads gtsam's original files; every
    data set's size ends in the same column, the longest name's too."""
    from steam_ref.cli import main

    optional_import("gtsam", "gtsam")
    monkeypatch.delenv(datasets.DATA_DIR_ENV, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))  # nothing fetched
    assert main(["data", "list"]) == 0
    out = capsys.readouterr().out
    (plaza,) = [line for line in out.splitlines() if line.startswith("plaza ")]
    assert plaza.endswith(f"absent; --dataset plaza reads the ORIGINAL, uncleaned Plaza1 files in {gtsam_data_dir()}")
    rows = [re.match(r"^\S+\s+(?:[\d,]+ B|-)", line) for line in out.splitlines() if line[:1].isalpha()]
    ends = {m.end() for m in rows if m}
    assert len([m for m in rows if m]) >= 6 and len(ends) == 1, out


# ---------------------------------------------------------------------------------------------
# RangeDataset checks
# ---------------------------------------------------------------------------------------------


def test_arrays_are_read_only_copies(small: RangeDataset) -> None:
    arrays = _fields(small)
    ds = RangeDataset(name="copy", source="test", **arrays)
    arrays["ground_truth"][0, 1] = 1e6
    assert ds.ground_truth[0, 1] != 1e6
    for name in FIELDS:
        with pytest.raises(ValueError, match="read-only"):
            getattr(ds, name)[0, 0] = 0.0
    with pytest.raises(ValueError, match="read-only"):
        ds.times[0] = 0.0


def test_properties(small: RangeDataset) -> None:
    assert small.n_poses == len(small.ground_truth) == 21
    assert small.n_landmarks == 5
    np.testing.assert_array_equal(small.times, small.ground_truth[:, 0])
    np.testing.assert_array_equal(small.landmark_ids, [1, 2, 3, 4, 5])
    assert small.landmark_ids.dtype.kind == "i"
    assert "n_poses=21" in repr(small)


def test_nan_names_array_row_and_column(small: RangeDataset) -> None:
    gt = np.array(small.ground_truth)
    gt[3, 2] = np.nan
    with pytest.raises(DataError, match=r"ground_truth\[3, 2\] \(y\) is nan"):
        _rebuild(small, ground_truth=gt)
    td = np.array(small.ranges)
    td[6, 3] = np.inf
    with pytest.raises(DataError, match=r"ranges\[6, 3\] \(range\) is inf"):
        _rebuild(small, ranges=td)


def test_unknown_landmark_id_names_id_and_row(small: RangeDataset) -> None:
    td = np.array(small.ranges)
    td[4, 2] = 99
    with pytest.raises(DataError, match=r"ranges row 4 .*landmark id 99\b"):
        _rebuild(small, ranges=td)
    with pytest.raises(DataError, match=r"landmark id 42"):
        small.landmark_rows([1, 42])


def test_duplicate_and_fractional_landmark_ids(small: RangeDataset) -> None:
    tl = np.array(small.landmarks)
    tl[3, 0] = tl[1, 0]
    with pytest.raises(DataError, match=rf"landmark id {tl[1, 0]:g} appears twice.*rows 1 and 3"):
        _rebuild(small, landmarks=tl)
    tl = np.array(small.landmarks)
    tl[2, 0] = 2.5
    with pytest.raises(DataError, match=r"landmarks\[2, 0\] \(id\) = 2\.5"):
        _rebuild(small, landmarks=tl)


def test_pose_times_must_increase(small: RangeDataset) -> None:
    gt = np.array(small.ground_truth)
    gt[5, 0] = gt[4, 0]
    with pytest.raises(DataError, match=rf"ground_truth row 5 has t={_t(gt[5, 0])}"):
        _rebuild(small, ground_truth=gt)


def test_a_range_going_back_in_time_is_kept_in_place(small: RangeDataset, tmp_path: Path) -> None:
    td = np.array(small.ranges)
    td[[7, 8]] = td[[8, 7]]
    ds = _rebuild(small, ranges=td)
    np.testing.assert_array_equal(ds.ranges, td)
    assert list(ds.ranges_going_back()) == _rows_going_back_loop(td[:, 0]) == [8]
    arrays = small.to_cmu_arrays()
    arrays["TD"] = td
    loaded = load_cmu_mat(_save_mat(tmp_path / "swapped.mat", **arrays))
    np.testing.assert_array_equal(loaded.ranges, td)
    assert loaded.source == f"{tmp_path / 'swapped.mat'}; TD kept in file order: row(s) 8 go back in time"


def test_the_source_note_names_at_most_five_rows(small: RangeDataset, tmp_path: Path) -> None:
    arrays = small.to_cmu_arrays()
    arrays["TD"] = arrays["TD"][::-1]  # every row after the first goes back
    loaded = load_cmu_mat(_save_mat(tmp_path / "reversed.mat", **arrays))
    assert list(loaded.ranges_going_back()) == list(range(1, small.n_ranges))
    assert loaded.source.endswith("; TD kept in file order: row(s) 1, 2, 3, 4, 5, ... go back in time")


def test_odometry_must_line_up_with_poses(small: RangeDataset) -> None:
    with pytest.raises(DataError, match=r"odometry has 19 rows but ground_truth has 21 poses"):
        _rebuild(small, odometry=np.array(small.odometry)[:-1])
    dr = np.array(small.odometry)
    dr[6, 0] += 0.5
    expected = rf"odometry row 6 has t={_t(dr[6, 0])} but pose 7 has t={_t(small.times[7])}"
    with pytest.raises(DataError, match=expected):
        _rebuild(small, odometry=dr)
    with pytest.raises(DataError, match=r"dead_reckoning has 20 rows"):
        _rebuild(small, dead_reckoning=np.array(small.dead_reckoning)[1:])


def test_wrong_columns_raise_shape_error(small: RangeDataset) -> None:
    with pytest.raises(ShapeError, match=r"ground_truth must have shape \(n, 4\).*\(21, 3\)"):
        _rebuild(small, ground_truth=np.array(small.ground_truth)[:, :3])
    with pytest.raises(ShapeError, match=r"ranges must have shape \(n, 4\).*\(84,\)"):
        _rebuild(small, ranges=np.array(small.ranges).ravel())


# ---------------------------------------------------------------------------------------------
# Loading files: malformed input
# ---------------------------------------------------------------------------------------------


def test_mat_round_trip(small: RangeDataset, tmp_path: Path) -> None:
    path = _save_mat(tmp_path / "toy.mat", **small.to_cmu_arrays())
    loaded = load_cmu_mat(path)
    _assert_same_data(loaded, small)
    assert loaded.name == "toy" and loaded.source == str(path)


def test_mat_without_drp_recomputes_it_and_says_so_a_short_one_is_refused(small: RangeDataset, tmp_path: Path) -> None:
    arrays = small.to_cmu_arrays()
    del arrays["DRp"]
    loaded = load_cmu_mat(_save_mat(tmp_path / "no_drp.mat", **arrays))
    np.testing.assert_allclose(
        loaded.dead_reckoning, _integrate_loop(small.ground_truth[0], small.odometry), rtol=0, atol=1e-12
    )
    assert "DRp recomputed" in loaded.source
    arrays["DRp"] = np.array(small.dead_reckoning)[:-2]  # present but short: refused, not replaced
    with pytest.raises(DataError, match=r"short\.mat: DRp has 19 rows but GT has 21"):
        load_cmu_mat(_save_mat(tmp_path / "short.mat", **arrays))


def test_mat_missing_array(small: RangeDataset, tmp_path: Path) -> None:
    arrays = small.to_cmu_arrays()
    del arrays["TD"]
    path = _save_mat(tmp_path / "no_td.mat", **arrays)
    with pytest.raises(DataError, match=r"no_td\.mat: no array 'TD'"):
        load_cmu_mat(path)


def test_mat_wrong_columns(small: RangeDataset, tmp_path: Path) -> None:
    arrays = small.to_cmu_arrays()
    arrays["GT"] = arrays["GT"][:, :3]
    path = _save_mat(tmp_path / "gt3.mat", **arrays)
    with pytest.raises(DataError, match=r"gt3\.mat: GT must have shape \(n, 4\).*\(21, 3\)"):
        load_cmu_mat(path)


def test_mat_with_nan_or_unknown_landmark(small: RangeDataset, tmp_path: Path) -> None:
    arrays = small.to_cmu_arrays()
    arrays["DR"][2, 1] = np.nan
    with pytest.raises(DataError, match=r"nan_dr\.mat: DR\[2, 1\] \(distance\) is nan"):
        load_cmu_mat(_save_mat(tmp_path / "nan_dr.mat", **arrays))
    arrays = small.to_cmu_arrays()
    arrays["TD"][5, 2] = 77
    with pytest.raises(DataError, match=r"bad_id\.mat: ranges row 5 .*landmark id 77"):
        load_cmu_mat(_save_mat(tmp_path / "bad_id.mat", **arrays))


@pytest.mark.parametrize("keep", [0.0, 0.1, 0.5, 0.95])
def test_truncated_mat(small: RangeDataset, tmp_path: Path, keep: float) -> None:
    whole = _save_mat(tmp_path / "whole.mat", **small.to_cmu_arrays()).read_bytes()
    path = tmp_path / "cut.mat"
    path.write_bytes(whole[: int(keep * len(whole))])
    with pytest.raises(DataError, match=r"cut\.mat"):
        load_cmu_mat(path)


def test_corrupt_or_missing_mat(tmp_path: Path) -> None:
    path = tmp_path / "noise.mat"
    path.write_bytes(np.random.default_rng(0).bytes(2000))
    with pytest.raises(DataError, match=r"noise\.mat: not a MATLAB v5 \.mat file"):
        load_cmu_mat(path)
    with pytest.raises(DataError, match=r"absent\.mat: no such file"):
        load_cmu_mat(tmp_path / "absent.mat")
    text_as_mat = _save_mat(
        tmp_path / "strings.mat", GT="hello", DR=np.zeros((0, 3)), TL=np.zeros((1, 3)), TD=np.zeros((0, 4))
    )
    with pytest.raises(DataError, match=r"strings\.mat: GT is not a numeric matrix"):
        load_cmu_mat(text_as_mat)


def test_text_set_round_trip(small: RangeDataset, tmp_path: Path) -> None:
    folder = _write_text_set(tmp_path / "toy", small)
    loaded = load_cmu_text(folder)
    assert loaded.name == "Toy" and "DRp recomputed" in loaded.source
    for name in ("ground_truth", "odometry", "landmarks", "ranges"):
        np.testing.assert_array_equal(getattr(loaded, name), getattr(small, name), err_msg=name)
    _assert_same_data(load_cmu_text(folder / "Toy_DR.txt"), loaded)


def test_text_bad_lines_name_file_and_line(small: RangeDataset, tmp_path: Path) -> None:
    folder = _write_text_set(tmp_path / "toy", small)
    lines = (folder / "Toy_DR.txt").read_text().splitlines()
    two_numbers = "\t".join(lines[4].split()[:2])
    (folder / "Toy_DR.txt").write_text("\n".join(lines[:4] + [two_numbers] + lines[5:]) + "\n")
    with pytest.raises(
        DataError, match=r"Toy_DR\.txt line 5: expected 3 numbers \(time, distance, heading change\), got 2"
    ):
        load_cmu_text(folder)
    (folder / "Toy_DR.txt").write_text("\n".join(lines[:2] + ["1.0 x 2.0"] + lines[3:]) + "\n")
    with pytest.raises(
        DataError, match=r"Toy_DR\.txt line 3, column 2 \(distance\): 'x' is not a finite decimal number"
    ):
        load_cmu_text(folder)
    (folder / "Toy_DR.txt").write_text("")
    with pytest.raises(DataError, match=r"Toy_DR\.txt: the file holds no rows"):
        load_cmu_text(folder)


def test_text_truncated_last_line(small: RangeDataset, tmp_path: Path) -> None:
    folder = _write_text_set(tmp_path / "toy", small)
    td = (folder / "Toy_TD.txt").read_bytes()
    (folder / "Toy_TD.txt").write_bytes(td[: len(td) - 40])
    expected = rf"Toy_TD\.txt line {small.n_ranges}: the last line does not end with a newline"
    with pytest.raises(DataError, match=expected):
        load_cmu_text(folder)


def test_text_missing_files(small: RangeDataset, tmp_path: Path) -> None:
    folder = _write_text_set(tmp_path / "toy", small)
    (folder / "Toy_TD.txt").unlink()
    with pytest.raises(DataError, match=r"Toy_TD\.txt: no such file"):
        load_cmu_text(folder)
    with pytest.raises(DataError, match=r"no such folder"):
        load_cmu_text(tmp_path / "elsewhere")
    _write_text_set(tmp_path / "two", small, "A")
    _write_text_set(tmp_path / "two", small, "B")
    with pytest.raises(DataError, match=r"several \(A, B\)"):
        load_cmu_text(tmp_path / "two")
    assert load_cmu_text(tmp_path / "two", "B").name == "B"


def test_text_and_mat_copies_must_agree(small: RangeDataset, tmp_path: Path) -> None:
    folder = _write_text_set(tmp_path / "toy", small)
    td = np.array(small.ranges)
    td[3, 3] += 1.0
    _save_mat(folder / "Toy_.mat", GT=np.array(small.ground_truth), TL=np.array(small.landmarks), TD=td)
    with pytest.raises(DataError, match=r"Toy_\.mat: TD row 3 differs from .*Toy_TD\.txt line 4"):
        load_cmu_text(folder)


# ---------------------------------------------------------------------------------------------
# Finding data: load_dataset, default_data_dirs, gtsam_data_dir
# ---------------------------------------------------------------------------------------------


def test_load_dataset_names(paper_synthetic: RangeDataset, plaza: RangeDataset) -> None:
    _assert_same_data(load_dataset("synthetic", seed=5), generate_synthetic(seed=5))
    _assert_same_data(load_dataset("paper-synthetic"), paper_synthetic)
    loaded = load_dataset("plaza")
    _assert_same_data(loaded, plaza)
    assert loaded.name == "plaza"


def test_search_order_data_dir_then_env_then_gtsam(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each of the three places wins over the ones after it, and is used when those before lack the file."""
    sets = {
        where: generate_synthetic(n_steps=8 + i, n_landmarks=3, seed=i)
        for i, where in enumerate(("mine", "env", "gtsam"))
    }
    for where, ds in sets.items():
        (tmp_path / where).mkdir()
        _save_mat(tmp_path / where / SYN_FILE, **ds.to_cmu_arrays())
    monkeypatch.setattr(search, "gtsam_data_dir", lambda: tmp_path / "gtsam")
    monkeypatch.setenv(datasets.DATA_DIR_ENV, str(tmp_path / "env"))

    def n_poses(**kwargs: Path) -> int:
        return load_dataset("paper-synthetic", **kwargs).n_poses

    (tmp_path / "empty").mkdir()
    found = load_dataset("paper-synthetic", data_dir=tmp_path / "mine")
    assert found.n_poses == sets["mine"].n_poses
    # a file that is not the published one is read as the user's own, its source saying so after "; "
    assert found.source.split("; ")[0] == str((tmp_path / "mine" / SYN_FILE).resolve())
    assert found.name == "Syn_theta_Plaza (not the published paper-synthetic)"
    assert n_poses(data_dir=tmp_path / "empty") == sets["env"].n_poses  # data_dir lacks it: env next
    assert n_poses() == sets["env"].n_poses
    monkeypatch.delenv(datasets.DATA_DIR_ENV)
    assert n_poses() == sets["gtsam"].n_poses  # then the gtsam wheel's Data/
    (tmp_path / "gtsam" / SYN_FILE).unlink()
    with pytest.raises(DataError, match=r"Syn_theta_Plaza\.mat"):
        load_dataset("paper-synthetic")


def test_default_data_dirs_are_exactly_data_dir_env_gtsam(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """No folder relative to the working directory or the package, even when ../shared/data exists there."""
    fake_gtsam = tmp_path / "gtsam" / "Data"
    for folder in ("given", "env"):
        (tmp_path / folder).mkdir()
    monkeypatch.setattr(search, "gtsam_data_dir", lambda: fake_gtsam)
    monkeypatch.setenv(datasets.DATA_DIR_ENV, str(tmp_path / "env"))
    (tmp_path / "work" / "cwd").mkdir(parents=True)
    _decoy_shared(tmp_path / "work")
    monkeypatch.chdir(tmp_path / "work" / "cwd")
    expected = [tmp_path / "given", tmp_path / "env", fake_gtsam]
    assert default_data_dirs(tmp_path / "given") == [p.resolve() for p in expected]
    assert default_data_dirs() == [p.resolve() for p in expected[1:]]
    assert default_data_dirs(tmp_path / "env") == default_data_dirs()  # no duplicates
    monkeypatch.setenv(datasets.DATA_DIR_ENV, "")  # empty means unset
    assert default_data_dirs() == [fake_gtsam.resolve()]
    monkeypatch.setattr(search, "gtsam_data_dir", lambda: None)
    assert default_data_dirs() == []
    assert not hasattr(datasets, "_SHARED_DATA") and not hasattr(search, "_SHARED_DATA")


def test_fetched_files_come_after_env_and_before_gtsam(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The folder `steam-ref data fetch` fills is searched third, and only once it exists."""
    fake_gtsam = tmp_path / "gtsam" / "Data"
    (tmp_path / "env").mkdir()
    monkeypatch.setattr(search, "gtsam_data_dir", lambda: fake_gtsam)
    monkeypatch.setenv(datasets.DATA_DIR_ENV, str(tmp_path / "env"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert default_data_dirs() == [(tmp_path / "env").resolve(), fake_gtsam.resolve()]
    cache = tmp_path / "xdg" / "steam_ref" / "data"
    assert search.data_cache_dir() == cache
    cache.mkdir(parents=True)
    assert default_data_dirs() == [(tmp_path / "env").resolve(), cache.resolve(), fake_gtsam.resolve()]


def test_not_found_message_lists_where_it_looked(isolated: Path) -> None:
    given = isolated / "my_data"
    given.mkdir()
    with pytest.raises(DataError) as caught:
        load_dataset("plaza", data_dir=given)
    message = str(caught.value)
    assert "\n" not in message
    assert str(given.resolve()) in message
    assert "shared" not in message  # the decoy ../shared/data beside the cwd is not searched
    assert PLAZA_FILE in message and "pip install gtsam" in message
    assert "--data-dir" in message and "$STEAM_REF_DATA_DIR" in message  # where to put the file
    with pytest.raises(DataError, match=r"looked in: nowhere .*STEAM_REF_DATA_DIR unset.*--data-dir"):
        load_dataset("paper-synthetic")
    with pytest.raises(DataError, match=r"'plazza' \(not one of synthetic, paper-synthetic, plaza"):
        load_dataset("plazza", data_dir=given)


def test_every_search_that_finds_no_file_says_where_it_looked_and_how_to_fetch(isolated: Path) -> None:
    """The data sets', the authors' runs' and the conformance kit's paper files: one message, naming every folder
    searched and the fetch command (the kit's once named only two of the four places, and no command)."""
    from steam_ref.conformance.paper import _data_file
    from steam_ref.paper.fidelity import find_authors_file

    given = isolated / "my_data"
    given.mkdir()
    for look, fetch in (
        (lambda: load_dataset("plaza", data_dir=given), "plaza"),
        (lambda: find_authors_file("plaza", given), "authors-plaza"),
        (lambda: _data_file("plaza", given), "plaza"),
    ):
        with pytest.raises(DataError) as caught:
            look()
        message = str(caught.value)
        assert "\n" not in message and f"looked in: {given.resolve()}" in message
        assert f"`steam-ref data fetch {fetch}`" in message and "$STEAM_REF_DATA_DIR" in message


def test_load_dataset_paths(small: RangeDataset, tmp_path: Path, isolated: Path) -> None:
    path = _save_mat(tmp_path / "toy.mat", **small.to_cmu_arrays())
    _assert_same_data(load_dataset(path), small)
    _assert_same_data(load_dataset("toy.mat", data_dir=tmp_path), small)  # a bare name is searched for
    folder = _write_text_set(tmp_path / "text", small)
    assert np.array_equal(load_dataset(folder).ranges, small.ranges)


def test_gtsam_data_dir_never_raises(monkeypatch: pytest.MonkeyPatch) -> None:
    import importlib.util

    def broken(name: str) -> None:
        raise ValueError(f"{name}.__spec__ is None")

    monkeypatch.setattr(importlib.util, "find_spec", broken)
    assert gtsam_data_dir() is None
    monkeypatch.setattr(importlib.util, "find_spec", lambda name: None)
    assert gtsam_data_dir() is None


# ---------------------------------------------------------------------------------------------
# The synthetic generator
# ---------------------------------------------------------------------------------------------


def test_generator_default_size_is_the_papers() -> None:
    ds = generate_synthetic()
    assert (ds.n_poses, len(ds.odometry), ds.n_landmarks, ds.n_ranges) == (1501, 1500, 298, 1501)
    np.testing.assert_array_equal(ds.times, np.arange(1, 1502))
    np.testing.assert_array_equal(ds.ranges[:, 0], ds.times)  # one range per pose, at its time
    travel = np.hypot(*np.diff(ds.ground_truth[:, 1:3], axis=0).T).sum()
    assert 50 < travel < 600  # "about 0.2 km" (Table I); the default Qc's 10-90 % band is 0.11-0.30 km
    assert ds.source.startswith("generated(seed=0")


def test_generator_is_reproducible_per_seed() -> None:
    a, b, c = (generate_synthetic(n_steps=200, n_landmarks=40, seed=s) for s in (3, 3, 4))
    _assert_same_data(a, b)
    for name in FIELDS:
        assert not np.array_equal(getattr(a, name), getattr(c, name)), name


def test_generator_odometry_and_ranges_carry_the_stated_noise() -> None:
    n, sd, st, sr = 1500, 0.05, 0.03, 0.2
    ds = generate_synthetic(n_steps=n, seed=11, odometry_sigmas=(sd, st), range_sigma=sr)
    step = np.diff(ds.ground_truth[:, 1:3], axis=0)
    residuals = {
        "distance": (ds.odometry[:, 1] - np.hypot(step[:, 0], step[:, 1]), sd),
        "turn": (_wrap(ds.odometry[:, 2] - np.diff(ds.ground_truth[:, 3])), st),
        "range": (ds.ranges[:, 3] - _true_ranges_loop(ds, np.arange(ds.n_poses)), sr),
    }
    for name, (r, sigma) in residuals.items():
        # mean within 4 standard errors; sample std within 10 % (its own standard error is ~1.8 %)
        assert abs(r.mean()) < 4 * sigma / np.sqrt(len(r)), name
        assert abs(r.std() / sigma - 1) < 0.10, name


def test_generator_dead_reckoning_integrates_its_odometry() -> None:
    ds = generate_synthetic(n_steps=300, n_landmarks=60, seed=2)
    np.testing.assert_allclose(ds.dead_reckoning, _integrate_loop(ds.ground_truth[0], ds.odometry), rtol=0, atol=1e-9)


def test_generator_path_is_a_wnoa_sample_heading_along_velocity() -> None:
    qc = 1e-4
    ds = generate_synthetic(n_steps=1500, seed=5, qc=qc)
    p, th = ds.ground_truth[:, 1:3], ds.ground_truth[:, 3]
    step = np.diff(p, axis=0)
    # With θ_k the direction of the velocity at t_k, the sideways part of the next step is the
    # integrated acceleration noise alone: N(0, Qc/3) for dt = 1. [YIB Eq. 17]
    lateral = -np.sin(th[:-1]) * step[:, 0] + np.cos(th[:-1]) * step[:, 1]
    assert abs(lateral.std() / np.sqrt(qc / 3) - 1) < 0.10
    assert abs(lateral.mean()) < 4 * np.sqrt(qc / 3 / len(lateral))
    # Second differences of a WNOA path with dt = 1 have variance 2 Qc / 3 per axis.
    second = np.diff(p, n=2, axis=0)
    assert np.all(np.abs(second.var(axis=0) / (2 * qc / 3) - 1) < 0.2)


def test_generator_landmarks_and_who_is_ranged() -> None:
    n_poses, n = 601, 120
    ds = generate_synthetic(n_steps=n_poses - 1, n_landmarks=n, seed=9)
    p, marks = ds.ground_truth[:, 1:3], ds.landmarks
    dist = np.hypot(p[:, None, 0] - marks[None, :, 1], p[:, None, 1] - marks[None, :, 2])
    assert dist.min() >= 2.0 - 1e-12  # at least 2 m from every pose
    np.testing.assert_array_equal(ds.landmark_ids, np.arange(1, n + 1))
    ranged = ds.ranges[:, 2].astype(int)
    # Landmark j is placed by, and ranged at, pose (2j + 1) n_poses // (2n); elsewhere the
    # ranged landmark is one of the 10 nearest.
    anchors = {(2 * j + 1) * n_poses // (2 * n) for j in range(n)}
    assert len({ranged[k] for k in anchors}) == n
    for k, j in enumerate(ranged):
        if k not in anchors:
            assert np.sum(dist[k] < dist[k, j - 1]) < 10, f"pose {k}: landmark {j} is not 10 nearest"
    first_seen = [list(ranged).index(j) for j in range(1, n + 1)]  # ids follow first sighting
    assert first_seen == sorted(first_seen)


def test_generator_rejects_bad_arguments() -> None:
    with pytest.raises(SteamError, match=r"n_steps must be a positive integer, got 0"):
        generate_synthetic(n_steps=0)
    with pytest.raises(SteamError, match=r"range_sigma .* got -1"):
        generate_synthetic(range_sigma=-1.0)
    with pytest.raises(ShapeError, match=r"qc must be a scalar or \(2, 2\).*\(3, 3\)"):
        generate_synthetic(qc=np.eye(3))
    with pytest.raises(SteamError, match=r"landmark_distance"):
        generate_synthetic(landmark_distance=(5.0, 2.0))


def test_help_on_a_data_set_class_gives_its_tables_columns() -> None:
    """``help(sr.RangeDataset)`` and ``help(sr.LandmarkDataset)`` (what a user building one from their own arrays
    reads) name every table with its shape and columns; the layout was in the modules' docstrings only."""
    from steam_ref.datasets.landmarks import LANDMARK_COLUMNS

    range_doc = RangeDataset.__doc__ or ""
    for table, shape in [
        ("ground_truth", "(n_poses, 4)"),
        ("odometry", "(n_poses - 1, 3)"),
        ("dead_reckoning", "(n_poses, 4)"),
        ("landmarks", "(n_landmarks, 3)"),
        ("ranges", "(n_ranges, 4)"),
    ]:
        assert re.search(rf"^\s+{table}\s+\w+\s+{re.escape(shape)}\s+\S", range_doc, re.M), table
    landmark_doc = datasets.LandmarkDataset.__doc__ or ""
    for table, columns in LANDMARK_COLUMNS.items():
        row = re.search(rf"^\s+{table}\s+\(([^)]*)\)\s+(.*)$", landmark_doc, re.M)
        assert row is not None, table
        assert row.group(1).endswith(f", {len(columns)}"), (table, row.group(1))
