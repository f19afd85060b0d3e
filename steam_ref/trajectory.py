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
    """A solver's states at poses ``states`` (sorted), queried at any time from the first state on."""

    def __init__(self, solver, states: Sequence[int], times: NDArray, qc: NDArray):
        self.solver = solver  # anything with estimate_of, estimate, joint_covariance(s), marginals
        self.states = list(states)  # poses with a state, increasing
        self.times = times  # (n_poses,) time of every pose
        self.qc = qc  # (3, 3) Qc of the WNOA prior
        self.prior = LinearSDE.wnoa(qc)  # the same prior as an SDE, for prediction after the last state

    def neighbours(self, t: float) -> tuple[int, int] | int:
        """The state at time t, or the two states around it."""
        times, solved = self.times, self.states
        if not solved or not times[solved[0]] <= t <= times[solved[-1]]:
            span = "no solved state yet" if not solved else f"[{times[solved[0]]:g}, {times[solved[-1]]:g}]"
            raise SteamError(f"time t={t!r} is outside the estimated span {span}")
        j = int(np.searchsorted(times[solved], t))
        return solved[j] if times[solved[j]] == t else (solved[j - 1], solved[j])

    def at(self, t: float, *, covariance: bool = False) -> NDArray | tuple[NDArray, NDArray]:
        """The state x(t) (6,), with its covariance (6, 6) if asked, for any t from the first state on.

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
        ta, tb = self.times[a], self.times[b]
        lam, psi = interpolation_matrices(ta, tb, t, self.qc)
        mean = lam @ self.solver.estimate_of(X(a)) + psi @ self.solver.estimate_of(X(b))  # [YIB Eq. 18]
        if not covariance:
            return mean
        return mean, interpolate_covariance(ta, tb, t, self.qc, self.solver.joint_covariance([X(a), X(b)]))

    def at_every_pose(self) -> tuple[NDArray, NDArray]:
        """Times (n,) and states (n, 6) at every pose of the span; reads the whole estimate once."""
        solved = self.states
        if not solved:
            return np.zeros(0), np.zeros((0, 6))
        values, times = self.solver.estimate(), self.times
        out = np.empty((solved[-1] + 1, 6))
        for a, b in zip(solved, solved[1:]):
            xa, xb = values[X(a)], values[X(b)]
            out[a] = xa
            for p in range(a + 1, b):
                lam, psi = interpolation_matrices(times[a], times[b], times[p], self.qc)  # [YIB Eq. 16]
                out[p] = lam @ xa + psi @ xb  # [YIB Eq. 18]
        out[solved[-1]] = values[X(solved[-1])]
        return times[: solved[-1] + 1].copy(), out

    def covariances(self, landmarks: Sequence[Key]) -> Covariances:
        """Marginal covariances at every pose of the span (interpolated between states) and of ``landmarks``."""
        solved = self.states
        marg = self.solver.marginals([X(i) for i in solved] + list(landmarks))
        gaps = [(a, b) for a, b in zip(solved, solved[1:]) if b > a + 1]
        joints = dict(zip(gaps, self.solver.joint_covariances([(X(a), X(b)) for a, b in gaps]))) if gaps else {}
        n = solved[-1] + 1 if solved else 0
        full = np.empty((n, 6, 6))
        for a, b in zip(solved, solved[1:]):
            full[a] = marg[X(a)]
            for p in range(a + 1, b):
                full[p] = interpolate_covariance(self.times[a], self.times[b], self.times[p], self.qc, joints[(a, b)])
        if solved:
            full[solved[-1]] = marg[X(solved[-1])]
        marks = np.array([marg[k] for k in landmarks]).reshape(-1, 2, 2)
        return Covariances(full[:, :3, :3].copy(), full[:, 3:, 3:].copy(), marks, tuple(k.index for k in landmarks))
