"""The oracle on SO(3) and SE(3): 3×3 and 4×4 matrices, SciPy's ``expm`` and ``expm_frechet`` and its rotations.

Independent expected values of the ``se3`` suite (kit v5). Nothing here shares code with ``steam_ref.lie``,
``steam_ref.motion`` or ``steam_ref.factors``: no series, no closed forms, no coefficient.

- A pose is stored as 12 numbers [t; R row-major], a rotation as R's 9 entries row-major; a twist ξ = [ρ; φ]
  (translation first), ξ^ = [[φ^, ρ], [0, 0]].
- Exp(ξ) = expm(ξ^) (SciPy, Padé). Log(T): φ = the rotation vector of R (SciPy's ``Rotation.as_rotvec``, through a
  quaternion: accurate at the half turn, where a Log read off R - Rᵀ loses every digit), ρ = V(φ)⁻¹ t with V(φ) the
  top-right block of expm([[φ^, I], [0, 0]]) (Van Loan: ∫₀¹ expm(s φ^) ds).
- J_r(ξ) = ∫₀¹ expm(-s ad_ξ) ds, the top-right block of expm([[-ad_ξ, I], [0, 0]]); ad_ξ's columns the commutators
  [ξ^, eᵢ^]∨; J_r⁻¹ a dense inverse. Its derivative DJ_r(ξ)[u] is the Fréchet derivative of that block exponential
  in the direction [[-ad_u, 0], [0, 0]] (``scipy.linalg.expm_frechet``), exact to rounding.
- A state x = [T; ϖ] (18 numbers) or [T; ϖ; ϖ̇] (24) moves by the right retraction
  x ⊕ δ = (T Exp(δ[:6]), ϖ + δ[6:12], ϖ̇ + δ[12:]).
- Every Jacobian is a central difference through that retraction at h, h/2, h/4, h/8 (h = 0.04) combined by
  Romberg's scheme (error O(h⁸), rounding ~1e-13 relative): the exact tier's reference.
- The WNOA residuals, WNOJ's (γ = [ξ; ξ̇; ξ̈] from the definitions ξ̇ = J_r⁻¹ϖ, ξ̈ = d/dt(J_r⁻¹ϖ)), the local GP's mean
  and covariance (Λ, Ψ and the conditional covariance from :mod:`.oracle`'s dense kernel) on these definitions;
  :data:`LIE3`, the :class:`.oracle_graph.Space` of SE(3) states for the graph oracle's solvers.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from ..errors import SteamError
from . import oracle as o
from .oracle_graph import Space

__all__ = [
    "hat",
    "exp",
    "log",
    "right_jacobian",
    "right_jacobian_inverse",
    "retract",
    "local",
    "derivative",
    "numeric_jacobian",
    "prior_error",
    "accel_prior_error",
    "interpolation_quantities",
    "extrapolation_quantities",
    "linearize_factor",
    "LIE3",
]

H = 0.04  # the first step of the Romberg table
LEVELS = 4  # h, h/2, h/4, h/8


def hat3(w: NDArray) -> NDArray:
    return np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])


def hat(xi: NDArray) -> NDArray:
    """ξ^ (4×4) for ξ = [ρ; φ]."""
    out = np.zeros((4, 4))
    out[:3, :3], out[:3, 3] = hat3(xi[3:]), xi[:3]
    return out


def _vee(M: NDArray) -> NDArray:
    return np.array([M[0, 3], M[1, 3], M[2, 3], M[2, 1], M[0, 2], M[1, 0]])


def matrix(pose: NDArray) -> NDArray:
    out = np.eye(4)
    out[:3, :3], out[:3, 3] = np.asarray(pose[3:12], float).reshape(3, 3), pose[:3]
    return out


def pose_of(M: NDArray) -> NDArray:
    return np.concatenate([M[:3, 3], M[:3, :3].ravel()])


def exp(xi: NDArray) -> NDArray:
    """Exp(ξ) as a pose [t; R row-major]."""
    return pose_of(scipy.linalg.expm(hat(np.asarray(xi, float))))


def so3_exp(phi: NDArray) -> NDArray:
    """Exp(φ) on SO(3) as R's 9 entries row-major."""
    return scipy.linalg.expm(hat3(np.asarray(phi, float))).ravel()


def so3_log(R: NDArray) -> NDArray:
    """Log(R): the rotation vector, angle in [0, π] (SciPy's quaternion route)."""
    return Rotation.from_matrix(np.asarray(R, float).reshape(3, 3)).as_rotvec()


def _V(phi: NDArray) -> NDArray:
    block = np.zeros((6, 6))
    block[:3, :3], block[:3, 3:] = hat3(phi), np.eye(3)
    return scipy.linalg.expm(block)[:3, 3:]


def log_matrix(M: NDArray) -> NDArray:
    phi = so3_log(M[:3, :3])
    return np.concatenate([np.linalg.solve(_V(phi), M[:3, 3]), phi])


def log(pose: NDArray) -> NDArray:
    return log_matrix(matrix(np.asarray(pose, float)))


def ad(xi: NDArray) -> NDArray:
    X = hat(np.asarray(xi, float))
    return np.column_stack([_vee(X @ hat(e) - hat(e) @ X) for e in np.eye(6)])


def _so3_ad(phi: NDArray) -> NDArray:
    return hat3(np.asarray(phi, float))  # [φ^, e_i^]∨ = φ × e_i


def _block(adx: NDArray) -> NDArray:
    n = len(adx)
    block = np.zeros((2 * n, 2 * n))
    block[:n, :n], block[:n, n:] = -adx, np.eye(n)
    return block


def right_jacobian(xi: NDArray) -> NDArray:
    """J_r(ξ) = ∫₀¹ expm(-s ad_ξ) ds (Van Loan); a 3-vector is on SO(3)."""
    xi = np.asarray(xi, float)
    adx = _so3_ad(xi) if len(xi) == 3 else ad(xi)
    return scipy.linalg.expm(_block(adx))[: len(xi), len(xi) :]


def right_jacobian_inverse(xi: NDArray) -> NDArray:
    return np.linalg.inv(right_jacobian(xi))


def jr_derivative(xi: NDArray, u: NDArray) -> NDArray:
    """DJ_r(ξ)[u], the Fréchet derivative of the Van Loan block exponential (exact to rounding)."""
    n = len(xi)
    direction = np.zeros((2 * n, 2 * n))
    direction[:n, :n] = -ad(np.asarray(u, float))
    _, frechet = scipy.linalg.expm_frechet(_block(ad(np.asarray(xi, float))), direction)
    return frechet[:n, n:]


def jr_inverse_times_derivative(xi: NDArray, v: NDArray, u: NDArray) -> NDArray:
    """D(J_r(ξ)⁻¹ v)[u] = -J_r⁻¹ DJ_r[u] J_r⁻¹ v."""
    Ji = right_jacobian_inverse(xi)
    return -Ji @ jr_derivative(xi, u) @ Ji @ v


def derivative(g: Callable[[NDArray], NDArray], n: int) -> NDArray:
    """∂g/∂δ at δ = 0 (δ of size n): central differences at h, h/2, h/4, h/8, Romberg's table (error O(h⁸))."""

    def central(h: float) -> NDArray:
        return np.column_stack([(np.asarray(g(h * e)) - np.asarray(g(-h * e))) / (2 * h) for e in np.eye(n)])

    table = [central(H / 2**k) for k in range(LEVELS)]
    for level in range(1, LEVELS):
        factor = 4.0**level
        table = [(factor * table[k + 1] - table[k]) / (factor - 1) for k in range(len(table) - 1)]
    return table[0]


@dataclass(frozen=True)
class MatrixGroup:
    """A group of rigid motions as the oracles write it, matrices and ``expm``: what they build on ξ^, its inverse,
    a pose's matrix and back and the matrix Log, once for SE(2) (:mod:`.oracle_lie`) and SE(3) (here). A state is a
    pose of ``pose_size`` numbers followed by vector parts (its twist, its acceleration); a vector of
    ``landmark_size`` is a landmark."""

    hat: Callable[[NDArray], NDArray]  # ξ (dof,) -> ξ^
    vee: Callable[[NDArray], NDArray]  # ξ^ -> ξ
    matrix: Callable[[NDArray], NDArray]  # a pose's numbers -> its matrix
    pose_of: Callable[[NDArray], NDArray]  # a matrix -> the pose's numbers
    log_matrix: Callable[[NDArray], NDArray]  # Log of a matrix, a tangent (dof,)
    pose_size: int
    dof: int
    landmark_size: int

    def adjoint(self, pose: NDArray) -> NDArray:
        """Ad(T): T Exp(ξ) T⁻¹ = Exp(Ad(T) ξ), columns (T eᵢ^ T⁻¹)∨."""
        T = self.matrix(np.asarray(pose, float))
        return np.column_stack([self.vee(T @ self.hat(e) @ np.linalg.inv(T)) for e in np.eye(self.dof)])

    def between(self, a: NDArray, b: NDArray) -> NDArray:
        return self.pose_of(np.linalg.inv(self.matrix(np.asarray(a, float))) @ self.matrix(np.asarray(b, float)))

    def retract(self, x: NDArray, delta: NDArray) -> NDArray:
        """x ⊕ δ: a pose or a state (right retraction: T Exp(δ_T), the vector parts plus theirs), or a landmark."""
        x, delta, n = np.asarray(x, float), np.asarray(delta, float), self.pose_size
        if len(x) == self.landmark_size:
            return x + delta
        pose = self.pose_of(self.matrix(x[:n]) @ scipy.linalg.expm(self.hat(delta[: self.dof])))
        return np.concatenate([pose, x[n:] + delta[self.dof :]])

    def local(self, x0: NDArray, x: NDArray) -> NDArray:
        """x ⊖ x₀ (the inverse of :meth:`retract`)."""
        x0, x, n = np.asarray(x0, float), np.asarray(x, float), self.pose_size
        if len(x) == self.landmark_size:
            return x - x0
        xi = self.log_matrix(np.linalg.inv(self.matrix(x0[:n])) @ self.matrix(x[:n]))
        return np.concatenate([xi, x[n:] - x0[n:]])

    def tangent_size(self, x: NDArray) -> int:
        """The size of a step δ of ``x`` (a pose's dof and its vector parts; a landmark's size)."""
        return len(x) if len(x) == self.landmark_size else self.dof + len(x) - self.pose_size


SE3 = MatrixGroup(hat, _vee, matrix, pose_of, log_matrix, pose_size=12, dof=6, landmark_size=3)
adjoint, between, retract, local = SE3.adjoint, SE3.between, SE3.retract, SE3.local


def jacobian_through(
    retract: Callable[[NDArray, NDArray], NDArray],
    step_size: int,
    f: Callable[..., NDArray],
    args: Sequence[NDArray],
    k: int,
    out_local: Callable | None = None,
) -> NDArray:
    """∂f/∂δₖ at δ = 0 (δₖ of ``step_size``) of f(..., xₖ ⊕ δ, ...) through ``retract`` (:func:`derivative`);
    ``out_local(y0, y)``: the output's local coordinates about y0 (default y - y0)."""
    args = [np.asarray(a, float) for a in args]
    y0 = np.asarray(f(*args), float)
    diff = out_local or (lambda a, b: np.asarray(b, float) - a)

    def g(d: NDArray) -> NDArray:
        return diff(y0, f(*args[:k], retract(args[k], d), *args[k + 1 :]))

    return derivative(g, step_size)


def numeric_jacobian(
    f: Callable[..., NDArray], args: Sequence[NDArray], k: int, out_local: Callable | None = None
) -> NDArray:
    """∂f/∂δₖ at δ = 0 of f(..., xₖ ⊕ δ, ...) through this module's right retraction (:func:`jacobian_through`)."""
    return jacobian_through(retract, SE3.tangent_size(np.asarray(args[k])), f, args, k, out_local)


# --- the local GP ---------------------------------------------------------------------------------------


def _xi(x1: NDArray, x2: NDArray) -> NDArray:
    return log_matrix(np.linalg.inv(matrix(x1[:12])) @ matrix(x2[:12]))


def local_gamma(x1: NDArray, x2: NDArray, model: str) -> NDArray:
    """γ₂ = [ξ; ξ̇] ('local-variable': ξ̇ = J_r(ξ)⁻¹ ϖ₂; 'simplified': ϖ₂), or with an acceleration (24 numbers)
    [ξ; ξ̇; ξ̈], ξ̈ = D(J_r⁻¹ϖ₂)[ξ̇] + J_r⁻¹ ϖ̇₂."""
    x1, x2 = np.asarray(x1, float), np.asarray(x2, float)
    xi = _xi(x1, x2)
    if model == "simplified":
        return np.concatenate([xi, x2[12:18]])
    if model != "local-variable":
        raise SteamError(f"unknown SE(3) prior model {model!r}")
    rate = right_jacobian_inverse(xi) @ x2[12:18]
    if len(x2) == 18:
        return np.concatenate([xi, rate])
    accel = jr_inverse_times_derivative(xi, x2[12:18], rate) + right_jacobian_inverse(xi) @ x2[18:]
    return np.concatenate([xi, rate, accel])


def start_gamma(x1: NDArray) -> NDArray:
    """γ₁ = [0; ϖ₁] (or [0; ϖ₁; ϖ̇₁])."""
    return np.concatenate([np.zeros(6), np.asarray(x1, float)[12:]])


def from_local(x1: NDArray, gamma: NDArray, model: str) -> NDArray:
    """The state at γ: (T₁ Exp ξ, J_r(ξ) ξ̇ [, DJ_r(ξ)[ξ̇] ξ̇ + J_r(ξ) ξ̈]) (simplified: ξ̇ as the twist)."""
    xi, rate = gamma[:6], gamma[6:12]
    pose = pose_of(matrix(np.asarray(x1, float)[:12]) @ scipy.linalg.expm(hat(xi)))
    if model == "simplified":
        return np.concatenate([pose, rate])
    twist = right_jacobian(xi) @ rate
    if len(gamma) == 12:
        return np.concatenate([pose, twist])
    accel = jr_derivative(xi, rate) @ rate + right_jacobian(xi) @ gamma[12:]
    return np.concatenate([pose, twist, accel])


def _model(derivatives: int) -> tuple[NDArray, NDArray]:
    return o.model_matrices("wnoa" if derivatives == 1 else "wnoj", 6)


def prior_error(x1: NDArray, x2: NDArray, dt: float, model: str) -> NDArray:
    """e = γ₂ - Φ(Δt) γ₁ (WNOA with either residual; WNOJ for 24-number states)."""
    A, _ = _model(1 if len(x1) == 18 else 2)
    return local_gamma(x1, x2, model) - o.transition(A, float(dt)) @ start_gamma(x1)


def accel_prior_error(x1: NDArray, x2: NDArray, dt: float) -> NDArray:
    return prior_error(x1, x2, dt, "local-variable")


def prior_covariance(dt: float, qc: NDArray, derivatives: int = 1) -> NDArray:
    A, F = _model(derivatives)
    return o.process_noise(A, F, np.asarray(qc, float), float(dt))


def interpolation_quantities(inputs: Mapping) -> dict:
    """x(τ), J_1, J_2 (and, given ``joint_cov``, cov_tau) of an interpolation case: γ(τ) = Λ γ₁ + Ψ γ₂ mapped back."""
    x1, x2, model = np.asarray(inputs["x1"], float), np.asarray(inputs["x2"], float), inputs["model"]
    t1, t2, tau, qc = float(inputs["t1"]), float(inputs["t2"]), float(inputs["tau"]), np.asarray(inputs["qc"], float)
    A, F = _model(1 if len(x1) == 18 else 2)
    lam, psi, cond = o.interpolation(A, F, qc, t1, t2, tau)

    def gamma_of(a: NDArray, b: NDArray) -> NDArray:
        return lam @ start_gamma(a) + psi @ local_gamma(a, b, model)

    def mean(a: NDArray, b: NDArray) -> NDArray:
        return from_local(a, gamma_of(a, b), model)

    x = mean(x1, x2)
    J1, J2 = (numeric_jacobian(mean, [x1, x2], k, local) for k in (0, 1))
    out = {"x_tau": x, "J_1": J1, "J_2": J2}
    if "joint_cov" in inputs:
        gamma = gamma_of(x1, x2)
        N = derivative(lambda d: local(x, from_local(x1, gamma + d, model)), len(gamma))
        out["cov_tau"] = o.mapped_covariance(np.hstack([J1, J2]), inputs["joint_cov"], N, cond)
    return out


def extrapolation_quantities(inputs: Mapping) -> dict:
    """x(t) = from_local(Φ(t - t₁) γ₁), its Jacobian J_1 and covariance J P₁ Jᵀ + N Q(t - t₁) Nᵀ."""
    x1, qc = np.asarray(inputs["x1"], float), np.asarray(inputs["qc"], float)
    s = float(inputs["t"]) - float(inputs["t1"])
    A, F = _model(1 if len(x1) == 18 else 2)
    Phi = o.transition(A, s)

    def mean(a: NDArray) -> NDArray:
        return from_local(a, Phi @ start_gamma(a), "local-variable")

    x = mean(x1)
    J = numeric_jacobian(mean, [x1], 0, local)
    gamma = Phi @ start_gamma(x1)
    N = derivative(lambda d: local(x, from_local(x1, gamma + d, "local-variable")), len(gamma))
    return {"x_t": x, "J_1": J, "cov_t": o.mapped_covariance(J, inputs["cov1"], N, o.process_noise(A, F, qc, s))}


# --- problems -------------------------------------------------------------------------------------------


def factor_error(spec: Mapping, xs: Sequence[NDArray]) -> NDArray:
    """The error of a factor spec of the se3 suite at its variables' values."""
    kind = spec["type"]
    if kind == "se3_prior":
        return prior_error(xs[0], xs[1], float(spec["dt"]), spec["model"])
    if kind == "se3_wnoj_prior":
        return accel_prior_error(xs[0], xs[1], float(spec["dt"]))
    if kind == "se3_state_prior":
        return local(np.asarray(spec["mean"], float), xs[0])
    if kind == "se3_velocity":
        return np.asarray(xs[0], float)[12:18] - np.asarray(spec["measured"], float)
    raise SteamError(f"unknown se3 factor type {kind!r}")


def factor_covariance(spec: Mapping) -> NDArray:
    if spec["type"] == "se3_prior":
        return prior_covariance(float(spec["dt"]), spec["qc"])
    if spec["type"] == "se3_wnoj_prior":
        return prior_covariance(float(spec["dt"]), spec["qc"], 2)
    return np.diag(np.asarray(spec["sigmas"], float) ** 2)


def factor_jacobians(spec: Mapping, xs: Sequence[NDArray]) -> tuple[NDArray, list[NDArray]]:
    """The error of a factor spec at ``xs`` and H_k = ∂e/∂δₖ in each key's right tangent
    (:func:`.oracle.error_and_jacobians` with this module's :func:`factor_error` and :func:`numeric_jacobian`)."""
    return o.error_and_jacobians(lambda *a: factor_error(spec, a), numeric_jacobian, xs)


def linearize_factor(spec: Mapping, xs: Sequence[NDArray]) -> dict:
    """e, W e, Hₖ, Aₖ = W Hₖ, b = -W e and the cost ½‖W e‖² of a factor spec at ``xs`` (:func:`.oracle.whitened`)."""
    return o.whitened(*factor_jacobians(spec, xs), factor_covariance(spec))


# SE(3) states move by the right retraction; every factor is linearized by differences through it (both looked up
# when called, so a test can swap either for a wrong port's).
LIE3 = Space(lambda x, delta: retract(x, delta), lambda spec, xs: linearize_factor(spec, xs))
