"""Batched partial back-substitution (bayes_tree/backsolve.py) against the clique-at-a-time loop.  [K12 Alg. 7]

The loop is the statement of the algorithm; the batched solver must visit the same cliques, mark
the same relinearization candidates in the same order (the next ordering depends on it) and give
the same δ to rounding, after every update of random streams and of prefixes of the paper's runs.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_isam import ACTIONS, THRESHOLDS, Stream

import steam_ref as sr
from steam_ref.bayes_tree import IncrementalSolver, UpdateReport
from steam_ref.datasets import load_dataset
from steam_ref.errors import SteamError
from steam_ref.paper.online import StreamingEstimator
from steam_ref.paper.options import StreamOptions
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.readings import Readings

TOLERANCE = 1e-12


def assert_same(loop: IncrementalSolver, batched: IncrementalSolver, a: UpdateReport, b: sr.UpdateReport) -> None:
    """Same cliques visited, same variables in the same order, same δ to 1e-12, same candidates."""
    assert a.backsubstituted_cliques == b.backsubstituted_cliques
    assert a.updated == b.updated
    assert a.relinearized == b.relinearized and a.reeliminated == b.reeliminated
    da, db = loop.delta(), batched.delta()
    assert list(da) == list(db)
    for k in da:
        np.testing.assert_allclose(db[k], da[k], rtol=0, atol=TOLERANCE, err_msg=str(k))
    assert list(loop._over) == list(batched._over)  # the next update's θ_rl, in order


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 2**32 - 1),
    n_landmarks=st.integers(1, 3),
    actions=ACTIONS,
    relinearize_threshold=THRESHOLDS,
    relinearize_skip=st.integers(1, 3),
    wildfire_threshold=st.sampled_from([0.0, 1e-3, 0.1]),
)
def test_batched_matches_the_loop_after_every_update(
    seed, n_landmarks, actions, relinearize_threshold, relinearize_skip, wildfire_threshold
):
    stream = Stream(np.random.default_rng(seed), n_states=20, n_landmarks=n_landmarks)
    params = sr.ISAM2Params(relinearize_threshold, relinearize_skip, wildfire_threshold)
    loop = IncrementalSolver(params)
    assert loop.params.backsubstitution == "loop"  # the default
    batched = IncrementalSolver(params, backsubstitution="batched")
    for action in ["state"] + actions:
        factors, values = stream.step(action)
        assert_same(loop, batched, loop.update(factors, values), batched.update(factors, values))


@pytest.mark.parametrize(("name", "n_poses"), [("paper-synthetic", 300), ("plaza", 600)])
def test_batched_matches_the_loop_on_a_paper_run_prefix(shared_data, name, n_poses):
    setup = PaperSetup.synthetic() if name == "paper-synthetic" else PaperSetup.plaza()
    readings = Readings.from_dataset(load_dataset(name), setup)
    runs = [
        StreamingEstimator(
            readings, setup.with_isam2(backsubstitution=m), StreamOptions(method="btgp", max_poses=n_poses)
        )
        for m in ("loop", "batched")
    ]
    while not runs[0].done:
        for run in runs:
            run.step()
        reports = [run.solver.reports for run in runs]
        assert len(reports[0]) == len(reports[1])
        if reports[0]:
            assert_same(runs[0].solver.inner, runs[1].solver.inner, reports[0][-1], reports[1][-1])
    assert len(runs[0].solver.reports) > 50  # the prefix really ran the incremental solver
    assert sum(r.backsubstituted_cliques for r in runs[1].solver.reports) > 1000


def test_singular_conditional_is_named_by_both(rng):
    """A zero pivot in a conditional (built by hand) is refused by both, naming the clique's variables."""
    for mode in ("loop", "batched"):
        solver = IncrementalSolver(backsubstitution=mode)
        solver.update([sr.PriorFactor.create(sr.X(0), np.zeros(3), np.ones(3))], {sr.X(0): np.zeros(3)})
        (cid,) = solver.tree.cliques
        clique = solver.tree.cliques[cid]
        R = clique.R.copy()
        R[1, 1] = 0.0
        solver.tree.cliques[cid] = type(clique)(
            clique.frontals, clique.separator, clique.frontal_dims, clique.separator_dims, R, clique.S, clique.d,
            clique.marginal, clique.factors,
        )  # fmt: skip
        with pytest.raises(SteamError, match=r"singular conditional in the clique of \(x0,\)"):
            solver._backsubstitute({cid})


@pytest.mark.parametrize("value", ["fast", "", None, 1])
def test_unknown_backsubstitution_is_named(value):
    with pytest.raises(SteamError, match=f"backsubstitution must be one of .*got {value!r}"):
        sr.ISAM2Params(backsubstitution=value)
