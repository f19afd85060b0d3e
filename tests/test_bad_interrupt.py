"""Ctrl-C inside ``IncrementalSolver.update``: any BaseException, wherever it lands, leaves
the solver exactly as a twin that never saw the update (factors, caches, tree, θ̄, δ, estimate, byte
for byte), then propagates; the next valid update then gives what an uninterrupted one gives.

Three ways in: a real SIGINT from a timer thread during a large update (where it lands is up to the
clock); a KeyboardInterrupt raised by a trace function at the n-th executed line of the update, for
lines spread over the whole update (every phase, deterministic); and a second Ctrl-C during the
rollback itself. A stream (``StreamingEstimator.step``) stopped once its front end took a pose refuses to go on,
naming the pose; stopped before, it goes on as if never stopped.
"""

from __future__ import annotations

import gc
import os
import signal
import sys
import threading
import time

import numpy as np
import pytest
from test_isam import Stream

import steam_ref
from steam_ref import L, X
from steam_ref.bayes_tree import IncrementalSolver, MarginalFactor, marginalize
from steam_ref.bayes_tree.state import SolverState
from steam_ref.bayes_tree.undo import UndoLog


def _array(a) -> tuple:
    a = np.asarray(a)
    return (a.dtype.str, a.shape, a.tobytes())


def _bytes(value) -> object:
    """A store's content as bytes, recursively (arrays by dtype, shape and data; factors by identity)."""
    if isinstance(value, np.ndarray):
        return _array(value)
    if isinstance(value, dict):
        return tuple((k, _bytes(v)) for k, v in value.items())
    if isinstance(value, (list, tuple)):
        return tuple(_bytes(v) for v in value)
    if hasattr(value, "blocks"):  # a GaussianFactor
        return (value.keys, _bytes(value.blocks), _array(value.rhs))
    if value is None or isinstance(value, (int, float, str)):
        return value
    if isinstance(value, MarginalFactor):  # made by each solver: compared by content
        return (value.keys, _array(value.A), _array(value.b), _array(value.theta0), value.dims)
    return id(value)  # a factor, a kind: the twin holds the same objects


def state(solver: IncrementalSolver) -> tuple:
    """Everything the solver holds, as bytes: every store of its one state object (SolverState.STORES, in
    order; the estimates formed first), its counters, and its tree."""
    tree = solver.tree
    cliques = tuple(
        (
            cid,
            c.frontals,
            c.separator,
            _array(c.R),
            _array(c.S),
            _array(c.d),
            c.marginal.keys,
            tuple(_array(b) for b in c.marginal.blocks),
            _array(c.marginal.rhs),
            c.factors,
            tree.parent[cid],
            tuple(tree.children[cid]),
        )
        for cid, c in sorted(tree.cliques.items())
    )
    solver.estimate()  # forms every stale estimate: the stale marks are then empty on both sides
    stores = tuple(_bytes(getattr(solver.state, name)) for name in SolverState.STORES)
    return (
        stores,
        cliques,
        tuple(tree.roots),
        tuple(sorted(tree.frontal_of.items())),
        tree._next_id,
        solver.state.steps,
        solver.state.tree_nnz,
        solver.state.n_factors,
    )


def parts(n_base: int, n_big: int, seed: int) -> tuple[list, tuple[list, dict], tuple[list, dict]]:
    """The updates that build the solver, one large update, and one more small one."""
    stream = Stream(np.random.default_rng(seed), n_base + n_big + 2, n_landmarks=20)
    base = [stream.step("state") for _ in range(n_base)]
    big_factors, big_values = [], {}
    for _ in range(n_big):
        f, v = stream.step("both")
        big_factors += f
        big_values |= v
    return base, (big_factors, big_values), stream.step("both")


def build(base: list) -> IncrementalSolver:
    solver = IncrementalSolver(relinearize_skip=1)
    for f, v in base:
        solver.update(f, v)
    return solver


@pytest.fixture(autouse=True)
def default_sigint():
    """Python's own SIGINT handler (KeyboardInterrupt), whatever the test runner installed."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def test_a_real_sigint_during_a_large_update_rolls_it_back() -> None:
    base, big, after = parts(20, 2000, seed=5)
    solver, twin, done = build(base), build(base), build(base)
    assert state(solver) == state(twin)
    t0 = time.perf_counter()
    done.update(*big)
    seconds = time.perf_counter() - t0
    done.update(*after)
    landed: list[str] = []
    for fraction in (0.02, 0.15, 0.3, 0.45, 0.6):
        timer = threading.Timer(fraction * seconds, os.kill, (os.getpid(), signal.SIGINT))
        returned = False
        # A KeyboardInterrupt raised inside a finalizer that the garbage collector runs is reported as
        # "unraisable" and lost (Python's rule, not the solver's): collect first, and not while waiting.
        gc.collect()
        gc.disable()
        try:
            timer.start()
            solver.update(*big)
            returned = True
            time.sleep(2 * seconds + 1)  # the signal lands here if the update was quicker than the clock
            pytest.fail("the SIGINT never arrived")
        except KeyboardInterrupt as interrupt:
            timer.join()
            if returned:  # the update finished first: start again from the twin's state
                solver = build(base)
                continue
            frames = [f.name for f in __import__("traceback").extract_tb(interrupt.__traceback__)]
            assert "update" in frames
            landed.append(frames[-1])
        finally:
            gc.enable()
        assert state(solver) == state(twin), f"not rolled back after a SIGINT in {landed[-1]}"
    assert len(landed) >= 3, f"only {len(landed)} of 5 interrupts landed inside the update"
    solver.update(*big)
    solver.update(*after)
    assert state(solver) == state(done)


# The package's own files: not the tests', which sit in a folder named steam_ref too when a clone keeps git's name.
PACKAGE = os.path.dirname(steam_ref.__file__) + os.sep
# The BLAS limit's lines (entered inside the update's transaction) depend on the process's history, a library
# scan cached until a module is imported, not on the update: not counted, so every run counts the same lines.
THREADS = os.path.join(PACKAGE, "linear", "threads.py")


def _ours(filename: str) -> bool:
    return filename.startswith(PACKAGE) and filename != THREADS


def _interrupt_at(n: int):
    """A trace function that raises KeyboardInterrupt at the n-th line executed (then stops tracing)."""
    count, top = 0, None

    def trace(frame, event, arg):  # counts the lines below update(): a line of its own is checks or the return
        nonlocal count, top
        if top is None and frame.f_code.co_name == "update":
            top = frame
        if event == "line" and _ours(frame.f_code.co_filename) and frame is not top:
            count += 1
            if count == n:
                raise KeyboardInterrupt(f"line {n}: {frame.f_code.co_name}")
        return trace

    return trace, lambda: count


def _lines_of_update(solver: IncrementalSolver, update: tuple[list, dict]) -> list[str]:
    """The function of each line executed below ``solver.update(*update)``, in order."""
    names: list[str] = []
    trace, _ = _interrupt_at(0)

    def record(frame, event, arg):
        out = trace(frame, event, arg)
        if event == "line" and _ours(frame.f_code.co_filename):
            names.append(frame.f_code.co_name)
        return record if out else None

    sys.settrace(record)
    try:
        solver.update(*update)
    finally:
        sys.settrace(None)
    return names


def test_an_interrupt_at_any_line_of_the_update_rolls_it_back() -> None:
    base, big, after = parts(25, 12, seed=7)
    build(base).update(*big)  # warm the process's memos (a first evaluation runs lines a second one skips)
    solver, twin, done = build(base), build(base), build(base)
    trace, lines = _interrupt_at(0)
    sys.settrace(trace)
    try:
        done.update(*big)
    finally:
        sys.settrace(None)
    total = lines()
    names = _lines_of_update(build(base), big)
    names = [n for n in names if n != "update"][:total]
    first = {name: i + 1 for i, name in reversed(list(enumerate(names)))}  # each function's first line
    last = {name: i + 1 for i, name in enumerate(names)}  # and its last
    done.update(*after)
    where = set()
    for n in sorted({*first.values(), *last.values(), *np.linspace(1, total, 60).astype(int)}):
        trace, _ = _interrupt_at(int(n))
        sys.settrace(trace)
        try:
            with pytest.raises(KeyboardInterrupt) as interrupt:
                solver.update(*big)
        finally:
            sys.settrace(None)
        where.add(str(interrupt.value).split(": ")[1])
        assert state(solver) == state(twin), f"not rolled back after {interrupt.value}"
    assert {"add_variable", "_fluid_relinearization", "eliminate_clique", "backsubstitute"} <= where
    solver.update(*big)
    solver.update(*after)
    assert state(solver) == state(done)


def test_a_second_interrupt_during_the_rollback_does_not_leave_it_half_done(monkeypatch) -> None:
    base, big, after = parts(25, 12, seed=8)
    solver, twin, done = build(base), build(base), build(base)
    done.update(*big)
    done.update(*after)
    original = UndoLog.rollback
    calls = []

    def rollback_then_interrupt(self):
        calls.append(1)
        if len(calls) == 1:  # undo half of it, then a second Ctrl-C
            for _ in range(len(self.entries) // 2):
                undo, *args = self.entries[-1]
                undo(*args)
                self.entries.pop()
            raise KeyboardInterrupt("second Ctrl-C")
        original(self)

    def fail_late(*args, **kwargs):
        raise KeyboardInterrupt("first Ctrl-C")

    monkeypatch.setattr(UndoLog, "rollback", rollback_then_interrupt)
    monkeypatch.setattr("steam_ref.bayes_tree.isam.backsubstitute", fail_late)  # after the new cliques are in
    with pytest.raises(KeyboardInterrupt, match="first Ctrl-C"):
        solver.update(*big)
    assert len(calls) == 2
    monkeypatch.undo()
    assert state(solver) == state(twin)
    solver.update(*big)
    solver.update(*after)
    assert state(solver) == state(done)


def test_factors_are_a_tuple_the_caller_cannot_edit() -> None:
    base, _, _ = parts(6, 1, seed=9)
    base, after = base[:-1], base[-1]
    solver, twin = build(base), build(base)
    assert isinstance(solver.factors, tuple)
    with pytest.raises(AttributeError):
        solver.factors.pop()  # type: ignore[attr-defined]
    solver.update(*after)
    twin.update(*after)
    assert state(solver) == state(twin)


def _lines_of(call) -> int:
    """How many steam_ref lines ``call()`` executes (the count an interrupt position runs up to)."""
    trace, lines = _interrupt_at(0)
    sys.settrace(trace)
    try:
        call()
    finally:
        sys.settrace(None)
    return lines()


@pytest.mark.parametrize("keys", [[X(0)], [X(1), X(2)], [X(12)], [X(5), L(3)], [L(4)], [L(2), L(9)]], ids=repr)
def test_an_interrupt_at_any_line_of_marginalize_leaves_the_solver_as_it_was(keys) -> None:
    """marginalize (a FixedLagSmoother's after every update) interrupted anywhere, cutting leaves off or
    re-eliminating: the solver as a twin that never saw it, byte for byte; then it marginalizes as the twin does."""
    base, _, _ = parts(16, 1, seed=11)
    solver, twin, done = build(base), build(base), build(base)
    marginalize(build(base), keys)  # the first MarginalFactor runs one-time class checks: not counted below
    for s in (solver, twin, done):
        state(s)  # forms every estimate, as each comparison below does: the runs then execute the same lines
    total = _lines_of(lambda: marginalize(done, keys))
    where = set()
    # 60 spread: 40 left every mutating step of a re-elimination unvisited for some hash seeds (set orders)
    for n in sorted({*np.linspace(1, total, 60).astype(int), *range(max(total - 40, 1), total + 1)}):  # the end changes
        trace, _ = _interrupt_at(int(n))
        sys.settrace(trace)
        try:
            with pytest.raises(KeyboardInterrupt) as interrupt:
                marginalize(solver, keys)
        finally:
            sys.settrace(None)
        where.add(str(interrupt.value).split(": ")[1])
        assert state(solver) == state(twin), f"not as it was after {interrupt.value}"
    assert "_marginalize" in where and where & {"cut", "insert_eliminated", "add", "drop_factors", "drop_variables"}, (
        where
    )
    report = marginalize(solver, keys)
    assert state(solver)[1:] == state(done)[1:]  # all but the ids of the factors: each made its MarginalFactors
    assert [None if f is None else f.keys for f in solver.factors] == [
        None if f is None else f.keys for f in done.factors
    ]
    assert report.leaves == marginalize(twin, keys).leaves


def _interrupt_in(name: str, n: int):
    """A trace function that raises KeyboardInterrupt at the n-th line executed in a function of ours named ``name``."""
    count = 0

    def trace(frame, event, arg):
        nonlocal count
        if event == "line" and frame.f_code.co_name == name and _ours(frame.f_code.co_filename):
            count += 1
            if count == n:
                raise KeyboardInterrupt(f"line {n} of {name}: {frame.f_code.co_filename}:{frame.f_lineno}")
        return trace

    return trace


@pytest.mark.parametrize("call", ["update", "marginalize"])
def test_an_interrupt_as_a_transaction_begins_or_commits_leaves_the_next_one_undoable(call) -> None:
    """Ctrl-C on each line of the transactions' own bookkeeping (the undo log's and the state's, opening and
    committing), then again in the same call after it stored a factor: each time the solver as it was. (An
    interrupt between the log's depth being raised and its try once left the depth raised for good: every later
    transaction was then a nested one, never rolled back, and the next interrupt kept its half-done change.)"""
    base, big, _ = parts(16, 3, seed=11)
    solver, twin = build(base), build(base)
    run = (lambda s: s.update(*big)) if call == "update" else (lambda s: marginalize(s, [L(4)]))
    reference = state(twin)
    for n in range(1, 100):
        sys.settrace(_interrupt_in("transaction", n))
        try:
            run(solver)
            break  # past the last line of the transactions: the call went through
        except KeyboardInterrupt as interrupt:
            first = interrupt
        finally:
            sys.settrace(None)
        assert state(solver) == reference, f"not as it was after {first}"
        sys.settrace(_interrupt_in("append_factors", 3))  # the factor count raised, the factors not all stored
        try:
            with pytest.raises(KeyboardInterrupt):
                run(solver)
        finally:
            sys.settrace(None)
        assert state(solver) == reference, f"an interrupt in append_factors not undone after {first}"
    assert n > 10  # every line of both transactions was tried
    assert state(solver) == state(run(twin) and twin)


def _smoother_state(smoother, keys) -> tuple:
    """state() and everything a FixedLagSmoother keeps besides: timestamps, what it forgot and when, its history,
    its counters."""
    last = smoother.last_marginalization
    history = tuple((c.key, _array(c.theta), _array(c.step), _array(c.gain)) for c in smoother.history.conditionals)
    return (
        state(smoother.solver),
        tuple(smoother.timestamps.items()),
        tuple(smoother.was_marginalized(k) for k in keys),
        history,
        (smoother.n_marginalized, smoother.newest, smoother.peak_window, None if last is None else last.keys),
    )


def test_an_interrupt_at_any_line_of_a_fixed_lag_update_leaves_it_as_before_and_usable() -> None:
    """Ctrl-C anywhere in FixedLagSmoother.update, the bookkeeping after its marginalization included (the
    history, the record of what was forgotten, the timestamps): the smoother exactly as a twin that never saw the
    update, and its next updates as the twin's."""
    from test_fixed_lag import LinearStream

    from steam_ref.bayes_tree import FixedLagSmoother

    stream = LinearStream(21, n_landmarks=2, fix_every=2)

    def make():
        return FixedLagSmoother(3.0, keep_history=True, relinearize_skip=1)

    reference = stream.smoother = make()
    updates = [stream.initial()] + [stream.step() for _ in range(14)]
    for f, v, t in updates:
        reference.update(f, v, timestamps=t)
    keys = list(dict.fromkeys(k for f, _, _ in updates for g in f for k in g.keys))
    base, (big, after) = updates[:12], updates[12:14]

    def build():
        s = make()
        for f, v, t in base:
            s.update(f, v, timestamps=t)
        return s

    solver, twin, done = build(), build(), build()
    _smoother_state(solver, keys)
    total = _lines_of(lambda: done.update(big[0], big[1], timestamps=big[2]))
    assert done.last_marginalization is not None and done.history  # the update does marginalize
    done.update(after[0], after[1], timestamps=after[2])
    where = set()
    for n in sorted({*np.linspace(1, total, 50).astype(int), *range(max(total - 60, 1), total + 1)}):
        trace, _ = _interrupt_at(int(n))
        sys.settrace(trace)
        try:
            with pytest.raises(KeyboardInterrupt) as interrupt:
                solver.update(big[0], big[1], timestamps=big[2])
        finally:
            sys.settrace(None)
        where.add(str(interrupt.value).split(": ")[1])
        assert _smoother_state(solver, keys) == _smoother_state(twin, keys), f"not as before after {interrupt.value}"
    assert {"_forget_old", "marginalize_keys"} <= where, where
    solver.update(big[0], big[1], timestamps=big[2])
    solver.update(after[0], after[1], timestamps=after[2])
    assert _smoother_state(solver, keys)[1:] == _smoother_state(done, keys)[1:]
    assert state(solver.solver)[1:] == state(done.solver)[1:]  # all but the factors' ids: the stream's are shared


def test_sigterm_stops_a_command_as_ctrl_c_does_in_one_line(tmp_path) -> None:
    """``kill`` or ``timeout`` (SIGTERM) during a run: one line and 143, the output never written (it was Python's
    default, an exit with no line and no cleanup, a sweep's worker processes left running without their parent)."""
    import subprocess

    out = tmp_path / "estimates.npz"
    env = os.environ | {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    command = [sys.executable, "-m", "steam_ref", "run", "--dataset", "synthetic", "--steps", "20000"]
    proc = subprocess.Popen(
        [*command, "--save-estimates", str(out), "--no-progress"], stderr=subprocess.PIPE, text=True, env=env
    )
    time.sleep(8)  # well past the imports (~1 s, a few under load): the stream, minutes long, is running
    assert proc.poll() is None, "the run ended before it could be stopped"
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    assert (proc.returncode, err) == (143, "steam-ref: terminated\n")
    assert not out.exists()


STOPS = {  # where a Ctrl-C lands inside StreamingEstimator.step, each after the front end took the pose
    "in the solver's update (undone whole)": "steam_ref.bayes_tree.isam.backsubstitute",
    "after the solver's update, before the stream records it": "steam_ref.paper.online.forget_landmarks",
    "in the front end, before the pose's readings are pending": "steam_ref.paper.frontend.FrontEnd._landmark_factors",
}


def _step_until_interrupted(stream) -> int:
    """Step ``stream`` until a step raises KeyboardInterrupt; the pose that step took."""
    while not stream.done:
        pose = stream.front.n_processed
        try:
            stream.step()
        except KeyboardInterrupt:
            return pose
    raise AssertionError("no step was interrupted")


@pytest.mark.parametrize("where", sorted(STOPS))
def test_a_stream_stopped_inside_a_step_refuses_to_go_on_and_names_the_pose(where, monkeypatch) -> None:
    """A Ctrl-C inside StreamingEstimator.step, once its front end took the pose, went on silently: in the front end
    the next step dropped the pose's readings; in the solver's update (undone) the next update gave them late; after
    it, every later step failed naming a state as given twice. Now every later step is refused, naming the pose and
    the interrupt, and the queries answer for what the solver holds (the stream's estimate before the step, when
    the solver's update was undone)."""
    from steam_ref.datasets import generate_synthetic
    from steam_ref.paper.online import StreamingEstimator
    from steam_ref.paper.options import StreamOptions
    from steam_ref.paper.presets import PaperSetup
    from steam_ref.paper.readings import Readings

    setup = PaperSetup.synthetic().with_schedule(every=1)
    readings = Readings.from_dataset(generate_synthetic(n_steps=30, n_landmarks=8, seed=3, range_sigma=0.3), setup)
    stream, twin = (StreamingEstimator(readings, setup, StreamOptions(method="btgp")) for _ in range(2))
    for _ in range(12):
        stream.step()
        twin.step()

    def ctrl_c(*args, **kwargs):
        raise KeyboardInterrupt("Ctrl-C")

    monkeypatch.setattr(STOPS[where], ctrl_c)
    pose = _step_until_interrupted(stream)  # the first pose with a landmark reading, or (every=1) an update
    monkeypatch.undo()
    with pytest.raises(steam_ref.SteamError, match=f"the step of pose {pose} was stopped by KeyboardInterrupt"):
        stream.step()
    if where.startswith("in the solver"):
        while twin.front.n_processed < pose:
            twin.step()
        np.testing.assert_array_equal(stream.trajectory()[1], twin.trajectory()[1])


def test_a_stream_stopped_before_its_front_end_takes_the_pose_goes_on_as_if_never_stopped(monkeypatch) -> None:
    """A Ctrl-C as step() begins, before the front end took the pose, changes nothing: the stream goes on, and its
    run equals one never stopped, to the bit."""
    from steam_ref.datasets import generate_synthetic
    from steam_ref.paper.frontend import FrontEnd
    from steam_ref.paper.online import StreamingEstimator
    from steam_ref.paper.options import StreamOptions
    from steam_ref.paper.presets import PaperSetup
    from steam_ref.paper.readings import Readings

    setup = PaperSetup.synthetic().with_schedule(every=1)
    readings = Readings.from_dataset(generate_synthetic(n_steps=30, n_landmarks=8, seed=3, range_sigma=0.3), setup)
    stream, twin = (StreamingEstimator(readings, setup, StreamOptions(method="btgp")) for _ in range(2))
    for _ in range(12):
        stream.step()
    monkeypatch.setattr(FrontEnd, "step", lambda self: (_ for _ in ()).throw(KeyboardInterrupt("Ctrl-C")))
    with pytest.raises(KeyboardInterrupt):
        stream.step()
    monkeypatch.undo()
    while not stream.done:
        stream.step()
    while not twin.done:
        twin.step()
    np.testing.assert_array_equal(stream.trajectory()[1], twin.trajectory()[1])
    assert list(stream.update_steps) == list(twin.update_steps)
