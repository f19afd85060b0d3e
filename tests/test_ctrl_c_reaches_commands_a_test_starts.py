"""The commands the interrupt tests start (tests/processes.py) hear Ctrl-C however pytest was started.

A process inherits an ignored signal: pytest run as a background job of a non-interactive shell (``pytest ... &``
in a script, where the shell ignores SIGINT for the job) ignored SIGINT, and so did every command a test started.
``steam-ref homework mark`` then ran on after the test's Ctrl-C, its cells sleeping out their minute, until the test
killed it 30 s later (returncode -9): a failure that looked like a hang in the command's own Ctrl-C path.
"""

from __future__ import annotations

import signal
import subprocess
import sys

import pytest
from processes import popen_in_a_terminal_session

SAYS = "import signal; print(signal.getsignal(signal.SIGINT))"  # Python keeps an inherited ignore: SIG_IGN


@pytest.fixture
def sigint_ignored():
    """This process ignores SIGINT, as pytest does when a script starts it with ``&``."""
    before = signal.signal(signal.SIGINT, signal.SIG_IGN)
    yield
    signal.signal(signal.SIGINT, before)


def _heard(proc: subprocess.Popen) -> str:
    out, _ = proc.communicate(timeout=60)
    return out.strip()


@pytest.mark.usefixtures("sigint_ignored")
def test_a_command_started_in_a_terminal_session_gets_ctrl_c_though_the_tests_ignore_it():
    proc = popen_in_a_terminal_session([sys.executable, "-c", SAYS], stdout=subprocess.PIPE, text=True)
    assert _heard(proc) == str(signal.default_int_handler)
    assert signal.getsignal(signal.SIGINT) == signal.SIG_IGN  # the test process is left as it was


@pytest.mark.usefixtures("sigint_ignored")
def test_a_plain_popen_passes_the_ignore_on():
    """What the interrupt tests did before: the command ignored the Ctrl-C they sent it."""
    proc = subprocess.Popen([sys.executable, "-c", SAYS], stdout=subprocess.PIPE, text=True, start_new_session=True)
    assert _heard(proc) == str(signal.SIG_IGN)
