"""Fill of R over a BTGP/1 run: ``UpdateReport.tree_nnz`` after every update, as GTSAM's ``ISAM2::treeNnz()``.

The cliques are the preset's (merged at ``amalgamation_zeros`` = z = 0.3, docs/bayes_tree.md "Relaxed
amalgamation": a merged clique's explicit zeros are counted); ``--amalgamation-zeros 0`` builds GTSAM's cliques,
whose fill is the count ``ISAM2::treeNnz()`` gives. Prints one JSON line per data set:
  dataset, amalgamation_zeros, updates, states, landmarks
  nnz_final                 nonzeros of R after the last update (per clique n_f(n_f + 1)/2 + n_f·n_s)
  nnz_at {25, 50, 75, 100}  nnz after that percentage of the updates
  nnz_per_state_final       nnz_final / states: bounded when the tree stays thin (the GP prior is a chain)
  cliques_final             cliques in the final tree
  largest_clique_dim        the largest frontal + separator size of a clique (a dense block of that side)
  run_s                     wall time of the run
and plots nnz over the updates to benchmarks/out/tree_fill_<dataset>.png.

    python benchmarks/tree_fill.py [--datasets paper-synthetic plaza] [--amalgamation-zeros Z]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import matplotlib as mpl

mpl.use("Agg")
import matplotlib.pyplot as plt

from steam_ref.choices import parse_decimal
from steam_ref.datasets import load_range_dataset
from steam_ref.errors import SteamError
from steam_ref.linear.amalgamation import zero_fraction
from steam_ref.paper.online import StreamingEstimator
from steam_ref.paper.options import StreamOptions
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.readings import Readings

OUT = Path(__file__).resolve().parent / "out"
PRESET = {"paper-synthetic": "synthetic", "plaza": "plaza"}


def run(dataset: str, amalgamation_zeros: float | None = None) -> dict:
    data = load_range_dataset(dataset)
    setup = PaperSetup.named(PRESET[dataset]).with_schedule(every=1)  # BTGP/1
    if amalgamation_zeros is not None:
        setup = setup.with_isam2(amalgamation_zeros=amalgamation_zeros)
    estimator = StreamingEstimator(Readings.from_dataset(data, setup), setup, StreamOptions(method="btgp"))
    start = time.perf_counter()
    estimator.run(data.ground_truth)
    seconds = time.perf_counter() - start
    nnz = estimator.solver.tree_nnz  # type: ignore[attr-defined]
    tree = estimator.solver.inner.tree  # type: ignore[attr-defined]
    states = sum(1 for k in tree.frontal_of if k.symbol == "x")
    OUT.mkdir(exist_ok=True)
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot(range(1, len(nnz) + 1), nnz, lw=1)
    ax.set(xlabel="update", ylabel="nnz of R (GTSAM's treeNnz)", title=f"BTGP/1 on {dataset}: fill per update")
    fig.tight_layout()
    fig.savefig(OUT / f"tree_fill_{dataset}.png", dpi=120)
    plt.close(fig)
    return {
        "dataset": dataset,
        "amalgamation_zeros": setup.isam2.amalgamation_zeros,
        "updates": len(nnz),
        "states": states,
        "landmarks": sum(1 for k in tree.frontal_of if k.symbol == "l"),
        "nnz_final": nnz[-1],
        "nnz_at": {p: nnz[max(0, round(p / 100 * len(nnz)) - 1)] for p in (25, 50, 75, 100)},
        "nnz_per_state_final": round(nnz[-1] / states, 1),
        "cliques_final": len(tree),
        "largest_clique_dim": max(sum(c.frontal_dims) + sum(c.separator_dims) for c in tree.cliques.values()),
        "run_s": round(seconds, 1),
    }


def _fraction(text: str) -> float:
    """``--amalgamation-zeros``: a fraction in [0, 1) (its home's rule), else argparse's one-line error."""
    try:
        return zero_fraction(parse_decimal(text))
    except SteamError:
        raise argparse.ArgumentTypeError(f"expected a fraction >= 0 and < 1, got {text!r}") from None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--datasets", nargs="+", default=list(PRESET), choices=list(PRESET))
    parser.add_argument(
        "--amalgamation-zeros",
        type=_fraction,
        default=None,
        metavar="Z",
        help="merge cliques up to this fraction of explicit zeros, 0 <= Z < 1 (default: the preset's; 0: GTSAM's cliques)",
    )
    args = parser.parse_args()
    for dataset in args.datasets:
        print(json.dumps(run(dataset, args.amalgamation_zeros)), flush=True)


if __name__ == "__main__":
    main()
