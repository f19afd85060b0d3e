"""The incremental solver (iSAM2 on the Bayes tree, [YIB Alg. 1 steps 2-7]) against dense solves.

After every update of a random sequence: the tree's solution equals numpy.linalg.solve of all
factors so far, linearized at the solver's own linearization point; RᵀR equals the permuted JᵀJ;
the structure is a valid Bayes tree. With thresholds 0, one update is one Gauss-Newton step.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import steam_ref as sr
from steam_ref.bayes_tree import IncrementalSolver, UpdateReport
from steam_ref.errors import ShapeError, SteamError, UnderdeterminedError, UnknownVariableError
from steam_ref.gp import process_noise, transition
from steam_ref.linear import LinearSystem, Ordering

QC = np.diag([0.1, 0.2, 0.3])
INF = float("inf")


class Stream:
    """A WNOA GP trajectory [YIB Eq. 30-31] revealed one state at a time, with velocity and range readings."""

    def __init__(self, rng: np.random.Generator, n_states: int, n_landmarks: int = 3, noise: float = 0.05):
        self.rng, self.noise, self.n_landmarks = rng, noise, n_landmarks
        self.times = np.cumsum(rng.uniform(0.5, 1.5, n_states))
        xs = [np.array([0.3, -0.2, 0.3, 1.0, 0.5, 0.1])]
        for dt in np.diff(self.times):
            xs.append(transition(dt, 3) @ xs[-1] + np.linalg.cholesky(process_noise(dt, QC)) @ rng.normal(size=6))
        self.xs = xs
        self.landmarks = rng.normal(size=(n_landmarks, 2)) * 5
        self.known: set = set()
        self.next = 0  # next state to reveal

    def velocity(self, i: int) -> sr.VelocityFactor:
        x = self.xs[i]
        c, s = np.cos(x[2]), np.sin(x[2])
        body = np.array([c * x[3] + s * x[4], -s * x[3] + c * x[4], x[5]]) + self.rng.normal(size=3) * 0.05
        return sr.VelocityFactor.create(sr.X(i), body, [0.5, 0.5, 1.0])

    def range(self, i: int, j: int, values: dict) -> list[sr.Factor]:
        """A range reading from state i to landmark j (with the landmark's prior when it is new)."""
        out, lm = [], sr.L(j)
        if lm not in self.known:
            guess = self.landmarks[j] + self.rng.normal(size=2) * 0.1
            values[lm] = guess
            out.append(sr.PriorFactor.create(lm, guess, [1.0, 1.0]))
            self.known.add(lm)
        # a range sensor reads no negative distance: a state ~0.1 m from a landmark folds its noise (a negative one is
        # refused as a bad reading, and hypothesis draws such streams)
        r = abs(np.hypot(*(self.xs[i][:2] - self.landmarks[j])) + self.rng.normal() * 0.05)
        return out + [sr.RangeFactor.create(sr.X(i), lm, r, 0.3)]

    def new_state(self, factors: list, values: dict) -> None:
        """Reveal the next state: its GP prior factor (or a prior on x0), velocity and one range."""
        i = self.next
        self.next += 1
        values[sr.X(i)] = self.xs[i] + self.rng.normal(size=6) * self.noise
        if i == 0:
            factors.append(sr.PriorFactor.create(sr.X(0), self.xs[0] + self.rng.normal(size=6) * 0.1, np.ones(6)))
        else:
            factors.append(sr.GPPriorFactor.wnoa(sr.X(i - 1), sr.X(i), self.times[i] - self.times[i - 1], QC))
        factors.append(self.velocity(i))
        factors.extend(self.range(i, i % self.n_landmarks, values))

    def old_readings(self, factors: list) -> None:
        """A reading on an already estimated state: a late range to a known landmark, or a velocity."""
        i = int(self.rng.integers(0, self.next))
        known = sorted(lm.index for lm in self.known)
        if known and self.rng.random() < 0.7:
            factors.extend(self.range(i, known[int(self.rng.integers(len(known)))], {}))
        else:
            factors.append(self.velocity(i))

    def step(self, action: str) -> tuple[list, dict]:
        factors, values = [], {}
        if action in ("state", "both", "two") and self.next < len(self.xs):
            self.new_state(factors, values)
            if action == "two" and self.next < len(self.xs):
                self.new_state(factors, values)
        if action in ("extra", "both") and self.next > 0:
            self.old_readings(factors)
        return factors, values


def natural_system(solver: IncrementalSolver) -> tuple[LinearSystem, Ordering]:
    """All factors so far, linearized at the solver's θ̄, columns in first-seen order."""
    theta = solver.linearization_point
    keys = tuple(theta)
    ordering = Ordering(keys, tuple(theta.dim(k) for k in keys))
    return LinearSystem.build(solver.factors, theta, ordering), ordering


def assert_matches_dense(solver: IncrementalSolver, *, exact_delta: bool) -> None:
    """Tree solution = dense solve; RᵀR = permuted JᵀJ; valid structure; estimate = θ̄ + δ."""
    system, ordering = natural_system(solver)
    J, b = system.to_dense()
    info = J.T @ J
    reference = np.linalg.solve(info, J.T @ b)
    # The absolute scale of the solution's rounding: Jᵀb is formed with errors of order ε|Jᵀ||b|, which
    # 𝓘⁻¹ carries into δ. Near the optimum δ itself is ~0 (b ⟂ range J) and is no scale at all.
    scale = max(np.abs(reference).max(), np.abs(np.linalg.solve(info, np.abs(J.T) @ np.abs(b))).max())
    tree = solver.tree.solve()
    np.testing.assert_allclose(
        np.concatenate([tree[k] for k in ordering.keys]), reference, rtol=1e-9, atol=1e-9 * scale
    )
    delta = solver.delta()
    if exact_delta:
        np.testing.assert_allclose(
            np.concatenate([delta[k] for k in ordering.keys]), reference, rtol=1e-9, atol=1e-9 * scale
        )
    assert solver.tree.problems() == []
    R, _, tree_order = solver.tree.to_dense()
    p = tree_order.scalar_permutation(ordering)
    np.testing.assert_allclose(R.T @ R, info[np.ix_(p, p)], rtol=1e-9, atol=1e-9 * np.abs(info).max())
    theta, estimate = solver.linearization_point, solver.estimate()
    for k in ordering.keys:
        np.testing.assert_array_equal(estimate[k], theta[k] + delta[k])


# --- property: every update of a random sequence -------------------------------------------

ACTIONS = st.lists(
    st.sampled_from(["state", "state", "state", "two", "extra", "both", "empty"]), min_size=2, max_size=30
)
THRESHOLDS = st.sampled_from([0.0, 0.02, 0.2, INF, {"x": 0.02, "l": INF}, {"x": INF, "l": 0.0}])


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 2**32 - 1),
    n_landmarks=st.integers(1, 3),
    actions=ACTIONS,
    relinearize_threshold=THRESHOLDS,
    relinearize_skip=st.integers(1, 3),
    wildfire_threshold=st.sampled_from([0.0, 1e-3, 0.1]),
)
def test_every_update_matches_dense_solve(
    seed, n_landmarks, actions, relinearize_threshold, relinearize_skip, wildfire_threshold
):
    stream = Stream(np.random.default_rng(seed), n_states=20, n_landmarks=n_landmarks)
    solver = IncrementalSolver(
        relinearize_threshold=relinearize_threshold,
        relinearize_skip=relinearize_skip,
        wildfire_threshold=wildfire_threshold,
    )
    for action in ["state"] + actions:
        factors, values = stream.step(action)
        report = solver.update(factors, values)
        assert isinstance(report, UpdateReport)
        assert_matches_dense(solver, exact_delta=wildfire_threshold == 0)
        # the report is consistent with the tree: new cliques exist, removed ones are gone
        assert all(c in solver.tree.cliques for c in report.new_cliques)
        assert not any(c in solver.tree.cliques for c in report.removed_cliques)
        assert sorted(report.reeliminated) == sorted(
            k for c in report.new_cliques for k in solver.tree.cliques[c].frontals
        )
        assert all(solver.tree.parent[o] in report.new_cliques for o in report.orphans)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), actions=ACTIONS)
def test_zero_thresholds_give_one_gauss_newton_step(seed, actions):
    """Relinearize everything, solve fully: the update is θ ← θ + 𝓘⁻¹Aᵀb at the current estimate.  [YIB Eq. 11]"""
    stream = Stream(np.random.default_rng(seed), n_states=10)
    solver = IncrementalSolver(relinearize_threshold=0.0, relinearize_skip=1, wildfire_threshold=0.0)
    for action in ["state"] + actions:
        factors, values = stream.step(action)
        point = solver.estimate()
        for k, v in values.items():
            point.insert(k, v)
        keys = tuple(point)
        ordering = Ordering(keys, tuple(point.dim(k) for k in keys))
        J, b = LinearSystem.build(list(solver.factors) + factors, point, ordering).to_dense()
        step = np.linalg.solve(J.T @ J, J.T @ b)
        solver.update(factors, values)
        got = np.concatenate([solver.estimate_of(k) for k in keys])
        expected = np.concatenate([point[k] for k in keys]) + step
        np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-9 * np.abs(expected).max())


# --- hand-drawn trees -----------------------------------------------------------------------


def chain_solver() -> tuple[IncrementalSolver, Stream]:
    """x0 (with a prior), then x1, x2, x3, each added with only its GP prior factor.

    With the newest variables ordered last, the tree is the chain

        [x2 x3]
           |
        [x1 : x2]
           |
        [x0 : x1]
    """
    stream = Stream(np.random.default_rng(7), n_states=4)
    solver = IncrementalSolver(relinearize_threshold=INF, wildfire_threshold=0.0)
    solver.update([sr.PriorFactor.create(sr.X(0), stream.xs[0], np.ones(6))], {sr.X(0): stream.xs[0]})
    for i in range(1, 4):
        prior = sr.GPPriorFactor.wnoa(sr.X(i - 1), sr.X(i), stream.times[i] - stream.times[i - 1], QC)
        solver.update([prior], {sr.X(i): stream.xs[i]})
    return solver, stream


def test_chain_tree_by_hand():
    solver, _ = chain_solver()
    tree = solver.tree
    shape = {(c.frontals, c.separator) for c in tree.cliques.values()}
    assert shape == {((sr.X(2), sr.X(3)), ()), ((sr.X(1),), (sr.X(2),)), ((sr.X(0),), (sr.X(1),))}
    assert tree.parent[tree.frontal_of[sr.X(0)]] == tree.frontal_of[sr.X(1)]
    assert tree.parent[tree.frontal_of[sr.X(1)]] == tree.frontal_of[sr.X(2)]


def test_reading_on_x1_removes_its_clique_and_the_root():
    # removed: [x1 : x2] and [x2 x3]; orphan: [x0 : x1], reattached under the clique of x1.
    solver, stream = chain_solver()
    tree = solver.tree
    c01, c12, root = tree.frontal_of[sr.X(0)], tree.frontal_of[sr.X(1)], tree.frontal_of[sr.X(3)]
    report = solver.update([stream.velocity(1)])
    assert set(report.removed_cliques) == {c12, root}
    assert report.orphans == (c01,)
    assert tree.parent[c01] == tree.frontal_of[sr.X(1)]
    assert sorted(report.reeliminated) == [sr.X(1), sr.X(2), sr.X(3)]
    assert_matches_dense(solver, exact_delta=True)


def test_reading_on_x3_removes_only_the_root():
    # removed: [x2 x3]; orphan: [x1 : x2] (with [x0 : x1] below it, untouched).
    solver, stream = chain_solver()
    tree = solver.tree
    c01, c12, root = tree.frontal_of[sr.X(0)], tree.frontal_of[sr.X(1)], tree.frontal_of[sr.X(3)]
    report = solver.update([stream.velocity(3)])
    assert report.removed_cliques == (root,)
    assert report.orphans == (c12,)
    assert c01 in tree.cliques and tree.parent[c01] == c12
    assert_matches_dense(solver, exact_delta=True)


def test_reading_on_x0_removes_everything():
    solver, stream = chain_solver()
    report = solver.update([stream.velocity(0)])
    assert len(report.removed_cliques) == 3 and report.orphans == ()
    assert_matches_dense(solver, exact_delta=True)


# --- relinearization and partial updates ----------------------------------------------------


def run(stream: Stream, solver: IncrementalSolver, actions: list[str]) -> list[UpdateReport]:
    return [solver.update(*stream.step(a)) for a in actions]


def test_per_kind_threshold_keeps_landmarks_at_their_first_linearization(rng):
    stream = Stream(rng, n_states=12, noise=0.2)
    solver = IncrementalSolver(relinearize_threshold={"x": 0.0, "l": INF}, relinearize_skip=1, wildfire_threshold=0.0)
    first: dict = {}
    for report in run(stream, solver, ["state"] * 12):
        for k in solver.linearization_point:
            if k.symbol == "l":
                first.setdefault(k, solver.linearization_point[k].copy())
                np.testing.assert_array_equal(solver.linearization_point[k], first[k])
        assert all(k.symbol == "x" for k in report.relinearized)
    assert any(k.symbol == "x" for r in [report] for k in r.relinearized)
    assert_matches_dense(solver, exact_delta=True)


def test_relinearize_skip_checks_every_kth_update(rng):
    stream = Stream(rng, n_states=12, noise=0.2)
    solver = IncrementalSolver(relinearize_threshold=0.0, relinearize_skip=3, wildfire_threshold=0.0)
    reports = run(stream, solver, ["state"] * 12)
    for r in reports:
        assert bool(r.relinearized) == (r.step % 3 == 0 and r.step > 1)


def test_relinearize_false_keeps_the_linearization_point(rng):
    stream = Stream(rng, n_states=6, noise=0.2)
    solver = IncrementalSolver(relinearize_threshold=0.0, relinearize_skip=1)
    run(stream, solver, ["state"] * 5)
    before = solver.linearization_point
    solver.update(*stream.step("state"), relinearize=False)
    after = solver.linearization_point
    for k in before:
        np.testing.assert_array_equal(after[k], before[k])


def test_wildfire_threshold_limits_back_substitution(rng):
    """A large threshold solves only the re-made cliques; 0 solves every clique."""
    for threshold, expect_all in [(0.0, True), (1e6, False)]:
        stream = Stream(np.random.default_rng(3), n_states=30)
        solver = IncrementalSolver(relinearize_threshold=INF, wildfire_threshold=threshold)
        report = run(stream, solver, ["state"] * 30)[-1]
        if expect_all:
            assert report.backsubstituted_cliques == len(solver.tree)
        else:
            assert report.backsubstituted_cliques == len(report.new_cliques) < len(solver.tree)
        assert_matches_dense(solver, exact_delta=expect_all)


def test_marginal_covariance_matches_dense_inverse(rng):
    stream = Stream(rng, n_states=10)
    solver = IncrementalSolver(relinearize_threshold=0.05, relinearize_skip=1)
    run(stream, solver, ["state"] * 10 + ["extra"] * 3)
    system, ordering = natural_system(solver)
    J, _ = system.to_dense()
    cov = np.linalg.inv(J.T @ J)
    for k in ordering.keys:
        o, d = ordering.offset_of[k], ordering.dims[ordering.position[k]]
        block = cov[o : o + d, o : o + d]
        np.testing.assert_allclose(solver.marginal_covariance(k), block, rtol=1e-9, atol=1e-12 * np.abs(block).max())
    marginals = solver.marginal_covariances()  # one pass down the tree
    assert set(marginals) == set(ordering.keys)
    for k in ordering.keys:
        o, d = ordering.offset_of[k], ordering.dims[ordering.position[k]]
        block = cov[o : o + d, o : o + d]
        np.testing.assert_allclose(marginals[k], block, rtol=1e-9, atol=1e-12 * np.abs(block).max())
    group = [sr.X(0), sr.X(9)]
    idx = np.concatenate([np.arange(ordering.offset_of[k], ordering.offset_of[k] + 6) for k in group])
    np.testing.assert_allclose(solver.joint_covariance(group), cov[np.ix_(idx, idx)], rtol=1e-9, atol=1e-12)


# --- bad input ------------------------------------------------------------------------------


def test_bad_updates_are_rejected_and_leave_the_solver_intact(rng):
    stream = Stream(rng, n_states=6)
    solver = IncrementalSolver(wildfire_threshold=0.0)
    run(stream, solver, ["state"] * 3)
    with pytest.raises(SteamError, match="x1"):  # a new value for an existing variable
        solver.update([stream.velocity(1)], {sr.X(1): np.zeros(6)})
    with pytest.raises(UnknownVariableError, match="x5"):  # a factor on a variable with no value
        solver.update([sr.VelocityFactor.create(sr.X(5), [1.0, 0.0, 0.0], 0.5)])
    with pytest.raises(UnderdeterminedError, match="x9"):  # a new variable no factor constrains
        solver.update([stream.velocity(1)], {sr.X(9): np.zeros(6)})
    with pytest.raises(ShapeError, match="x4"):  # a value of the wrong size
        solver.update([sr.VelocityFactor.create(sr.X(4), [1.0, 0.0, 0.0], 0.5)], {sr.X(4): np.zeros(4)})
    with pytest.raises(SteamError, match=r"new_factors\[0\] is a str"):
        solver.update(["not a factor"])
    assert_matches_dense(solver, exact_delta=True)
    run(stream, solver, ["state", "extra"])
    assert_matches_dense(solver, exact_delta=True)


def test_failed_elimination_rolls_the_update_back(rng):
    """A new landmark seen by one range only is free (1 equation, 2 unknowns): the update fails,
    naming it, and leaves tree, linearization point and estimate exactly as they were."""
    stream = Stream(rng, n_states=8, noise=0.2)
    solver = IncrementalSolver(relinearize_threshold=0.0, relinearize_skip=1, wildfire_threshold=0.0)
    run(stream, solver, ["state"] * 5)
    theta, estimate, n_cliques = solver.linearization_point, solver.estimate(), len(solver.tree)
    lonely = sr.RangeFactor.create(sr.X(2), sr.L(9), 4.0, 0.3)
    with pytest.raises(UnderdeterminedError, match="l9"):
        solver.update([stream.velocity(4), lonely], {sr.L(9): np.array([3.0, 1.0])})
    assert len(solver.tree) == n_cliques and sr.L(9) not in solver.estimate()
    for k in theta:
        np.testing.assert_array_equal(solver.linearization_point[k], theta[k])
        np.testing.assert_array_equal(solver.estimate_of(k), estimate[k])
    assert_matches_dense(solver, exact_delta=True)
    run(stream, solver, ["state", "extra", "state"])
    assert_matches_dense(solver, exact_delta=True)


def test_bad_options_are_rejected():
    with pytest.raises(SteamError, match="relinearize_threshold"):
        IncrementalSolver(relinearize_threshold=-1.0)
    with pytest.raises(SteamError, match="'l'"):
        IncrementalSolver(relinearize_threshold={"x": 0.1, "l": float("nan")})
    with pytest.raises(SteamError, match="relinearize_skip"):
        IncrementalSolver(relinearize_skip=0)
    with pytest.raises(SteamError, match="wildfire_threshold"):
        IncrementalSolver(wildfire_threshold=-0.1)


def test_threshold_dict_without_a_kind_is_named(rng):
    stream = Stream(rng, n_states=4)
    solver = IncrementalSolver(relinearize_threshold={"x": 0.0}, relinearize_skip=1)
    with pytest.raises(SteamError, match="'l'"):
        solver.update(*stream.step("state"))  # brings x0 and the first landmark
    assert len(solver) == 0 and len(solver.tree) == 0 and solver.factors == ()


def test_unknown_key_queries_are_named():
    solver = IncrementalSolver()
    with pytest.raises(UnknownVariableError, match="x3"):
        solver.estimate_of(sr.X(3))
    with pytest.raises(UnknownVariableError, match="x3"):
        solver.marginal_covariance(sr.X(3))


# --- incremental: the work per new state does not grow -------------------------------------


def test_new_states_reeliminate_a_bounded_number_of_variables(rng):
    """2,000 GP states with range readings to 4 landmarks: after a warm-up, every update
    re-eliminates at most 4 + 6 variables, and the count does not grow along the trajectory.

    Each new state brings its GP prior factor to the previous state, a velocity reading and a range
    to one landmark. The constrained ordering keeps the touched variables (previous and new state,
    the landmark) at the top, so the removed part is the landmarks, those two states and a few
    states min degree leaves near them, whatever the length. Relinearization is off and the
    wildfire threshold infinite: what they add is a policy, not a property of the tree.
    """
    n, m, warm_up = 2000, 4, 50
    stream = Stream(rng, n_states=n, n_landmarks=m, noise=0.0)
    solver = IncrementalSolver(relinearize_threshold=INF, wildfire_threshold=INF)
    counts = np.array([len(solver.update(*stream.step("state"), relinearize=False).reeliminated) for _ in range(n)])
    assert counts[warm_up:].max() <= m + 6
    assert counts[-500:].mean() <= counts[warm_up : warm_up + 500].mean() + 0.5
    assert len(solver.tree) >= n // 2  # the tree really is long: most states have their own clique
    assert solver.tree.problems() == []


# --- parameters -----------------------------------------------------------------------------


def test_params_defaults_are_gtsams_and_keyword_changes_override_them():
    params = sr.ISAM2Params()
    assert (params.relinearize_threshold, params.relinearize_skip, params.wildfire_threshold) == (0.1, 10, 0.001)
    assert IncrementalSolver().params == params
    solver = IncrementalSolver(params.replace(relinearize_skip=3), wildfire_threshold=0)
    assert solver.params == sr.ISAM2Params(0.1, 3, 0.0)
    assert params.relinearize_skip == 10  # replace made a copy


def test_params_per_kind_threshold_is_a_plain_copy():
    given = {"x": 0.1, "l": 1}
    params = sr.ISAM2Params(relinearize_threshold=given)
    given["x"] = 5.0
    assert params.threshold_for("x") == 0.1 and params.threshold_for("l") == 1.0
    assert type(params.relinearize_threshold) is dict
    assert isinstance(params.threshold_for("l"), float)
    with pytest.raises(SteamError, match="'v'"):
        params.threshold_for("v")
    assert sr.ISAM2Params(relinearize_threshold=0.3).threshold_for("anything") == 0.3


@pytest.mark.parametrize(
    ("changes", "named"),
    [
        (dict(relinearize_threshold=-0.5), "-0.5"),
        (dict(relinearize_threshold=float("nan")), "nan"),
        (dict(relinearize_threshold=True), "True"),
        (dict(relinearize_threshold={"x": -1.0}), "'x'"),
        (dict(relinearize_threshold="big"), "'big'"),
        (dict(relinearize_skip=0), "0"),
        (dict(relinearize_skip=2.5), "2.5"),
        (dict(relinearize_skip=True), "True"),
        (dict(wildfire_threshold=-1e-3), "-0.001"),
        (dict(wildfire_threshold=False), "False"),
        (dict(wildfire=0.1), "'wildfire'"),
    ],
)
def test_bad_params_are_named(changes, named):
    with pytest.raises(SteamError, match=named):
        sr.ISAM2Params().replace(**changes)
    with pytest.raises(SteamError, match=named):
        IncrementalSolver(**changes)


def test_report_times_every_phase_within_the_total(rng):
    stream = Stream(rng, n_states=5)
    solver = IncrementalSolver(relinearize_skip=1)
    for report in run(stream, solver, ["state"] * 5):
        assert list(report.timings) == [
            "check",
            "add",
            "relinearize",
            "remove",
            "linearize",
            "order",
            "eliminate",
            "backsubstitute",
        ]
        assert all(t >= 0 for t in report.timings.values())
        assert sum(report.timings.values()) <= report.time_s


def test_relinearize_blocks_move_only_the_blocks_over_the_threshold(rng):
    """With {'x': (3, 3)} (pose and velocity as GTSAM would hold them, two variables), a relinearized
    state moves θ̄ by δ on the blocks whose own max |δ| ≥ β and keeps the rest of δ, and the tree
    stays the dense solve of its factors."""
    stream = Stream(rng, n_states=14, noise=0.3)
    beta = 0.02
    solver = IncrementalSolver(
        relinearize_threshold=beta, relinearize_skip=1, wildfire_threshold=0.0, relinearize_blocks={"x": (3, 3)}
    )
    partial = 0
    for action in ["state"] * 14:
        theta, delta = solver.linearization_point, solver.delta()
        report = solver.update(*stream.step(action))
        for k in report.relinearized:
            blocks = [slice(0, 3), slice(3, 6)] if k.symbol == "x" else [slice(0, 2)]
            moved = solver.linearization_point[k] - theta[k]
            for b in blocks:
                over = np.abs(delta[k][b]).max() >= beta
                np.testing.assert_allclose(moved[b], delta[k][b] if over else 0.0, rtol=0, atol=1e-12)
            partial += k.symbol == "x" and (np.abs(delta[k][:3]).max() >= beta) != (np.abs(delta[k][3:]).max() >= beta)
        assert_matches_dense(solver, exact_delta=True)
    assert partial > 0  # some state relinearized one block and not the other


def test_relinearize_blocks_are_checked():
    with pytest.raises(SteamError, match=r"relinearize_blocks\['x'\]"):
        sr.ISAM2Params(relinearize_blocks={"x": (3, -3)})
    params = sr.ISAM2Params(relinearize_blocks={"x": [3, 3]})
    assert params.relinearize_blocks == {"x": (3, 3)}
    np.testing.assert_array_equal(
        params.blocks_to_move("x", np.array([0.0, 0.2, 0, 0, 0, 0.01]), 0.1), [1, 1, 1, 0, 0, 0]
    )
    np.testing.assert_array_equal(params.blocks_to_move("l", np.array([0.0, 0.01]), 0.1), [0, 0])
    with pytest.raises(SteamError, match="do not add up"):
        params.blocks_to_move("x", np.zeros(4), 0.1)
    with pytest.raises(SteamError, match="map a key's symbol"):
        sr.ISAM2Params(relinearize_blocks="x")


def test_a_variable_its_blocks_do_not_fit_is_rejected_on_insert(rng):
    """Checked when the variable arrives, not at the next relinearization; the solver is left as it was."""
    solver = IncrementalSolver(relinearize_blocks={"x": (3, 3)})
    stream = Stream(rng, n_states=3)
    solver.update(*stream.step("state"))
    before = solver.estimate()
    with pytest.raises(ShapeError, match=r"\(3, 3\) for symbol 'x' do not add up to its size 4"):
        solver.update([sr.PriorFactor.create(sr.X(9), np.zeros(4), 1.0)], {sr.X(9): np.zeros(4)})
    assert set(solver.estimate()) == set(before) and len(solver) == len(before)
