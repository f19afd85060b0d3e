"""How far apart the two SE(2) WNOA residuals' optima land: "local-variable" (Anderson & Barfoot; GTSAM 4.3's
``WnoaMotionFactorPose2``, STEAM's ``const_vel_se2``) against "simplified" (gpslam, Theseus).
[derivations §11]

The same problem (the paper's front end with ``PaperSetup(prior="se2")``: readings, noise, priors, Tukey)
is solved to its batch optimum with each residual by Gauss-Newton (AMD ordering, until no variable moves
by more than 1e-9), the simplified one started from the local-variable optimum; the pose-by-pose distance
between the two optima (position in metres, heading in radians), median and max, and each optimum's
position RMSE against the truth are one JSON line per task:

- ``plaza``: the Plaza run, every pose a state, started from a streamed estimate (``--start FILE.npz``,
  written by ``steam-ref run --dataset plaza --prior se2 --save-estimates FILE.npz``);
- ``turn``: a task drawn from the SE(2) model (``sample_from_model`` with the SE(2) prior, the consistency set-up of
  ``paper.consistency.consistency_se2_setup``) whose yaw rate starts at ``--turn`` rad a step (near and past
  1 rad), started at the truth; the vector-space prior's optimum of the same readings is scored too.

    python benchmarks/se2_residuals.py plaza --start plaza_se2.npz
    python benchmarks/se2_residuals.py turn --turn 0.9 1.2 1.6 [--steps 40] [--seed 0]
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from steam_ref.batch import gauss_newton
from steam_ref.datasets import load_dataset, sample_from_model
from steam_ref.lie import SE2_STATE
from steam_ref.paper.consistency import consistency_se2_setup, model_of
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.problem import build_problem
from steam_ref.paper.readings import Readings
from steam_ref.variables import L, Values, X


def optimum(problem, start: Values) -> Values:
    result = gauss_newton(
        problem.graph, start, ordering="amd", max_iterations=100, relative_tolerance=1e-14, step_tolerance=1e-9
    )
    return result.values


def with_kinds(problem, values: dict) -> Values:
    return Values(values, kinds={k: problem.initial.kind(k) for k in values})


def distances(a: Values, b: Values, states) -> dict:
    d = np.array([SE2_STATE.local(a[X(int(i))], b[X(int(i))])[:3] for i in states])
    trans, head = np.hypot(d[:, 0], d[:, 1]), np.abs(d[:, 2])
    return {
        "translation_m": {"median": float(np.median(trans)), "max": float(trans.max())},
        "heading_rad": {"median": float(np.median(head)), "max": float(head.max())},
    }


def rmse(values: Values, states, truth: np.ndarray) -> float:
    p = np.array([values[X(int(i))][:2] for i in states])
    return float(np.sqrt(np.mean(np.sum((p - truth[: len(states), :2]) ** 2, axis=1))))


def both(readings: Readings, setup: PaperSetup, start: dict, truth: np.ndarray) -> dict:
    problems = {m: build_problem(readings, setup.replace(prior="se2", se2_residual=m)) for m in ("local-variable", "simplified")}  # fmt: skip
    local = optimum(problems["local-variable"], with_kinds(problems["local-variable"], start))
    simple = optimum(problems["simplified"], with_kinds(problems["simplified"], dict(local.items())))
    states = problems["local-variable"].states
    return {
        "distance": distances(local, simple, states),
        "rmse_local_variable_m": rmse(local, states, truth),
        "rmse_simplified_m": rmse(simple, states, truth),
        "cost_local_variable": problems["local-variable"].graph.error(local),
        "cost_simplified": problems["simplified"].graph.error(simple),
    }


def plaza(path: str) -> dict:
    setup = PaperSetup.plaza().replace(prior="se2")
    data = load_dataset("plaza")
    readings = Readings.from_dataset(data, setup)
    run = np.load(path)
    rates = [run[k] for k in (("vx", "vy", "omega") if "vx" in run.files else ("xdot", "ydot", "thetadot"))]
    tr = np.column_stack([run["x"], run["y"], run["theta"], *rates])
    tr[:, 2] = -((-tr[:, 2] + np.pi) % (2 * np.pi) - np.pi)  # θ in (-π, π]
    start = {X(int(i)): tr[int(i)] for i in run["state_poses"]}
    start |= {L(int(j)): p for j, p in zip(run["landmark_ids"], run["landmarks"], strict=True)}
    truth = np.asarray(data.ground_truth)[:, 1:] if data.ground_truth.shape[1] > 3 else np.asarray(data.ground_truth)
    return {"task": "plaza", "n_states": len(start) - len(run["landmark_ids"])} | both(readings, setup, start, truth)


def turn(rate: float, steps: int, seed: int) -> dict:
    setup = consistency_se2_setup(rate)
    task = sample_from_model(steps, 8, seed, **model_of(setup))
    readings = Readings.from_dataset(task.data, setup)
    start = {X(i): x for i, x in enumerate(task.states)} | {L(j): p for j, p in task.landmarks.items()}
    out = {"task": "turn", "turn_rad_per_step": rate, "steps": steps, "seed": seed}
    out["per_step_rotation_rad"] = {"median": float(np.median(np.abs(task.states[:, 5]))), "max": float(np.abs(task.states[:, 5]).max())}  # fmt: skip
    out |= both(readings, setup, start, task.states)
    vector = build_problem(readings, setup.replace(prior="wnoa"))
    c, s = np.cos(task.states[:, 2]), np.sin(task.states[:, 2])
    world = np.column_stack([task.states[:, :3], c * task.states[:, 3] - s * task.states[:, 4],
                             s * task.states[:, 3] + c * task.states[:, 4], task.states[:, 5]])  # fmt: skip
    vstart = Values({X(i): x for i, x in enumerate(world)} | {L(j): p for j, p in task.landmarks.items()})
    out["rmse_vector_space_m"] = rmse(optimum(vector, vstart), vector.states, task.states)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("task", choices=("plaza", "turn"))
    parser.add_argument("--start", help="plaza: a streamed SE(2) run's --save-estimates file")
    parser.add_argument("--turn", type=float, nargs="+", default=[0.9, 1.2, 1.6])
    parser.add_argument("--steps", type=int, default=40)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    if args.task == "plaza":
        if not args.start:
            parser.error("plaza needs --start FILE.npz")
        print(json.dumps(plaza(args.start)), flush=True)
    else:
        for rate in args.turn:
            print(json.dumps(turn(rate, args.steps, args.seed)), flush=True)


if __name__ == "__main__":
    main()
