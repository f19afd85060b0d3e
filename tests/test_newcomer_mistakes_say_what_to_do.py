"""The mistakes a newcomer makes with ``import steam_ref as sr``, each met as the installed user meets it: the error
is the project's own (:class:`sr.SteamError`), names the offending value, and says what to do; doing it then works."""

from __future__ import annotations

import math

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


def _bearing_makers():
    from steam_ref.factors import PoseReading

    return {
        "BearingFactor": lambda b: sr.BearingFactor.create(KEYS[0], sr.L(0), b, 0.05),
        "BearingRangeFactor": lambda b: sr.BearingRangeFactor.create(KEYS[0], sr.L(0), b, 4.0, [0.05, 0.1]),
        "PoseReading.bearing (SE(2))": lambda b: PoseReading.bearing(KEYS[0], sr.L(0), b, 0.05, group=sr.SE2),
    }


@pytest.mark.parametrize("maker", sorted(_bearing_makers()))
@pytest.mark.parametrize("degrees", [90.0, -45.0, 360.0, 7.0])
def test_a_bearing_in_degrees_is_refused_with_its_value_in_radians(maker: str, degrees: float) -> None:
    """A reading beyond a full turn either way (abs(b) > 2π) is no sensor's radians: refused, naming the value and
    its conversion (math.radians, the oracle), never wrapped into a wrong direction."""
    with pytest.raises(sr.SteamError) as caught:
        _bearing_makers()[maker](degrees)
    message = str(caught.value)
    assert f"={degrees!r}" in message and "radians" in message, message
    assert f"np.radians({degrees!r}) = {np.radians(degrees):.6g}" in message, message


@pytest.mark.parametrize("maker", sorted(_bearing_makers()))
def test_a_bearing_within_a_full_turn_is_read_either_way_round(maker: str) -> None:
    """[0, 2π) and [-π, π) both work: a reading b and b - 2π give the same error, at 2π itself too."""
    x, landmark = np.array([1.0, 2.0, 0.3, 0.5, 0.1, 0.0]), np.array([4.0, -1.0])
    for b in (5.0, 2 * np.pi, 3.5):
        one, other = _bearing_makers()[maker](b), _bearing_makers()[maker](b - 2 * np.pi)
        np.testing.assert_allclose(one.error(x, landmark), other.error(x, landmark), rtol=0, atol=1e-12)


@pytest.mark.parametrize("maker", sorted(_bearing_makers()))
@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_a_float32_full_turn_is_a_full_turn_read_as_given(maker: str, sign: float) -> None:
    """np.float32(2π) is 2π + 1.7e-7 as float64: a float32 sensor's full turn, refused before as "beyond a full turn"
    with a hint to convert degrees. It is read as given (not clipped to 2π): its error is that of a reading of 0 less
    float32's rounding, the difference of the two float64 numbers (exact, Sterbenz)."""
    x, landmark = np.array([1.0, 2.0, 0.3, 0.5, 0.1, 0.0]), np.array([4.0, -1.0])
    turn = np.float32(sign * 2 * np.pi)
    rounding = float(turn) - sign * 2 * np.pi  # 1.7e-7 either way round
    assert abs(rounding) > 1e-7
    one, zero = _bearing_makers()[maker](turn), _bearing_makers()[maker](0.0)
    assert getattr(one, "inner", one).measured[0] == float(turn)  # the reading kept as given (PoseReading wraps one)
    np.testing.assert_allclose(one.error(x, landmark)[0], zero.error(x, landmark)[0] - rounding, rtol=0, atol=1e-12)


@pytest.mark.parametrize("maker", sorted(_bearing_makers()))
def test_a_bearing_just_past_a_full_turn_is_refused_with_both_readings_of_it(maker: str) -> None:
    """The next float32 after 2π, and 2π + 1e-4 in float64, are past a full turn: refused, naming the value, the
    bound and both remedies, degrees and the wrapped radians (math.remainder, the oracle)."""
    for value in (float(np.nextafter(np.float32(2 * np.pi), np.float32(7.0))), 2 * np.pi + 1e-4):
        with pytest.raises(sr.SteamError) as caught:
            _bearing_makers()[maker](value)
        message = str(caught.value)
        assert f"={value!r}" in message and f"{float(np.float32(2 * np.pi))!r}: 2π as float32 rounds it" in message
        assert f"np.radians({value!r}) = {np.radians(value):.6g}" in message, message
        assert f"math.remainder({value!r}, 2 * math.pi) = {math.remainder(value, 2 * math.pi):.6g}" in message


@pytest.mark.parametrize("solver", ["graph check", "batch", "incremental"])
def test_a_prior_on_the_pose_alone_says_the_factor_was_made_for_three_numbers(solver: str) -> None:
    """``PriorFactor.create(X(0), [x, y, θ], ...)`` on a state of six numbers: the error says what the factor was made
    for and both ways out; making it for six numbers, as it says, solves."""
    factors = list(sr.gp_prior_factors(KEYS, np.arange(5.0), QC))
    values = {k: np.zeros(6) for k in KEYS}
    run = {
        "graph check": lambda f: sr.FactorGraph(f).check_values(values),
        "batch": lambda f: sr.gauss_newton(f, values),
        "incremental": lambda f: sr.IncrementalSolver().update(f, values),
    }[solver]
    with pytest.raises(sr.ShapeError) as caught:
        run([*factors, sr.PriorFactor.create(KEYS[0], np.zeros(3), 0.1)])
    message = str(caught.value)
    assert "PriorFactor expects x0 of size 3" in message and "has size 6" in message, message
    assert "the factor was made for a variable of 3 numbers (a PriorFactor's mean and noise" in message, message
    assert "so make it for 6 or give x0 a value of 3" in message, message
    run([*factors, sr.PriorFactor.create(KEYS[0], np.zeros(6), 0.1)])


@pytest.mark.parametrize("given", ["list", "generator"])
def test_keys_given_as_a_trajectorys_states_are_named_as_keys_with_the_indices_to_give(given: str) -> None:
    """``Trajectory(result, keys, times, qc)``: the states are pose indices. The keys were shown as NumPy read them,
    ``[['x', '0'], ['x', '1'], ...]``; they are named as keys, with what to give instead, which then works."""
    factors = [*sr.gp_prior_factors(KEYS, np.arange(5.0), QC), sr.PriorFactor.create(KEYS[0], np.zeros(6), 0.1)]
    result = sr.gauss_newton(sr.FactorGraph(factors), {k: np.zeros(6) for k in KEYS})
    states = list(KEYS) if given == "list" else (k for k in KEYS)
    with pytest.raises(sr.SteamError) as caught:
        sr.Trajectory(result, states, np.arange(5.0), QC)
    message = str(caught.value)
    assert "not keys: got states=[x0, x1, x2, x3, ...]" in message and "[k.index for k in keys]" in message, message
    assert "['x'" not in message, message
    xt = sr.Trajectory(result, [k.index for k in KEYS], np.arange(5.0), QC).at(2.5)
    np.testing.assert_allclose(xt, np.zeros(6), atol=1e-12)  # everything at rest at the origin: so is x(2.5)
