"""A variable's kind cannot be wrong silently: every factor declares the kind of each of its keys
(``Factor.key_kinds``), every solver takes a variable's kind from its factors, and a contradiction is refused with a
:class:`~steam_ref.errors.KindError` naming the key and both kinds.

The problem is test_se2_solvers.py's (a robot turning ~1.1 rad a step among three landmarks, SE(2) states) with its
dense Gauss-Newton oracle, which retracts on SE(2) by itself: estimates given as a plain dict, as the README and
tutorial 00 give them, must reach that optimum as estimates given with ``Values(kinds=)`` do, byte for byte the same.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_se2_solvers import LANDMARKS, assert_close, dense_gauss_newton, kind, problem

from steam_ref.batch import gauss_newton
from steam_ref.bayes_tree import FixedLagSmoother, IncrementalSolver, marginalize
from steam_ref.errors import KindError, ShapeError, SteamError
from steam_ref.factors import LiePriorFactor, LieStatePrior, PriorFactor, VelocityFactor, kinds_of
from steam_ref.graph import FactorGraph
from steam_ref.lie import SE2, SE2_STATE
from steam_ref.manifold import VECTOR
from steam_ref.variables import L, Values, X

EXACT = dict(relinearize_threshold=0.0, relinearize_skip=1, wildfire_threshold=0.0)
QC = np.diag([0.05, 0.02, 0.1])


@pytest.fixture(scope="module")
def chain():
    steps, guesses, _ = problem(7, 10)
    factors = [f for fs in steps for f in fs]
    return steps, guesses, factors, dense_gauss_newton(factors, guesses)


def step_values(i, guesses):
    """The variables step i brings, as a plain dict: X(i), and the landmarks at step 0."""
    return {k: guesses[k] for k in [X(i)] + ([L(j) for j in LANDMARKS] if i == 0 else [])}


def told(values):
    return Values(values, kinds={k: kind(k) for k in values})


def same(a, b, keys):
    assert all(a[k].tobytes() == b[k].tobytes() for k in keys)


def test_the_factors_declare_their_kinds(chain):
    _, _, factors, _ = chain
    kinds = kinds_of(factors)
    assert all(kinds[k] is kind(k) for k in kinds) and len(kinds) == 13
    assert VelocityFactor.create(X(0), np.zeros(3), 1.0).key_kinds == (VECTOR,)
    assert FactorGraph(factors).kinds() == kinds


def test_an_update_of_se2_states_as_a_plain_dict_is_the_update_with_their_kinds(chain):
    """One update of everything (0.57 off the explicit-kind estimate at c21f15c: the states moved by +), then one per
    state; then both reach the dense optimum."""
    steps, guesses, factors, want = chain
    plain, explicit = IncrementalSolver(**EXACT), IncrementalSolver(**EXACT)
    plain.update(factors, dict(guesses))
    explicit.update(factors, told(guesses))
    same(plain.estimate(), explicit.estimate(), guesses)
    plain, explicit = IncrementalSolver(**EXACT), IncrementalSolver(**EXACT)
    for i, fs in enumerate(steps):
        plain.update(fs, step_values(i, guesses))
        explicit.update(fs, told(step_values(i, guesses)))
        same(plain.estimate(), explicit.estimate(), plain.estimate())
    for _ in range(12):
        plain.update()
    assert_close(plain.estimate(), want, want)
    assert plain.estimate().kind(X(4)) is SE2_STATE and plain.estimate().kind(L(1)) is VECTOR


def test_batch_gauss_newton_of_a_plain_dict_of_se2_states_reaches_the_optimum(chain):
    """The optimum, not the UnderdeterminedError of c21f15c (SE(2) Jacobians read in a vector's tangent)."""
    _, guesses, factors, want = chain
    result = gauss_newton(factors, dict(guesses), relative_tolerance=1e-14, step_tolerance=1e-12)
    assert result.converged
    assert_close(result.values, want, want)


def test_a_fixed_lag_smoother_of_plain_dicts_is_the_one_with_kinds(chain):
    steps, guesses, _, _ = chain
    plain, explicit = FixedLagSmoother(3.0, **EXACT), FixedLagSmoother(3.0, **EXACT)
    for i, fs in enumerate(steps):
        plain.update(fs, step_values(i, guesses), timestamps={X(i): float(i)})
        explicit.update(fs, told(step_values(i, guesses)), timestamps={X(i): float(i)})
    assert plain.n_marginalized == explicit.n_marginalized > 3
    same(plain.estimate(), explicit.estimate(), plain.estimate())


def test_a_world_velocity_factor_on_an_se2_state_is_refused_by_every_solver(chain):
    """VelocityFactor reads a vector state's world velocity; on an SE(2) state it reported converged=True, 1.25 off."""
    steps, guesses, factors, _ = chain
    wrong = VelocityFactor.create(X(2), [1.0, 0.0, 1.1], 0.05)
    message = r"the kind of x2 is given twice and differs: se2 by LiePriorFactor, vector by VelocityFactor"
    with pytest.raises(KindError, match=message):
        gauss_newton(factors + [wrong], dict(guesses))
    with pytest.raises(KindError, match=message):
        FactorGraph(factors + [wrong])
    with pytest.raises(KindError, match=message):
        IncrementalSolver().update(factors + [wrong], dict(guesses))
    with pytest.raises(KindError, match=message):
        FixedLagSmoother(3.0).update(factors + [wrong], dict(guesses))
    graph = FactorGraph(factors)
    with pytest.raises(KindError, match="x2 is given twice and differs: se2 by the graph's factors, vector by Veloc"):
        graph.add([wrong])
    assert len(graph) == len(factors)  # nothing added
    solver = IncrementalSolver()
    for i, fs in enumerate(steps):
        solver.update(fs, step_values(i, guesses))
    before = solver.estimate()
    with pytest.raises(KindError, match="the kind of x2 is given twice and differs: se2 by the solver, vector by Vel"):
        solver.update([wrong])
    assert len(solver.factors) == len(factors)
    same(solver.estimate(), before, before)


def test_a_kind_given_to_a_value_that_its_factors_contradict_is_refused(chain):
    _, guesses, factors, _ = chain
    vectors = Values(guesses, kinds={X(0): VECTOR})
    message = r"the kind of x0 is given twice and differs: vector by its value \(Values\(kinds=\)\), se2 by its factors"
    with pytest.raises(KindError, match=message):
        gauss_newton(factors, vectors)
    with pytest.raises(KindError, match=message):
        IncrementalSolver().update(factors, vectors)


def test_an_se2_kind_on_a_value_that_is_none_is_refused_when_given():
    """An SE(2) kind on a 3-vector was accepted until the first retract; a heading outside (-π, π] is refused, not
    wrapped (the value a user gave is the value a solver starts from)."""
    with pytest.raises(
        ShapeError, match=r"the estimate of x0 must be one SE2_STATE state \(6 numbers\), got shape \(3,\)"
    ):
        Values({X(0): np.zeros(3)}, kinds={X(0): SE2_STATE})
    with pytest.raises(
        ShapeError, match=r"the estimate of x1 must be one SE2_STATE state \(6 numbers\), got shape \(3,\)"
    ):
        Values().insert(X(1), np.zeros(3), SE2_STATE)
    turned = np.array([0.0, 0.0, 4.0, 1.0, 0.0, 0.0])
    with pytest.raises(SteamError, match=r"the estimate of x0: the heading of an SE\(2\) pose must lie in .*θ=4.0"):
        Values({X(0): turned}, kinds={X(0): SE2_STATE})
    prior = LieStatePrior.create(X(0), np.zeros(6), 0.1, group=SE2)
    with pytest.raises(SteamError, match=r"new_values\[x0\]: the heading of an SE\(2\) pose must lie in .*θ=4.0"):
        IncrementalSolver().update([prior], {X(0): turned})
    with pytest.raises(SteamError, match=r"the estimate of x0: the heading of an SE\(2\) pose .*θ=4.0"):
        gauss_newton([prior], {X(0): turned})
    with pytest.raises(ShapeError, match="LieStatePrior expects x0 of size 6, its value has size 3"):
        IncrementalSolver().update([prior], {X(0): np.zeros(3)})
    edge = np.array([0.0, 0.0, np.pi, 1.0, 0.0, 0.0])  # π itself is in (-π, π]
    assert Values({X(0): edge}, kinds={X(0): SE2_STATE}).kind(X(0)) is SE2_STATE
    VECTOR.check("anything", np.zeros(7))  # a vector of any size


def test_a_marginal_factor_keeps_the_kinds_it_was_made_with(chain):
    steps, guesses, _, _ = chain
    solver = IncrementalSolver(**EXACT)
    for i, fs in enumerate(steps[:5]):
        solver.update(fs, step_values(i, guesses))
    report = marginalize(solver, [X(0)])
    made = [solver.factors[j] for j in report.marginal_factors]
    assert made and all(m is kind(k) for f in made for k, m in zip(f.keys, f.key_kinds, strict=True))
    with pytest.raises(KindError, match="the kind of x1 is given twice and differs: se2 by the solver, vector"):
        solver.update([VelocityFactor.create(X(1), [1.0, 0.0, 1.1], 0.05)])
    solver.update([LiePriorFactor.create(X(4), X(5), 1.0, QC, group=SE2)], {X(5): guesses[X(5)]})  # what agrees goes on
    assert solver.estimate().kind(X(5)) is SE2_STATE


def test_a_landmark_prior_is_a_vector_prior_on_a_vector():
    """PriorFactor declares a vector: on a landmark it agrees with the SE(2) readings' landmark slot."""
    prior, state = PriorFactor.create(L(1), [3.0, 4.0], 0.01), LieStatePrior.create(X(0), np.zeros(6), 0.1, group=SE2)
    assert kinds_of([prior, state]) == {L(1): VECTOR, X(0): SE2_STATE}
    with pytest.raises(KindError, match="the kind of x0 is given twice and differs: se2 by LieStatePrior, vector by"):
        kinds_of([state, PriorFactor.create(X(0), np.zeros(6), 0.1)])
