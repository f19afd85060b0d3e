"""Qc from data: the maximum-likelihood diagonal Qc of a motion prior, given the poses of a run.  [DER 16.1-16.5]

A motion prior's white noise has a power spectral density Qc [YIB Eq. 14]; the paper gives one per data set,
tuned by hand. :func:`fit_qc` reads one from ground truth instead: the poses [x, y, θ] of a run at its states'
times (on the prior's clock) are the data, the states' velocities (and any higher derivative) are not observed.
The velocities are smoothed (a batch solve of the prior's own factors with every pose held at the truth), and
the fitted Qc is the maximum of the poses' likelihood, which for a prior whose noise over a step is Q(Δt) ⊗ Qc
has a closed form per dimension (docs/derivations.md §16):

    Qc_jj = min over the velocities of Σᵢ eᵢⱼᵀ Q(Δtᵢ)⁻¹ eᵢⱼ / (N - k + 1)

(N intervals, k blocks of the state: 2 for WNOA; eᵢⱼ the prior residual's components of dimension j). On a
vector-space prior it is exact and the velocities it smooths do not depend on Qc; on a Lie group it is the
same to first order, and ``refit`` smooths again at the fitted Qc until it settles.

Why maximum likelihood and not NEES calibration: it needs no estimator run and no Monte Carlo study (whose tasks
are drawn from the model at a Qc already chosen), it fits each dimension on its own, and its spread is known
(each Qc_jj is a χ² with N - k + 1 degrees of freedom: ``QcFit.standard_error``). NEES on one real run mixes the
readings' noise and the linearization with Qc and calibrates one scale at best.

Written against :class:`~steam_ref.motion.MotionPrior` alone: its prior factor (error and noise), its first
state's prior (a pose held, the velocity free) and a new state's value; it asks no prior its name.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..arguments import finite, integer, real_array
from ..batch import gauss_newton
from ..errors import ConvergenceError, ConvergenceWarning, DataError, ShapeError, SteamError
from ..factors import Factor
from ..gp.clock import Clock
from ..graph import FactorGraph
from ..motion import MotionPrior, as_motion_prior
from ..variables import Values, X

__all__ = ["QcFit", "fit_qc", "finite_difference_velocity", "poses_needed", "qc_units"]

POSE_HOLD = 1e-4  # a pose's sigma, over the smallest position sigma the prior allows over a step: the truth held
FREE_VELOCITY = 1e6  # the sigma of the first state's velocity (and higher) prior: no information, in effect
_COUPLING = 1e-9  # relative size of Σᵢ's entries between two dimensions above which the noise is not Q(Δt) ⊗ Qc
POSE_UNITS = ("m", "m", "rad")  # a planar pose [x, y, θ] (docs/api.md), and an SE(2) twist's [vx, vy, ω] per time
_SUPERSCRIPTS = str.maketrans({"^": None, **dict(zip("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹", strict=True))})


def qc_units(blocks: int, clock: Clock, *, superscripts: bool = False) -> tuple[str, ...]:
    """The unit of each diagonal entry of a planar prior's Qc (and of its standard error), as ``'m^2/s^3'``, or
    ``'m²/s³'`` with ``superscripts``: Qc is the power spectral density of the white noise w(t) that drives the
    k-th derivative of the pose [YIB Eq. 14, 30-31], k = ``blocks`` (2 for WNOA: p̈ = w(t), the acceleration; 3 for
    WNOJ and Singer, the jerk), so w is in units of the pose per time^k and Qc, w² times time, per time^(2k - 1):
    m²/s³ for x and y and rad²/s³ for θ under WNOA. Time is the model's (``clock.unit``): seconds, or on a
    'pose-index' clock the pose step ('m^2/step^3')."""
    blocks = integer("blocks", blocks, 1)
    units = tuple(f"{u}^2/{clock.unit}^{2 * blocks - 1}" for u in POSE_UNITS)
    return tuple(u.translate(_SUPERSCRIPTS) for u in units) if superscripts else units


@dataclass(frozen=True)
class QcFit:
    """The fitted Qc and what it was fitted from (:func:`fit_qc`)."""

    qc: NDArray  # (d, d) diagonal: the maximum-likelihood Qc, on the prior's clock
    standard_error: NDArray  # (d,) of each diagonal entry: Qc_jj sqrt(2 / dof) (χ² with dof degrees of freedom)
    dof: int  # degrees of freedom of each dimension: N - k + 1
    intervals: int  # N, the steps between the poses
    blocks: int  # k, blocks of d numbers in a state's tangent (2 for WNOA: pose, velocity)
    rounds: int  # smoothings done (one without ``refit``)
    smoothed_at: NDArray  # (d, d) the Qc the last smoothing used
    states: NDArray = field(repr=False)  # (n, state_dim) the smoothed states the residuals were read at

    def summary(self) -> dict[str, object]:
        """The figures as JSON-ready numbers."""
        return {
            "qc_diagonal": np.diag(self.qc).tolist(),
            "standard_error": self.standard_error.tolist(),
            "dof": self.dof,
            "intervals": self.intervals,
            "blocks": self.blocks,
            "rounds": self.rounds,
            "smoothed_at_diagonal": np.diag(self.smoothed_at).tolist(),
        }


def finite_difference_velocity(times: NDArray, poses: NDArray) -> NDArray:
    """(n, 3) world-frame [ẋ, ẏ, θ̇] at each pose: the backward difference over the step before it (the first
    pose: the forward one), headings already unwrapped. Only a starting value for the smoothing."""
    velocity = np.diff(poses, axis=0) / np.diff(times)[:, None]
    return np.vstack([velocity[:1], velocity])


def _inputs(times: ArrayLike, poses: ArrayLike | None) -> tuple[NDArray, NDArray]:
    """The checked model times (n,) and poses (n, 3), headings unwrapped; SteamError naming a bad value."""
    if poses is None:
        raise DataError("fit_qc needs ground truth (the poses at the states' times): the data set has none")
    t, p = real_array("times", times), real_array("poses", poses)
    if t.ndim != 1:
        raise ShapeError(f"times must be a 1-d array, one time per pose, got shape {t.shape}")
    if p.ndim != 2 or p.shape[1] != 3:
        raise ShapeError(f"poses must be (n, 3) [x, y, θ] at the states' times, got shape {p.shape}")
    if len(t) != len(p):
        raise ShapeError(f"times and poses must have one row per pose, got {len(t)} times and {len(p)} poses")
    finite("times", t)
    finite("poses", p)
    step = np.diff(t)
    if np.any(step <= 0):
        i = int(np.flatnonzero(step <= 0)[0])
        raise DataError(
            f"times must increase strictly, but times[{i}] = {float(t[i])!r} and times[{i + 1}] = {float(t[i + 1])!r}"
        )
    p[:, 2] = np.unwrap(p[:, 2])  # a step turns less than half a turn: a vector prior reads the heading unwrapped
    return t, p


def _blocks(prior: MotionPrior, factor: Factor) -> tuple[int, int]:
    """(d, k): the noise's dimensions and the blocks of d numbers in the prior's residual (a state's tangent)."""
    d = prior.qc.shape[0]
    if factor.dim % d:
        raise SteamError(f"{prior!r}: its prior factor has {factor.dim} numbers, not blocks of Qc's {d}")
    return d, factor.dim // d


def poses_needed(prior: MotionPrior | ArrayLike) -> int:
    """The fewest poses :func:`fit_qc` fits ``prior`` to: a state of k blocks of Qc's d numbers (a pose and its
    velocity: 2; and its acceleration: 3) leaves k - 1 of them unobserved, so the fit needs more than k - 1 steps."""
    prior = as_motion_prior(prior)
    return _blocks(prior, prior.prior_factor(X(0), X(1), 1.0))[1] + 1


def _noise(prior: MotionPrior, factors: list[Factor], d: int, k: int) -> NDArray:
    """(N, d, k, k): each step's noise Σᵢ = (WᵀW)⁻¹, by dimension, over the prior's own Qc_jj (Q(Δtᵢ) for each j);
    SteamError when Σᵢ couples two dimensions (not Q(Δt) ⊗ a diagonal Qc)."""
    W = np.stack([f.sqrt_information for f in factors])
    sigma = np.linalg.inv(np.einsum("nki,nkj->nij", W, W))
    order = np.arange(d * k).reshape(k, d).T  # dimension j: components j, j + d, ..., j + (k - 1) d
    blocks = sigma[:, order[:, :, None, None], order[None, None, :, :]]  # (N, d, k, d, k)
    own = blocks[:, np.arange(d), :, np.arange(d), :].transpose(1, 0, 2, 3)  # (N, d, k, k)
    cross = blocks.copy()
    cross[:, np.arange(d), :, np.arange(d), :] = 0.0
    scale = np.max(np.abs(sigma), axis=(1, 2))
    worst = np.max(np.abs(cross), axis=(1, 2, 3, 4)) / scale
    if np.any(worst > _COUPLING):
        i = int(np.argmax(worst))
        raise SteamError(
            f"{prior!r}: its noise over step {i} couples two dimensions (relative size {float(worst[i]):.3g}); "
            "fit_qc fits the diagonal Qc of a prior whose noise is Q(Δt) ⊗ Qc with Qc diagonal"
        )
    return own / np.diag(prior.qc)[None, :, None, None]


def _smooth(prior: MotionPrior, times: NDArray, poses: NDArray, start: NDArray) -> tuple[NDArray, list[Factor]]:
    """The states with every pose held at ``poses`` and the velocities (and higher) free: the minimum over them of
    the prior's cost [DER 16.3], by Gauss-Newton from ``start``; and the prior factors between them."""
    n = len(times)
    factors = [prior.prior_factor(X(i), X(i + 1), float(times[i + 1] - times[i])) for i in range(n - 1)]
    d, k = _blocks(prior, factors[0])
    position = np.sqrt(np.min(_noise(prior, factors, d, k)[:, :, 0, 0] * np.diag(prior.qc)))
    sigmas = [np.full(d, POSE_HOLD * position)] + [np.full(d, FREE_VELOCITY)] * (k - 1)
    holds = [prior.first_state_prior(X(i), poses[i], np.zeros(d), sigmas) for i in range(n)]
    initial = Values({X(i): start[i] for i in range(n)})
    result = gauss_newton(FactorGraph(factors + holds), initial, max_iterations=100)
    if not result.converged:
        raise ConvergenceError(f"fit_qc: smoothing the velocities under {prior!r} did not converge ({result.reason})")
    return result.values.stack([X(i) for i in range(n)]), factors


def fit_qc(
    prior: MotionPrior | ArrayLike,
    times: ArrayLike,
    poses: ArrayLike | None,
    *,
    refit: Callable[[NDArray], MotionPrior] | None = None,
    rounds: int = 10,
    tolerance: float = 1e-4,
) -> QcFit:
    """The maximum-likelihood diagonal Qc of ``prior`` from the ``poses`` (n, 3) [x, y, θ] at ``times`` (n,).
    [DER 16.1-16.5]

    ``times`` are on the prior's clock (a set-up's ``Clock.model``: on a 'pose-index' clock, the pose index).
    ``prior``: a :class:`~steam_ref.motion.MotionPrior` (or Qc of the paper's WNOA) whose noise over a step is
    Q(Δt) ⊗ Qc with its own Qc diagonal; the velocities are smoothed at that Qc. ``refit(qc)`` builds the same prior
    at another Qc (``lambda qc: motion_prior('se2', qc)``): then the velocities are smoothed again at the fitted Qc
    until no diagonal entry moves by more than ``tolerance`` relative, at most ``rounds`` times (a prior on a Lie
    group; on a vector prior the smoothed velocities do not depend on Qc and one round is exact).
    DataError when ``poses`` is None (no ground truth) or the times do not increase; ShapeError for mismatched
    lengths or shapes; SteamError for a prior whose noise couples dimensions.
    """
    prior = as_motion_prior(prior)
    t, p = _inputs(times, poses)
    rounds = integer("rounds", rounds, 1)
    dt = np.diff(t)
    if len(t) < poses_needed(prior):
        k = poses_needed(prior) - 1
        raise DataError(
            f"fit_qc needs more than {k - 1} steps between poses (a state has {k - 1} unobserved blocks), got {len(dt)}"
        )
    velocity = finite_difference_velocity(t, p)
    states = np.array(
        [prior.initial_state(p[i], velocity[i], float(dt[max(i - 1, 0)])) for i in range(len(t))], dtype=float
    )
    for done in range(1, rounds + 1):
        if not np.allclose(prior.qc, np.diag(np.diag(prior.qc)), rtol=0.0, atol=0.0):
            raise SteamError(f"fit_qc smooths at a diagonal Qc; {prior!r} has Qc {prior.qc.tolist()!r}")
        states, factors = _smooth(prior, t, p, states)
        d, k = _blocks(prior, factors[0])
        n_steps = len(factors)
        dof = n_steps - k + 1
        errors = type(factors[0]).stack(factors).error(states[:-1], states[1:])  # (N, k d), one call
        by_dimension = errors.reshape(n_steps, k, d).transpose(0, 2, 1)  # (N, d, k)
        step_noise = _noise(prior, factors, d, k)  # Q(Δtᵢ), (N, d, k, k)
        whitened = np.einsum("ndk,ndk->nd", by_dimension, np.linalg.solve(step_noise, by_dimension[..., None])[..., 0])
        fitted = np.sum(whitened, axis=0) / dof  # [DER 16.2]
        smoothed_at = np.array(prior.qc)
        moved = np.max(np.abs(fitted / np.diag(smoothed_at) - 1.0))
        if refit is None or moved <= tolerance:
            break
        if done == rounds:
            warnings.warn(
                f"fit_qc: after {rounds} smoothings the fitted Qc still moved by {moved:.3g} relative (tolerance "
                f"{tolerance:g}); the last is returned",
                ConvergenceWarning,
                stacklevel=2,
            )
            break
        prior = refit(np.diag(fitted))
    return QcFit(
        qc=np.diag(fitted),
        standard_error=fitted * np.sqrt(2.0 / dof),
        dof=dof,
        intervals=n_steps,
        blocks=k,
        rounds=done,
        smoothed_at=smoothed_at,
        states=states,
    )
