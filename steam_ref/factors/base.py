"""Factor, the base of every factor, and the square-root information of a noise model.  [YIB Eq. 2, 6, 26-27]

A factor f(θ) ∝ exp(-½ ‖e(θ)‖²_Σ) has an error e = h(θ) - y (for a prior, θ - mean) and a noise
covariance Σ. It gives its *unwhitened* error and Jacobians; whitening by W (WᵀW = Σ⁻¹) and the
robust loss are applied by :func:`steam_ref.linear.system.linearize`.

Every ``error``/``jacobians`` is written once, with NumPy broadcasting over leading axes, so the same
code evaluates one factor (arguments of shape (d,)) or a whole batch of factors of one type
(arguments of shape (n, d), built by :meth:`Factor.stack`). This keeps a batch linearization of
twenty thousand factors fast without a second, "vectorized" copy of any measurement model.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import lapack

from ..arguments import asymmetric, finite, most_asymmetric, real_array
from ..errors import NumericalError, ShapeError, SteamError
from ..manifold import VECTOR, Manifold
from ..robust import RobustLoss
from ..variables import FLOAT64, Key, check_roles, kind_clash

__all__ = ["Factor", "sqrt_information", "check_factors", "kinds_of", "wrong_size", "STATE_DIM", "LANDMARK_DIM"]

STATE_DIM = 6  # [x, y, θ, ẋ, ẏ, θ̇]
LANDMARK_DIM = 2


def _finite_weight(name: str, W: NDArray, noise: NDArray) -> NDArray:
    """W itself, unless inverting the noise left float64's normal range: W, or the information WᵀW (its diagonal,
    the sum of each column's squares: 1/sigma² for sigmas), is not finite (a sigma below about 1e-154, a covariance
    below about 1e-308), or the information underflows below the smallest normal number (a sigma above about
    6.7e153: such a reading weighs nothing a solver can compute with). The one check that a noise model's
    information is a number."""
    with np.errstate(over="ignore", invalid="ignore", under="ignore"):  # refused just below
        information = np.einsum("ij,ij->j", W, W)
    if not (np.all(np.isfinite(W)) and np.all(np.isfinite(information))):
        raise NumericalError(
            f"{name} is too small to invert in float64 (its information, the inverse covariance, overflows): "
            f"{name}={noise.tolist()}"
        )
    if np.any(information < np.finfo(float).tiny):
        raise NumericalError(
            f"{name} is too large for float64 (its information, the inverse covariance, underflows to "
            f"{information.min():.3g}, below the smallest normal number): {name}={noise.tolist()}"
        )
    return W


FLOAT_TYPES = (float, np.float64)  # a number memoised by value (an int or a bool goes the checked way each time)


class Memo(dict):
    """A memo of values made from a stream's recurring inputs (a sensor's sigmas, a batch's shape, a gap's Φ), bounded:
    it keeps the first ``size`` it is given and no more (never evicting), so an input met once per step, say a
    reading's own sigmas, costs no memory past them, only the making of its value each time."""

    def __init__(self, size: int = 256):
        super().__init__()
        self.size = size

    @property
    def full(self) -> bool:
        """Whether it keeps nothing more."""
        return len(self) >= self.size

    def keep(self, key: Any, value: Any) -> Any:
        """``value``, kept under ``key`` unless the memo is full."""
        if not self.full:
            self[key] = value
        return value


_SIGMA_WEIGHTS = Memo()  # W of each set of sigmas met so far (read-only), by their float64 bytes


def sqrt_information(noise: NDArray | float, m: int, name: str = "noise") -> NDArray:
    """Upper-triangular W with WᵀW = Σ⁻¹, from sigmas (m,) / a scalar sigma, or a covariance (m, m).

    ``name`` is the argument the noise came in as, for the error messages. W of sigmas is memoised by their
    value and read-only (a stream makes every reading of a sensor with the same sigmas, each step).
    """
    if type(noise) in FLOAT_TYPES:  # one sigma met before: W by the bytes of np.full(m, sigma), without making them
        W = _SIGMA_WEIGHTS.get(struct.pack("d", noise) * m)
        if W is not None:
            return W
    elif type(noise) is np.ndarray and noise.dtype is FLOAT64 and noise.shape == (m,):  # sigmas met before
        W = _SIGMA_WEIGHTS.get(noise.tobytes())
        if W is not None:
            return W
    noise = real_array(name, noise)
    if noise.ndim == 0:
        noise = np.full(m, float(noise))
    if noise.shape == (m,):
        memo = noise.tobytes()  # m is the length: sigmas of two sizes never share bytes
        W = _SIGMA_WEIGHTS.get(memo)
        if W is not None:  # made, and so checked, before
            return W
    finite(name, noise)
    if noise.shape == (m,):
        if np.any(noise <= 0):
            shown = noise.tolist() if m > 1 else noise[0]
            raise SteamError(f"{name} (standard deviation{'s' if m > 1 else ''}) must be positive, got {name}={shown}")
        with np.errstate(over="ignore", divide="ignore"):  # checked by _finite_weight
            W = _finite_weight(name, np.diag(1.0 / noise), noise)
        W.flags.writeable = False
        return _SIGMA_WEIGHTS.keep(memo, W)
    if noise.shape == (m, m):
        if asymmetric(noise):
            i, j = most_asymmetric(noise)
            raise SteamError(
                f"{name} (a covariance) is not symmetric: entry ({i}, {j}) = {float(noise[i, j])!r} "
                f"but ({j}, {i}) = {float(noise[j, i])!r}"
            )
        try:
            # Σ = U Uᵀ with U upper triangular (the Cholesky factor of Σ with rows and columns reversed,
            # reversed back), so Σ⁻¹ = U⁻ᵀ U⁻¹ and W = U⁻¹: a triangular inverse, no inverse of Σ itself.
            U = np.linalg.cholesky(noise[::-1, ::-1])[::-1, ::-1]
            with np.errstate(over="ignore", invalid="ignore", divide="ignore"):  # checked by _finite_weight
                # W = U⁻¹ by LAPACK's triangular inverse: not solve_triangular(U, I), whose ?trtrs OpenBLAS
                # threads, ~40 ms a call on a busy machine (the same choice as covariance._extend)
                W = lapack.dtrtri(U, lower=0)[0]
            return _finite_weight(name, W, noise)
        except np.linalg.LinAlgError:
            raise SteamError(f"{name} (a covariance) is not positive definite: {noise.tolist()}") from None
    raise ShapeError(
        f"{name} must be a scalar, sigmas of shape ({m},) or a covariance ({m}, {m}); got shape {noise.shape}"
    )


def wrong_size(factor: object, key: Key, dim: int, have: int, held: str = "value") -> ShapeError:
    """The error of ``factor``, made for a variable ``key`` of ``dim`` numbers, met with one of ``have`` (its
    ``held``: its value in a solver, its estimate in a batch): what the factor expects, and the two ways out. The one
    home of that message, for the graph's check, the batch's linearization and iSAM2's update."""
    return ShapeError(
        f"{type(factor).__name__} expects {key!r} of size {dim}, its {held} has size {have}: the factor was made for a "
        f"variable of {dim} numbers (a PriorFactor's mean and noise, a reading's state_dim=), so make it for {have} "
        f"or give {key!r} a value of {dim}"
    )


def check_factor(name: str, factor: object) -> Factor:
    """``factor`` itself if it is a Factor (one reading, the inner one of an interpolated factor); SteamError naming
    ``name`` otherwise."""
    if not isinstance(factor, Factor):
        raise SteamError(f"{name} must be a Factor (a reading such as a RangeFactor), got {name}={factor!r:.80}")
    return factor


def check_factors(name: str, factors: object) -> list[Factor]:
    """The factors of a Factor or an iterable of factors, as a list; SteamError naming the first non-factor."""
    if isinstance(factors, Factor):
        return [factors]
    if isinstance(factors, (str, bytes)) or not isinstance(factors, Iterable):
        raise SteamError(f"{name} must be a factor or an iterable of factors, got {name}={factors!r}")
    out = list(factors)
    for i, f in enumerate(out):
        if not isinstance(f, Factor):
            raise SteamError(f"{name}[{i}] is a {type(f).__name__} ({f!r}), not a Factor")
    return out


def kinds_of(
    factors: Sequence[Factor], held: Mapping[Key, Manifold] | None = None, held_by: str = "the solver"
) -> dict[Key, Manifold]:
    """The kind of every variable ``factors`` name, as they declare it (:attr:`Factor.key_kinds`).

    :class:`~steam_ref.errors.KindError`, naming the key and both kinds, when two factors disagree on a variable
    or one disagrees with ``held``, the kinds ``held_by`` holds already (a solver's variables, a graph's).
    """
    out: dict[Key, Manifold] = {}
    held = {} if held is None else held
    for f in factors:
        for k, kind in zip(f.keys, f.key_kinds, strict=True):
            have = out.get(k)
            if have is None:
                have = out[k] = held.get(k, kind)
            if have is not kind and have != kind:
                raise _clash(k, have, kind, f, factors, held, held_by)
    return out


def _clash(
    key: Key, have: Manifold, kind: Manifold, f: Factor, factors: Sequence[Factor], held: Mapping, held_by: str
) -> Exception:
    """The KindError of :func:`kinds_of`, naming who gave ``key`` its first kind (the error path only)."""
    if key in held:
        return kind_clash(key, have, held_by, kind, type(f).__name__)
    first = next(g for g in factors if key in g.keys)
    return kind_clash(key, have, type(first).__name__, kind, type(f).__name__)


def apply(A: NDArray, x: NDArray) -> NDArray:
    """A x for one matrix (A.dot(x): a third of einsum's call cost) or for a stack of them (einsum), as a factor
    is evaluated alone (``whitened_error``) or in a batch (linearization, the divergence check)."""
    one = A.ndim == 2 and isinstance(x, np.ndarray) and x.ndim == 1
    return A.dot(x) if one else np.einsum("...ij,...j->...i", A, x)


_IDENTITIES: dict[int, NDArray] = {}  # I (n, n) of each size asked, read-only


def identity(n: int) -> NDArray:
    """The identity (n, n), read-only, made once per size: the Jacobian of a prior, of a GP prior's later state."""
    eye = _IDENTITIES.get(n)
    if eye is None:
        eye = _IDENTITIES[n] = np.eye(n)
        eye.flags.writeable = False
    return eye


_IDENTITY_STACKS = Memo()  # I broadcast to each shape (..., n, n) asked, read-only (a few batch sizes recur)


def identity_stack(shape: tuple[int, ...]) -> NDArray:
    """The identity broadcast to ``shape`` (..., n, n), a read-only view made once per shape: the Jacobian of a
    batch of GP priors' later states."""
    eye = _IDENTITY_STACKS.get(shape)
    if eye is None:
        eye = _IDENTITY_STACKS.keep(shape, np.broadcast_to(identity(shape[-1]), shape))
    return eye


def zero_jacobian(x: NDArray, m: int) -> NDArray:
    """A zero Jacobian (..., m, dim) for the leading shape of x."""
    return np.zeros(x.shape[:-1] + (m, x.shape[-1]))


def _same(a: object, b: object) -> bool:
    """Whether two values of a shared field are equal (arrays element by element)."""
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return bool(np.array_equal(a, b))  # type: ignore[arg-type]
    return a is b or bool(a == b)


_DECLARED: set[type] = set()  # the factor classes whose fields :meth:`Factor._check_declared` has checked


@dataclass(frozen=True, eq=False)
class Factor:
    """Base class. Subclasses set ``keys``, ``key_dims``, ``sqrt_information`` and the model.

    Every dataclass field a subclass adds is declared in exactly one of three class tuples, so that
    :meth:`stack` knows what to do with it: ``_batched``, the per-factor arrays it stacks along a new
    leading axis; ``_batched_factors``, the wrapped factors it stacks by their own class; ``_shared``,
    the fields equal across a batch (a state size, say), checked equal when stacked. ``keys`` and
    ``loss`` are the base's. A field declared nowhere raises at the first construction of the class.

    A factor that reads states and landmarks declares how many state keys its keys begin with, ``n_states``; the
    base checks at every construction (:func:`~steam_ref.variables.check_roles`) that those are states ``X(i)`` and
    the rest landmarks ``L(j)``, or, with ``roles_of_states_only``, the states alone (an interpolated reading: the
    keys after its two states are the wrapped reading's, which checked them when it was made).
    """

    keys: tuple[Key, ...]
    sqrt_information: NDArray  # W (m, m), upper triangular, WᵀW = Σ⁻¹
    loss: RobustLoss | None = field(default=None, kw_only=True)  # None: plain least squares

    _batched: ClassVar[tuple[str, ...]] = ("sqrt_information",)  # per-factor arrays
    _batched_factors: ClassVar[tuple[str, ...]] = ()  # wrapped factors, stacked by their own class
    _shared: ClassVar[tuple[str, ...]] = ()  # fields equal across a batch: checked equal, kept once
    key_dims: ClassVar[tuple[int, ...]] = ()
    n_states: ClassVar[int | None] = None  # the state keys X(i) its keys begin with (class docstring); None: any keys
    roles_of_states_only: ClassVar[bool] = False  # True: the keys after the states are a wrapped reading's

    @classmethod
    def _check_declared(cls) -> None:
        """SteamError unless every dataclass field of ``cls`` is declared once (class docstring)."""
        if cls in _DECLARED:
            return
        groups = {"_batched": cls._batched, "_batched_factors": cls._batched_factors, "_shared": cls._shared}
        declared = [n for names in groups.values() for n in names] + ["keys", "loss"]
        twice = sorted({n for n in declared if declared.count(n) > 1})
        if twice:
            raise SteamError(
                f"{cls.__name__} declares field {twice[0]!r} twice among _batched, _batched_factors, _shared"
            )
        names = [f.name for f in fields(cls)]
        for name in names:
            if name not in declared:
                raise SteamError(
                    f"{cls.__name__} does not say how to stack its field {name!r}: list it in _batched (a per-factor "
                    "array), _batched_factors (a wrapped factor) or _shared (equal across a batch)"
                )
        for group, listed in groups.items():
            unknown = [n for n in listed if n not in names]
            if unknown:
                raise SteamError(f"{cls.__name__}.{group} names {unknown[0]!r}, which is not a field of the class")
        _DECLARED.add(cls)

    def __post_init__(self) -> None:
        """Every factor names each variable once: two Jacobian blocks of one variable would be added by
        a batch solve but overwrite each other in a clique, so the two would solve different problems."""
        type(self)._check_declared()
        if self.loss is not None and not isinstance(self.loss, RobustLoss):
            raise SteamError(
                f"{type(self).__name__}: loss must be a RobustLoss (Huber(k), Tukey(c)) or None, got loss={self.loss!r}"
            )
        for k in self.keys:
            if not isinstance(k, Key):
                raise SteamError(f"{type(self).__name__}: {k!r} is not a variable key (make one with X(i) or L(j))")
        if len(set(self.keys)) < len(self.keys):  # a variable named twice (found below only then)
            repeated = [k for i, k in enumerate(self.keys) if k in self.keys[:i]]
            raise SteamError(f"{type(self).__name__} names variable {repeated[0]!r} twice (keys {self.keys})")
        if self.n_states is not None:  # states, then landmarks (class docstring)
            keys = self.keys[: self.n_states] if self.roles_of_states_only else self.keys
            check_roles(type(self).__name__, keys, self.n_states)

    @property
    def dim(self) -> int:
        """Size m of the error."""
        return self.sqrt_information.shape[-1]

    @property
    def key_kinds(self) -> tuple[Manifold, ...]:
        """The kind of each key (:mod:`steam_ref.manifold`), in key order: the space the factor's Jacobians are
        taken in. :data:`~steam_ref.manifold.VECTOR` for every key unless the subclass says otherwise (a factor on
        SE(2) states says ``lie.SE2_STATE`` for them); a solver takes each variable's kind from its factors."""
        return (VECTOR,) * len(self.keys)

    # error and jacobians take one array per key, named by each subclass (x, l; x1, x2): the base's
    # (*xs: Any, **kwargs: Any) is how a type checker is told that any such signature overrides it.
    def error(self, *xs: Any, **kwargs: Any) -> NDArray:
        """Unwhitened error e = h(θ) - y: (..., m)."""
        raise NotImplementedError

    def jacobians(self, *xs: Any, **kwargs: Any) -> tuple[NDArray, ...]:
        """∂e/∂xₖ for each key: each (..., m, dₖ)."""
        raise NotImplementedError

    def error_and_jacobians(self, *xs: Any) -> tuple[NDArray, tuple[NDArray, ...]]:
        """:meth:`error` and :meth:`jacobians` at the same point, what a linearization asks for: a factor whose error
        is a by-product of its Jacobians' computation (a Lie group's local variables, an interpolated state) gives
        both from one evaluation, equal to the two calls'."""
        return self.error(*xs), self.jacobians(*xs)

    def batch_signature(self) -> tuple:
        """Factors with equal signatures can be stacked and evaluated together."""
        return (type(self), self.loss, self.dim)

    @classmethod
    def stack(cls, factors: list[Factor]) -> Factor:
        """One instance whose array fields have a leading axis over ``factors`` (same signature).

        Every field is declared (class docstring); a ``_shared`` field, and the loss, must be equal
        across ``factors``: SteamError naming the field and the first factor that differs otherwise.
        """
        cls._check_declared()
        batch = object.__new__(cls)
        one = len(factors) == 1
        for name in cls._batched:  # np.array of equal-shaped arrays is np.stack's result at a fifth of its call cost
            value = (
                np.asarray(getattr(factors[0], name))[None] if one else np.array([getattr(f, name) for f in factors])
            )
            object.__setattr__(batch, name, value)  # one: a view, no copy
        for name in cls._batched_factors:
            inner = [getattr(f, name) for f in factors]
            object.__setattr__(batch, name, type(inner[0]).stack(inner))
        for name in ("loss", *cls._shared):
            first = getattr(factors[0], name)
            if not one:  # a batch of one (a linearization's usual group in a stream): nothing to compare
                given = [getattr(f, name) for f in factors]
                same_object = all(v is first for v in given)  # the usual case (None, a small int), at no cost
                differs = None if same_object else next((i for i, v in enumerate(given) if not _same(v, first)), None)
                if differs is not None:
                    raise SteamError(
                        f"{cls.__name__}.stack: factor {differs} has {name}={getattr(factors[differs], name)!r}, "
                        f"factor 0 {name}={first!r}; a shared field must be equal across a batch (a varying one is "
                        "_batched)"
                    )
            object.__setattr__(batch, name, first)
        object.__setattr__(batch, "keys", None)
        return batch

    def whitened_error(self, *xs: NDArray) -> NDArray:
        """W e (no robust loss): its squared norm is the Mahalanobis norm of Eq. 6."""
        return apply(self.sqrt_information, self.error(*xs))

    def whitened_jacobians(self) -> tuple[NDArray, ...] | None:
        """W Hₖ for each key, (m, dₖ), when they do not depend on the estimates (a linear factor's: made once, finite,
        read-only, equal to what a linearization of this factor alone computes); None, the default, when they do."""
        return None
