"""steam_ref's factors and stream fed to GTSAM 4.3's ISAM2: the one home of every GTSAM replica.

Used by ``benchmarks/vs_gtsam.py``, ``benchmarks/victoria_park.py`` and ``tests/test_gtsam_crosscheck.py``:

- :func:`custom_factor`: one of our factors as a ``gtsam.CustomFactor`` that calls our error and
  Jacobians from Python (the same model; GTSAM pays pybind11's copy of the ``Values`` into every
  callback). The time spent inside the callbacks is added up in :data:`CALLBACK_SECONDS`.
- :class:`CustomISAM2`: GTSAM's ISAM2 behind steam_ref's ``OnlineSolver`` interface, every factor a
  :func:`custom_factor` (setup (a) of the comparison with GTSAM).
- :class:`NativeISAM2`: GTSAM's ISAM2 with built-in C++ factors only (setup (b)): the state is a
  ``Pose2`` and a body-frame velocity (GTSAM's ``WnoaMotionFactorPose2``, white noise on acceleration on
  SE(2), not the paper's vector-space prior), a velocity reading is a ``PriorFactorVector`` on the
  velocity, a range a ``RangeFactor2D`` with the same Tukey loss, a landmark prior a
  ``PriorFactorPoint2``. It answers ``estimate_of`` with [x, y, θ, world-frame velocity], so our front end
  can predict from it; it is a yardstick of the machinery, not the same model. Given our SE(2) factors
  (a run with ``PaperSetup(prior="se2")``, the local-variable residual) it is the *same* model:
  ``LiePriorFactor`` → ``WnoaMotionFactorPose2``, ``BodyVelocityFactor`` → ``PriorFactorVector``, an
  ``PoseReading`` range → ``RangeFactor2D``, ``LieStatePrior`` → ``PriorFactorPose2`` and
  ``PriorFactorVector``; the states are SE(2) states and ``estimate_of`` answers [x, y, θ, body twist].
  ``pairs`` keeps each of our factors with the GTSAM factors that stand for it.
- :class:`NativeFixedLag`: the same factors through GTSAM 4.3's ``IncrementalFixedLagSmoother``, each state's
  pose and velocity stamped with its time; a landmark stamped as ``landmarks`` says (:data:`LANDMARK_STAMPS`).

GTSAM is imported when this module is; importing it without gtsam installed raises ImportError.
"""

from __future__ import annotations

import time

import gtsam
import numpy as np

from steam_ref.factors import GPPriorFactor, PriorFactor, RangeFactor, VelocityFactor
from steam_ref.factors.lie_prior import LiePriorFactor, LieStatePrior
from steam_ref.factors.lie_readings import BodyVelocityFactor, PoseReading
from steam_ref.paper.online_solver import OnlineSolver
from steam_ref.variables import Key, Values, X

__all__ = [
    "CALLBACK_SECONDS",
    "CustomISAM2",
    "NativeISAM2",
    "NativeFixedLag",
    "LANDMARK_STAMPS",
    "custom_factor",
    "gkey",
    "isam2_params",
]

CALLBACK_SECONDS = [0.0]  # seconds spent inside custom_factor callbacks since the process started


def gkey(key: Key, kind: str | None = None) -> int:
    """GTSAM's key of one of ours ('x' states, 'l' landmarks; ``kind`` 'p' or 'v' for a state's pose or velocity)."""
    return gtsam.symbol(kind or ("x" if key.symbol == "x" else "l"), key.index)


def _noise(factor) -> gtsam.noiseModel.Base:
    """The factor's whitening (√information), robust with its Tukey loss when it has one."""
    base = gtsam.noiseModel.Gaussian.SqrtInformation(np.asarray(factor.sqrt_information, dtype=float))
    if factor.loss is None:
        return base
    return gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Tukey.Create(factor.loss.c), base)


def custom_factor(factor) -> gtsam.CustomFactor:
    """One of our factors as a GTSAM factor: our error and Jacobians, GTSAM's noise model and loss."""

    def evaluate(this, values, H):
        start = time.perf_counter()
        xs = [values.atVector(k) for k in this.keys()]
        if H is not None:
            for i, J in enumerate(factor.jacobians(*xs)):
                H[i] = np.asarray(J)
        error = np.asarray(factor.error(*xs))
        CALLBACK_SECONDS[0] += time.perf_counter() - start
        return error

    return gtsam.CustomFactor(_noise(factor), [gkey(k) for k in factor.keys], evaluate)


def isam2_params(relinearize_threshold: float = 0.1, relinearize_skip: int = 10, wildfire: float = 1e-3):
    """GTSAM's ISAM2Params (its defaults unless told: the paper's scripts use them)."""
    params = gtsam.ISAM2Params()
    params.setRelinearizeThreshold(relinearize_threshold)
    params.relinearizeSkip = relinearize_skip
    gn = gtsam.ISAM2GaussNewtonParams()
    gn.setWildfireThreshold(wildfire)
    params.setOptimizationParams(gn)
    return params


class CustomISAM2(OnlineSolver):
    """GTSAM's ISAM2 fed our factors as :func:`custom_factor`s (the same model, setup (a))."""

    name = "gtsam-custom"

    def __init__(self, params=None):
        self.isam = gtsam.ISAM2(isam2_params() if params is None else params)

    def update(self, factors, values) -> None:
        graph, initial = gtsam.NonlinearFactorGraph(), gtsam.Values()
        for f in factors:
            graph.add(custom_factor(f))
        for k in values:
            initial.insert(gkey(k), np.asarray(values[k], dtype=float))
        self.isam.update(graph, initial)

    def estimate_of(self, key, *, past: str = "lagged"):  # noqa: ARG002 (nothing is forgotten, or as it left)
        return self.isam.calculateEstimateVector(gkey(key))

    def estimate(self) -> Values:
        final = self.isam.calculateEstimate()
        out = Values()
        for k in final.keys():
            s = gtsam.Symbol(k)
            out.insert(Key(chr(s.chr()), s.index()), final.atVector(k))
        return out


def _rotation(theta: float) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


class NativeISAM2(OnlineSolver):
    """GTSAM's ISAM2 with built-in C++ factors only (setup (b), module docstring).

    ``qc`` is the diagonal of the WNOA power spectral density (the preset's Qc).
    """

    name = "gtsam-native"

    def __init__(self, qc, params=None, *, se2: bool = False):
        self.qc = np.asarray(qc, dtype=float)
        self.isam = gtsam.ISAM2(isam2_params() if params is None else params)
        self.times: dict[int, float] = {}  # state index → time, from the GP priors' Δt (the first at 0)
        self.se2 = se2  # our states are SE(2) states [x, y, θ, body twist] (values in and estimates out)
        self.pairs: list[tuple] = []  # (our factor, [the GTSAM factors standing for it])

    def _state(self, key: Key) -> gtsam.StateData:
        return gtsam.StateData(gkey(key, "p"), gkey(key, "v"), self.times[key.index])

    def _se2_factors(self, f) -> list | None:
        """GTSAM's built-in factors for one of our SE(2) factors (None: not an SE(2) factor)."""
        if isinstance(f, LiePriorFactor):
            if f.model != "local-variable":
                raise ValueError(f"GTSAM's WnoaMotionFactorPose2 is the local-variable residual, not {f.model!r}")
            k1, k2 = f.keys
            self.times.setdefault(k1.index, 0.0)
            self.times[k2.index] = self.times[k1.index] + float(f.phi[0, 3])  # Φ = [[I, Δt I], [0, I]]
            return [gtsam.WnoaMotionFactorPose2(self._state(k1), self._state(k2), self.qc)]
        if isinstance(f, BodyVelocityFactor):
            return [gtsam.PriorFactorVector(gkey(f.keys[0], "v"), np.asarray(f.measured, dtype=float), _noise(f))]
        if isinstance(f, PoseReading) and isinstance(f.inner, RangeFactor):
            x, lm = f.keys
            return [gtsam.RangeFactor2D(gkey(x, "p"), gkey(lm), float(f.inner.measured[0]), _noise(f))]
        if isinstance(f, LieStatePrior):
            k, m, W = f.keys[0], np.asarray(f.mean, dtype=float), np.asarray(f.sqrt_information, dtype=float)
            if np.any(W[:3, 3:]) or np.any(W[3:, :3]):
                raise ValueError("the native replica takes a first-state prior with independent pose and velocity")
            return [
                gtsam.PriorFactorPose2(gkey(k, "p"), gtsam.Pose2(*m[:3]), gtsam.noiseModel.Gaussian.SqrtInformation(W[:3, :3])),
                gtsam.PriorFactorVector(gkey(k, "v"), m[3:], gtsam.noiseModel.Gaussian.SqrtInformation(W[3:, 3:])),
            ]  # fmt: skip
        return None

    def _factors(self, f) -> list:
        if self.se2:
            found = self._se2_factors(f)
            if found is not None or not isinstance(f, PriorFactor):
                if found is None:
                    raise ValueError(f"no built-in GTSAM factor stands for {type(f).__name__} here")
                return found
        if isinstance(f, GPPriorFactor):
            k1, k2 = f.keys
            self.times.setdefault(k1.index, 0.0)
            self.times[k2.index] = self.times[k1.index] + float(f.phi[0, 3])  # Φ = [[I, Δt I], [0, I]]
            return [gtsam.WnoaMotionFactorPose2(self._state(k1), self._state(k2), self.qc)]
        noise = _noise(f)
        if isinstance(f, VelocityFactor):  # the body-frame velocity is the state's velocity here
            return [gtsam.PriorFactorVector(gkey(f.keys[0], "v"), np.asarray(f.measured, dtype=float), noise)]
        if isinstance(f, RangeFactor):
            x, lm = f.keys
            return [gtsam.RangeFactor2D(gkey(x, "p"), gkey(lm), float(f.measured[0]), noise)]
        if isinstance(f, PriorFactor) and f.keys[0].symbol == "l":
            return [gtsam.PriorFactorPoint2(gkey(f.keys[0]), np.asarray(f.mean, dtype=float), noise)]
        if isinstance(f, PriorFactor) and f.keys[0].symbol == "x":  # the first state: pose and velocity apart
            k, m, W = f.keys[0], np.asarray(f.mean, dtype=float), np.asarray(f.sqrt_information, dtype=float)
            if np.any(W[:3, 3:]) or np.any(W[3:, :3]):
                raise ValueError("the native replica takes a first-state prior with independent pose and velocity")
            pose = gtsam.noiseModel.Gaussian.SqrtInformation(W[:3, :3])
            velocity = gtsam.noiseModel.Gaussian.SqrtInformation(W[3:, 3:])
            body = np.r_[_rotation(m[2]).T @ m[3:5], m[5]]
            return [
                gtsam.PriorFactorPose2(gkey(k, "p"), gtsam.Pose2(*m[:3]), pose),
                gtsam.PriorFactorVector(gkey(k, "v"), body, velocity),
            ]
        raise ValueError(f"no built-in GTSAM factor stands for {type(f).__name__} here")

    def update(self, factors, values) -> None:
        self.isam.update(*self._graph(factors, values))

    def _graph(self, factors, values) -> tuple[gtsam.NonlinearFactorGraph, gtsam.Values]:
        """The GTSAM factors standing for ``factors`` and the initial values of ``values``."""
        graph, initial = gtsam.NonlinearFactorGraph(), gtsam.Values()
        for f in factors:
            built = self._factors(f)
            if self.se2:
                self.pairs.append((f, built))
            for g in built:
                graph.add(g)
        for k in values:
            v = np.asarray(values[k], dtype=float)
            if k.symbol == "x":
                initial.insert(gkey(k, "p"), gtsam.Pose2(*v[:3]))
                initial.insert(gkey(k, "v"), v[3:] if self.se2 else np.r_[_rotation(v[2]).T @ v[3:5], v[5]])
            else:
                initial.insert(gkey(k), gtsam.Point2(*v))
        return graph, initial

    def estimate_of(self, key, *, past: str = "lagged"):  # noqa: ARG002 (nothing is forgotten, or as it left)
        if key.symbol != "x":
            return np.asarray(self.isam.calculateEstimatePoint2(gkey(key)))
        return self._state_of(
            self.isam.calculateEstimatePose2(gkey(key, "p")), self.isam.calculateEstimateVector(gkey(key, "v"))
        )

    def _state_of(self, pose, body) -> np.ndarray:
        """Our state of GTSAM's pose and body velocity."""
        if self.se2:
            return np.r_[pose.x(), pose.y(), pose.theta(), body]
        return np.r_[pose.x(), pose.y(), pose.theta(), _rotation(pose.theta()) @ body[:2], body[2]]

    def positions(self, states) -> np.ndarray:
        """(n, 2) the estimated positions of ``states`` (indices), from one full estimate."""
        final = self.isam.calculateEstimate()
        return np.array([[p.x(), p.y()] for p in (final.atPose2(gtsam.symbol("p", i)) for i in states)])


LANDMARK_STAMPS = (
    "last-seen",
    "unstamped",
)  # a landmark stamped with the newest time of each update naming it, or never


class NativeFixedLag(NativeISAM2):
    """:class:`NativeISAM2`'s factors through GTSAM 4.3's ``IncrementalFixedLagSmoother(lag)``, as steam_ref's
    ``FixedLagTreeSolver`` stamps its variables: a state's pose and velocity with its pose's time (``times``), a
    landmark (``landmarks="last-seen"``) with the newest state's time of each update whose factors name it, so it
    leaves the window a lag after it was last seen; ``"unstamped"`` gives a landmark no time (GTSAM never
    marginalizes it on its own). GTSAM marginalizes, after each update, what is stamped more than ``lag`` before
    the newest stamp; :meth:`forgotten` names those (our keys), read as they were before that update, the last
    estimate GTSAM gave of them (a variable marginalized in the update that brings it: its initial value), for ``estimate_of``
    afterwards."""

    name = "gtsam-fixed-lag"

    def __init__(self, qc, lag: float, times, params=None, *, landmarks: str = "last-seen", se2: bool = False):
        super().__init__(qc, params, se2=se2)
        if landmarks not in LANDMARK_STAMPS:
            raise ValueError(f"landmarks must be one of {LANDMARK_STAMPS}, got {landmarks!r}")
        self.isam = None
        self.smoother = gtsam.IncrementalFixedLagSmoother(float(lag), isam2_params() if params is None else params)
        self.lag, self.pose_times, self.landmarks = float(lag), np.asarray(times, dtype=float), landmarks
        self.stamp: dict[Key, float] = {}  # our key → its newest stamp
        self.queue: list[tuple[float, int, Key]] = []  # (stamp, order, key), a heap; stale entries skipped
        self.lagged: dict[Key, np.ndarray] = {}  # a forgotten key → its estimate as it left
        self._forgotten: list[Key] = []
        self.newest = -np.inf

    def update(self, factors, values) -> None:
        import heapq

        graph, initial = self._graph(factors, values)
        stamps = {k: float(self.pose_times[k.index]) for k in values if k.symbol == "x"}
        self.newest = max([self.newest, *stamps.values()])
        if self.landmarks == "last-seen" and np.isfinite(self.newest):
            stamps |= {k: self.newest for f in factors for k in f.keys if k.symbol != "x"}
        given = gtsam.FixedLagSmootherKeyTimestampMap()
        for k, t in stamps.items():
            for g in (gkey(k, "p"), gkey(k, "v")) if k.symbol == "x" else (gkey(k),):
                given.insert((g, t))
            self.stamp[k] = t
            heapq.heappush(self.queue, (t, len(self.queue), k))
        for k in values:
            self.lagged.pop(k, None)  # entered again
        self._forgotten = []
        while self.queue and self.queue[0][0] < self.newest - self.lag:
            t, _, k = heapq.heappop(self.queue)
            if self.stamp.get(k) == t:  # its newest stamp: GTSAM marginalizes it in this update
                self.lagged[k] = np.asarray(values[k], dtype=float) if k in values else self.estimate_of(k)
                del self.stamp[k]
                self._forgotten.append(k)
        self.smoother.update(graph, initial, given)

    def forgotten(self):
        return self._forgotten

    def estimate_of(self, key, *, past: str = "lagged"):  # noqa: ARG002 (nothing is forgotten, or as it left)
        if key in self.lagged:
            return self.lagged[key]
        if key.symbol != "x":
            return np.asarray(self.smoother.calculateEstimatePoint2(gkey(key)))
        return self._state_of(
            self.smoother.calculateEstimatePose2(gkey(key, "p")), self.smoother.calculateEstimateVector(gkey(key, "v"))
        )

    def positions(self, states) -> np.ndarray:
        """(n, 2) the estimated positions of ``states`` (indices): the window's from one estimate, the rest as they left."""
        final = self.smoother.calculateEstimate()
        out = []
        for i in states:
            key = gtsam.symbol("p", i)
            out.append([final.atPose2(key).x(), final.atPose2(key).y()] if final.exists(key) else self.lagged[X(i)][:2])
        return np.array(out)
