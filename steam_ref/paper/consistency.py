"""Are the covariances honest? NEES of each estimated state over Monte Carlo runs on tasks drawn from the model.

One run (:func:`run_seed`): a task is drawn from the estimator's own model
(:func:`~steam_ref.datasets.sample_from_model`: the path from the GP prior with the set-up's Qc, every
reading with the set-up's noise, the landmarks' survey and pose 0 from their priors), each estimator
solves it, and each estimated state is scored by its NEES ε = eᵀ P⁻¹ e
(:func:`~steam_ref.evaluate.nees`): e the error against the truth, P the estimator's marginal covariance
of that state at the end of the run — for a smoother, the covariance of the final estimate of x(tₖ)
given all the data, not a filter's covariance at time k. At poses without a state (``skip`` > 1) both
come from the GP: x̄(t) and its covariance interpolated from the two states around t [YIB Eq. 18]
(:class:`~steam_ref.trajectory.Trajectory`).

Over N runs (:func:`summarize`), ANEES at each pose (or landmark) is the mean of its N values; the figure
reported per estimator and kind of state (pose [x, y, θ], velocity [ẋ, ẏ, θ̇], landmark [x, y]) is that
ANEES averaged over the poses (landmarks), and it is compared with the two-sided 95 % band of one
pose's ANEES, χ²⁻¹(0.025 / 0.975; N d) / N (:func:`~steam_ref.evaluate.chi2_band`). The band of one pose is
conservative for the average: the poses' ANEES are correlated χ² variables of mean d, and the variance
of their average is at most the largest of theirs.

For a landmark (which a run that drops readings may not see) the figure is the mean NEES of the runs that saw
one, averaged, against the same band with N those runs. A run whose mean NEES is beyond χ²⁻¹(0.999; d) is "far
outside" (an estimate lost in a wrong minimum rather than a covariance a little off); it stays in the ANEES.

**Too few runs.** An ANEES inside the band is called "consistent" only when the study has enough runs to
have seen a tail of lost runs large enough to push the expected ANEES above the band
(:func:`~steam_ref.evaluate.runs_needed`: 60 runs for poses and velocities, 71 for landmarks at 95 %; the
derivation is in :mod:`steam_ref.evaluate.consistency` and docs/derivations.md); with fewer the verdict is
"inconclusive (too few runs)" and the estimator's ``consistent`` is None (docs/derivations.md §12: the
interpolated BTGP, 17.7 over 200 runs, was inside the band at 20).

The set-up (:func:`consistency_setup`) is the paper's synthetic one scaled to where its posterior is
Gaussian, with Gaussian ranges (no Tukey loss: a robust loss is not the model the data are drawn from).
With the paper's own parameters (σ = π on pose 0's heading, Qc = 0.01 diag(1, 1, 25), velocity σ 0.5,
ranges σ 1 m) the problem is far from linear on the scale of its errors: over 30 runs of 50 steps the
batch optimum's pose ANEES was 59.6 and BTGP/1's 28.1, against a band of [2.19, 3.94], so NEES would
measure the linearisation, not the solver. ``qc_scale`` gives an estimator a deliberately wrong prior:
the data still come from the set-up's Qc.

Measured with ``steam-ref consistency --seeds 200 --jobs 2`` (docs/experiments.md): the batch optimum, BTGP/1,
BTGP/10 and skip 5 without interpolation consistent in every kind; Qc × 100 underconfident; skip 5 with interpolated
readings overconfident (pose ANEES 17.7): in 26 of the 200 runs iSAM2's lazy relinearization (GTSAM's defaults)
leaves interpolated factors linearized at stale states, away from the optimum, which is consistent on those runs.

**Any motion prior.** The task is drawn from the set-up's motion prior (``sample_from_model`` asks it), and
each estimator's error is the truth against its estimate in the coordinates its covariance is in, as its own
prior says (``MotionPrior.errors`` of the truth's world-frame pose and velocity, ``MotionPrior.world_states``):
for the vector-space priors the difference, heading wrapped; on SE(2) the truth in the right tangent at the
estimate, x_true ⊖ x̂ = [Log(T̂⁻¹T); ϖ - ϖ̂] (the pose block in the body frame). The study of a named model is
one entry of :data:`STUDIES`: ``steam-ref consistency --prior se2`` (:func:`consistency_se2_setup`) draws from
the SE(2) WNOA model, ``turn`` starting the task's yaw rate at that many rad a step, and its estimator "btgp/1
vector-space prior" solves the same task with the paper's vector-space WNOA prior (its error: position and
wrapped heading in the world frame, the truth's world velocity [R(θ) [vx, vy], ω]).

**SE(3).** ``--prior se3`` and ``se3-wnoj`` are entries of the same table whose study is a
:class:`~steam_ref.paper.rigid.RigidStudy` (3-D tasks, batch and BTGP, each state's pose and twist: d = 6). Any
:class:`Study` runs through :func:`run_seed`, :func:`check_result` and :func:`summarize` (which read its ``kinds``).
"""

from __future__ import annotations

import functools
import json
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

import numpy as np

from ..arguments import integer, is_integer
from ..batch import gauss_newton
from ..datasets import sample_from_model
from ..errors import SteamError
from ..evaluate import INCONCLUSIVE, LOST_QUANTILE, chi2_band, chi2_quantile, nees, runs_needed, verdict
from ..linear.threads import limited
from ..trajectory import Trajectory
from ..variables import L, Values
from .online import StreamingEstimator
from .options import StreamOptions
from .presets import PaperSetup
from .problem import build_problem, sequential_batch
from .readings import Readings
from .rigid import RIGID_QC, RigidSetup, RigidStudy
from .solvers import PeriodicBatchSolver

__all__ = [
    "Estimator",
    "ESTIMATORS",
    "ConsistencyStudy",
    "consistency_setup",
    "consistency_se2_setup",
    "SE2_ESTIMATORS",
    "Study",
    "StudyModel",
    "STUDIES",
    "model_of",
    "check_result",
    "run_seed",
    "summarize",
    "KINDS",
]

KINDS = {"pose": 3, "velocity": 3, "landmark": 2}  # each kind of state and its dimension d


@dataclass(frozen=True)
class Estimator:
    """One estimator of the study: the batch optimum, or BTGP on a schedule and layout, with a prior."""

    method: str = "btgp"  # 'batch' (the batch optimum of everything) or 'btgp'
    every: int = 1  # BTGP's schedule: '/1', '/10'
    skip: int = 1  # a state every ``skip`` poses
    interpolate: bool = True  # readings between states interpolated (Eq. 29) or dropped
    qc_scale: float = 1.0  # the estimator's Qc is the set-up's times this (the data keep the set-up's)
    prior: str | None = None  # the estimator's motion prior; None: the set-up's (the one the data come from)


ESTIMATORS: dict[str, Estimator] = {
    "batch": Estimator("batch"),
    "btgp/1": Estimator(),
    "btgp/10": Estimator(every=10),
    "btgp/1 skip 5 interpolated": Estimator(skip=5),
    "btgp/1 skip 5 not interpolated": Estimator(skip=5, interpolate=False),
    "btgp/1 Qc x100": Estimator(qc_scale=100.0),
    "btgp/1 vector-space prior": Estimator(prior="wnoa"),
}
PAPER_ESTIMATORS = tuple(e for e in ESTIMATORS if ESTIMATORS[e].prior is None)  # the default study
SE2_ESTIMATORS = ("batch", "btgp/1", "btgp/1 vector-space prior")  # the default study on SE(2) tasks
RIGID_ESTIMATORS = ("batch", "btgp")  # a 3-D study's: paper.rigid.solve_rigid's methods


def consistency_setup() -> PaperSetup:
    """The model the tasks are drawn from: the paper's synthetic set-up scaled to where its posterior is
    Gaussian (module docstring), ranges Gaussian (no Tukey loss)."""
    return PaperSetup.synthetic().replace(
        qc=1e-3 * np.eye(3),
        velocity_sigmas=np.full(3, 0.02),
        interpolated_velocity_sigmas=np.full(3, 0.02),
        range_sigma=0.05,
        landmark_prior_sigma=0.2,
        first_pose_sigmas=np.array([0.05, 0.05, 0.02]),
        first_velocity_sigmas=np.array([0.05, 0.05, 0.02]),
        tukey_c=None,
    )


def consistency_se2_setup(turn: float = 0.0, se2_residual: str = "local-variable") -> PaperSetup:
    """:func:`consistency_setup` on SE(2) states: tasks from the SE(2) WNOA model of ``se2_residual``, the yaw rate
    starting at ``turn`` rad a step (forward speed 1 m a step)."""
    return consistency_setup().replace(
        prior="se2", se2_residual=se2_residual, first_velocity=np.array([1.0, 0.0, turn])
    )


class Study(Protocol):
    """A consistency study to the command, the sweep and :func:`summarize`: its task's size, its estimators, the kinds
    of state it scores (name → d), its parameters (JSON), run ``index`` (:meth:`ConsistencyStudy.run`)."""

    @property
    def n_steps(self) -> int: ...
    @property
    def n_landmarks(self) -> int: ...
    @property
    def estimators(self) -> tuple[str, ...]: ...
    @property
    def kinds(self) -> dict[str, int]: ...
    def describe(self) -> dict: ...
    def run(self, index: int) -> dict: ...


@dataclass(frozen=True)
class ConsistencyStudy:
    """What a Monte Carlo consistency study runs: the task's size, the set-up, the estimators, the seed."""

    n_steps: int = 40
    n_landmarks: int = 8
    seed: int = 0  # the root of np.random.SeedSequence(seed).spawn(n_seeds)
    setup: PaperSetup = field(default_factory=consistency_setup)
    estimators: tuple[str, ...] = PAPER_ESTIMATORS
    kinds: ClassVar[dict[str, int]] = KINDS  # the kinds of state it scores

    def __post_init__(self) -> None:
        for name in ("n_steps", "n_landmarks"):
            integer(f"ConsistencyStudy.{name}", getattr(self, name), 1)
        integer("ConsistencyStudy.seed", self.seed, 0)
        unknown = [e for e in self.estimators if e not in ESTIMATORS]
        if unknown or not self.estimators:
            raise SteamError(
                f"unknown estimator {unknown[0] if unknown else None!r}; use some of {', '.join(ESTIMATORS)}"
            )

    def describe(self) -> dict:
        """The study's parameters (a resumed file must have been written by the same study)."""
        s = self.setup
        return {
            "n_steps": self.n_steps,
            "n_landmarks": self.n_landmarks,
            "seed": self.seed,
            "setup": s.name,
            "qc": np.diag(s.qc).tolist(),
            "tukey_c": s.tukey_c,
            "estimators": list(self.estimators),
            "prior": s.prior,
            **s.prior_options(),
            "first_velocity": s.first_velocity.tolist(),
        }

    def sample(self, index: int):
        """Task ``index``: drawn with child ``index`` of SeedSequence(seed).spawn(...)."""
        seed = np.random.SeedSequence(self.seed, spawn_key=(index,))  # = SeedSequence(seed).spawn(n)[index]
        return sample_from_model(self.n_steps, self.n_landmarks, seed, **model_of(self.setup))

    def run(self, index: int) -> dict:
        """Run ``index``: {estimator: {'pose' | 'velocity' | 'landmark': [NEES of each], 'warnings': [...]}}."""
        task = self.sample(index)
        out: dict = {}
        stream = None  # BTGP/1's final estimate: the batch optimum's second start
        names = sorted(self.estimators, key=lambda n: ESTIMATORS[n] != ESTIMATORS["btgp/1"])  # BTGP/1 first
        for name in names:
            estimator = ESTIMATORS[name]
            setup = self.setup.replace(qc=estimator.qc_scale * self.setup.qc, prior=estimator.prior or self.setup.prior)
            readings = Readings.from_dataset(task.data, setup)
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                same = estimator.qc_scale == 1.0 and estimator.skip == 1
                trajectory, ids = _solve(estimator, readings, setup, stream if same else None)
                if ESTIMATORS[name] == ESTIMATORS["btgp/1"]:
                    stream = trajectory.solver.estimate()
                times, states = trajectory.at_every_pose()
                cov = trajectory.covariances([L(i) for i in ids])
            truth = task.prior.world_states(task.states[: len(times)])  # the truth's pose and velocity, world frame
            marks = np.array([trajectory.solver.estimate_of(L(i)) for i in ids]).reshape(-1, 2)
            true_marks = np.array([task.landmarks[i] for i in ids]).reshape(-1, 2)
            error = trajectory.prior.errors(states, truth)  # in the coordinates of the estimator's covariance
            pose_error, velocity_error = error[:, :3], error[:, 3:]
            out[name] = {
                "pose": nees(pose_error, cov.pose).tolist(),
                "velocity": nees(velocity_error, cov.velocity).tolist(),
                "landmark": nees(marks - true_marks, cov.landmark).tolist(),
                "warnings": sorted({str(w.message)[:200] for w in caught}),
            }
        return {name: out[name] for name in self.estimators}


@dataclass(frozen=True)
class StudyModel:
    """A model a study draws its tasks from, by the name ``steam-ref consistency --prior`` gives it: its set-up
    (``setup(**options)``), the estimators its study runs, the options ``setup`` takes (the command's names), and
    the study (``study(n_steps=, n_landmarks=, seed=, setup=, estimators=)``, a :class:`Study`)."""

    setup: Callable[..., Any]
    estimators: tuple[str, ...]
    options: tuple[str, ...] = ()
    study: Callable[..., Study] = ConsistencyStudy


STUDIES: dict[str, StudyModel] = {
    "wnoa": StudyModel(consistency_setup, PAPER_ESTIMATORS),
    "se2": StudyModel(consistency_se2_setup, SE2_ESTIMATORS, ("turn", "se2_residual")),
    "se3": StudyModel(RigidSetup, RIGID_ESTIMATORS, study=RigidStudy),
    # WNOJ's Qc is on the jerk, and a first acceleration off by σ turns the twist by 40 σ in 40 steps: both smaller
    "se3-wnoj": StudyModel(
        functools.partial(RigidSetup, "se3-wnoj", RIGID_QC / 1000, {"first_twist": 0.005}),
        RIGID_ESTIMATORS,
        study=RigidStudy,
    ),
}


def model_of(setup: PaperSetup) -> dict:
    """The model a set-up's estimator assumes, as :func:`~steam_ref.datasets.sample_from_model`'s keywords."""
    return dict(
        prior=setup.motion_prior(),
        velocity_sigmas=setup.velocity_sigmas,
        range_sigma=setup.range_sigma,
        landmark_sigma=setup.landmark_prior_sigma,
        first_pose_sigmas=setup.first_pose_sigmas,
        first_velocity=setup.first_velocity,
        first_velocity_sigmas=setup.first_velocity_sigmas,
        first_acceleration_sigmas=setup.first_acceleration_sigmas,
    )


def _solve(
    estimator: Estimator, readings: Readings, setup: PaperSetup, start: Values | None = None
) -> tuple[Trajectory, list[int]]:
    """The estimator's final trajectory (estimates and covariances at any time) and its landmarks' ids (BTGP/1 runs
    first, so that its estimate can be the batch optimum's second start).

    The batch optimum is the lower of the minima Gauss-Newton reaches from a sequential batch (chunks of
    10 poses) and from ``start`` (BTGP/1's estimate of the same problem, when given): a descent from
    dead reckoning alone can stop in a worse minimum than the stream found.
    """
    if estimator.method == "batch":
        problem = build_problem(readings, setup, skip=estimator.skip, interpolate=estimator.interpolate)
        result = sequential_batch(problem, chunk=10)
        if start is not None:
            other = gauss_newton(problem.graph, start, ordering="amd", max_iterations=50)
            result = other if other.cost < result.cost else result
        solver = PeriodicBatchSolver("amd")  # holds the optimum; its covariances come from 𝓘 there
        solver.graph, solver.values = problem.graph, result.values
        ids = [i for i in sorted(readings.landmarks) if L(i) in result.values]  # a landmark no reading sees has none
        return Trajectory(solver, problem.states.tolist(), readings.clock, setup.motion_prior()), ids
    options = StreamOptions(skip=estimator.skip, interpolate=estimator.interpolate)
    run = StreamingEstimator(readings, setup.with_schedule(every=estimator.every), options)
    run.run()
    return run.solved(), sorted(run.landmark_estimates())


@limited
def run_seed(study: Study, index: int) -> dict:
    """One Monte Carlo run of ``study``: task ``index``, each estimator's NEES of each kind of state (JSON)."""
    return study.run(integer("index", index, minimum=0))  # SeedSequence's spawn keys are >= 0


def _nees_list(value: object, what: str, length: int | None, most: int) -> None:
    """SteamError unless ``value`` is a list of non-negative finite numbers, ``length`` long (at most ``most``)."""
    if not isinstance(value, list):
        raise SteamError(f"{what} is {json.dumps(value)[:40]}, not a list of NEES values")
    if (length is not None and len(value) != length) or len(value) > most:
        wanted = f"{length}" if length is not None else f"at most {most}"
        raise SteamError(f"{what} has {len(value)} values where the study has {wanted}")
    for k, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
            raise SteamError(f"{what}[{k}] is {json.dumps(v)[:40]}: a NEES is a finite number >= 0")


def check_result(study: Study, item: object, result: object) -> None:
    """SteamError saying what is wrong with ``result``, read back as the result of run ``item`` of ``study``
    (:func:`run_seed`'s output): every estimator of the study, each with one NEES per pose and velocity
    (``n_steps + 1``), at most one per landmark (an unseen one has none), each a finite number >= 0, and its
    warnings as text. A log is read back through this, so a damaged or edited line is never averaged in."""
    if not is_integer(item) or item < 0:
        raise SteamError(f"the item {json.dumps(item)[:40]} is not a run's index (an integer >= 0)")
    if not isinstance(result, dict):
        raise SteamError(f"the result is {json.dumps(result)[:40]}, not an object of estimators")
    missing = [name for name in study.estimators if name not in result]
    if missing:
        raise SteamError(f"no result of estimator {missing[0]!r}")
    n_poses = study.n_steps + 1
    for name in study.estimators:
        row = result[name]
        if not isinstance(row, dict):
            raise SteamError(f"estimator {name!r}: {json.dumps(row)[:40]} is not an object of NEES lists")
        for kind in study.kinds:
            length, most = (None, study.n_landmarks) if kind == "landmark" else (n_poses, n_poses)
            _nees_list(row.get(kind), f"estimator {name!r}: {kind}", length, most)
        notes = row.get("warnings")
        if not isinstance(notes, list) or not all(isinstance(w, str) for w in notes):
            raise SteamError(f"estimator {name!r}: warnings {json.dumps(notes)[:40]} is not a list of text")


def summarize(
    results: dict[int, dict], estimators: tuple[str, ...], level: float = 0.95, kinds: dict[str, int] = KINDS
) -> dict:
    """ANEES of each estimator and kind (``kinds``: a study's, name → d) over the runs ``results`` (index →
    :func:`run_seed`'s output), with its band and verdict; the per-pose ANEES too (for the plot)."""
    order = sorted(results)
    for i in order:  # every run has every estimator: an ANEES over fewer runs would not be the one reported
        missing = [name for name in estimators if not isinstance(results[i], dict) or name not in results[i]]
        if missing:
            raise SteamError(f"run {i} has no result for estimator {missing[0]!r}: every run needs every estimator")
    out: dict = {"n_seeds": len(order), "level": level, "estimators": {}}
    for name in estimators:
        row: dict = {}
        for kind, d in kinds.items():
            runs = [r for r in (np.asarray(results[i][name][kind], dtype=float) for i in order) if r.size]  # seen
            if not runs:  # a run that saw no landmark has none: the ANEES and band are over the runs that did
                raise SteamError(f"estimator {name!r}: no run has a {kind} NEES, so there is no {kind} ANEES")
            anees = float(np.mean([r.mean() for r in runs]))  # the runs' means, averaged
            band = chi2_band(len(runs), d, level)
            # A run whose mean NEES is beyond the 99.9 % point of one state's χ²(d): lost (a wrong minimum). Counted.
            far = sum(bool(r.mean() > chi2_quantile(LOST_QUANTILE, d)) for r in runs)
            needed = runs_needed(d, level)  # fewer runs could have missed a tail of lost runs (evaluate.consistency)
            row[kind] = {
                "anees": anees,
                "band": list(band),
                "verdict": verdict(anees, band, enough_runs=len(runs) >= needed),
                "runs_needed": needed,
                "dim": d,
                "median_run": float(np.median([r.mean() for r in runs])),
                "runs_far_outside": far,
            }
            if kind != "landmark":  # every run has every pose; a landmark may go unseen (readings dropped)
                per_state = np.mean(runs, axis=0)
                inside = (per_state >= band[0]) & (per_state <= band[1])
                row[kind] |= {"per_state": per_state.tolist(), "inside_fraction": float(np.mean(inside))}
        verdicts = [row[k]["verdict"] for k in kinds]
        # True, False, or None when no kind is inconsistent but some are inconclusive (too few runs)
        row["consistent"] = (
            True
            if all(v == "consistent" for v in verdicts)
            else None
            if all(v in ("consistent", INCONCLUSIVE) for v in verdicts)
            else False
        )
        row["runs_with_warnings"] = sum(bool(results[i][name]["warnings"]) for i in order)
        out["estimators"][name] = row
    return out
