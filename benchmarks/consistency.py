"""The consistency study with 1 and with N worker processes, in one sitting: time, speed-up, same figures.

Runs ``steam-ref consistency``'s study (:mod:`steam_ref.paper.consistency`: every estimator on each of
``--seeds`` tasks drawn from the model) through :func:`steam_ref.paper.sweep.run_sweep` with ``--jobs 1``
and with ``--jobs N`` (loky), alternately, ``--repeat`` times, and prints one JSON line per sitting:

    seeds, jobs, serial_s, parallel_s, ratio (parallel / serial), target_ratio, meets_target, same_figures

then a last line with the median ratio and the study's ANEES per estimator and kind (the figures of
``steam-ref consistency --json``), and draws the ANEES pose by pose (``--plot``). The target for the
parallel sweep: 200 seeds with --jobs 2 in at most 0.6 x the time of --jobs 1. ``--prior`` runs another study of
the table (:data:`~steam_ref.paper.consistency.STUDIES`): ``--prior se3 --seeds 46`` is the SE(3) study at the runs
its verdict needs, its ANEES in the band (docs/experiments.md).

    python benchmarks/consistency.py [--prior wnoa] [--seeds 200] [--jobs 2] [--repeat 1] [--plot consistency.png]
"""

from __future__ import annotations

import argparse
import functools
import json
import statistics
import time

from steam_ref.paper.consistency import STUDIES, Study, run_seed, summarize
from steam_ref.paper.sweep import run_sweep
from steam_ref.plot.figures import plot_anees

TARGET_RATIO = 0.6


def _study(study: Study, seeds: int, jobs: int) -> tuple[float, dict]:
    start = time.perf_counter()
    results = run_sweep(functools.partial(run_seed, study), range(seeds), jobs=jobs)
    seconds = time.perf_counter() - start
    return seconds, summarize({int(k): v for k, v in results.items()}, study.estimators, kinds=study.kinds)


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--prior", choices=tuple(STUDIES), default="wnoa", help="the study of this model (STUDIES)")
    p.add_argument("--seeds", type=int, default=200)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--repeat", type=int, default=1, help="sittings of (1 job, N jobs); the median ratio is reported")
    p.add_argument("--plot", default="consistency.png")
    a = p.parse_args(argv)
    model = STUDIES[a.prior]
    study = model.study(setup=model.setup(), estimators=model.estimators)
    ratios = []
    summary: dict = {}
    for _ in range(a.repeat):
        serial_s, serial = _study(study, a.seeds, 1)
        parallel_s, summary = _study(study, a.seeds, a.jobs)
        ratios.append(parallel_s / serial_s)
        row = {
            "seeds": a.seeds,
            "jobs": a.jobs,
            "serial_s": round(serial_s, 2),
            "parallel_s": round(parallel_s, 2),
            "ratio": round(ratios[-1], 3),
            "target_ratio": TARGET_RATIO,
            "meets_target": ratios[-1] <= TARGET_RATIO,
            "same_figures": serial == summary,
        }
        print(json.dumps(row), flush=True)
    anees = {
        name: {kind: [round(row[kind]["anees"], 4), row[kind]["verdict"]] for kind in study.kinds}
        for name, row in summary["estimators"].items()
    }
    print(json.dumps({"median_ratio": round(statistics.median(ratios), 3), "anees": anees}))
    curves = [k for k in study.kinds if k != "landmark"]  # an ANEES at every state
    per_pose = {name: {k: row[k]["per_state"] for k in curves} for name, row in summary["estimators"].items()}
    bands = {k: tuple(next(iter(summary["estimators"].values()))[k]["band"]) for k in curves}
    plot_anees(per_pose, bands, n_runs=a.seeds, path=a.plot)


if __name__ == "__main__":
    main()
