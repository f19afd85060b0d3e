"""How an SE(2) state moves in the ``se2`` suite (kit v5): the right retraction x ⊕ δ and its inverse (across ±π,
a pure translation, a tiny and a beyond-π turn), and the prediction after the last state with its Jacobian and its
covariance under both WNOA models (the mean is either model's; the covariance's map N from the local variable to
the state is not). Every case is independent: :mod:`steam_ref.conformance.oracle_lie`.
"""

from __future__ import annotations

from .base import GROUP, LIE_CHECKS, Case
from .gp import small_spd
from .lie_groups import QC

__all__ = ["motion_cases"]

ORACLE_RETRACT = (
    "oracle: x + d = (T Exp(d[:3]), w + d[3:]) with Exp = expm of the 3x3 matrix and the heading read off it by "
    "atan2 in (-pi, pi]; x' - x = [Log(T^-1 T'); w' - w] with Log from atan2 and V(phi)^-1 (Van Loan)"
)
ORACLE_AHEAD = (
    "oracle: g(t) = Phi(t - t1) [0; w1] mapped back to the state by the case's model (T1 Exp(xi), J_r(xi) xi_dot or "
    "xi_dot); J_1 by central differences (Romberg) through the right retraction; N = dx(t)/dg(t) by the same "
    "differences; Q(t - t1) by quadrature"
)
EQUATION = "[YIB Eq. 17, 22] on SE(2) states through local variables; README 'SE(2)'"

X1 = [1.0, 2.0, 0.3, 1.2, 0.1, 0.9]


def _ahead(model: str) -> dict:
    cov1 = small_spd(6, 3, 2)
    return {"kind": "extrapolation", "model": model, "x1": X1, "t1": 3.5, "t": 4.1, "qc": QC, "cov1": cov1}


def motion_cases() -> list[Case]:
    twist = {
        "local-variable": "the twist J_r(xi) xi_dot, so N = [[J_r(xi), 0], [d(J_r(xi) xi_dot)/d xi, J_r(xi)]]",
        "simplified": "the twist xi_dot, so N = [[J_r(xi), 0], [0, I]]",
    }
    return [
        Case(
            "retract_across_pi",
            EQUATION,
            "x + d = (T Exp(d[:3]), w + d[3:]) row by row, and (x + d) - x = [Log(T^-1 T'); w' - w]: a heading 3.0 "
            "turned by 0.4 (stored -2.883, not 3.4), -3.1 turned by -0.3, a pure translation (d's angle 0: the "
            "position moves by R(theta) rho), a turn of 1e-9, and a turn of 3.5 (beyond pi: local gives back "
            "3.5 - 2 pi and another rho, Log's angle in (-pi, pi])",
            {
                "kind": "retract",
                "x": [
                    [1.0, 2.0, 3.0, 0.5, 0.1, 0.2],
                    [-0.5, 0.4, -3.1, 0.9, -0.2, -0.6],
                    [2.0, -1.0, 0.5, 1.0, 0.0, 0.3],
                    [0.0, 0.0, 0.2, 0.4, 0.3, 0.0],
                    [1.0, 1.0, 1.0, 0.2, 0.2, 0.2],
                ],
                "delta": [
                    [0.1, -0.2, 0.4, 0.05, 0.0, -0.1],
                    [0.3, 0.1, -0.3, 0.0, 0.1, 0.2],
                    [0.7, -0.4, 0.0, 0.1, 0.1, 0.1],
                    [0.2, 0.1, 1e-09, 0.0, 0.0, 0.5],
                    [0.5, 0.2, 3.5, -0.1, 0.0, 0.1],
                ],
            },
            {"retract": GROUP, "local": GROUP},
            True,
            ORACLE_RETRACT,
        ),
        *(
            Case(
                f"extrapolation_{model.replace('-', '_')}",
                EQUATION,
                f"the prediction 0.6 s after the last state (t1 = 3.5, t = 4.1), model '{model}': x(t) = (T1 Exp((t - "
                f"t1) w1), w1) (either model), J_1 = dx(t)/d(delta_1) in right tangents, and its covariance in the right "
                f"tangent at x(t), J_1 P1 J_1^T + N Q(t - t1) N^T, P1 = cov1, N = dx(t)/dg(t) for the local variable "
                f"g = [xi; xi_dot] with {twist[model]}",
                _ahead(model),
                LIE_CHECKS["extrapolation"],
                True,
                ORACLE_AHEAD,
            )
            for model in ("local-variable", "simplified")
        ),
    ]
