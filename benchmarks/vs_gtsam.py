"""steam_ref's BTGP against GTSAM 4.3's ISAM2 (C++) on the same stream: the rows of the performance targets, in one run.

Each row is a data set, a prior, a schedule (/1, /10), a GTSAM set-up and optionally a lag. The same front end feeds
the same readings to our solver and to GTSAM's, each run in a fresh Python process with the environment as the user
has it (no BLAS or OpenMP thread variable set: steam_ref limits its solvers to one BLAS thread by itself,
:mod:`steam_ref.linear.threads`; GTSAM runs with its own defaults). Every distinct run of every row runs once per
``--repeat``, all of them alternating (so that a change of load hits every row alike); medians are reported.

- ``steam``: steam_ref's BTGP (the preset's iSAM2 settings), or with a lag its fixed-lag smoother (``--lag``);
- (a) ``custom``: GTSAM's ISAM2 (its defaults) with our factors as ``gtsam.CustomFactor``s calling our
  errors and Jacobians from Python (the same model; ``gtsam_callback_s`` is the time inside those calls);
- (b) ``native``: GTSAM's ISAM2 with built-in C++ factors only (``WnoaMotionFactorPose2``,
  ``PriorFactorVector`` on the body velocity, ``RangeFactor2D`` with Tukey, ``PriorFactorPoint2``): the
  SE(2) motion prior, not the paper's, so a yardstick of the machinery rather than the same model; on a row
  ``plaza-se2`` ours runs the SE(2) prior (``--prior se2``, local-variable residual) and (b) is then the same model;
  with a lag, GTSAM 4.3's ``IncrementalFixedLagSmoother`` (``gtsam_replica.NativeFixedLag``), a state stamped with its
  time and a landmark with the newest time of each update naming it (``--landmarks last-seen``, ours's rule) or
  never (``unstamped``).

The default rows (``ROWS``): Plaza BTGP/1 and /10 against (b), paper-synthetic /1 against (a), the SE(2) prior on
the whole Plaza /1 against (b), and Plaza /10 with a 60 s lag against GTSAM's fixed-lag smoother. A run that fails
(GTSAM's smoother can) makes its row a ``failed`` line naming the exception.

Every solver is asked for the newest state only after each update (the front end predicts from it);
the RMSE is taken once at the end over every state (a fixed-lag run: the forgotten ones as they left the window).
One JSON line per row: ``steam_*`` and ``gtsam_*`` wall and CPU seconds of the stream (front end included,
imports not), RMSE, peak memory (ru_maxrss of the child), ``ratio_wall`` / ``ratio_cpu`` = GTSAM's / ours (above 1:
ours is faster; ``ratio_cpu_pairs`` each alternating pair's), and ours's median update time over the first and the
last 1,000 updates (is the per-update cost flat?). Ours also gives ``steam_backsub_s``, the seconds its updates spent
in partial back-substitution (``UpdateReport.timings``), with its clique solves, and ``ratio_wall_if_backsub_free``:
GTSAM's wall time over ours less that share, the ratio even a free back-substitution could not beat
(docs/experiments.md, "What the targets would need"). An SE(2) row whose vector-space run (same data set, schedule
and lag) ran too gives ``ratio_cpu_over_vector``, ours on SE(2) over ours in vector space, with its pairs. The
machine may be shared: the ratios, measured in the same sitting, are the figures to read; CPU seconds are less
disturbed by other load than wall seconds.

    python benchmarks/vs_gtsam.py [--repeat 3] [--rows DATASET[-se2]/EVERY/SETUP[/lag=S],...] [--landmarks last-seen]
                                  [--max-poses N] [--quick]
    python benchmarks/vs_gtsam.py --datasets paper-synthetic,plaza --every 1,10 --setups custom,native   # every combination
"""

from __future__ import annotations

import argparse
import json
import re
import statistics
import subprocess
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
QUICK_POSES = 300  # --quick: this prefix of every run
# the paper's three rows (Plaza /1 and /10 against GTSAM's C++, paper-synthetic /1 against the CustomFactor replica),
# the SE(2) prior on the whole Plaza run against GTSAM's WnoaMotionFactorPose2 (and against our vector-space /1), and a
# fixed-lag /10 row against GTSAM 4.3's IncrementalFixedLagSmoother
ROWS = "plaza/1/native,plaza/10/native,paper-synthetic/1/custom,plaza-se2/1/native,plaza/10/native/lag=60"
KEYS = ("wall_s", "cpu_s", "rmse_m", "peak_rss_mb", "callback_s", "update_first_median_s", "update_last_median_s")
OURS = ("backsub_s", "clique_solves")  # ours only: the back-substitution's share (``phases``)


def child(
    solver: str,
    dataset: str,
    every: int,
    max_poses: int | None,
    prior: str = "wnoa",
    lag: float | None = None,
    landmarks: str = "last-seen",
) -> dict:
    """One stream in this process (called in a fresh one): its figures. ``prior`` 'se2' runs ours on SE(2) states
    and GTSAM's native set-up on the same SE(2) factors; a ``lag`` runs ours as a fixed-lag smoother and GTSAM's
    native set-up through its ``IncrementalFixedLagSmoother``, landmarks stamped as ``landmarks`` says."""
    import numpy as np

    from steam_ref.datasets import load_dataset
    from steam_ref.paper.online import StreamingEstimator
    from steam_ref.paper.options import StreamOptions
    from steam_ref.paper.presets import PaperSetup
    from steam_ref.paper.readings import Readings
    from steam_ref.paper.results import peak_rss_mb, position_rmse
    from steam_ref.variables import X

    setup = PaperSetup.plaza() if dataset == "plaza" else PaperSetup.synthetic()
    se2 = prior == "se2"
    if se2:
        setup = setup.replace(prior="se2", se2_residual="local-variable")
    data = load_dataset(dataset)
    readings = Readings.from_dataset(data, setup)
    instance = None
    if solver != "steam":
        sys.path.insert(0, str(HERE))
        import gtsam_replica

        qc = np.diag(setup.qc)
        if solver == "custom":
            instance = gtsam_replica.CustomISAM2()
        elif lag is not None:
            instance = gtsam_replica.NativeFixedLag(qc, lag, readings.times, landmarks=landmarks, se2=se2)
        else:
            instance = gtsam_replica.NativeISAM2(qc, se2=se2)
    options = StreamOptions(method="btgp", max_poses=max_poses, lag=lag if solver == "steam" else None)
    est = StreamingEstimator(readings, setup.with_schedule(every=every), options, solver=instance)
    wall, cpu = time.perf_counter(), time.process_time()
    while not est.done:
        est.step()
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    states = est.states[: est.n_solved]
    if solver == "native":
        positions = instance.positions(states)
    else:
        final = est.solver.estimate()
        positions = np.array([final[X(i)][:2] for i in states])
    truth = np.asarray(data.ground_truth)[states, 1:3]
    updates = est.update_seconds
    return phases(est.solver if solver == "steam" else None) | {
        "wall_s": wall,
        "cpu_s": cpu,
        "rmse_m": position_rmse(positions, truth),
        "peak_rss_mb": peak_rss_mb(),
        "callback_s": gtsam_replica.CALLBACK_SECONDS[0] if solver == "custom" else None,
        "n_updates": len(updates),
        "n_poses": est.n_poses,
        "n_marginalized": est.solver.n_marginalized if solver == "steam" else (len(instance.lagged) if lag else None),
        "update_first_median_s": statistics.median(updates[:1000]) if updates else None,
        "update_last_median_s": statistics.median(updates[-1000:]) if updates else None,
    }


def phases(solver: object | None) -> dict:
    """Our run's seconds per phase of the iSAM2 update, summed over its updates (the stream's ``phase_seconds``), and
    its clique solves: what a faster back-substitution could save at most (empty for a GTSAM run)."""
    if solver is None:
        return {"phase_s": None, "backsub_s": None, "clique_solves": None}
    totals = dict(solver.phase_seconds)  # type: ignore[attr-defined]
    solves = solver.clique_solves  # type: ignore[attr-defined]
    return {"phase_s": totals, "backsub_s": totals.get("backsubstitute", 0.0), "clique_solves": solves}


def run_child(
    solver: str,
    dataset: str,
    every: int,
    max_poses: int | None,
    prior: str = "wnoa",
    lag: float | None = None,
    landmarks: str = "last-seen",
) -> dict:
    args = [sys.executable, __file__, "--child", solver, "--datasets", dataset, "--every", str(every)]
    args += [] if max_poses is None else ["--max-poses", str(max_poses)]
    args += ["--prior", prior, "--landmarks", landmarks] + ([] if lag is None else ["--lag", str(lag)])
    start = time.perf_counter()
    proc = subprocess.run(args, capture_output=True, text=True)
    if proc.returncode != 0:  # the exception's first line and what follows it (GTSAM's messages span lines)
        lines = [line.strip() for line in proc.stderr.splitlines() if line.strip()]
        at = max(
            (i for i, line in enumerate(lines) if re.match(r"^[\w.]+(Error|Exception)\b", line)), default=len(lines) - 1
        )
        return {"failed": " ".join(lines[at : at + 3]) if lines else f"exit {proc.returncode}"}
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    print(
        f"  {solver} {dataset}/{every} prior={prior} lag={lag}: {out['cpu_s']:.1f} s CPU, "
        f"{time.perf_counter() - start:.0f} s in all",
        file=sys.stderr,
        flush=True,
    )
    return out


def _median(rows: list[dict], key: str):
    values = [r[key] for r in rows if r.get(key) is not None]
    return statistics.median(values) if values else None


def parse_rows(text: str) -> list[tuple[str, str, int, str, float | None]]:
    """Rows 'DATASET[-se2]/EVERY/SETUP[/lag=SECONDS]' as (dataset, prior, every, setup, lag)."""
    rows = []
    for item in text.split(","):
        parts = item.strip().split("/")
        name, every, setup = parts[0], int(parts[1]), parts[2]
        lag = float(parts[3].removeprefix("lag=")) if len(parts) > 3 else None
        dataset, prior = (name.removesuffix("-se2"), "se2") if name.endswith("-se2") else (name, "wnoa")
        if setup not in ("custom", "native") or (lag is not None and setup != "native"):
            raise SystemExit(f"a row's set-up is custom or native (a lag: native only), got {item!r}")
        rows.append((dataset, prior, every, setup, lag))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument(
        "--rows", default=ROWS, help=f"comma-separated DATASET[-se2]/EVERY/SETUP[/lag=S] (default {ROWS})"
    )
    parser.add_argument("--datasets", default=None, help="with --every and --setups: every combination as rows")
    parser.add_argument("--every", default="1,10")
    parser.add_argument("--setups", default="custom,native", help="GTSAM set-ups: custom (a), native (b)")
    parser.add_argument(
        "--landmarks", default="last-seen", help="a lag row: how GTSAM stamps a landmark (last-seen, unstamped)"
    )
    parser.add_argument("--max-poses", type=int, default=None)
    parser.add_argument("--quick", action="store_true", help=f"the first {QUICK_POSES} poses, one repeat")
    parser.add_argument("--child", default=None, help=argparse.SUPPRESS)
    parser.add_argument("--prior", default="wnoa", help=argparse.SUPPRESS)
    parser.add_argument("--lag", type=float, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child is not None:
        out = child(args.child, args.datasets, int(args.every), args.max_poses, args.prior, args.lag, args.landmarks)
        print(json.dumps(out))
        return
    repeat, max_poses = (1, QUICK_POSES) if args.quick else (args.repeat, args.max_poses)
    if args.datasets is not None:
        combos = [
            f"{d}/{e}/{s}"
            for d in args.datasets.split(",")
            for e in args.every.split(",")
            for s in args.setups.split(",")
        ]
        rows = parse_rows(",".join(combos))
    else:
        rows = parse_rows(args.rows)
    # every distinct run once per repeat, all of them alternating, so that a change of load hits every row alike
    runs: dict[tuple, list[dict]] = {}
    for dataset, prior, every, setup, lag in rows:
        runs.setdefault(("steam", dataset, prior, every, lag), [])
        runs.setdefault((setup, dataset, prior, every, lag), [])
    for _ in range(repeat):
        for key, done in runs.items():
            done.append(run_child(key[0], key[1], key[3], max_poses, key[2], key[4], args.landmarks))
    for dataset, prior, every, setup, lag in rows:
        print(
            json.dumps(row_of(runs, dataset, prior, every, setup, lag, repeat, max_poses, args.landmarks)), flush=True
        )


def row_of(
    runs: dict,
    dataset: str,
    prior: str,
    every: int,
    setup: str,
    lag: float | None,
    repeat: int,
    max_poses,
    landmarks: str,
) -> dict:
    """One printed row: medians of ours and of GTSAM's runs, their ratios (GTSAM's / ours: above 1, ours is faster),
    and for an SE(2) row, ours' time over ours' vector-space run of the same schedule when that ran too."""
    mine, theirs_runs = runs[("steam", dataset, prior, every, lag)], runs[(setup, dataset, prior, every, lag)]
    row = {
        "dataset": dataset,
        "prior": prior,
        "every": every,
        "setup": setup,
        "lag_s": lag,
        "repeat": repeat,
        "max_poses": max_poses,
    }
    if lag is not None:
        row["gtsam_landmarks"] = landmarks
    failed = [r["failed"] for r in mine + theirs_runs if "failed" in r]
    ok_mine, ok_theirs = [r for r in mine if "failed" not in r], [r for r in theirs_runs if "failed" not in r]
    if failed:
        row["failed"] = failed[0]
    if not ok_mine or not ok_theirs:
        return row
    ours = {k: _median(ok_mine, k) for k in KEYS + OURS}
    theirs = {k: _median(ok_theirs, k) for k in KEYS}
    row |= {"n_poses": ok_mine[0]["n_poses"], "n_updates": ok_mine[0]["n_updates"]}
    row |= {f"steam_{k}": ours[k] for k in KEYS if k != "callback_s"}
    row |= {f"gtsam_{k}": theirs[k] for k in KEYS}
    row["ratio_wall"] = theirs["wall_s"] / ours["wall_s"]
    row["ratio_cpu"] = theirs["cpu_s"] / ours["cpu_s"]
    row["ratio_cpu_pairs"] = [
        t["cpu_s"] / m["cpu_s"]
        for m, t in zip(mine, theirs_runs, strict=True)
        if "failed" not in m and "failed" not in t
    ]
    if lag is not None:
        row["steam_n_marginalized"], row["gtsam_n_marginalized"] = (
            ok_mine[0]["n_marginalized"],
            ok_theirs[0]["n_marginalized"],
        )
    row |= {"steam_backsub_s": ours["backsub_s"], "steam_clique_solves": ours["clique_solves"]}
    row["steam_phase_s"] = {k: statistics.median(r["phase_s"][k] for r in ok_mine) for k in ok_mine[0]["phase_s"]}
    without = statistics.median(r["wall_s"] - r["backsub_s"] for r in ok_mine)
    row["steam_wall_without_backsub_s"] = without  # the stream with back-substitution free
    row["ratio_wall_if_backsub_free"] = theirs["wall_s"] / without  # the most a faster one could reach
    vector = runs.get(("steam", dataset, "wnoa", every, lag))
    if prior != "wnoa" and vector:
        pairs = [
            a["cpu_s"] / b["cpu_s"]
            for a, b in zip(mine, vector, strict=True)
            if "failed" not in a and "failed" not in b
        ]
        row["steam_vector_cpu_s"] = _median(vector, "cpu_s")
        row["ratio_cpu_over_vector"] = ours["cpu_s"] / row["steam_vector_cpu_s"]  # ours on SE(2) / ours in vector space
        row["ratio_cpu_over_vector_pairs"] = pairs
    return row


if __name__ == "__main__":
    main()
