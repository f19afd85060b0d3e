"""The processes a test started, read from /proc (Linux; psutil is not among the test extras): a command's
descendants, and whether one still runs, so that a test can check that an interrupt left none behind."""

from __future__ import annotations

import os
import signal
import subprocess
import time
from pathlib import Path


def _children() -> dict[int, list[int]]:
    """Every process's children, by pid."""
    children: dict[int, list[int]] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            stat = (entry / "stat").read_text()
        except OSError:  # gone meanwhile
            continue
        parent = int(stat.rsplit(")", 1)[1].split()[1])  # the field after the state; the name may hold ')'
        children.setdefault(parent, []).append(int(entry.name))
    return children


def descendants(pid: int) -> list[int]:
    """The pids of a process's children, theirs, and so on."""
    children, found, todo = _children(), [], [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            found.append(child)
            todo.append(child)
    return found


def running(pid: int) -> bool:
    """The process exists and is not a zombie (ended, not yet reaped)."""
    try:
        return (Path("/proc") / str(pid) / "stat").read_text().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def command_line(pid: int) -> str:
    """The command line a process was started with, its arguments joined by spaces ("" once it is gone)."""
    try:
        return (Path("/proc") / str(pid) / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


def left_running(pids: list[int], wait_s: float = 3.0) -> list[int]:
    """Those of ``pids`` still running after up to ``wait_s`` seconds for them to end."""
    deadline = time.monotonic() + wait_s
    while any(map(running, pids)) and time.monotonic() < deadline:
        time.sleep(0.05)
    return [pid for pid in pids if running(pid)]


def clean_up(proc: subprocess.Popen, pids: list[int]) -> None:
    """Kill ``proc`` if it still runs and every one of ``pids`` that does: only what a test started, by pid."""
    if proc.poll() is None:
        proc.kill()
        proc.wait()
    for pid in pids:
        if running(pid):
            os.kill(pid, signal.SIGKILL)


def popen_in_a_terminal_session(args: list[str], **kwargs) -> subprocess.Popen:
    """``subprocess.Popen(args, **kwargs)`` in a process group of its own, as a terminal gives a command, and with
    Ctrl-C (SIGINT) at its default, as a terminal gives it. A process inherits an ignored signal: pytest started as
    a background job of a non-interactive shell (``pytest ... &`` in a script) ignores SIGINT, and so would the
    command, which then runs on after the test's Ctrl-C until the test kills it."""
    before = signal.signal(signal.SIGINT, signal.default_int_handler)  # a handler, unlike an ignore, ends at exec
    try:
        return subprocess.Popen(args, start_new_session=True, **kwargs)
    finally:
        signal.signal(signal.SIGINT, before)
