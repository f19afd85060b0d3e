"""A hostile user's sweep of the command and the API: each case here was found answering wrongly (a traceback, a
hang, an option passed over in silence, a data file overwritten) and now gives one line and exit code 2, or the
project's own exception, naming the value.

- ``--jobs`` beyond :data:`~steam_ref.cli.args.MAX_JOBS` (``consistency``, ``reproduce``): refused, not a loky
  ``OverflowError`` traceback (a 24-digit count) nor minutes spawning 100,000 workers;
- ``--qc`` times ``--qc-scale`` past float64: refused naming both, without NumPy's overflow warning;
- an output (``--save-trajectory``, ``--plot``, ...) that names a file the run reads: refused before the run, the
  data file left byte for byte as it was;
- a 3-D run (``--dataset synthetic-3d``) given a planar option it does not read (``--method pb``, ``--no-interpolate``,
  ``--amalgamation-zeros``, ``--lag-batch``, ``--trajectory-format``): refused by name, not ignored;
- ``--seed`` with a data set read from a file: refused (the seed draws a generated set only);
- a negative number in exponent form (``--turn -1e-3``): read as the option's value, not as an unknown option;
- ``StreamOptions(time_budget_s=inf)``: refused as the other times are (a finite number of seconds).
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from steam_ref.cli.args import MAX_JOBS
from steam_ref.cli.commands import build_parser
from steam_ref.errors import SteamError
from steam_ref.paper.options import StreamOptions
from tests.cli_runs import runner

steam_ref = runner()


def _one_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith("steam-ref: error: "), err
    return lines[0]


def _gtsam_text(path: Path, n_poses: int = 12) -> Path:
    """A tiny planar data set in GTSAM's load2D text format: a straight chain of poses, a tree seen from each."""
    rows = []
    for i in range(n_poses - 1):
        rows.append(f"ODOMETRY {i} {i + 1} 1.0 0.0 0.01 0.01 0 0 0.01 0 0.001")
        rows.append(f"LANDMARK {i + 1} 100 {4.0 - i} 3.0 0.4 0 0.4")
    path.write_text("\n".join(rows) + "\n", encoding="ascii")
    return path


@pytest.mark.parametrize("command", [["consistency", "--seeds", "2"], ["reproduce", "--quick"]])
@pytest.mark.parametrize("jobs", ["99999999999999999999999", str(MAX_JOBS + 1), "100000"])
def test_jobs_beyond_the_bound_is_one_line(capsys, tmp_path, command, jobs):
    code, out, err = steam_ref(
        capsys, *command, "--jobs", jobs, *(["--out", tmp_path / "r"] * (command[0] == "reproduce"))
    )
    line = _one_line(err)
    assert code == 2 and out == ""
    assert "--jobs" in line and repr(jobs) in line and f"<= {MAX_JOBS}" in line
    assert not (tmp_path / "r").exists()


def test_jobs_at_the_bound_is_accepted():
    args = build_parser("consistency").parse_args(["consistency", "--jobs", str(MAX_JOBS)])
    assert args.jobs == MAX_JOBS


def test_qc_times_qc_scale_past_float64_is_one_line(capsys):
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # NumPy's "overflow encountered in multiply" would be a second line
        code, out, err = steam_ref(capsys, "run", "--steps", 5, "--qc", "1e308,1,1", "--qc-scale", "1e8")
    line = _one_line(err)
    assert code == 2 and out == ""
    assert "--qc" in line and "--qc-scale" in line and "1e+308" in line


@pytest.mark.parametrize("command", ["run", "batch"])
def test_an_output_that_is_the_input_is_refused(capsys, tmp_path, command):
    data = _gtsam_text(tmp_path / "walk.txt")
    before = data.read_bytes()
    code, out, err = steam_ref(
        capsys, command, "--dataset", data, "--preset", "victoria-park", "--save-trajectory", data
    )
    line = _one_line(err)
    assert code == 2 and out == ""
    assert "--save-trajectory" in line and str(data) in line
    assert data.read_bytes() == before


def test_an_output_linked_to_the_input_is_refused(capsys, tmp_path):
    data = _gtsam_text(tmp_path / "walk.txt")
    before = data.read_bytes()
    (tmp_path / "estimate.txt").symlink_to(data)
    code, _, err = steam_ref(
        capsys, "run", "--dataset", data, "--preset", "victoria-park", "--save-trajectory", tmp_path / "estimate.txt"
    )
    line = _one_line(err)
    assert code == 2 and "--save-trajectory" in line and str(data) in line
    assert data.read_bytes() == before


def test_an_output_beside_the_input_is_written(capsys, tmp_path):
    data = _gtsam_text(tmp_path / "walk.txt")
    code, _, err = steam_ref(
        capsys, "run", "--dataset", data, "--preset", "victoria-park", "--save-trajectory", tmp_path / "estimate.txt"
    )
    assert code == 0, err
    assert len((tmp_path / "estimate.txt").read_text().splitlines()) > 1


@pytest.mark.parametrize(
    "option",
    [
        ["--method", "pb"],
        ["--method", "pbvr"],
        ["--no-interpolate"],
        ["--amalgamation-zeros", "0.5"],
        ["--lag", "5", "--lag-batch", "2"],
        ["--progress"],  # a 3-D run draws no progress bar: --progress was ignored
    ],
)
def test_a_planar_option_on_a_3d_run_is_refused(capsys, option):
    code, out, err = steam_ref(capsys, "run", "--dataset", "synthetic-3d", "--steps", 5, *option)
    line = _one_line(err)
    assert code == 2 and out == ""
    name = next(o for o in option if o.startswith("--") and o != "--lag")
    assert f"{name} does not apply" in line


@pytest.mark.parametrize("command", ["run", "batch", "fit-qc"])
def test_a_seed_for_a_file_is_refused(capsys, tmp_path, command):
    data = _gtsam_text(tmp_path / "walk.txt")
    code, out, err = steam_ref(capsys, command, "--dataset", data, "--preset", "victoria-park", "--seed", 3)
    line = _one_line(err)
    assert code == 2 and out == ""
    assert "--seed" in line and str(data) in line


def test_a_seed_for_a_generated_set_is_taken():
    args = build_parser("run").parse_args(["run", "--seed", "3"])
    assert args.seed == 3


@pytest.mark.parametrize("text", ["-1e-3", "-2E-1", "-.5", "-3"])
def test_a_negative_number_in_any_decimal_form_is_a_value(text):
    args = build_parser("consistency").parse_args(["consistency", "--prior", "se2", "--turn", text])
    assert args.turn == float(text)


def test_a_negative_scale_in_exponent_form_is_refused_as_a_number(capsys):
    code, _, err = steam_ref(capsys, "run", "--qc-scale", "-1e3")
    line = _one_line(err)
    assert code == 2 and "--qc-scale" in line and "'-1e3'" in line and "expected one argument" not in line


@pytest.mark.parametrize("budget", [math.inf, np.float64(np.inf)])
def test_an_infinite_time_budget_is_refused(budget):
    with pytest.raises(SteamError, match="time_budget_s"):
        StreamOptions(time_budget_s=budget)
