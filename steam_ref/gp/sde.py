"""A general linear time-invariant SDE and its exact discretisation.  [YIB Eq. 14, 17, 22-23]

    ẋ(t) = A x(t) + v + F w(t),   w(t) ~ GP(0, Qc δ(t - t'))                        [YIB Eq. 14]

with constant A (n, n), F (n, m), Qc (m, m) and a constant exogenous input v (n,). Between two
times t_{i-1} < t_i the state obeys exactly

    x(t_i) = Φ(t_i, t_{i-1}) x(t_{i-1}) + v_i + w_i,   w_i ~ N(0, Q_i)                  [YIB Eq. 22]

with Φ(t, s) = exp(A (t - s)), Q_i of [YIB Eq. 17] and v_i of [YIB Eq. 23]. All three come from
matrix exponentials, so any (A, F) works. The named priors (``LinearSDE.wnoa``, ``.wnoj``,
``.singer``) carry a ``ClosedForm`` and ``transition`` / ``process_noise`` then use its closed
forms (``steam_ref.gp.prior`` for WNOA [YIB Eq. 30-31], ``steam_ref.gp.models`` for WNOJ and
Singer); ``transition_expm`` / ``process_noise_van_loan`` (or ``general()``) keep the matrix
exponential route, and the tests check the two against each other and against quadrature.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from ..arguments import check_covariance, finite, number, real_array, time_step
from ..errors import ShapeError, SteamError
from .models import ClosedForm, check_alpha
from .prior import check_qc, finite_result

__all__ = ["LinearSDE", "check_prior", "check_sde", "as_sde", "dense_kernel"]


def _finite_matrix(name: str, a: ArrayLike, ndim: int) -> NDArray:
    a = real_array(name, a)  # a private copy, made read-only below
    if a.ndim != ndim or a.size == 0:
        raise ShapeError(f"{name} must be a non-empty {ndim}-d array, got shape {a.shape}")
    finite(name, a).setflags(write=False)
    return a


@dataclass(frozen=True, eq=False)
class LinearSDE:
    """ẋ = A x + v + F w,  w ~ GP(0, Qc δ), all coefficients constant.  [YIB Eq. 14]

    Arrays are copied to read-only float arrays on construction; v defaults to zero. With a
    ``model``, A and F must be that model's, and Φ and Q come from its closed forms.
    """

    A: NDArray  # (n, n) system matrix
    F: NDArray  # (n, m) noise input matrix
    qc: NDArray  # (m, m) power spectral density of w, symmetric positive definite
    v: NDArray | None = None  # (n,) constant exogenous input; zero gives a zero-mean GP
    model: ClosedForm | None = None  # a prior known in closed form, or None: matrix exponentials

    def __post_init__(self) -> None:
        A, F = _finite_matrix("A", self.A, 2), _finite_matrix("F", self.F, 2)
        n = A.shape[0]
        if A.shape != (n, n):
            raise ShapeError(f"A must be square (n, n), got shape {A.shape}")
        if F.shape[0] != n:
            raise ShapeError(f"F must be (n, m) = ({n}, m) to match A, got shape {F.shape}")
        qc = _finite_matrix("Qc", check_qc(self.qc), 2)
        if qc.shape != (F.shape[1], F.shape[1]):
            raise ShapeError(f"Qc must be (m, m) = {(F.shape[1],) * 2} to match F, got shape {qc.shape}")
        v = _finite_matrix("v", np.zeros(n) if self.v is None else self.v, 1)
        if v.shape != (n,):
            raise ShapeError(f"v must be ({n},) to match A, got shape {v.shape}")
        if self.model is not None:
            if not isinstance(self.model, ClosedForm):
                raise SteamError(f"model must be a ClosedForm or None, got model={self.model!r}")
            mA, mF = self.model.matrices(qc.shape[0])
            if mA.shape != A.shape or mF.shape != F.shape or not (np.array_equal(mA, A) and np.array_equal(mF, F)):
                raise SteamError(f"A and F are not those of model={self.model!r} with d={qc.shape[0]}")
        for name, value in (("A", A), ("F", F), ("qc", qc), ("v", v)):
            object.__setattr__(self, name, value)

    @classmethod
    def _known(cls, model: ClosedForm, qc: ArrayLike, v: ArrayLike | None) -> LinearSDE:
        qc = check_qc(qc)
        A, F = model.matrices(qc.shape[0])
        return cls(A, F, qc, None if v is None else _finite_matrix("v", v, 1), model)

    @classmethod
    def wnoa(cls, qc: ArrayLike, v: ArrayLike | None = None) -> LinearSDE:
        """The white-noise-on-acceleration prior p̈ = w, x = [p; ṗ], p of size d = len(Qc).  [YIB Eq. 30-31]"""
        return cls._known(ClosedForm("wnoa"), qc, v)

    @classmethod
    def wnoj(cls, qc: ArrayLike, v: ArrayLike | None = None) -> LinearSDE:
        """White noise on jerk p⃛ = w, x = [p; ṗ; p̈], p of size d = len(Qc): (3d)-state.  [YIB Eq. 14]"""
        return cls._known(ClosedForm("wnoj"), qc, v)

    @classmethod
    def singer(
        cls,
        qc: ArrayLike,
        alpha: float | None = None,
        *,
        time_constant: float | None = None,
        v: ArrayLike | None = None,
    ) -> LinearSDE:
        """Singer's model p⃛ = -α p̈ + w, x = [p; ṗ; p̈], p of size d = len(Qc).  [YIB Eq. 14], [S70]

        Give exactly one of ``alpha`` (> 0, 1/s) and ``time_constant`` = 1/α (> 0, s), the
        correlation time of the acceleration. Qc = 2α σ² gives a stationary acceleration
        variance σ² per axis (Singer's σ_m²). α → 0 is WNOJ.
        """
        if (alpha is None) == (time_constant is None):
            raise SteamError(
                f"give exactly one of alpha and time_constant, got alpha={alpha!r}, time_constant={time_constant!r}"
            )
        if alpha is not None:
            a = check_alpha(alpha)
        else:
            a = 1.0 / check_alpha(time_constant, "time_constant")
            if not np.isfinite(a):
                raise SteamError(
                    f"time_constant={time_constant!r} is too small: alpha = 1/time_constant overflows float64"
                )
        return cls._known(ClosedForm("singer", a), qc, v)

    def general(self) -> LinearSDE:
        """The same SDE without its closed forms: Φ by expm, Q by Van Loan's method."""
        return replace(self, model=None)

    @cached_property
    def decay_rate(self) -> float:
        """The fastest decay of the SDE, max(0, -Re λ) over A's eigenvalues λ (Singer's α; 0 for WNOA and WNOJ):
        Φ(t - dt, t) = Φ(t, t - dt)⁻¹ grows as e^{decay_rate dt}."""
        return max(0.0, -float(np.linalg.eigvals(self.A).real.min()))

    @property
    def n(self) -> int:
        """Size of the state x."""
        return self.A.shape[0]

    def transition(self, dt: float) -> NDArray:
        """Φ(t + dt, t) = exp(A dt): (n, n), in closed form for a known model. Any finite dt.  [YIB Eq. 16]"""
        if self.model is not None:
            return self.model.transition(dt, self.qc.shape[0])
        return self.transition_expm(dt)

    def process_noise(self, dt: float) -> NDArray:
        """Q(dt) of [YIB Eq. 17]: (n, n), in closed form for a known model, else by Van Loan's method."""
        if self.model is not None:
            return self.model.process_noise(dt, self.qc)
        return self.process_noise_van_loan(dt)

    def sqrt_information(self, dt: float) -> NDArray | None:
        """W with WᵀW = Q(dt)⁻¹ where the model has it in closed form, memoised by value, and there is no input:
        the paper's WNOA, whose prior factor is then ``GPPriorFactor.wnoa``'s bit for bit. None otherwise (the
        factor factors Q(dt)).  [YIB Eq. 17, 22]

        Every prior factor asks it first, so it is where a known model refuses an interval over which its prior is
        too stiff for float64 beside the readings (``ClosedForm.check_step``: Singer's αΔt), naming the model's
        parameters and the interval, before the elimination breaks down blaming a state."""
        if self.model is not None:
            self.model.check_step(dt)
        if self.model is None or np.any(self.v):
            return None
        return self.model.sqrt_information(dt, self.qc)

    def transition_expm(self, dt: float) -> NDArray:
        """Φ(t + dt, t) = exp(A dt) by scipy's expm: (n, n). Any finite dt; Φ(t, s)⁻¹ = Φ(s, t).  [YIB Eq. 16]"""
        dt = time_step(dt, positive=False)
        return finite_result("Φ(dt) = expm(A dt)", scipy.linalg.expm(self.A * dt), dt=dt)

    def process_noise_van_loan(self, dt: float) -> NDArray:
        """Q(dt) = ∫₀^dt Φ(dt, s) F Qc Fᵀ Φ(dt, s)ᵀ ds by Van Loan's method: (n, n).  [YIB Eq. 17]

        With C = [[-A, F Qc Fᵀ], [0, Aᵀ]] dt, expm(C) = [[·, E₁₂], [0, Φᵀ]] and
        E₁₂ = ∫₀^dt e^{-A(dt-s)} F Qc Fᵀ e^{Aᵀs} ds, so Q = Φ E₁₂ [VL78]. expm(C) holds
        e^{-A dt}, which grows for a decaying mode, and Φ E₁₂ cancels it: for Singer's αdt ≳ 10 only the
        closed form is accurate (docs/derivations.md, section 6). expm's error is relative to the norm of the block,
        so Q's small entries (Q_pp ∝ dt⁵ of Singer's model) carry up to ~1e-9 relative error at dt = 1e-3 where the
        closed forms are exact to rounding (measured against 40 digits; WNOA's and WNOJ's nilpotent A lose nothing).
        """
        dt, n = time_step(dt), self.n
        G = self.F @ self.qc @ self.F.T
        C = np.block([[-self.A, G], [np.zeros((n, n)), self.A.T]]) * dt
        with np.errstate(over="ignore", invalid="ignore"):
            E = scipy.linalg.expm(C)
            Q = E[n:, n:].T @ E[:n, n:]  # Φ(dt) E₁₂ = ∫ Φ F Qc Fᵀ Φᵀ ds  [YIB Eq. 17]
        return finite_result("Q(dt) by Van Loan's method", (Q + Q.T) / 2, dt=dt)

    def input_integral(self, dt: float) -> NDArray:
        """v_i = ∫₀^dt Φ(dt, s) v ds, the mean drift over one step: (n,).  [YIB Eq. 23]

        expm([[A, v], [0, 0]] dt) has top-right column ∫₀^dt e^{A(dt-s)} v ds.
        """
        dt, n = time_step(dt), self.n
        if not np.any(self.v):
            return np.zeros(n)
        C = np.zeros((n + 1, n + 1))
        C[:n, :n], C[:n, n] = self.A, self.v
        with np.errstate(over="ignore", invalid="ignore"):
            v_dt = scipy.linalg.expm(C * dt)[:n, n]  # [YIB Eq. 23]
        return finite_result("the input integral v(dt)", v_dt, dt=dt)

    def mean(self, times: ArrayLike, t0: float, mu0: ArrayLike) -> NDArray:
        """μ(t) for each t in `times` (any order, all ≥ t0), given μ(t0) = mu0: (len(times), n).

        Propagates μ_k = Φ(t_k, t_{k-1}) μ_{k-1} + v_k over the sorted times  [YIB Eq. 22-23].
        """
        times, mu0, t0 = real_array("times", times), real_array("mu0", mu0), number("t0", t0)
        if times.ndim != 1:
            raise ShapeError(f"times must be a finite 1-d array, got shape {times.shape}")
        if mu0.shape != (self.n,):
            raise ShapeError(f"mu0 must be ({self.n},), got shape {mu0.shape}")
        finite("times", times), finite("mu0", mu0)
        if times.size and times.min() < t0:
            raise SteamError(f"the mean is defined for t >= t0 = {t0}, got t = {times.min()}")
        order = np.argsort(times, kind="stable")
        out = np.empty((times.size, self.n))
        t_prev, mu = float(t0), mu0
        for k in order:
            if times[k] > t_prev:
                dt = times[k] - t_prev
                mu = self.transition(dt) @ mu + self.input_integral(dt)  # [YIB Eq. 22-23]
                t_prev = times[k]
            out[k] = mu
        return out


def check_prior(prior: ArrayLike | LinearSDE, name: str = "prior") -> NDArray | LinearSDE:
    """A motion prior argument: a LinearSDE as it is, or Qc of the WNOA prior checked (a read-only (d, d) array).

    The one place that tells the two forms apart (with :func:`check_sde` and :func:`as_sde` below, and
    ``gp.interpolate.interpolation_terms``): the GP factors ask these, never the argument's type."""
    if isinstance(prior, LinearSDE):
        return prior
    try:
        return check_qc(prior)
    except SteamError as exc:
        raise type(exc)(f"{name} must be a LinearSDE or Qc, a (d, d) matrix: {exc}") from None


def check_sde(sde: object, name: str = "sde", hint: str = "") -> LinearSDE:
    """``sde`` if it is a LinearSDE; SteamError naming it (and ``hint``, what to use instead) otherwise."""
    if not isinstance(sde, LinearSDE):
        raise SteamError(f"{name} must be a LinearSDE{hint}, got {name}={sde!r}")
    return sde


def as_sde(prior: ArrayLike | LinearSDE, name: str = "prior") -> LinearSDE:
    """A motion prior argument as a LinearSDE: one as it is, Qc as ``LinearSDE.wnoa(Qc)`` (whose prior factors are
    the memoised closed forms of Qc's, bit for bit: :meth:`LinearSDE.sqrt_information`)."""
    prior = check_prior(prior, name)
    return prior if isinstance(prior, LinearSDE) else LinearSDE.wnoa(prior)


def dense_kernel(sde: LinearSDE, times: ArrayLike, P0: ArrayLike) -> NDArray:
    """The kernel matrix K of [YIB Eq. 3] for x(times[0]) ~ N(·, P0): (M n, M n), dense.

    times must be strictly increasing. Marginals follow P_k = Φ_k P_{k-1} Φ_kᵀ + Q_k and, for
    t_j ≥ t_k, K(t_j, t_k) = Φ(t_j, t_k) P_k. O(M² n³): for figures and checks, not for solvers.
    """
    times, P0 = real_array("times", times), real_array("P0", P0)
    n, M = sde.n, times.size
    if times.ndim != 1 or M == 0:
        raise ShapeError(f"times must be a finite non-empty 1-d array, got shape {times.shape}")
    if np.any(~(np.diff(finite("times", times)) > 0)):
        raise SteamError(f"times must be strictly increasing, got {times.tolist()}")
    check_covariance("P0", P0, n)
    Phi = [sde.transition(dt) for dt in np.diff(times)]
    K = np.zeros((M * n, M * n))
    P = P0
    for k in range(M):
        if k > 0:
            P = Phi[k - 1] @ P @ Phi[k - 1].T + sde.process_noise(times[k] - times[k - 1])
        C = P  # K(t_j, t_k), j = k, k+1, ...
        for j in range(k, M):
            if j > k:
                C = Phi[j - 1] @ C
            K[j * n : (j + 1) * n, k * n : (k + 1) * n] = C
            K[k * n : (k + 1) * n, j * n : (j + 1) * n] = C.T
    return K
