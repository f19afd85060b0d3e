"""The 3-D fixed-lag run's window: its landmarks age by the planar stream's rule (docs/bayes_tree.md).

The rule, one home for both streams (``paper.solvers.FixedLagTreeSolver`` and ``forget_landmarks``): each update
stamps its state with its time and the landmarks its factors name with that time, a variable stamped more than the
lag before the newest state leaves, and a landmark read again after it left enters anew, at its survey with its
survey's prior. The 3-D run stamped its states only, so every landmark it had read stayed in the window to the end:
the window, its memory and the update's time grew with the map.

Oracles: the window, update by update, worked out by brute force from the data's own tables (each reading's state,
each landmark's last reading); BTGP, for a lag longer than the run; for what a variable left the window with, a twin
of the smoother taken just before the update that forgot it, given the same update with nothing to forget.
"""

from __future__ import annotations

import copy
import json
import math
from collections import Counter

import numpy as np
import pytest
from cli_runs import runner

from steam_ref.bayes_tree import FixedLagSmoother
from steam_ref.datasets.rigid import generate_rigid
from steam_ref.errors import UnknownVariableError
from steam_ref.factors import PriorFactor
from steam_ref.factors.point_readings import PointReading, RangeReading
from steam_ref.manifold import Manifold
from steam_ref.motion import motion_prior
from steam_ref.paper import solvers
from steam_ref.paper.rigid import solve_rigid, steps
from steam_ref.variables import L, Values, X

LAG = 5.0
READINGS = (RangeReading, PointReading)  # a landmark's readings (synthetic-3d's are at its states' times)


def _reading_steps(data) -> dict[int, set[int]]:
    """Brute force: the state index each landmark reading goes on (the first state time at or after it), by landmark."""
    t = data.state_times
    out: dict[int, set[int]] = {}
    for table in (data.ranges, data.points):
        for tau, lid in table[:, :2]:
            out.setdefault(int(lid), set()).add(int(np.argmax(t >= tau - 1e-9)))
    return out


def _windows(data, lag: float) -> list[tuple[set, set]]:
    """Brute force, for each update i: the variables held just before it forgets (the last window and what update i
    brings) and just after (each state and landmark whose last stamp, the time of the last update naming it, is
    within ``lag`` of tᵢ)."""
    t, read = data.state_times, _reading_steps(data)
    out, held = [], set()
    for i in range(len(t)):
        last = {L(j): max(s for s in steps_ if s <= i) for j, steps_ in read.items() if min(steps_) <= i}
        stamped = {X(j): j for j in range(i + 1)} | last
        before = held | {X(i)} | {k for k, s in last.items() if s == i}
        held = {k for k, s in stamped.items() if t[s] >= t[i] - lag}
        out.append((before, held))
    return out


@pytest.fixture
def recorded(monkeypatch):
    """Each update of the fixed-lag 3-D run's smoother: the factors it got, the window after it, what it forgot, and
    a twin of the smoother, taken before the update and given it with an endless lag, whose estimate of each forgotten
    variable is the one that variable had at the end of the update that forgot it."""
    update, out = FixedLagSmoother.update, []
    monkeypatch.setattr(Manifold, "__deepcopy__", lambda self, memo: self, raising=False)  # kinds: one object each

    def record(self, factors, values, **options):
        twin = copy.deepcopy(self)
        twin.lag = math.inf
        update(twin, factors, values, **options)
        report = update(self, factors, values, **options)
        done = self.last_marginalization
        left = {k: twin.estimate_of(k) for k in ([] if done is None else done.keys)}
        out.append({"factors": factors, "values": dict(values), "held": set(self.estimate()), "left": left})
        return report

    monkeypatch.setattr(FixedLagSmoother, "update", record)
    return out


def test_a_lag_longer_than_the_run_forgets_nothing_and_is_btgp():
    data = generate_rigid(40, seed=0)
    prior = motion_prior("se3", data.qc)
    btgp = solve_rigid(data, prior, "btgp")
    lagged = solve_rigid(data, prior, "fixed-lag", lag=1e6)
    np.testing.assert_array_equal(lagged.states, btgp.states)
    assert lagged.solver.n_marginalized == 0
    marks = [L(j) for j in _reading_steps(data)]
    assert len(marks) > 1
    for k in marks:
        np.testing.assert_array_equal(lagged.solver.estimate_of(k), btgp.solver.estimate_of(k))


def test_a_landmark_read_more_than_a_lag_ago_leaves_with_the_estimate_it_had_then(recorded):
    """After each update the window holds exactly the brute-force one; each landmark an update forgot is read,
    lagged, as it was at the end of that update."""
    data = generate_rigid(60, seed=4)  # landmarks 0, 2, 5 and 10 read again long after they left
    prior = motion_prior("se3", data.qc)
    run = solve_rigid(data, prior, "fixed-lag", lag=LAG)
    windows = _windows(data, LAG)
    assert len(recorded) == len(windows)
    last_left = {}
    for i, (update, (_, held)) in enumerate(zip(recorded, windows, strict=True)):
        assert update["held"] == held, f"update {i}: {sorted(update['held'] ^ held)}"
        last_left.update(update["left"])
    gone = {k for k in last_left if k.symbol == "l" and not run.solver.inner.holds(k)}
    assert len(gone) >= 5
    for k in gone:
        np.testing.assert_allclose(run.solver.estimate_of(k), last_left[k], rtol=0, atol=1e-10, err_msg=repr(k))
    for k in run.solver.forgotten():  # the last update's, as the planar stream reads them
        assert not run.solver.inner.holds(k)


def test_a_states_estimate_is_the_one_it_had_at_the_end_of_the_update_that_forgot_it(recorded):
    """The run's states: each forgotten one as it left, at the end of the update that forgot it. They were the ones
    of the update before (read from the window before each update, so the last update's refinement was lost)."""
    data = generate_rigid(30, seed=1)
    run = solve_rigid(data, motion_prior("se3", data.qc), "fixed-lag", lag=LAG)
    left = {k: v for update in recorded for k, v in update["left"].items() if k.symbol == "x"}
    assert len(left) == 30 - LAG
    for k, value in left.items():
        np.testing.assert_allclose(run.states[k.index], value, rtol=0, atol=1e-10, err_msg=repr(k))


def test_the_window_stays_bounded_over_a_long_run():
    """200 s, 40 landmarks: the most variables held at once, and the window at the end, are the brute force's (the
    last lag's states and landmarks), far fewer than the landmarks read; before, every landmark read stayed."""
    data = generate_rigid(200, seed=1)
    run = solve_rigid(data, motion_prior("se3", data.qc), "fixed-lag", lag=LAG)
    windows = _windows(data, LAG)
    assert run.solver.peak_window == max(len(before) for before, _ in windows)
    assert set(run.solver.inner.estimate()) == windows[-1][1]
    read = len(_reading_steps(data))
    assert read >= 30 and run.solver.peak_window <= 2 * (LAG + 2) < read


def test_steam_ref_run_on_a_3d_set_reports_the_fixed_lag_window(capsys):
    """``steam-ref run --dataset synthetic-3d --lag`` gives the window as a planar run does: the variables marginalized
    and the most held at once, the brute force's."""
    code, out, err = runner("run")(
        capsys, "--dataset", "synthetic-3d", "--steps", 60, "--seed", 1, "--lag", LAG, "--json"
    )
    assert code == 0, err
    lagged = json.loads(out)["fixed-lag"]
    windows = _windows(generate_rigid(60, seed=1), LAG)
    assert lagged["lag_s"] == LAG and lagged["peak_window"] == max(len(before) for before, _ in windows)
    assert lagged["n_marginalized"] == sum(len(before - after) for before, after in windows)


def test_a_landmark_read_again_enters_anew_at_its_survey_and_none_of_its_readings_is_dropped(recorded):
    """Landmark 2 of this run is read at 5 s and again from 48 s: it leaves, then enters with its survey as its
    first value and its survey's prior again, and leaves again; its lagged estimate is that of its second stay; the
    solver is given every reading of every landmark, once."""
    data = generate_rigid(60, seed=4)
    prior = motion_prior("se3", data.qc)
    run = solve_rigid(data, prior, "fixed-lag", lag=LAG)
    survey = {int(row[0]): row[1:] for row in data.landmarks}
    entries = [i for i, u in enumerate(recorded) if L(2) in u["values"]]
    left = [i for i, u in enumerate(recorded) if L(2) in u["left"]]
    assert len(entries) == 2 and entries[0] < left[0] < entries[1], (entries, left)
    for i in entries:
        np.testing.assert_array_equal(recorded[i]["values"][L(2)], survey[2])
        priors = [f for f in recorded[i]["factors"] if isinstance(f, PriorFactor) and f.keys == (L(2),)]
        assert len(priors) == 1
    assert L(2) in recorded[entries[1]]["held"] and left[-1] > entries[1]  # back in the window, and gone again
    lagged = run.solver.estimate_of(L(2))  # its second stay's, not its first
    np.testing.assert_allclose(lagged, recorded[left[-1]]["left"][L(2)], rtol=0, atol=1e-10)
    assert np.max(np.abs(lagged - recorded[left[0]]["left"][L(2)])) > 1e-6
    given = Counter(f.keys[-1].index for u in recorded for f in u["factors"] if isinstance(f, READINGS))
    expected = Counter(int(j) for table in (data.ranges, data.points) for j in table[:, 1])
    assert given == expected


def test_a_forgotten_landmark_read_without_entering_anew_is_refused_not_dropped():
    """The steps with no one taking the forgotten landmarks out of ``entered``: the reading of landmark 2 at 48 s
    (or an earlier one of another) names a landmark the smoother forgot, and the update says so."""
    data = generate_rigid(60, seed=4)
    prior = motion_prior("se3", data.qc)
    solver = solvers.FixedLagTreeSolver(None, LAG, data.state_times)

    def run() -> None:
        for step in steps(data, prior):
            solver.update(step.factors, Values({X(step.index): step.value, **step.landmarks}))

    with pytest.raises(UnknownVariableError, match=r"names l\d+, which was marginalized at update \d+"):
        run()
