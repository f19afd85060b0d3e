"""The Lie group protocol: what a group of rigid motions gives the states, factors and GP built on it.  [SOLA; DER 11]

A :class:`LieGroup` is one object per group (``steam_ref.lie.SE2`` is the first); everything written
against it (the state kind ``GroupState``, the local GP of ``lie.gp``, the factors on group states)
works for the next group unchanged. Its conventions, the same for every group (those of GTSAM's
``Pose2``/``Pose3``, of manif and of [SOLA]):

- **Storage.** An element is a flat float array of ``size`` numbers (SE(2): [x, y, θ]; SO(3): R's 9 entries
  row-major; SE(3): [t; R row-major]); a tangent vector (a twist) has ``dim`` numbers, **translation first**:
  ξ = [ρ; φ]. Each kernel checks its inputs' last axis (ShapeError naming the argument).
- **Right Jacobians.** Every Jacobian is taken in the right (body) tangent of each argument and of
  the value: for y = f(x), J = ∂ Log(f(x)⁻¹ f(x Exp δ)) / ∂δ at δ = 0. So J_r(ξ) is defined by
  Exp(ξ + dξ) = Exp(ξ) Exp(J_r(ξ) dξ) to first order, and Ad(T) by T Exp(ξ) T⁻¹ = Exp(Ad(T) ξ).
- **Broadcasting.** Every method broadcasts over leading axes: ξ (..., dim), an element (..., size),
  a Jacobian (..., dim, dim), a group matrix (..., n, n); so a batch of factors evaluates it once, and each
  element of a batch gets the bits it gets alone. So a square is ``x * x`` or ``np.square``, never ``x ** 2``:
  NumPy 2.4 raises an array to an integer power by products but a scalar by C's ``pow``, which differ in the last bit.
- **One call for a value and its Jacobians.** ``compose``, ``inverse`` and ``between`` return the
  value, or with ``jacobians=True`` the value and its Jacobians from the same call (GTSAM's
  ``Pose2::between(p2, H1, H2)``, manif's ``compose(m, J_mc_ma, J_mc_mb)``).

A group implements what differs between groups: Exp, Log, hat and vee, the matrix of an element, the
angle its series switch tests, J_r, Ad, the value of compose and inverse, and the exact derivative
of J_r(ξ) v; each of its closed forms switches to a series below ``series_below``. This base class
derives the rest once, for every group: the Jacobians of compose, inverse and between from Ad
[SOLA; DER 11.8], and (for a group without closed forms of its own) between
= compose(inverse(a), b), J_r⁻¹ = (J_r)⁻¹ and the derivative of J_r(ξ)⁻¹ v from that of J_r(ξ) v.

**A planar robot.** What a planar front end, reading or evaluation needs of a state on the group (the element of a
dead-reckoned pose [x, y, θ], the planar pose of an element, the body twist of a world-frame velocity [ẋ, ẏ, θ̇]
and back, a name for each number of a state) are methods here too: ``from_planar``, ``to_planar``,
``body_twist``, ``world_velocity``, ``state_names``. A group whose elements hold a planar pose writes them (SE(2));
the base class refuses each with a SteamError naming the group, so a group without one fails clearly, not wrongly.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from typing import Any, ClassVar, Literal, overload

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from ..arguments import finite, real_array
from ..errors import ShapeError, SteamError

__all__ = ["LieGroup", "check_group", "matrix_of", "mv"]


def matrix_of(rows: list[list[NDArray | float]], like: NDArray) -> NDArray:
    """A stack of matrices (..., n, m) from rows of entries, each an array broadcast to ``like``'s shape or a number."""
    entries = [v for row in rows for v in row]
    out = np.empty(np.shape(like) + (len(rows), len(rows[0])), dtype=np.result_type(like, *entries))
    for i, row in enumerate(rows):
        for j, v in enumerate(row):
            out[..., i, j] = v
    return out


def mv(a: NDArray, v: NDArray) -> NDArray:
    """a v for stacks of matrices (..., n, m) and vectors (..., m), broadcast over the leading axes (einsum: for a
    stack of small matrices, faster than matmul on the vectors as columns; a stack of matrices times matrices is ``@``)."""
    return np.einsum("...ij,...j->...i", a, v)


class LieGroup(ABC):
    """A matrix Lie group on flat arrays, right Jacobians, translation first (module docstring).

    A group sets ``name`` (a short lower-case name, "se2"), ``dim`` (the tangent's size), ``size``
    (an element's stored size), ``series_below`` (the angle below which its coefficients come from
    their series) and the abstract methods. A group class has one object (``SE2Group() is SE2``), also
    after a round trip through pickle, so a group is compared by identity.
    """

    name: str
    dim: int
    size: int
    series_below: float

    # --- what each group implements ---------------------------------------------------------------

    @abstractmethod
    def exp(self, xi: ArrayLike) -> NDArray:
        """Exp(ξ): the element (..., size) of the twist ξ (..., dim)."""

    @abstractmethod
    def log(self, a: ArrayLike) -> NDArray:
        """Log(a): the twist (..., dim) of the element a, its angle in the principal range; Exp(Log(a)) = a."""

    @abstractmethod
    def hat(self, xi: ArrayLike) -> NDArray:
        """ξ^: the Lie algebra matrix (..., n, n) of the twist ξ; Exp(ξ) = expm(ξ^)."""

    @abstractmethod
    def vee(self, X: ArrayLike) -> NDArray:
        """The twist (..., dim) of a Lie algebra matrix X (..., n, n): vee(hat(ξ)) = ξ."""

    @abstractmethod
    def matrix(self, a: ArrayLike) -> NDArray:
        """The element a as its (..., n, n) matrix: compose is the matrix product, inverse the matrix inverse."""

    @abstractmethod
    def from_matrix(self, M: ArrayLike) -> NDArray:
        """The element (..., size) whose :meth:`matrix` is M (..., n, n), in its stored form: the inverse of
        ``matrix`` (M's rotation taken as it is: a caller reading a file makes it one first)."""

    @abstractmethod
    def angle(self, xi: ArrayLike) -> NDArray:
        """The rotation angle of ξ (..., ) that the series switch tests (SE(2): abs(φ)); positively homogeneous."""

    @abstractmethod
    def right_jacobian(self, xi: ArrayLike) -> NDArray:
        """J_r(ξ) (..., dim, dim): Exp(ξ + dξ) = Exp(ξ) Exp(J_r(ξ) dξ) to first order."""

    @abstractmethod
    def adjoint(self, a: ArrayLike) -> NDArray:
        """Ad(a) (..., dim, dim): a Exp(ξ) a⁻¹ = Exp(Ad(a) ξ)."""

    @abstractmethod
    def jr_times_jacobian(self, xi: ArrayLike, v: ArrayLike) -> NDArray:
        """∂(J_r(ξ) v)/∂ξ (..., dim, dim), exact."""

    @abstractmethod
    def _compose(self, a: NDArray, b: NDArray) -> NDArray:
        """The value a b (float arrays)."""

    @abstractmethod
    def _inverse(self, a: NDArray) -> NDArray:
        """The value a⁻¹ (a float array)."""

    # --- what follows for any group (a group may replace one by its own closed form) -------------------

    def _between(self, a: NDArray, b: NDArray) -> NDArray:
        """The value a⁻¹ b (float arrays)."""
        return self._compose(self._inverse(a), b)

    def _as_last(self, name: str, value: object, n: int, what: str) -> NDArray:
        try:
            a = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ShapeError(f"{name} must be an array of numbers, got {name}={value!r:.80}") from None
        if a.shape[-1:] != (n,):
            raise ShapeError(f"{name} must be {what} of {self!r} ({n} numbers in its last axis), got shape {a.shape}")
        return a

    def _twists(self, name: str, xi: object) -> NDArray:
        """``xi`` as a float array of twists (..., dim); ShapeError naming ``name`` otherwise (the public kernels
        check their inputs' shapes, so a 4-vector is never read as an SE(2) twist or pose)."""
        return self._as_last(name, xi, self.dim, "a twist")

    def _elements(self, name: str, a: object) -> NDArray:
        """``a`` as a float array of elements (..., size) in their stored form; ShapeError naming ``name`` otherwise."""
        return self._as_last(name, a, self.size, "an element")

    def _algebra(self, name: str, X: object, n: int) -> NDArray:
        """``X`` as a float array of Lie algebra matrices (..., n, n); ShapeError naming ``name`` otherwise."""
        try:
            M = np.asarray(X, dtype=float)
        except (TypeError, ValueError):
            raise ShapeError(f"{name} must be an array of numbers, got {name}={X!r:.80}") from None
        if M.shape[-2:] != (n, n):
            raise ShapeError(f"{name} must be a Lie algebra matrix of {self!r} ({n} × {n}), got shape {M.shape}")
        return M

    def identity(self) -> NDArray:
        """The identity element, Exp(0) (size,)."""
        return self.exp(np.zeros(self.dim))

    def check(self, name: str, a: object) -> NDArray:
        """``a`` as one finite element (size,) in its stored form; ShapeError or SteamError naming ``name``."""
        a = real_array(name, a)
        if a.shape != (self.size,):
            raise ShapeError(f"{name} must be an element of {self!r} ({self.size} numbers), got shape {a.shape}")
        self.check_stored(name, finite(name, a))
        return a

    def check_stored(self, name: str, a: NDArray) -> None:
        """Nothing, or SteamError naming ``name`` when the finite float element ``a`` (size,) is not in the group's
        stored form (SE(2): θ in (-π, π]; SO(3): R a rotation); :meth:`check`'s own rule, which a state's check
        (``lie.state.GroupState.check``) applies to its pose without checking the numbers again."""
        del name, a  # a group whose every finite array of its size is an element

    # The scalar coefficients of the group's closed forms, for the battery's sweep against their definitions at
    # 50 digits (tests/test_lie_groups.py); a group that lists none is checked through its matrices alone.
    coefficient_definitions: ClassVar[Mapping[str, Callable[[Any, Any], Any]]] = {}

    def coefficients(self, theta: ArrayLike) -> dict[str, NDArray]:
        """Each coefficient of ``coefficient_definitions`` at the angles θ, as the group computes it (series below
        ``series_below``, closed forms above); a definition maps (θ, a math module such as mpmath) to its value."""
        del theta  # a group that lists no coefficients
        return {}

    def right_jacobian_inverse(self, xi: ArrayLike) -> NDArray:
        """J_r(ξ)⁻¹ (..., dim, dim): Log(Exp(ξ) Exp(δ)) = ξ + J_r(ξ)⁻¹ δ to first order."""
        return np.linalg.inv(self.right_jacobian(xi))

    def jr_inverse_times_jacobian(self, xi: ArrayLike, v: ArrayLike) -> NDArray:
        """∂(J_r(ξ)⁻¹ v)/∂ξ (..., dim, dim), exact: d(J⁻¹) = -J⁻¹ dJ J⁻¹, so it is -J⁻¹ ∂(J_r(ξ) u)/∂ξ at u = J⁻¹ v."""
        jinv = self.right_jacobian_inverse(xi)
        return -(jinv @ self.jr_times_jacobian(xi, mv(jinv, np.asarray(v, dtype=float))))

    @overload
    def log_between(
        self, a: ArrayLike, b: ArrayLike, v: ArrayLike, jacobians: Literal[False] = False
    ) -> tuple[NDArray, NDArray]: ...
    @overload
    def log_between(
        self, a: ArrayLike, b: ArrayLike, v: ArrayLike, jacobians: Literal[True]
    ) -> tuple[NDArray, NDArray, NDArray, NDArray, NDArray]: ...
    def log_between(
        self, a: ArrayLike, b: ArrayLike, v: ArrayLike, jacobians: bool = False
    ) -> tuple[NDArray, NDArray] | tuple[NDArray, NDArray, NDArray, NDArray, NDArray]:
        """ξ = Log(a⁻¹ b) and u = J_r(ξ)⁻¹ v (a twist v seen in the rates of ξ); with ``jacobians``, also ∂ξ/∂δa =
        -J_r(ξ)⁻¹ Ad(Exp(-ξ)), ∂ξ/∂δb = J_r(ξ)⁻¹ and ∂u/∂ξ: a local variable of the GP on the group and its
        Jacobians in one call [DER 11.10, 11.13]. Here from the group's methods in turn; a group may fuse them (SE(2)
        reads the coefficients of its angle once, ``_log_between``)."""
        return self._log_between(self._elements("a", a), self._elements("b", b), self._twists("v", v), jacobians)

    def _log_between(
        self, a: NDArray, b: NDArray, v: NDArray, jacobians: bool
    ) -> tuple[NDArray, NDArray] | tuple[NDArray, NDArray, NDArray, NDArray, NDArray]:
        """:meth:`log_between` of checked elements and twist: here from the group's methods in turn."""
        if not jacobians:
            xi = self.log(self._between(a, b))
            return xi, mv(self.right_jacobian_inverse(xi), v)
        rel, Ha, _ = self.between(a, b, jacobians=True)
        xi = self.log(rel)
        jinv = self.right_jacobian_inverse(xi)
        return xi, mv(jinv, v), (jinv @ Ha), jinv, self.jr_inverse_times_jacobian(xi, v)

    def compose_exp(self, a: ArrayLike, xi: ArrayLike) -> NDArray:
        """a Exp(ξ): the element ``a`` moved by ξ in its right tangent (a state's retraction, ``lie.state``). Here
        compose after exp; a group may fuse them."""
        return self._compose(self._elements("a", a), self.exp(xi))

    # --- second order, for a prior with an acceleration in its state (written once, for every group) ------------

    def ad(self, xi: ArrayLike) -> NDArray:
        """ad_ξ (..., dim, dim): ad_ξ η = vee(ξ^ η^ - η^ ξ^), the derivative of Ad(Exp(s ξ)) at s = 0."""
        xi = self._twists("xi", xi)
        X, E = self.hat(xi)[..., None, :, :], self.hat(np.eye(self.dim))  # (..., 1, n, n), (dim, n, n)
        return np.swapaxes(self.vee(X @ E - E @ X), -1, -2)  # column j is ad_ξ e_j

    def jr_derivatives(self, xi: ArrayLike, u: ArrayLike) -> tuple[NDArray, NDArray]:
        """The derivatives of J_r along u: DJ[u] = ∂J_r(ξ + s u)/∂s at 0 (..., dim, dim), and the second ones
        D²J[u, e_j] (..., dim, dim, dim), j first, exact.  [DER 14.2]

        J_r(ξ) = φ₁(-ad_ξ), φ₁(z) = (eᶻ - 1)/z; for A = -ad_ξ, E = -ad_u, F_j = -ad_(e_j), the function φ₁ of the
        block upper-triangular M = [[A, E, F, 0], [0, A, 0, F], [0, 0, A, E], [0, 0, 0, A]] holds DJ[u] in its
        block (0, 1) and D²J[u, e_j] = D²φ₁(A)[E, F_j] in its block (0, 3); φ₁(M) is the top-right block of
        expm([[M, I], [0, 0]]) (a matrix function by scaling and squaring: no series cut, no branch on the angle).
        """
        xi, u = self._twists("xi", xi), self._twists("u", u)
        d = self.dim
        A, E, F = -self.ad(xi), -self.ad(u), -self.ad(np.eye(d))  # (..., d, d), (..., d, d), (d, d, d)
        shape = np.broadcast_shapes(A.shape[:-2], E.shape[:-2])
        A = np.broadcast_to(A, shape + (d, d))[..., None, :, :]
        E = np.broadcast_to(E, shape + (d, d))[..., None, :, :]
        M = np.zeros(shape + (d, 8 * d, 8 * d))
        for b in range(4):
            M[..., b * d : (b + 1) * d, b * d : (b + 1) * d] = A
        M[..., 0:d, d : 2 * d] = M[..., 2 * d : 3 * d, 3 * d : 4 * d] = E
        M[..., 0:d, 2 * d : 3 * d] = M[..., d : 2 * d, 3 * d : 4 * d] = F
        M[..., : 4 * d, 4 * d :] = np.eye(4 * d)
        phi1 = scipy.linalg.expm(M)[..., : 4 * d, 4 * d :]  # φ₁(M)
        return phi1[..., 0, 0:d, d : 2 * d], phi1[..., 0:d, 3 * d : 4 * d]

    def jr_times_hessian(self, xi: ArrayLike, v: ArrayLike, u: ArrayLike) -> NDArray:
        """∂/∂ξ [∂(J_r(ξ) v)/∂ξ u] at fixed u and v (..., dim, dim): column j is D²J[u, e_j] v, exact.  [DER 14.2]"""
        _, second = self.jr_derivatives(xi, u)
        return np.swapaxes(mv(second, np.asarray(v, dtype=float)[..., None, :]), -1, -2)

    def jr_inverse_times_hessian(self, xi: ArrayLike, v: ArrayLike, u: ArrayLike) -> NDArray:
        """∂/∂ξ [∂(J_r(ξ)⁻¹ v)/∂ξ u] at fixed u and v (..., dim, dim), exact.  [DER 14.3]

        With f = J⁻¹ v, J f = v twice differentiated: D²f[u, w] = -J⁻¹ (D²J[u, w] f + DJ[u] Df[w] + DJ[w] Df[u]),
        and DJ[w] z = ∂(J z)/∂ξ w, Df[w] = ∂(J⁻¹ v)/∂ξ w.
        """
        jinv = self.right_jacobian_inverse(xi)
        f = mv(jinv, np.asarray(v, dtype=float))
        G = self.jr_inverse_times_jacobian(xi, v)
        dj_u, _ = self.jr_derivatives(xi, u)
        inner = (
            self.jr_times_hessian(xi, f, u) + (dj_u @ G) + self.jr_times_jacobian(xi, mv(G, np.asarray(u, dtype=float)))
        )
        return -(jinv @ inner)

    def _eye(self, shape: tuple[int, ...]) -> NDArray:
        return np.broadcast_to(np.eye(self.dim), shape + (self.dim, self.dim)).copy()

    @overload
    def compose(self, a: ArrayLike, b: ArrayLike, jacobians: Literal[False] = False) -> NDArray: ...
    @overload
    def compose(self, a: ArrayLike, b: ArrayLike, jacobians: Literal[True]) -> tuple[NDArray, NDArray, NDArray]: ...
    def compose(
        self, a: ArrayLike, b: ArrayLike, jacobians: bool = False
    ) -> NDArray | tuple[NDArray, NDArray, NDArray]:
        """a b; with ``jacobians``, also ∂(a b)/∂δa = Ad(b⁻¹) and ∂(a b)/∂δb = I.  [DER 11.8]"""
        a, b = self._elements("a", a), self._elements("b", b)
        value = self._compose(a, b)
        if not jacobians:
            return value
        return value, self.adjoint(self._inverse(b)), self._eye(value.shape[:-1])

    @overload
    def inverse(self, a: ArrayLike, jacobians: Literal[False] = False) -> NDArray: ...
    @overload
    def inverse(self, a: ArrayLike, jacobians: Literal[True]) -> tuple[NDArray, NDArray]: ...
    def inverse(self, a: ArrayLike, jacobians: bool = False) -> NDArray | tuple[NDArray, NDArray]:
        """a⁻¹; with ``jacobians``, also ∂a⁻¹/∂δa = -Ad(a).  [DER 11.8]"""
        a = self._elements("a", a)
        value = self._inverse(a)
        if not jacobians:
            return value
        return value, -self.adjoint(a)

    @overload
    def between(self, a: ArrayLike, b: ArrayLike, jacobians: Literal[False] = False) -> NDArray: ...
    @overload
    def between(self, a: ArrayLike, b: ArrayLike, jacobians: Literal[True]) -> tuple[NDArray, NDArray, NDArray]: ...
    def between(
        self, a: ArrayLike, b: ArrayLike, jacobians: bool = False
    ) -> NDArray | tuple[NDArray, NDArray, NDArray]:
        """a⁻¹ b; with ``jacobians``, also ∂(a⁻¹b)/∂δa = -Ad((a⁻¹b)⁻¹) and ∂(a⁻¹b)/∂δb = I.  [DER 11.8]"""
        a, b = self._elements("a", a), self._elements("b", b)
        value = self._between(a, b)
        if not jacobians:
            return value
        return value, -self.adjoint(self._inverse(value)), self._eye(value.shape[:-1])

    # --- a planar robot's pose and velocity (a group whose elements hold one says how) ----------------

    def state_names(self) -> tuple[str, ...]:
        """A name for each number of a state on this group (its pose's ``size``, then its twist's ``dim``),
        as files write them; generic unless the group names them (SE(2): x, y, theta, vx, vy, omega)."""
        return tuple(f"pose{i}" for i in range(self.size)) + tuple(f"twist{i}" for i in range(self.dim))

    def from_planar(self, pose: ArrayLike) -> NDArray:  # noqa: ARG002 (a planar group's)
        """The element (..., size) of a planar pose [x, y, θ] (..., 3) in the world frame, in its stored form:
        how a dead-reckoned pose enters a state. SteamError for a group that holds no planar pose."""
        raise SteamError(self._not_planar("the element of a planar pose [x, y, θ]"))

    def to_planar(self, a: ArrayLike) -> NDArray:  # noqa: ARG002 (a planar group's)
        """The planar pose [x, y, θ] (..., 3) of the element ``a`` (..., size). SteamError for a group that
        holds no planar pose."""
        raise SteamError(self._not_planar("the planar pose [x, y, θ] of an element"))

    def body_twist(self, a: ArrayLike, velocity: ArrayLike) -> NDArray:  # noqa: ARG002 (a planar group's)
        """The body twist (..., dim) of a robot at the element ``a`` moving with the world-frame planar velocity
        [ẋ, ẏ, θ̇] (..., 3). SteamError for a group that holds no planar pose."""
        raise SteamError(self._not_planar("the body twist of a planar world-frame velocity"))

    def world_velocity(self, a: ArrayLike, twist: ArrayLike) -> NDArray:  # noqa: ARG002 (a planar group's)
        """The world-frame planar velocity [ẋ, ẏ, θ̇] (..., 3) of the body twist ``twist`` (..., dim) at the
        element ``a``. SteamError for a group that holds no planar pose."""
        raise SteamError(self._not_planar("the world-frame planar velocity of a body twist"))

    def _not_planar(self, what: str) -> str:
        return (
            f"{self!r} holds no planar pose, so it cannot give {what}: a planar front end, reading or evaluation "
            f"needs a group that says how (SE2 does)"
        )

    # --- one object per group ----------------------------------------------------------------------

    _instances: ClassVar[dict[type, LieGroup]] = {}

    def __new__(cls) -> LieGroup:
        """The one object of each group class: constructing or unpickling one gives the same object, so a
        factor or state kind holding a group is compared by identity, as the solvers compare kinds."""
        if cls not in LieGroup._instances:
            LieGroup._instances[cls] = super().__new__(cls)
        return LieGroup._instances[cls]

    def __repr__(self) -> str:
        return self.name.upper()


def check_group(group: object, name: str = "group") -> LieGroup:
    """``group`` if it is a :class:`LieGroup`; SteamError naming it otherwise."""
    if not isinstance(group, LieGroup):
        raise SteamError(f"{name} must be a LieGroup (steam_ref.lie.SE2, ...), got {name}={group!r}")
    return group
