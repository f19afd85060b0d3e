"""Consistency of an estimator: NEES of its states, ANEES over Monte Carlo runs, and the χ² band.

For a state x of dimension d estimated as x̂ with covariance P, the normalised estimation error squared
is ε = (x̂ - x)ᵀ P⁻¹ (x̂ - x) [BLK01 Sec. 5.4.2]. When the estimator is consistent (its errors are
zero-mean Gaussian with the covariance it reports), ε is χ²-distributed with d degrees of freedom, so
over N independent runs the average ε̄ = (1/N) Σ εₖ (ANEES) has N ε̄ ~ χ²(N d), and the two-sided 95 %
acceptance band for ε̄ is [χ²⁻¹(0.025; N d) / N, χ²⁻¹(0.975; N d) / N] [BLK01 Sec. 5.4.2].
Above the band the estimator is overconfident (covariances too small), below it underconfident.

**Too few runs to call it consistent.** The band is exact when every run's ε is χ²(d); an estimator can
fail differently: most runs fine, a few lost in a wrong minimum with an ε far beyond any χ²(d) value (the
interpolated BTGP of docs/experiments.md: 26 of 200 runs). Such a tail moves the ANEES only in the runs that
contain one of its runs, so a study too short to contain one sees nothing. Call a run *lost* when its ε is
beyond M = χ²⁻¹(0.999; d) (:data:`LOST_QUANTILE`). A fraction p of lost runs raises the expected ANEES by at
least p (M - d) (each replaces a run of mean d by one above M), which puts it above the band's top h(N) once
p > p*(N) = (h(N) - d) / (M - d). N runs contain no lost run with probability (1 - p)^N; so the study could
have missed a tail large enough to make the estimator inconsistent with probability above α = 1 - level
while (1 - p*(N))^N > α. Below the smallest N where (1 - p*(N))^N ≤ α (:func:`runs_needed`: 60 runs for
d = 3, 71 for d = 2 at 95 %; since N p*(N) grows like √N, every larger N qualifies too) an ANEES inside the
band is *inconclusive*, never "consistent" (:func:`verdict` with ``enough_runs=False``). An ANEES outside
the band is a verdict at any N: it is what the χ² test rejects at its level.

The error of a heading is wrapped to [-π, π): a state's estimate and the truth may differ by whole turns.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.special import gammaincinv

from ..arguments import asymmetric, finite, is_integer, number, real_array
from ..dead_reckoning import wrap_angle
from ..errors import NumericalError, ShapeError, SteamError

__all__ = [
    "nees",
    "chi2_band",
    "chi2_quantile",
    "pose_errors",
    "verdict",
    "runs_needed",
    "LOST_QUANTILE",
    "INCONCLUSIVE",
]

LOST_QUANTILE = 0.999  # a run whose NEES is beyond χ²⁻¹(0.999; d) is lost (a wrong minimum), not a little off
INCONCLUSIVE = "inconclusive (too few runs)"


def pose_errors(estimate: NDArray, truth: NDArray) -> NDArray:
    """Errors (n, 3) of planar poses [x, y, θ]: the difference, its heading wrapped to [-π, π)."""
    estimate, truth = real_array("estimate", estimate), real_array("truth", truth)
    if estimate.shape != truth.shape or estimate.ndim != 2 or estimate.shape[1] != 3:
        raise ShapeError(f"pose errors need two (n, 3) arrays of one shape, got {estimate.shape} and {truth.shape}")
    e = finite("estimate", estimate) - finite("truth", truth)
    e[:, 2] = wrap_angle(e[:, 2])
    return e


def nees(errors: NDArray, covariances: NDArray) -> NDArray:
    """ε = eᵀ P⁻¹ e of each error (n, d) with its covariance (n, d, d).  [BLK01 Sec. 5.4.2]

    Computed through a Cholesky factor L of each P, ε = ‖L⁻¹ e‖², all n in one stacked call each (NumPy's
    stacked ``cholesky`` and ``solve`` factor and solve each P as they would one at a time: the same values);
    a P that is not symmetric is a :class:`~steam_ref.errors.SteamError`, one that is not positive definite a
    :class:`~steam_ref.errors.NumericalError`, each naming its row.
    """
    e, P = real_array("errors", errors), real_array("covariances", covariances)
    if e.ndim != 2 or e.shape[1] == 0 or P.shape != (*e.shape, e.shape[1]):
        raise ShapeError(f"nees needs errors (n, d), d >= 1, and covariances (n, d, d), got {e.shape} and {P.shape}")
    if not (np.all(np.isfinite(e)) and np.all(np.isfinite(P))):
        raise NumericalError("nees: an error or a covariance is not finite")
    if len(e) == 0:
        return np.zeros(0)
    # Cholesky reads one triangle only: [[1, 5], [0, 1]] would pass as the identity
    unsymmetric = asymmetric(P)
    if unsymmetric.any():
        k = int(np.argmax(unsymmetric))
        raise SteamError(f"nees: covariances[{k}] must be symmetric, got {P[k].tolist()}")
    try:
        lower = np.linalg.cholesky(P)
    except np.linalg.LinAlgError:
        k = next(k for k in range(len(P)) if not _positive_definite(P[k]))  # the stacked call names no row
        raise NumericalError(f"nees: covariance {k} is not positive definite: {P[k].tolist()}") from None
    w = np.linalg.solve(lower, e[:, :, None])  # L⁻¹ e of each row, (n, d, 1)
    return (np.swapaxes(w, 1, 2) @ w)[:, 0, 0]  # each a (1, d) @ (d, 1) product: NumPy's dot of w with itself


def _positive_definite(P: NDArray) -> bool:
    """Whether a symmetric ``P`` has a Cholesky factor."""
    try:
        np.linalg.cholesky(P)
    except np.linalg.LinAlgError:
        return False
    return True


def chi2_band(n_runs: int, dim: int, level: float = 0.95) -> tuple[float, float]:
    """The two-sided ``level`` band of the ANEES of ``n_runs`` runs of a ``dim``-dimensional state:
    χ²⁻¹((1 ∓ level)/2; N d) / N.  [BLK01 Sec. 5.4.2]"""
    for name, value in (("n_runs", n_runs), ("dim", dim)):
        if not is_integer(value) or value < 1:
            raise SteamError(f"{name} must be a positive integer, got {value!r}")
    if isinstance(level, bool) or not isinstance(level, (int, float)) or not 0 < level < 1:
        raise SteamError(f"level must be a number in (0, 1), got {level!r}")
    dof = n_runs * dim
    tail = (1 - level) / 2
    return chi2_quantile(tail, dof) / n_runs, chi2_quantile(1 - tail, dof) / n_runs


def chi2_quantile(p: float, dof: float) -> float:
    """χ²⁻¹(p; k) = 2 P⁻¹(k/2, p), P the regularized lower incomplete gamma function (SciPy's ``gammaincinv``;
    ``scipy.stats.chi2.ppf`` computes the same, at the cost of importing scipy.stats: docs/experiments.md). The one home of the χ² quantile.
    ``p`` in [0, 1], ``dof`` > 0 (SciPy answers NaN outside them)."""
    prob, k = number("p", p), number("dof", dof)
    if not 0 <= prob <= 1:
        raise SteamError(f"p must be a probability in [0, 1], got p={prob}")
    if k <= 0:
        raise SteamError(f"dof must be a number of degrees of freedom > 0, got dof={k}")
    return float(2 * gammaincinv(k / 2, prob))


def runs_needed(dim: int, level: float = 0.95) -> int:
    """The fewest runs whose ANEES inside the band supports "consistent" at ``level``: the smallest N with
    (1 - p*(N))^N ≤ 1 - level, p*(N) = (h(N) - d) / (χ²⁻¹(0.999; d) - d), h(N) the band's top (module
    docstring). 60 for d = 3, 71 for d = 2 at 95 %."""
    chi2_band(1, dim, level)  # the checks of dim and level
    lost = chi2_quantile(LOST_QUANTILE, dim)
    n = 1
    while (1 - (chi2_band(n, dim, level)[1] - dim) / (lost - dim)) ** n > 1 - level:
        n += 1
    return n


def verdict(anees: float, band: tuple[float, float], enough_runs: bool = True) -> str:
    """'consistent' inside the band, else 'not consistent (overconfident)' / '(underconfident)'; inside the
    band with too few runs to have seen a tail of lost runs (``enough_runs=False``, :func:`runs_needed`),
    :data:`INCONCLUSIVE`."""
    anees = number("anees", anees)
    if anees < 0:
        raise SteamError(f"anees is an average of squares, never negative, got anees={anees}")
    if not (isinstance(band, (tuple, list)) and len(band) == 2):
        raise SteamError(f"band must be a pair (lower, upper), got band={band!r}")
    lo, hi = number("band[0]", band[0]), number("band[1]", band[1])
    if not 0 <= lo <= hi:
        raise SteamError(f"band must be (lower, upper) with 0 <= lower <= upper, got band={band!r}")
    if anees > hi:
        return "not consistent (overconfident)"
    if anees < lo:
        return "not consistent (underconfident)"
    return "consistent" if enough_runs else INCONCLUSIVE
