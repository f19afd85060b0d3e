"""The mistakes a newcomer makes with ``import steam_ref as sr``, each met as the installed user meets it: the error
is the project's own (:class:`sr.SteamError`), names the offending value, and says what to do; doing it then works."""

from __future__ import annotations

import numpy as np
import pytest

import steam_ref as sr

QC = 0.01 * np.diag([1.0, 1.0, 25.0])
KEYS = [sr.X(i) for i in range(5)]


def _odometry_only() -> tuple[list, dict]:
    """Five states linked by the GP prior, with odometry on each, and a landmark seen by one range: no prior at all."""
    factors = list(sr.gp_prior_factors(KEYS, np.arange(5.0), QC))
    factors += [sr.VelocityFactor.create(k, [1.0, 0.0, 0.1], 0.05) for k in KEYS]
    factors.append(sr.RangeFactor.create(KEYS[2], sr.L(0), 3.0, 0.1))
    values = {k: np.array([float(i), 0.0, 0.0, 1.0, 0.0, 0.1]) for i, k in enumerate(KEYS)}
    return factors, values | {sr.L(0): np.array([2.0, 3.0])}


@pytest.mark.parametrize("solver", ["batch", "incremental"])
def test_a_forgotten_prior_names_the_free_variable_and_says_to_add_a_prior(solver: str) -> None:
    factors, values = _odometry_only()
    solve = {
        "batch": lambda f: sr.gauss_newton(sr.FactorGraph(f), values),
        "incremental": lambda f: sr.IncrementalSolver().update(f, values),
    }[solver]
    with pytest.raises(sr.UnderdeterminedError) as caught:
        solve(factors)
    message = str(caught.value)
    assert isinstance(caught.value, sr.SteamError) and "\n" not in message
    assert any(f"variable {k!r}" in message for k in [*KEYS, sr.L(0)]), message
    assert "add factors that pin it down: a PriorFactor on one state" in message, message
    assert "for a landmark, a PriorFactor or readings" in message, message
    # doing what it says (a prior on the first state and on the landmark) gives a solvable problem
    fixed = factors + [
        sr.PriorFactor.create(KEYS[0], values[KEYS[0]], 0.1),
        sr.PriorFactor.create(sr.L(0), [2.0, 3.0], 0.5),
    ]
    solve(fixed)


def test_the_remedy_is_said_once_however_the_error_is_raised() -> None:
    """Raised with a message, without one, or pickled across a process (a sweep's worker): the same one remedy."""
    import pickle

    with_message = sr.UnderdeterminedError("variable x3 is not constrained by the factors")
    assert str(with_message) == f"variable x3 is not constrained by the factors; {sr.UnderdeterminedError.remedy}"
    assert str(pickle.loads(pickle.dumps(with_message))) == str(with_message)
    assert str(sr.UnderdeterminedError()) == sr.UnderdeterminedError.remedy
    assert str(with_message).count("PriorFactor on one state") == 1
