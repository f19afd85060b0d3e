"""A whole run at an earlier commit and at this tree, alternating: wall time, update time and peak memory.

The bookkeeping that keeps the solver honest (one state, one undo log, the divergence check) must not cost a user
time or memory: Plaza BTGP/1 is measured at ``--ref`` (default a80dcd0, the last commit before that bookkeeping)
and at this working tree, each in a fresh process, ``--pairs`` times (default 4), the order of each pair
alternating, with one BLAS thread (``OPENBLAS_NUM_THREADS=1``; a80dcd0 did not limit the BLAS itself). The
reference tree is extracted with ``git archive`` into a temporary folder (this needs a clone with history); both
read the data through the same ``$STEAM_REF_DATA_DIR``. Each run is the command a user types,
``python -m steam_ref run --dataset plaza --method btgp --every 1 --json``; its own JSON gives ``total_s``,
``update_s_median`` and ``peak_rss_mb``. Prints one JSON line with every run, the medians and the ratios (this
tree over the reference: below 1 is faster or smaller), and writes benchmarks/out/against_commit.png.

    python benchmarks/against_commit.py [--pairs 4] [--ref a80dcd0] [--dataset plaza] [--max-poses N]
"""

from __future__ import annotations

import argparse
import io
import json
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parents[1]
OUT = Path(__file__).resolve().parent / "out"
FIGURES = ("total_s", "update_s_median", "peak_rss_mb")


def extract(ref: str, into: Path) -> Path:
    """The package as it was at ``ref``, unpacked under ``into``."""
    archive = subprocess.run(["git", "-C", str(HERE), "archive", ref, "steam_ref"], check=True, capture_output=True)
    with tarfile.open(fileobj=io.BytesIO(archive.stdout)) as tar:
        tar.extractall(into, filter="data")
    return into


def run(tree: Path, argv: list[str], cwd: Path) -> dict:
    """One run of the command with ``tree`` first on the path; its JSON line's figures."""
    env = os.environ | {"PYTHONPATH": str(tree), "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, "-m", "steam_ref", *argv], cwd=cwd, env=env, capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"the run at {tree} failed: {proc.stderr.strip()[-1500:]}")
    row = json.loads(proc.stdout.strip().splitlines()[-1])
    return {k: row[k] for k in (*FIGURES, "rmse_m")}


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--pairs", type=int, default=4)
    p.add_argument("--ref", default="a80dcd0")
    p.add_argument("--dataset", default="plaza")
    p.add_argument("--max-poses", type=int, default=None)
    a = p.parse_args(argv)
    command = ["run", "--dataset", a.dataset, "--method", "btgp", "--every", "1", "--json"]  # no terminal: no bar
    command += [] if a.max_poses is None else ["--max-poses", str(a.max_poses)]
    runs: dict[str, list[dict]] = {"ref": [], "now": []}
    with tempfile.TemporaryDirectory() as tmp:
        trees = {"ref": extract(a.ref, Path(tmp) / "ref"), "now": HERE}
        neutral = Path(tmp)  # not a tree: `python -m` puts the working folder first on the path
        for i in range(a.pairs):
            for name in ("ref", "now") if i % 2 == 0 else ("now", "ref"):
                runs[name].append(run(trees[name], command, neutral))
                print(name, runs[name][-1], file=sys.stderr)
    medians = {name: {k: statistics.median(r[k] for r in rows) for k in FIGURES} for name, rows in runs.items()}
    ratios = {k: round(medians["now"][k] / medians["ref"][k], 3) for k in FIGURES}
    pair_ratios = [round(n["total_s"] / r["total_s"], 3) for n, r in zip(runs["now"], runs["ref"], strict=True)]
    same = {r["rmse_m"] for rows in runs.values() for r in rows}
    print(
        json.dumps(
            {"ref": a.ref, "dataset": a.dataset, "pairs": a.pairs, "rmse_m": sorted(same), "medians": medians}
            | {"ratio_now_over_ref": ratios, "total_s_ratio_per_pair": pair_ratios, "runs": runs}
        )
    )

    import matplotlib as mpl

    mpl.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(FIGURES), figsize=(10, 3), layout="constrained")
    for ax, k in zip(axes, FIGURES, strict=True):
        for x, name in enumerate(("ref", "now")):
            ax.plot([x] * len(runs[name]), [r[k] for r in runs[name]], "o", alpha=0.6)
        ax.set(xticks=[0, 1], xticklabels=[a.ref, "this tree"], title=k, xlim=(-0.5, 1.5))
    fig.suptitle(f"{a.dataset} BTGP/1, {a.pairs} alternating pairs")
    OUT.mkdir(exist_ok=True)
    fig.savefig(OUT / "against_commit.png", dpi=120)


if __name__ == "__main__":
    main()
