"""A ``Trajectory`` built with a motion prior of another kind than the solver's states (the SE(2) prior over states a
vector-space prior solved, or the reverse) read every query silently wrong: the vector state's world-frame velocity
[ẋ, ẏ] taken as a body twist, or a body twist as a world velocity. Both have six numbers, so the size check passed.
Now it is a KindError naming the state and both kinds, for a batch result, an incremental solver and a fixed-lag
smoother alike, each of which says the kind it holds a variable as (``kind_of``); the matching prior still answers
Eq. 18 (checked against the dense formula of ``gp.interpolate_state``).
"""

from __future__ import annotations

import numpy as np
import pytest

import steam_ref as sr
from steam_ref import X
from steam_ref.errors import KindError, UnknownVariableError
from steam_ref.gp import interpolate_state
from steam_ref.lie import SE2_STATE
from steam_ref.manifold import VECTOR

QC = np.diag([0.1, 0.1, 0.05])
TIMES = [0.0, 1.0]


def _solved(name: str) -> list:
    """Two states one second apart under the prior ``name``, solved by batch, iSAM2 and the fixed-lag smoother."""
    prior = sr.motion_prior(name, QC)
    factors = [
        prior.prior_factor(X(0), X(1), 1.0),
        prior.first_state_prior(X(0), [0.0, 0.0, 1.0], [0.5, 1.0, 0.2], [[0.01] * 3] * 2),
    ]
    values = {X(i): prior.initial_state([0.0, i * 1.0, 1.0 + 0.2 * i], [0.0, 1.0, 0.2], 1.0) for i in range(2)}
    batch = sr.gauss_newton(sr.FactorGraph(factors), values)
    incremental = sr.IncrementalSolver()
    incremental.update(factors, values)
    window = sr.FixedLagSmoother(5.0)
    window.update(factors, values, timestamps={X(0): 0.0, X(1): 1.0})
    return [batch, incremental, window]


@pytest.mark.parametrize(("solved_with", "read_with"), [("wnoa", "se2"), ("se2", "wnoa")])
def test_a_trajectory_with_a_prior_of_another_kind_is_refused(solved_with, read_with):
    other = sr.motion_prior(read_with, QC)
    for solver in _solved(solved_with):
        held = sr.motion_prior(solved_with, QC).kind
        message = rf"the kind of x1 is given twice and differs: {held.name} by the solver, {other.kind.name} by the"
        with pytest.raises(KindError, match=message):
            sr.Trajectory(solver, [0, 1], TIMES, other)


def test_every_solver_says_the_kind_it_holds_a_variable_as():
    for name, kind in (("wnoa", VECTOR), ("se2", SE2_STATE)):
        for solver in _solved(name):
            assert solver.kind_of(X(0)) is kind
            with pytest.raises(UnknownVariableError, match=r"x7"):
                solver.kind_of(X(7))


def test_the_matching_prior_still_answers_eq_18():
    for solver in _solved("wnoa"):
        t = sr.Trajectory(solver, [0, 1], TIMES, QC)
        expected = interpolate_state(0.0, solver.estimate_of(X(0)), 1.0, solver.estimate_of(X(1)), 0.3, QC)
        np.testing.assert_allclose(t.at(0.3), expected, rtol=0, atol=1e-12)
