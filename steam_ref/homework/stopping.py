"""Stopping marking runs at once: Ctrl-C or SIGTERM while ``steam-ref homework mark`` runs.

A run given a ``stop`` (a :class:`threading.Event`) tells :func:`started` its kernel once it is up and :func:`ended`
when it is over; :func:`stop_marking` sets the stop and kills the kernel of every run that obeys it. A kernel runs
in a session of its own, which a terminal's Ctrl-C does not reach: without this its cells would run on to their
time limits while the command waits for them.
"""

from __future__ import annotations

import threading
from typing import Any

from ..errors import SteamError

__all__ = ["Stopped", "check_stop", "stop_marking", "started", "ended"]


class Stopped(Exception):
    """A marking run ended because the ``stop`` it obeys was set (:func:`stop_marking`): it gives no mark."""


# The kernel of each marking run in progress (by the run's key), with the stop it obeys: what stop_marking kills.
_RUNS: dict[int, tuple[threading.Event, Any]] = {}
_RUNS_LOCK = threading.Lock()


def stop_marking(stop: threading.Event) -> None:
    """Set ``stop`` and kill the kernel of every run that obeys it, so that each ends at once, raising
    :class:`Stopped`; a run still starting its kernel kills it as soon as it is up. (Ctrl-C while marking: a
    kernel runs in a session of its own, which a terminal's Ctrl-C never reaches, and its cells would run on to
    their time limits.) SteamError naming ``stop`` unless it is a :class:`threading.Event`."""
    check_stop(stop)
    with _RUNS_LOCK:
        stop.set()
        kernels = [km for obeys, km in _RUNS.values() if obeys is stop]
    for km in kernels:
        _kill(km)


def check_stop(stop: object) -> None:
    """SteamError naming ``stop`` unless it is a :class:`threading.Event` (or None: a run nothing stops)."""
    if stop is not None and not isinstance(stop, threading.Event):
        raise SteamError(f"stop must be a threading.Event or None, got stop={stop!r}")


def _kill(km: Any) -> None:
    """Kill the process of a kernel manager's kernel, if it has one (from any thread)."""
    process = getattr(getattr(km, "provisioner", None), "process", None)
    if process is not None:
        process.kill()  # a no-op once it has been reaped


def started(stop: threading.Event, run: int, km: Any) -> None:
    """Run ``run``'s kernel (its manager ``km``) is up: kept for :func:`stop_marking`, or, ``stop`` already set,
    killed at once, raising :class:`Stopped`."""
    with _RUNS_LOCK:  # kept, or refused: stop_marking sets the stop and reads the runs under this lock
        stopping = stop.is_set()
        if not stopping:
            _RUNS[run] = (stop, km)
    if stopping:
        _kill(km)
        raise Stopped


def ended(run: int) -> None:
    """Run ``run`` is over (whether or not its kernel was ever up)."""
    with _RUNS_LOCK:
        _RUNS.pop(run, None)
