"""The solvers' BLAS thread limit (steam_ref.linear.threads): one thread inside every entry point by
default, as seen by threadpoolctl from inside the work; ``$STEAM_REF_BLAS_THREADS`` and
``steam_ref.blas_threads`` opt out; the BLAS is as it was after the call; entering is cheap.

Each test starts the BLAS at 2 threads (a multi-threaded BLAS's default on the 2-core machine), so a
solver that did not limit it would be seen at 2.
"""

from __future__ import annotations

import os
import sys
import time
import warnings

import numpy as np
import pytest
from cli_runs import run_module
from threadpoolctl import threadpool_info, threadpool_limits

import steam_ref as sr
from steam_ref import covariance
from steam_ref.cli.commands import main
from steam_ref.errors import SteamError
from steam_ref.linear import threads

MANY = 2  # what the BLAS starts at in these tests


def blas_threads_now() -> set[int]:
    return {int(i["num_threads"]) for i in threadpool_info() if i["user_api"] == "blas"}


@pytest.fixture
def start_at_many(monkeypatch):
    """The BLAS at MANY threads, no $STEAM_REF_BLAS_THREADS; restored after the test."""
    monkeypatch.delenv(threads.ENV_VAR, raising=False)
    with threadpool_limits(limits=MANY, user_api="blas"):
        assert blas_threads_now() == {MANY}
        yield


@pytest.fixture
def seen(monkeypatch) -> list[set[int]]:
    """The BLAS threads in force each time a PriorFactor's error is evaluated (inside the solvers)."""
    record: list[set[int]] = []
    original = sr.PriorFactor.error

    def spy(self, *xs, **kwargs):
        record.append(blas_threads_now())
        return original(self, *xs, **kwargs)

    monkeypatch.setattr(sr.PriorFactor, "error", spy)
    return record


def prior_problem() -> tuple[list[sr.Factor], dict]:
    """Two states and a landmark, each with a prior, and a range between them: a well-posed problem."""
    factors = [
        sr.PriorFactor.create(sr.X(0), np.zeros(6), 0.1),
        sr.PriorFactor.create(sr.L(0), np.array([3.0, 4.0]), 0.5),
        sr.RangeFactor.create(sr.X(0), sr.L(0), 5.1, 0.2),
    ]
    return factors, {sr.X(0): np.full(6, 0.01), sr.L(0): np.array([3.1, 3.9])}


def run_each_entry_point() -> None:
    factors, values = prior_problem()
    sr.gauss_newton(sr.FactorGraph(factors), sr.Values(values))
    sr.levenberg_marquardt(sr.FactorGraph(factors), sr.Values(values))
    sr.IncrementalSolver().update(factors, values)
    sr.FixedLagSmoother(lag=10.0).update(factors, values, timestamps={sr.X(0): 0.0})


def test_every_solver_entry_point_runs_with_one_blas_thread(start_at_many, seen):
    run_each_entry_point()
    assert len(seen) >= 4 and all(s == {1} for s in seen), seen
    assert blas_threads_now() == {MANY}  # as it was, after each call


class _LapackSpy:
    """scipy.linalg.lapack, recording the BLAS threads at each routine looked up through it."""

    def __init__(self, record: list[set[int]]) -> None:
        self.record = record

    def __getattr__(self, name: str):
        from scipy.linalg import lapack

        self.record.append(blas_threads_now())
        return getattr(lapack, name)


def test_a_covariance_query_runs_with_one_blas_thread(start_at_many, monkeypatch):
    factors, values = prior_problem()
    solver = sr.IncrementalSolver()
    with threads.blas_threads(1):
        solver.update(factors, values)
    record: list[set[int]] = []
    monkeypatch.setattr(covariance, "lapack", _LapackSpy(record))
    solver.marginal_covariance(sr.X(0))
    solver.joint_covariance([sr.X(0), sr.L(0)])
    assert record and all(s == {1} for s in record), record
    assert blas_threads_now() == {MANY}


def test_the_environment_variable_sets_the_threads_and_zero_leaves_the_blas_alone(start_at_many, seen, monkeypatch):
    monkeypatch.setenv(threads.ENV_VAR, "2")
    with threadpool_limits(limits=1, user_api="blas"):  # started at 1, so 2 is the variable's doing
        run_each_entry_point()
    assert seen and all(s == {2} for s in seen), seen
    seen.clear()
    monkeypatch.setenv(threads.ENV_VAR, "0")  # the BLAS left as it is: at MANY
    run_each_entry_point()
    assert seen and all(s == {MANY} for s in seen), seen


def test_blas_threads_opts_out_in_code_and_the_entry_points_inside_it_keep_it(start_at_many, seen):
    with sr.blas_threads(None):
        run_each_entry_point()
    assert seen and all(s == {MANY} for s in seen), seen
    seen.clear()
    with sr.blas_threads(1):
        assert blas_threads_now() == {1}
        with sr.blas_threads(2):  # inside a limit, an explicit choice still applies, until its end
            run_each_entry_point()
        assert blas_threads_now() == {1}
    assert seen and all(s == {2} for s in seen), seen
    assert blas_threads_now() == {MANY}


def test_the_limit_is_restored_after_an_error(start_at_many):
    with pytest.raises(SteamError):
        sr.IncrementalSolver().update([sr.PriorFactor.create(sr.X(0), np.zeros(6), 0.1)], {})  # no value for X(0)
    assert blas_threads_now() == {MANY}
    assert threads._depth == 0


@pytest.mark.parametrize("bad", ["-1", "two", "1.5", "99999999999999999999", "4097", "\u0663", "\uff13", "1_0"])
def test_a_bad_environment_value_is_named(monkeypatch, bad):
    """Beyond a C int was ctypes' OverflowError; '٣' (Arabic-Indic 3) and '３' (full-width) were read as 3,
    where every option of the command refuses them."""
    monkeypatch.setenv(threads.ENV_VAR, bad)
    with pytest.raises(SteamError, match=f"STEAM_REF_BLAS_THREADS={bad!r}"):
        sr.IncrementalSolver().update(*prior_problem())
    assert threads._depth == 0


@pytest.mark.parametrize("bad", [0, -2, 1.0, True, "1", np.float64(2.0), np.bool_(True), 4097, 2**64])
def test_blas_threads_rejects_what_is_not_a_count(bad):
    with pytest.raises(SteamError, match="blas_threads"):
        sr.blas_threads(bad)


def test_blas_threads_takes_a_numpy_integer(start_at_many, seen):
    with threadpool_limits(limits=1, user_api="blas"), sr.blas_threads(np.int64(2)):
        run_each_entry_point()
    assert seen and all(s == {2} for s in seen), seen


@pytest.mark.parametrize("bad", ["many", "99999999999999999999", "\u0663"])
def test_the_cli_names_a_bad_environment_value_in_one_line(bad):
    out = run_module("run", "--steps", "20", "--json", env=os.environ | {"STEAM_REF_BLAS_THREADS": bad}, timeout=120)
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert out.stderr.strip().count("\n") == 0 and f"STEAM_REF_BLAS_THREADS={bad!r}" in out.stderr


def test_a_command_that_never_solves_does_not_read_the_variable(monkeypatch, capsys):
    monkeypatch.setenv(threads.ENV_VAR, "many")
    assert main(["data", "list"]) == 0, capsys.readouterr().err
    assert main(["run", "--steps", "5"]) == 2  # one that solves refuses it before the run
    assert "STEAM_REF_BLAS_THREADS='many'" in capsys.readouterr().err


def test_without_threadpoolctl_the_solvers_run_unlimited_and_say_so_once(monkeypatch):
    monkeypatch.setitem(sys.modules, "threadpoolctl", None)  # its import fails, as when it is not installed
    monkeypatch.setattr(threads, "_controller", None)
    monkeypatch.setattr(threads, "_missing_said", False, raising=False)
    factors, values = prior_problem()
    first, second = sr.IncrementalSolver(), sr.IncrementalSolver()
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        first.update(factors, values)
        second.update(factors, values)
    assert len(said) == 1 and issubclass(said[0].category, sr.SteamWarning)  # once, not at every solve
    assert str(said[0].message).startswith("threadpoolctl (a dependency of steam_ref) is not installed")
    assert threads._depth == 0
    monkeypatch.undo()  # the same estimate with the limit
    limited = sr.IncrementalSolver()
    limited.update(factors, values)
    for key in values:
        np.testing.assert_array_equal(first.estimate_of(key), limited.estimate_of(key))


def test_entering_costs_microseconds_and_a_nested_entry_next_to_nothing(start_at_many):
    """An update takes a few tenths of a millisecond at the least; the limit around it must not be measurable
    next to that. Each figure is the least over batches (another process's load only adds time)."""
    factors, values = prior_problem()
    sr.IncrementalSolver().update(factors, values)  # the libraries scanned once
    noop = threads.limited(lambda: None)

    def per_call(n: int = 100) -> float:
        t0 = time.perf_counter()
        for _ in range(n):
            noop()
        return (time.perf_counter() - t0) / n

    top = min(per_call() for _ in range(20))
    with sr.blas_threads(1):
        nested = min(per_call() for _ in range(20))
    solver = sr.IncrementalSolver()
    solver.update(factors, values)
    seconds = []
    for i in range(1, 21):  # the smallest update there is: one new state with its own prior
        t0 = time.perf_counter()
        solver.update([sr.PriorFactor.create(sr.X(i), np.zeros(6), 0.1)], {sr.X(i): np.zeros(6)})
        seconds.append(time.perf_counter() - t0)
    update = float(np.median(seconds))
    assert nested < 2e-6, nested
    assert top < 5e-5, top  # ~5-15 µs
    assert top < 0.05 * update, (top, update)
