"""One BLAS thread for the solvers' small dense algebra, unless the user asks for more.

The solvers' dense work is many small blocks: a clique's frontal and separator blocks (a few states
wide), a factor's 3×6 Jacobians, a 6×6 transition. A multi-threaded BLAS (OpenBLAS, MKL) and OpenMP wake
their threads for each call and spend longer handing the work out than doing it: the fixed-lag Plaza run
took several times longer with OpenBLAS's default threads than with one (docs/experiments.md, "BLAS
threads: fast by default", has the figures). So every entry point of the solvers runs its work under a
thread limit, through :mod:`threadpoolctl` (the one module that sets it):

- :func:`limited`, a decorator on the entry points (``gauss_newton``, ``levenberg_marquardt``,
  ``IncrementalSolver.update``, ``FixedLagSmoother.update``, ``finish_at_optimum``, the covariance queries,
  the paper's runs) and
  :func:`limit`, the same as a ``with`` block (every CLI command that solves). The limit is entered once, by
  the outermost call, and restored when that call returns; a nested entry (``update`` inside a stream, a
  covariance query inside ``update``) costs a counter check, a top-level one the limit's setting, both small
  next to an update (``tests/test_threads.py`` measures both; docs/experiments.md has the figures).
- The number of threads: ``$STEAM_REF_BLAS_THREADS`` when set (a whole number from 1 to :data:`MOST_THREADS`,
  written in ASCII digits as every number the command reads; ``0`` leaves the BLAS and OpenMP as they are,
  threads chosen by their own variables), else 1. Read at each outermost entry.
- :func:`blas_threads`, the opt-out in code: ``with steam_ref.blas_threads(4): ...`` runs the solvers
  called inside with 4 threads (any integer, NumPy's included), ``blas_threads(None)`` leaves the BLAS as it
  is. The entry points called inside it do not change the limit.

The libraries are those loaded when the limit is entered (numpy's and scipy's OpenBLAS, CHOLMOD's
OpenMP); the scan behind it (threadpoolctl's ``ThreadpoolController``, the slow part) is kept, and redone
only when a module has been imported since. The limit is process-wide (OpenBLAS has one thread count), so
it is counted process-wide: the first entry in any thread sets it, the last exit restores it.

threadpoolctl is a dependency of steam_ref; where it is missing anyway (a hand-made environment), the
solvers run with the BLAS as it is, and the first limit says so once (a :class:`~steam_ref.errors.SteamWarning`):
the estimates are the same, only the time differs.
"""

from __future__ import annotations

import functools
import os
import sys
import threading
import warnings
from collections.abc import Callable
from types import TracebackType
from typing import Any, TypeVar

from ..arguments import is_integer, parse_decimal
from ..errors import SteamError, SteamWarning

__all__ = ["ENV_VAR", "MOST_THREADS", "blas_threads", "configured_threads", "limit", "limited"]

ENV_VAR = "STEAM_REF_BLAS_THREADS"
MOST_THREADS = 4096  # more BLAS threads than this is a typo (a count beyond a C int was a ctypes OverflowError)
F = TypeVar("F", bound=Callable[..., Any])

_lock = threading.Lock()
_depth = 0  # entries of limit()/blas_threads() still open, in any thread
_active: Any = None  # the _Limit set by the outermost entry (None: it left the BLAS alone)
_controller: Any = None  # threadpoolctl.ThreadpoolController, kept while no module is imported
_n_modules = -1  # len(sys.modules) when _controller scanned the loaded libraries
_missing_said = False  # whether the missing threadpoolctl has been warned of (once per process)


def configured_threads() -> int | None:
    """The BLAS/OpenMP threads the solvers run with: ``$STEAM_REF_BLAS_THREADS`` (``0``: None, leave them
    as they are), 1 when it is unset or empty. Raises :class:`SteamError` naming a value that is not a
    whole number from 0 to :data:`MOST_THREADS` in ASCII digits (``٣`` and ``1_0`` are refused, as the
    command's options refuse them: :func:`~steam_ref.arguments.parse_decimal`)."""
    raw = os.environ.get(ENV_VAR, "").strip()
    if not raw:
        return 1
    n = parse_decimal(raw, int)
    if n is None or not 0 <= n <= MOST_THREADS:
        raise SteamError(
            f"${ENV_VAR}={raw!r}: expected a whole number of BLAS threads from 1 to {MOST_THREADS:,}, or 0 to leave "
            "the BLAS as it is"
        )
    return int(n) or None


def _checked(n: object) -> int | None:
    if n is None:
        return None
    if not is_integer(n) or not 1 <= n <= MOST_THREADS:
        raise SteamError(
            f"blas_threads: expected a whole number of threads from 1 to {MOST_THREADS:,}, or None, got {n!r}"
        )
    return int(n)


def _controller_now() -> Any:
    """threadpoolctl's controller of the libraries loaded now (scanned again only after an import), or None
    when threadpoolctl is missing (said once)."""
    global _controller, _n_modules, _missing_said
    if _controller is None or len(sys.modules) != _n_modules:
        try:
            from threadpoolctl import ThreadpoolController
        except ImportError:
            if not _missing_said:
                _missing_said = True
                warnings.warn(
                    "threadpoolctl (a dependency of steam_ref) is not installed: the solvers run with the BLAS's own "
                    f"threads, not the {ENV_VAR} limit; the estimates are the same, the time may not be "
                    "(pip install threadpoolctl)",
                    SteamWarning,
                    stacklevel=5,
                )
            return None
        _controller, _n_modules = ThreadpoolController(), len(sys.modules)
    return _controller


class _Limit:
    """``n`` threads for every BLAS and OpenMP library loaded now, each library's own count kept to restore
    (none without threadpoolctl).

    Through threadpoolctl's per-library controllers (``get_num_threads`` / ``set_num_threads``), not
    ``ThreadpoolController.limit``, which also reads every library's version and architecture, at about three
    times the cost (docs/experiments.md)."""

    __slots__ = ("_saved",)

    def __init__(self, n: int) -> None:
        controller = _controller_now()
        self._saved = [] if controller is None else [(lib, lib.get_num_threads()) for lib in controller.lib_controllers]
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
