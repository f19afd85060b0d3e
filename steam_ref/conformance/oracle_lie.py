"""The oracle on SE(2): 3×3 matrices and SciPy's ``expm`` (SE(3)'s is :mod:`.oracle_rigid`).

Independent expected values of the ``se2`` suite. Nothing here shares code with ``steam_ref.lie`` or
``steam_ref.factors``: no series, no closed forms.

- Exp(ξ) = expm(ξ^) of the 3×3 matrix ξ^ = [[0, -φ, ρ₁], [φ, 0, ρ₂], [0, 0, 0]], tangent order [ρ; φ];
  the pose [x, y, θ] read off it with θ = atan2(R₁₀, R₀₀) in (-π, π] (a -π from atan2 is taken as +π; under the
  alternative convention 'signed-half-turn', ``half_turn=None``, atan2's ±π is kept: GTSAM's Pose2).
- Log(T): φ = that angle; ρ = V(φ)⁻¹ t, where the columns of V(φ) are the translations of
  expm([e₁; φ]^) and expm([e₂; φ]^) (t = V(φ) ρ is linear in ρ).
- J_r(ξ) = ∫₀¹ expm(-s ad_ξ) ds, by Van Loan's block exponential: the top-right block of
  expm([[-ad_ξ, I], [0, 0]]); ad_ξ's columns are the commutators [ξ^, eᵢ^]∨. J_r⁻¹ by a dense inverse.
- The state x = [x, y, θ, vx, vy, ω] (pose and body twist) moves by the right retraction
  x ⊕ δ = (T Exp(δ[:3]), ϖ + δ[3:]); x ⊖ x₀ = [Log(T₀⁻¹T); ϖ - ϖ₀].
- Every Jacobian is a Romberg-extrapolated central difference through that retraction (steps h to h/8, error
  O(h⁸)), of the output in its own local coordinates about the unperturbed output.
- The WNOA residuals and the local GP (Λ, Ψ and the conditional covariance from :mod:`.oracle`'s dense
  kernel) on these definitions, the prediction after the last state; readings of a state (range, bearing,
  bearing-range of the pose as :mod:`.oracle` writes them for a vector state, the body twist), also at τ through the
  local GP's mean (kit v5); :data:`LIE`, the :class:`.oracle_graph.Space` in which the graph oracle's
  Gauss-Newton and iSAM2 replay (:mod:`.oracle_graph`) solve problems on these states.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from ..errors import SteamError
from . import oracle as o
from .oracle_graph import Space
from .oracle_rigid import MatrixGroup, jacobian_through
from .oracle_rigid import derivative as romberg

__all__ = [
    "hat",
    "exp",
    "log",
    "right_jacobian",
    "retract",
    "local",
    "prior_error",
    "derivative",
    "numeric_jacobian",
    "interpolate",
    "interpolation_quantities",
    "extrapolation_quantities",
    "retraction_quantities",
    "factor_error",
    "factor_jacobians",
    "linearize_factor",
    "LIE",
]


def hat(xi: NDArray) -> NDArray:
    """ξ^ for ξ = [ρ₁, ρ₂, φ]."""
    r1, r2, p = xi
    return np.array([[0.0, -p, r1], [p, 0.0, r2], [0.0, 0.0, 0.0]])


def _vee(M: NDArray) -> NDArray:
    return np.array([M[0, 2], M[1, 2], M[1, 0]])


def matrix(pose: NDArray) -> NDArray:
    """The 3×3 homogeneous matrix of [x, y, θ]."""
    c, s = np.cos(pose[2]), np.sin(pose[2])
    return np.array([[c, -s, pose[0]], [s, c, pose[1]], [0.0, 0.0, 1.0]])


HALF_TURN = np.pi  # the angle of the half turn: +π, the kit's (angles in (-π, π]); None under 'signed-half-turn'


def _angle(M: NDArray, half_turn: float | None = HALF_TURN) -> float:
    """The angle of M, atan2(R₁₀, R₀₀), with ±π (the double nearest π) read as ``half_turn``; None keeps atan2's
    sign (the sign of R₁₀: that double lies 1.2e-16 inside the half turn)."""
    a = float(np.arctan2(M[1, 0], M[0, 0]))
    return a if half_turn is None or abs(a) < np.pi else half_turn


def pose_of(M: NDArray, half_turn: float | None = HALF_TURN) -> NDArray:
    return np.array([M[0, 2], M[1, 2], _angle(M, half_turn)])


def exp(xi: NDArray, half_turn: float | None = HALF_TURN) -> NDArray:
    """Exp(ξ) as a pose [x, y, θ], θ in (-π, π] (``half_turn`` None: ±π as atan2 gives it)."""
    return pose_of(scipy.linalg.expm(hat(np.asarray(xi, float))), half_turn)


def _V(phi: float) -> NDArray:
    """V(φ) with t = V(φ) ρ in Exp([ρ; φ]): the top-right block of expm([[φ J, I], [0, 0]]) (Van Loan),
    which is ∫₀¹ expm(s φ J) ds, the translation part of expm(ξ^) read column by column."""
    block = np.zeros((4, 4))
    block[:2, :2], block[:2, 2:] = [[0.0, -phi], [phi, 0.0]], np.eye(2)
    return scipy.linalg.expm(block)[:2, 2:]


def log_matrix(M: NDArray, half_turn: float | None = HALF_TURN) -> NDArray:
    """Log of a 3×3 pose matrix: [V(φ)⁻¹ t; φ], φ in (-π, π] (``half_turn`` None: ±π as atan2 gives it)."""
    phi = _angle(M, half_turn)
    return np.array([*np.linalg.solve(_V(phi), M[:2, 2]), phi])


def log(pose: NDArray, half_turn: float | None = HALF_TURN) -> NDArray:
    return log_matrix(matrix(np.asarray(pose, float)), half_turn)


def _ad(xi: NDArray) -> NDArray:
    X = hat(xi)
    return np.column_stack([_vee(X @ hat(e) - hat(e) @ X) for e in np.eye(3)])


def right_jacobian(xi: NDArray) -> NDArray:
    """J_r(ξ) = ∫₀¹ expm(-s ad_ξ) ds (Van Loan)."""
    block = np.zeros((6, 6))
    block[:3, :3], block[:3, 3:] = -_ad(np.asarray(xi, float)), np.eye(3)
    return scipy.linalg.expm(block)[:3, 3:]


def right_jacobian_inverse(xi: NDArray) -> NDArray:
    return np.linalg.inv(right_jacobian(xi))


SE2 = MatrixGroup(hat, _vee, matrix, pose_of, log_matrix, pose_size=3, dof=3, landmark_size=2)  # a 6-vector: a state
adjoint, between, retract, local = SE2.adjoint, SE2.between, SE2.retract, SE2.local


def derivative(g: Callable[[NDArray], NDArray], n: int) -> NDArray:
    """∂g/∂δ at δ = 0 (δ of size n): central differences at h, h/2, h/4, h/8 (h = 0.04) combined by Romberg's table
    (:func:`.oracle_rigid.derivative`, error O(h⁸), ~1e-13; kit v4 was built with h = 1e-3 and h/2, ~1e-12)."""
    return romberg(g, n)


def numeric_jacobian(
    f: Callable[..., NDArray], args: Sequence[NDArray], k: int, out_local: Callable | None = None
) -> NDArray:
    """∂f/∂δₖ at δ = 0 of f(..., xₖ ⊕ δ, ...) through this module's right retraction (:func:`.oracle_rigid.jacobian_through`,
    :func:`derivative`'s table); ``out_local(y0, y)``: the output's local coordinates about y0 (default y - y0)."""
    return jacobian_through(retract, SE2.tangent_size(np.asarray(args[k])), f, args, k, out_local)


def prior_error(x1: NDArray, x2: NDArray, dt: float, model: str) -> NDArray:
    """e = [ξ - Δt ϖ₁; J_r(ξ)⁻¹ ϖ₂ - ϖ₁] (local-variable) or [ξ - Δt ϖ₁; ϖ₂ - ϖ₁] (simplified), ξ = Log(T₁⁻¹T₂)."""
    x1, x2 = np.asarray(x1, float), np.asarray(x2, float)
    xi = log_matrix(np.linalg.inv(matrix(x1[:3])) @ matrix(x2[:3]))
    if model == "local-variable":
        velocity = right_jacobian_inverse(xi) @ x2[3:]
    elif model == "simplified":
        velocity = x2[3:]
    else:
        raise SteamError(f"unknown SE(2) prior model {model!r}")
    return np.concatenate([xi - dt * x1[3:], velocity - x1[3:]])


def _wnoa() -> tuple[NDArray, NDArray]:
    return o.model_matrices("wnoa", 3)


def prior_covariance(dt: float, qc: NDArray) -> NDArray:
    A, F = _wnoa()
    return o.process_noise(A, F, np.asarray(qc, float), float(dt))


def _local_gamma(x1: NDArray, x2: NDArray, model: str) -> NDArray:
    """γ₂ in the frame of T₁: the prior's error plus Φ γ₁ (Δt = 0 gives [ξ; ξ̇(t₂)])."""
    return prior_error(x1, x2, 0.0, model) + np.concatenate([np.zeros(3), np.asarray(x1, float)[3:]])


def _from_local(x1: NDArray, gamma: NDArray, model: str) -> NDArray:
    """The state at γ = [ξ; ξ̇]: (T₁ Exp ξ, J_r(ξ) ξ̇) (simplified: ξ̇)."""
    xi, xidot = gamma[:3], gamma[3:]
    pose = pose_of(matrix(np.asarray(x1, float)[:3]) @ scipy.linalg.expm(hat(xi)))
    twist = right_jacobian(xi) @ xidot if model == "local-variable" else xidot
    return np.concatenate([pose, twist])


def interpolate(t1: float, t2: float, tau: float, qc: NDArray, model: str):
    """x(τ) = from_local(Λ γ₁ + Ψ γ₂), with the local GP's matrices and conditional covariance (dense kernel)."""
    A, F = _wnoa()
    lam, psi, cond = o.interpolation(A, F, np.asarray(qc, float), t1, t2, tau)

    def mean(a: NDArray, b: NDArray) -> NDArray:
        gamma = lam @ np.concatenate([np.zeros(3), np.asarray(a, float)[3:]]) + psi @ _local_gamma(a, b, model)
        return _from_local(a, gamma, model)

    return mean, lam, psi, cond


def extrapolation_quantities(inputs: Mapping) -> dict:
    """x(t) = from_local(Φ(t - t₁) γ₁) after the last state (either model: the same mean), its Jacobian J_1 and its
    covariance J P₁ Jᵀ + N Q(t - t₁) Nᵀ with N = ∂x(t)/∂γ(t) of the case's model."""
    x1, model = np.asarray(inputs["x1"], float), inputs["model"]
    s = float(inputs["t"]) - float(inputs["t1"])
    A, F = _wnoa()
    Phi = o.transition(A, s)

    def gamma_of(a: NDArray) -> NDArray:
        return Phi @ np.concatenate([np.zeros(3), np.asarray(a, float)[3:]])

    def mean(a: NDArray) -> NDArray:
        return _from_local(a, gamma_of(a), model)

    x = mean(x1)
    J = numeric_jacobian(mean, [x1], 0, local)
    N = derivative(lambda d: local(x, _from_local(x1, gamma_of(x1) + d, model)), 6)
    Q = o.process_noise(A, F, np.asarray(inputs["qc"], float), s)
    return {"x_t": x, "J_1": J, "cov_t": o.mapped_covariance(J, inputs["cov1"], N, Q)}


def retraction_quantities(inputs: Mapping) -> dict:
    """x ⊕ δ of each row, and (x ⊕ δ) ⊖ x (δ again while δ's angle lies in (-π, π))."""
    moved = [retract(x, d) for x, d in zip(inputs["x"], inputs["delta"], strict=True)]
    return {
        "retract": np.array(moved),
        "local": np.array([local(x, y) for x, y in zip(inputs["x"], moved, strict=True)]),
    }


def interpolation_quantities(inputs: Mapping) -> dict:
    """x(τ) and its Jacobians J_1, J_2, or (given ``joint_cov``) x(τ) and its covariance, of an interpolation
    case's inputs."""
    x1, x2, model = np.asarray(inputs["x1"], float), np.asarray(inputs["x2"], float), inputs["model"]
    t1, t2, tau, qc = float(inputs["t1"]), float(inputs["t2"]), float(inputs["tau"]), inputs["qc"]
    mean, lam, psi, cond = interpolate(t1, t2, tau, qc, model)
    x = mean(x1, x2)
    J1, J2 = (numeric_jacobian(mean, [x1, x2], k, local) for k in (0, 1))
    if "joint_cov" not in inputs:
        return {"x_tau": x, "J_1": J1, "J_2": J2}
    gamma = lam @ np.concatenate([np.zeros(3), x1[3:]]) + psi @ _local_gamma(x1, x2, model)
    N = derivative(lambda d: local(x, _from_local(x1, gamma + d, model)), 6)  # ∂[δT; dϖ]/∂γ
    return {"x_tau": x, "cov_tau": o.mapped_covariance(np.hstack([J1, J2]), inputs["joint_cov"], N, cond)}


# --- problems -------------------------------------------------------------------------------------


def factor_error(spec: Mapping, xs: Sequence[NDArray]) -> NDArray:
    """The error of a factor spec of the se2 suite at its variables' values."""
    kind = spec["type"]
    if kind == "se2_prior":
        return prior_error(xs[0], xs[1], float(spec["dt"]), spec["model"])
    if kind == "se2_state_prior":
        return local(np.asarray(spec["mean"], float), xs[0])
    if kind == "se2_range":
        return np.array(
            [np.hypot(*(np.asarray(xs[1], float) - np.asarray(xs[0], float)[:2])) - float(spec["measured"])]
        )
    if kind in ("se2_bearing", "se2_bearing_range"):  # kit v5: the pose [x, y, θ] read as a vector state's
        return o.measurement_error(kind.removeprefix("se2_"), spec, np.asarray(xs[0], float), np.asarray(xs[1], float))
    if kind == "se2_velocity":  # kit v5: the body twist
        return np.asarray(xs[0], float)[3:] - np.asarray(spec["measured"], float)
    if kind == "se2_interpolated":  # kit v5: the inner reading at x(τ), the local GP's mean
        mean = interpolate(float(spec["t1"]), float(spec["t2"]), float(spec["tau"]), spec["qc"], spec["model"])[0]
        return factor_error(spec["inner"], [mean(xs[0], xs[1]), *xs[2:]])
    if kind == "prior":
        return np.asarray(xs[0], float) - np.asarray(spec["mean"], float)
    raise SteamError(f"unknown se2 factor type {kind!r}")


def factor_covariance(spec: Mapping) -> NDArray:
    if spec["type"] == "se2_prior":
        return prior_covariance(float(spec["dt"]), spec["qc"])
    if spec["type"] == "se2_interpolated":
        return factor_covariance(spec["inner"])
    size = {"se2_velocity": 3, "se2_bearing_range": 2}.get(spec["type"], len(spec.get("sigmas", [0])))
    return o.noise_covariance(spec, size)


def factor_jacobians(spec: Mapping, xs: Sequence[NDArray]) -> tuple[NDArray, list[NDArray]]:
    """The error of a factor spec at ``xs`` and its Jacobian H_k = ∂e/∂δₖ in each key's right tangent
    (:func:`.oracle.error_and_jacobians` with this module's :func:`factor_error` and :func:`numeric_jacobian`)."""
    return o.error_and_jacobians(lambda *a: factor_error(spec, a), numeric_jacobian, xs)


def linearize_factor(spec: Mapping, xs: Sequence[NDArray]) -> dict:
    """e, W e, Hₖ, Aₖ = W Hₖ, b = -W e and the cost ½‖W e‖² of a factor spec at ``xs`` (no robust losses here:
    :func:`.oracle.whitened`)."""
    return o.whitened(*factor_jacobians(spec, xs), factor_covariance(spec))


# The states move by the right retraction; every factor is linearized by differences through it. Both are looked
# up when called, so a test can swap either for a wrong port's.
LIE = Space(lambda x, delta: retract(x, delta), lambda spec, xs: linearize_factor(spec, xs), lambda x0, x: local(x0, x))
