"""A Singer time constant so small that the prior's Q(Δt) is too stiff for float64 beside the readings is refused by
the prior itself, naming the time constant, alpha and the interval, before the elimination breaks down blaming a
state as if a PriorFactor were missing.

Oracles: the solver's own verdicts on a drawn 3-D task (a clean solve with every warning an error, or the breakdown
the old message blamed on a missing prior), and the limit written out from float64's epsilon, as derived in
``steam_ref.gp.models`` (the prior holds the twist (αΔt)²/3 times as stiffly as WNOJ, more than any other block; at
most sqrt(1/eps)).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

from steam_ref.datasets.rigid import RIGID_QC, sample_rigid_task
from steam_ref.errors import NumericalError, UnderdeterminedError
from steam_ref.factors import GPPriorFactor
from steam_ref.gp import LinearSDE
from steam_ref.gp.models import SINGER_LARGEST_ALPHA_DT
from steam_ref.motion import motion_prior
from steam_ref.paper.rigid import solve_rigid
from steam_ref.variables import X

LIMIT = math.sqrt(3 / math.sqrt(np.finfo(float).eps))  # (αΔt)²/3 <= sqrt(1/eps)


def _task():
    """Ten states 1 s apart on SE(3), drawn from Singer's model with a time constant of 1 s."""
    return sample_rigid_task(motion_prior("se3-singer", RIGID_QC, singer_time_constant=1.0), 10, 4, 0).data


def _prior(time_constant: float):
    return motion_prior("se3-singer", RIGID_QC, singer_time_constant=time_constant)


def test_the_limit_is_the_one_derived_from_float64s_epsilon() -> None:
    assert abs(SINGER_LARGEST_ALPHA_DT - LIMIT) <= 1e-15 * LIMIT


@pytest.mark.parametrize("method", ["batch", "btgp"])
def test_a_tiny_time_constant_on_a_3d_stream_names_itself_and_the_interval(method: str) -> None:
    """A time constant of 1e-6 s over 1 s gaps (alpha*dt = 1e6): the old code's batch solve broke down at x5 with
    "add a PriorFactor"; now the prior refuses it with its own parameters and what to give."""
    with pytest.raises(NumericalError) as caught:
        solve_rigid(_task(), _prior(1e-6), method)
    message = str(caught.value)
    assert not isinstance(caught.value, UnderdeterminedError) and "PriorFactor" not in message, message
    assert "time_constant=1e-06" in message and "alpha=1e+06" in message and "dt=1.0" in message, message
    assert f"alpha*dt <= {LIMIT:.3g}" in message, message
    assert f"give a time constant of at least {1.0 / LIMIT:.3g}" in message, message
    assert "\n" not in message


def test_the_time_constant_the_message_names_solves_cleanly_and_one_below_is_refused() -> None:
    """At the least time constant the message names the 3-D task solves with no warning (IllConditionedWarning
    made an error); 10% below it, the prior refuses it."""
    least = 1.0 / LIMIT * (1 + 1e-12)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        run = solve_rigid(_task(), _prior(least), "batch")
    assert np.all(np.isfinite(run.states))
    with pytest.raises(NumericalError, match=r"alpha\*dt = 1\.5[0-9]*e\+04"):
        solve_rigid(_task(), _prior(0.9 * least), "batch")


def test_the_vector_prior_is_refused_by_the_same_check() -> None:
    """The planar prior's factor (``GPPriorFactor.from_sde``) asks the same SDE: one check, one message; a shorter
    interval, alpha*dt within the limit, is made."""
    sde = LinearSDE.singer(np.eye(3), time_constant=1e-6)
    with pytest.raises(NumericalError, match=r"time_constant=1e-06 \(alpha=1e\+06\) over an interval dt=0\.5"):
        GPPriorFactor.from_sde(X(0), X(1), 0.5, sde)
    factor = GPPriorFactor.from_sde(X(0), X(1), 1e-6 * LIMIT / 2, sde)
    assert np.all(np.isfinite(factor.sqrt_information))
