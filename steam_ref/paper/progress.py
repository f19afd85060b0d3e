"""What a long command shows while it works: a progress bar or line on stderr, and what each says.

The one home of progress display; every command that can run longer than a few seconds uses it (``run``,
``batch``, ``fidelity``, ``reproduce``, ``consistency``, ``conformance selftest --paper``):

- :func:`wanted`: ``--progress`` / ``--no-progress`` when given, else on when stderr is a terminal and the
  output is not ``--json`` (so a pipe, a log file or CI gets no bar).
- :func:`stream_label`: what a streamed run's bar is called: the data set, the method and its schedule
  ('/1', '/10'), and the layout when it is not a state at every pose — ``plaza PB/1``,
  ``paper-synthetic BTGP/1 skip 5 interpolated``.
- :func:`bar`: a counting bar (tqdm) with that label; :func:`say`: a line beside it, e.g. when a time budget
  cuts a run short (``plaza PB/1: time budget 300 s used up after 330 of 1,000 poses; the run stops
  there``), so a bar that stops early says why.
- :func:`working`: a line with the elapsed time, for a step without a loop to count.

A progress display never costs a run: each of them writes through :func:`display`, stderr as a display
sees it, where a write that fails (stderr on a full disk, ``2>/dev/full``, or closed, ``2>&-``) is
dropped and the display goes quiet; the run goes on and writes its outputs.
"""

from __future__ import annotations

import contextlib
import sys
import threading
from collections.abc import Iterator
from typing import Any

__all__ = ["bar", "display", "drawn_here_only", "say", "stream_label", "wanted", "working"]


def wanted(asked: bool | None, json_output: bool = False) -> bool:
    """``--progress`` / ``--no-progress`` if given, else on when stderr is a terminal and not ``--json``."""
    if asked is not None:
        return asked
    try:
        return not json_output and sys.stderr is not None and sys.stderr.isatty()
    except ValueError:  # a closed stderr
        return False


def stream_label(dataset: str | None, method: str, every: int, skip: int = 1, interpolate: bool = True) -> str:
    """'plaza PB/1', 'synthetic BTGP/10 skip 5 not interpolated': the data set (when known), the method and
    its schedule, and the layout when states are ``skip`` poses apart."""
    run = f"{method.upper()}/{every}"
    if skip > 1:
        run += f" skip {skip} {'interpolated' if interpolate else 'not interpolated'}"
    return f"{dataset} {run}" if dataset else run


class _Display:
    """``stream`` as a progress display writes to it: the first write or flush that fails (OSError: a full
    disk, a closed descriptor; ValueError: a closed file) is dropped and every later one skipped."""

    def __init__(self, stream: Any) -> None:
        self.stream = stream
        self.failed = stream is None  # started with stderr closed: Python then sets sys.stderr to None

    def write(self, text: str) -> int:
        self._try(lambda: self.stream.write(text))
        return len(text)

    def flush(self) -> None:
        self._try(lambda: self.stream.flush())

    def _try(self, step: Any) -> None:
        if self.failed:
            return
        try:
            step()
        except (OSError, ValueError):
            self.failed = True

    def __getattr__(self, name: str) -> Any:  # encoding, isatty, fileno: what tqdm asks of its file
        return getattr(self.stream, name)


_shown: _Display | None = None  # the display of the last stderr seen (one per stream, so bars and lines share it)


def display() -> Any:
    """stderr as a progress display writes to it (the stream ``sys.stderr`` is now): a write that fails is
    dropped, never raised, and the display goes quiet."""
    global _shown
    if _shown is None or _shown.stream is not sys.stderr:
        _shown = _Display(sys.stderr)
    return _shown


def bar(total: int | None, label: str, enabled: bool, unit: str = "it") -> Any:
    """A tqdm bar on stderr named ``label``, refreshed at most twice a second; a silent one when not
    ``enabled``."""
    from tqdm import tqdm

    return tqdm(total=total, desc=label, disable=not enabled, mininterval=0.5, file=display(), unit=unit)


def drawn_here_only() -> None:
    """Bars in this process lock one another out with a thread lock, not tqdm's default, a multiprocessing
    semaphore: for a sweep's worker process (:mod:`steam_ref.paper.sweep`), whose bars are silent and shared with no
    other process, and which a Ctrl-C kills: a semaphore it made would be left registered with the resource tracker,
    which then warns of it on stderr after the command's one line."""
    from tqdm import tqdm

    tqdm.set_lock(threading.RLock())


def say(line: str, enabled: bool) -> None:
    """``line`` on stderr, beside any bar (tqdm.write keeps the bar below it), when ``enabled``."""
    if enabled:
        from tqdm import tqdm

        tqdm.write(line, file=display())


@contextlib.contextmanager
def working(what: str, enabled: bool) -> Iterator[None]:
    """A progress line on stderr, ``what`` and the elapsed time, refreshed twice a second while the block runs."""
    if not enabled:
        yield
        return
    from tqdm import tqdm

    done = threading.Event()
    with tqdm(desc=what, total=None, bar_format="{desc}: {elapsed}", file=display(), leave=False) as line:
        thread = threading.Thread(target=lambda: [line.refresh() for _ in iter(lambda: done.wait(0.5), True)])
        thread.daemon = True
        thread.start()
        try:
            yield
        finally:
            done.set()
            thread.join()
