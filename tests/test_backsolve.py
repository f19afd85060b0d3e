"""Partial back-substitution (bayes_tree/backsolve.py) [K12 Alg. 7] against the full solve of the tree.

With the wildfire threshold α = 0 the loop visits every clique below the re-eliminated top and gives the
δ of a full back-substitution from the roots (``BayesTree.solve``); with α > 0 no variable it skipped moved
by more than what α lets through. A clique's solved form δ_F = g - G δ_S gives the least-squares δ_F of its
factors (dense oracle). A singular conditional is named.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_isam import ACTIONS, THRESHOLDS, Stream

import steam_ref as sr
from steam_ref.bayes_tree import IncrementalSolver
from steam_ref.errors import SteamError
from steam_ref.linear.conditional import eliminate_clique
from steam_ref.linear.system import GaussianFactor


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**32 - 1), actions=ACTIONS, relinearize_threshold=THRESHOLDS)
def test_with_alpha_zero_the_loop_gives_the_full_solve_after_every_update(seed, actions, relinearize_threshold):
    stream = Stream(np.random.default_rng(seed), n_states=20, n_landmarks=2)
    solver = IncrementalSolver(sr.ISAM2Params(relinearize_threshold, 1, 0.0))
    for action in ["state"] + actions:
        solver.update(*stream.step(action))
        full, delta = solver.tree.solve(), solver.delta()
        assert sorted(full, key=str) == sorted(delta, key=str)
        for k in full:
            np.testing.assert_allclose(delta[k], full[k], rtol=0, atol=1e-9, err_msg=str(k))


@pytest.mark.parametrize("separator", [(), ("s",), ("s", "t")])
def test_the_solved_form_gives_the_least_squares_frontals_of_the_factors(rng, separator):
    """g - G δ_S (g = R⁻¹d, G = R⁻¹S) minimizes ‖A_F δ_F + A_S δ_S - b‖² over δ_F, by numpy's lstsq.  [YIB Eq. 25]"""
    frontals, dims = ("x", "y"), {"x": 3, "y": 2, "s": 3, "t": 2}
    keys = frontals + separator
    factors = [
        GaussianFactor(ks, tuple(rng.normal(size=(4, dims[k])) * 10.0 ** rng.integers(-2, 3) for k in ks), rng.normal(size=4))
        for ks in [keys, frontals[:1], keys[1:] or frontals]
    ]  # fmt: skip
    clique = eliminate_clique(frontals, separator, dims, factors)
    A = np.vstack(
        [
            np.hstack([f.blocks[f.keys.index(k)] if k in f.keys else np.zeros((4, dims[k])) for k in keys])
            for f in factors
        ]
    )
    b = np.concatenate([f.rhs for f in factors])
    nf = sum(dims[k] for k in frontals)
    for _ in range(3):
        s = rng.normal(size=A.shape[1] - nf)
        expected = np.linalg.lstsq(A[:, :nf], b - A[:, nf:] @ s, rcond=None)[0]
        np.testing.assert_allclose(clique.solve(s), expected, rtol=1e-10, atol=1e-12 * np.abs(expected).max())


def test_singular_conditional_is_named():
    """A zero pivot in a conditional (built by hand) is refused when the clique is made, naming its variables."""
    solver = IncrementalSolver()
    solver.update([sr.PriorFactor.create(sr.X(0), np.zeros(3), np.ones(3))], {sr.X(0): np.zeros(3)})
    (cid,) = solver.tree.cliques
    clique = solver.tree.cliques[cid]
    R = clique.R.copy()
    R[1, 1] = 0.0
    with pytest.raises(SteamError, match=r"singular conditional in the clique of \(x0,\)"):
        type(clique)(
            clique.frontals, clique.separator, clique.frontal_dims, clique.separator_dims, R, clique.S, clique.d,
            clique.marginal, clique.factors,
        )  # fmt: skip


def test_the_batched_back_substitution_is_gone():
    with pytest.raises(SteamError, match="no field 'backsubstitution'"):
        sr.ISAM2Params().replace(backsubstitution="batched")
