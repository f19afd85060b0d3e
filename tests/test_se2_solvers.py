"""SE(2) states (``steam_ref.lie.SE2_STATE``) through every solver, against a dense Gauss-Newton written here
that retracts on SE(2) and takes its Jacobians by central differences through the retraction (not the
factors' own): batch Gauss-Newton, the Bayes tree with relinearization, marginalization (against a dense
Schur complement frozen at the linearization point, Eq. 10.4 of the derivations), the fixed-lag smoother's
kept history, and covariance recovery (the dense inverse of JᵀJ at the optimum, in the right tangent:
the pose block in the body frame).

The robot turns about 1.1 rad a step, so an estimate moved by ``+`` in place of the right retraction would land
measurably elsewhere; the factors declare their states SE(2) (``key_kinds``), so a plain dict of estimates reaches
the same optimum and states called vectors are refused (the batch test checks both).
"""

from __future__ import annotations

import numpy as np
import pytest

from steam_ref.batch import gauss_newton
from steam_ref.bayes_tree import FixedLagSmoother, IncrementalSolver, marginalize
from steam_ref.errors import KindError
from steam_ref.factors import PriorFactor
from steam_ref.factors.lie_prior import LiePriorFactor, LieStatePrior
from steam_ref.factors.lie_readings import BodyVelocityFactor, PoseReading
from steam_ref.lie import SE2, SE2_STATE, world_position_covariance
from steam_ref.manifold import VECTOR
from steam_ref.variables import L, Values, X

QC = np.diag([0.05, 0.02, 0.1])
LANDMARKS = {1: np.array([3.0, 4.0]), 2: np.array([-2.0, 5.0]), 3: np.array([1.0, -4.0])}
RANGE_SIGMA, VEL_SIGMAS = 0.05, np.array([0.05, 0.05, 0.05])


def kind(key):
    return SE2_STATE if key.symbol == "x" else VECTOR


def problem(seed: int, n: int, model: str = "local-variable"):
    """A robot turning ~1.1 rad a step among three surveyed landmarks; per-state batches of factors and a start
    0.2 (tangent) off the truth."""
    rng = np.random.default_rng(seed)
    truth = [np.r_[0.0, 0.0, 0.0, 1.0, 0.0, 1.1]]
    for _ in range(n - 1):
        w = truth[-1][3:] + rng.normal(0, 0.05, 3)
        truth.append(np.r_[SE2.compose(truth[-1][:3], SE2.exp(w)), w])
    steps = []
    for i, x in enumerate(truth):
        fs = [LieStatePrior.create(X(0), x, np.full(6, 0.05), group=SE2)] if i == 0 else []
        fs += [PriorFactor.create(L(j), l, 1e-2) for j, l in LANDMARKS.items()] if i == 0 else []
        fs += [LiePriorFactor.create(X(i - 1), X(i), 1.0, QC, model, group=SE2)] if i > 0 else []
        fs.append(BodyVelocityFactor.create(X(i), x[3:] + VEL_SIGMAS * rng.standard_normal(3), VEL_SIGMAS, group=SE2))
        for j, l in LANDMARKS.items():
            r = float(np.hypot(*(l - x[:2]))) + RANGE_SIGMA * rng.standard_normal()
            fs.append(PoseReading.range(X(i), L(j), r, RANGE_SIGMA, group=SE2))
        steps.append(fs)
    guesses = {X(i): SE2_STATE.retract(x, rng.normal(0, 0.2, 6)) for i, x in enumerate(truth)}
    guesses |= {L(j): l + rng.normal(0, 0.05, 2) for j, l in LANDMARKS.items()}
    return steps, guesses, truth


def new_values(i, guesses):
    """The variables step i brings: X(i), and the landmarks at step 0."""
    keys = [X(i)] + ([L(j) for j in LANDMARKS] if i == 0 else [])
    return Values({k: guesses[k] for k in keys}, kinds={k: kind(k) for k in keys})


def retract(x, delta):
    return {k: kind(k).retract(x[k], delta[k]) for k in x}


def dense_jacobian(factors, x, keys):
    """Whitened residual r and J = ∂r(x ⊕ δ)/∂δ, each factor's block by central differences through ⊕ (every
    perturbation of a factor's variables evaluated in one broadcast call of its error)."""
    starts = dict(zip(keys, np.cumsum([0] + [len(x[k]) for k in keys[:-1]]), strict=True))
    rows, blocks, h = [], [], 1e-6
    for f in factors:
        dims = [len(x[k]) for k in f.keys]
        n = 2 * sum(dims)
        args = [np.repeat(x[k][None, :], n + 1, axis=0) for k in f.keys]  # row 0: x; then ±h along each axis
        row = 1
        for pos, k in enumerate(f.keys):
            d = dims[pos]
            steps = np.repeat(h * np.eye(d), 2, axis=0) * np.tile([1.0, -1.0], d)[:, None]  # +h e₀, -h e₀, +h e₁, ...
            args[pos][row : row + 2 * d] = kind(k).retract(np.repeat(x[k][None, :], 2 * d, axis=0), steps)
            row += 2 * d
        e = f.whitened_error(*args)
        rows.append(e[0])
        J = np.zeros((e.shape[1], sum(len(x[k]) for k in keys)))
        row = 1
        for pos, k in enumerate(f.keys):
            for a in range(dims[pos]):
                J[:, starts[k] + a] += (e[row] - e[row + 1]) / (2 * h)
                row += 2
        blocks.append(J)
    return np.concatenate(rows), np.vstack(blocks)


def split(v, keys, x):
    out, o = {}, 0
    for k in keys:
        out[k] = v[o : o + len(x[k])]
        o += len(x[k])
    return out


def dense_gauss_newton(factors, initial, marginal=None):
    """Gauss-Newton on SE(2) (x ← x ⊕ δ). ``marginal`` = (keys S, θ₀_S, H, g): a frozen quadratic
    ½ uᵀHu + gᵀu in u = θ_S ⊖ θ₀_S with constant Jacobian (the MarginalFactor's definition, Eq. 10.4)."""
    keys = list(initial)
    x = {k: np.array(v, float) for k, v in initial.items()}
    for _ in range(30):
        r, J = dense_jacobian(factors, x, keys)
        H, grad = J.T @ J, J.T @ r
        if marginal is not None:
            skeys, theta0, Hm, gm = marginal
            idx = np.concatenate([np.arange(*span) for span in spans(keys, x, skeys)])
            u = np.concatenate([kind(k).local(theta0[k], x[k]) for k in skeys])
            H[np.ix_(idx, idx)] += Hm
            grad[idx] += Hm @ u + gm
        delta = np.linalg.solve(H, -grad)
        x = retract(x, split(delta, keys, x))
        if np.abs(delta).max() < 1e-10:  # the difference Jacobians' error (~1e-9) slows the last steps, not the point
            break
    return x


def spans(keys, x, wanted):
    starts = dict(zip(keys, np.cumsum([0] + [len(x[k]) for k in keys[:-1]]), strict=True))
    return [(starts[k], starts[k] + len(x[k])) for k in wanted]


def assert_close(got, want, keys, tol=1e-7):
    for k in keys:
        assert np.abs(kind(k).local(want[k], got[k])).max() < tol, (k, got[k], want[k])


@pytest.fixture(scope="module")
def chain():
    steps, guesses, truth = problem(7, 10)
    factors = [f for fs in steps for f in fs]
    return steps, guesses, truth, factors, dense_gauss_newton(factors, guesses)


def test_batch_gauss_newton_on_se2_states(chain):
    _, guesses, truth, factors, want = chain
    kinds = {k: kind(k) for k in guesses}
    got = gauss_newton(factors, Values(guesses, kinds=kinds), relative_tolerance=1e-14, step_tolerance=1e-12).values
    assert_close(got, want, want)
    assert got.kind(X(3)) is SE2_STATE
    assert max(np.abs(SE2_STATE.local(truth[i], want[X(i)])[:3]).max() for i in range(10)) < 0.2  # near the truth
    plain = gauss_newton(factors, guesses, relative_tolerance=1e-14, step_tolerance=1e-12).values  # kinds: the factors'
    assert all(plain[k].tobytes() == got[k].tobytes() for k in want) and plain.kind(X(3)) is SE2_STATE
    with pytest.raises(KindError, match="the kind of x0 is given twice and differs: vector by its value"):
        gauss_newton(factors, Values(guesses, kinds=dict.fromkeys(guesses, VECTOR)))  # x + δ: refused


@pytest.mark.parametrize("model", ["local-variable", "simplified"])
def test_the_bayes_tree_relinearizes_se2_states(model):
    steps, guesses, _ = problem(8, 12, model)
    # a variable is relinearized when its step reaches 1e-9: the fixed point is the optimum to that
    solver = IncrementalSolver(relinearize_threshold=1e-9, relinearize_skip=1, wildfire_threshold=0.0)
    for i, fs in enumerate(steps):
        solver.update(fs, new_values(i, guesses))
    for _ in range(30):  # updates with nothing new: fluid relinearization to the optimum
        solver.update()
    want = dense_gauss_newton([f for fs in steps for f in fs], guesses)
    estimate = solver.estimate()
    assert_close(estimate, want, want)
    assert estimate.kind(X(4)) is SE2_STATE and -np.pi < estimate[X(4)][2] <= np.pi


def test_marginalization_freezes_the_schur_complement_in_the_se2_tangent():
    steps, guesses, truth = problem(9, 10)
    solver = IncrementalSolver(relinearize_threshold=0.0, relinearize_skip=1, wildfire_threshold=0.0)
    for i, fs in enumerate(steps):
        solver.update(fs, new_values(i, guesses))
    for _ in range(10):
        solver.update()
    theta0 = dict(solver.linearization_point)
    drop = [X(0), X(1)]
    marginalize(solver, drop)
    # later readings pull the separator away from θ₀, so the frozen factor's θ ⊖ θ₀ matters
    rng = np.random.default_rng(1)
    later = [PoseReading.range(X(2), L(j), float(np.hypot(*(l - truth[2][:2]))) + 0.3, 0.02, group=SE2) for j, l in LANDMARKS.items()]  # fmt: skip
    later += [BodyVelocityFactor.create(X(2), truth[2][3:] + rng.normal(0, 0.3, 3), 0.01, group=SE2)]
    solver.update(later)
    for _ in range(20):
        solver.update()
    # the oracle: the Schur complement of the factors on X0, X1 at θ₀, onto the variables they share with the rest
    factors = [f for fs in steps for f in fs]
    gone = [f for f in factors if set(f.keys) & set(drop)]
    touched = list(dict.fromkeys(k for f in gone for k in f.keys))
    sep = [k for k in touched if k not in drop]
    r, J = dense_jacobian(gone, theta0, drop + sep)
    H, g = J.T @ J, J.T @ r
    m = sum(len(theta0[k]) for k in drop)
    schur = H[m:, m:] - H[m:, :m] @ np.linalg.solve(H[:m, :m], H[:m, m:])
    gs = g[m:] - H[m:, :m] @ np.linalg.solve(H[:m, :m], g[:m])
    rest = [f for f in factors if f not in gone] + later
    start = {k: v for k, v in theta0.items() if k not in drop}
    want = dense_gauss_newton(rest, start, marginal=(sep, theta0, schur, gs))
    estimate = solver.estimate()
    assert X(0) not in estimate and max(np.abs(kind(k).local(theta0[k], want[k])).max() for k in sep) > 1e-2
    assert_close(estimate, want, want, tol=1e-6)


def test_the_fixed_lag_history_on_se2_states_is_near_the_full_optimum():
    """No closed oracle for a window that slid over a nonlinear problem: the smoothed history and the window
    must lie near the full batch optimum (the marginal factors froze at nearly converged points), far nearer
    than the lagged history before smoothing; a history recovered with + in place of ⊕ would not."""
    steps, guesses, _ = problem(10, 16)
    smoother = FixedLagSmoother(3.0, keep_history=True, relinearize_threshold=0.0, relinearize_skip=1,
                                wildfire_threshold=0.0)  # fmt: skip
    lagged = {}
    for i, fs in enumerate(steps):
        smoother.update(fs, new_values(i, guesses), timestamps={X(i): float(i)})
        for _ in range(3):
            smoother.update()
        done = smoother.last_marginalization
        lagged |= {} if done is None else {k: v for k, v in done.estimates.items() if k.symbol == "x"}
    assert smoother.n_marginalized >= 10
    want = dense_gauss_newton([f for fs in steps for f in fs], guesses)
    past, window = smoother.smoothed_history(), smoother.estimate()
    assert set(past) | set(window) == set(want)
    off = max(np.abs(SE2_STATE.local(want[k], past[k])).max() for k in past if k.symbol == "x")
    assert off < 5e-3, off
    assert_close(window, want, [k for k in window if k.symbol == "x"], tol=5e-3)
    assert all(-np.pi < past[k][2] <= np.pi for k in past if k.symbol == "x")


def test_covariances_of_se2_states_are_those_of_the_right_tangent(chain):
    steps, guesses, _, factors, want = chain
    keys = list(want)
    _, J = dense_jacobian(factors, want, keys)
    cov = np.linalg.inv(J.T @ J)  # the dense oracle, in the right tangent at the optimum
    result = gauss_newton(factors, Values(guesses, kinds={k: kind(k) for k in guesses}))
    solver = IncrementalSolver(relinearize_threshold=0.0, relinearize_skip=1, wildfire_threshold=0.0)
    for i, fs in enumerate(steps):
        solver.update(fs, new_values(i, guesses))
    for _ in range(10):
        solver.update()
    (a, b), (c, d) = spans(keys, want, [X(4), X(5)])
    for got in (result.marginal_covariance(X(4)), solver.marginal_covariance(X(4))):
        np.testing.assert_allclose(got, cov[a:b, a:b], rtol=1e-5, atol=1e-12)
    np.testing.assert_allclose(solver.joint_covariance([X(4), X(5)])[:6, 6:], cov[a:b, c:d], rtol=1e-5, atol=1e-10)
    # the world-frame position: the first-order spread of the position of x ⊕ δ
    x, P = want[X(4)], cov[a:b, a:b]
    Jp = np.column_stack([(SE2_STATE.retract(x, 1e-6 * e)[:2] - SE2_STATE.retract(x, -1e-6 * e)[:2]) / 2e-6 for e in np.eye(6)])  # fmt: skip
    np.testing.assert_allclose(world_position_covariance(x, P), Jp @ P @ Jp.T, rtol=1e-6)
    assert not np.allclose(world_position_covariance(x, P), P[:2, :2], rtol=1e-2)  # the body frame is not the world's
