"""One BLAS thread for the solvers' small dense algebra, unless the user asks for more.

The solvers' dense work is many small blocks: a clique's frontal and separator blocks (a few states
wide), a factor's 3×6 Jacobians, a 6×6 transition. A multi-threaded BLAS (OpenBLAS, MKL) and OpenMP wake
their threads for each call and spend longer handing the work out than doing it: on a 2-core machine the
fixed-lag Plaza run (``steam-ref run --dataset plaza --lag 60 --lag-history --max-poses 4000``) took 4.8×
longer with OpenBLAS's default threads than with ``OPENBLAS_NUM_THREADS=1``. So every entry point of the
solvers runs its work under a thread limit, through :mod:`threadpoolctl` (the one module that sets it):

- :func:`limited`, a decorator on the entry points (``gauss_newton``, ``levenberg_marquardt``,
  ``IncrementalSolver.update``, ``FixedLagSmoother.update``, ``finish_at_optimum``, the covariance queries,
  the paper's runs) and
  :func:`limit`, the same as a ``with`` block (every CLI command). The limit is entered once, by the
  outermost call, and restored when that call returns; a nested entry (``update`` inside a stream, a
  covariance query inside ``update``) costs a counter check (under a microsecond), a top-level one about
  10 µs (``tests/test_threads.py`` measures both), against an update's tenths of milliseconds or more.
- The number of threads: ``$STEAM_REF_BLAS_THREADS`` when set (a whole number ≥ 1; ``0`` leaves the BLAS
  and OpenMP as they are, threads chosen by their own variables), else 1. Read at each outermost entry.
- :func:`blas_threads`, the opt-out in code: ``with steam_ref.blas_threads(4): ...`` runs the solvers
  called inside with 4 threads, ``blas_threads(None)`` leaves the BLAS as it is. The entry points called
  inside it do not change the limit.

The libraries are those loaded when the limit is entered (numpy's and scipy's OpenBLAS, CHOLMOD's
OpenMP); the scan behind it (threadpoolctl's ``ThreadpoolController``, ~0.6 ms) is kept, and redone only
when a module has been imported since. The limit is process-wide (OpenBLAS has one thread count), so it
is counted process-wide: the first entry in any thread sets it, the last exit restores it.
"""

from __future__ import annotations

import functools
import os
import sys
import threading
from collections.abc import Callable
from types import TracebackType
from typing import Any, TypeVar

from ..errors import SteamError

__all__ = ["ENV_VAR", "blas_threads", "configured_threads", "limit", "limited"]

ENV_VAR = "STEAM_REF_BLAS_THREADS"
F = TypeVar("F", bound=Callable[..., Any])

_lock = threading.Lock()
_depth = 0  # entries of limit()/blas_threads() still open, in any thread
_active: Any = None  # the _Limit set by the outermost entry (None: it left the BLAS alone)
_controller: Any = None  # threadpoolctl.ThreadpoolController, kept while no module is imported
_n_modules = -1  # len(sys.modules) when _controller scanned the loaded libraries


def configured_threads() -> int | None:
    """The BLAS/OpenMP threads the solvers run with: ``$STEAM_REF_BLAS_THREADS`` (``0``: None, leave them
    as they are), 1 when it is unset or empty. Raises :class:`SteamError` naming a value that is not a
    whole number ≥ 0."""
    raw = os.environ.get(ENV_VAR, "").strip()
    if not raw:
        return 1
    try:
        n = int(raw)
    except ValueError:
        n = -1
    if n < 0:
        raise SteamError(
            f"${ENV_VAR}={raw!r}: expected a whole number of BLAS threads (1 or more), or 0 to leave the BLAS as it is"
        )
    return n or None


def _checked(n: object) -> int | None:
    if n is None:
        return None
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise SteamError(f"blas_threads: expected a whole number of threads (1 or more) or None, got {n!r}")
    return n


class _Limit:
    """``n`` threads for every BLAS and OpenMP library loaded now, each library's own count kept to restore.

    Through threadpoolctl's per-library controllers (``get_num_threads`` / ``set_num_threads``), ~5 µs for
    numpy's and scipy's OpenBLAS and OpenMP; ``ThreadpoolController.limit`` would also read every library's
    version and architecture, ~20 µs."""

    __slots__ = ("_saved",)

    def __init__(self, n: int) -> None:
        global _controller, _n_modules
        if _controller is None or len(sys.modules) != _n_modules:
            from threadpoolctl import ThreadpoolController

            _controller, _n_modules = ThreadpoolController(), len(sys.modules)
        self._saved = [(lib, lib.get_num_threads()) for lib in _controller.lib_controllers]
        for lib, threads in self._saved:
            if threads is not None and threads != n:  # None: a library that cannot say, left alone
                lib.set_num_threads(n)

    def restore_original_limits(self) -> None:
        for lib, threads in self._saved:
            if threads is not None and lib.get_num_threads() != threads:
                lib.set_num_threads(threads)


class _Entry:
    """One entry of the limit: the outermost sets ``threads`` (None: leaves the BLAS alone) until the last
    exit; a nested one only counts, unless ``force`` (an explicit :func:`blas_threads` inside a limited
    call), which sets its own until its exit."""

    __slots__ = ("_own", "force", "threads")

    def __init__(self, threads: int | None, force: bool = False) -> None:
        self.threads, self.force = threads, force
        self._own: Any = None  # the limiter an explicit blas_threads() set inside a limit

    def __enter__(self) -> None:
        global _depth, _active
        with _lock:
            if _depth == 0:
                _active = None if self.threads is None else _Limit(self.threads)
            elif self.force and self.threads is not None:
                self._own = _Limit(self.threads)
            _depth += 1

    def __exit__(self, kind: type[BaseException] | None, value: BaseException | None, tb: TracebackType | None) -> None:
        global _depth, _active
        with _lock:
            _depth -= 1
            if self._own is not None:  # an explicit blas_threads() inside a limited call: back to the outer limit
                self._own.restore_original_limits()
                self._own = None
            if _depth == 0 and _active is not None:  # the last exit, in any thread
                _active.restore_original_limits()
                _active = None


def limit() -> _Entry:
    """A ``with`` block running under the configured thread limit (:func:`configured_threads`), entered
    only if no limit is in force already."""
    return _Entry(configured_threads() if _depth == 0 else None)


def blas_threads(n: int | None) -> _Entry:
    """``with blas_threads(n):`` the solvers called inside run with ``n`` BLAS/OpenMP threads (None: as the
    BLAS is, with its own default or its environment variables), whatever ``$STEAM_REF_BLAS_THREADS`` says."""
    return _Entry(_checked(n), force=True)


def limited(function: F) -> F:
    """Decorator: ``function`` runs under :func:`limit` (a counter check when a limit is in force)."""

    @functools.wraps(function)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        if _depth:
            return function(*args, **kwargs)
        with _Entry(configured_threads()):
            return function(*args, **kwargs)

    return wrapper  # type: ignore[return-value]
