"""``steam-ref run --dataset kitti``: a 3-D data set (``DataSet.rigid``) solved on the states of its prior's group.

Run by ``steam-ref run`` when ``--dataset`` names a set whose loader gives :class:`~steam_ref.datasets.rigid.RigidReadings`
(``kitti``): the readings solved with ``--prior`` (default 'se3'; any prior of the table on a group of rigid motions
in 3-D) at the set's Qc times ``--qc-scale``, in batch and by BTGP (one iSAM2 update per state), and with ``--lag`` also
by the fixed-lag smoother; each scored at the held-out position fixes by the GP's mean there [YIB Eq. 18], beside a
straight line between the fixes around each (``paper.rigid``). ``--max-poses N`` keeps the first N states. The planar
options (a schedule, a layout, figures of a planar run) do not apply and are refused by name.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from ..datasets.rigid import RigidReadings
from ..datasets.search import load_dataset
from ..errors import SteamError
from ..motion import MOTION_PRIORS, motion_prior
from ..paper.rigid import held_out_errors, solve_rigid, straight_line_errors
from .streams import json_line

__all__ = ["run_rigid"]

# run's options that a 3-D run does not read, with the value that means "not given"
_PLANAR: dict[str, object] = {
    "every": None, "skip": 1, "range_states": False, "converge_at_end": False, "departure": [], "preset": None,
    "score_against_optimum": False, "se2_residual": None, "steps": None, "save_estimates": None, "plot": None,
    "tree_dot": None, "lag_history": False, "time_budget": None, "relinearize_threshold": None,
    "relinearize_skip": None,
}  # fmt: skip


def _figures(errors: np.ndarray) -> dict:
    return {
        "rmse_m": float(np.sqrt(np.mean(errors**2))),
        "median_m": float(np.median(errors)),
        "max_m": float(np.max(errors)),
    }


def run_rigid(args: argparse.Namespace) -> int:
    """Solve the 3-D set ``args.dataset`` and print its held-out position errors (module docstring)."""
    given = [f"--{k.replace('_', '-')}" for k, none in _PLANAR.items() if getattr(args, k, none) != none]
    if given or getattr(args, "save_trajectory", None):
        raise SteamError(f"--dataset {args.dataset} is a 3-D set: {(given or ['--save-trajectory'])[0]} does not apply")
    loaded = load_dataset(args.dataset, data_dir=args.data_dir, seed=args.seed)
    if not isinstance(loaded, RigidReadings):
        raise SteamError(f"--dataset {args.dataset!r} gives no 3-D readings")
    data = loaded
    if args.max_poses is not None:
        data = data.head(args.max_poses)
    name = args.prior or "se3"
    takes = MOTION_PRIORS[name].options if name in MOTION_PRIORS else ()  # an unknown name: motion_prior says so
    options = {k: getattr(args, k) for k in takes if getattr(args, k, None) is not None}
    qc = args.qc_scale * (np.eye(6) if data.qc is None else data.qc)
    prior = motion_prior(name, qc, **options)
    straight = straight_line_errors(data)
    summary: dict = {
        "dataset": args.dataset,
        "prior": args.prior or "se3",
        "qc": np.diag(qc).tolist(),
        "states": len(data.state_times),
        "readings": {"position_fixes": len(data.positions), "gyro": len(data.gyro)},
        "held_out_fixes": len(straight),
        "lacks": data.lacks,
        "straight_line": _figures(straight),
    }
    methods = ["batch", "btgp"] + ([] if args.lag is None else ["fixed-lag"])
    for method in methods:
        start = time.perf_counter()
        run = solve_rigid(data, prior, method, lag=args.lag or 10.0)
        summary[method] = _figures(held_out_errors(data, prior, run.states)) | {
            "seconds": round(time.perf_counter() - start, 2),
            "dropped_readings": run.dropped,
        }
        if method == "batch":
            summary[method]["converged"] = bool(getattr(run.solver, "converged", False))
    if args.json:
        print(json_line(summary))
        return 0
    lines = [f"{args.dataset}: {summary['states']} states on {prior.kind!r}, prior {summary['prior']}"]
    lines += [f"held-out GPS fixes: {summary['held_out_fixes']} (the data set lacks {data.lacks})"]
    for what in ("straight_line", *methods):
        f = summary[what]
        lines.append(f"  {what:14s} RMSE {f['rmse_m']:.3f} m, median {f['median_m']:.3f} m, max {f['max_m']:.3f} m")
    print("\n".join(lines))
    return 0
