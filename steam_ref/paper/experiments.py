"""The experiments of Fig. 3 (synthetic) and Fig. 4 (Plaza), and a results table.  [YIB Sec. IV]

- left panels (:func:`timing_experiment`): cumulative computation time against time step for
  PB/1, PB/10, PBVR/1, PBVR/10, BTGP/1 and BTGP/10 (all states estimated, as in the paper);
  the periodic batch methods may run under a time budget, i.e. on a prefix, and are reported so;
- right panels (:func:`interpolation_experiment`): position RMSE and total time of BTGP/1 against
  the time-step difference between estimated states (1, 2, 3, 5, 10, 20), with interpolation
  (Eq. 29) and without (readings between states dropped);
- accuracy (:func:`published_run_experiment`): BTGP/1 as the authors made their saved runs (every
  pose a state), beside those runs pose by pose (:mod:`steam_ref.paper.fidelity`);
- :func:`results_table`: Markdown, the paper's claims beside our figures;
- :func:`reproduce`: all of it, written to a folder (the ``steam-ref reproduce`` command).

The figures are drawn by :mod:`steam_ref.plot.figures`, which imports matplotlib inside its functions only.
"""

from __future__ import annotations

import functools
import json
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..datasets import LandmarkDataset, RangeDataset, load_range_dataset
from ..errors import DataError
from ..files import replace_file
from ..linear.threads import limited
from ..plot.figures import plot_timing_and_tradeoff, plot_trajectory
from .fidelity import AUTHORS_RUNS, Fidelity, compare, load_authors_run
from .online import RunResult, run_online
from .options import StreamOptions
from .presets import PaperSetup
from .sweep import run_sweep

__all__ = [
    "SKIPS",
    "TIMING_RUNS",
    "Experiment",
    "timing_experiment",
    "interpolation_experiment",
    "INTERPOLATION_DEPARTURES",
    "published_run_experiment",
    "speedup_on_prefix",
    "results_table",
    "reproduce",
    "REPRODUCED_FILES",
]

SKIPS = (1, 2, 3, 5, 10, 20)  # time-step differences between estimated states (Fig. 3/4, right)
TIMING_RUNS = (("pb", 1), ("pb", 10), ("pbvr", 1), ("pbvr", 10), ("btgp", 1), ("btgp", 10))
REPRODUCED_FILES = ("runs.jsonl", "fig3.png", "fig3_trajectory.png", "fig4.png", "fig4_trajectory.png", "results.md")


@dataclass
class Experiment:
    """The runs of one data set."""

    name: str  # label of the data set
    data: RangeDataset | LandmarkDataset = field(repr=False)  # a set without ground truth has no RMSE ('–')
    setup: PaperSetup = field(repr=False)
    timing: dict[str, RunResult] = field(default_factory=dict)  # 'PB/1' → run
    with_interp: dict[int, RunResult] = field(default_factory=dict)  # skip → BTGP/1 with interpolation
    without_interp: dict[int, RunResult] = field(default_factory=dict)  # skip → BTGP/1 without
    published: RunResult | None = None  # BTGP/1 as the authors' saved run: every pose a state, final marginals
    fidelity: Fidelity | None = None  # the published run against the authors' saved one (when found)
    note: str = ""  # why there is no fidelity comparison, if there is none


def timing_experiment(
    exp: Experiment, *, batch_budget_s: float | None = 120.0, max_poses: int | None = None, progress: bool = False
) -> None:
    """Fig. 3/4 left: every (method, schedule) of :data:`TIMING_RUNS`; PB and PBVR under a budget."""
    for method, every in TIMING_RUNS:
        budget = batch_budget_s if method != "btgp" else None
        opts = StreamOptions(method=method, max_poses=max_poses, time_budget_s=budget, progress=progress)
        exp.timing[f"{method.upper()}/{every}"] = run_online(exp.data, exp.setup.with_schedule(every=every), opts)


# The interpolation sweep starts a state's heading rate from the plain heading change, not from the
# scripts' Pose2 difference (the departure 'plain-heading-rate'): a state made just after the heading
# crosses ±π then starts 2π off in θ̇, which interpolated factors feel through Λ and Ψ (a state's own
# factors are linear in θ̇), and BTGP/1 on Plaza goes astray at skip 20 (RMSE 8.8 m against 0.91 m;
# docs/experiments.md). The scripts' Plaza layout never interpolates a range, so they never met this.
INTERPOLATION_DEPARTURES = ("plain-heading-rate",)


def interpolation_experiment(
    exp: Experiment, *, skips: tuple[int, ...] = SKIPS, max_poses: int | None = None, progress: bool = False
) -> None:
    """Fig. 3/4 right: BTGP/1 at each skip, with and without interpolation (the set-up departing
    from the scripts by :data:`INTERPOLATION_DEPARTURES`)."""
    setup = exp.setup.departing(*INTERPOLATION_DEPARTURES)
    for skip in skips:
        for interpolate, store in ((True, exp.with_interp), (False, exp.without_interp)):
            opts = StreamOptions(skip=skip, interpolate=interpolate, max_poses=max_poses, progress=progress)
            store[skip] = run_online(exp.data, setup, opts)


def published_run_experiment(
    exp: Experiment, *, max_poses: int | None = None, progress: bool = False, data_dir: str | None = None
) -> RunResult:
    """BTGP/1 as the authors ran it for their saved runs (every pose a state, the set-up's defaults),
    with its final marginals, compared with the authors' saved run when one is found for ``exp.name``
    (:mod:`steam_ref.paper.fidelity`). A prefix run (``max_poses``) is not comparable and says so. Returns
    the run (also ``exp.published``)."""
    run = run_online(
        exp.data, exp.setup, StreamOptions(max_poses=max_poses, progress=progress), covariances=max_poses is None
    )
    exp.published = run
    if not run.completed:
        exp.note = f"first {run.n_steps_processed} steps only, not comparable with the authors' run"
    elif exp.name not in AUTHORS_RUNS or not isinstance(exp.data, RangeDataset):
        exp.note = f"no saved authors' run for {exp.name!r}"
    else:
        try:
            exp.fidelity = compare(run, load_authors_run(exp.name, exp.data, data_dir), exp.data.ground_truth)[0]
        except DataError as err:
            exp.note = str(err)
    return run


def _one_run(data, setup: PaperSetup, options: StreamOptions, item) -> RunResult:
    """One run of the interpolation sweep (``item`` its (skip, interpolate)): a picklable task."""
    skip, interpolate = item
    return run_online(data, setup, options.replace(skip=skip, interpolate=interpolate))


def _fresh_process(function, *args):
    """``function(*args)`` in a new process, alone: its time and peak memory are its own."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn")) as pool:
        return pool.submit(function, *args).result()


def parallel_experiments(exp: Experiment, jobs: int, *, batch_budget_s: float | None, max_poses: int | None) -> None:
    """:func:`timing_experiment` and :func:`interpolation_experiment` with ``jobs`` workers: the interpolation
    sweep in parallel, every timing run serial, each in a fresh process."""
    for method, every in TIMING_RUNS:
        budget = batch_budget_s if method != "btgp" else None
        opts = StreamOptions(method=method, max_poses=max_poses, time_budget_s=budget)
        setup = exp.setup.with_schedule(every=every)
        exp.timing[f"{method.upper()}/{every}"] = _fresh_process(run_online, exp.data, setup, opts)
    setup = exp.setup.departing(*INTERPOLATION_DEPARTURES)
    items = [[skip, interpolate] for skip in SKIPS for interpolate in (True, False)]
    runs = run_sweep(functools.partial(_one_run, exp.data, setup, StreamOptions(max_poses=max_poses)), items, jobs=jobs)
    for skip, interpolate in items:
        store = exp.with_interp if interpolate else exp.without_interp
        store[skip] = runs[json.dumps([skip, interpolate])]


def speedup_on_prefix(slow: RunResult, fast: RunResult) -> tuple[float, int]:
    """How many times faster ``fast`` covered the steps ``slow`` covered: (ratio, steps)."""
    n = min(len(slow.step_seconds), len(fast.step_seconds))
    t_slow, t_fast = float(np.sum(slow.step_seconds[:n])), float(np.sum(fast.step_seconds[:n]))
    return (t_slow / t_fast if t_fast > 0 else float("inf")), n


def _fmt(x: float | None, unit: str = "", digits: int = 3) -> str:
    return "–" if x is None or not np.isfinite(x) else f"{x:.{digits}f}{unit}"


def _timing_rows(exp: Experiment) -> list[str]:
    rows = []
    for label, r in exp.timing.items():
        prefix = r.options.max_poses is not None and r.n_steps_processed >= r.options.max_poses
        cut = (
            ""
            if r.completed
            else f" ({'prefix' if prefix else 'time budget'}: {r.n_steps_processed} of {r.n_poses_total} steps)"
        )
        rows.append(
            f"| {exp.name} | {label} | {r.n_steps_processed} | {_fmt(r.total_s, ' s', 2)}{cut} "
            f"| {_fmt(r.rmse_m, ' m')} |"
        )
    return rows


def _published_row(exp: Experiment, r: RunResult) -> str:
    """BTGP/1 as the authors ran it (``r``), beside their saved run: RMSE and the distance pose by pose."""
    f = exp.fidelity
    if f is None:
        return f"| {exp.name} | BTGP/1, every pose a state: position RMSE | – | {r.rmse_m:.5f} m ({exp.note}) |"
    cov = "" if f.pose_cov_median is None else f"; pose marginals {f.pose_cov_median:.3%} apart (median)"
    return (
        f"| {exp.name} | BTGP/1, every pose a state: position RMSE (authors' saved run) | {f.authors_rmse_m:.5f} m | "
        f"{f.rmse_m:.5f} m; within {1000 * f.pose_max_m:.1f} mm of the authors' estimate at every pose "
        f"(RMS {1000 * f.pose_rms_m:.2f} mm), landmarks within {1000 * f.landmark_max_m:.2f} mm{cov} |"
    )


def _claims(exp: Experiment, paper: dict[str, str]) -> list[str]:
    """Our figures beside the paper's claims for one data set."""
    out = []
    if exp.published is not None:
        out.append(_published_row(exp, exp.published))
    bt = exp.timing.get("BTGP/1")
    for slow in ("PB/1", "PBVR/1"):
        if bt is not None and slow in exp.timing:
            ratio, n = speedup_on_prefix(exp.timing[slow], bt)
            out.append(f"| {exp.name} | BTGP/1 vs {slow} | far faster | {ratio:.0f}× faster over the first {n} steps |")
    if "PB/1" in exp.timing and "PBVR/1" in exp.timing:
        ratio, n = speedup_on_prefix(exp.timing["PB/1"], exp.timing["PBVR/1"])
        out.append(
            f"| {exp.name} | PBVR/1 vs PB/1 (reordering) | {paper['reorder']} "
            f"| PBVR {ratio:.2f}× PB's speed over the first {n} steps |"
        )
    base = exp.with_interp.get(1)
    for skip, r in sorted(exp.with_interp.items()):
        if base is None or skip == 1:
            continue
        frac = 1 - r.n_states / max(len(r.times), 1)
        saved = 1 - r.total_s / base.total_s
        drmse = (r.rmse_m - base.rmse_m) * 100
        out.append(
            f"| {exp.name} | interpolation, skip {skip} ({frac:.0%} of states interpolated) | {paper['interp']} | "
            f"time saved {saved:.0%}, RMSE {r.rmse_m:.3f} m ({drmse:+.1f} cm) |"
        )
    return out


PAPER_CLAIMS = {
    "synthetic": {
        "reorder": "reordering helps (298 landmarks)",
        "interp": "~90% interpolated: ~33% time saved, accuracy kept",
    },
    "plaza": {
        "reorder": "no gain from reordering (4 landmarks)",
        "interp": "~80% interpolated: ~68% time saved, RMSE +~8 cm",
    },
}


def results_table(experiments: list[Experiment], notes: Sequence[str] = ()) -> str:
    """Markdown: timing runs, interpolation sweeps, and the paper's claims beside ours."""
    lines = [
        "# Fig. 3 / Fig. 4 reproduced",
        "",
        "## Cumulative time (left panels)",
        "",
        "| data | run | steps | total time | RMSE |",
        "|---|---|---|---|---|",
    ]
    for exp in experiments:
        lines += _timing_rows(exp)
    lines += [
        "",
        "## Interpolation trade-off (right panels), BTGP/1",
        "",
        "| data | skip | states | RMSE with | time with | RMSE without | time without |",
        "|---|---|---|---|---|---|---|",
    ]
    for exp in experiments:
        for skip in sorted(exp.with_interp):
            w, o = exp.with_interp[skip], exp.without_interp.get(skip)
            lines.append(
                f"| {exp.name} | {skip} | {w.n_states} | {_fmt(w.rmse_m, ' m')} | {_fmt(w.total_s, ' s', 2)} | "
                f"{_fmt(o.rmse_m if o else None, ' m')} | {_fmt(o.total_s if o else None, ' s', 2)} |"
            )
    lines += ["", "## The paper's claims beside ours", "", "| data | claim | paper | ours |", "|---|---|---|---|"]
    for exp in experiments:
        lines += _claims(exp, PAPER_CLAIMS["plaza" if exp.setup.name == "plaza" else "synthetic"])
    if notes:
        lines += ["", "## Notes", ""] + [f"- {n}" for n in notes]
    return "\n".join(lines) + "\n"


# --- Everything ---------------------------------------------------------------------------------

# The paper's figures each data set of reproduce draws, in order: (the timing and interpolation figure, the
# trajectory figure), synthetic first, then Plaza.  [YIB Sec. IV]
PAPER_FIGURES = (("Fig. 3", "Fig. 1"), ("Fig. 4", "Fig. 2"))


def _write(path: Path, write: Callable[[str], object], wrote: Callable[[Path, bool], object] | None) -> None:
    """``path`` written whole or not at all (:func:`~steam_ref.files.replace_file`); ``wrote(path, replaced)``
    told, ``replaced`` True when a file was there before."""
    replaced = os.path.exists(path)
    replace_file(path, write, "reproduce")
    if wrote is not None:
        wrote(path, replaced)


def _draw_timing(exp: Experiment, figure: str, coverage: str, path: str) -> None:
    """Fig. 3/4 of one data set (:func:`~steam_ref.plot.figures.plot_timing_and_tradeoff`)."""
    title = f"{figure} of the paper reproduced: {exp.name}{coverage}"
    plot_timing_and_tradeoff(exp.timing, exp.with_interp, exp.without_interp, name=exp.name, title=title, path=path)


def _draw_trajectory(exp: Experiment, figure: str, coverage: str, path: str) -> None:
    """Fig. 1/2 of one data set: BTGP/1's estimate (with interpolation, skip 1) over the poses it covered."""
    run, data = exp.with_interp[1], exp.data
    n = len(run.trajectory)
    rmse = "" if run.rmse_m is None or not np.isfinite(run.rmse_m) else f", position RMSE {run.rmse_m:.3f} m"
    plot_trajectory(
        None if data.ground_truth is None else data.ground_truth[:n, 1:3],
        run.trajectory[:, :2],
        landmarks_true=data.landmarks[:, 1:3] if len(data.landmarks) else None,
        landmarks_estimated=run.landmarks,
        dead_reckoning=data.dead_reckoning[:n, 1:3],
        estimate_label=f"{run.method.upper()} estimate",
        title=f"{figure} of the paper reproduced: {exp.name}{coverage}\n{run.method.upper()}/1{rmse}",
        path=path,
    )


def _datasets(data_dir: str | None) -> tuple[list[tuple[str, RangeDataset, PaperSetup]], list[str]]:
    """paper-synthetic (else the generated task) and Plaza (if found)."""
    notes, out = [], []
    try:
        out.append(("paper-synthetic", load_range_dataset("paper-synthetic", data_dir), PaperSetup.synthetic()))
    except DataError as exc:
        notes.append(f"paper-synthetic not found ({exc}); the generated task is used instead")
        out.append(("synthetic", load_range_dataset("synthetic"), PaperSetup.synthetic()))
    try:
        out.append(("plaza", load_range_dataset("plaza", data_dir), PaperSetup.plaza()))
    except DataError as exc:
        notes.append(f"Plaza skipped: {exc}")
    return out, notes


@limited
def reproduce(
    out: str | Path,
    *,
    quick: bool = False,
    data_dir: str | None = None,
    progress: bool = True,
    data_sets: list[tuple[str, RangeDataset | LandmarkDataset, PaperSetup]] | None = None,
    jobs: int = 1,
    wrote: Callable[[Path, bool], object] | None = None,
) -> str:
    """Run Fig. 3/4's experiments; write ``fig3.png``/``fig4.png`` (each titled by the paper's figure it
    reproduces), the trajectories ``fig3_trajectory.png``/``fig4_trajectory.png`` (as Fig. 1/2), ``runs.jsonl``
    and ``results.md`` to ``out``, each whole or not at all (a file there is replaced only by a complete one),
    telling ``wrote(path, replaced)`` after each; return the Markdown table. ``quick``: 1,000-pose prefixes
    and 20 s budgets.
    ``data_sets`` (name, data, set-up) replaces the paper's two data sets. ``jobs`` > 1: the accuracy
    runs (the interpolation sweep) run that many at a time (:func:`~steam_ref.paper.sweep.run_sweep`),
    and every timing run runs alone, one after another, each in a fresh process."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    sets: list[tuple[str, RangeDataset | LandmarkDataset, PaperSetup]]
    notes: list[str]
    if data_sets is not None:
        sets, notes = list(data_sets), []
    else:
        found, notes = _datasets(data_dir)
        sets = [(name, data, setup) for name, data, setup in found]
    prefix, budget = (1000, 20.0) if quick else (None, 300.0)
    notes.append(
        f"PB and PBVR run under a {budget:g} s budget per run; speed ratios are taken over the steps both covered"
    )
    notes.append(
        "the interpolation sweep starts each state's heading rate from the plain heading change "
        "(departure plain-heading-rate), not the scripts' Pose2 difference; see docs/experiments.md"
    )
    if quick:
        notes.append(f"quick mode: only the first {prefix} poses of each data set")
    if jobs > 1:
        notes.append(
            f"--jobs {jobs}: the interpolation sweep ran {jobs} runs at a time (its RMSE as serial; its times "
            "under that load); every timing run (PB, PBVR, BTGP) ran alone, one after another, each in a fresh "
            "process, so its times and peak memory are its own"
        )
    experiments, log = [], []
    # not strict: data_sets may hold a single set (then no fig4)
    for (name, data, setup), fig, (figure, path_figure) in zip(sets, ("fig3", "fig4"), PAPER_FIGURES, strict=False):
        exp = Experiment(name, data, setup)
        if jobs > 1:
            parallel_experiments(exp, jobs, batch_budget_s=budget, max_poses=prefix)
        else:
            timing_experiment(exp, batch_budget_s=budget, max_poses=prefix, progress=progress)
            interpolation_experiment(exp, max_poses=prefix, progress=progress)
        published = published_run_experiment(exp, max_poses=prefix, progress=progress, data_dir=data_dir)
        for r in [*exp.timing.values(), *exp.with_interp.values(), *exp.without_interp.values(), published]:
            log.append(json.dumps(r.summary(name)) + "\n")
        n_data = len(data.dead_reckoning)
        covered = len(exp.with_interp[1].trajectory)
        coverage = f" (first {covered} of {n_data} poses)" if covered < n_data else ""
        _write(out / f"{fig}.png", functools.partial(_draw_timing, exp, figure, coverage), wrote)
        _write(out / f"{fig}_trajectory.png", functools.partial(_draw_trajectory, exp, path_figure, coverage), wrote)
        experiments.append(exp)
    _write(out / "runs.jsonl", lambda name: Path(name).write_text("".join(log)), wrote)
    table = results_table(experiments, notes)
    _write(out / "results.md", lambda name: Path(name).write_text(table), wrote)
    return table
