"""Absurd readings and diverging streams.

Two classes. **Readings no sensor gives** are refused when the data set is made, naming the reading:
a value whose float64 spacing exceeds its sigma (a bearing of 1e17 rad: numbers there are 16 rad
apart), and a range that contradicts the other ranges to its landmark by more than the robot moved
between them (the triangle inequality along the odometry's path). The oracle is the triangle
inequality itself, worked out here from the sighting and the poses, not the loader's arithmetic.

**A stream whose estimate diverges says so**: a reading beyond any plausible noise at the prediction
is named by a DivergenceWarning, an estimate that stops fitting what it was just given is called
diverging, and both are recorded in the result and its JSON. Reproduced on a 300-pose cut of
Victoria Park (gtsam's Data/victoria_park.txt) with one sighting moved to x = 1e6 m: the CLI blames
that line, and the stream (fed the reading past the loader) names that reading first.
"""

from __future__ import annotations

import dataclasses
import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from requirements import optional_import, skip_or_fail

from steam_ref.cli import commands as cli
from steam_ref.datasets import LandmarkDataset, gtsam_data_dir, load_gtsam_2d
from steam_ref.errors import DataError, DivergenceWarning
from steam_ref.paper.online import StreamingEstimator
from steam_ref.paper.options import StreamOptions
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.readings import Readings

VP = PaperSetup.victoria_park()


@pytest.fixture(scope="module")
def cut(tmp_path_factory) -> tuple[list[str], Path]:
    """The lines of the first 300 poses of Victoria Park, and that cut written to a file."""
    optional_import("gtsam", "gtsam")
    folder = gtsam_data_dir()
    if folder is None or not (folder / "victoria_park.txt").is_file():
        skip_or_fail("gtsam's Data/ folder has no victoria_park.txt; pip install gtsam", "optional")
    lines, n = [], 0
    for line in (folder / "victoria_park.txt").read_text().splitlines():
        n += line.startswith("ODOMETRY")
        if n == 300:
            break
        lines.append(line)
    path = tmp_path_factory.mktemp("vp") / "vp300.txt"
    path.write_text("\n".join(lines) + "\n")
    return lines, path


def _with_line(tmp_path: Path, lines: list[str], index: int, field: int, value: str) -> Path:
    fields = lines[index].split()
    fields[field] = value
    path = tmp_path / "edited.txt"
    path.write_text("\n".join(lines[:index] + [" ".join(fields)] + lines[index + 1 :]) + "\n")
    return path


def _sightings(lines: list[str]) -> list[int]:
    return [i for i, line in enumerate(lines) if line.startswith("LANDMARK")]


def test_the_clean_cut_loads(cut) -> None:
    data = load_gtsam_2d(cut[1])
    assert (data.n_poses, len(data.bearing_ranges)) == (300, 183)


def test_one_sighting_at_a_million_metres_is_refused_naming_its_line(cut, tmp_path: Path, capsys) -> None:
    lines, _ = cut
    index = _sightings(lines)[91]
    assert lines[index].split()[2] == "135"  # landmark 135, which is seen 7 times
    path = _with_line(tmp_path, lines, index, 3, "1e6")
    code = cli.main(["run", "--dataset", str(path), "--preset", "victoria-park"])
    _, err = capsys.readouterr()
    assert code == 2 and len(err.splitlines()) == 1
    assert f"line {index + 1}, bearing_ranges[91, 3] (range) = 1000000.0000420136" in err
    assert "landmark 135" in err


# Moving one sighting's x by an amount: the triangle inequality says when that must be refused. The
# oracle: the other sightings of the same landmark, the odometry's path length between the poses, and
# the slack of 10 sigmas (range sigmas plus the odometry's translation sigmas along the path).
@settings(max_examples=25, deadline=None, database=None)
@given(which=st.integers(0, 182), offset=st.sampled_from([1e3, 1e4, -1e4, 1e6, 1e9, 3.0, -3.0, 0.5]))
def test_a_moved_sighting_is_refused_exactly_when_the_triangle_inequality_says(cut, tmp_path_factory, which, offset):
    lines, path = cut
    clean = load_gtsam_2d(path)
    index = _sightings(lines)[which]
    fields = lines[index].split()
    x, y = float(fields[3]) + offset, float(fields[4])
    edited = _with_line(tmp_path_factory.mktemp("moved"), lines, index, 3, repr(x))
    br, odo, cov = clean.bearing_ranges, clean.odometry, clean.odometry_covariance
    poses = clean.reading_poses("bearing_ranges")
    r = math.hypot(x, y)
    step = np.hypot(odo[:, 1], odo[:, 2])
    sigma_step = np.sqrt(cov[:, 0] + cov[:, 3])
    impossible = False
    for k in range(len(br)):
        if k == which or br[k, 1] != br[which, 1]:
            continue
        a, b = sorted((int(poses[k]), int(poses[which])))
        moved, odo_slack = step[a:b].sum(), sigma_step[a:b].sum()
        impossible |= abs(r - br[k, 3]) > moved + 10 * (br[k, 5] + br[which, 5] + odo_slack)
    if impossible:
        with pytest.raises(DataError, match=rf"line {index + 1}, bearing_ranges\[{which}, 3\]"):
            load_gtsam_2d(edited)
    else:
        assert len(load_gtsam_2d(edited).bearing_ranges) == 183


def _dataset(bearing: float, distance: float, sigmas=(0.05, 0.1)) -> LandmarkDataset:
    poses = np.array([[0.0, 0], [1, 1], [2, 2]])
    odometry = np.array([[1.0, 1, 0, 0], [2, 1, 0, 0]])
    covariance = np.tile([0.01, 0, 0, 0.01, 0, 0.001], (2, 1))
    sightings = np.array(
        [[0.0, 7, 0.3, 10.0, 0.05, 0.1], [1, 7, bearing, distance, *sigmas], [2, 7, 0.4, 9.0, 0.05, 0.1]]
    )
    return LandmarkDataset("three", poses, odometry, covariance, bearing_ranges=sightings)


@settings(max_examples=60, deadline=None, database=None)
@given(bearing=st.floats(-1e20, 1e20, allow_nan=False), sigma=st.floats(1e-6, 10.0))
def test_a_bearing_whose_float_spacing_exceeds_its_sigma_is_refused(bearing: float, sigma: float) -> None:
    """The oracle: math.ulp, the distance to the next float up, against the sigma."""
    if math.ulp(abs(bearing)) > sigma:
        with pytest.raises(DataError, match=r"bearing_ranges\[1, 2\] \(bearing\)"):
            _dataset(bearing, 9.5, (sigma, 0.1))
    else:
        _dataset(bearing, 9.5, (sigma, 0.1))


def test_a_bearing_of_1e17_rad_names_the_spacing() -> None:
    with pytest.raises(DataError, match=r"= 1e\+17 at t=1.0: float64 numbers there are 16 apart, more than its sigma"):
        _dataset(1e17, 9.5)


def test_a_landmark_seen_by_two_contradicting_ranges_alone_names_both() -> None:
    poses = np.array([[0.0, 0], [1, 1]])
    odometry = np.array([[1.0, 1, 0, 0]])
    covariance = np.array([[0.01, 0, 0, 0.01, 0, 0.001]])
    sightings = np.array([[0.0, 7, 0.3, 10.0, 0.05, 0.1], [1, 7, 0.3, 500.0, 0.05, 0.1]])
    with pytest.raises(DataError, match=r"one of bearing_ranges\[0, 3\] \(range\) = 10.0 and bearing_ranges\[1, 3\]"):
        LandmarkDataset("two", poses, odometry, covariance, bearing_ranges=sightings)


# --- the stream ---------------------------------------------------------------------------------


def _absurd_readings(path: Path, row: int) -> Readings:
    """The cut's readings with sighting ``row`` moved to x = 1e6 m in the robot's frame, past the loader."""
    readings = Readings.from_dataset(load_gtsam_2d(path), VP)
    br = readings.bearing_ranges
    value = br.value.copy()
    y = value[row, 1] * math.sin(value[row, 0])
    value[row] = [math.atan2(y, 1e6), math.hypot(1e6, y)]
    return dataclasses.replace(readings, bearing_ranges=dataclasses.replace(br, value=value))


def test_the_clean_stream_raises_no_divergence(cut) -> None:
    readings = Readings.from_dataset(load_gtsam_2d(cut[1]), VP)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DivergenceWarning)
        result = StreamingEstimator(readings, VP, StreamOptions()).run()
    assert result.divergence == () and result.summary()["divergence"] == []


def test_a_diverging_stream_names_the_absurd_reading_first_and_records_it(cut) -> None:
    readings = _absurd_readings(cut[1], 91)
    with pytest.warns(DivergenceWarning) as caught:
        result = StreamingEstimator(readings, VP, StreamOptions()).run()
    first = str(caught[0].message)
    assert "BearingRangeFactor on x129, l135" in first and "1000000.0000420136" in first
    assert "sigmas from the prediction" in first
    assert any("the estimate is diverging" in str(w.message) for w in caught)
    assert result.divergence[0] == first
    row = json.loads(json.dumps(result.summary("vp300")))
    assert row["divergence"][0] == first
    # the estimate it warns about is indeed wrecked: the last pose is kilometres from the clean run's
    clean = StreamingEstimator(Readings.from_dataset(load_gtsam_2d(cut[1]), VP), VP, StreamOptions()).run()
    assert np.hypot(*(result.trajectory[-1, :2] - clean.trajectory[-1, :2])) > 1e3


def test_ranges_and_bearing_ranges_to_one_landmark_are_checked_together() -> None:
    """A range table (sigma in column 3) and a bearing-range table (range sigma in column 5) together."""
    poses = np.array([[0.0, 0], [1, 1], [2, 2]])
    odometry = np.array([[1.0, 1, 0, 0], [2, 1, 0, 0]])
    covariance = np.tile([0.01, 0, 0, 0.01, 0, 0.001], (2, 1))
    ranges = np.array([[0.0, 7, 10.0, 0.1], [1, 7, 10.5, 0.1], [2, 7, 60.0, 0.1]])
    sightings = np.array([[1.0, 7, 0.3, 10.2, 0.05, 0.1]])
    with pytest.raises(DataError, match=r"ranges\[2, 2\] \(range\) = 60.0 cannot be right: landmark 7"):
        LandmarkDataset("mixed", poses, odometry, covariance, ranges=ranges, bearing_ranges=sightings, landmark_ids=[7])
    ranges[2, 2] = 9.0  # 1 m from the last, after 1 m of travel: possible
    LandmarkDataset("mixed", poses, odometry, covariance, ranges=ranges, bearing_ranges=sightings, landmark_ids=[7])
