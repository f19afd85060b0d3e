"""The profile of a streamed BTGP run per phase of the iSAM2 update, at an earlier commit and at this tree.

What a change to the solver bought, phase by phase: the same streams run at ``--ref`` (default aaef952) and at this
working tree, each run in a fresh process with ``PYTHONPATH`` set to one tree only (the reference is extracted with
``git archive`` by :func:`against_commit.extract`: this needs a clone with history); each child checks that
``steam_ref.__file__`` lies in the tree it was given, and the parent checks it again. Every row runs ``--repeat``
times (default 3) at each tree, the order alternating, rows interleaved (a change of load hits both trees alike).

A child runs what ``steam-ref run --dataset D --every E`` runs (cli/run.py: the data set's preset, its schedule at
``E``, :class:`~steam_ref.paper.online.StreamingEstimator` with BTGP) and reports, in seconds of ``--clock``:

- ``phase_s``: each phase of the iSAM2 update (``check``, ``add``, ``relinearize``, ``remove``, ``linearize``,
  ``order``, ``eliminate``, ``backsubstitute``: ``UpdateReport.timings``), summed over every update;
- ``update_rest_s``: the rest of the solver's updates (the bookkeeping between the phases, the stream's record);
- ``outside_updates_s``: the stream outside the solver's updates (the front end, the divergence check, predicting
  from the new estimate, the final queries and the RMSE);
- ``wall_s`` and ``cpu_s`` (``time.process_time``) of the whole stream, imports and loading not included;
- ``cliques_eliminated`` (new cliques, summed over updates), ``cliques_solved`` (back-substitution's clique
  solves), ``variables_reeliminated`` and ``factors_linearized``, when the reference's ``UpdateReport`` has them;
- ``rmse_m``: a moved estimate shows here.

One JSON line per row: for each figure the medians at the reference and here and their ratio (here over ref: below 1
is faster), ``ratio_cpu_pairs`` (each alternating pair's CPU ratio), the counts at both, and the RMSEs. With the
same code at both (``--ref`` a commit whose package equals this tree's), the ratios measure the noise of the sitting.

``--clock cpu`` (the default) makes the update's own phase timer read ``time.process_time`` instead of
``time.perf_counter`` (the child replaces ``time`` in ``steam_ref.bayes_tree.isam``; a tree whose module has no
``time`` to replace fails): on a shared machine the wall seconds of a phase are mostly other processes'
(docs/experiments.md, "Per phase against an earlier commit", has the noise check). ``--clock wall`` keeps the
package's own clock.

    python benchmarks/phases.py [--ref aaef952] [--repeat 3] [--rows plaza/1,plaza/10,paper-synthetic/1]
                                [--max-poses N] [--clock cpu|wall] [--quick]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
import types
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))  # the benchmarks folder is no package
from against_commit import HERE, extract

ROWS = "plaza/1,plaza/10,paper-synthetic/1"
QUICK_POSES = 300  # --quick: this prefix, one repeat
PHASES = ("check", "add", "relinearize", "remove", "linearize", "order", "eliminate", "backsubstitute")
TIMES = ("update_rest_s", "outside_updates_s", "wall_s", "cpu_s")
COUNTS = ("cliques_eliminated", "cliques_solved", "variables_reeliminated", "factors_linearized", "n_updates")


def child(dataset: str, every: int, max_poses: int | None, tree: Path, clock: str = "cpu") -> dict:
    """One stream in this process, as ``steam-ref run --dataset D --every E`` runs it; fails if ``steam_ref`` is not
    ``tree``'s. ``clock`` 'cpu' times the phases in CPU seconds, 'wall' in the package's own wall seconds."""
    import warnings

    import steam_ref

    where = Path(steam_ref.__file__).resolve()
    if not where.is_relative_to(tree.resolve()):
        raise SystemExit(f"steam_ref was imported from {where}, not from the tree {tree}: check PYTHONPATH")
    from steam_ref.datasets import load_dataset
    from steam_ref.datasets.registry import DATASETS
    from steam_ref.paper.online import StreamingEstimator
    from steam_ref.paper.options import StreamOptions
    from steam_ref.paper.presets import PaperSetup
    from steam_ref.paper.readings import Readings
    from steam_ref.paper.solvers import BayesTreeSolver

    seconds = time.process_time if clock == "cpu" else time.perf_counter
    if clock == "cpu":
        from steam_ref.bayes_tree import isam

        if getattr(isam, "time", None) is not time:
            raise SystemExit(f"{isam.__file__} reads no `time` module whose clock could be replaced: use --clock wall")
        isam.time = types.SimpleNamespace(perf_counter=time.process_time)

    class Counted(BayesTreeSolver):
        """BTGP as the stream makes it (``make_solver('btgp', isam2=...)``), adding up each update's counts."""

        def __init__(self, params) -> None:
            super().__init__(params)
            self.counts = dict.fromkeys(COUNTS[:-1], 0)
            self.update_s = 0.0  # in the solver's update, on ``seconds``

        def update(self, factors, values) -> None:
            start = seconds()
            super().update(factors, values)
            self.update_s += seconds() - start
            r = self.reports[-1]
            figures = {
                "cliques_eliminated": _length(getattr(r, "new_cliques", None)),
                "cliques_solved": getattr(r, "backsubstituted_cliques", None),
                "variables_reeliminated": _length(getattr(r, "reeliminated", None)),
                "factors_linearized": getattr(r, "linearized_factors", None),
            }
            for key, n in figures.items():  # None: the reference's report has no such figure
                self.counts[key] = None if n is None or self.counts[key] is None else self.counts[key] + n

    with warnings.catch_warnings():  # as the CLI's load_with_note: its summary says what it read
        warnings.simplefilter("ignore")
        data = load_dataset(dataset, seed=0)
    setup = PaperSetup.named(DATASETS[dataset].preset).with_schedule(every=every)
    options = StreamOptions(method="btgp", max_poses=max_poses, progress=False)
    solver = Counted(setup.isam2_params())
    est = StreamingEstimator(Readings.from_dataset(data, setup), setup, options, solver=solver, name=dataset)
    wall, cpu = time.perf_counter(), time.process_time()
    result = est.run(data.ground_truth)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    phase_s = dict(solver.phase_seconds)
    updates, total = solver.update_s, (cpu if clock == "cpu" else wall)
    return {
        "steam_ref": str(where.parent),
        "phase_s": phase_s,
        "update_rest_s": updates - sum(phase_s.values()),
        "outside_updates_s": total - updates,
        "wall_s": wall,
        "cpu_s": cpu,
        **solver.counts,
        "n_updates": len(est.update_seconds),
        "n_poses": est.n_poses,
        "rmse_m": result.rmse_m,
    }


def _length(items) -> int | None:
    return None if items is None else len(items)


def run_child(tree: Path, dataset: str, every: int, max_poses: int | None, cwd: Path, clock: str) -> dict:
    """One stream in a fresh process with only ``tree`` on ``PYTHONPATH``."""
    argv = [sys.executable, __file__, "--child", f"{dataset}/{every}", "--tree", str(tree), "--clock", clock]
    argv += [] if max_poses is None else ["--max-poses", str(max_poses)]
    env = os.environ | {"PYTHONPATH": str(tree)}
    proc = subprocess.run(argv, env=env, cwd=cwd, capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"the run of {dataset}/{every} at {tree} failed:\n{proc.stderr.strip()[-2000:]}")
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    if not Path(out["steam_ref"]).is_relative_to(tree.resolve()):
        raise SystemExit(f"the run at {tree} imported steam_ref from {out['steam_ref']}")
    return out


def compare(ref: list[dict], here: list[dict]) -> dict:
    """Medians at both trees and their ratio (here / ref) for every phase and time; the counts; the RMSEs."""

    def figure(values_ref: list[float], values_here: list[float]) -> dict:
        r, h = statistics.median(values_ref), statistics.median(values_here)
        return {"ref": round(r, 4), "here": round(h, 4), "ratio": round(h / r, 3) if r > 0 else None}

    names = [p for p in PHASES if any(p in x["phase_s"] for x in ref + here)]
    names += sorted({p for x in ref + here for p in x["phase_s"]} - set(PHASES))  # a phase added since
    phases = {
        p: figure([x["phase_s"].get(p, 0.0) for x in ref], [x["phase_s"].get(p, 0.0) for x in here]) for p in names
    }
    phases["sum"] = figure([sum(x["phase_s"].values()) for x in ref], [sum(x["phase_s"].values()) for x in here])
    times = {k: figure([x[k] for x in ref], [x[k] for x in here]) for k in TIMES}
    counts = {
        k: {"ref": sorted({x[k] for x in ref}, key=str), "here": sorted({x[k] for x in here}, key=str)} for k in COUNTS
    }
    rmse = {"ref": sorted({x["rmse_m"] for x in ref}), "here": sorted({x["rmse_m"] for x in here})}
    return {
        "phase_s": phases,
        **times,
        "ratio_cpu": times["cpu_s"]["ratio"],
        "ratio_wall": times["wall_s"]["ratio"],
        "ratio_cpu_pairs": [round(h["cpu_s"] / r["cpu_s"], 3) for r, h in zip(ref, here, strict=True)],
        **counts,
        "rmse_m": rmse,
        "same_rmse": rmse["ref"] == rmse["here"],
    }


def parse_rows(text: str) -> list[tuple[str, int]]:
    """Rows 'DATASET/EVERY,...' as (dataset, every)."""
    rows = []
    for item in text.split(","):
        name, _, every = item.strip().partition("/")
        if not name or not every.isdigit() or int(every) < 1:
            raise SystemExit(f"a row is DATASET/EVERY with EVERY a positive integer, got {item!r}")
        rows.append((name, int(every)))
    return rows


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--ref", default="aaef952", help="the earlier commit (default %(default)s)")
    p.add_argument("--repeat", type=int, default=3, help="runs of each row at each tree (default %(default)s)")
    p.add_argument("--rows", default=ROWS, help=f"comma-separated DATASET/EVERY (default {ROWS})")
    p.add_argument("--max-poses", type=int, default=None, help="process only the first N poses")
    p.add_argument("--quick", action="store_true", help=f"{QUICK_POSES}-pose prefixes, one repeat")
    p.add_argument("--clock", choices=("cpu", "wall"), default="cpu", help="the phases' clock (default %(default)s)")
    p.add_argument("--child", default=None, help=argparse.SUPPRESS)
    p.add_argument("--tree", default=None, help=argparse.SUPPRESS)
    a = p.parse_args(argv)
    if a.child is not None:
        ((dataset, every),) = parse_rows(a.child)
        print(json.dumps(child(dataset, every, a.max_poses, Path(a.tree), a.clock)))
        return
    if a.quick:
        a.max_poses, a.repeat = a.max_poses or QUICK_POSES, 1
    if a.repeat < 1:
        raise SystemExit(f"--repeat must be at least 1, got {a.repeat}")
    rows = parse_rows(a.rows)
    runs: dict[tuple[str, int], dict[str, list[dict]]] = {row: {"ref": [], "here": []} for row in rows}
    with tempfile.TemporaryDirectory() as tmp:
        trees = {"ref": extract(a.ref, Path(tmp) / "ref"), "here": HERE}
        for i in range(a.repeat):
            for j, (dataset, every) in enumerate(rows):
                for name in ("ref", "here") if (i + j) % 2 == 0 else ("here", "ref"):
                    out = run_child(trees[name], dataset, every, a.max_poses, Path(tmp), a.clock)
                    runs[(dataset, every)][name].append(out)
                    print(f"  {name} {dataset}/{every}: {out['cpu_s']:.2f} s CPU", file=sys.stderr, flush=True)
    for (dataset, every), by in runs.items():
        head = {
            "row": f"{dataset}/{every}",
            "ref": a.ref,
            "repeat": a.repeat,
            "max_poses": a.max_poses,
            "clock": a.clock,
        }
        head["n_poses"] = by["here"][0]["n_poses"]
        print(json.dumps(head | compare(by["ref"], by["here"])), flush=True)


if __name__ == "__main__":
    main()
