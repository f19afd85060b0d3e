"""Bad input to the public Python API, as a new user would give it (API arguments are validated
where they enter, with messages that name the argument and the value).

Each case of ``CASES`` is one finding of the sweep: a call that gave a silent wrong answer, a
non-project exception (TypeError, KeyError, OverflowError, LinAlgError, ...) or a message that named
the wrong thing. It must now raise the project's error, of the type given, with a message naming the
argument and its value. Then: every failed ``IncrementalSolver.update`` leaves the solver exactly as
it was, and property tests over the GP functions (random time steps, finite or not) see finite arrays
or a SteamError, never another exception.
"""

from __future__ import annotations

import math
import os
import re
import tempfile

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import example, given, settings
from hypothesis import strategies as st

import steam_ref as sr
from steam_ref import L, X, covariance, dead_reckoning, evaluate, gp, plot
from steam_ref.bayes_tree import marginalize
from steam_ref.errors import (
    KindError,
    NumericalError,
    ShapeError,
    SteamError,
    UnderdeterminedError,
    UnknownVariableError,
)
from steam_ref.factors import LieStatePrior
from steam_ref.gp import LinearSDE
from steam_ref.lie import SE2, SE2_STATE
from steam_ref.linear import (
    LinearSystem,
    Ordering,
    SparseCholesky,
    constrained_min_degree,
    linearize,
    make_ordering,
)
from steam_ref.linear import solve as linear_solve
from steam_ref.manifold import VECTOR
from steam_ref.paper.online import StreamingEstimator
from steam_ref.paper.results import position_rmse
from steam_ref.paper.solvers import FixedLagTreeSolver, make_solver
from steam_ref.trajectory import Trajectory

QC = np.diag([0.1, 0.2, 0.3])
WNOJ = LinearSDE.wnoj(QC)
ONES = np.ones(6)
PHI, Q = gp.transition(1.0, 3), gp.process_noise(1.0, QC)
KEYS = [X(0), X(1)]
DIMS = {X(0): 6, X(1): 6}
INNER = sr.RangeFactor.create(X(-1), L(0), 5.0, 0.3)  # a reading at a time with no state
PNG = "unused.png"  # every plotting case fails before it draws


def two_states() -> tuple[list[sr.Factor], sr.Values]:
    """Two WNOA states one second apart, with a prior on the first: a tiny problem that solves."""
    factors = sr.gp_prior_factors(KEYS, [0.0, 1.0], QC) + [sr.PriorFactor.create(X(0), np.zeros(6), 1.0)]
    return factors, sr.Values({X(0): np.zeros(6), X(1): ONES})


def solver() -> sr.IncrementalSolver:
    factors, values = two_states()
    s = sr.IncrementalSolver()
    s.update(factors, dict(values))
    return s


def system() -> LinearSystem:
    factors, values = two_states()
    return LinearSystem.build(factors, values, Ordering(tuple(KEYS), (6, 6)))


def gaussian() -> list:
    """The linearized factors of ``two_states``."""
    factors, values = two_states()
    return [gf for group in linearize(factors, values) for gf in group.gaussian_factors()]


def trajectory(**changes) -> Trajectory:
    args = {"solver": solver(), "states": [0, 1], "times": np.array([0.0, 1.0]), "prior": QC} | changes
    return Trajectory(**args)


def info(matrix) -> sp.csc_matrix:
    return sp.csc_matrix(np.asarray(matrix, dtype=float))


SYMMETRIC_PD = 12 * np.eye(12)
UPPER = np.triu(np.ones((12, 12))) + 12 * np.eye(12)  # not symmetric

# (id, call, error type, regex the message must match: the argument and its value)
CASES = [
    # --- gp: time steps, dimensions, Qc -------------------------------------------------------------
    ("transition dt=nan", lambda: gp.transition(np.nan, 3), SteamError, r"time step must be finite, got dt=nan"),
    ("transition dt='1'", lambda: gp.transition("1", 3), SteamError, r"got dt='1'"),
    ("transition dt=True", lambda: gp.transition(True, 3), SteamError, r"got dt=True"),
    ("transition d=0", lambda: gp.transition(1.0, 0), SteamError, r"d must be an integer >= 1, got d=0"),
    ("transition d=-1", lambda: gp.transition(1.0, -1), SteamError, r"got d=-1"),
    ("transition d=2.5", lambda: gp.transition(1.0, 2.5), SteamError, r"d must be an integer, got d=2.5"),
    ("process_noise dt='abc'", lambda: gp.process_noise("abc", QC), SteamError, r"got dt='abc'"),
    ("process_noise dt=None", lambda: gp.process_noise(None, QC), SteamError, r"got dt=None"),
    ("process_noise dt=[1.0]", lambda: gp.process_noise(np.array([1.0]), QC), SteamError, r"got dt=array\(\[1\.\]\)"),
    ("process_noise dt=1e120 overflows", lambda: gp.process_noise(1e120, QC), NumericalError, r"Q\(dt\).*dt=1e\+120"),
    (
        "process_noise_inverse dt=1e-120 overflows",
        lambda: gp.process_noise_inverse(1e-120, QC),
        NumericalError,
        r"dt=1e-120",
    ),
    ("sqrt_information dt=1e-320", lambda: gp.process_noise_sqrt_information(1e-320, QC), NumericalError, r"dt=1e-320"),
    (
        "qc empty",
        lambda: gp.process_noise(1.0, np.zeros((0, 0))),
        ShapeError,
        r"Qc .*size at least 1, got shape \(0, 0\)",
    ),
    (
        "qc string",
        lambda: gp.process_noise(1.0, "abc"),
        ShapeError,
        r"Qc must be an array of numbers, got the string Qc='abc'",
    ),
    ("qc complex", lambda: gp.process_noise(1.0, [[1j]]), ShapeError, r"Qc must be an array of numbers.*complex"),
    ("qc bool", lambda: gp.process_noise(1.0, [[True]]), ShapeError, r"Qc must be an array of numbers.*bool"),
    ("wnoj_transition dt=1e300", lambda: gp.wnoj_transition(1e300, 3), NumericalError, r"dt=1e\+300"),
    ("wnoj_process_noise dt=1e70", lambda: gp.wnoj_process_noise(1e70, QC), NumericalError, r"dt=1e\+70"),
    (
        "wnoj_process_noise_inverse dt=1e-70",
        lambda: gp.wnoj_process_noise_inverse(1e-70, QC),
        NumericalError,
        r"dt=1e-70",
    ),
    ("wnoj_transition d=True", lambda: gp.wnoj_transition(1.0, True), SteamError, r"got d=True"),
    ("singer alpha='1'", lambda: LinearSDE.singer(QC, "1"), SteamError, r"alpha must be a real number, got alpha='1'"),
    ("singer alpha=True", lambda: LinearSDE.singer(QC, True), SteamError, r"got alpha=True"),
    (
        "singer alpha=1e300 overflows Q",
        lambda: LinearSDE.singer(QC, 1e300).process_noise(1.0),
        NumericalError,
        r"alpha=1e\+300",
    ),
    ("singer transition dt=-1e300", lambda: gp.singer_transition(-1e300, 1.0, 3), NumericalError, r"dt=-1e\+300"),
    (
        "general Van Loan dt=1e120 gave NaN",
        lambda: LinearSDE.wnoa(QC).general().process_noise(1e120),
        NumericalError,
        r"dt=1e\+120",
    ),
    ("sde.transition dt='abc'", lambda: WNOJ.transition("abc"), SteamError, r"got dt='abc'"),
    (
        "LinearSDE A empty",
        lambda: LinearSDE(np.zeros((0, 0)), np.zeros((0, 1)), [[1.0]]),
        ShapeError,
        r"A must be a non-empty 2-d array, got shape \(0, 0\)",
    ),
    ("LinearSDE v NaN named", lambda: LinearSDE.wnoa(QC, v=np.full(6, np.nan)), ShapeError, r"v\[0\] = nan"),
    (
        "sde.mean t0=nan gave mu0 everywhere",
        lambda: LinearSDE.wnoa(QC).mean([1, 2], np.nan, np.zeros(6)),
        SteamError,
        r"got t0=nan",
    ),
    ("sde.mean mu0 NaN", lambda: LinearSDE.wnoa(QC).mean([1, 2], 0, np.full(6, np.nan)), ShapeError, r"mu0\[0\] = nan"),
    (
        "dense_kernel P0 NaN",
        lambda: gp.dense_kernel(LinearSDE.wnoa(QC), [0, 1], np.full((6, 6), np.nan)),
        ShapeError,
        r"P0\[0, 0\] = nan",
    ),
    (
        "dense_kernel P0 not symmetric",
        lambda: gp.dense_kernel(LinearSDE.wnoa(QC), [0, 1], np.triu(np.ones((6, 6)))),
        SteamError,
        r"P0 must be symmetric, but P0\[0, 1\] = 1.0",
    ),
    # --- gp: interpolation and extrapolation ---------------------------------------------------------
    (
        "interpolation t1=None",
        lambda: gp.interpolation_matrices(None, 1, 0.5, QC),
        SteamError,
        r"t1 must be a real number, got t1=None",
    ),
    ("interpolation t1='0'", lambda: gp.interpolation_matrices_sde(WNOJ, "0", 1, 0.5), SteamError, r"got t1='0'"),
    (
        "interpolation t1=-inf blamed dt",
        lambda: gp.interpolation_matrices(-np.inf, 1, 0.5, QC),
        SteamError,
        r"got t1=-inf",
    ),
    ("interpolation t1=True", lambda: gp.interpolation_matrices(True, 2, 1.5, QC), SteamError, r"got t1=True"),
    (
        "interpolation gap 1e-120",
        lambda: gp.interpolation_matrices(0, 1e-120, 5e-121, QC),
        NumericalError,
        r"dt=1e-120",
    ),
    (
        "interpolation_sde gap 1e-120 LinAlgError",
        lambda: gp.interpolation_matrices_sde(WNOJ, 0, 1e-120, 5e-121),
        NumericalError,
        r"t2 - t1 = 1e-120",
    ),
    (
        "interpolation_sde gap 1e200 OverflowError",
        lambda: gp.interpolation_matrices_sde(WNOJ, 0, 1e200, 1),
        NumericalError,
        r"dt=1e\+200",
    ),
    (  # its one entry inside (t1, t2): it was refused as "t1 < tau < t2 ... got at 0: t1=0, tau=0.5, t2=1"
        "interpolation_many tau a scalar",
        lambda: gp.interpolation_matrices_many(0, 1, 0.5, QC),
        ShapeError,
        r"^tau must be a vector of times \(n,\), got shape \(\)$",
    ),
    (
        "interpolation_many tau a table",
        lambda: gp.interpolation_matrices_many(0, 1, [[0.25, 0.5]], QC),
        ShapeError,
        r"^tau must be a vector of times \(n,\), got shape \(1, 2\)$",
    ),
    (
        "interpolate_state x1 string",
        lambda: gp.interpolate_state(0, "abc", 1, ONES, 0.5, QC),
        ShapeError,
        r"got the string x1='abc'",
    ),
    (
        "interpolate_state x1 NaN named",
        lambda: gp.interpolate_state(0, np.full(6, np.nan), 1, ONES, 0.5, QC),
        ShapeError,
        r"x1\[0\] = nan",
    ),
    (
        "interpolate_covariance joint_cov not symmetric",
        lambda: gp.interpolate_covariance(0, 1, 0.5, QC, np.triu(np.ones((12, 12))) + np.eye(12)),
        SteamError,
        r"joint_cov must be symmetric, but joint_cov\[0, 1\] = 1.0 and joint_cov\[1, 0\] = 0.0",
    ),
    (
        "interpolate_covariance joint_cov negative variance",
        lambda: gp.interpolate_covariance_sde(LinearSDE.wnoa(QC), 0, 1, 0.5, -np.eye(12)),
        SteamError,
        r"joint_cov\[0, 0\] = -1.0",
    ),
    (
        "interpolate_covariance joint_cov string",
        lambda: gp.interpolate_covariance(0, 1, 0.5, QC, "abc"),
        ShapeError,
        r"got the string joint_cov='abc'",
    ),
    (
        "extrapolate t1=-inf blamed dt",
        lambda: gp.extrapolate_state_sde(WNOJ, -np.inf, np.ones(9), 1.0),
        SteamError,
        r"t1 must be a finite number, got t1=-inf",
    ),
    (
        "extrapolate t1=None",
        lambda: gp.extrapolate_covariance_sde(WNOJ, None, 1.0, np.eye(9)),
        SteamError,
        r"got t1=None",
    ),
    (
        "extrapolate t=1e200 overflows",
        lambda: gp.extrapolate_state_sde(WNOJ, 0.0, np.ones(9), 1e200),
        NumericalError,
        r"dt=1e\+200",
    ),
    (
        "extrapolate cov1 not symmetric",
        lambda: gp.extrapolate_covariance_sde(WNOJ, 0, 1, np.triu(np.ones((9, 9)))),
        SteamError,
        r"cov1 must be symmetric",
    ),
    (
        "extrapolate cov1 negative variance",
        lambda: gp.extrapolate_covariance_sde(WNOJ, 0, 1, -np.eye(9)),
        SteamError,
        r"cov1\[0, 0\] = -1.0",
    ),
    # --- factors --------------------------------------------------------------------------------------
    ("GPPriorFactor.wnoa dt=True", lambda: sr.GPPriorFactor.wnoa(X(0), X(1), True, QC), SteamError, r"got dt=True"),
    ("GPPriorFactor.wnoa dt='1'", lambda: sr.GPPriorFactor.wnoa(X(0), X(1), "1", QC), SteamError, r"got dt='1'"),
    (
        "GPPriorFactor.wnoa dt=1e-120",
        lambda: sr.GPPriorFactor.wnoa(X(0), X(1), 1e-120, QC),
        NumericalError,
        r"dt=1e-120",
    ),
    (
        "GPPriorFactor.from_sde tiny gap blamed the covariance",
        lambda: sr.GPPriorFactor.from_sde(X(0), X(1), 1e-70, WNOJ),
        NumericalError,
        r"Q\(dt\).*dt=1e-70",
    ),
    (
        "GPPriorFactor.from_sde sde=Qc",
        lambda: sr.GPPriorFactor.from_sde(X(0), X(1), 1.0, QC),
        SteamError,
        r"sde must be a LinearSDE.*got sde=array",
    ),
    (
        "from_matrices phi 0-d IndexError",
        lambda: sr.GPPriorFactor.from_matrices(X(0), X(1), 1.0, Q),
        ShapeError,
        r"phi \(Φ\) must be a square .*got shape \(\)",
    ),
    (
        "from_matrices phi NaN accepted",
        lambda: sr.GPPriorFactor.from_matrices(X(0), X(1), np.full((6, 6), np.nan), Q),
        ShapeError,
        r"phi\[0, 0\] = nan",
    ),
    (
        "from_matrices q scalar read as sigma",
        lambda: sr.GPPriorFactor.from_matrices(X(0), X(1), PHI, 2.0),
        ShapeError,
        r"q \(Qᵢ\) must be a \(6, 6\) covariance.*got shape \(\)",
    ),
    (
        "from_matrices q (6,) read as sigmas",
        lambda: sr.GPPriorFactor.from_matrices(X(0), X(1), PHI, np.ones(6)),
        ShapeError,
        r"q \(Qᵢ\).*got shape \(6,\)",
    ),
    (
        "from_matrices q named q, not noise",
        lambda: sr.GPPriorFactor.from_matrices(X(0), X(1), PHI, np.triu(np.ones((6, 6)))),
        SteamError,
        r"q \(a covariance\) is not symmetric",
    ),
    (
        "from_matrices v 2-D flattened",
        lambda: sr.GPPriorFactor.from_matrices(X(0), X(1), PHI, Q, np.ones((2, 3))),
        ShapeError,
        r"v must be 6 finite numbers",
    ),
    (
        "PriorFactor mean 2-D flattened",
        lambda: sr.PriorFactor.create(X(0), [[1, 2], [3, 4]], 1.0),
        ShapeError,
        r"mean .*x0.* 1-D vector, got shape \(2, 2\)",
    ),
    ("PriorFactor mean empty", lambda: sr.PriorFactor.create(X(0), [], 1.0), ShapeError, r"mean .* got shape \(0,\)"),
    (
        "PriorFactor mean string",
        lambda: sr.PriorFactor.create(X(0), "abc", 1.0),
        ShapeError,
        r"got the string mean='abc'",
    ),
    (
        "PriorFactor mean '5' parsed",
        lambda: sr.PriorFactor.create(X(0), "5", 1.0),
        ShapeError,
        r"got the string mean='5'",
    ),
    (
        "PriorFactor noise '1' parsed",
        lambda: sr.PriorFactor.create(X(0), ONES, "1"),
        ShapeError,
        r"got the string noise='1'",
    ),
    ("PriorFactor noise True", lambda: sr.PriorFactor.create(X(0), ONES, True), ShapeError, r"noise=True"),
    (
        "PriorFactor noise 0 named",
        lambda: sr.PriorFactor.create(X(0), ONES, 0.0),
        SteamError,
        r"noise \(standard deviations\) must be positive, got noise=\[0.0",
    ),
    (
        "PriorFactor loss string",
        lambda: sr.PriorFactor.create(X(0), ONES, 1.0, loss="huber"),
        SteamError,
        r"loss must be a RobustLoss.*got loss='huber'",
    ),
    (
        "PriorFactor loss class",
        lambda: sr.PriorFactor.create(X(0), ONES, 1.0, loss=sr.Huber),
        SteamError,
        r"got loss=<class",
    ),
    (
        "OdometryFactor measured 2-D",
        lambda: sr.OdometryFactor.create(X(0), [[1], [2]], 1.0),
        ShapeError,
        r"measured must be 2 finite numbers.*\[\[1\], \[2\]\]",
    ),
    (
        "VelocityFactor measured string",
        lambda: sr.VelocityFactor.create(X(0), "ab", 1.0),
        ShapeError,
        r"got the string measured='ab'",
    ),
    (
        "RangeFactor measured string",
        lambda: sr.RangeFactor.create(X(0), L(0), "5", 0.3),
        ShapeError,
        r"got the string measured='5'",
    ),
    ("RangeFactor measured True", lambda: sr.RangeFactor.create(X(0), L(0), True, 0.3), ShapeError, r"measured=True"),
    (
        "RangeFactor measured [[5]]",
        lambda: sr.RangeFactor.create(X(0), L(0), [[5.0]], 0.3),
        ShapeError,
        r"measured must be 1 finite number.*\[\[5.0\]\]",
    ),
    (
        "RangeFactor sigma named sigma",
        lambda: sr.RangeFactor.create(X(0), L(0), 5.0, 0.0),
        SteamError,
        r"sigma \(standard deviation\) must be positive, got sigma=0.0",
    ),
    (
        "RangeFactor sigma shape named sigma",
        lambda: sr.RangeFactor.create(X(0), L(0), 5.0, [1, 2]),
        ShapeError,
        r"sigma must be a scalar.*got shape \(2,\)",
    ),
    (
        "BearingFactor measured '1'",
        lambda: sr.BearingFactor.create(X(0), L(0), "1", 0.1),
        ShapeError,
        r"got the string measured='1'",
    ),
    (
        "BearingRangeFactor bearing list ValueError",
        lambda: sr.BearingRangeFactor.create(X(0), L(0), [1, 2], 5.0, [0.1, 0.3]),
        ShapeError,
        r"bearing must be 1 finite number.*\[1, 2\]",
    ),
    (
        "BearingRangeFactor range_ list ValueError",
        lambda: sr.BearingRangeFactor.create(X(0), L(0), 0.1, [5, 6], [0.1, 0.3]),
        ShapeError,
        r"range must be 1 finite number.*\[5, 6\]",
    ),
    (
        "BearingRangeFactor negative range named",
        lambda: sr.BearingRangeFactor.create(X(0), L(0), 0.1, -5.0, [0.1, 0.3]),
        SteamError,
        r"cannot be negative, got range=-5.0",
    ),
    (
        "InterpolatedFactor inner string",
        lambda: sr.InterpolatedFactor.create("f", X(0), X(1), 0, 1, 0.5, QC),
        SteamError,
        r"inner must be a Factor.*got inner='f'",
    ),
    (
        "InterpolatedFactor prior None",
        lambda: sr.InterpolatedFactor.create(INNER, X(0), X(1), 0, 1, 0.5, None),
        ShapeError,
        r"prior must be a LinearSDE or Qc.*None",
    ),
    (
        "InterpolatedFactor prior string",
        lambda: sr.InterpolatedFactor.create(INNER, X(0), X(1), 0, 1, 0.5, "abc"),
        ShapeError,
        r"prior must be .*'abc'",
    ),
    (
        "InterpolatedFactor t1='0'",
        lambda: sr.InterpolatedFactor.create(INNER, X(0), X(1), "0", 1, 0.5, QC),
        SteamError,
        r"got t1='0'",
    ),
    (
        "gp_prior_factors keys generator",
        lambda: sr.gp_prior_factors((X(i) for i in range(3)), [0, 1], QC),
        ShapeError,
        r"3 keys, times of shape \(2,\)",
    ),
    (
        "gp_prior_factors times string",
        lambda: sr.gp_prior_factors(KEYS, "ab", QC),
        ShapeError,
        r"got the string times='ab'",
    ),
    (
        "gp_prior_factors times -inf blamed dt",
        lambda: sr.gp_prior_factors(KEYS, [-np.inf, 0], QC),
        ShapeError,
        r"times\[0\] = -inf",
    ),
    (
        "gp_prior_factors prior string",
        lambda: sr.gp_prior_factors(KEYS, [0, 1], "abc"),
        ShapeError,
        r"prior must be .*'abc'",
    ),
    # --- losses, keys, values -----------------------------------------------------------------------
    ("Huber k='1'", lambda: sr.Huber("1"), SteamError, r"Huber threshold: k must be a real number, got k='1'"),
    ("Huber k=None", lambda: sr.Huber(None), SteamError, r"got k=None"),
    ("Huber k=True", lambda: sr.Huber(True), SteamError, r"got k=True"),
    ("Huber k=inf", lambda: sr.Huber(np.inf), SteamError, r"k must be a finite number, got k=inf"),
    ("Tukey c=inf gave NaN cost", lambda: sr.Tukey(np.inf), SteamError, r"c must be a finite number, got c=inf"),
    ("Tukey c=[1]", lambda: sr.Tukey([1]), SteamError, r"got c=\[1\]"),
    ("X(1.5) truncated", lambda: X(1.5), SteamError, r"X takes an integer index, got 1.5"),
    ("X(True)", lambda: X(True), SteamError, r"got True"),
    # sr.Key is public: a key made by hand followed X's rules for nothing (x1.5, xTrue, a 2**70 index, a symbol 'xx')
    ("Key('x', 1.5)", lambda: sr.Key("x", 1.5), SteamError, r"Key takes an integer index, got 1.5"),
    ("Key('x', True)", lambda: sr.Key("x", True), SteamError, r"Key takes an integer index, got True"),
    ("Key('x', 2**70)", lambda: sr.Key("x", 2**70), SteamError, r"Key takes an index of magnitude below 2\*\*56"),
    ("Key('xx', 1)", lambda: sr.Key("xx", 1), SteamError, r"a key's symbol is one character of 8 bits .*got 'xx'"),
    ("Key(0, 1)", lambda: sr.Key(0, 1), SteamError, r"a key's symbol is one character of 8 bits .*got 0"),
    ("L('a')", lambda: L("a"), SteamError, r"L takes an integer index, got 'a'"),
    ("X(nan)", lambda: X(np.nan), SteamError, r"got nan"),
    (
        "Values value string",
        lambda: sr.Values({X(0): "abc"}),
        ShapeError,
        r"estimate of x0 must be a vector of numbers, got 'abc'",
    ),
    ("Values(5)", lambda: sr.Values(5), SteamError, r"got 5"),
    (
        "Values.retract wrong size broadcast",
        lambda: sr.Values({X(0): ONES}).retract({X(0): np.zeros(5)}),
        ShapeError,
        r"update of x0 has shape \(5,\)",
    ),
    (
        "Values.stack mixed sizes",
        lambda: sr.Values({X(0): ONES, L(0): np.zeros(2)}).stack([X(0), L(0)]),
        ShapeError,
        r"sizes \[2, 6\]",
    ),
    # --- orderings and the linear system ------------------------------------------------------------
    (
        "make_ordering xl dims missing KeyError",
        lambda: make_ordering("xl", KEYS, {X(0): 6}, []),
        UnknownVariableError,
        r"dims gives no size for variable x1",
    ),
    (
        "make_ordering amd dims missing",
        lambda: make_ordering("amd", KEYS, {X(0): 6}, [KEYS]),
        UnknownVariableError,
        r"x1",
    ),
    (
        "make_ordering amd factor names unknown KeyError",
        lambda: make_ordering("amd", KEYS, DIMS, [(X(0), X(5))]),
        UnknownVariableError,
        r"factor_keys\[0\] = \(x0, x5\) names x5",
    ),
    (
        "make_ordering keys strings",
        lambda: make_ordering("xl", ["x0"], {"x0": 6}, []),
        SteamError,
        r"keys\[0\] = 'x0' is not a variable key",
    ),
    (
        "make_ordering size 0 accepted",
        lambda: make_ordering("xl", KEYS, {X(0): 0, X(1): 6}, []),
        ShapeError,
        r"size of variable x0 .* positive integer, got 0",
    ),
    (
        "make_ordering size 2.5 accepted",
        lambda: make_ordering("natural", KEYS, {X(0): 2.5, X(1): 6}, []),
        ShapeError,
        r"got 2.5",
    ),
    (
        "make_ordering Ordering lacking a key",
        lambda: make_ordering(Ordering((X(0),), (6,)), KEYS, DIMS, []),
        UnknownVariableError,
        r"lacks variable x1",
    ),
    (
        "make_ordering Ordering with a wrong size",
        lambda: make_ordering(Ordering(tuple(KEYS), (3, 6)), KEYS, DIMS, []),
        ShapeError,
        r"x0 of size 3, its estimate has size 6",
    ),
    (
        "make_ordering Ordering with an extra key",
        lambda: make_ordering(Ordering((*KEYS, X(2)), (6, 6, 6)), KEYS, DIMS, []),
        UnknownVariableError,
        r"has variable x2, which is not among",
    ),
    ("Ordering one size short", lambda: Ordering(tuple(KEYS), (6,)), ShapeError, r"2 keys, 1 dims"),
    (
        "constrained_min_degree repeated variable dropped",
        lambda: constrained_min_degree([X(0), X(0), X(1)], DIMS, [KEYS]),
        SteamError,
        r"variables lists x0 twice",
    ),
    (
        "constrained_min_degree last unknown ignored",
        lambda: constrained_min_degree(KEYS, DIMS, [KEYS], last=[X(7)]),
        UnknownVariableError,
        r"last names x7",
    ),
    (
        "constrained_min_degree last a single key",
        lambda: constrained_min_degree(KEYS, DIMS, [KEYS], last=X(0)),
        SteamError,
        r"single key x0: write \[x0\]",
    ),
    (
        "constrained_min_degree factor_keys flat",
        lambda: constrained_min_degree(KEYS, DIMS, tuple(KEYS)),
        UnknownVariableError,
        r"factor_keys\[0\] = x0 names 'x'",
    ),
    (
        "LinearSystem ordering size overlaps columns",
        lambda: LinearSystem.build(*two_states(), Ordering(tuple(KEYS), (3, 6))),
        ShapeError,
        r"ordering gives variable x0 size 3, its factors' blocks have 6 columns",
    ),
    (
        "LinearSystem ordering a string",
        lambda: LinearSystem.build(*two_states(), "amd"),
        SteamError,
        r"ordering must be an Ordering.*got ordering='amd'",
    ),
    (
        "LinearSystem a non-factor",
        lambda: LinearSystem.build([*two_states()[0], "f"], two_states()[1], Ordering(tuple(KEYS), (6, 6))),
        SteamError,
        r"factors\[2\] is a str \('f'\), not a Factor",
    ),
    (
        "SparseCholesky not square (CholmodError)",
        lambda: SparseCholesky.factor(info(np.ones((12, 11))), Ordering(tuple(KEYS), (6, 6))),
        ShapeError,
        r"must be square \(12, 12\).*got shape \(12, 11\)",
    ),
    (
        "SparseCholesky not symmetric",
        lambda: SparseCholesky.factor(info(UPPER), Ordering(tuple(KEYS), (6, 6)), "superlu"),
        SteamError,
        r"not symmetric: entry \(1, 0\) = 0.0 but \(0, 1\) = 1.0",
    ),
    (
        "SparseCholesky wrong size",
        lambda: SparseCholesky.factor(info(np.eye(5)), Ordering(tuple(KEYS), (6, 6))),
        ShapeError,
        r"got shape \(5, 5\)",
    ),
    (
        "SparseCholesky NaN",
        lambda: SparseCholesky.factor(info(np.full((12, 12), np.nan)), Ordering(tuple(KEYS), (6, 6))),
        NumericalError,
        r"NaN or inf in column 0, of variable x0",
    ),
    (
        "SparseCholesky.solve wrong length",
        lambda: SparseCholesky.factor(info(SYMMETRIC_PD), Ordering(tuple(KEYS), (6, 6)), "superlu").solve(np.ones(5)),
        ShapeError,
        r"rhs .*\(12,\).*got shape \(5,\)",
    ),
    # --- graph, batch, covariance ------------------------------------------------------------------
    (
        "FactorGraph.add(5)",
        lambda: sr.FactorGraph().add(5),
        SteamError,
        r"factors must be a factor or an iterable of factors, got factors=5",
    ),
    ("FactorGraph(None)", lambda: sr.FactorGraph(None), SteamError, r"got factors=None"),
    (
        "FactorGraph.add names the position",
        lambda: sr.FactorGraph().add([two_states()[0][0], 3]),
        SteamError,
        r"factors\[1\] is a int \(3\)",
    ),
    (
        "check_values missing names the factor",
        lambda: sr.FactorGraph(two_states()[0]).check_values(sr.Values({X(0): ONES})),
        UnknownVariableError,
        r"factor 0 \(GPPriorFactor\) names x1, which has no estimate",
    ),
    (
        "check_values None",
        lambda: sr.FactorGraph(two_states()[0]).check_values(None),
        SteamError,
        r"values must be a Values or a mapping.*got values=None",
    ),
    (
        "marginal_covariances a single key",
        lambda: covariance.marginal_covariances(system(), X(0)),
        SteamError,
        r"keys must be a list of keys, got the single key x0: write \[x0\]",
    ),
    (
        "marginal_covariances of no system",
        lambda: covariance.marginal_covariances("A", [X(0)]),
        SteamError,
        r"system must be a LinearSystem.*got system='A'",
    ),
    (
        "solve of no system",
        lambda: linear_solve(None),
        SteamError,
        r"system must be a LinearSystem.*got system=None",
    ),
    (
        "marginal_covariances None",
        lambda: covariance.marginal_covariances(system(), None),
        SteamError,
        r"got keys=None",
    ),
    (
        "marginal_covariances strings",
        lambda: covariance.marginal_covariances(system(), ["x0"]),
        SteamError,
        r"keys\[0\] = 'x0' is not a variable key",
    ),
    (
        "sparse_joint_covariances a flat group",
        lambda: covariance.sparse_joint_covariances(*two_states(), [X(0)]),
        SteamError,
        r"groups\[0\] must be a list of keys, got the single key x0",
    ),
    # --- the Bayes tree and iSAM2 -------------------------------------------------------------------
    (
        "BayesTree.from_factors nonlinear factors AttributeError",
        lambda: sr.BayesTree.from_factors(two_states()[0], KEYS),
        SteamError,
        r"factors\[0\] is a GPPriorFactor, not a GaussianFactor",
    ),
    (
        "BayesTree.from_factors ordering a string",
        lambda: sr.BayesTree.from_factors(gaussian(), "x0"),
        SteamError,
        r"ordering must be a list of variable keys, got ordering='x0'",
    ),
    (
        "BayesTree.from_factors extra key KeyError",
        lambda: sr.BayesTree.from_factors(gaussian(), [*KEYS, X(2)]),
        UnderdeterminedError,
        r"variable x2 of the ordering is named by no factor",
    ),
    (
        "IncrementalSolver params string",
        lambda: sr.IncrementalSolver("fast"),
        SteamError,
        r"params must be an ISAM2Params or None, got params='fast'",
    ),
    (
        "update(None)",
        lambda: solver().update(None),
        SteamError,
        r"new_factors must be a factor or an iterable of factors, got new_factors=None",
    ),
    (
        "update names the non-factor",
        lambda: solver().update([sr.PriorFactor.create(X(2), ONES, 1.0), 3]),
        SteamError,
        r"new_factors\[1\] is a int \(3\)",
    ),
    (
        "update values a list of pairs",
        lambda: solver().update([sr.PriorFactor.create(X(2), ONES, 1.0)], [(X(2), ONES)]),
        SteamError,
        r"new_values must be a mapping.*got \[\(x2",
    ),
    (
        "update values key a string",
        lambda: solver().update([], {"x2": ONES}),
        SteamError,
        r"new_values has the key 'x2', which is not a variable key",
    ),
    (
        "update value 2-D flattened",
        lambda: solver().update([sr.PriorFactor.create(X(2), ONES, 1.0)], {X(2): np.ones((2, 3))}),
        ShapeError,
        r"new_values\[x2\] must be a non-empty 1-D vector, got shape \(2, 3\)",
    ),
    (
        "update value empty blamed as unconstrained",
        lambda: solver().update([], {X(2): np.zeros(0)}),
        ShapeError,
        r"new_values\[x2\] .*got shape \(0,\)",
    ),
    (
        "update value string",
        lambda: solver().update([], {X(2): "abc"}),
        ShapeError,
        r"new_values\[x2\] must be an array of numbers.*'abc'",
    ),
    (
        "update relinearize string",
        lambda: solver().update([], relinearize="no"),
        SteamError,
        r"relinearize must be True or False, got relinearize='no'",
    ),
    (
        "estimate_of a list",
        lambda: solver().estimate_of([X(0)]),
        SteamError,
        r"key must be a variable key.*got key=\[x0\]",
    ),
    ("marginal_covariance a list", lambda: solver().marginal_covariance([X(0)]), SteamError, r"got key=\[x0\]"),
    (
        "joint_covariance a single key",
        lambda: solver().joint_covariance(X(0)),
        SteamError,
        r"got the single key x0: write \[x0\]",
    ),
    (
        "joint_covariances a flat group",
        lambda: solver().joint_covariances([X(0)]),
        SteamError,
        r"groups\[0\] must be a list of keys",
    ),
    (
        "IncrementalSolver.marginal_covariances a single key",
        lambda: solver().marginal_covariances(X(0)),
        SteamError,
        r"single key x0",
    ),
    (
        "ISAM2Params threshold '0.1' parsed",
        lambda: sr.ISAM2Params(relinearize_threshold="0.1"),
        SteamError,
        r"relinearize_threshold must be a number >= 0, got '0.1'",
    ),
    (
        "ISAM2Params skip inf OverflowError",
        lambda: sr.ISAM2Params(relinearize_skip=np.inf),
        SteamError,
        r"relinearize_skip must be a positive integer, got inf",
    ),
    ("ISAM2Params skip nan ValueError", lambda: sr.ISAM2Params(relinearize_skip=np.nan), SteamError, r"got nan"),
    ("ISAM2Params skip 2.0", lambda: sr.ISAM2Params(relinearize_skip=2.0), SteamError, r"got 2.0"),
    (
        "ISAM2Params blocks with a bool",
        lambda: sr.ISAM2Params(relinearize_blocks={"x": (True, 5)}),
        SteamError,
        r"relinearize_blocks\['x'\] must be positive integer block sizes, got \(True, 5\)",
    ),
    (
        "ISAM2Params blocks keyed by an int (never matched)",
        lambda: sr.ISAM2Params(relinearize_blocks={3: (3, 3)}),
        SteamError,
        r"a key of relinearize_blocks \(a key's symbol.*got 3$",
    ),
    (
        "ISAM2Params thresholds keyed by a symbol no key can have (never matched)",
        lambda: sr.ISAM2Params(relinearize_threshold={"x": 0.1, "xx": 0.5}),
        SteamError,
        r"a key of relinearize_threshold \(a key's symbol.*\) is one character of 8 bits .*got 'xx'",
    ),
    (
        "ISAM2Params blocks keyed by a symbol no key can have (never matched)",
        lambda: sr.ISAM2Params(relinearize_blocks={"pose": (3, 3)}),
        SteamError,
        r"a key of relinearize_blocks \(a key's symbol.*\) is one character of 8 bits .*got 'pose'",
    ),
    (
        "ISAM2Params thresholds keyed by an int (never matched)",
        lambda: sr.ISAM2Params(relinearize_threshold={3: 0.1}),
        SteamError,
        r"a key of relinearize_threshold \(a key's symbol.*got 3$",
    ),
    # --- trajectory, results, dead_reckoning -----------------------------------------------------------------
    (
        "Trajectory states unsorted gave a wrong span",
        lambda: trajectory(states=[1, 0]),
        SteamError,
        r"states must increase strictly, but states\[0\] = 1 and states\[1\] = 0",
    ),
    (
        "Trajectory states beyond times IndexError",
        lambda: trajectory(states=[0, 5]),
        SteamError,
        r"states names pose 5, but times has 2 poses",
    ),
    (
        "Trajectory states floats IndexError",
        lambda: trajectory(states=[0.0, 1.0]),
        SteamError,
        r"states must be pose indices.*\[0.0, 1.0\]",
    ),
    ("Trajectory times NaN", lambda: trajectory(times=np.array([0.0, np.nan])), ShapeError, r"times\[1\] = nan"),
    (
        "Trajectory times decreasing",
        lambda: trajectory(times=np.array([1.0, 0.0])),
        SteamError,
        r"times must not decrease, but times\[0\] = 1.0 and times\[1\] = 0.0",
    ),
    (
        "Trajectory prior of another state size blamed x1",
        lambda: trajectory(prior=WNOJ),
        ShapeError,
        r"prior has states of 9 numbers, the solver's x1 has shape \(6,\)",
    ),
    ("Trajectory prior None", lambda: trajectory(prior=None), ShapeError, r"prior must be a LinearSDE or Qc"),
    ("Trajectory.at('abc')", lambda: trajectory().at("abc"), SteamError, r"t must be a real number, got t='abc'"),
    ("Trajectory.at('0.5') parsed", lambda: trajectory().at("0.5"), SteamError, r"got t='0.5'"),
    ("Trajectory.at(True)", lambda: trajectory().at(True), SteamError, r"got t=True"),
    (
        "Trajectory.at covariance='yes'",
        lambda: trajectory().at(0.5, covariance="yes"),
        SteamError,
        r"covariance must be True or False, got covariance='yes'",
    ),
    (
        "Trajectory.covariances of a state reshaped silently",
        lambda: trajectory().covariances([X(0)]),
        ShapeError,
        r"landmarks names x0, a variable of size 6",
    ),
    (
        "Trajectory.covariances a single key",
        lambda: trajectory().covariances(L(0)),
        SteamError,
        r"landmarks must be a list of keys, got the single key l0",
    ),
    (
        "position_rmse broadcast silently",
        lambda: position_rmse(np.zeros((3, 2)), np.zeros((1, 2))),
        ShapeError,
        r"same shape, got \(3, 2\) and \(1, 2\)",
    ),
    (
        "position_rmse 1-D AxisError",
        lambda: position_rmse(np.zeros(3), np.zeros(3)),
        ShapeError,
        r"positions must be \(n, 2\).*got shape \(3,\)",
    ),
    (
        "position_rmse empty gave NaN",
        lambda: position_rmse(np.zeros((0, 2)), np.zeros((0, 2))),
        ShapeError,
        r"got shape \(0, 2\)",
    ),
    (
        "position_rmse NaN",
        lambda: position_rmse(np.full((2, 2), np.nan), np.zeros((2, 2))),
        ShapeError,
        r"positions\[0, 0\] = nan",
    ),
    (
        "compose pose of 2",
        lambda: dead_reckoning.compose([1, 2], 1.0, 0.0),
        ShapeError,
        r"pose must be \(3,\).*got shape \(2,\)",
    ),
    (
        "compose distance NaN",
        lambda: dead_reckoning.compose([1, 2, 0], np.nan, 0.0),
        SteamError,
        r"distance must be a finite number, got distance=nan",
    ),
    (
        "integrate_odometry (3, 2) reshaped silently",
        lambda: dead_reckoning.integrate_odometry([0, 0, 0, 0], np.ones((3, 2))),
        ShapeError,
        r"odometry must be \(n, 3\).*got shape \(3, 2\)",
    ),
    (
        "integrate_odometry NaN",
        lambda: dead_reckoning.integrate_odometry([0, 0, 0, 0], np.full((2, 3), np.nan)),
        ShapeError,
        r"odometry\[0, 0\] = nan",
    ),
    (
        "integrate_odometry start NaN",
        lambda: dead_reckoning.integrate_odometry([0, np.nan, 0, 0], np.ones((2, 3))),
        ShapeError,
        r"start\[1\] = nan",
    ),
    # --- plot --------------------------------------------------------------------------------------
    (
        "plot_state_samples 2-D IndexError",
        lambda: plot.plot_state_samples([0, 1], np.zeros((2, 6)), path=PNG),
        ShapeError,
        r"samples must be a non-empty 3-d array, got shape \(2, 6\)",
    ),
    (
        "plot_matrix 1-D",
        lambda: plot.plot_matrix(np.ones(3), path=PNG),
        ShapeError,
        r"M must be a non-empty 2-d array, got shape \(3,\)",
    ),
    ("plot_sparsity empty", lambda: plot.plot_sparsity(np.zeros((0, 0)), path=PNG), ShapeError, r"got shape \(0, 0\)"),
    (
        "plot_interpolation lengths differ",
        lambda: plot.plot_interpolation([0, 1, 2], [0, 1], [1, 1], path=PNG),
        ShapeError,
        r"lengths 3, 2, 2",
    ),
    (
        "plot_trajectory (n, 3) drawn silently",
        lambda: plot.plot_trajectory(None, np.zeros((4, 3)), path=PNG),
        ShapeError,
        r"estimate_xy must be a non-empty \(n, 2\) array, got shape \(4, 3\)",
    ),
    (
        "plot_trajectory landmarks (k, 3) reshaped silently",
        lambda: plot.plot_trajectory(None, np.zeros((4, 2)), landmarks_true=np.ones((2, 3)), path=PNG),
        ShapeError,
        r"landmarks_true .*got shape \(2, 3\)",
    ),
    (
        "plot_timing a run without cumulative_s",
        lambda: plot.plot_timing({"a": 3}, path=PNG),
        SteamError,
        r"runs\['a'\] has no 'cumulative_s'",
    ),
    (
        "plot_fidelity 2-D",
        lambda: plot.plot_fidelity({"a": np.zeros((2, 2))}, path=PNG),
        ShapeError,
        r"distances\['a'\]",
    ),
    (
        "draw_spy highlight unknown KeyError",
        lambda: plot.draw_spy(solver().tree, highlight=[X(9)], path=PNG),
        UnknownVariableError,
        r"highlight names x9",
    ),
    # --- kinds: a variable's manifold, from its factors -----------------------------------------------
    (
        "Values kind not a Manifold",
        lambda: sr.Values({X(0): ONES}, kinds={X(0): "se2"}),
        SteamError,
        r"the kind of x0 must be a Manifold .*got 'se2'",
    ),
    (
        "Values SE(2) kind on a 3-vector accepted until the first retract",
        lambda: sr.Values({X(0): np.zeros(3)}, kinds={X(0): SE2_STATE}),
        ShapeError,
        r"the estimate of x0 must be one SE2_STATE state \(6 numbers\), got shape \(3,\)",
    ),
    (
        "Values SE(2) heading 4.0 taken as given",
        lambda: sr.Values({X(0): np.r_[0.0, 0.0, 4.0, 0.0, 0.0, 0.0]}, kinds={X(0): SE2_STATE}),
        SteamError,
        r"the estimate of x0: the heading of an SE\(2\) pose must lie in \(-π, π\], got θ=4.0",
    ),
    (
        "gauss_newton a world velocity on an SE(2) state converged 1.25 off",
        lambda: sr.gauss_newton(
            [
                LieStatePrior.create(X(0), np.zeros(6), 0.1, group=SE2),
                sr.VelocityFactor.create(X(0), [1.0, 0.0, 0.0], 0.1),
            ],
            {X(0): np.zeros(6)},
        ),
        KindError,
        r"the kind of x0 is given twice and differs: se2 by LieStatePrior, vector by VelocityFactor",
    ),
    (
        "IncrementalSolver.update a vector kind for an SE(2) factor's state",
        lambda: sr.IncrementalSolver().update(
            [LieStatePrior.create(X(0), np.zeros(6), 0.1, group=SE2)],
            sr.Values({X(0): np.zeros(6)}, kinds={X(0): VECTOR}),
        ),
        KindError,
        r"the kind of x0 is given twice and differs: vector by its value \(Values\(kinds=\)\), se2 by its factors",
    ),
    (
        "IncrementalSolver.update constrained not a mapping",
        lambda: sr.IncrementalSolver().update(*two_states(), constrained=[X(0)]),
        SteamError,
        r"constrained must be a mapping key -> number or None, got \[x0\]",
    ),
    (
        "IncrementalSolver.update constrained rank not a number",
        lambda: sr.IncrementalSolver().update(*two_states(), constrained={X(0): "first"}),
        SteamError,
        r"the rank of x0 among the keys eliminated first must be a real number, got .*'first'",
    ),
    (
        "IncrementalSolver.update constrained rank not a number, its key not re-eliminated",
        lambda: solver().update([sr.PriorFactor.create(X(1), ONES, 1.0)], constrained={L(5): "first"}),
        SteamError,
        r"the rank of l5 among the keys eliminated first must be a real number, got .*'first'",
    ),
    (
        "IncrementalSolver.marginalize_leaves constrained rank a bool",
        lambda: solver().marginalize_leaves([X(0)], constrained={X(7): True}),
        SteamError,
        r"the rank of x7 among the keys eliminated first must be a real number, got .*True",
    ),
    (
        "IncrementalSolver.marginalize_leaves constrained not a mapping",
        lambda: solver().marginalize_leaves([X(0)], constrained=[X(1)]),
        SteamError,
        r"constrained must be a mapping key -> number or None, got \[x1\]",
    ),
    (
        "IncrementalSolver.marginalize_leaves keep_conditionals not a bool",
        lambda: solver().marginalize_leaves([X(0)], keep_conditionals="yes"),
        SteamError,
        r"keep_conditionals must be True or False, got keep_conditionals='yes'",
    ),
    (
        "FixedLagSmoother keep_history not a bool",
        lambda: sr.FixedLagSmoother(1.0, keep_history="no"),
        SteamError,
        r"keep_history must be True or False, got keep_history='no'",
    ),
    (
        "marginalize keep_conditionals not a bool",
        lambda: marginalize(solver(), [X(0)], keep_conditionals=None),
        SteamError,
        r"keep_conditionals must be True or False, got keep_conditionals=None",
    ),
    (  # an AttributeError ('NoneType' object has no attribute 'clock') from inside the readings
        "run_online setup=None",
        lambda: sr.run_online(sr.generate_synthetic(5, 2, seed=1), None),
        SteamError,
        r"setup must be a PaperSetup \(PaperSetup.synthetic\(\), .*got setup=None",
    ),
    (  # an AttributeError ('dict' object has no attribute 'layout') from the front end
        "run_online options a dict",
        lambda: sr.run_online(sr.generate_synthetic(5, 2, seed=1), sr.PaperSetup.synthetic(), {"method": "pb"}),
        SteamError,
        r"options must be a StreamOptions \(StreamOptions\(method=.*got options=\{'method': 'pb'\}",
    ),
    (  # an AttributeError ('RangeDataset' object has no attribute 'range_rows')
        "StreamingEstimator given a data set",
        lambda: StreamingEstimator(sr.generate_synthetic(5, 2, seed=1), sr.PaperSetup.synthetic(), sr.StreamOptions()),
        SteamError,
        r"readings must be a Readings \(Readings.from_dataset\(data, setup\).*got readings=RangeDataset",
    ),
    (  # accepted: a string is true, so 'no' asked for the covariances
        "run_online covariances='no'",
        lambda: sr.run_online(sr.generate_synthetic(5, 2, seed=1), sr.PaperSetup.synthetic(), covariances="no"),
        SteamError,
        r"covariances must be True or False, got covariances='no'",
    ),
    (  # an IsADirectoryError from np.savetxt, which had opened (and emptied) a file given before writing it
        "write_tum to a folder",
        lambda: sr.write_tum(tempfile.gettempdir(), [0.0], [[0.0, 0.0, 0.0]]),
        SteamError,
        rf"write_tum: cannot write {re.escape(repr(tempfile.gettempdir()))} \(Is a directory\)",
    ),
    (
        "write_kitti into a missing folder",
        lambda: evaluate.write_kitti(os.path.join(tempfile.gettempdir(), "no such folder", "a.txt"), [[0.0, 0.0, 0.0]]),
        SteamError,
        r"write_kitti: cannot write .*no such folder/a\.txt' \(No such file or directory\)",
    ),
]


@pytest.mark.parametrize(("call", "error", "message"), [pytest.param(c, e, m, id=i) for i, c, e, m in CASES])
def test_bad_input_raises_the_named_error(call, error, message):
    with pytest.raises(error, match=message):
        call()


def test_every_case_is_tried_once():
    ids = [case[0] for case in CASES]
    assert len(ids) == len(set(ids))


# --- what is accepted (so the checks above are not too strict) ---------------------------------------


def test_what_is_accepted_still_works():
    """Integers and NumPy scalars for numbers, lists for arrays, mappings for Values, any iterable of
    factors or keys, 0-d arrays for numbers: each gives the same answer as the canonical form."""
    np.testing.assert_array_equal(gp.process_noise(np.int64(2), QC.tolist()), gp.process_noise(2.0, QC))
    np.testing.assert_array_equal(gp.transition(np.array(0.5), np.int64(3)), gp.transition(0.5, 3))
    np.testing.assert_array_equal(gp.transition(-1.0, 3)[:3, 3:], -np.eye(3))  # Φ(t, s) for s > t is fine
    assert sr.Huber(2) == sr.Huber(2.0) and sr.Tukey(np.float32(15)).c == 15.0
    assert X(np.int64(3)) == X(3) and X(-1).index == -1
    factors, values = two_states()
    result = sr.gauss_newton(iter(factors), {k: values[k] for k in values})  # an iterable, a dict
    assert result.converged
    assert sr.RangeFactor.create(X(0), L(0), 0, 1).measured[0] == 0.0  # a zero range is a reading
    assert sr.BearingRangeFactor.create(X(0), L(0), 0.1, np.array(5.0), [0.1, 0.3]).measured.tolist() == [0.1, 5.0]
    s = solver()
    assert s.joint_covariance([]).shape == (0, 0)  # the joint of no variable
    np.testing.assert_array_equal(covariance.sparse_joint_covariance(factors, values, []), np.zeros((0, 0)))
    dup = s.joint_covariance([X(0), X(0)])  # a repeated key repeats its block: [[P, P], [P, P]]
    np.testing.assert_allclose(dup[:6, :6], dup[6:, :6])
    np.testing.assert_allclose(
        s.joint_covariance(k for k in KEYS),
        covariance.sparse_joint_covariance(factors, values, KEYS),
        atol=1e-9,
    )
    assert LinearSystem.build([], values, Ordering(tuple(KEYS), (6, 6))).A.shape == (0, 12)


# --- a failed update leaves the solver exactly as it was ---------------------------------------------


def chain_step(i: int) -> tuple[list[sr.Factor], dict]:
    """State i of a WNOA chain 1 s apart, with a velocity reading and (for i > 0) its GP prior factor."""
    x = np.array([i * 1.0, 0.1 * i, 0.05 * i, 1.0, 0.1, 0.05])
    factors = [sr.VelocityFactor.create(X(i), [1.0, 0.0, 0.05], [0.5, 0.5, 1.0])]
    if i == 0:
        factors.append(sr.PriorFactor.create(X(0), x, 0.1))
    else:
        factors.append(sr.GPPriorFactor.wnoa(X(i - 1), X(i), 1.0, QC))
    factors.append(sr.RangeFactor.create(X(i), L(0), math.hypot(5.0 - x[0], 2.0 - x[1]) + 0.02 * (-1) ** i, 0.3))
    values = {X(i): x + 0.05}
    if i == 0:
        factors.append(sr.PriorFactor.create(L(0), [5.0, 2.0], 1.0))
        values[L(0)] = np.array([5.1, 1.9])
    return factors, values


def state_of(s: sr.IncrementalSolver) -> dict:
    """Everything a caller can see of a solver, copied."""
    tree = s.tree
    return {
        "estimate": {k: v.copy() for k, v in s.estimate().items()},
        "theta": {k: v.copy() for k, v in s.linearization_point.items()},
        "delta": s.delta(),
        "n_factors": len(s.factors),
        "n_variables": len(s),
        "cliques": {c: (q.frontals, q.separator, q.R.copy(), q.S.copy(), q.d.copy()) for c, q in tree.cliques.items()},
        "parents": dict(tree.parent),
        "marginals": s.marginal_covariances(),
    }


def assert_same_state(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for name in ("n_factors", "n_variables", "parents"):
        assert a[name] == b[name], name
    for name in ("estimate", "theta", "delta", "marginals"):
        assert a[name].keys() == b[name].keys(), name
        for k in a[name]:
            np.testing.assert_array_equal(a[name][k], b[name][k], err_msg=f"{name}[{k}]")
    assert a["cliques"].keys() == b["cliques"].keys()
    for c, (f, sep, R, S, d) in a["cliques"].items():
        f2, sep2, R2, S2, d2 = b["cliques"][c]
        assert (f, sep) == (f2, sep2)
        for x, y in ((R, R2), (S, S2), (d, d2)):
            np.testing.assert_array_equal(x, y)


def lonely_landmark(i: int):
    """A new landmark seen by one range: 1 equation, 2 unknowns, so elimination fails."""
    factors, values = chain_step(i)
    return factors + [sr.RangeFactor.create(X(i - 1), L(9), 4.0, 0.3)], values | {L(9): np.array([3.0, 1.0])}


def overflowing_reading(i: int):
    """A prior of sigma 1e-200 about 0 (a range of 1e200 with sigma 0.3 is refused when made: float64 cannot
    resolve it): its cost overflows when linearized away from 0."""
    factors, values = chain_step(i)
    return factors + [sr.PriorFactor.create(X(i - 1), np.zeros(6), 1e-200)], values


def overflowing_value(i: int):
    """A new state at 1e200 m: the range to it overflows."""
    factors, _ = chain_step(i)
    return factors, {X(i): np.full(6, 1e200)}


def checked_input(i: int):
    """Bad input found before anything changes: a factor on a variable with no value."""
    factors, values = chain_step(i)
    return factors + [sr.VelocityFactor.create(X(50), [1.0, 0.0, 0.0], 0.5)], values


def value_again(i: int):
    """Bad input found before anything changes: a new value for a variable the solver holds (PB and PBVR took it in
    place of their estimate)."""
    factors, values = chain_step(i)
    return factors, {**values, X(i - 1): np.zeros(6)}


@pytest.mark.parametrize(
    ("make_failure", "error"),
    [
        (lonely_landmark, UnderdeterminedError),
        (overflowing_reading, NumericalError),
        (overflowing_value, NumericalError),
        (checked_input, UnknownVariableError),
    ],
)
@pytest.mark.parametrize("relinearize_skip", [1, 2])  # with 1, the failing update also relinearizes first
def test_a_failed_update_rolls_back_exactly(make_failure, error, relinearize_skip):
    """The failing update leaves every estimate, increment, linearization point, clique and marginal
    as it was; the next good update then gives exactly what a solver that never saw it gives."""
    params = {"relinearize_threshold": 0.0, "relinearize_skip": relinearize_skip, "wildfire_threshold": 0.0}
    s, twin = sr.IncrementalSolver(**params), sr.IncrementalSolver(**params)
    for i in range(4):
        for solver_ in (s, twin):
            solver_.update(*chain_step(i))
    for k in s.estimate():  # the two agree before the failure
        np.testing.assert_array_equal(s.estimate_of(k), twin.estimate_of(k))
    before = state_of(s)
    with pytest.raises(error):
        s.update(*make_failure(4))
    assert_same_state(state_of(s), before)
    for i in (4, 5):
        report, twin_report = s.update(*chain_step(i)), twin.update(*chain_step(i))
        assert report.step == twin_report.step
    assert_same_state(state_of(s), state_of(twin))


STREAM_SOLVERS = {
    "pb": lambda: make_solver("pb"),
    "pbvr": lambda: make_solver("pbvr"),
    "btgp": lambda: make_solver("btgp"),
    "btgp-lag": lambda: make_solver("btgp", lag=2.5, times=np.arange(10.0)),
}


def stream_state(s) -> dict:
    """What a stream solver answers: every estimate, and the marginal covariance of every variable it holds (the
    fixed-lag one's window), copied."""
    estimate = s.estimate()
    held = [k for k in estimate if not isinstance(s, FixedLagTreeSolver) or s.retired(k) is None]
    return {"estimate": {k: estimate[k].copy() for k in estimate}, "marginals": s.marginal_covariances(held)}


def interrupted(i: int):
    """A good update cut short by Ctrl-C inside the solve (see solve_interrupted)."""
    return chain_step(i)


@pytest.mark.parametrize(
    ("make_failure", "error"),
    [
        (lonely_landmark, UnderdeterminedError),
        (overflowing_value, NumericalError),
        (checked_input, UnknownVariableError),
        (value_again, SteamError),
        (interrupted, KeyboardInterrupt),
    ],
)
@pytest.mark.parametrize("method", sorted(STREAM_SOLVERS))
def test_a_failed_stream_update_leaves_every_stream_solver_as_it_was(make_failure, error, method, monkeypatch):
    """PB and PBVR kept the failed update's factors and values before their Gauss-Newton ran, so one refused update
    (a landmark one range cannot place) failed every later one too; now each stream solver answers after a failed
    or interrupted update (Ctrl-C in the solve) exactly as one that never saw it, and the next good updates agree."""
    s, twin = STREAM_SOLVERS[method](), STREAM_SOLVERS[method]()
    for i in range(4):
        for solver_ in (s, twin):
            solver_.update(*as_stream_update(chain_step(i)))
    before = stream_state(s)
    if error is KeyboardInterrupt:
        solve = (
            "steam_ref.paper.solvers.gauss_newton"
            if method.startswith("pb")
            else "steam_ref.bayes_tree.isam.backsubstitute"
        )

        def ctrl_c(*args, **kwargs):
            raise KeyboardInterrupt("Ctrl-C in the solve")

        monkeypatch.setattr(solve, ctrl_c)
    with pytest.raises(error):
        s.update(*as_stream_update(make_failure(4)))
    monkeypatch.undo()
    assert_same_stream_state(stream_state(s), before)
    for i in (4, 5):
        s.update(*as_stream_update(chain_step(i)))
        twin.update(*as_stream_update(chain_step(i)))
    assert_same_stream_state(stream_state(s), stream_state(twin))


def as_stream_update(update: tuple[list, dict]) -> tuple[list, sr.Values]:
    """An update as a stream gives it: the new values a Values."""
    factors, values = update
    return factors, sr.Values(values)


def assert_same_stream_state(a: dict, b: dict) -> None:
    for name in ("estimate", "marginals"):
        assert list(a[name]) == list(b[name]), name
        for k in a[name]:
            np.testing.assert_array_equal(a[name][k], b[name][k], err_msg=f"{name}[{k}]")


# --- property tests: the GP functions never raise anything but SteamError ----------------------------

TIMES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),  # NaN, ±inf, subnormals, ±1e308
    st.floats(min_value=1e-6, max_value=1e6),  # the ordinary range, so passing calls are exercised too
    st.integers(-(10**6), 10**6),
    st.sampled_from([True, False, None, "1", [1.0], np.array([1.0, 2.0]), np.float32(0.5), np.int64(2)]),
)


def finite_or_steam_error(call) -> bool:
    """True when ``call()`` returns finite arrays (a tuple of them, or one) or raises a SteamError;
    False when it returns a NaN or inf. Any other exception propagates and fails the test."""
    try:
        out = call()
    except SteamError:
        return True
    return all(bool(np.all(np.isfinite(a))) for a in (out if isinstance(out, tuple) else (out,)))


GP_CALLS = [
    lambda dt: gp.transition(dt, 3),
    lambda dt: gp.process_noise(dt, QC),
    lambda dt: gp.process_noise_inverse(dt, QC),
    lambda dt: gp.process_noise_sqrt_information(dt, QC),
    lambda dt: gp.wnoj_transition(dt, 2),
    lambda dt: gp.wnoj_process_noise(dt, QC),
    lambda dt: gp.wnoj_process_noise_inverse(dt, QC),
    lambda dt: gp.singer_transition(dt, 0.7, 3),
    lambda dt: gp.singer_process_noise(dt, 0.7, QC),
    lambda dt: gp.singer_process_noise(1.0, dt, QC),  # dt as α
    lambda dt: WNOJ.transition(dt),
    lambda dt: WNOJ.general().process_noise(dt),
    lambda dt: LinearSDE.wnoa(QC, v=np.ones(6)).input_integral(dt),
    lambda dt: gp.extrapolate_state_sde(WNOJ, 0.0, np.ones(9), dt),
    lambda dt: gp.extrapolate_covariance_sde(WNOJ, 0.0, dt, np.eye(9)),
    lambda dt: sr.GPPriorFactor.wnoa(X(0), X(1), dt, QC).sqrt_information,
    lambda dt: sr.GPPriorFactor.from_sde(X(0), X(1), dt, LinearSDE.singer(QC, 0.3)).sqrt_information,
]


@settings(max_examples=60, deadline=None)
@given(dt=TIMES)
def test_gp_functions_of_one_time_step_give_finite_arrays_or_a_steam_error(dt):
    bad = [i for i, call in enumerate(GP_CALLS) if not finite_or_steam_error(lambda call=call: call(dt))]
    assert bad == [], f"GP_CALLS {bad} returned a non-finite array at dt={dt!r}"


@settings(max_examples=60, deadline=None)
@given(t1=TIMES, t2=TIMES, tau=TIMES)
@example(t1=-3.4028235677973366e38, t2=1.0, tau=np.float32(0.5))  # found by Hypothesis: float32 τ - t₁ overflowed
def test_interpolation_gives_finite_arrays_or_a_steam_error(t1, t2, tau):
    assert finite_or_steam_error(lambda: gp.interpolation_matrices(t1, t2, tau, QC))
    assert finite_or_steam_error(lambda: gp.interpolation_matrices_sde(WNOJ, t1, t2, tau))
    assert finite_or_steam_error(lambda: gp.interpolate_state(t1, ONES, t2, ONES, tau, QC))
    assert finite_or_steam_error(lambda: gp.interpolate_covariance(t1, t2, tau, QC, np.eye(12)))
    assert finite_or_steam_error(lambda: gp.interpolate_covariance_sde(WNOJ, t1, t2, tau, np.eye(18)))
    assert finite_or_steam_error(lambda: sr.InterpolatedFactor.create(INNER, X(0), X(1), t1, t2, tau, QC).lam)


def test_a_singer_prior_over_a_vanishing_gap_is_refused_not_infinite():
    """Hypothesis found it: Q(6.7e-63) of a Singer prior is positive definite but its inverse overflows."""
    with pytest.raises(sr.NumericalError, match="too small to invert"):
        sr.GPPriorFactor.from_sde(X(0), X(1), 6.7e-63, LinearSDE.singer(QC, 0.3))
    with pytest.raises(sr.NumericalError, match="too small to invert"):
        sr.RangeFactor.create(X(0), sr.L(0), 1.0, 1e-320)
