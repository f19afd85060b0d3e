"""Values.retract (θ̄ ⊕ δθ, what every batch iteration does): each moved variable by its kind, every other an
independent copy, the order of the variables kept, and a step that is not finite named by its variable.

Oracle: x + δ by hand for vector-space variables; SE(2)'s own retract for a pose kind."""

from __future__ import annotations

import numpy as np
import pytest

import steam_ref as sr
from steam_ref.errors import NumericalError
from steam_ref.lie import SE2_STATE


def values():
    return sr.Values({sr.X(0): np.arange(6.0), sr.L(0): np.array([1.0, 2.0]), sr.L(1): np.array([3.0, 4.0])})


def test_moved_by_hand_and_the_rest_independent_copies():
    v = values()
    out = v.retract({sr.L(0): np.array([0.5, -1.0])})
    np.testing.assert_array_equal(out[sr.L(0)], [1.5, 1.0])
    np.testing.assert_array_equal(out[sr.X(0)], np.arange(6.0))
    assert list(out) == list(v)
    for k in v:
        assert not np.shares_memory(out[k], v[k])
    np.testing.assert_array_equal(v[sr.L(0)], [1.0, 2.0])  # the original untouched


def test_a_pose_moves_by_its_kind():
    pose = np.array([1.0, 2.0, 0.3, 0.1, 0.0, 0.2])
    v = sr.Values({sr.X(0): pose}, kinds={sr.X(0): SE2_STATE})
    step = np.array([0.1, -0.2, 0.05, 0.0, 0.1, 0.0])
    np.testing.assert_array_equal(v.retract({sr.X(0): step})[sr.X(0)], SE2_STATE.retract(pose, step))


def test_a_non_finite_step_is_named_by_its_variable():
    v = sr.Values({sr.L(0): np.array([1.0, 2.0]), sr.L(1): np.array([3.0, 4.0])})
    with pytest.raises(NumericalError, match=r"update of l1 is not finite"):
        v.retract({sr.L(0): np.array([1.0, 1.0]), sr.L(1): np.array([np.inf, 0.0])})
