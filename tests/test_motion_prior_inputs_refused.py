"""What a user hands a motion prior's own methods (docs/api.md, "Choose a motion prior") when building a problem by
hand: the first state's prior (pose, velocity, sigmas per block), a new state's value (pose, world velocity and the
step ``dt``) and a landmark reading on the prior's state. Each of these took a string, a bool, a complex number, NaN,
a short vector, a step of 0 or any object, and either built a wrong factor or state (a 5-number state, a complex
state, a state of NaN), or failed with NumPy's own ValueError, TypeError, IndexError or AttributeError. Each is now a
SteamError naming the argument; what was accepted still gives the same factor or state (the sigmas as one (blocks, 3)
array give the factor their list gives).
"""

from __future__ import annotations

import numpy as np
import pytest

from steam_ref import BearingFactor, PriorFactor, RangeFactor, motion_prior
from steam_ref.errors import ShapeError, SteamError
from steam_ref.motion import MOTION_PRIORS
from steam_ref.variables import L, X

QC = np.diag([0.02, 0.01, 0.05])
PLANAR = [name for name in MOTION_PRIORS if not name.startswith("se3")]  # a [x, y, θ] front and a 3 × 3 Qc


def _blocks(prior) -> list[list[float]]:
    """Sigmas for every block of the prior's first state (pose, velocity, acceleration...)."""
    return [[0.1, 0.2, 0.3]] * (prior.state_dim // 3)


BAD_TRIPLES = [  # (what, value, the message with {a} for the argument's name)
    ("a string", "abc", r"{a} must be an array of numbers, got the string {a}='abc'"),
    ("bools", [True, False, True], r"{a} must be an array of numbers, got {a}=\[True, False, True\] \(dtype bool\)"),
    ("complex", [1j, 0.0, 0.0], r"{a} must be an array of numbers, got {a}=.* \(dtype complex128\)"),
    ("NaN", [np.nan, 0.0, 0.0], r"{a} must be finite, but {a}\[0\] = nan"),
    ("too short", [0.0, 0.0], r"{a} must be 3 finite numbers \(shape \(3,\)\), got \[0.0, 0.0\]"),
    ("a table", [[0.0, 0.0, 0.0]], r"{a} must be 3 finite numbers \(shape \(3,\)\), got \[\[0.0, 0.0, 0.0\]\]"),
    ("objects", np.array([0.0, 0.0, 0.0], dtype=object), r"{a} must be an array of numbers, .*\(dtype object\)"),
]


@pytest.mark.parametrize("name", PLANAR)
@pytest.mark.parametrize(("what", "value", "message"), BAD_TRIPLES, ids=[c[0] for c in BAD_TRIPLES])
def test_a_bad_pose_or_velocity_is_refused_naming_it(name, what, value, message):
    del what
    prior = motion_prior(name, QC)
    with pytest.raises(ShapeError, match=message.format(a="pose")):
        prior.first_state_prior(X(0), value, [1.0, 0.0, 0.0], _blocks(prior))
    with pytest.raises(ShapeError, match=message.format(a="velocity")):
        prior.first_state_prior(X(0), [0.0, 0.0, 0.0], value, _blocks(prior))
    with pytest.raises(ShapeError, match=message.format(a="pose")):
        prior.initial_state(value, [1.0, 0.0, 0.0], 0.5)
    with pytest.raises(ShapeError, match=message.format(a="world_velocity")):
        prior.initial_state([0.0, 0.0, 0.0], value, 0.5)


@pytest.mark.parametrize("name", PLANAR)
@pytest.mark.parametrize("dt", [0.0, -0.5, np.nan, np.inf])
def test_a_new_state_after_a_step_that_is_not_positive_is_refused(name, dt):
    # On SE(2) the heading rate is wrap(θ̇ dt) / dt: a step of 0 gave NaN (and a RuntimeWarning), the vector priors
    # ignored it; both now refuse it as every factor between states does.
    with pytest.raises(SteamError, match=rf"time step must be positive and finite, got dt={dt}"):
        motion_prior(name, QC).initial_state([0.0, 0.0, 0.0], [1.0, 0.0, 0.5], dt)


BAD_SIGMAS = [
    ("strings", ["0.1", "0.1", "0.1"], r"sigmas\[0\] must be an array of numbers, got sigmas\[0\]=\['0.1'"),
    ("bools", [True, True, True], r"sigmas\[0\] must be an array of numbers, .*dtype bool"),
    ("complex", [0.1 + 0j] * 3, r"sigmas\[0\] must be an array of numbers, .*dtype complex"),
    ("ragged", [0.1, [0.1], 0.1], r"sigmas\[0\] must be an array of numbers"),
    ("objects", np.array([0.1] * 3, dtype=object), r"sigmas\[0\] must be an array of numbers, .*dtype object"),
]


@pytest.mark.parametrize("name", PLANAR)
@pytest.mark.parametrize(("what", "block", "message"), BAD_SIGMAS, ids=[c[0] for c in BAD_SIGMAS])
def test_a_sigma_block_that_is_not_numbers_is_refused_naming_it(name, what, block, message):
    del what
    prior = motion_prior(name, QC)
    with pytest.raises(ShapeError, match=message):
        prior.first_state_prior(X(0), [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [block, *_blocks(prior)[1:]])


@pytest.mark.parametrize("name", PLANAR)
def test_sigmas_as_one_array_give_the_factor_their_list_gives(name):
    prior = motion_prior(name, QC)
    blocks = _blocks(prior)
    listed = prior.first_state_prior(X(0), [1.0, 2.0, 0.3], [1.0, 0.0, 0.1], blocks)
    stacked = prior.first_state_prior(X(0), [1.0, 2.0, 0.3], [1.0, 0.0, 0.1], np.array(blocks))
    np.testing.assert_array_equal(stacked.sqrt_information, listed.sqrt_information)
    state = prior.initial_state([1.0, 2.0, 0.3], [1.0, 0.0, 0.1], 0.5)
    assert np.array_equal(stacked.error(state), listed.error(state))
    # the sigmas are the diagonal of the noise: W = diag(1 / sigma) (the prior's sigmas read in its tangent)
    np.testing.assert_allclose(np.diag(listed.sqrt_information), 1 / np.concatenate(blocks), rtol=1e-15)


@pytest.mark.parametrize("name", PLANAR)
def test_a_pose_reading_must_be_a_landmark_reading_made_for_the_priors_state(name):
    prior = motion_prior(name, QC)
    with pytest.raises(SteamError, match=r"a pose reading is a range, bearing or bearing-range factor, got 'x0'"):
        prior.pose_reading("x0")  # the Lie priors failed with AttributeError, the vector ones returned it
    with pytest.raises(
        SteamError, match=r"a pose reading is a range, bearing or bearing-range factor, got PriorFactor"
    ):
        prior.pose_reading(PriorFactor.create(L(0), [0.0, 0.0], 1.0))
    other = 9 if prior.state_dim == 6 else 6
    wrong = RangeFactor.create(X(3), L(0), 5.0, 0.1, state_dim=other)
    with pytest.raises(
        ShapeError, match=rf"RangeFactor on x3 was made for a state of {other} numbers, the state here "
    ):
        prior.pose_reading(wrong)  # the vector priors returned it, to fail at the solve as a size clash
    right = BearingFactor.create(X(3), L(0), 0.5, 0.1, state_dim=prior.state_dim)
    assert prior.pose_reading(right).keys == (X(3), L(0))


def _reading(prior):
    """A range at a time with no state (its placeholder key X(-1)), as the prior's interpolated factor takes it."""
    return prior.pose_reading(RangeFactor.create(X(-1), L(0), 5.0, 0.1, state_dim=prior.state_dim))


@pytest.mark.parametrize("name", PLANAR)
def test_a_reading_between_states_that_is_not_a_factor_is_refused_naming_it(name):
    # The group priors failed with AttributeError ('str' object has no attribute 'key_kinds').
    prior = motion_prior(name, QC)
    with pytest.raises(SteamError, match=r"^inner must be a Factor \(a reading such as a RangeFactor\), got inner='r'"):
        prior.interpolated_factor("r", X(0), X(1), 0.0, 1.0, 0.5)
    with pytest.raises(SteamError, match=r"^inners\[1\] is a str \('r'\), not a Factor"):
        prior.interpolated_factors([_reading(prior), "r"], X(0), X(1), 0.0, 1.0, [0.25, 0.5])


BAD_TAUS = [
    ("one time too few", [0.5], r"^taus must hold one time per reading of inners \(2\), got shape \(1,\)"),
    ("a table", [[0.25, 0.5]], r"^taus must hold one time per reading of inners \(2\), got shape \(1, 2\)"),
    ("a string", "0.25 0.5", r"^taus must be an array of numbers, got the string taus='0.25 0.5'"),
    ("NaN", [0.25, np.nan], r"^taus must be finite, but taus\[1\] = nan"),
]


@pytest.mark.parametrize("name", PLANAR)
@pytest.mark.parametrize(("what", "taus", "message"), BAD_TAUS, ids=[c[0] for c in BAD_TAUS])
def test_times_that_do_not_pair_with_the_readings_are_refused(name, what, taus, message):
    # The vector priors failed with zip's ValueError or NumPy's TypeError ("iteration over a 0-d array").
    del what
    prior = motion_prior(name, QC)
    with pytest.raises(ShapeError, match=message):
        prior.interpolated_factors([_reading(prior)] * 2, X(0), X(1), 0.0, 1.0, taus)
    one_by_one = [prior.interpolated_factor(_reading(prior), X(0), X(1), 0.0, 1.0, t) for t in (0.25, 0.5)]
    together = prior.interpolated_factors([_reading(prior)] * 2, X(0), X(1), 0.0, 1.0, [0.25, 0.5])
    x = prior.initial_state([1.0, 2.0, 0.3], [1.0, 0.0, 0.1], 1.0)
    for a, b in zip(one_by_one, together, strict=True):  # what is accepted still gives the same factors
        np.testing.assert_allclose(
            b.error(x, x + 0.01, np.array([4.0, 1.0])), a.error(x, x + 0.01, np.array([4.0, 1.0]))
        )
