"""Joint covariance of the first and the last state from BTGP's Bayes tree on a whole run.  [K11 Sec. 3]

Runs BTGP/1 with the paper's set-up on a data set (Plaza by default: 9,658 states, 4 landmarks),
then asks the final tree for the joint covariance of the first and the last state
(``covariance.tree_joint_covariance``: one walk down the two root paths, carrying only the
variables still needed). Prints one JSON line:

    dataset, n_states, n_cliques, run_s, depth_first, cliques_walked, joint_s_median (of --repeat),
    joint_peak_mb (tracemalloc, the query alone), target_s, target_mb, meets_target

The target set when the joint covariance was made to scale: under 1 s and 200 MB on Plaza.

    python benchmarks/covariance.py [--dataset plaza] [--max-poses N] [--repeat 5]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
import tracemalloc

from steam_ref.covariance import tree_joint_covariance
from steam_ref.datasets import load_dataset
from steam_ref.paper.online import StreamingEstimator
from steam_ref.paper.options import StreamOptions
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.readings import Readings
from steam_ref.variables import X

PRESET = {"synthetic": "synthetic", "paper-synthetic": "synthetic", "plaza": "plaza"}
TARGET_S, TARGET_MB = 1.0, 200.0


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--dataset", default="plaza", choices=sorted(PRESET))
    p.add_argument("--max-poses", type=int, default=None, help="run only this prefix of the poses")
    p.add_argument("--repeat", type=int, default=5, help="timed queries (the median is reported)")
    a = p.parse_args(argv)
    setup = PaperSetup.named(PRESET[a.dataset]).with_schedule(every=1)
    estimator = StreamingEstimator(
        Readings.from_dataset(load_dataset(a.dataset), setup),
        setup,
        StreamOptions(method="btgp", max_poses=a.max_poses),
    )
    start = time.perf_counter()
    estimator.run()
    run_s = time.perf_counter() - start
    tree = estimator.solver.inner.tree
    states = estimator.states[: estimator.n_solved]
    keys = [X(states[0]), X(states[-1])]
    paths = [tree.path_to_root(tree.clique_containing(k)) for k in keys]
    seconds = []
    for _ in range(a.repeat):
        t0 = time.perf_counter()
        tree_joint_covariance(tree, keys)
        seconds.append(time.perf_counter() - t0)
    tracemalloc.start()
    tree_joint_covariance(tree, keys)
    peak_mb = tracemalloc.get_traced_memory()[1] / 1e6
    tracemalloc.stop()
    joint_s = statistics.median(seconds)
    out = dict(
        dataset=a.dataset,
        n_states=len(states),
        n_cliques=len(tree),
        run_s=round(run_s, 2),
        depth_first=len(paths[0]),
        cliques_walked=len(set(paths[0]) | set(paths[1])),
        joint_s_median=round(joint_s, 4),
        joint_peak_mb=round(peak_mb, 3),
        target_s=TARGET_S,
        target_mb=TARGET_MB,
        meets_target=joint_s < TARGET_S and peak_mb < TARGET_MB,
    )
    json.dump(out, sys.stdout)
    sys.stdout.write("\n")


if __name__ == "__main__":
    main()
