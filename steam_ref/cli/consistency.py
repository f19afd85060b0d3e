"""``steam-ref consistency``: ANEES of each estimator over Monte Carlo runs, with its 95 % band and verdict.

    steam-ref consistency [--dataset synthetic] [--seeds 200] [--seed 0] [--steps 40] [--landmarks 8]
                          [--jobs N] [--backend loky|dask] [--scheduler ADDRESS]
                          [--log FILE.jsonl | --resume FILE.jsonl] [--json] [--plot FILE.png]
                          [--prior wnoa|se2|se3|se3-wnoj [--se2-residual local-variable|simplified] [--turn RATE]]

The runs are :func:`steam_ref.paper.consistency.run_seed` on tasks drawn from the estimator's own model (with
``--prior se3`` or ``se3-wnoj``, 3-D tasks: :class:`~steam_ref.paper.rigid.RigidStudy`, batch and BTGP, pose and twist),
spread over ``--jobs`` workers (:func:`steam_ref.paper.sweep.run_sweep`); the figures do not depend on the
backend or the number of workers.
"""

from __future__ import annotations

import argparse
import functools
import math
import time

from ..errors import SteamError
from ..evaluate import INCONCLUSIVE
from ..paper import progress
from ..paper.consistency import STUDIES, Study, check_result, run_seed, summarize
from ..paper.sweep import run_sweep
from ..plot.figures import plot_anees
from .paths import check_output, check_outputs_apart, write_output
from .streams import json_line

__all__ = ["run"]


def _text(summary: dict, kinds: dict[str, int]) -> str:
    head = (
        f"ANEES over {summary['n_seeds']} runs ({summary['seconds']} s, {summary['jobs']} job(s), "
        f"{summary['backend']}); 95 % band of one pose's ANEES, χ²(N d)/N"
    )
    lines = [head]
    for name, row in summary["estimators"].items():
        parts = []
        for kind in kinds:
            k = row[kind]
            lost = f", {k['runs_far_outside']} run(s) far outside" if k["runs_far_outside"] else ""
            parts.append(f"{kind} {k['anees']:.3f} in [{k['band'][0]:.3f}, {k['band'][1]:.3f}]: {k['verdict']}{lost}")
        lines.append(f"  {name}: {_overall(row, summary['n_seeds'], kinds)}\n    " + "\n    ".join(parts))
    return "\n".join(lines)


def _overall(row: dict, n_seeds: int, kinds: dict[str, int]) -> str:
    """An estimator's verdict over every kind of state; inconclusive says how many runs a verdict needs."""
    if row["consistent"] is None:
        needed = max(row[k]["runs_needed"] for k in kinds if row[k]["verdict"] == INCONCLUSIVE)
        return (
            f"inconclusive: inside the band, but {n_seeds} runs are too few to have seen a tail of lost runs "
            f"(--seeds {needed} or more to call it consistent)"
        )
    return "consistent" if row["consistent"] else "not consistent"


def _study(args: argparse.Namespace) -> Study:
    """The study of ``--prior`` (:data:`~steam_ref.paper.consistency.STUDIES`: its set-up, estimators and study),
    with the options given (``--se2-residual``, ``--turn``), each refused by a model that does not take it."""
    model = STUDIES[args.prior]
    given = {name: getattr(args, name) for name in ("turn", "se2_residual") if getattr(args, name) is not None}
    for name in given:
        if name not in model.options:
            takers = " or ".join(f"--prior {p}" for p, m in STUDIES.items() if name in m.options)
            raise SteamError(f"--{name.replace('_', '-')} applies to {takers} only")
    turn = given.get("turn", 0.0)
    if not math.isfinite(turn) or abs(turn) >= math.pi:
        raise SteamError(f"--turn must be a yaw rate in (-π, π) rad a step, got {args.turn!r}")
    return model.study(
        n_steps=args.steps, n_landmarks=args.landmarks, seed=args.seed, setup=model.setup(**given),
        estimators=model.estimators,
    )  # fmt: skip


def run(args: argparse.Namespace) -> int:
    """Run the study, print its figures, draw them."""
    for path, suffix, option in ((args.plot, ".png", "--plot"), (args.log, ".jsonl", "--log")):
        check_output(path, suffix, option)
    check_output(args.resume, ".jsonl", "--resume")
    check_outputs_apart({"--plot": args.plot, "--log": args.log, "--resume": args.resume})
    study = _study(args)
    start = time.perf_counter()
    label = f"consistency on {args.dataset}: {len(study.estimators)} estimators, seeds"
    with progress.bar(args.seeds, label, progress.wanted(args.progress, args.json), unit="seed") as shown:
        results = run_sweep(
            functools.partial(run_seed, study),
            range(args.seeds),
            jobs=args.jobs,
            backend=args.backend,
            scheduler=args.scheduler,
            log=args.resume or args.log,
            study=study.describe(),
            resume=args.resume is not None,
            check=functools.partial(check_result, study),  # each line read back is validated, naming file and line
            on_result=lambda _item, _result: shown.update(1),
        )
    summary = summarize({int(k): v for k, v in results.items()}, study.estimators, kinds=study.kinds)
    summary |= {"seconds": round(time.perf_counter() - start, 2), "jobs": args.jobs, "backend": args.backend}
    where = ""
    if args.plot:  # the kinds every state has (not a landmark): an ANEES at each state
        first = next(iter(summary["estimators"].values()))
        curves = [k for k in study.kinds if "per_state" in first[k]]
        per_pose = {name: {k: row[k]["per_state"] for k in curves} for name, row in summary["estimators"].items()}
        bands = {k: tuple(first[k]["band"]) for k in curves}
        title = f"ANEES on {args.dataset} tasks ({args.prior} prior), {summary['n_seeds']} runs: 95 % band shaded"
        where = write_output(
            args.plot,
            "--plot",
            lambda name: plot_anees(per_pose, bands, n_runs=summary["n_seeds"], title=title, path=name),
        )
    for row in summary["estimators"].values():  # the per-pose curves are for the plot
        for kind in study.kinds:
            row[kind].pop("per_state", None)
    print(json_line(summary) if args.json else _text(summary, study.kinds) + where)
    return 0
