"""Every motion prior of the table (steam_ref.motion.MOTION_PRIORS) through the same checks: its factors agree
with its own prediction, interpolation and sampling; its readings measure what the sampler draws; a stream and a
trajectory run on it. (That no module outside the homes of the priors and the groups tests a prior by name is
tests/test_seam.py's.)"""

from __future__ import annotations

import itertools
import re

import numpy as np
import pytest

import steam_ref as sr
from steam_ref.datasets import generate_synthetic, sample_from_model
from steam_ref.errors import ShapeError, SteamError
from steam_ref.factors import RangeFactor
from steam_ref.gp import LinearSDE
from steam_ref.lie import SE2, LieGroup
from steam_ref.lie.se2 import SE2Group
from steam_ref.motion import (
    MOTION_PRIORS,
    LieGroupWnoa,
    MotionPrior,
    VectorPrior,
    as_motion_prior,
    motion_prior,
    predict_state,
    reading_inside,
)
from steam_ref.paper.frontend import FrontEnd, Layout
from steam_ref.paper.online import StreamingEstimator
from steam_ref.paper.options import StreamOptions
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.readings import Readings
from steam_ref.variables import L, X

QC = np.diag([0.02, 0.01, 0.05])
# The planar priors: a state whose front is [x, y, θ] and a 3 × 3 Qc, as the synthetic task and its readings need. The
# SE(3) priors (6 × 6 Qc, no planar pose) are checked in tests/test_se3_prior.py and tests/test_wnoj_group.py.
PLANAR = [name for name in sorted(MOTION_PRIORS) if not name.startswith("se3")]
PRIORS = PLANAR + ["se2 simplified"]
SIGMAS = ([0.1, 0.1, 0.05], [0.1, 0.1, 0.05], [0.05, 0.05, 0.02])


def prior_of(name: str, qc: np.ndarray = QC) -> MotionPrior:
    if name == "se2 simplified":
        return motion_prior("se2", qc, se2_residual="simplified")
    return motion_prior(name, qc)


def a_state(prior: MotionPrior, rng) -> np.ndarray:
    """A state of the prior with a brisk turn, drawn from its own first-state prior."""
    return prior.sample_states(rng, 1, 1.0, np.array([1.0, 0.2, 0.7]), SIGMAS)[0]


@pytest.mark.parametrize("name", PRIORS)
def test_a_prediction_has_a_zero_prior_error_and_the_first_state_prior_is_zero_at_its_mean(name, rng):
    prior = prior_of(name)
    x = a_state(prior, rng)
    assert x.shape == (prior.state_dim,) and len(prior.state_names) == prior.state_dim
    for dt in (0.3, 1.0, 2.5):
        e = prior.prior_factor(X(0), X(1), dt).error(x, predict_state(x, dt, prior))
        np.testing.assert_allclose(e, 0.0, atol=1e-12)  # [YIB Eq. 22]: the mean of the next state
    pose, velocity = np.array([1.0, -2.0, 0.4]), np.array([0.5, 0.1, 0.2])
    mean = prior.initial_state(pose, velocity, 1.0)
    prior_factor = prior.first_state_prior(X(0), pose, mean[3:6], SIGMAS)
    np.testing.assert_allclose(prior_factor.error(mean), 0.0, atol=1e-15)
    far = prior.kind.retract(mean, np.r_[0.2, np.zeros(prior.state_dim - 1)])  # 0.2 m along its first tangent axis
    assert abs(prior_factor.whitened_error(far)[0]) == pytest.approx(2.0, rel=1e-12)  # σ = 0.1 there


@pytest.mark.parametrize("name", PRIORS)
def test_the_interpolated_factor_reads_the_priors_interpolated_state(name, rng):
    prior = prior_of(name)
    xa = a_state(prior, rng)
    xb = prior.predict(xa, 2.0) + np.r_[0.05 * rng.standard_normal(6), np.zeros(prior.state_dim - 6)]
    inner = RangeFactor.create(X(-1), L(0), 3.0, 0.1, state_dim=prior.state_dim)
    factor = prior.interpolated_factor(prior.pose_reading(inner), X(0), X(1), 1.0, 3.0, 1.7)
    assert reading_inside(factor) is inner and factor.keys == (X(0), X(1), L(0))
    mark = np.array([2.0, 1.0])
    at = prior.interpolate(1.0, xa, 3.0, xb, 1.7)
    np.testing.assert_allclose(factor.error(xa, xb, mark), inner.error(at, mark), rtol=1e-13, atol=1e-15)
    near = prior.interpolate(1.0, xa, 3.0, xb, 1.0 + 1e-9)  # x(t) → x(ta) as t → ta
    np.testing.assert_allclose(near[:6], xa[:6], atol=1e-7)


@pytest.mark.parametrize("name", PRIORS)
def test_drawn_states_leave_prior_residuals_that_are_chi_square(name):
    """The prior factor's whitened residuals between consecutive drawn states are the drawn noise: χ²(n)."""
    prior = prior_of(name, np.diag([0.02, 0.01, 2e-4]))  # the turn rate a random walk kept below π a step
    rng = np.random.default_rng(4)  # 150 runs of 11 states: 1500 steps, each run's turn rate (and, with an
    runs = [prior.sample_states(rng, 11, 1.0, np.array([1.0, 0.0, 0.1]), SIGMAS) for _ in range(150)]  # acceleration
    factor = prior.prior_factor(X(0), X(1), 1.0)  # in the state, its drift) short of half a turn a step
    nees = [np.sum(factor.whitened_error(a, b) ** 2) for states in runs for a, b in itertools.pairwise(states)]
    n = prior.state_dim  # mean of 1500 χ²(n) draws: n ± 4 √(2n / 1500)
    assert abs(np.mean(nees) - n) < 4 * np.sqrt(2 * n / len(nees))


@pytest.mark.parametrize("name", PRIORS)
def test_a_velocity_reading_measures_what_the_sampler_draws(name, rng):
    prior = prior_of(name)
    states = prior.sample_states(rng, 5, 1.0, np.array([1.0, 0.3, 0.6]), SIGMAS)
    for x, z in zip(states, prior.body_velocity(states), strict=True):
        np.testing.assert_allclose(prior.velocity_reading(X(0), z, 0.1).error(x), 0.0, atol=1e-14)


@pytest.mark.parametrize("name", PRIORS)
def test_world_states_are_the_world_frame_pose_and_velocity(name, rng):
    """The world velocity is the time derivative of the world pose along the prior's own prediction (central
    differences), and a state's error against its own world states is zero."""
    prior = prior_of(name)
    x = a_state(prior, rng)
    world = prior.world_states(x[None])[0]
    h = 1e-6
    ahead, behind = prior.world_states(np.array([prior.predict(x, h), prior.predict(x, 2 * h)]))
    np.testing.assert_allclose(world[:3], x[:3], atol=1e-15)
    np.testing.assert_allclose((behind[:3] - ahead[:3]) / h, world[3:6], rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(prior.errors(x[None], world[None]), 0.0, atol=1e-14)


def test_predict_state_on_se2_follows_the_arc_not_the_straight_line():
    """A robot at the origin driving 1 m/s forward and turning 1 rad/s for 0.5 s: (sin 0.5, 1 - cos 0.5)."""
    x = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 1.0])
    arc = sr.predict_state(x, 0.5, sr.motion_prior("se2", np.eye(3)))
    np.testing.assert_allclose(arc[:3], [np.sin(0.5), 1 - np.cos(0.5), 0.5], rtol=1e-15)
    np.testing.assert_allclose(arc[:2], [0.479426, 0.122417], atol=1e-6)
    np.testing.assert_allclose(arc[:3], SE2.exp(0.5 * x[3:]), atol=1e-15)
    line = sr.predict_state(x, 0.5, np.eye(3))  # the vector-space prior: [x, y, θ] += dt [ẋ, ẏ, θ̇]
    np.testing.assert_array_equal(line, [0.5, 0.0, 0.5, 1.0, 0.0, 1.0])


class _NoPlane(SE2Group):
    """SE(2) that does not say it holds a planar pose: what any group without one is to the prior."""

    name = "noplane"
    from_planar, to_planar = LieGroup.from_planar, LieGroup.to_planar
    body_twist, world_velocity = LieGroup.body_twist, LieGroup.world_velocity


def test_the_lie_group_prior_is_its_groups_and_a_group_without_a_planar_pose_refuses_the_planar_calls(rng):
    """LieGroupWnoa takes its group: name, kind, state and factors are the group's. On a group that does not hold
    a planar pose, the group-only work (factors, interpolation, prediction, drawing) runs as on SE(2), and every
    planar call (a dead-reckoned pose or world velocity in, a world-frame state out) is refused naming the group."""
    prior = LieGroupWnoa(SE2, QC, "simplified")
    assert (prior.name, prior.kind, prior.state_dim, prior.residual) == ("se2", sr.lie.SE2_STATE, 6, "simplified")
    assert prior.prior_factor(X(0), X(1), 1.0).group is SE2
    other = LieGroupWnoa(_NoPlane(), QC)
    assert other.kind is sr.lie.GroupState(_NoPlane()) and other.kind is not prior.kind
    x = prior.sample_states(rng, 2, 0.5, np.array([1.0, 0.0, 0.3]), SIGMAS)
    y = other.sample_states(np.random.default_rng(7), 2, 0.5, np.array([1.0, 0.0, 0.3]), SIGMAS)
    se2 = LieGroupWnoa(SE2, QC)
    np.testing.assert_array_equal(
        y, se2.sample_states(np.random.default_rng(7), 2, 0.5, np.array([1.0, 0.0, 0.3]), SIGMAS)
    )
    np.testing.assert_array_equal(other.extrapolate(0.0, x[0], 0.7), se2.extrapolate(0.0, x[0], 0.7))
    for call in (
        lambda: other.initial_state(np.zeros(3), np.ones(3), 1.0),
        lambda: other.first_state_prior(X(0), np.zeros(3), np.ones(3), SIGMAS),
        lambda: other.world_states(x),
        lambda: other.errors(x, prior.world_states(x)),
    ):
        with pytest.raises(SteamError, match=r"NOPLANE holds no planar pose"):
            call()
    with pytest.raises(SteamError, match=r"group must be a LieGroup .*got group='se2'"):
        LieGroupWnoa("se2", QC)  # type: ignore[arg-type]
    with pytest.raises(SteamError, match=r"qc must be \(3, 3\) on the body twist of a state on SE2"):
        LieGroupWnoa(SE2, np.eye(2))


def test_the_table_names_each_prior_and_refuses_what_it_does_not_know():
    assert isinstance(motion_prior("wnoa", QC), VectorPrior) and motion_prior("wnoa", QC).state_dim == 6
    assert isinstance(motion_prior("se2", QC), LieGroupWnoa) and motion_prior("se2", QC).kind is sr.lie.SE2_STATE
    singer = motion_prior("singer", QC, singer_time_constant=2.0)
    np.testing.assert_allclose(singer.sde.A[6:, 6:], -0.5 * np.eye(3))
    with pytest.raises(SteamError, match=r"unknown motion prior 'cv'.*wnoa, wnoj, singer, se2"):
        motion_prior("cv", QC)
    with pytest.raises(SteamError, match=r"'wnoj' takes no option 'se2_residual'"):
        motion_prior("wnoj", QC, se2_residual="simplified")
    with pytest.raises(SteamError, match="model must be one of"):
        motion_prior("se2", QC, se2_residual="exact")
    prior = motion_prior("se2", QC)
    assert as_motion_prior(prior) is prior
    assert as_motion_prior(LinearSDE.wnoj(QC)).state_dim == 9
    with pytest.raises(SteamError, match=r"prior must be a LinearSDE or Qc.*MotionPrior"):
        as_motion_prior("abc")


@pytest.mark.parametrize("name", PLANAR)
def test_the_front_end_a_stream_and_a_trajectory_run_on_every_prior(name):
    data = generate_synthetic(n_steps=24, n_landmarks=5, seed=3, range_sigma=0.3)
    setup = PaperSetup.synthetic().replace(prior=name)
    prior = setup.motion_prior()
    steps = list(FrontEnd(Readings.from_dataset(data, setup), setup, Layout(skip=3)))
    for step in steps:
        for key, value in step.values.items():
            if key.symbol == "x":
                assert step.kinds[key] is prior.kind and value.shape == (prior.state_dim,)
    run = StreamingEstimator(Readings.from_dataset(data, setup), setup, StreamOptions(skip=3))
    result = run.run(data.ground_truth)
    assert result.trajectory.shape == (25, prior.state_dim) and result.rmse_m < 1.0
    mean, cov = run.estimate_at(float(run.readings.times[-1]) + 0.5, covariance=True)  # after the last state
    np.testing.assert_allclose(mean, prior.extrapolate(24.0, run.solver.estimate_of(X(24)), 24.5), atol=1e-12)
    assert cov.shape == (prior.state_dim,) * 2 and np.all(np.linalg.eigvalsh(cov) > 0)


def test_a_task_drawn_from_each_prior_is_in_its_layout():
    for name in PLANAR:
        setup = PaperSetup.synthetic().replace(prior=name)
        task = sample_from_model(
            10, 3, 1, prior=setup.motion_prior(), velocity_sigmas=[0.1] * 3, range_sigma=0.1, landmark_sigma=0.1,
            first_pose_sigmas=[0.1] * 3, first_velocity=[1.0, 0.0, 0.1], first_velocity_sigmas=[0.1] * 3,
            first_acceleration_sigmas=[0.1] * 3,
        )  # fmt: skip
        assert task.states.shape == (11, task.prior.state_dim) and task.prior.name == name


@pytest.mark.parametrize("name", PRIORS + ["se3", "se3-wnoj"])
def test_every_prior_refuses_a_state_of_the_wrong_size_or_not_finite_naming_it(name, rng):
    """Interpolation and prediction take states of the prior's size: one number short or over is a ShapeError naming
    the state and its shape, NaN a ShapeError too; never a NumPy broadcasting error or NaN returned (the paper's
    WNOA interpolated a NaN state to NaN). (A group prior's mean broadcasts over a stack of states.)"""
    prior = (
        prior_of(name) if not name.startswith("se3") else motion_prior(name, np.diag([0.4, 0.3, 0.2, 0.1, 0.1, 0.1]))
    )
    n = prior.state_dim
    tangent = getattr(prior.kind, "dim", n)  # a group state's tangent; a vector state's own size
    good = prior.predict(_start(prior), 0.3)
    short, over = good[:-1], np.r_[good, 0.0]
    nan = good.copy()
    nan[-1] = np.nan
    for bad, shape in ((short, (n - 1,)), (over, (n + 1,)), (nan, None)):
        shown = re.escape(str(shape)) if shape else "finite"  # the prior's check (xa, xb, x1) names it first
        with pytest.raises(ShapeError, match=f"xa.*{shown}"):
            prior.interpolate(0.0, bad, 1.0, good, 0.5)
        with pytest.raises(ShapeError, match=f"xb.*{shown}"):
            prior.interpolate(0.0, good, 1.0, bad, 0.5)
        with pytest.raises(ShapeError, match=f"x1.*{shown}"):
            prior.extrapolate(0.0, bad, 1.0)
        with pytest.raises(ShapeError, match=f"xa.*{shown}"):
            prior.interpolate_covariance(0.0, bad, 1.0, good, 0.5, np.eye(2 * tangent))
        with pytest.raises(ShapeError, match=f"x1.*{shown}"):
            prior.extrapolate_covariance(0.0, bad, 1.0, np.eye(tangent))


def _start(prior: MotionPrior) -> np.ndarray:
    """A state of ``prior`` at rest at the origin (its group's identity, or zeros), moving at 1 along x."""
    x = np.zeros(prior.state_dim)
    group = getattr(prior, "group", None)
    front = 3 if group is None else group.size
    if group is not None:
        x[:front] = group.identity()
    x[front] = 1.0
    return x
