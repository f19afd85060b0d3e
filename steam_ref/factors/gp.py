"""Factors of the GP motion prior: between consecutive states, and at a time with no state.  [YIB Eq. 22, 29]

:class:`GPPriorFactor` links two consecutive estimated states (Eq. 22-23); :class:`InterpolatedFactor`
moves a measurement taken at a time τ between two states onto those states through the GP
interpolation Λ(τ), Ψ(τ) (Eq. 18-19, 29). Both work for any state size n (2d for WNOA, 3d for WNOJ and Singer).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from numpy.typing import NDArray

from ..arguments import finite, number, real_array
from ..errors import NumericalError, ShapeError, SteamError
from ..gp.interpolate import interpolation_terms
from ..gp.prior import process_noise_sqrt_information, transition
from ..gp.sde import LinearSDE, as_sde, check_prior, check_sde
from ..variables import Key, key_list
from .base import FLOAT_TYPES, Factor, Memo, apply, check_factor, identity_stack, sqrt_information
from .measured import measured_vector

__all__ = ["GPPriorFactor", "gp_prior_factors", "InterpolatedFactor"]


# --- The GP motion prior ------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class GPPriorFactor(Factor):
    """The GP motion prior between two consecutive states: how smoothly the robot may move.  [YIB Eq. 22-23]

    Made by one of::

        GPPriorFactor.wnoa(key1, key2, dt, qc)          the paper's prior (white noise on acceleration)
        GPPriorFactor.from_sde(key1, key2, dt, sde)     WNOJ, Singer, any LTI SDE (steam_ref.gp.LinearSDE)
        GPPriorFactor.from_matrices(key1, key2, phi, q, v=None)

    ``key1``, ``key2``: the states ``X(i-1)``, ``X(i)``, each [x, y, θ, ẋ, ẏ, θ̇] for the paper's prior (velocity
    in the world frame; WNOJ and Singer append [ẍ, ÿ, θ̈]); ``dt`` > 0: the time between them (s); ``qc``: Qc, the
    (d, d) power spectral density of the acceleration noise, the paper's (3, 3) in m²/s³ for x, y and rad²/s³ for θ
    (docs/api.md, "Conventions", says how to choose it). For a whole trajectory, :func:`gp_prior_factors` makes them
    all.

    Error:  e = xᵢ - Φ(Δt) xᵢ₋₁ - vᵢ,   Σ = Qᵢ = Q(Δt)
    (WNOA: Φ(Δt) = [[I, Δt I], [0, I]], vᵢ = 0, Q(Δt) = [[Δt³/3 Qc, Δt²/2 Qc], [Δt²/2 Qc, Δt Qc]])
    """

    phi: NDArray  # Φ(tᵢ, tᵢ₋₁), (n, n)
    v: NDArray  # vᵢ of Eq. 23, (n,)

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "phi", "v")
    n_states: ClassVar[int | None] = 2  # two states, whatever the constructor

    @classmethod
    def wnoa(cls, key1: Key, key2: Key, dt: float, qc: NDArray) -> GPPriorFactor:
        """The white-noise-on-acceleration prior over a gap dt (s) > 0; qc: Qc (d, d), the paper's (3, 3).
        [YIB Eq. 22, 30-31]"""
        # a dt met before with this Qc holding the same values (a read-only view of a writeable array, or an array
        # made writeable again, may have changed since): checked then
        key = (dt, id(qc))
        made = _BY_GAP.get(key) if type(dt) in FLOAT_TYPES else None
        if made is not None and made[4] != qc.tobytes():
            del _BY_GAP[key]
            made = None
        if made is None:
            w = process_noise_sqrt_information(dt, qc)  # WᵀW = Qᵢ⁻¹, memoised per (dt, Qc)
            d = w.shape[0] // 2
            v = np.zeros(2 * d)
            v.flags.writeable = False  # shared by every factor of this gap, as W and Φ are
            made = (qc, w, transition(dt, d), v, None)
            if type(dt) in FLOAT_TYPES and type(qc) is np.ndarray and not qc.flags.writeable:
                made = _BY_GAP.keep(key, (*made[:4], qc.tobytes()))  # the memo holds Qc: an id in it is still its
        return cls((key1, key2), made[1], phi=made[2], v=made[3])

    @classmethod
    def from_matrices(cls, key1: Key, key2: Key, phi: NDArray, q: NDArray, v: NDArray | None = None) -> GPPriorFactor:
        """From Φ(tᵢ, tᵢ₋₁) (n, n), Qᵢ (n, n) and vᵢ (n,) of any LTI SDE (see ``steam_ref.gp.sde``).  [YIB Eq. 22]"""
        phi = real_array("phi", phi)
        if phi.ndim != 2 or phi.shape[0] != phi.shape[1] or phi.shape[0] == 0:
            raise ShapeError(f"phi (Φ) must be a square (n, n) matrix, n >= 1, got shape {phi.shape}")
        n = phi.shape[0]
        q = real_array("q", q)
        if q.shape != (n, n):  # a covariance: not a sigma, nor sigmas, as sqrt_information would read them
            raise ShapeError(f"q (Qᵢ) must be a ({n}, {n}) covariance to match phi, got shape {q.shape}")
        v = np.zeros(n) if v is None else measured_vector(v, n, "v")
        return cls((key1, key2), sqrt_information(q, n, "q"), phi=finite("phi", phi), v=v)

    @classmethod
    def from_sde(cls, key1: Key, key2: Key, dt: float, sde: LinearSDE) -> GPPriorFactor:
        """The prior of ``sde`` over a gap dt: Φ, Qᵢ and vᵢ from its (closed-form or general) discretisation; W
        from the SDE where it knows it in closed form (the paper's WNOA: memoised, ``wnoa``'s factor bit for bit),
        else from Qᵢ."""
        sde = check_sde(sde, hint=" (for Qc of the WNOA prior use GPPriorFactor.wnoa)")
        w = sde.sqrt_information(dt)  # WᵀW = Qᵢ⁻¹ in closed form, or None
        if w is not None:
            return cls((key1, key2), w, phi=sde.transition(dt), v=sde.input_integral(dt))
        q = sde.process_noise(dt)
        try:
            np.linalg.cholesky(q)
        except np.linalg.LinAlgError:
            raise NumericalError(
                f"Q(dt) of this prior is not positive definite in float64 at dt={dt!r}: "
                "the gap is too small (or too large)"
            ) from None
        return cls.from_matrices(key1, key2, sde.transition(dt), q, sde.input_integral(dt))

    @property
    def key_dims(self) -> tuple[int, int]:  # type: ignore[override]
        n = self.phi.shape[-1]
        return (n, n)

    def error(self, x1: NDArray, x2: NDArray) -> NDArray:
        n = self.phi.shape[-1]
        if np.shape(x1)[-1:] != (n,) or np.shape(x2)[-1:] != (n,):  # a Qc of another d than the states'
            raise ShapeError(
                f"GPPriorFactor over states of size {n} got states of shapes {np.shape(x1)} and {np.shape(x2)}"
            )
        return x2 - apply(self.phi, x1) - self.v  # [YIB Eq. 22]

    def jacobians(self, x1: NDArray, x2: NDArray) -> tuple[NDArray, NDArray]:  # noqa: ARG002 (linear: constant)
        return -self.phi, identity_stack(self.phi.shape)

    def whitened_jacobians(self) -> tuple[NDArray, ...] | None:
        """W (-Φ) and W I, made once for each W and Φ (a stream's priors share them, memoised per gap), as a
        linearization of this factor alone makes them. None (made anew by the linearization) if one is not finite,
        if W or Φ is writeable (a caller may change it in place: ``wnoa``'s are read-only), or if the memo is full."""
        W, phi = self.sqrt_information, self.phi
        if W.flags.writeable or phi.flags.writeable:
            return None
        made = _WHITENED.get((id(W), id(phi)))  # the memo holds W and Φ: an id in it is still theirs
        if made is None:
            if _WHITENED.full:
                return None
            batch = type(self).stack([self])
            with np.errstate(all="ignore"):
                blocks = tuple((batch.sqrt_information @ J)[0] for J in batch.jacobians(phi, phi))
            if not all(np.isfinite(A).all() for A in blocks):
                return None
            for A in blocks:
                A.flags.writeable = False
            made = _WHITENED.keep((id(W), id(phi)), (W, phi, blocks))
        return made[2]


_BY_GAP = Memo()  # (Qc, W, Φ, v, Qc's bytes) of ``wnoa`` by (dt, id of a read-only Qc)
_WHITENED = Memo()  # (W, Φ, blocks) by the ids of W and Φ: a stream's priors share a few gaps; past the memo's size,
# new ones go the linearization's usual way


def gp_prior_factors(keys: list[Key], times: NDArray, prior: NDArray | LinearSDE) -> list[GPPriorFactor]:
    """The M - 1 GP prior factors linking consecutive states at strictly increasing times.  [YIB Eq. 22]

    ``keys``: any iterable of M state keys (``[X(0), X(1), ...]``), each state [x, y, θ, ẋ, ẏ, θ̇] (velocity in
    the world frame); ``times``: their M times (s); ``prior``: Qc of the paper's WNOA prior, a (3, 3) power
    spectral density in m²/s³ (x, y) and rad²/s³ (θ), or any :class:`~steam_ref.gp.LinearSDE`. With Qc, factor i
    is ``GPPriorFactor.wnoa(keys[i], keys[i+1], times[i+1] - times[i], qc)``, error xᵢ₊₁ - Φ xᵢ (``from_sde`` with a
    LinearSDE, error xᵢ₊₁ - Φ xᵢ - vᵢ). What Qc means and how to choose it: docs/api.md, "Conventions".
    """
    keys, gaps = consecutive_gaps(keys, times)
    sde = as_sde(prior)
    return [GPPriorFactor.from_sde(keys[i], keys[i + 1], gaps[i], sde) for i in range(len(gaps))]  # Qc: wnoa's


def consecutive_gaps(keys: list[Key], times: NDArray) -> tuple[list[Key], NDArray]:
    """The M state keys and the M - 1 gaps between their times, each > 0, for the prior factors linking consecutive
    states (any prior's: :func:`gp_prior_factors`, ``lie_prior.lie_prior_factors``); SteamError or ShapeError naming
    the first time that does not increase strictly, or a count of times that is not one per key."""
    keys, times = key_list("keys", keys), real_array("times", times)
    if times.ndim != 1 or len(times) != len(keys):
        raise ShapeError(f"need one time per key: {len(keys)} keys, times of shape {times.shape}")
    gaps = np.diff(finite("times", times))
    if np.any(~(gaps > 0)):
        i = int(np.flatnonzero(~(gaps > 0))[0])
        raise SteamError(f"times must increase strictly: t[{i}]={times[i]} then t[{i + 1}]={times[i + 1]}")
    return keys, gaps


# --- Measurements at a missing (interpolated) state ---------------------------------------------


@dataclass(frozen=True, eq=False)
class InterpolatedFactor(Factor):
    """A measurement at a time τ with no estimated state, moved onto its two neighbours.  [YIB Eq. 29]

        ``InterpolatedFactor.create(inner, key1, key2, t1, t2, tau, prior)``

    ``inner``: the measurement as if x(τ) were a state (its first key stands for x(τ), e.g. ``X(-1)``);
    ``key1``, ``key2``: the states at ``t1`` < ``tau`` < ``t2`` (s); ``prior``: Qc or a LinearSDE, as for
    :class:`GPPriorFactor`.

    Error:  e = e_inner(Λ(τ) xᵢ₋₁ + Ψ(τ) xᵢ + c, …)

    The wrapped ``inner`` factor's first key stands for the missing state x(τ) (it is not a variable
    of the graph); its other keys (a landmark, say) are kept. x̄(τ) = Λ(τ) x̄(tᵢ₋₁) + Ψ(τ) x̄(tᵢ) + c
    [YIB Eq. 18], where c = v(τ, tᵢ₋₁) - Ψ v(tᵢ, tᵢ₋₁) carries a prior's exogenous input [YIB Eq. 23]
    (zero for the paper's zero-mean prior; derivation in ``gp.interpolate.interpolate_state_sde``), so

        e(xᵢ₋₁, xᵢ, …) = e_inner(Λ xᵢ₋₁ + Ψ xᵢ + c, …),   ∂e/∂xᵢ₋₁ = H Λ,  ∂e/∂xᵢ = H Ψ   [YIB Eq. 19, 29]
    """

    inner: Factor  # the measurement at x(τ)
    lam: NDArray  # Λ(τ), (n, n)
    psi: NDArray  # Ψ(τ), (n, n)
    offset: NDArray  # c, (n,): the prior mean's part [YIB Eq. 23]

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information", "lam", "psi", "offset")
    _batched_factors: ClassVar[tuple[str, ...]] = ("inner",)
    n_states: ClassVar[int | None] = 2  # its two states (the inner reading checks its own keys)
    roles_of_states_only: ClassVar[bool] = True

    @classmethod
    def create(
        cls, inner: Factor, key1: Key, key2: Key, t1: float, t2: float, tau: float, prior: NDArray | LinearSDE
    ) -> InterpolatedFactor:
        """Move ``inner`` (a factor on x(τ), t1 < τ < t2) onto the states ``key1`` at t1 and ``key2`` at t2.

        ``prior`` is Qc (the paper's WNOA prior) or any :class:`~steam_ref.gp.LinearSDE`.
        """
        if isinstance(check_factor("inner", inner), InterpolatedFactor):
            raise SteamError("an interpolated factor cannot wrap another interpolated factor")
        prior = check_prior(prior)
        t1, t2, tau = number("t1", t1), number("t2", t2), number("tau", tau)  # floats, not float32 (NumPy 2)
        lam, psi, offset = interpolation_terms(prior, t1, t2, tau)  # [YIB Eq. 16, 23]
        if lam.shape[0] != inner.key_dims[0]:
            raise ShapeError(
                f"the prior gives states of size {lam.shape[0]}, {type(inner).__name__} expects {inner.key_dims[0]}"
            )
        keys = (key1, key2) + tuple(inner.keys[1:])
        return cls(keys, inner.sqrt_information, inner=inner, lam=lam, psi=psi, offset=offset, loss=inner.loss)

    @property
    def key_dims(self) -> tuple[int, ...]:  # type: ignore[override]
        d = self.inner.key_dims[0]
        return (d, d) + tuple(self.inner.key_dims[1:])

    def batch_signature(self) -> tuple:
        return (type(self), self.inner.batch_signature())

    def interpolated_state(self, x1: NDArray, x2: NDArray) -> NDArray:
        """x̄(τ) = Λ x̄₁ + Ψ x̄₂ + c  [YIB Eq. 18, 23]."""
        return apply(self.lam, x1) + apply(self.psi, x2) + self.offset

    def error(self, x1: NDArray, x2: NDArray, *rest: NDArray) -> NDArray:
        return self.inner.error(self.interpolated_state(x1, x2), *rest)  # [YIB Eq. 29]

    def jacobians(self, x1: NDArray, x2: NDArray, *rest: NDArray) -> tuple[NDArray, ...]:
        H, *others = self.inner.jacobians(self.interpolated_state(x1, x2), *rest)
        return (H @ self.lam, H @ self.psi, *others)  # [YIB Eq. 19, 29]

    def error_and_jacobians(self, x1: NDArray, x2: NDArray, *rest: NDArray) -> tuple[NDArray, tuple[NDArray, ...]]:
        """The error and its Jacobians at one interpolated state, the inner factor's from its one evaluation."""
        e, (H, *others) = self.inner.error_and_jacobians(self.interpolated_state(x1, x2), *rest)
        return e, (H @ self.lam, H @ self.psi, *others)  # [YIB Eq. 19, 29]
