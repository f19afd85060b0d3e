"""``steam-ref run --dataset kitti``: a 3-D data set (``DataSet.rigid``) solved on the states of its prior's group.

Run by ``steam-ref run`` when ``--dataset`` names a set whose loader gives :class:`~steam_ref.datasets.rigid.RigidReadings`
(``kitti``): the readings solved with ``--prior`` (default 'se3'; any prior of the table on a group of rigid motions
in 3-D) at the set's Qc times ``--qc-scale``, in batch and by BTGP (one iSAM2 update per state), and with ``--lag`` also
by the fixed-lag smoother (the planar stream's window: the variables it marginalized and the most it held at once are
reported); each scored at the held-out position fixes by the GP's mean there [YIB Eq. 18], beside a straight line
between the fixes around each (``paper.rigid``). ``--max-poses N`` keeps the first N states. The planar options (a
schedule, a layout, figures of a planar run, ``--progress``: it draws no bar) do not apply and are refused by name.

``--save-trajectory FILE`` (``--trajectory-format``) writes, as the planar run does, the estimate of the run's method:
BTGP's (``--method``'s one value on a 3-D set), or with ``--lag`` the fixed-lag smoother's (each state as it left the
window), at the states' times in the set's seconds, through the planar run's checks and writer
(:func:`~steam_ref.cli.paths.save_trajectory`: TUM or KITTI of poses in 3-D, ``group=SE3V``). ``steam-ref batch`` on a
3-D set solves it here too, by batch alone (from BTGP's estimate on a set without first values), and its
``--save-trajectory`` writes the batch's estimate the same way.

A generated set (``synthetic-3d``: ``--steps``, ``--seed``) has its true states: each method's states are also scored
against them (:func:`~steam_ref.evaluate.group_ape`: translation and rotation RMSE; batch and BTGP also by the pose
NEES of their marginal covariances, :func:`~steam_ref.paper.rigid.rigid_nees`), beside the first values (the prior's
prediction from the first state: dead reckoning) and a straight line between the position fixes at the states.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from ..datasets.rigid import RigidReadings, generate_rigid
from ..datasets.search import load_dataset
from ..errors import SteamError
from ..evaluate import group_ape
from ..lie.points import position
from ..lie.state import group_state
from ..motion import MOTION_PRIORS, MotionPrior, motion_prior
from ..paper.rigid import (
    RigidRun,
    held_out_errors,
    rigid_nees,
    solve_rigid,
    steps,
    straight_line_at,
    straight_line_errors,
)
from .args import check_prior_options, seed_of
from .explain import files_of
from .paths import check_outputs_apart, check_outputs_not_inputs, check_trajectory_output, save_trajectory
from .streams import json_line

__all__ = ["run_rigid"]

# run's and batch's options that a 3-D run does not read, with the value that means "not given" (it runs batch and BTGP, and
# fixed-lag with --lag, whatever --method says; its readings between states are always interpolated)
_PLANAR: dict[str, object] = {
    "every": None, "skip": 1, "range_states": False, "converge_at_end": False, "departure": [], "preset": None,
    "score_against_optimum": False, "se2_residual": None, "save_estimates": None, "plot": None, "qc": None,
    "tree_dot": None, "lag_history": False, "time_budget": None, "relinearize_threshold": None,
    "relinearize_skip": None, "method": "btgp", "interpolate": True, "amalgamation_zeros": None, "lag_batch": 0.0,
    "ordering": "amd",  # batch's: a 3-D batch runs Gauss-Newton on AMD's ordering, whatever --ordering says
}  # fmt: skip


def _figures(errors: np.ndarray) -> dict:
    if not errors.size:  # no held-out fix inside the states' and the kept fixes' span (a short run)
        return {"rmse_m": None, "median_m": None, "max_m": None}
    return {
        "rmse_m": float(np.sqrt(np.mean(errors**2))),
        "median_m": float(np.median(errors)),
        "max_m": float(np.max(errors)),
    }


def _against_truth(data: RigidReadings, prior: MotionPrior, states: np.ndarray) -> dict:
    """The translation and rotation RMSE of ``states``' poses against the set's true states."""
    g = group_state(prior.kind).group
    assert data.truth is not None
    error = group_ape(g, data.truth[:, : g.size], states[:, : g.size])
    return {"translation_rmse_m": error.translation_stats.rmse, "rotation_rmse_rad": error.heading_stats.rmse}


def _yardsticks(data: RigidReadings, prior: MotionPrior) -> dict:
    """A generated set's yardsticks at its states: the first values (the prior's predictions from the first state,
    dead reckoning) and the straight line between the position fixes (its translation only)."""
    assert data.truth is not None
    g = group_state(prior.kind).group
    first = np.array([step.value for step in steps(data, prior, data.initial_states)])
    out = {"dead_reckoning": _against_truth(data, prior, first)}
    if len(data.positions) >= 2:
        line = straight_line_at(data, data.state_times) - position(g, data.truth[:, : g.size])[0]
        out["straight_line"] = {"translation_rmse_m": float(np.sqrt(np.mean(np.sum(line**2, axis=1))))}
    return out


def _scored(data: RigidReadings, prior: MotionPrior, method: str, run: RigidRun) -> dict:
    """A method's figures against the truth: RMSE, and for batch and BTGP the mean pose NEES over the states."""
    out = _against_truth(data, prior, run.states)
    if method != "fixed-lag":  # the fixed-lag smoother keeps no marginal of a past state
        assert data.truth is not None
        out["pose_anees"] = float(np.mean(rigid_nees(run, data.truth, prior)["pose"]))
    return out


def run_rigid(args: argparse.Namespace, *, batch_only: bool = False) -> int:
    """Solve the 3-D set ``args.dataset`` and print its held-out position errors (module docstring): ``steam-ref run``'s
    methods, or with ``batch_only`` (``steam-ref batch``) the batch alone, whose estimate ``--save-trajectory`` then
    writes. An option of ``run`` the command lacks (batch has no ``--steps``, ``--lag``, ``--prior``...) is not given."""
    given = [  # an option on by default (--interpolate) was given as --no-...
        f"--{'no-' * (none is True)}{k.replace('_', '-')}"
        for k, none in _PLANAR.items()
        if getattr(args, k, none) != none
    ]
    if getattr(args, "progress", None):  # asked for a bar this run draws none of (--no-progress: what it does anyway)
        given.append("--progress")
    if given:
        raise SteamError(f"--dataset {args.dataset} is a 3-D set: {given[0]} does not apply")
    check_trajectory_output(args)  # the planar run's checks, before anything is solved
    outputs = {"--save-trajectory": args.save_trajectory}
    check_outputs_apart(outputs)  # not the file stdout or stderr goes to
    name = getattr(args, "prior", None) or "se3"
    taken = {"singer_time_constant": getattr(args, "singer_time_constant", None)}  # --se2-residual: planar, above
    if name in MOTION_PRIORS:  # an unknown name: motion_prior says so
        check_prior_options(name, taken)  # an option the prior does not take is refused, never ignored
    options = {k: v for k, v in taken.items() if v is not None}
    n_steps, lag = getattr(args, "steps", None), getattr(args, "lag", None)
    loaded = (
        load_dataset(args.dataset, data_dir=args.data_dir, seed=seed_of(args))
        if n_steps is None
        else generate_rigid(n_steps, seed=seed_of(args))
    )
    if not isinstance(loaded, RigidReadings):
        raise SteamError(f"--dataset {args.dataset!r} gives no 3-D readings")
    data = loaded
    check_outputs_not_inputs(outputs, files_of(data.source))  # kitti's GPS and IMU files
    if args.max_poses is not None:
        data = data.head(args.max_poses)
    qc = getattr(args, "qc_scale", 1.0) * (np.eye(6) if data.qc is None else data.qc)
    prior = motion_prior(name, qc, **options)
    straight = straight_line_errors(data)
    summary: dict = {
        "dataset": args.dataset,
        "prior": name,
        "qc": np.diag(qc).tolist(),
        "states": len(data.state_times),
        "readings": {  # every table a run reads (the held-out fixes: below)
            "position_fixes": len(data.positions),
            "gyro": len(data.gyro),
            "ranges": len(data.ranges),
            "landmark_points": len(data.points),
        },
        "held_out_fixes": len(straight),
        "lacks": data.lacks,
        "straight_line": _figures(straight),
    }
    truth = data.on(prior.kind) if data.truth is not None else None  # the true states as the prior's
    if truth is not None:
        summary["against_truth"] = _yardsticks(truth, prior)
    methods = ["batch"] if batch_only else ["batch", "btgp"] + ([] if lag is None else ["fixed-lag"])
    # batch descends from the set's first values; a set with none (a generated one: the prior's predictions from the
    # first state, far off after a few turns) from BTGP's estimate, as the 3-D consistency study does
    from_btgp = data.initial_states is None
    solved = ["btgp", *(m for m in methods if m != "btgp")] if from_btgp else methods
    runs: dict[str, RigidRun] = {}
    figures: dict[str, dict] = {}
    for method in solved:
        start = time.perf_counter()
        initial = runs["btgp"].states if method == "batch" and from_btgp else None
        run = runs[method] = solve_rigid(data, prior, method, initial=initial, lag=lag or 10.0)
        figures[method] = _figures(held_out_errors(data, prior, run.states)) | {
            "seconds": round(time.perf_counter() - start, 2),
            "dropped_readings": run.dropped,
        }
        if method == "fixed-lag":  # the window, as a planar run reports it
            window = {k: getattr(run.solver, k) for k in ("n_marginalized", "peak_window")}
            figures[method] |= {"lag_s": float(args.lag), **window}
        if method == "batch":
            figures[method]["converged"] = bool(getattr(run.solver, "converged", False))
            figures[method]["start"] = "btgp" if from_btgp else "first values"
    # the run's own file first, as the planar run writes it: the estimate of its method, BTGP (--method's one value
    # on a 3-D set), or with --lag the fixed-lag smoother's; the batch command's, the batch's
    g = group_state(prior.kind).group
    written = "batch" if batch_only else "btgp" if lag is None else "fixed-lag"
    where = save_trajectory(args, data.state_times, runs[written].states[:, : g.size], group=g)  # its line, or ""
    for method in methods:
        summary[method] = figures[method]
        if truth is not None:
            summary["against_truth"][method] = _scored(truth, prior, method, runs[method])
    if args.json:
        print(json_line(summary))
        return 0
    lines = [f"{args.dataset}: {summary['states']} states on {prior.kind!r}, prior {summary['prior']}"]
    lacks = f" (the data set lacks {data.lacks})" if data.lacks else ""
    lines += [f"held-out GPS fixes: {summary['held_out_fixes']}{lacks}"]
    for what in ("straight_line", *methods):
        f = summary[what]
        if f["rmse_m"] is None:
            lines.append(f"  {what:14s} no held-out fix inside the states' and the kept fixes' span")
            continue
        lines.append(f"  {what:14s} RMSE {f['rmse_m']:.3f} m, median {f['median_m']:.3f} m, max {f['max_m']:.3f} m")
    if "fixed-lag" in summary:
        f = summary["fixed-lag"]
        lines.append(
            f"  lag {f['lag_s']:g} s: {f['n_marginalized']} variables marginalized, at most {f['peak_window']} held"
        )
    if truth is not None:
        lines.append("against the true states: translation RMSE, rotation RMSE, mean pose NEES (6 if consistent)")
        for what, f in summary["against_truth"].items():
            rotation = f" {f['rotation_rmse_rad']:.4f} rad" if "rotation_rmse_rad" in f else ""
            nees = f", NEES {f['pose_anees']:.2f}" if "pose_anees" in f else ""
            lines.append(f"  {what:14s} {f['translation_rmse_m']:.3f} m{rotation}{nees}")
    print("\n".join(lines) + where)
    return 0
