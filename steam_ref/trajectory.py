"""The estimated trajectory as a function of time: states, Eq. 18 between them, covariances.

A :class:`Trajectory` reads a solver's current estimate of the states at the poses ``states``. At a
state it returns the solver's estimate and marginal covariance; between states tᵢ < t < tⱼ,
x̄(t) = Λ(t) x̄ᵢ + Ψ(t) x̄ⱼ [YIB Eq. 18] and the covariance from the joint covariance of (xᵢ, xⱼ)
(:func:`steam_ref.gp.interpolate.interpolate_covariance`). After the last state t_N it predicts
by the prior, x̄(t) = Φ(t, t_N) x̄_N and Φ P_N Φᵀ + Q(t - t_N)
(:func:`steam_ref.gp.interpolate.extrapolate_state_sde`); before the first state there is no
prior to speak of (the GP starts there, [YIB Eq. 14]) and a query is an error.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .errors import SteamError
from .gp.interpolate import (
    extrapolate_covariance_sde,
    extrapolate_state_sde,
    interpolate_covariance,
    interpolate_covariance_sde,
    interpolate_state_sde,
    interpolation_matrices,
)
from .gp.sde import LinearSDE
from .variables import Key, X

__all__ = ["Trajectory", "Covariances"]


@dataclass(frozen=True)
class Covariances:
    """Final marginal covariances of a run, in the order of its times and landmark ids."""

    pose: NDArray  # (n, 3, 3) of [x, y, θ] at every covered pose
    velocity: NDArray  # (n, 3, 3) of [ẋ, ẏ, θ̇] at every covered pose
    landmark: NDArray  # (m, 2, 2) of each landmark, in the order of ``landmark_ids``
    landmark_ids: tuple[int, ...]  # (m,) the landmarks' ids


class Trajectory:
    """A solver's states at poses ``states`` (sorted), queried at any time from the first state on.

    ``prior`` is the motion prior the states were estimated with: Qc (3, 3) of the paper's WNOA prior,
    or any :class:`~steam_ref.gp.LinearSDE` (WNOJ, Singer: states of 9 numbers).
    """

    def __init__(self, solver, states: Sequence[int], times: NDArray, prior: NDArray | LinearSDE):
        self.solver = solver  # anything with estimate_of, estimate, joint_covariance(s), marginals
        self.states = list(states)  # poses with a state, increasing
        self.times = times  # (n_poses,) time of every pose
        # Qc of a WNOA prior uses the memoised closed forms; any other prior goes through its LinearSDE.
        self.qc = None if isinstance(prior, LinearSDE) else np.asarray(prior, dtype=float)
        self.prior = prior if isinstance(prior, LinearSDE) else LinearSDE.wnoa(prior)
        self.n = self.prior.n  # size of a state

    def _between(self, a: int, b: int, t: float, xa: NDArray, xb: NDArray) -> NDArray:
        """x̄(t) between the states at poses a and b.  [YIB Eq. 18]"""
        ta, tb = self.times[a], self.times[b]
        if self.qc is None:
            return interpolate_state_sde(self.prior, ta, xa, tb, xb, t)
        lam, psi = interpolation_matrices(ta, tb, t, self.qc)  # [YIB Eq. 16]
        return lam @ xa + psi @ xb

    def _between_covariance(self, a: int, b: int, t: float, joint: NDArray) -> NDArray:
        ta, tb = self.times[a], self.times[b]
        if self.qc is None:
            return interpolate_covariance_sde(self.prior, ta, tb, t, joint)
        return interpolate_covariance(ta, tb, t, self.qc, joint)

    def neighbours(self, t: float) -> tuple[int, int] | int:
        """The state at time t, or the two states around it."""
        times, solved = self.times, self.states
        if not solved or not times[solved[0]] <= t <= times[solved[-1]]:
            span = "no solved state yet" if not solved else f"[{times[solved[0]]:g}, {times[solved[-1]]:g}]"
            raise SteamError(f"time t={t!r} is outside the estimated span {span}")
        j = int(np.searchsorted(times[solved], t))
        return solved[j] if times[solved[j]] == t else (solved[j - 1], solved[j])

    def at(self, t: float, *, covariance: bool = False) -> NDArray | tuple[NDArray, NDArray]:
        """The state x(t) (n,), with its covariance (n, n) if asked, for any t from the first state on.

        Between states: [YIB Eq. 18]; after the last state t_N: the prior's prediction from x̄_N, P_N.
        """
        t = float(t)
        solved, times = self.states, self.times
        if solved and t < times[solved[0]]:
            raise SteamError(
                f"time t={t!r} is before the first estimated state at t={times[solved[0]]:g}: the GP prior starts "
                f"there, so queries need t >= {times[solved[0]]:g} (after the last state, at t={times[solved[-1]]:g}, "
                "the prior extrapolates)"
            )
        if solved and t > times[solved[-1]]:
            last, key = times[solved[-1]], X(solved[-1])
            mean = extrapolate_state_sde(self.prior, last, self.solver.estimate_of(key), t)
            if not covariance:
                return mean
            return mean, extrapolate_covariance_sde(self.prior, last, t, self.solver.joint_covariance([key]))
        near = self.neighbours(t)
        if isinstance(near, int):
            mean = self.solver.estimate_of(X(near)).copy()
            return (mean, self.solver.joint_covariance([X(near)])) if covariance else mean
        a, b = near
        mean = self._between(a, b, t, self.solver.estimate_of(X(a)), self.solver.estimate_of(X(b)))
        if not covariance:
            return mean
        return mean, self._between_covariance(a, b, t, self.solver.joint_covariance([X(a), X(b)]))

    def at_every_pose(self) -> tuple[NDArray, NDArray]:
        """Times (n_poses,) and states (n_poses, n) at every pose of the span; reads the whole estimate once."""
        solved = self.states
        if not solved:
            return np.zeros(0), np.zeros((0, self.n))
        values, times = self.solver.estimate(), self.times
        out = np.empty((solved[-1] + 1, self.n))
        for a, b in zip(solved, solved[1:]):
            xa, xb = values[X(a)], values[X(b)]
            out[a] = xa
            for p in range(a + 1, b):
                out[p] = self._between(a, b, times[p], xa, xb)  # [YIB Eq. 18]
        out[solved[-1]] = values[X(solved[-1])]
        return times[: solved[-1] + 1].copy(), out

    def covariances(self, landmarks: Sequence[Key]) -> Covariances:
        """Marginal covariances at every pose of the span (interpolated between states) and of ``landmarks``."""
        solved = self.states
        marg = self.solver.marginals([X(i) for i in solved] + list(landmarks))
        gaps = [(a, b) for a, b in zip(solved, solved[1:]) if b > a + 1]
        joints = dict(zip(gaps, self.solver.joint_covariances([(X(a), X(b)) for a, b in gaps]))) if gaps else {}
        n = solved[-1] + 1 if solved else 0
        full = np.empty((n, self.n, self.n))
        for a, b in zip(solved, solved[1:]):
            full[a] = marg[X(a)]
            for p in range(a + 1, b):
                full[p] = self._between_covariance(a, b, self.times[p], joints[(a, b)])
        if solved:
            full[solved[-1]] = marg[X(solved[-1])]
        marks = np.array([marg[k] for k in landmarks]).reshape(-1, 2, 2)
        return Covariances(full[:, :3, :3].copy(), full[:, 3:6, 3:6].copy(), marks, tuple(k.index for k in landmarks))
