"""Bad set-ups, options and fits ("never silently wrong"): each refused where it enters,
with an error naming the argument and the value; the range correction's fit is checked; the
authors' saved covariances must be covariances; data folders that do not exist are named."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import scipy.io

from steam_ref import datasets
from steam_ref.datasets import RangeDataset, generate_synthetic, load_cmu_mat, load_dataset
from steam_ref.errors import DataError, ShapeError, SteamError
from steam_ref.paper.fidelity import load_authors_run
from steam_ref.paper.options import StreamOptions
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.problem import build_problem, sequential_batch
from steam_ref.paper.readings import RANGE_CORRECTION_SLOPES, Readings, range_correction

DATA = generate_synthetic(n_steps=40, n_landmarks=5, seed=1, range_sigma=0.1, landmark_distance=(2.0, 30.0))


def _with_ranges(data: RangeDataset, ranges: np.ndarray) -> RangeDataset:
    return RangeDataset("edited", data.ground_truth, data.odometry, data.dead_reckoning, data.landmarks, ranges)


# ---------------------------------------------------------------------------------------------
# PaperSetup and StreamOptions: checked where they enter
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("range_correction_steps", -3000),
        ("range_correction_steps", "3000"),
        ("range_sigma", 0.0),
        ("range_sigma", math.nan),
        ("range_sigma", -20.0),
        ("tukey_c", math.inf),
        ("tukey_c", 0),
        ("landmark_prior_sigma", -1.0),
        ("velocity_sigmas", [0.05, 0.01]),
        ("interpolated_velocity_sigmas", [0.5, 0.0, 0.02]),
        ("first_pose_sigmas", [1.0, math.nan, 3.0]),
        ("first_velocity", "zero"),
        ("landmarks_up_front", 1),
        ("pose2_heading_rate_guess", "yes"),
        ("relinearize_blocks", (3, 2)),
        ("relinearize_blocks", (6.0,)),
        ("name", ""),
    ],
)
def test_paper_setup_refuses_a_bad_field(field: str, value) -> None:
    shown = re.escape(repr(np.asarray(value).tolist() if isinstance(value, list) else value))
    # the message names the field and the value: "got VALUE" or, from steam_ref.arguments, "got PaperSetup.FIELD=VALUE"
    with pytest.raises(SteamError, match=rf"PaperSetup\.{field} must be .*, got (PaperSetup\.{field}=)?{shown}"):
        PaperSetup.plaza().replace(**{field: value})


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("every", math.nan),
        ("every", "3"),
        ("every", 0),
        ("final_updates", -1),
        ("final_updates", 2.5),
        ("final_updates", True),
        ("start_after_ranges", -50),
        ("start_after_ranges", None),
        ("initial_batch", 1),
        ("initial_batch_tolerance", 0.0),
        ("initial_batch_tolerance", math.nan),
    ],
)
def test_schedule_refuses_a_bad_field(field: str, value) -> None:
    shown = re.escape(repr(value))
    with pytest.raises(SteamError, match=rf"Schedule\.{field} must be .*, got (Schedule\.{field}=)?{shown}"):
        PaperSetup.plaza().with_schedule(**{field: value})


def test_paper_setup_qc_is_checked() -> None:
    with pytest.raises(
        ShapeError, match=r"PaperSetup\.qc must be a \(3, 3\) matrix.*got \[\[1\.0, 0\.0\], \[0\.0, 1\.0\]\]"
    ):
        PaperSetup.plaza().replace(qc=np.eye(2))
    with pytest.raises(SteamError, match=r"Qc must be symmetric positive definite"):
        PaperSetup.plaza().replace(qc=-np.eye(3))
    setup = PaperSetup.plaza().replace(tukey_c=None, first_velocity=[0, 0, 0])  # both allowed
    assert setup.range_loss is None and setup.first_velocity.tolist() == [0.0, 0.0, 0.0]


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("max_poses", 1),
        ("max_poses", 2.5),
        ("pb_max_iterations", 0),
        ("time_budget_s", True),
        ("time_budget_s", math.nan),
        ("time_budget_s", -1.0),
        ("pb_relative_tolerance", None),
        ("pb_relative_tolerance", math.inf),
        ("interpolate", 1),
        ("range_states", "no"),
        ("progress", None),
        ("converge_at_end", 1),
    ],
)
def test_stream_options_refuse_a_bad_field(field: str, value) -> None:
    with pytest.raises(SteamError, match=rf"{field} must be .*, got ({field}=)?{re.escape(repr(value))}"):
        StreamOptions(**{field: value})


def test_unknown_fields_are_named() -> None:
    with pytest.raises(SteamError, match=r"StreamOptions has no field 'evry'"):
        StreamOptions().replace(evry=10)
    with pytest.raises(SteamError, match=r"PaperSetup has no field 'range_correction'"):
        PaperSetup.plaza().replace(range_correction=0)


@pytest.mark.parametrize(("field", "value"), [("chunk", 0), ("chunk", -100), ("final_iterations", 0), ("chunk", 2.0)])
def test_sequential_batch_refuses_bad_counts(field: str, value) -> None:
    problem = build_problem(generate_synthetic(n_steps=5, n_landmarks=2, seed=0), PaperSetup.synthetic())
    with pytest.raises(SteamError, match=rf"{field} must be a positive integer, got {re.escape(repr(value))}"):
        sequential_batch(problem, **{field: value})


# ---------------------------------------------------------------------------------------------
# The range correction's fit
# ---------------------------------------------------------------------------------------------


def test_a_clean_fit_is_near_one_and_passes() -> None:
    a, b = range_correction(DATA, 40)
    assert RANGE_CORRECTION_SLOPES == (0.5, 2.0)
    assert abs(a - 1) < 0.1 and abs(b) < 0.5


def test_one_absurd_range_is_refused_naming_the_fit_and_the_reading() -> None:
    ranges = np.array(DATA.ranges)
    ranges[7, 3] = 1e6
    bad = _with_ranges(DATA, ranges)
    expected = (
        r"range correction over the first 40 poses: the least-squares fit r' = a r \+ b has slope a = -?[0-9.e-]+, "
        r"offset b = [0-9.e-]+ over 40 readings; a slope outside \[0\.5, 2\] .*ranges row 7, 1000000\.0 m"
    )
    with pytest.raises(DataError, match=expected):
        range_correction(bad, 40)
    with pytest.raises(DataError, match=r"ranges row 7, 1000000\.0 m"):  # the way a run meets it
        Readings.from_dataset(bad, PaperSetup.plaza().replace(range_correction_steps=40))


def test_readings_that_cannot_fix_a_slope() -> None:
    ranges = np.array(DATA.ranges)
    ranges[:, 3] = 4.0
    with pytest.raises(DataError, match=r"all 40 readings are 4\.0 m, which cannot fix a slope"):
        range_correction(_with_ranges(DATA, ranges), 40)
    with pytest.raises(DataError, match=r"needs at least 2 readings in its window, got 1"):
        range_correction(DATA, 1)


def test_a_corrected_range_below_zero_is_refused() -> None:
    """Readings fitting r' = 1.5 r - 10 exactly over the first 20 poses; a later 1 m reading would
    become -8.5 m."""
    truth = np.hypot(*(DATA.ground_truth[:, 1:3] - DATA.landmarks[DATA.landmark_rows(DATA.ranges[:, 2]), 1:3]).T)
    ranges = np.array(DATA.ranges)
    ranges[:, 3] = (truth + 10) / 1.5
    ranges[30, 3] = 1.0
    setup = PaperSetup.plaza().replace(range_correction_steps=20)
    with pytest.raises(
        DataError,
        match=(
            r"ranges row 30: 1\.0 m corrected to 1\.(5|49)\d* r \+ -(10\.0|9\.9)\d* = -8\.(5|49)\d* m, "
            "a negative range"
        ),
    ):
        Readings.from_dataset(_with_ranges(DATA, ranges), setup)


def test_plaza_with_one_absurd_range(shared_data: Path) -> None:
    """The finding: one 1e6 m range in Plaza's window made the slope negative and every corrected
    range about 3.5 m. The clean file's fit is untouched."""
    plaza = load_cmu_mat(shared_data / "Plaza1_thrown_away_some_range.mat")
    a, b = range_correction(plaza, 3000)
    assert a == pytest.approx(0.934999, abs=1e-6) and b == pytest.approx(-0.016448, abs=1e-6)
    ranges = np.array(plaza.ranges)
    ranges[10, 3] = 1e6
    with pytest.raises(
        DataError, match=r"slope a = -8\.4\d*e-06, offset b = 41\.2\d* over 1092 readings.*ranges row 10, 1000000\.0 m"
    ):
        range_correction(_with_ranges(plaza, ranges), 3000)


# ---------------------------------------------------------------------------------------------
# The synthetic generator and the data search path
# ---------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (dict(seed=-1), r"seed must be an integer >= 0, got -1"),
        (dict(seed=1.5), r"seed .* got 1\.5"),
        (dict(seed=True), r"seed .* got True"),
        (dict(n_steps=math.nan), r"n_steps must be a positive integer, got nan"),
        (dict(n_steps=math.inf), r"n_steps .* got inf"),
        (dict(n_landmarks=0), r"n_landmarks .* got 0"),
        (dict(range_sigma="1"), r"range_sigma .* got '1'"),
        (dict(landmark_distance=(1, "b")), r"landmark_distance"),
        (dict(odometry_sigmas="x"), r"odometry_sigmas .* got 'x'"),
        (dict(n_nearest=2.5), r"n_nearest .* got 2\.5"),
    ],
)
def test_generator_refuses_bad_arguments(kwargs, message) -> None:
    with pytest.raises(SteamError, match=message):
        generate_synthetic(**{"n_steps": 5, "n_landmarks": 2, **kwargs})


def test_generator_never_writes_a_negative_range() -> None:
    """With 3 m of range noise and landmarks 2-5 m away, raw draws go negative: they are drawn again."""
    data = generate_synthetic(n_steps=300, n_landmarks=30, seed=0, range_sigma=3.0)
    truth = np.hypot(*(data.ground_truth[:, 1:3] - data.landmarks[data.landmark_rows(data.ranges[:, 2]), 1:3]).T)
    assert np.any(truth < 3.0 * 2) and np.all(data.ranges[:, 3] >= 0)


def test_data_folders_that_are_not_there(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "a_file").write_text("x")
    with pytest.raises(DataError, match=r"the data set name is empty"):
        load_dataset("")
    with pytest.raises(
        DataError, match=rf"data_dir \(--data-dir\) '{re.escape(str(tmp_path / 'nowhere'))}' does not exist"
    ):
        load_dataset("synthetic", data_dir=tmp_path / "nowhere")
    with pytest.raises(DataError, match=r"'.*a_file' is not a folder"):
        load_dataset("paper-synthetic", data_dir=tmp_path / "a_file")
    with pytest.raises(DataError, match=r"data_dir \(--data-dir\) is empty"):
        load_dataset("plaza", data_dir="")
    (tmp_path / "Syn_theta_Plaza.mat").mkdir()  # a folder where the file should be is not passed over
    with pytest.raises(DataError, match=r"Syn_theta_Plaza\.mat: not a file"):
        load_dataset("paper-synthetic", data_dir=tmp_path)
    (tmp_path / "authors" / "Plaza1_full_data_run.mat").mkdir(parents=True)
    with pytest.raises(DataError, match=r"authors/Plaza1_full_data_run\.mat: not a file"):
        load_authors_run("plaza", SMALL, tmp_path)
    monkeypatch.setenv(datasets.DATA_DIR_ENV, str(tmp_path / "typo"))
    with pytest.raises(DataError, match=r"\$STEAM_REF_DATA_DIR '.*typo' does not exist"):
        load_dataset("plaza")


# ---------------------------------------------------------------------------------------------
# The authors' saved runs: covariances must be covariances
# ---------------------------------------------------------------------------------------------

SMALL = generate_synthetic(n_steps=6, n_landmarks=2, seed=4)


def _authors_run(folder: Path, **changes) -> Path:
    """A saved run of SMALL in the authors' layout, as authors/Plaza1_full_data_run.mat in ``folder``."""
    n, rng = SMALL.n_poses, np.random.default_rng(0)
    xyt = SMALL.ground_truth[:, 1:4] + 0.01 * rng.standard_normal((n, 3))

    def spd(d: int) -> np.ndarray:
        m = rng.standard_normal((d, d))
        return m @ m.T + d * np.eye(d)

    state = np.empty((n, 2), dtype=object)
    for k in range(n):
        state[k, 0], state[k, 1] = spd(3), spd(3)
    marks = np.empty((SMALL.n_landmarks, 1), dtype=object)
    for k in range(SMALL.n_landmarks):
        marks[k, 0] = spd(2)
    run = dict(
        estStateInds=np.arange(n).reshape(-1, 1),
        XYT=xyt,
        XYT_dot=np.zeros((n, 3)),
        XY=SMALL.landmarks[:, 1:3],
        diff=SMALL.ground_truth[:, 1:3] - xyt[:, :2],
        step_t=np.ones((n - 1, 2)),
        stateMarginal=state,
        landmarkMarginal=marks,
    )
    for key, edit in changes.items():
        run[key] = edit(run[key])
    (folder / "authors").mkdir(parents=True, exist_ok=True)
    path = folder / "authors" / "Plaza1_full_data_run.mat"
    scipy.io.savemat(path, run)
    return path


def _edit_cell(row: int, column: int, change):
    def edit(cells: np.ndarray) -> np.ndarray:
        cells = cells.copy()
        cells[row, column] = change(np.array(cells[row, column]))
        return cells

    return edit


def test_a_valid_saved_run_loads(tmp_path: Path) -> None:
    path = _authors_run(tmp_path)
    run = load_authors_run("plaza", SMALL, tmp_path)
    assert run.source == path and run.pose_covariance.shape == (SMALL.n_poses, 3, 3)
    np.testing.assert_array_equal(run.pose_covariance, np.transpose(run.pose_covariance, (0, 2, 1)))


def _skew(c: np.ndarray) -> np.ndarray:
    c[0, 1] += 0.5
    return c


def _negative(c: np.ndarray) -> np.ndarray:
    return -c


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        (dict(stateMarginal=_edit_cell(2, 0, _skew)), r"stateMarginal pose 2 is not symmetric"),
        (dict(stateMarginal=_edit_cell(4, 1, _skew)), r"stateMarginal velocity 4 is not symmetric"),
        (dict(landmarkMarginal=_edit_cell(1, 0, _skew)), r"landmarkMarginal 1 is not symmetric"),
        (dict(stateMarginal=_edit_cell(3, 0, _negative)), r"stateMarginal pose 3 is not positive definite"),
        (
            dict(stateMarginal=_edit_cell(0, 1, lambda c: c[:2, :2])),
            r"stateMarginal velocity 0 must be a finite 3x3 matrix",
        ),
        (dict(landmarkMarginal=_edit_cell(0, 0, lambda c: c * np.nan)), r"landmarkMarginal 0 must be a finite 2x2"),
        (dict(XYT_dot=lambda a: a * np.nan), r"XYT_dot\[0, 0\] is nan"),
        (dict(XYT=lambda a: a[:, :2]), r"XYT has shape \(7, 2\), expected \(7, 3\)"),
        (dict(estStateInds=lambda a: a + 0.5), r"estStateInds must be increasing pose indices"),
        (dict(stateMarginal=lambda a: a[:-1]), r"stateMarginal has shape \(6, 2\)"),
    ],
    ids=[
        "pose-skew",
        "velocity-skew",
        "landmark-skew",
        "not-pd",
        "2x2",
        "nan-cov",
        "nan",
        "columns",
        "fractional",
        "rows",
    ],
)
def test_a_bad_saved_run_is_refused(tmp_path: Path, changes, message) -> None:
    path = _authors_run(tmp_path, **changes)
    with pytest.raises(DataError, match=rf"{re.escape(str(path))}: {message}"):
        load_authors_run("plaza", SMALL, tmp_path)
