"""Each coefficient of SO(3)'s and SE(3)'s closed forms against its definition at 50 digits, from θ = 1e-12 to π.
[derivations §13]

For every coefficient of :mod:`steam_ref.lie.coefficients` (A = sin θ/θ, ..., G2), the relative error of ours
(series below θ = 2, closed forms above, B1 and A2 about their roots) and of the plain closed form (its
definition evaluated in float64, as a port without the series would) against the definition in mpmath with 120
digits. Prints one JSON line per coefficient (the worst error of each, and where) and draws the curves:

    python benchmarks/lie_coefficients.py [--points 500] [--plot docs/figures/lie_coefficients.png]
"""

from __future__ import annotations

import argparse
import json
import math
import types

import mpmath as mp
import numpy as np

from steam_ref.lie import SO3
from steam_ref.lie.coefficients import SERIES_BELOW

# float64's math module for the definitions (m.sin, m.cos, m.cot), evaluated as written: the plain closed forms
PLAIN = types.SimpleNamespace(sin=np.sin, cos=np.cos, cot=lambda x: 1 / np.tan(x))


def angles(points: int) -> np.ndarray:
    """Log-spaced from 1e-12 to 1, then uniform to π (where the roots and the switch lie), with π itself."""
    return np.r_[np.logspace(-12, 0, points // 2, endpoint=False), np.linspace(1.0, np.pi, points - points // 2)]


def errors(theta: np.ndarray) -> dict[str, dict[str, np.ndarray]]:
    """{name: {"ours": relative errors, "plain": the plain closed form's}} at the angles θ."""
    ours = SO3.coefficients(theta)
    with np.errstate(all="ignore"):
        plain = {name: np.asarray(f(theta, PLAIN), dtype=float) for name, f in SO3.coefficient_definitions.items()}
    out = {}
    with mp.workdps(120):
        for name, definition in SO3.coefficient_definitions.items():
            want = [definition(mp.mpf(float(t)), mp) for t in theta]
            rel = [
                np.array(
                    [
                        float(abs(mp.mpf(float(g)) - w) / abs(w)) if math.isfinite(g) else np.inf
                        for g, w in zip(got, want, strict=True)
                    ]
                )
                for got in (ours[name], plain[name])
            ]
            out[name] = {"ours": rel[0], "plain": rel[1]}
    return out


def plot(theta: np.ndarray, errs: dict[str, dict[str, np.ndarray]], path: str) -> None:
    import matplotlib as mpl

    mpl.use("Agg")
    import matplotlib.pyplot as plt

    k = 8 / (np.pi - 1)  # the x axis: log θ up to 1 (12 decades), then θ itself to π (as wide as 8 decades)

    def forward(x: np.ndarray) -> np.ndarray:
        x = np.maximum(np.asarray(x, dtype=float), 1e-300)
        return np.where(x < 1, np.log10(x), (x - 1) * k)

    def inverse(y: np.ndarray) -> np.ndarray:
        y = np.asarray(y, dtype=float)
        return np.where(y < 0, 10.0 ** np.minimum(y, 0), 1 + y / k)

    names = list(errs)
    cols = 4
    rows = -(-len(names) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.2 * rows), sharex=True, sharey=True)
    floor = 1e-18  # an exact answer drawn at the bottom
    for ax, name in zip(axes.ravel(), names, strict=False):
        for key, style in (("plain", {"color": "0.75", "lw": 0.8}), ("ours", {"color": "C0", "lw": 1.0})):
            ax.plot(theta, np.clip(errs[name][key], floor, 1.0), **style)
        ax.set_xscale("function", functions=(forward, inverse))
        ax.set_yscale("log")
        ax.set_xticks([1e-12, 1e-8, 1e-4, 1.0, 2.0, np.pi], ["1e-12", "1e-8", "1e-4", "1", "2", "π"])
        ax.axhline(1e-13, color="C3", lw=0.6, ls="--")
        ax.axvline(SERIES_BELOW, color="0.5", lw=0.5, ls=":")
        ax.set_title(name, fontsize=9)
        ax.tick_params(labelsize=7)
    for ax in axes.ravel()[len(names) :]:
        ax.axis("off")
    fig.suptitle(
        "Relative error against 50 digits: ours (blue), the plain closed form (grey); bound 1e-13 (red), series switch θ = 2",
        fontsize=9,
    )
    fig.supxlabel("θ (rad)", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=500)
    parser.add_argument("--plot", default=None, help="write the figure here (PNG)")
    args = parser.parse_args(argv)
    theta = angles(args.points)
    errs = errors(theta)
    for name, e in errs.items():
        i = int(np.argmax(e["ours"]))
        print(
            json.dumps(
                {
                    "coefficient": name,
                    "worst_relative_error": float(e["ours"][i]),
                    "at_theta": float(theta[i]),
                    "plain_closed_form_worst": float(np.max(e["plain"])),
                }
            )
        )
    if args.plot:
        plot(theta, errs, args.plot)


if __name__ == "__main__":
    main()
