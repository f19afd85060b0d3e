"""GTSAM 4.3's ``WnoaMotionFactorPose3`` Jacobians beside ours, against 8th-order differences, for |ξ| from 1e-6 to 3.
[derivations §11, §13]

The residual is the same on both sides (e = [ξ - Δt ϖ₁; J_r(ξ)⁻¹ ϖ₂ - ϖ₁], agreeing to 1e-12:
tests/test_gtsam_wnoa3.py); GTSAM differentiates J_r(ξ)⁻¹ ϖ₂ by a truncated series, ours exactly
(``LieGroup.jr_inverse_times_jacobian``). At each size s, two states a body moving as its twists say: ξ = Log(T₁⁻¹T₂)
with rotation and translation parts of norm s, ϖ₁ = ξ / Δt plus a tenth of it in noise, ϖ₂ = ϖ₁ plus as much
(Δt = 0.7, Qc = diag(0.5, 0.8, 1.1, 0.05, 0.07, 0.09)); the error is the largest entry of W (J - J₈) over both
states' 12 × 12 blocks, W the factor's square-root information and J₈ the 8th-order central differences of our
residual through the right retraction (step 2⁻⁷, :mod:`steam_ref.conformance.differences`), the worst of ``--seeds``
draws. Ours sits on the differences' own floor. Prints one JSON line (sizes, both errors) and draws the curves:

    python benchmarks/wnoa_pose3_jacobians.py [--points 37] [--seeds 3] [--plot docs/figures/wnoa_pose3_jacobians.png]
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from steam_ref.conformance.differences import jacobian8
from steam_ref.lie import SE3, GroupState
from steam_ref.motion import LieGroupWnoa
from steam_ref.variables import X

PERM = np.r_[3:6, 0:3]  # ours [ρ; φ] -> GTSAM's [ω; v], both ways
ROWS = np.r_[PERM, 6 + PERM]
QC = np.diag([0.5, 0.8, 1.1, 0.05, 0.07, 0.09])
DT = 0.7
STATE = GroupState(SE3)


def states(size: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Two states [T; ϖ] (SE3's poses [t; R]) as the module docstring says."""
    rng = np.random.default_rng(seed)
    xi = rng.standard_normal(6)
    xi[:3] *= size / np.linalg.norm(xi[:3])
    xi[3:] *= size / np.linalg.norm(xi[3:])
    T = SE3.exp(rng.standard_normal(6))
    w1 = xi / DT + 0.1 * size * rng.standard_normal(6)
    w2 = w1 + 0.1 * size * rng.standard_normal(6)
    return np.r_[T, w1], np.r_[SE3.compose(T, SE3.exp(xi)), w2]


def gtsam_jacobians(x1: np.ndarray, x2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """GTSAM's ∂e/∂x₁, ∂e/∂x₂ (12, 12) each, in our order."""
    import gtsam

    factor = gtsam.WnoaMotionFactorPose3(gtsam.StateData(1, 2, 0.0), gtsam.StateData(3, 4, DT), np.diag(QC)[PERM])
    H = [np.zeros((12, 6), order="F") for _ in range(4)]
    args = []
    for x in (x1, x2):
        args += [gtsam.Pose3(SE3.matrix(x[:12])), x[12:][PERM]]
    factor.evaluateError(*args, *H)
    back = np.argsort(ROWS)
    return np.hstack(H[:2])[back][:, back], np.hstack(H[2:])[back][:, back]


def errors(size: float, seeds: int) -> tuple[float, float]:
    """The worst whitened Jacobian error over ``seeds`` draws: (ours, GTSAM's)."""
    prior = LieGroupWnoa(SE3, QC).prior_factor(X(0), X(1), DT)
    W = prior.sqrt_information
    ours_off = theirs_off = 0.0
    for seed in range(seeds):
        x1, x2 = states(size, seed)
        num = (
            jacobian8(lambda d, a=x1, b=x2: prior.error(STATE.retract(a, d), b), 12),
            jacobian8(lambda d, a=x1, b=x2: prior.error(a, STATE.retract(b, d)), 12),
        )
        for ours, theirs, n in zip(prior.jacobians(x1, x2), gtsam_jacobians(x1, x2), num, strict=True):
            ours_off = max(ours_off, float(np.max(np.abs(W @ (ours - n)))))
            theirs_off = max(theirs_off, float(np.max(np.abs(W @ (theirs - n)))))
    return ours_off, theirs_off


def plot(sizes: np.ndarray, ours: np.ndarray, theirs: np.ndarray, path: str) -> None:
    import matplotlib as mpl

    mpl.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.0, 3.6))
    floor = 1e-16  # an exact difference drawn at the bottom
    ax.loglog(sizes, np.maximum(theirs, floor), "o-", color="C3", ms=3, lw=1.0, label="GTSAM 4.3 (truncated series)")
    ax.loglog(sizes, np.maximum(ours, floor), "o-", color="C0", ms=3, lw=1.0, label="steam_ref (exact)")
    ax.set_xlabel("|ξ| (rad; translation part of the same norm, m)")
    ax.set_ylabel("max |W (J − J₈)|")
    ax.set_title("WnoaMotionFactorPose3: whitened Jacobian error against 8th-order differences", fontsize=9)
    ax.grid(True, which="major", lw=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=37)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--plot", default=None, help="write the figure here (PNG)")
    args = parser.parse_args(argv)
    sizes = np.logspace(-6, np.log10(3.0), args.points)
    ours, theirs = np.array([errors(float(s), args.seeds) for s in sizes]).T
    print(
        json.dumps(
            {
                "sizes": sizes.tolist(),
                "ours": ours.tolist(),
                "gtsam": theirs.tolist(),
                "ours_worst": float(ours.max()),
                "gtsam_at": {
                    f"{s:g}": float(np.interp(np.log(s), np.log(sizes), theirs)) for s in (0.01, 0.1, 1.0, 2.0)
                },
            }
        )
    )
    if args.plot:
        plot(sizes, ours, theirs, args.plot)


if __name__ == "__main__":
    main()
