"""A parallel sweep (``steam-ref consistency --jobs 2``, joblib's loky workers) stopped by SIGTERM (``kill``) or by
Ctrl-C (SIGINT to the whole process group, as a terminal sends it): the command's one line on stderr and its exit
code, no worker process left running, and its results file still read back, each result the one a serial run gives.

(Each worker made a multiprocessing semaphore, tqdm's lock for its silent bars; killed with it, the worker left
it registered with the resource tracker, which wrote "There appear to be 2 leaked semaphore objects to clean up at
shutdown" and a line of source after the command's line. With Ctrl-C the workers took the interrupt too.)
"""

from __future__ import annotations

import functools
import os
import signal
import subprocess
import sys
import time

import pytest
from processes import clean_up, command_line, descendants, left_running, popen_in_a_terminal_session

from steam_ref.cli.commands import build_parser
from steam_ref.cli.consistency import _study
from steam_ref.paper.consistency import check_result, run_seed
from steam_ref.paper.sweep import read_results

# Small tasks, far more seeds than run before the signal: the sweep is running when it comes.
ARGV = ["consistency", "--seeds", "2000", "--steps", "12", "--landmarks", "3", "--jobs", "2", "--no-progress"]


def _workers(pids: list[int]) -> list[int]:
    return [pid for pid in pids if "LokyProcess" in command_line(pid)]


@pytest.mark.skipif(sys.platform != "linux", reason="reads the processes from /proc")
@pytest.mark.parametrize(
    ("name", "group", "early", "code", "line"),
    [
        ("SIGTERM", False, False, 143, "steam-ref: terminated"),
        ("SIGINT", True, False, 130, "steam-ref: interrupted"),
        ("SIGINT", True, True, 130, "steam-ref: interrupted"),
    ],
    ids=["sigterm", "ctrl-c to the group", "ctrl-c as the workers start"],
)
def test_an_interrupted_parallel_sweep_answers_in_one_line_and_leaves_no_worker(
    tmp_path, name, group, early, code, line
):
    """``early``: the signal 0.3 s after the workers appear, while they load NumPy and SciPy (a second or more), before
    any result (a worker hit then wrote its traceback: it had not yet reached the line that ignores the signal)."""
    log = tmp_path / "runs.jsonl"
    env = os.environ | {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    proc = popen_in_a_terminal_session(
        [sys.executable, "-m", "steam_ref", *ARGV, "--log", str(log)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    started: list[int] = []
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:  # until the workers run and a result is in the file
            started = descendants(proc.pid)
            if len(_workers(started)) == 2 and (early or (log.exists() and log.read_text().count("\n") >= 2)):
                break
            assert proc.poll() is None, "the sweep ended before it could be stopped"
            time.sleep(0.05)
        else:
            pytest.fail("no result within 60 s")
        time.sleep(0.3 if early else 0)
        started = descendants(proc.pid)  # the workers and the resource trackers
        signal_number = getattr(signal, name)
        if group:
            os.killpg(proc.pid, signal_number)
        else:
            proc.send_signal(signal_number)
        _, err = proc.communicate(timeout=60)
        left = left_running(started)
    finally:
        clean_up(proc, started)
    assert (proc.returncode, err) == (code, line + "\n")
    assert left == [], f"worker processes still running after {name}: {left}"
    study = _study(build_parser("consistency").parse_args(ARGV))
    done = read_results(log, study.describe(), functools.partial(check_result, study))
    if early:
        return  # the study line alone, read back
    assert done, "no result kept"
    first = min(done, key=int)
    assert done[first] == run_seed(study, int(first))  # the seed's serial run, in this process
