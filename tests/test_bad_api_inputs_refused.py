"""A sweep of bad inputs the public API and the command accepted, each now refused with the project's own exception
naming the value (the command: one line, exit code 2). Every case here passed through, or failed elsewhere with
another error, before.

- a key index of magnitude 2⁵⁶ or more (``X(2**70)``): GTSAM's Symbol has 56 bits for it (oracle: ``gtsam.Symbol``);
  negative indices are kept (``X(-1)`` is the placeholder key of an interpolated reading's inner measurement);
- a reading of a landmark with the state and landmark keys swapped (range, bearing, bearing-range, on a vector
  state, on SE(2), on any group), and a GP prior (vector or Lie) or a reading interpolated between two states on a
  key that is not a state;
- a one-element list given as a range or a bearing (one number, documented so): ``[5.0]`` is not ``5.0``;
- ``estimates_of`` given a key twice (its answer, a mapping by key, held it once);
- a sigma whose information 1/sigma² overflows float64 (``PriorFactor`` sigma 1e-300);
- ``generate_synthetic(n_steps=10**9)``: refused up front, naming n_steps and the memory it needs, not NumPy's
  bare MemoryError;
- ``run --dataset /dev/null``: "not a file (a device)", not "not found";
- ``run --qc 1e308,1e308,1e308``: refused naming --qc and the value, not "x1 is not constrained" after the run began.
"""

from __future__ import annotations

import math
import tracemalloc

import gtsam
import mpmath
import numpy as np
import pytest

import steam_ref as sr
from steam_ref import L, X
from steam_ref.bayes_tree.dot import gtsam_key
from steam_ref.cli.args import QC_SCALES
from steam_ref.cli.inputs import scaled_qc
from steam_ref.datasets import generate_synthetic, load_dataset
from steam_ref.datasets.synthetic import MAX_SYNTHETIC_BYTES, synthetic_bytes
from steam_ref.errors import DataError, NumericalError, ShapeError, SteamError
from steam_ref.factors.lie_prior import LieAccelPriorFactor, LiePriorFactor
from steam_ref.factors.lie_readings import LieInterpolatedFactor, PoseReading
from steam_ref.factors.point_readings import PointReading, RangeReading
from steam_ref.gp import LinearSDE
from steam_ref.lie import SE2, SE3
from steam_ref.paper.solvers import BayesTreeSolver, PeriodicBatchSolver
from tests.cli_runs import runner

steam_ref = runner()
QC = np.diag([0.01, 0.01, 0.25])


def _one_line(err: str) -> str:
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1, err
    assert lines[0].startswith("steam-ref: error: "), err
    return lines[0]


# --- 1. a key's index fits GTSAM's 56 bits ---------------------------------------------------------------------------


@pytest.mark.parametrize("make", [X, L])
@pytest.mark.parametrize("index", [2**70, 2**56, -(2**56), -(2**70), np.uint64(2**63)])
def test_a_key_index_past_56_bits_is_refused_by_value(make, index):
    with pytest.raises(SteamError, match=rf"{make.__name__}\({int(index)}\)") as raised:
        make(index)
    assert "2**56" in str(raised.value)


def test_gtsam_keeps_56_bits_of_index_and_the_largest_kept_key_is_gtsams():
    """GTSAM itself: Symbol('x', 2⁵⁶ - 1) is the key gtsam_key gives X(2⁵⁶ - 1); Symbol('x', 2⁵⁶) has no key."""
    top = 2**56 - 1
    assert gtsam_key(X(top)) == gtsam.Symbol("x", top).key()
    assert gtsam_key(L(top)) == gtsam.Symbol("l", top).key()
    with pytest.raises(ValueError, match="Symbol index is too large"):
        gtsam.Symbol("x", 2**56).key()


def test_negative_indices_are_kept_each_its_own_integer():
    """X(-1) is the placeholder of an interpolated reading's inner measurement (and so any negative index, down to
    -(2⁵⁶ - 1)): kept, and gtsam_key still gives X and L keys distinct integers across the whole range."""
    assert X(-1).index == -1 and X(-(2**56 - 1)).index == -(2**56 - 1)
    inner = sr.RangeFactor.create(X(-1), L(0), 4.0, 0.3)
    assert inner.keys == (X(-1), L(0))
    ends = [X(-(2**56 - 1)), X(2**56 - 1), L(-(2**56 - 1)), L(2**56 - 1)]
    assert len({gtsam_key(k) for k in ends}) == 4
    assert gtsam_key(L(2**56 - 1)) < gtsam_key(X(-(2**56 - 1)))  # the two symbols' ranges never meet


# --- 2. a reading's state and landmark in their roles; 4. a GP prior on states -------------------------------------


SWAPPED = {
    "RangeFactor": lambda s, l: sr.RangeFactor.create(s, l, 5.0, 0.1),
    "BearingFactor": lambda s, l: sr.BearingFactor.create(s, l, 0.5, 0.1),
    "BearingRangeFactor": lambda s, l: sr.BearingRangeFactor.create(s, l, 0.5, 5.0, [0.1, 0.1]),
    "PoseReading.range": lambda s, l: PoseReading.range(s, l, 5.0, 0.1, group=SE2),
    "PoseReading.bearing_range": lambda s, l: PoseReading.bearing_range(s, l, 0.5, 5.0, [0.1, 0.1], group=SE2),
    "RangeReading": lambda s, l: RangeReading.create(s, l, 5.0, 0.1, group=SE3),
    "PointReading": lambda s, l: PointReading.create(s, l, [1.0, 2.0, 3.0], 0.1, group=SE3),
}


@pytest.mark.parametrize("make", SWAPPED.values(), ids=SWAPPED.keys())
def test_a_landmark_reading_with_its_keys_swapped_is_refused_naming_both(make):
    make(X(0), L(0))  # the right way round is a reading
    with pytest.raises(SteamError, match=r"got \(l0, x0\): l0 is not a state key, x0 is not a landmark key"):
        make(L(0), X(0))
    with pytest.raises(SteamError, match=r"got \(x0, x1\): x1 is not a landmark key"):
        make(X(0), X(1))


PRIORS = {
    "GPPriorFactor.wnoa": lambda a, b: sr.GPPriorFactor.wnoa(a, b, 1.0, QC),
    "GPPriorFactor.from_sde": lambda a, b: sr.GPPriorFactor.from_sde(a, b, 1.0, LinearSDE.wnoj(QC)),
    "GPPriorFactor.from_matrices": lambda a, b: sr.GPPriorFactor.from_matrices(a, b, np.eye(2), np.eye(2)),
    "gp_prior_factors": lambda a, b: sr.gp_prior_factors([a, b], [0.0, 1.0], QC)[0],
    "LiePriorFactor": lambda a, b: LiePriorFactor.create(a, b, 1.0, QC, group=SE2),
    "LieAccelPriorFactor": lambda a, b: LieAccelPriorFactor.create(a, b, 1.0, LinearSDE.wnoj(QC), group=SE2),
    "InterpolatedFactor": lambda a, b: sr.InterpolatedFactor.create(
        sr.RangeFactor.create(X(-1), L(7), 3.0, 0.5), a, b, 0.0, 1.0, 0.5, QC
    ),
    "LieInterpolatedFactor": lambda a, b: LieInterpolatedFactor.create(
        PoseReading.range(X(-1), L(7), 3.0, 0.5, group=SE2), a, b, 0.0, 1.0, 0.5, QC, group=SE2
    ),
}


@pytest.mark.parametrize("make", PRIORS.values(), ids=PRIORS.keys())
def test_a_motion_prior_on_a_key_that_is_not_a_state_is_refused_naming_it(make):
    make(X(0), X(1))
    with pytest.raises(SteamError, match=r"got \(l0, l1\): l0 is not a state key, l1 is not a state key"):
        make(L(0), L(1))
    with pytest.raises(SteamError, match=r"got \(x0, l1\): l1 is not a state key"):
        make(X(0), L(1))


# --- 3. one number where one is documented --------------------------------------------------------------------------


ONE_NUMBER = {
    "RangeFactor measured": lambda v: sr.RangeFactor.create(X(0), L(0), v, 0.1),
    "BearingFactor measured": lambda v: sr.BearingFactor.create(X(0), L(0), v, 0.1),
    "BearingRangeFactor bearing": lambda v: sr.BearingRangeFactor.create(X(0), L(0), v, 5.0, [0.1, 0.1]),
    "BearingRangeFactor range_": lambda v: sr.BearingRangeFactor.create(X(0), L(0), 0.5, v, [0.1, 0.1]),
    "PoseReading.range measured": lambda v: PoseReading.range(X(0), L(0), v, 0.1, group=SE2),
    "RangeReading measured": lambda v: RangeReading.create(X(0), L(0), v, 0.1, group=SE3),
}


@pytest.mark.parametrize("make", ONE_NUMBER.values(), ids=ONE_NUMBER.keys())
def test_a_one_element_list_given_as_one_number_is_refused(make):
    for scalar in (5.0, 5, np.float32(5.0), np.array(5.0)):  # a number, in each accepted form
        factor = make(scalar)
        assert 5.0 in getattr(factor, "inner", factor).measured
    for listed in ([5.0], np.array([5.0]), (5.0,)):
        with pytest.raises(ShapeError, match=r"must be 1 finite number \(a scalar, not a sequence\), got \[5\.0\]"):
            make(listed)


# --- 5. estimates_of: each key once ----------------------------------------------------------------------------------


def _two_states() -> tuple[list[sr.Factor], sr.Values]:
    factors = sr.gp_prior_factors([X(0), X(1)], [0.0, 1.0], QC) + [sr.PriorFactor.create(X(0), np.zeros(6), 1.0)]
    return factors, sr.Values({X(0): np.zeros(6), X(1): np.ones(6)})


@pytest.mark.parametrize("make", [sr.IncrementalSolver, BayesTreeSolver, PeriodicBatchSolver])
def test_estimates_of_a_key_given_twice_is_refused_naming_it(make):
    solver = make()
    solver.update(*_two_states())
    once = solver.estimates_of([X(0), X(1)])
    np.testing.assert_array_equal(once[X(1)], solver.estimate_of(X(1)))
    with pytest.raises(SteamError, match=r"keys names x0 twice \(keys\[0\] and keys\[2\]\)"):
        solver.estimates_of([X(0), X(1), X(0)])


# --- 6. a noise model whose information overflows ---------------------------------------------------------------------


@pytest.mark.parametrize("sigma", [1e-300, 1e-160, [1.0, 1.0, 1.0, 1.0, 1.0, 1e-200]])
def test_a_sigma_whose_information_overflows_is_refused_naming_it(sigma):
    smallest = mpmath.mpf(float(np.min(sigma)))  # the information 1/sigma², exactly: past float64's largest number,
    assert 1 / smallest**2 > np.finfo(float).max and 1 / smallest < np.finfo(float).max  # the weight 1/sigma is not
    with pytest.raises(NumericalError, match=r"information.*overflows.*noise=.*e-[0-9]{3}"):
        sr.PriorFactor.create(X(0), np.zeros(6), sigma)


def test_the_smallest_sigmas_whose_information_is_finite_are_kept():
    """1/sigma² just below float64's largest number: kept, its weight exact."""
    sigma = 1e-154  # information 1e308
    assert math.isfinite(1.0 / sigma**2)
    W = sr.PriorFactor.create(X(0), np.zeros(6), sigma).sqrt_information
    np.testing.assert_array_equal(W, np.eye(6) / sigma)
    cov = sr.PriorFactor.create(X(0), np.zeros(2), 1e-300 * np.eye(2)).sqrt_information  # information 1e300
    np.testing.assert_allclose(cov.T @ cov, 1e300 * np.eye(2), rtol=1e-14)
    with pytest.raises(NumericalError, match="noise="):
        sr.PriorFactor.create(X(0), np.zeros(2), 1e-310 * np.eye(2))


@pytest.mark.parametrize("sigma", [1e200, 7e153, [1.0, 1.0, 1.0, 1.0, 1.0, 1e160]])
def test_a_sigma_whose_information_underflows_is_refused_naming_it(sigma):
    largest = mpmath.mpf(float(np.max(sigma)))  # the information 1/sigma², exactly: below float64's smallest normal
    assert 1 / largest**2 < np.finfo(float).tiny
    with pytest.raises(NumericalError, match=r"information.*underflows.*noise=.*e\+[0-9]{3}"):
        sr.PriorFactor.create(X(0), np.zeros(6), sigma)


def test_the_largest_sigmas_whose_information_is_normal_are_kept():
    """1/sigma² just above float64's smallest normal number: kept, its weight exact; a covariance of 1e300 too."""
    sigma = 6.5e153
    assert 1 / mpmath.mpf(sigma) ** 2 > np.finfo(float).tiny
    W = sr.PriorFactor.create(X(0), np.zeros(6), sigma).sqrt_information
    np.testing.assert_array_equal(W, np.eye(6) / sigma)
    cov = sr.PriorFactor.create(X(0), np.zeros(2), 1e300 * np.eye(2)).sqrt_information  # information 1e-300
    np.testing.assert_allclose(cov.T @ cov, 1e-300 * np.eye(2), rtol=1e-14)


# --- 7. a generated task past the memory ceiling ----------------------------------------------------------------------


@pytest.mark.parametrize("past_the_edge", [False, True])
def test_a_synthetic_task_past_the_memory_ceiling_is_refused_up_front(past_the_edge):
    """10**9 steps (NumPy's bare MemoryError before), and the first count past the ceiling."""
    edge = next(
        n for n in range(MAX_SYNTHETIC_BYTES // 300 - 100_000, 10**9) if synthetic_bytes(n, 298) > MAX_SYNTHETIC_BYTES
    )
    n_steps = edge if past_the_edge else 10**9
    assert synthetic_bytes(edge - 1, 298) <= MAX_SYNTHETIC_BYTES
    need = synthetic_bytes(n_steps, 298)
    assert need > MAX_SYNTHETIC_BYTES
    with pytest.raises(SteamError, match=rf"n_steps={n_steps}, .*about {need / 1e9:.3g} GB"):
        generate_synthetic(n_steps=n_steps)


@pytest.mark.parametrize(("n_steps", "n_landmarks"), [(20_000, 10), (2_000, 20_000), (5_000, 298)])
def test_the_memory_estimate_bounds_the_generators_peak(n_steps, n_landmarks):
    """tracemalloc's peak of a real generation (NumPy's arrays included) is under the estimate, and the estimate
    is not far above it (so the ceiling refuses what would truly be too big)."""
    tracemalloc.start()
    try:
        generate_synthetic(n_steps, n_landmarks)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak <= synthetic_bytes(n_steps, n_landmarks) <= 3 * peak


# --- 8. a data set path that is not a regular file ---------------------------------------------------------------------


def test_a_device_as_the_data_set_is_not_a_file_not_not_found(capsys):
    with pytest.raises(DataError, match=r"/dev/null: not a file \(a device\)"):
        load_dataset("/dev/null")
    code, out, err = steam_ref(capsys, "run", "--dataset", "/dev/null", "--preset", "plaza")
    line = _one_line(err)
    assert code == 2 and out == ""
    assert "/dev/null: not a file (a device)" in line and "not found" not in line


# --- 9. --qc beyond what float64 resolves beside the readings -----------------------------------------------------------


def test_a_qc_of_1e308_is_refused_naming_qc_before_the_run(capsys):
    code, out, err = steam_ref(capsys, "run", "--qc", "1e308,1e308,1e308", "--max-poses", 20)
    line = _one_line(err)
    assert code == 2 and out == ""
    assert "--qc 1e+308,1e+308,1e+308" in line and "not constrained" not in line


def test_scaled_qc_keeps_the_run_within_qc_scales_of_the_preset():
    """The bound is QC_SCALES times the preset's diagonal, either way, whether reached by --qc or --qc-scale."""
    low, high = QC_SCALES
    np.testing.assert_array_equal(scaled_qc(QC, None, high), high * QC)  # the preset's times the largest scale
    at_edge = list(high * np.diag(QC))
    np.testing.assert_array_equal(scaled_qc(QC, at_edge, 1.0), np.diag(at_edge))
    for given, factor in ((list(2 * high * np.diag(QC)), 1.0), (list(np.diag(QC)), 2 * high), ([1e-3] * 3, low)):
        with pytest.raises(SteamError, match=r"--qc .* times --qc-scale .* beyond 1e-08 to 1e\+08 times the preset"):
            scaled_qc(QC, given, factor)
