"""What the long commands show while they work (steam_ref.paper.progress): each bar names the data set, the
method and its schedule; a line says when a time budget cuts a run short; nothing when stderr is not a
terminal or with --no-progress, something with --progress."""

from __future__ import annotations

import errno
import io
import json
import os
import subprocess

import pytest
from cli_runs import run_module

from steam_ref.cli.commands import main
from steam_ref.datasets import generate_synthetic
from steam_ref.paper import progress
from steam_ref.paper.experiments import Experiment, timing_experiment
from steam_ref.paper.presets import PaperSetup


@pytest.fixture(scope="module")
def small():
    return generate_synthetic(n_steps=30, n_landmarks=6, seed=3)


def test_a_stream_label_names_the_data_set_the_method_its_schedule_and_the_layout():
    assert progress.stream_label("plaza", "pb", 1) == "plaza PB/1"
    assert progress.stream_label("plaza", "btgp", 10) == "plaza BTGP/10"
    assert progress.stream_label("synthetic", "btgp", 1, 5, False) == "synthetic BTGP/1 skip 5 not interpolated"
    assert progress.stream_label(None, "pbvr", 10) == "PBVR/10"


def test_every_timing_run_is_labelled_and_the_budget_says_when_it_cuts_a_run_short(small, capsys):
    exp = Experiment("synthetic", small, PaperSetup.synthetic())
    timing_experiment(exp, batch_budget_s=1e-6, progress=True)  # PB and PBVR stop after their first pose
    err = capsys.readouterr().err
    for label in ("PB/1", "PB/10", "PBVR/1", "PBVR/10", "BTGP/1", "BTGP/10"):
        assert f"synthetic {label}:" in err, label
    for label in ("PB/1", "PB/10", "PBVR/1", "PBVR/10"):
        assert f"synthetic {label}: time budget 1e-06 s used up after 1 of 31 poses; the run stops there" in err
        assert not exp.timing[label].completed
    assert "BTGP/1: time budget" not in err and exp.timing["BTGP/1"].completed  # BTGP has no budget


def test_a_run_within_its_budget_says_nothing_about_it(small, capsys):
    exp = Experiment("synthetic", small, PaperSetup.synthetic())
    timing_experiment(exp, batch_budget_s=600.0, progress=True)
    assert "time budget" not in capsys.readouterr().err


def test_progress_is_off_without_a_terminal_and_on_when_asked(monkeypatch, capsys, small_mat):
    monkeypatch.setattr("sys.stderr", io.StringIO())  # not a terminal
    assert not progress.wanted(None) and progress.wanted(True) and not progress.wanted(False, json_output=False)
    monkeypatch.undo()
    args = ["consistency", "--seeds", "2", "--steps", "8", "--landmarks", "2"]
    assert main(args) == 0  # capsys: not a terminal
    assert capsys.readouterr().err == ""
    assert main([*args, "--progress"]) == 0
    assert "consistency on synthetic: 6 estimators, seeds" in capsys.readouterr().err
    batch = ["batch", "--dataset", str(small_mat[0]), "--preset", "synthetic"]  # a step without a loop
    assert main([*batch, "--progress"]) == 0
    assert f"{small_mat[0]} batch (AMD): 00:0" in capsys.readouterr().err
    assert main([*batch, "--no-progress"]) == 0
    assert capsys.readouterr().err == ""


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_on_a_terminal_the_bar_shows_without_being_asked_and_no_progress_turns_it_off(monkeypatch):
    terminal = _Terminal()
    monkeypatch.setattr("sys.stderr", terminal)
    assert main(["run", "--max-poses", "30"]) == 0
    assert "synthetic BTGP/1" in terminal.getvalue()
    terminal.seek(0), terminal.truncate()
    assert main(["run", "--max-poses", "30", "--no-progress"]) == 0
    assert main(["consistency", "--seeds", "2", "--steps", "8", "--landmarks", "2", "--no-progress"]) == 0
    assert terminal.getvalue() == ""


# -- a progress display never costs a run ---------------------------------------------------------


class _Full(io.StringIO):
    """stderr on a full disk: every write fails as /dev/full's does."""

    def write(self, text: str) -> int:
        raise OSError(errno.ENOSPC, "No space left on device")

    def isatty(self) -> bool:
        return True


@pytest.mark.parametrize("stderr", [_Full, None], ids=["full", "closed"])
def test_a_stderr_that_cannot_take_the_bar_costs_the_run_nothing(monkeypatch, capsys, tmp_path, stderr, small_mat):
    monkeypatch.setattr("sys.stderr", stderr() if stderr else None)  # None: Python's stderr when fd 2 is closed
    saved = tmp_path / "trajectory.txt"
    code = main(["run", "--steps", "40", "--progress", "--json", "--save-trajectory", str(saved)])
    assert code == 0 and saved.is_file()
    assert json.loads(capsys.readouterr().out)["n_poses"] == 41
    for command in (
        ["batch", "--dataset", str(small_mat[0]), "--preset", "synthetic", "--progress"],
        ["consistency", "--seeds", "2", "--steps", "8", "--progress"],
    ):
        assert main(command) == 0, command


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
@pytest.mark.parametrize("where", ["/dev/full", "closed"])
def test_the_command_with_its_stderr_full_or_closed_completes_and_writes_its_files(tmp_path, where):
    saved = tmp_path / "trajectory.txt"
    args = ["run", "--steps", "40", "--progress", "--json", "--save-trajectory", saved]
    if where == "closed":
        proc = run_module(*args, stdout=subprocess.PIPE, preexec_fn=lambda: os.close(2))
    else:
        with open(where, "w") as full:
            proc = run_module(*args, stdout=subprocess.PIPE, stderr=full)
    assert proc.returncode == 0 and saved.is_file()
    assert json.loads(proc.stdout)["n_poses"] == 41
