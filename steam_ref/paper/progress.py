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
"""

from __future__ import annotations

import contextlib
import sys
import threading
from collections.abc import Iterator
from typing import Any

__all__ = ["bar", "say", "stream_label", "wanted", "working"]


def wanted(asked: bool | None, json_output: bool = False) -> bool:
    """``--progress`` / ``--no-progress`` if given, else on when stderr is a terminal and not ``--json``."""
    if asked is not None:
        return asked
    return not json_output and sys.stderr.isatty()


def stream_label(dataset: str | None, method: str, every: int, skip: int = 1, interpolate: bool = True) -> str:
    """'plaza PB/1', 'synthetic BTGP/10 skip 5 not interpolated': the data set (when known), the method and
    its schedule, and the layout when states are ``skip`` poses apart."""
    run = f"{method.upper()}/{every}"
    if skip > 1:
        run += f" skip {skip} {'interpolated' if interpolate else 'not interpolated'}"
    return f"{dataset} {run}" if dataset else run


def bar(total: int | None, label: str, enabled: bool, unit: str = "it") -> Any:
    """A tqdm bar on stderr named ``label``, refreshed at most twice a second; a silent one when not
    ``enabled``."""
    from tqdm import tqdm

    return tqdm(total=total, desc=label, disable=not enabled, mininterval=0.5, file=sys.stderr, unit=unit)


def say(line: str, enabled: bool) -> None:
    """``line`` on stderr, beside any bar (tqdm.write keeps the bar below it), when ``enabled``."""
    if enabled:
        from tqdm import tqdm

        tqdm.write(line, file=sys.stderr)


@contextlib.contextmanager
def working(what: str, enabled: bool) -> Iterator[None]:
    """A progress line on stderr, ``what`` and the elapsed time, refreshed twice a second while the block runs."""
    if not enabled:
        yield
        return
    from tqdm import tqdm

    done = threading.Event()
    with tqdm(desc=what, total=None, bar_format="{desc}: {elapsed}", file=sys.stderr, leave=False) as line:
        thread = threading.Thread(target=lambda: [line.refresh() for _ in iter(lambda: done.wait(0.5), True)])
        thread.daemon = True
        thread.start()
        try:
            yield
        finally:
            done.set()
            thread.join()
