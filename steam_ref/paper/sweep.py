"""Independent runs (seeds, Qc, skip, every) in parallel, on this machine or a Dask cluster, resumable.

:func:`run_sweep` calls ``function(item)`` for every item (a JSON value: an index, a dict of
parameters) through joblib: loky worker processes by default, or joblib's ``dask`` backend on a
``dask.distributed`` cluster (``scheduler`` its address; without one, a ``LocalCluster`` on 127.0.0.1 with
``jobs`` single-threaded workers). The code a run executes is the same either way, so are its results.

- **Threads**: each call runs under ``blas_threads(1)`` (:mod:`steam_ref.linear.threads`) — one BLAS thread
  per worker whatever ``$STEAM_REF_BLAS_THREADS`` says, so ``jobs`` workers use ``jobs`` cores and never
  oversubscribe them.
- **Seeds**: a study spawns them, ``np.random.SeedSequence(seed).spawn(n)``; item i uses child i
  (``SeedSequence(seed, spawn_key=(i,))`` is the same child), so a run's draws depend on its index only,
  never on which worker ran it or in what order.
- **Streaming and resuming**: each result is appended to a JSONL file as it arrives (one line
  ``{"item": ..., "result": ...}``, flushed) after a first line ``{"study": ...}`` describing the study.
  ``resume=True`` reads the file back, checks it was written by the same study, and runs only the items
  it lacks; a last line cut short by an interruption is ignored (and left in the file, followed by a line
  break), any other unreadable line is an error naming it: text that is not UTF-8 or not JSON (or JSON past Python's reader's limits), a line
  without ``item`` and ``result``, or a result that ``check`` (the caller's test of one result) refuses.
  An item on two lines is refused, naming both, unless the two lines are the same result (a run repeated
  after an interruption gives the same figures, seed for seed): a result is never picked by its position.
- **Dask**: a ``scheduler`` address is checked before any work (``host:port`` or ``tcp://host:port``);
  a log that already holds every item runs nothing and starts no cluster.
- **Interrupts**: only this process answers Ctrl-C or SIGTERM (a terminal's Ctrl-C and ``timeout``'s SIGTERM
  reach the whole process group): the worker processes it starts inherit both held (:func:`_held`), so none
  is hit while it starts, then ignore both (loky's through :func:`_worker_start`, a local Dask cluster's through
  :func:`dask_setup`), and the interrupt that stops the sweep
  kills its loky workers and waits for them (joblib's generator closed), or closes the Dask cluster, before it
  goes on to the caller, a second one meanwhile held until they are gone. So the command's one line is all
  stderr gets: no worker's traceback, no resource tracker's warning of a semaphore left behind (a worker's bars
  lock with a thread lock, :func:`~steam_ref.paper.progress.drawn_here_only`; the feeder threads of the queues
  the stop closed are waited for, :func:`_stop`), no worker left running. The
  results already logged stay, and resuming runs the rest.
"""

from __future__ import annotations

import contextlib
import json
import logging
import os
import re
import signal
import sys
import threading
import time
import warnings
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

from ..arguments import is_integer
from ..errors import DataError, SteamError
from ..linear.threads import blas_threads
from . import progress

__all__ = ["BACKENDS", "run_sweep", "read_results"]

BACKENDS = ("loky", "dask")


def _limited(function: Callable[[Any], Any], item: Any) -> tuple[Any, Any]:
    """``function(item)`` with one BLAS/OpenMP thread; returns (item, result)."""
    with blas_threads(1):
        return item, function(item)


# The signals a command answers (Ctrl-C; SIGTERM from kill, timeout or a batch scheduler): its parent process alone.
_INTERRUPTS = (signal.SIGINT, signal.SIGTERM)


def _worker_start() -> None:
    """What a loky worker process does first: ignore Ctrl-C and SIGTERM (the parent answers them and kills its
    workers), and lock its bars with a thread lock (a semaphore would outlive the worker it is killed with)."""
    for interrupt in _INTERRUPTS:
        signal.signal(interrupt, signal.SIG_IGN)
    progress.drawn_here_only()


def dask_setup(worker: Any) -> None:  # noqa: ARG001 (Dask's preload hook: called with the worker)
    """The preload of a local Dask cluster's worker processes (Dask calls a preloaded module's ``dask_setup``, in
    the worker process's main thread): as :func:`_worker_start` for loky's."""
    _worker_start()


@contextlib.contextmanager
def _held() -> Iterator[None]:
    """Ctrl-C and SIGTERM held while the block runs, then delivered: a process started meanwhile inherits them held
    (a worker, hit as it starts, would write its traceback), and one stopping the workers cannot be cut short (a
    worker left running). In the main thread only, where Python runs its signal handlers."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.pthread_sigmask(signal.SIG_BLOCK, _INTERRUPTS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


def _start_trackers() -> None:
    """The resource trackers of multiprocessing and loky started, if they are not: starting one unblocks Ctrl-C and
    SIGTERM in the thread that starts it (the tracker ignores both), so they are started before the signals are held
    for the workers' start (:func:`_held`), and every worker starts with both held from its first line."""
    from multiprocessing import resource_tracker

    from joblib.externals.loky.backend import resource_tracker as loky_tracker

    resource_tracker.ensure_running()
    loky_tracker.ensure_running()


# How long stopping a sweep waits for the feeder threads of the queues it closed (they end in milliseconds).
_FEEDER_WAIT_S = 1.0


def _stop(outputs: Any) -> None:
    """Stop a sweep that will not be read to its end: joblib's generator closed, which kills its loky workers and
    waits for them; its warning that the runs not read were cancelled says what the caller asked for.

    Then the feeder threads of the queues that closes are waited for (:data:`_FEEDER_WAIT_S` in all). Loky does not
    join the feeder of a queue this process made, so one can still be finishing when the command exits; that
    daemon thread then drops the last reference to its queue during the interpreter's shutdown, the queue's lock
    is unlinked there but its tracker is never told, and the tracker's warning of a "leaked semlock" followed the
    command's one line (one Ctrl-C in ~14, ``tests/test_interrupted_parallel_sweep.py``). A feeder of another
    queue of the caller's, still open, costs that wait once."""
    with _held(), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        outputs.close()
        deadline = time.monotonic() + _FEEDER_WAIT_S
        for thread in threading.enumerate():
            if thread.name == "QueueFeederThread" and thread is not threading.current_thread():
                thread.join(max(0.0, deadline - time.monotonic()))


def _key(item: Any) -> str:
    return json.dumps(item, sort_keys=True)


def _text_of(path: str | os.PathLike) -> str:
    """The file's text; DataError naming the file when it cannot be read (a folder, missing, not readable) and the
    line of a byte that is not UTF-8."""
    try:
        raw = Path(path).read_bytes()
    except IsADirectoryError:
        raise DataError(f"{path}: a folder, not a results file; give the JSONL file a sweep wrote") from None
    except OSError as err:
        raise DataError(f"{path}: cannot read it ({err.strerror or err})") from None
    try:
        return raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[: exc.start].count(b"\n") + 1
        raise DataError(f"{path}, line {line}: byte {raw[exc.start]:#04x} is not UTF-8 text") from None


def _json(text: str) -> tuple[Any, str]:
    """(the JSON value of one line, "") or (None, what is wrong with it): not JSON, an integer past Python's digit
    limit, nesting past its recursion limit. Never raises: a line is judged by its caller, naming file and line."""
    try:
        return json.loads(text), ""
    except json.JSONDecodeError as err:
        return None, f"not JSON ({err.msg})"
    except ValueError:  # an integer of more than sys.get_int_max_str_digits() digits
        return None, f"not readable JSON (an integer of more than {sys.get_int_max_str_digits()} digits)"
    except RecursionError:
        return None, "not readable JSON (nested deeper than the reader's recursion limit)"


def read_results(
    path: str | os.PathLike, study: dict, check: Callable[[Any, Any], None] | None = None
) -> dict[str, Any]:
    """The results a JSONL file holds, by item (its JSON text): DataError naming the file, and the line, when the
    file cannot be read (a folder, missing, not readable), its first line is not a study line or was written by
    another study, it has an unreadable line other than a last one cut short (not JSON, JSON of another shape, an
    integer or a nesting past what Python's reader takes), a result ``check(item, result)`` refuses (it raises
    SteamError saying why), or an item on two lines with different results."""
    lines = _text_of(path).split("\n")
    if not lines or not lines[0].strip():
        raise DataError(f"{path}: empty, no study line; remove it or give another file")
    head, wrong = _json(lines[0])
    if wrong or not isinstance(head, dict) or "study" not in head:
        what = wrong or f"{json.dumps(head)[:80]}, not an object holding 'study'"
        raise DataError(f"{path}, line 1: not a study line: {what}; give the JSONL file a sweep wrote")
    if head["study"] != json.loads(json.dumps(study)):
        raise DataError(
            f"{path} was written by another study ({json.dumps(head['study'])[:200]}); "
            f"this one is {json.dumps(study)[:200]}: give another file"
        )
    done: dict[str, Any] = {}
    seen: dict[str, int] = {}  # item → the line it was read from
    last = len(lines) - 1  # the text after the final line break ('' when the file ends with one)
    for number, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        row, wrong = _json(line)
        if not wrong and (not isinstance(row, dict) or set(row) != {"item", "result"}):
            wrong = "not an object holding 'item' and 'result'"
        if wrong:
            if number - 1 == last:  # cut short while being written: that item runs again
                continue
            raise DataError(f"{path}, line {number}: not a result line ({line[:80]!r}): {wrong}")
        key = _key(row["item"])
        if check is not None:
            try:
                check(row["item"], row["result"])
            except SteamError as err:
                raise DataError(f"{path}, line {number}: item {key[:40]}: {err}") from None
        if key in done and _key(done[key]) != _key(row["result"]):
            raise DataError(
                f"{path}, lines {seen[key]} and {number}: item {key[:40]} has two different results; "
                "remove the wrong one (a result is never picked by its position)"
            )
        done[key], seen[key] = row["result"], seen.get(key, number)
    return done


def _open_log(
    path: Path, study: dict, resume: bool, check: Callable[[Any, Any], None] | None
) -> tuple[dict[str, Any], Any]:
    """(results already there, the file opened for appending)."""
    if path.exists() and path.stat().st_size > 0:
        if not resume:
            raise SteamError(f"{path} exists: pass resume to continue it, or give a new file (nothing is overwritten)")
        done = read_results(path, study, check)
        log = open(path, "a")  # noqa: SIM115 - closed by run_sweep
        if not path.read_text().endswith("\n"):
            log.write("\n")  # a line cut short stays alone on its line
        return done, log
    log = open(path, "w")  # noqa: SIM115 - closed by run_sweep
    log.write(json.dumps({"study": study}) + "\n")
    log.flush()
    return {}, log


def run_sweep(
    function: Callable[[Any], Any],
    items: Iterable[Any],
    *,
    jobs: int = 1,
    backend: str = "loky",
    scheduler: str | None = None,
    log: str | os.PathLike | None = None,
    study: dict | None = None,
    resume: bool = False,
    on_result: Callable[[Any, Any], None] | None = None,
    check: Callable[[Any, Any], None] | None = None,
) -> dict[str, Any]:
    """``function(item)`` for every item, in parallel; returns {item's JSON text: result}.

    ``function`` must be picklable (a module-level function, or a ``functools.partial`` of one); with a
    ``log`` it must return JSON values (a result that is not is refused, naming its item), without one any
    picklable result comes back as it is. ``log``: the JSONL file results stream to (``study`` its first line); ``resume``: continue
    it, running only the items it lacks, each result read back passed to ``check(item, result)`` (which
    raises SteamError to refuse it). ``on_result(item, result)`` is called as each result arrives.
    """
    import joblib

    if backend not in BACKENDS:
        raise SteamError(f"backend must be one of {', '.join(BACKENDS)}, got {backend!r}")
    if not is_integer(jobs) or jobs < 1:
        raise SteamError(f"jobs must be a positive integer, got {jobs!r}")
    if scheduler is not None and backend != "dask":
        raise SteamError("a scheduler address needs the dask backend (--backend dask)")
    if scheduler is not None:
        _check_address(scheduler)
    items = list(items)
    done: dict[str, Any] = {}
    stream = None
    if log is not None:
        done, stream = _open_log(Path(log), study or {}, resume, check)
    todo = [item for item in items if _key(item) not in done]
    results = {k: v for k, v in done.items() if k in {_key(i) for i in items}}
    cluster = client = None
    try:
        if not todo:  # every item is in the log: nothing to run, no cluster (joblib's dask backend needs one)
            return results
        parallel = backend == "dask" or min(jobs, len(todo)) > 1  # else joblib runs each item here, one by one
        if parallel:
            _start_trackers()
        if backend == "dask":
            with _held() if scheduler is None else contextlib.nullcontext():  # a local cluster's start: as loky's
                client, cluster = _dask_client(scheduler, jobs)
        config = (
            joblib.parallel_config(backend="dask")
            if backend == "dask"
            else joblib.parallel_config("loky", initializer=_worker_start)
        )
        with config:
            workers = min(jobs, len(todo)) if backend == "loky" else -1  # no idle worker started for nothing
            run = joblib.Parallel(n_jobs=workers, return_as="generator_unordered")
            outputs = None
            try:
                # the workers start here, inheriting the signals held: none is hit as it starts (when they run here,
                # nothing is held: Ctrl-C stops the first run as any other)
                with _held() if parallel else contextlib.nullcontext():
                    outputs = run(joblib.delayed(_limited)(function, item) for item in todo)
                for item, result in outputs:
                    results[_key(item)] = result
                    if stream is not None:
                        stream.write(_line(item, result) + "\n")  # a result that is not JSON is refused
                        stream.flush()
                    if on_result is not None:
                        on_result(item, result)
            except BaseException:  # Ctrl-C, SIGTERM or an error, wherever it landed: no run goes on
                if outputs is not None:
                    _stop(outputs)
                raise
    finally:
        if stream is not None:
            stream.close()
        with _held():
            if client is not None:
                client.close()
            if cluster is not None:
                cluster.close()
    return results


# host:port, optionally tcp:// or tls://; a host is a name, an IPv4 address or a bracketed IPv6 one
_ADDRESS = re.compile(r"(?:(?:tcp|tls)://)?(?:\[[0-9A-Fa-f:.]+\]|[A-Za-z0-9](?:[A-Za-z0-9.-]*[A-Za-z0-9])?):(\d{1,5})")


def _check_address(scheduler: object) -> None:
    """SteamError naming ``scheduler`` when it is not a Dask scheduler's address (host:port)."""
    match = _ADDRESS.fullmatch(scheduler) if isinstance(scheduler, str) else None
    if match is None or not 0 < int(match.group(1)) < 65536:
        raise SteamError(
            f"--scheduler {scheduler!r} is not a Dask scheduler's address: give host:port or tcp://host:port "
            "(e.g. tcp://127.0.0.1:8786)"
        )


def _line(item: Any, result: Any) -> str:
    """The log line of one result; SteamError naming the item when the result is not made of JSON values."""
    try:
        return json.dumps({"item": item, "result": result})
    except (TypeError, ValueError) as err:
        raise SteamError(
            f"the result for item {item!r} is not JSON ({err}): the function must return JSON values"
        ) from None


def _dask_client(scheduler: str | None, jobs: int):
    """(client, cluster): a client of the scheduler at ``scheduler``, or of a new LocalCluster on
    127.0.0.1 with ``jobs`` single-threaded worker processes (cluster None when given an address)."""
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise SteamError("--backend dask needs dask.distributed: pip install 'steam_ref[dask]'") from None
    if scheduler is not None:
        try:
            return Client(scheduler, timeout=10), None
        except (OSError, TimeoutError, ValueError) as err:
            raise SteamError(f"cannot reach the Dask scheduler at {scheduler!r} ({err})") from None
    cluster = LocalCluster(  # its workers preload this module: dask_setup; its warnings (a task cancelled) unsaid
        n_workers=jobs, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None,
        preload=[__name__], silence_logs=logging.ERROR,
    )  # fmt: skip
    return Client(cluster), cluster
