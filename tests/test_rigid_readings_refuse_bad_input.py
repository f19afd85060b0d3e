"""3-D readings (``RigidReadings``) and a 3-D run (``solve_rigid``) refuse what they cannot read, naming it, with the
package's own exceptions: a range or body-frame point of a landmark the survey does not hold (a fractional id was
read as the integer below it, an unknown one failed with a bare KeyError), a landmark surveyed twice (the second
survey silently replaced the first), a table with no sigma, first values, a first state or a truth of the wrong
shape (an IndexError, or nothing until a solver read them).

Oracle: the generated set's own tables, each changed in one entry; what must be named is the entry changed.
"""

from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest

from steam_ref.datasets.rigid import RIGID_QC, generate_rigid, sample_rigid_task
from steam_ref.errors import DataError, ShapeError, SteamError
from steam_ref.motion import motion_prior
from steam_ref.paper.rigid import held_out_errors, solve_rigid, straight_line_errors


@pytest.fixture(scope="module")
def data():
    return generate_rigid(12, seed=0)


@pytest.mark.parametrize("table", ["ranges", "points"])
@pytest.mark.parametrize("landmark", [0.5, 99.0, -1.0])
def test_a_reading_of_a_landmark_not_surveyed_is_refused_naming_the_row_and_id(data, table, landmark):
    rows = getattr(data, table).copy()
    rows[3, 1] = landmark
    with pytest.raises(DataError, match=rf"{table} row 3 .* names landmark id {landmark:g}.*not in landmarks"):
        replace(data, **{table: rows})


def test_a_fractional_landmark_id_is_not_read_as_the_landmark_below_it(data):
    """Before: ranges naming landmark 0.5 solved as if they named landmark 0, without a word."""
    rows = data.ranges.copy()
    rows[rows[:, 1] == 0, 1] = 0.5
    with pytest.raises(DataError, match=r"landmark id 0\.5"):
        solve_rigid(replace(data, ranges=rows), motion_prior("se3", RIGID_QC), "batch")


def test_a_landmark_surveyed_twice_or_by_a_fractional_id_is_refused(data):
    survey = data.landmarks.copy()
    survey[1, 0] = survey[0, 0]
    with pytest.raises(DataError, match=r"id 0 appears twice in landmarks, rows 0 and 1"):
        replace(data, landmarks=survey)
    survey = data.landmarks.copy()
    survey[1, 0] = 1.25
    with pytest.raises(DataError, match=r"landmarks\[1, 0\] \(id\) = 1.25 is not an integer"):
        replace(data, landmarks=survey)


@pytest.mark.parametrize("key", ["position", "gyro", "range", "point", "landmark", "first_pose", "first_twist"])
def test_a_table_without_its_sigma_is_refused_naming_the_sigma(data, key):
    sigmas = {k: v for k, v in data.sigmas.items() if k != key}
    with pytest.raises(DataError, match=f"sigmas has no '{key}'"):
        replace(data, sigmas=sigmas)


@pytest.mark.parametrize(
    ("field", "value", "shape"),
    [
        ("first_state", np.zeros(11), (12,)),
        ("initial_states", np.zeros((12, 12)), (13, 12)),
        ("truth", np.zeros((13, 6)), (13, 12)),
    ],
)
def test_states_of_the_wrong_shape_are_refused_naming_the_field(data, field, value, shape):
    with pytest.raises(ShapeError, match=re.escape(f"{field} must be {shape}") + ".*" + re.escape(f"{value.shape}")):
        replace(data, **{field: value})


@pytest.mark.parametrize("method", ["batch", "btgp", "fixed-lag"])
@pytest.mark.parametrize("shape", [(5, 12), (13, 6), (14, 12)])
def test_first_values_of_the_wrong_shape_are_a_shape_error_naming_initial(data, method, shape):
    """Before: 5 rows for 13 states was an IndexError (batch) after the first five states' factors were made; 14
    rows ran, the last never read."""
    with pytest.raises(ShapeError, match=rf"initial must be \(13, 12\).*got shape \({shape[0]}, {shape[1]}\)"):
        solve_rigid(data, motion_prior("se3", RIGID_QC), method, initial=np.zeros(shape))


def test_a_sample_given_where_its_readings_are_meant_is_refused_naming_data():
    """docs/api.md names ``sample_rigid_task`` (which draws a task with its truth) and ``solve_rigid(data, ...)`` in
    one breath; the sample itself given as ``data`` failed with AttributeError: 'RigidSample' object has no
    attribute 'on' (and ``straight_line_errors`` with one on 'state_times')."""
    prior = motion_prior("se3", RIGID_QC)
    sample = sample_rigid_task(prior, 6, 3, 0)
    says = r"data must be a RigidReadings \(a RigidSample's readings are its \.data\), got a RigidSample"
    with pytest.raises(SteamError, match=says):
        solve_rigid(sample, prior)
    with pytest.raises(SteamError, match=says):
        straight_line_errors(sample)
    with pytest.raises(SteamError, match=says):
        held_out_errors(sample, prior, sample.states)
    assert solve_rigid(sample.data, prior).states.shape == sample.states.shape  # its readings, as meant
