"""A task drawn from the SE(2) WNOA model (steam_ref.datasets.sample_from_model with the prior
``motion_prior('se2', qc)``): the motion prior's residuals at the true states are the drawn noise, so their
whitened squares are χ²(6)."""

from __future__ import annotations

import numpy as np
import pytest

from steam_ref.datasets import sample_from_model
from steam_ref.errors import DataError, SteamError
from steam_ref.factors.lie_prior import LiePriorFactor, lie_prior_factors
from steam_ref.lie import SE2
from steam_ref.motion import motion_prior
from steam_ref.variables import X

QC = np.diag([0.04, 0.01, 2e-4])  # the turn rate is a random walk: kept below π a step over 1500 steps
KW = dict(
    velocity_sigmas=[0.1, 0.1, 0.05],
    range_sigma=0.5,
    landmark_sigma=0.1,
    first_pose_sigmas=[0.1, 0.1, 0.05],
    first_velocity=[1.0, 0.0, 0.9],  # ~0.9 rad a step: a robot that turns
    first_velocity_sigmas=[0.1, 0.1, 0.1],
)


def _sample(n_steps, n_landmarks, seed, model="local-variable", **changes):
    return sample_from_model(
        n_steps, n_landmarks, seed, prior=motion_prior("se2", QC, se2_residual=model), **(KW | changes)
    )


def _nees(sample, model):
    n = len(sample.states)
    factors = lie_prior_factors([X(i) for i in range(n)], np.arange(n, dtype=float), QC, model, group=SE2)
    batch = LiePriorFactor.stack(factors)  # every step at once, as a solver evaluates them
    return np.sum(batch.whitened_error(sample.states[:-1], sample.states[1:]) ** 2, axis=1)


@pytest.mark.parametrize("model", ["local-variable", "simplified"])
def test_the_prior_residuals_at_the_truth_are_chi_square_6(model):
    s = _sample(1500, 20, 11, model)
    nees = _nees(s, model)
    # mean of 1500 χ²(6) draws: 6 ± 3 · √(12/1500) = 6 ± 0.27
    assert abs(nees.mean() - 6.0) < 3 * np.sqrt(12 / len(nees))
    assert np.all((s.states[:, 2] > -np.pi) & (s.states[:, 2] <= np.pi))


def test_the_other_models_residual_does_not_fit_a_turning_draw():
    s = _sample(1500, 20, 11, "local-variable")
    assert _nees(s, "simplified").mean() > 6.0 + 6 * np.sqrt(12 / 1500)


def test_odometry_reads_the_body_twist_and_the_task_has_its_parts():
    s = _sample(400, 8, 5)
    resid = s.data.odometry[:, 1:] - s.states[1:, 3:]
    np.testing.assert_allclose(resid.std(axis=0), KW["velocity_sigmas"], rtol=0.15)
    assert len(s.landmarks) == 8 and len(s.data.ranges) == 401
    assert s.data.source == "sample_from_model(n_steps=400, n_landmarks=8, prior='se2')"
    assert s.prior.residual == "local-variable"


def test_bad_input():
    with pytest.raises(SteamError, match="model must be one of"):
        _sample(10, 2, 0, "exact")
    with pytest.raises(DataError, match=r"step \d+ turned .* outside \(-π, π\)"):
        _sample(50, 2, 0, first_velocity=[1.0, 0.0, 3.1])
