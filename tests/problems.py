"""Small STEAM problems with known truth, built from the GP prior itself (not from steam_ref's data code)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import steam_ref as sr
from steam_ref.gp import interpolate_state, process_noise, transition


@dataclass
class SmallProblem:
    graph: sr.FactorGraph
    initial: sr.Values
    truth: dict
    times: np.ndarray
    qc: np.ndarray


def sample_trajectory(rng, times, qc, x0):
    """Exact samples of the WNOA GP at the given times: xᵢ = Φ xᵢ₋₁ + chol(Qᵢ) ξ."""
    xs = [np.asarray(x0, float)]
    for dt in np.diff(times):
        xs.append(transition(dt, 3) @ xs[-1] + np.linalg.cholesky(process_noise(dt, qc)) @ rng.normal(size=6))
    return xs


def small_problem(rng, n_states=8, n_landmarks=3, noise=0.05, robust=True, interpolated=0) -> SmallProblem:
    """A GP trajectory with velocity and range readings, landmark priors, and a perturbed start.

    ``interpolated`` extra range readings are placed between estimated states (Eq. 29).
    """
    qc = np.diag([0.1, 0.2, 0.3])
    keys = [sr.X(i) for i in range(n_states)]
    times = np.cumsum(rng.uniform(0.5, 1.5, n_states))
    xs = sample_trajectory(rng, times, qc, [0.3, -0.2, 0.3, 1.0, 0.5, 0.1])
    truth = dict(zip(keys, xs, strict=True))
    lms = {sr.L(j): rng.normal(size=2) * 5 for j in range(n_landmarks)}
    truth.update(lms)
    loss = sr.Tukey(15.0) if robust else None
    graph = sr.FactorGraph(sr.gp_prior_factors(keys, times, qc))
    graph.add(sr.PriorFactor.create(keys[0], xs[0] + rng.normal(size=6) * 0.1, np.ones(6)))
    for k, l in lms.items():
        graph.add(sr.PriorFactor.create(k, l + rng.normal(size=2) * 0.1, [1.0, 1.0]))
    for i, (key, x) in enumerate(zip(keys, xs, strict=True)):
        th = x[2]
        body = [np.cos(th) * x[3] + np.sin(th) * x[4], -np.sin(th) * x[3] + np.cos(th) * x[4], x[5]]
        graph.add(sr.VelocityFactor.create(key, np.array(body) + rng.normal(size=3) * 0.05, [0.5, 0.5, 1.0]))
        lk = sr.L(i % n_landmarks)
        r = np.hypot(*(x[:2] - lms[lk]))
        graph.add(sr.RangeFactor.create(key, lk, abs(r + rng.normal() * 0.05), 0.3, loss=loss))  # never negative
    for _ in range(interpolated):
        i = int(rng.integers(0, n_states - 1))
        tau = rng.uniform(times[i], times[i + 1])
        lk = sr.L(int(rng.integers(0, n_landmarks)))
        x_tau = interpolate_state(times[i], xs[i], times[i + 1], xs[i + 1], tau, qc)
        r = np.hypot(*(x_tau[:2] - lms[lk])) + rng.normal() * 0.05
        inner = sr.RangeFactor.create(sr.X(-1), lk, r, 0.3, loss=loss)
        graph.add(sr.InterpolatedFactor.create(inner, keys[i], keys[i + 1], times[i], times[i + 1], tau, qc))
    initial = sr.Values({k: v + rng.normal(size=v.shape) * noise for k, v in truth.items()})
    return SmallProblem(graph, initial, truth, times, qc)
