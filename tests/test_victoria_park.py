"""Victoria Park and landmark data sets: the GTSAM text loader against ``gtsam.load2D`` and hand-parsed
rows, the checks of :class:`LandmarkDataset`, the front end on bearing-range readings (unsurveyed
landmarks placed by their first sighting), and a short prefix streamed by BTGP reaching the batch
optimum. Plaza2 by name. Oracles: gtsam's own loader and Pose2, formulas written out here, the
stationarity check of the batch solve."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from requirements import optional_import, skip_or_fail

from steam_ref.bayes_tree import ISAM2Params
from steam_ref.cli.commands import main
from steam_ref.datasets import LandmarkDataset, gtsam_data_dir, load_dataset, load_gtsam_2d
from steam_ref.errors import DataError, SteamError
from steam_ref.factors import BearingRangeFactor, InterpolatedFactor, PriorFactor
from steam_ref.paper.converge import rotated
from steam_ref.paper.experiments import Experiment, interpolation_experiment, results_table, timing_experiment
from steam_ref.paper.frontend import FrontEnd, Layout
from steam_ref.paper.online import StreamingEstimator
from steam_ref.paper.options import StreamOptions
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.problem import build_problem, converged_batch, score_estimate
from steam_ref.paper.readings import Readings
from steam_ref.variables import L, X

VP = PaperSetup.victoria_park()


def _gtsam_file(name: str) -> Path:
    """A file of the installed gtsam's Data/ folder; skip (or fail when optional packages are required) without it."""
    optional_import("gtsam", "gtsam")
    folder = gtsam_data_dir()
    if folder is None or not (folder / name).is_file():
        skip_or_fail(f"gtsam's Data/ folder has no {name}; pip install gtsam", "optional")
    return folder / name


@pytest.fixture(scope="module")
def victoria() -> LandmarkDataset:
    return load_gtsam_2d(_gtsam_file("victoria_park.txt"), name="victoria-park")


@pytest.fixture(scope="module")
def prefix_problem(victoria):
    """The first 300 poses of Victoria Park with the authors' set-up, and its converged batch optimum."""
    readings = Readings.from_dataset(victoria, VP).prefix(300)
    problem = build_problem(readings, VP)
    return readings, problem, converged_batch(problem)


# --- the loader -------------------------------------------------------------------------------


def test_the_file_has_the_documented_sizes(victoria):
    assert (victoria.n_poses, len(victoria.odometry), len(victoria.bearing_ranges), victoria.n_landmarks) == (
        6969,
        6968,
        3640,
        151,
    )
    np.testing.assert_array_equal(victoria.times, np.arange(6969.0))  # time = pose index
    assert (
        len(victoria.ranges) == len(victoria.bearings) == len(victoria.landmarks) == 0 and victoria.ground_truth is None
    )


def test_loader_equals_gtsam_load2d(victoria):
    """Every ODOMETRY row as gtsam's BetweenFactorPose2, every sighting as its BearingRangeFactor2D: the
    measured bearing and range and the noise sigmas, and which pose and landmark, in file order."""
    gtsam = optional_import("gtsam", "gtsam")
    graph, _ = gtsam.load2D(str(_gtsam_file("victoria_park.txt")))
    pose_id = victoria.poses[:, 1].astype(int)
    between, sightings = [], []
    for k in range(graph.size()):
        f = graph.at(k)
        (between if isinstance(f, gtsam.BetweenFactorPose2) else sightings).append(f)
    assert len(between) == 6968 and len(sightings) == 3640
    for k, f in enumerate(between):
        m = f.measured()
        assert list(f.keys()) == [pose_id[k], pose_id[k + 1]]
        np.testing.assert_allclose(
            victoria.odometry[k, 1:], [m.x(), m.y(), m.theta()], rtol=1e-15, atol=0
        )  # θ: Rot2 round trip
        np.testing.assert_allclose(np.sqrt(np.diag(victoria.covariance(k))), f.noiseModel().sigmas(), rtol=1e-15)
    for k, f in enumerate(sightings):
        m, (pose_key, mark_key) = f.measured(), f.keys()
        row = victoria.bearing_ranges[k]
        assert pose_key == pose_id[int(row[0])]
        assert gtsam.Symbol(mark_key).chr() == ord("l") and gtsam.Symbol(mark_key).index() == int(row[1])
        np.testing.assert_allclose(row[2:4], [m.bearing().theta(), m.range()], rtol=0, atol=1e-14)
        np.testing.assert_allclose(row[4:6], f.noiseModel().sigmas(), rtol=1e-15)


def test_loader_on_hand_parsed_rows(tmp_path):
    """A small file in GTSAM's format, its rows worked out here: pose ids skip the landmark's (5),
    times are pose indices, a sighting at (3, -4) is bearing atan2(-4, 3), range 5, sigmas sqrt(v/10), sqrt(v)."""
    path = tmp_path / "toy.txt"
    path.write_text(
        "ODOMETRY 0 1 1.0 0.5 0.1 0.0001 0 0 4e-06 0 4e-06\n"
        "LANDMARK 1 5 3.0 -4.0 0.9 0 0.9\n"
        "\n"
        "ODOMETRY 1 6 2.0 0.0 -0.2 0.01 0.001 0 0.02 0 0.03\n"
        "LANDMARK 6 5 -1.0 0.0 0.4 0 0.4\n"
        "LANDMARK 6 7 0.0 2.0 0.4 0 0.4\n"
    )
    ds = load_gtsam_2d(path)
    np.testing.assert_array_equal(ds.poses, [[0, 0], [1, 1], [2, 6]])
    np.testing.assert_array_equal(ds.odometry, [[1, 1.0, 0.5, 0.1], [2, 2.0, 0.0, -0.2]])
    np.testing.assert_array_equal(ds.covariance(1), [[0.01, 0.001, 0], [0.001, 0.02, 0], [0, 0, 0.03]])
    expected = [
        [1, 5, math.atan2(-4, 3), 5.0, math.sqrt(0.09), math.sqrt(0.9)],
        [2, 5, math.pi, 1.0, math.sqrt(0.04), math.sqrt(0.4)],
        [2, 7, math.pi / 2, 2.0, math.sqrt(0.04), math.sqrt(0.4)],
    ]
    np.testing.assert_allclose(ds.bearing_ranges, expected, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(ds.landmark_ids, [5, 7])  # in the order of first sighting
    # dead reckoning composes Pose2(dx, dy, dθ) from zero: pose 2 = (1, 0.5, 0.1) ⊕ (2, 0, -0.2)
    np.testing.assert_allclose(
        ds.dead_reckoning[2], [2, 1 + 2 * math.cos(0.1), 0.5 + 2 * math.sin(0.1), -0.1], atol=1e-15
    )
    assert load_dataset(str(path)).bearing_ranges.shape == (3, 6)  # a .txt path goes to this loader


BAD_FILES = {
    "a word for a number": (
        "ODOMETRY 0 1 1.0 x 0.1 1 0 0 1 0 1\n",
        r"line 1, field 5: 'x' is not a finite decimal number",
    ),
    "nan": ("ODOMETRY 0 1 1.0 nan 0.1 1 0 0 1 0 1\n", r"line 1, field 5: 'nan'"),
    "a short row": (
        "ODOMETRY 0 1 1.0 0.0 0.1 1 0 0 1 0 1\nLANDMARK 1 5 3.0 -4.0 0.9 0\n",
        r"line 2: a LANDMARK row has 7 numbers",
    ),
    "an unknown pose": (
        "ODOMETRY 0 1 1.0 0.0 0.1 1 0 0 1 0 1\nLANDMARK 4 5 3.0 -4.0 0.9 0 0.9\n",
        r"line 2: LANDMARK seen from pose id 4, .*unknown pose id",
    ),
    "a broken chain": (
        "ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\nODOMETRY 2 3 1 0 0 1 0 0 1 0 1\n",
        r"line 2: ODOMETRY from pose id 2, but the odometry so far ends at pose id 1",
    ),
    "a landmark id used by a pose": (
        "ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\nLANDMARK 1 0 3.0 -4.0 0.9 0 0.9\n",
        r"line 2: LANDMARK id 0 is also a pose id",
    ),
    "an unknown row type": ("ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\nVERTEX2 1 0 0 0\n", r"line 2: unknown row type 'VERTEX2'"),
    "an anisotropic sighting": (
        "ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\nLANDMARK 1 5 3.0 -4.0 0.9 0 0.5\n",
        r"line 2: LANDMARK covariance .* is not v·I",
    ),
    "a sighting at range 0": (
        "ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\nLANDMARK 1 5 0 0 0.9 0 0.9\n",
        r"line 2: LANDMARK 5 seen at range 0",
    ),
    "no final newline": ("ODOMETRY 0 1 1 0 0 1 0 0 1 0 1", r"line 1: the last line does not end with a newline"),
    "a singular odometry covariance": (
        "ODOMETRY 0 1 1 0 0 1 0 0 1 0 0\n",
        r"odometry_covariance row 0 .* is not positive definite",
    ),
}


@pytest.mark.parametrize("case", sorted(BAD_FILES))
def test_a_bad_file_names_the_file_and_line(tmp_path, case):
    text, message = BAD_FILES[case]
    path = tmp_path / "bad.txt"
    path.write_text(text)
    with pytest.raises(DataError, match=message) as err:
        load_gtsam_2d(path)
    assert str(path) in str(err.value)


# --- LandmarkDataset's checks -------------------------------------------------------------------


def _toy(**changes) -> LandmarkDataset:
    """Three poses at t = 0, 1, 2, one range, one bearing, one bearing-range; landmarks 3 (surveyed) and 4."""
    fields = dict(
        name="toy",
        poses=[[0, 0], [1, 1], [2, 2]],
        odometry=[[1, 1, 0, 0], [2, 1, 0, 0.5]],
        odometry_covariance=np.tile([1, 0, 0, 1, 0, 1], (2, 1)),
        ranges=[[1, 3, 2.0, 0.5]],
        bearings=[[1, 4, 0.3, 0.1]],
        bearing_ranges=[[2, 4, 0.2, 4.0, 0.1, 0.5]],
        landmark_ids=[3, 4],
        landmarks=[[3, 2.0, 1.0]],
    )
    return LandmarkDataset(**(fields | changes))


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        (dict(ranges=[[1, 3, -2.0, 0.5]]), r"ranges\[0, 2\] \(range\) = -2.0 at t=1.0 is negative"),
        (dict(bearing_ranges=[[2, 4, 0.2, -4.0, 0.1, 0.5]]), r"bearing_ranges\[0, 3\] \(range\) = -4.0 .* is negative"),
        (
            dict(bearings=[[1, 9, 0.3, 0.1]]),
            r"bearings row 0 \(t=1.0\) names landmark id 9, which is not in landmark_ids \(\[3, 4\]\)",
        ),
        (dict(ranges=[[1, 3, np.nan, 0.5]]), r"ranges\[0, 2\] \(range\) is nan: every value must be finite"),
        (
            dict(bearing_ranges=[[2, 4, 0.2, 4.0, 0.0, 0.5]]),
            r"bearing_ranges\[0, 4\] \(sigma bearing\) = 0.0: a sigma must be > 0",
        ),
        (dict(ranges=[[1.5, 3, 2.0, 0.5]]), r"ranges row 0 has t=1.5, which is no pose's time"),
        (
            dict(bearing_ranges=[[2, 4, 0.2, 4.0, 0.1, 0.5], [1, 4, 0.2, 4.0, 0.1, 0.5]]),
            r"bearing_ranges times must not go back: bearing_ranges row 1",
        ),
        (dict(poses=[[0, 0], [2, 1], [1, 2]]), r"pose times must increase strictly: poses row 2"),
        (dict(poses=[[0, 0], [1, 1], [2, 1]]), r"id 1 appears twice in poses"),
        (dict(odometry=[[1, 1, 0, 0], [3, 1, 0, 0.5]]), r"odometry row 1 has t=3.0 but pose 2 has t=2.0"),
        (dict(landmarks=[[8, 2.0, 1.0]]), r"landmarks row 0 surveys landmark id 8, which is not in landmark_ids"),
        (dict(ground_truth=np.zeros((2, 4))), r"ground_truth has 2 rows but poses has 3"),
    ],
)
def test_bad_tables_name_table_row_and_value(changes, message):
    with pytest.raises(DataError, match=message):
        _toy(**changes)


def test_readings_of_a_landmark_dataset():
    ds = _toy()
    r = Readings.from_dataset(ds, VP)
    np.testing.assert_array_equal(r.velocity[1:], [[1, 0, 0], [1, 0, 0.5]])  # [dx, dy, dθ] / dt, dt = 1
    assert r.range_pose.tolist() == [1] and r.range_sigma.tolist() == [0.5]
    assert r.bearings.pose.tolist() == [1] and r.bearing_ranges.pose.tolist() == [2]
    np.testing.assert_array_equal(r.bearing_ranges.value, [[0.2, 4.0]])
    assert list(r.landmarks) == [3] and r.n_landmark_readings == 3
    short = r.prefix(2)
    assert short.n_poses == 2 and short.n_landmark_readings == 2


# --- the front end ---------------------------------------------------------------------------------


def test_an_unsurveyed_landmark_is_placed_by_its_first_sighting_with_no_prior(victoria):
    """Pose 4 is the first with a sighting (tree 5): the front end composes poses 1-4 from the odometry
    (Pose2 composition, checked with gtsam.Pose2) and puts the tree at pose 4 ⊕ (r cos b, r sin b)."""
    gtsam = optional_import("gtsam", "gtsam")
    front = FrontEnd(Readings.from_dataset(victoria, VP), VP)
    steps = [front.step() for _ in range(5)]
    pose = gtsam.Pose2()
    for k in range(4):
        pose = pose.compose(gtsam.Pose2(*victoria.odometry[k, 1:]))
    np.testing.assert_allclose(steps[4].values[X(4)][:3], [pose.x(), pose.y(), pose.theta()], atol=1e-14)
    bearing, distance = victoria.bearing_ranges[0, 2:4]
    expected = pose.transformFrom(np.array([distance * np.cos(bearing), distance * np.sin(bearing)]))
    np.testing.assert_allclose(steps[4].values[L(5)], expected, atol=1e-13)
    factors = steps[4].factors
    (br,) = [f for f in factors if isinstance(f, BearingRangeFactor)]
    assert br.keys == (X(4), L(5)) and br.state_dim == 6
    np.testing.assert_allclose(br.sqrt_information, np.diag(1 / victoria.bearing_ranges[0, 4:6]))
    assert not any(isinstance(f, PriorFactor) and f.keys == (L(5),) for s in steps for f in s.factors)
    assert steps[4].n_landmark_readings == 1


def test_a_range_alone_cannot_place_an_unsurveyed_landmark():
    ds = _toy(ranges=[[1, 4, 2.0, 0.5]], bearings=np.zeros((0, 4)))  # landmark 4 is ranged before its bearing-range
    front = FrontEnd(Readings.from_dataset(ds, VP), VP)
    front.step()
    with pytest.raises(
        SteamError, match="landmark 4 is not surveyed and its first reading is a range or a bearing alone"
    ):
        front.step()


def test_readings_between_states_are_interpolated_bearing_ranges(victoria):
    readings = Readings.from_dataset(victoria, VP).prefix(60)
    problem = build_problem(readings, VP, Layout(skip=5))
    inner = [f.inner for f in problem.graph if isinstance(f, InterpolatedFactor)]
    between = int(np.sum((readings.bearing_ranges.pose % 5 != 0) & (readings.bearing_ranges.pose != 59)))
    assert sum(isinstance(f, BearingRangeFactor) for f in inner) == between > 0


# --- streamed against batch ---------------------------------------------------------------------------


def test_the_batch_optimum_is_stationary_and_fixed_along_the_rotation(prefix_problem):
    """The reference: stationary by the batch's own check, and turning it about the origin only raises the cost."""
    _, problem, best = prefix_problem
    assert best.converged, best.reason
    cost = problem.graph.error(best.values)
    for angle in (-1e-3, 1e-3):
        assert problem.graph.error(rotated(best.values, angle)) > cost


ZERO = ISAM2Params(
    relinearize_threshold=0.0, relinearize_skip=1, wildfire_threshold=0.0
)  # every update a Gauss-Newton step


def _stream(readings, setup, final_updates):
    setup = setup.with_schedule(every=10, final_updates=final_updates).replace(isam2=ZERO)
    est = StreamingEstimator(readings, setup, StreamOptions())
    while not est.done:
        est.step()
    return est.solver.estimate()


def _xy(values, n):
    return np.array([values[X(i)][:2] for i in range(n)])


def test_the_batch_descent_turns_a_turned_start_back(prefix_problem):
    """From the optimum turned by 0.2 rad, Gauss-Newton alone would take thousands of steps back (a
    thousandth of the way each); with the line search over the rotation the descent returns to it."""
    _, problem, best = prefix_problem
    again = converged_batch(problem, start=rotated(best.values, 0.2))
    assert again.converged
    n = problem.readings.n_poses
    np.testing.assert_allclose(_xy(again.values, n), _xy(best.values, n), rtol=0, atol=1e-3)


def test_btgp_with_zero_thresholds_reaches_the_batch_optimum(prefix_problem):
    """BTGP/10 on 300 poses, every variable relinearized at every update, then 100 updates with nothing
    new (Gauss-Newton steps): within 0.1 mm of the converged batch optimum at every pose. The heading of
    pose 0 is pinned (σ = 1e-4 rad): with the scripts' σ = π see the next test."""
    readings = prefix_problem[0]
    pinned = VP.replace(first_pose_sigmas=np.array([1.0, 1.0, 1e-4]))
    reference = converged_batch(build_problem(readings, pinned))
    assert reference.converged, reference.reason
    n = readings.n_poses
    np.testing.assert_allclose(_xy(_stream(readings, pinned, 100), n), _xy(reference.values, n), rtol=0, atol=1e-4)


def test_with_the_scripts_heading_prior_btgp_stops_a_rotation_away_from_the_optimum(prefix_problem):
    """With the scripts' prior (heading of pose 0 σ = π) nothing but that prior fixes the map's
    orientation, and each Gauss-Newton step turns the map a thousandth of the way to the optimum
    (docs/experiments.md, Victoria Park): the same stream ends ~0.09 rad (metres) away, yet within
    1 cm of it once turned about the origin, at a cost 1e-3 above the optimum's."""
    readings, problem, best = prefix_problem
    ours = _stream(readings, VP, 5)
    n = readings.n_poses
    a, b = _xy(ours, n), _xy(best.values, n)
    angle = np.arctan2(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]), np.sum(a * b))
    assert 0.01 < abs(angle) < 0.2 and np.max(np.hypot(*(a - b).T)) > 1.0
    assert np.max(np.hypot(*(_xy(rotated(ours, angle), n) - b).T)) < 1e-2
    assert 0 < problem.graph.error(ours) - problem.graph.error(best.values) < 1e-3


# --- Plaza2 ------------------------------------------------------------------------------------------


def test_plaza2_loads_by_name_and_runs_with_the_plaza_preset():
    _gtsam_file("Plaza2_.mat")
    ds = load_dataset("plaza2")
    assert (ds.name, ds.n_poses, len(ds.odometry), ds.n_landmarks, ds.n_ranges) == ("plaza2", 4091, 4090, 4, 1816)
    readings = Readings.from_dataset(ds, PaperSetup.plaza())
    a, b = readings.range_correction
    assert 0.5 < a < 2 and abs(b) < 5  # fitted on Plaza2's own ground truth
    est = StreamingEstimator(readings, PaperSetup.plaza().with_schedule(every=10), StreamOptions(max_poses=400))
    while not est.done:
        est.step()
    assert est.n_solved > 0


# --- scoring, the CLI and the experiments -------------------------------------------------------------


def test_a_turned_estimate_scores_its_turn_and_nothing_else(prefix_problem):
    """The optimum turned by 0.01 rad about the origin: the score finds the turn, the raw distance is the
    chord 2 sin(0.005) |p| at each pose, and once turned back nothing is left."""
    _, problem, best = prefix_problem
    score = score_estimate(problem, best, rotated(best.values, 0.01))
    xy = np.array([best.values[X(int(i))][:2] for i in problem.states])
    np.testing.assert_allclose(score.distance, 2 * np.sin(0.005) * np.hypot(*xy.T), rtol=1e-9, atol=1e-12)
    assert score.rotation == pytest.approx(-0.01, abs=1e-12)
    assert np.max(score.distance_unrotated) < 1e-9 and score.cost_gap > 0


def test_cli_runs_victoria_park_and_scores_it_against_the_batch(capsys, tmp_path):
    _gtsam_file("victoria_park.txt")
    plot = tmp_path / "vp.png"
    code = main(["run", "--dataset", "victoria-park", "--max-poses", "150", "--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    row = json.loads(out)  # without the flag: no silent batch solves, and the JSON says so
    assert row["score_against_optimum"] is False and "batch_converged" not in row and "ground truth" in row["score"]
    argv = ["run", "--dataset", "victoria-park", "--max-poses", "150", "--score-against-optimum", "--json"]
    code = main([*argv, "--plot", str(plot)])
    out, err = capsys.readouterr()
    assert code == 0, err
    row = json.loads(out)
    assert row["every"] == 10 and row["rmse_m"] is None and row["batch_converged"] is True
    assert row["score_against_optimum"] is True
    assert (
        row["batch_distance_unrotated_median_m"] >= 0
        and 0 <= row["batch_distance_median_m"] <= row["batch_distance_max_m"]
    )
    assert row["n_updates"] > 0
    assert plot.stat().st_size > 10_000


def test_cli_converge_at_end_lands_on_the_batch_optimum(capsys):
    """``--converge-at-end``: the run's estimate is the optimum the score is taken against (to 0.1 mm:
    two descents into one minimum differ by their tolerance), and the JSON line says it converged."""
    _gtsam_file("victoria_park.txt")
    argv = ["run", "--dataset", "victoria-park", "--max-poses", "300", "--converge-at-end"]
    code = main([*argv, "--score-against-optimum", "--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    row = json.loads(out)
    assert row["converged_at_end"] is True and 0 < row["convergence_s"] < row["total_s"]
    assert row["batch_converged"] is True and row["batch_distance_max_m"] < 1e-4


def test_cli_names_the_bad_line_of_a_gtsam_text_file(capsys, tmp_path):
    path = tmp_path / "bad.txt"
    path.write_text("ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\nLANDMARK 7 5 3.0 -4.0 0.9 0 0.9\n")
    code = main(["run", "--dataset", str(path), "--preset", "victoria-park"])
    _, err = capsys.readouterr()
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert f"{path} line 2: LANDMARK seen from pose id 7" in err


def test_the_experiments_run_on_victoria_park(victoria):
    exp = Experiment("victoria-park", victoria, VP)
    timing_experiment(exp, batch_budget_s=None, max_poses=60)
    interpolation_experiment(exp, skips=(1, 3), max_poses=60)
    runs = [*exp.timing.values(), *exp.with_interp.values(), *exp.without_interp.values()]
    assert len(runs) == 10 and all(r.n_steps_processed == 60 and np.isnan(r.rmse_m) for r in runs)
    assert exp.with_interp[3].n_states < exp.with_interp[1].n_states == 60
    assert "| victoria-park | BTGP/10 | 60 |" in results_table([exp])


def test_cli_batch_and_pbvr_with_skip_on_a_prefix_file(capsys, tmp_path):
    """The first 400 rows of the file are a data set too (a path): the batch command reports no RMSE, and
    PBVR/10 with skip 3 (interpolated bearing-ranges) is scored against the batch optimum."""
    path = tmp_path / "vp_prefix.txt"
    path.write_text("".join(_gtsam_file("victoria_park.txt").read_text().splitlines(keepends=True)[:400]))
    code = main(["batch", "--dataset", str(path), "--preset", "victoria-park", "--json"])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert json.loads(out)["rmse_m"] is None
    code = main(
        ["run", "--dataset", str(path), "--preset", "victoria-park", "--method", "pbvr", "--skip", "3"]
        + ["--score-against-optimum", "--json"]
    )
    out, err = capsys.readouterr()
    assert code == 0, err
    row = json.loads(out)
    assert (
        row["method"] == "pbvr"
        and row["skip"] == 3
        and row["every"] == 10
        and row["n_estimated_states"] < row["n_poses"]
    )
    assert row["batch_converged"] is True and row["batch_distance_median_m"] >= 0
