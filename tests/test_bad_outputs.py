"""What the command writes and prints, on the inputs that lost it: a robot that does not move (no
alignment is defined, the other figures and every file stand), outputs named only by their extension
(``.npz``, ``.png``: dotfiles keep their data), a stdout that cannot encode the package's own text, a
stdout that is closed, a pipe closed by its reader, outputs naming one file or the file stdout goes to,
and ``--trajectory-format`` or ``--save-trajectory ''`` that would write nothing."""

from __future__ import annotations

import io
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.io
from cli_runs import run_module

from steam_ref.cli import commands as cli
from steam_ref.cli import main as entry
from steam_ref.datasets import generate_synthetic
from steam_ref.datasets.kitti import GPS_FILE, IMU_FILE
from steam_ref.datasets.search import gtsam_data_dir
from steam_ref.evaluate import read_tum

PNG = b"\x89PNG\r\n\x1a\n"


def _parked(folder: Path, where: tuple[float, float]) -> str:
    """A CMU .mat whose robot stays at ``where`` (its ranges from the moving task, which does not matter)."""
    arrays = generate_synthetic(n_steps=12, n_landmarks=3, seed=3, range_sigma=0.3).to_cmu_arrays()
    arrays["GT"][:, 1:3] = where
    path = folder / f"parked_{where[0]}.mat"
    scipy.io.savemat(path, arrays)
    return str(path)


def _call(capsys, argv: list[str]) -> tuple[int, str, str]:
    code = cli.main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


# -- a robot that does not move: no alignment, every other figure and every file --


@pytest.mark.parametrize("where", [(0.0, 0.0), (0.004563633891996413, -0.00571464073773764)])
@pytest.mark.parametrize("command", ["run", "batch"])
def test_a_parked_robot_is_evaluated_without_alignment_and_its_files_are_written(tmp_path, capsys, where, command):
    """At (0, 0) the centred truth is exactly zero (this exited 2 and wrote nothing); elsewhere it is a few
    ulps of rounding, which gave a Sim(2) scale of 1e-33 and an SE(2) rotation fitted to noise, in silence."""
    data = _parked(tmp_path, where)
    saved = tmp_path / "trajectory.txt"
    argv = [command, "--dataset", data, "--preset", "synthetic", "--json", "--save-trajectory", str(saved)]
    code, out, err = _call(capsys, argv)
    assert code == 0, err
    evaluation = json.loads(out)["evaluation"]
    assert evaluation["ape_se2"] is None and evaluation["ape_sim2"] is None
    assert "truth's positions all coincide" in evaluation["alignment_undefined"]
    truth = np.array(where)
    times, poses = read_tum(saved)
    assert len(times) == 13
    distance = np.hypot(*(poses[:, :2] - truth).T)  # the unaligned APE, recomputed from the file written
    assert evaluation["ape"]["translation_m"]["rmse"] == pytest.approx(np.sqrt(np.mean(distance**2)), rel=1e-12)
    assert evaluation["rpe"]["translation_m"]["n"] == 12


def test_a_parked_robot_says_why_in_the_text_summary(tmp_path, capsys):
    code, out, _ = _call(capsys, ["run", "--dataset", _parked(tmp_path, (0.0, 0.0)), "--preset", "synthetic"])
    assert code == 0
    assert "alignment is undefined: the truth's positions all coincide" in out


# -- outputs named only by their extension --


def test_dotfile_outputs_keep_their_data_and_leave_no_temporary(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    argv = ["run", "--steps", "6", "--json", "--save-estimates", str(out / ".npz"), "--plot", str(out / ".png")]
    code, _, err = _call(capsys, [*argv, "--save-trajectory", str(out / ".txt")])
    assert code == 0, err
    assert sorted(p.name for p in out.iterdir()) == [".npz", ".png", ".txt"]  # no hidden temporary left
    with np.load(out / ".npz") as saved:
        assert len(saved["times"]) == 7 and saved["pose_covariance"].shape == (7, 3, 3)
    assert (out / ".png").read_bytes().startswith(PNG)
    assert len(read_tum(out / ".txt")[0]) == 7


def test_a_figure_saved_as_a_dotfile_is_that_file(tmp_path):
    """matplotlib appends ".png" to a name without an extension, and ".png" has none to it."""
    from steam_ref.plot.figures import plot_trajectory

    plot_trajectory(None, np.array([[0.0, 0.0], [1.0, 1.0]]), path=str(tmp_path / ".png"))
    assert sorted(p.name for p in tmp_path.iterdir()) == [".png"]
    assert (tmp_path / ".png").read_bytes().startswith(PNG)


def test_consistency_plot_named_as_a_dotfile_is_that_file(tmp_path, capsys):
    code, _, err = _call(capsys, ["consistency", "--seeds", "2", "--json", "--plot", str(tmp_path / ".png")])
    assert code == 0, err
    assert sorted(p.name for p in tmp_path.iterdir()) == [".png"]
    assert (tmp_path / ".png").read_bytes().startswith(PNG)


# -- a stdout that cannot encode the package's own text --


def _ascii_stdout(monkeypatch) -> io.BytesIO:
    raw = io.BytesIO()
    monkeypatch.setattr(sys, "stdout", io.TextIOWrapper(raw, encoding="ascii", errors="strict"))
    return raw


def test_help_with_alpha_on_an_ascii_stdout(monkeypatch):
    raw = _ascii_stdout(monkeypatch)
    with pytest.raises(SystemExit) as exit_:
        entry(["run", "--help"])
    sys.stdout.flush()
    assert exit_.value.code == 0
    assert "1/\\u03b1 on the preset's GP clock" in " ".join(raw.getvalue().decode("ascii").split())


def test_consistency_chi_squared_on_an_ascii_stdout(monkeypatch, capsys):
    raw = _ascii_stdout(monkeypatch)
    assert entry(["consistency", "--seeds", "2"]) == 0
    sys.stdout.flush()
    assert "\\u03c7\\xb2(N d)/N" in raw.getvalue().decode("ascii")


def test_conformance_check_with_a_non_ascii_case_name_on_an_ascii_stdout(tmp_path, monkeypatch, capsys):
    from steam_ref.conformance import KIT_VERSION

    (tmp_path / "gp").mkdir()
    results = {"kit_version": KIT_VERSION, "cases": {"cas_é_χ": {"x": 1.0}}}
    (tmp_path / "gp" / "results.json").write_text(json.dumps(results), encoding="utf-8")
    raw = _ascii_stdout(monkeypatch)
    assert entry(["conformance", "check", str(tmp_path), "--only", "gp"]) == 1  # gp's cases are missing
    sys.stdout.flush()
    assert "gp/cas_\\xe9_\\u03c7" in raw.getvalue().decode("ascii")


def test_the_module_on_an_ascii_stdout_is_not_a_traceback():
    proc = run_module("run", "--help", env=dict(os.environ, PYTHONIOENCODING="ascii"), text=False, timeout=120)
    assert proc.returncode == 0 and proc.stderr == b""
    assert b"\\u03b1" in proc.stdout


@pytest.mark.skipif(sys.platform != "linux", reason="a file name of any bytes")
def test_a_file_name_that_is_not_utf8_shows_its_byte_not_pythons_surrogate(tmp_path):
    """A byte of a file name that is not UTF-8 (0xff) is held by Python as the lone surrogate U+DCFF, which both an
    error's line (quoting the path's repr) and stdout (printing the path) wrote as ``\\udcff``. Both now show the
    byte, ``\\xff``, as Python shows it in ``os.fsencode(path)``; a name holding the text ``\\udcff`` stays itself."""
    folder = os.fsencode(tmp_path)
    env = {**os.environ, "MPLBACKEND": "Agg", "PYTHONPATH": str(Path(__file__).resolve().parents[1])}  # bytes argv:
    # run_module's arguments are str
    base = [sys.executable, "-m", "steam_ref", "run", "--dataset", "synthetic", "--steps", "5", "--plot"]
    proc = subprocess.run([*base, folder + b"/\xff/x.png"], env=env, capture_output=True, timeout=120)
    assert proc.returncode == 2
    assert b"folder '" + folder + b"/\\xff' does not exist" in proc.stderr, proc.stderr
    proc = subprocess.run([*base, folder + b"/\xffx.png"], env=env, capture_output=True, timeout=120)
    assert proc.returncode == 0 and proc.stderr == b"", proc.stderr
    assert b"plot written to " + folder + b"/\\xffx.png" in proc.stdout, proc.stdout
    assert (tmp_path / os.fsdecode(b"\xffx.png")).is_file()
    proc = subprocess.run([*base, folder + b"/\\udcffy/x.png"], env=env, capture_output=True, timeout=120)
    assert b"folder '" + folder + b"/\\\\udcffy' does not exist" in proc.stderr, proc.stderr  # its repr's \\


# -- stdout closed, a pipe closed by its reader, outputs onto stdout --


def test_a_closed_stdout_is_refused_before_the_run(tmp_path):
    """Python sets sys.stdout to None when fd 1 is closed, and print() then drops everything: rc 0, nothing."""
    saved = tmp_path / "t.txt"
    proc = run_module(
        "run",
        "--steps",
        "4",
        "--save-trajectory",
        saved,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=False,
        preexec_fn=lambda: os.close(1),
    )
    assert proc.returncode == 2
    assert proc.stderr.decode().splitlines() == [
        "steam-ref: error: stdout is closed: the figures would be lost (redirect it to a file)"
    ]
    assert not saved.exists()


def test_a_pipe_closed_by_its_reader_is_quiet_and_the_files_are_written(tmp_path):
    saved = tmp_path / "t.txt"
    read, write = os.pipe()
    os.close(read)  # the reader went away before a byte was printed
    try:
        proc = run_module(
            "run", "--steps", 4, "--save-trajectory", saved, stdout=write, stderr=subprocess.PIPE, text=False
        )
    finally:
        os.close(write)
    assert proc.stderr == b""
    assert proc.returncode == 141
    assert len(read_tum(saved)[0]) == 5


def test_an_output_onto_the_file_stdout_goes_to_is_refused(tmp_path):
    log = tmp_path / "summary.json"
    with open(log, "wb") as stdout:
        proc = run_module(
            "run", "--steps", 4, "--json", "--save-trajectory", "/dev/stdout", stdout=stdout, stderr=subprocess.PIPE
        )
    assert proc.returncode == 2
    assert "--save-trajectory: '/dev/stdout' is the file stdout is redirected to" in proc.stderr


@pytest.mark.parametrize(
    ("argv", "target", "option"),
    [(["fidelity", "--plot", "{d}/f.png"], "f.png", "--plot"), (["reproduce", "--out", "{d}"], "results.md", "--out")],
)
def test_fidelity_and_reproduce_refuse_to_write_over_the_file_stdout_goes_to(tmp_path, argv, target, option):
    """``fidelity --plot f.png > f.png`` (and ``reproduce --out d > d/results.md``) replaced the printed figures with
    the figure after the run; refused first, as run, batch and consistency refuse it (in seconds: the runs take
    minutes)."""
    with open(tmp_path / target, "wb") as stdout:
        args = [a.format(d=tmp_path) for a in argv]
        proc = run_module(*args, "--no-progress", stdout=stdout, stderr=subprocess.PIPE, timeout=60)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert f"{option}: '{tmp_path / target}' is the file stdout is redirected to" in proc.stderr, proc.stderr


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["--save-trajectory", "{d}/a.png", "--plot", "{d}/a.png"], "both name"),
        (["--save-trajectory", "{d}/x/../a.dot", "--tree-dot", "{d}/a.dot"], "--save-trajectory and --tree-dot both"),
        (["--save-trajectory", ""], "--save-trajectory: expected a file name, got ''"),
        (["--trajectory-format", "kitti"], "--trajectory-format kitti is the format of --save-trajectory"),
    ],
)
def test_outputs_that_would_lose_data_are_refused_before_the_run(tmp_path, capsys, monkeypatch, argv, needle):
    (tmp_path / "x").mkdir()
    monkeypatch.setattr("steam_ref.cli.run.StreamingEstimator", lambda *a, **k: pytest.fail("the run started"))
    monkeypatch.setattr("steam_ref.cli.batch.sequential_batch", lambda *a, **k: pytest.fail("the run started"))
    for command in ("run", "batch"):
        args = [a.format(d=tmp_path) for a in argv]
        if command == "batch" and "--tree-dot" in args:
            continue
        code, out, err = _call(capsys, [command, "--dataset", "synthetic", "--preset", "synthetic", *args])
        assert (code, out) == (2, "") and len(err.splitlines()) == 1
        assert needle in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x"]


@pytest.mark.parametrize("name", [GPS_FILE, IMU_FILE])
@pytest.mark.parametrize("command", ["run", "batch"])
def test_a_kitti_output_onto_either_of_its_data_files_is_refused_and_leaves_it(tmp_path, capsys, command, name):
    """KITTI reads two files: --save-trajectory naming the IMU file (a copy of gtsam's) was written over it, the data
    set's source then naming it with a note the data-file check did not read as a path; both are refused now."""
    folder = gtsam_data_dir()
    if folder is None or not (folder / GPS_FILE).is_file():
        pytest.skip("gtsam's Data/ has no KITTI files")
    for each in (GPS_FILE, IMU_FILE):
        shutil.copy(folder / each, tmp_path / each)
    before = (tmp_path / name).read_bytes()
    argv = [command, "--dataset", "kitti", "--data-dir", str(tmp_path), "--max-poses", "5"]
    code, out, err = _call(capsys, [*argv, "--save-trajectory", str(tmp_path / name)])
    assert (code, out) == (2, "") and len(err.splitlines()) == 1, err
    assert f"--save-trajectory: '{tmp_path / name}' is the data file" in err
    assert (tmp_path / name).read_bytes() == before


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_an_error_with_stderr_full_still_exits_2_not_with_a_traceback():
    """The error line cannot be written; the exit code still says what happened (it was 1: the failed print's
    own traceback, which could not be written either)."""
    with open("/dev/full", "w") as full:
        proc = run_module("run", "--skip", "-1", stderr=full, stdout=subprocess.PIPE, timeout=120)
    assert proc.returncode == 2 and proc.stdout == ""
