"""Levenberg-Marquardt stops on a short step only when the estimate is near a minimum, not when λ made it short.

A damped step (𝓘 + λ diag 𝓘) δ = Aᵀb shrinks as λ grows, after rejected steps or from a large ``initial_damping``,
however far the minimum is; the Gauss-Newton step (λ = 0) is the distance to the minimum of the linearized cost.
The problems are two of Moré, Garbow & Hillstrom's test functions (ACM TOMS 7, 1981), with their classic starts and
minima known in closed form: Rosenbrock's (problem 1) and Brown's badly scaled function (problem 4). The oracles are
those minima and the Gauss-Newton step computed here by dense NumPy from Jacobians written out by hand.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from steam_ref.batch import check_stationarity, levenberg_marquardt
from steam_ref.factors import Factor
from steam_ref.variables import L, Values

P = L(0)  # the one 2-D variable


def rosenbrock(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """e = [10 (y - x²), 1 - x] and its Jacobian; minimum 0 at (1, 1)."""
    x, y = p[..., 0], p[..., 1]
    J = np.zeros(p.shape[:-1] + (2, 2))
    J[..., 0, 0], J[..., 0, 1], J[..., 1, 0] = -20 * x, 10.0, -1.0
    return np.stack([10 * (y - x**2), 1 - x], axis=-1), J


def brown(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """e = [x - 10⁶, y - 2·10⁻⁶, x y - 2] and its Jacobian; minimum 0 at (10⁶, 2·10⁻⁶)."""
    x, y = p[..., 0], p[..., 1]
    J = np.zeros(p.shape[:-1] + (3, 2))
    J[..., 0, 0], J[..., 1, 1], J[..., 2, 0], J[..., 2, 1] = 1.0, 1.0, y, x
    return np.stack([x - 1e6, y - 2e-6, x * y - 2], axis=-1), J


@dataclass(frozen=True, eq=False)
class Residuals(Factor):
    """The residuals of one of the functions above, unit noise, on the vector variable ``P``."""

    function: str
    _shared: ClassVar[tuple[str, ...]] = ("function",)
    key_dims: ClassVar[tuple[int, ...]] = (2,)

    def error(self, p):
        return FUNCTIONS[self.function][0](p)[0]

    def jacobians(self, p):
        return (FUNCTIONS[self.function][0](p)[1],)


FUNCTIONS = {"rosenbrock": (rosenbrock, 2), "brown": (brown, 3)}


def factors(function: str) -> list[Factor]:
    return [Residuals((P,), np.eye(FUNCTIONS[function][1]), function=function)]


def gauss_newton_step(function: str, p: np.ndarray) -> np.ndarray:
    """δ = -(JᵀJ)⁻¹ Jᵀe at ``p``, dense."""
    e, J = FUNCTIONS[function][0](p)
    return np.linalg.solve(J.T @ J, -J.T @ e)


def damped_step(function: str, p: np.ndarray, lam: float) -> np.ndarray:
    """δ = -(JᵀJ + λ diag JᵀJ)⁻¹ Jᵀe at ``p``, dense: Marquardt's step."""
    e, J = FUNCTIONS[function][0](p)
    info = J.T @ J
    return np.linalg.solve(info + lam * np.diag(np.diag(info)), -J.T @ e)


def test_a_step_short_only_because_the_initial_damping_is_large_does_not_stop_lm():
    start = np.array([-1.2, 1.0])
    tolerance, lam = 1e-6, 1e6
    # the premise, by dense algebra: the first damped step is below the tolerance, the Gauss-Newton step is not,
    # and the cost falls (the step is taken): the old rule stopped here, at cost 12.1, far from the minimum
    first = damped_step("rosenbrock", start, lam)
    assert np.linalg.norm(first) < tolerance < np.linalg.norm(gauss_newton_step("rosenbrock", start))
    cost = lambda p: 0.5 * float(np.sum(rosenbrock(p)[0] ** 2))
    assert cost(start + first) < cost(start)
    initial = {P: start.copy()}
    result = levenberg_marquardt(factors("rosenbrock"), initial, initial_damping=lam, step_tolerance=tolerance)
    assert result.converged, result.reason
    np.testing.assert_allclose(result.values[P], [1.0, 1.0], rtol=0, atol=1e-6)  # the minimum
    assert result.cost <= 1e-12
    assert len(result.iterations) <= 100  # within max_iterations, the Gauss-Newton check not counted
    np.testing.assert_array_equal(initial[P], start)  # the initial estimate untouched
    unchecked = levenberg_marquardt(
        factors("rosenbrock"), initial, initial_damping=lam, step_tolerance=tolerance, check=False
    )
    assert not unchecked.converged and unchecked.reason.endswith("(stationarity not checked)")
    np.testing.assert_array_equal(unchecked.values[P], result.values[P])


def test_a_step_short_after_rejected_steps_stops_lm_only_within_the_tolerance_of_the_minimum():
    """From Moré, Garbow & Hillstrom's start (1, 1), eight steps are rejected, λ rises from 10⁻⁵ to 10³ and
    the first step taken is about 500 long, while the minimum is 10⁶ away."""
    start, minimum, tolerance = np.array([1.0, 1.0]), np.array([1e6, 2e-6]), 1e3
    result = levenberg_marquardt(factors("brown"), {P: start}, step_tolerance=tolerance)
    first = next(it for it in result.iterations if it.accepted)
    assert first.damping >= 1e2 and first.step_norm < tolerance  # the premise: λ made the step short
    np.testing.assert_allclose(
        first.step_norm, np.linalg.norm(damped_step("brown", start, first.damping)), rtol=1e-9
    )  # and it is Marquardt's step, by dense algebra
    assert result.iterations[-1] is not first  # the old rule stopped at it, 10⁶ from the minimum
    # the rule's promise: where it stops, the Gauss-Newton step, and so the distance to the minimum, is within it
    assert np.linalg.norm(gauss_newton_step("brown", result.values[P])) <= tolerance
    assert np.linalg.norm(result.values[P] - minimum) <= tolerance
    assert result.reason.startswith("step norm")  # the step rule stopped it, where it holds
    # converged says only what the check at the returned estimate says
    found = check_stationarity(factors("brown"), Values({P: result.values[P]}), result.ordering)
    assert result.converged == found.holds(1e-8, 1e-12)


def test_a_short_step_near_the_minimum_still_stops_lm_at_once():
    """Where the damping is small, a short taken step stops LM at that iteration, as before: the check of the
    Gauss-Newton step adds no iteration and moves no estimate (a guard on the fix: it passes on the old rule too)."""
    tolerance = 1e-3
    result = levenberg_marquardt(
        factors("rosenbrock"),
        {P: np.array([-1.2, 1.0])},
        step_tolerance=tolerance,
        relative_tolerance=0.0,
        absolute_tolerance=0.0,
    )
    taken = [it for it in result.iterations if it.accepted]
    assert taken[-1] is result.iterations[-1] and taken[-1].step_norm <= tolerance
    assert all(it.step_norm > tolerance for it in taken[:-1])  # it stopped at the first short step taken
    assert np.linalg.norm(gauss_newton_step("rosenbrock", result.values[P])) <= tolerance
    assert "step norm" in result.reason  # the step rule stopped it, not a cost rule (both are off)
    np.testing.assert_allclose(result.values[P], [1.0, 1.0], rtol=0, atol=1e-6)
