"""Options and numbers blamed on what the user gave: the weak classes of the bad-input sweep.

- ``--qc-scale`` and ``--singer-time-constant``: outside the range float64 resolves (1e-8..1e8 and
  1e-6..1e8 s) refused naming the option, before any run; inside it, accepted. ``--singer-time-constant``
  with another prior is refused, not ignored. ``conformance selftest/build --data-dir`` must exist.
- A reading float64 cannot resolve to its sigma is refused when its factor is made, naming it: a bearing
  of 1e17 rad, a range of 1e200 m, a prior (a landmark covariance of 1e-300) tighter than its mean's
  float spacing. The oracle is ``math.ulp`` against the sigma. A sigma whose information 1/sigma² overflows
  float64 (below about 1e-154; mpmath the oracle) is refused before, as a NumericalError.
- Huber and Tukey refuse a threshold whose square (which ρ holds) overflows or underflows.
- iSAM2's elimination breaking down on an ill-conditioned problem says so as GN/LM do.
- ``--converge-at-end`` with one 1e300 m range: refused when the readings are made, one line, no
  numpy RuntimeWarning.
"""

from __future__ import annotations

import math
import warnings

import mpmath
import numpy as np
import pytest
import scipy.io
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import steam_ref as sr
from steam_ref.cli import commands as cli
from steam_ref.datasets import generate_synthetic, load_gtsam_2d
from steam_ref.errors import NumericalError, SteamError


def _never(*args, **kwargs):
    raise AssertionError("the run started although the input was bad")


class Reached(Exception):
    pass


def _reached(*args, **kwargs):
    raise Reached


def _run(capsys, argv: list[str]) -> tuple[int | None, str]:
    try:
        code = cli.main(argv)
    except Reached:
        code = None
    return code, capsys.readouterr().err


NUMBERS = st.one_of(
    st.sampled_from([1e-30, 1e30, 1e-300, 1e300, 5e-324, 1e-8, 1e8, 1e-6, 1.0, 100.0, 0.0, -1.0, 1.5e-8, 9.9e7]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(1e-12, 1e12),
)


@settings(max_examples=60, deadline=None, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(value=NUMBERS, option=st.sampled_from(["--qc-scale", "--singer-time-constant"]))
def test_a_scale_outside_what_float64_resolves_is_blamed_on_its_option(monkeypatch, capsys, value, option) -> None:
    """The data set is missing, so an accepted value ends in that one-line error instead, before any run."""
    monkeypatch.setattr("steam_ref.cli.fidelity.run_online", _never)
    low, high = {"--qc-scale": (1e-8, 1e8), "--singer-time-constant": (1e-6, 1e8)}[option]
    prior = ["--prior", "singer"] if option == "--singer-time-constant" else []
    code, err = _run(capsys, ["run", "--dataset", "missing.mat", *prior, f"{option}={value!r}"])
    if math.isfinite(value) and low <= value <= high:
        assert code == 2 and "missing.mat" in err and option not in err, err
    else:
        assert code == 2 and len(err.splitlines()) == 1 and option in err and f"from {low:g} to {high:g}" in err


@pytest.mark.parametrize(
    "option", ["--relinearize-threshold", "--amalgamation-zeros", "--lag-batch", "--time-budget", "--lag"]
)
@pytest.mark.parametrize("text", ["1e-400", "0.5e-330", "-2e-999"])
def test_a_number_float64_reads_as_zero_is_refused_not_read_as_zero(capsys, option, text) -> None:
    """'--relinearize-threshold 1e-400' was read as 0 (relinearize at every update), '--lag-batch 1e-400' as no batch,
    '--amalgamation-zeros 1e-400' as none: a number the user wrote other than 0 became 0 in silence. Now refused in
    one line naming the option and what float64 makes of it; a 0 written as 0 (0, 0e5, 0.000) is still 0."""
    lag = ["--lag", "5"] if option == "--lag-batch" else []
    code, err = _run(capsys, ["run", "--dataset", "missing.mat", *lag, f"{option}={text}"])
    assert code == 2 and len(err.splitlines()) == 1, err
    assert f"argument {option}:" in err and f"got {text!r}" in err, err
    if option not in ("--time-budget", "--lag"):  # > 0: refused as 0 is
        assert "which float64 cannot hold (it reads as 0)" in err, err
        for zero in ("0", "0e5", "0.000", "-0"):
            code, err = _run(capsys, ["run", "--dataset", "missing.mat", *lag, f"{option}={zero}"])
            assert code == 2 and "missing.mat" in err and option not in err, err


@pytest.mark.parametrize("text", ["1e-400", "-2e-999"])
def test_a_scale_float64_reads_as_zero_is_refused_not_read_as_zero(capsys, text) -> None:
    """The same rule for a number in a range that holds 0 (cli.args.scale: 'consistency --turn'): '--turn 1e-400' was
    read as a turn of 0 in silence. Refused by the parser, before --prior is looked at; a 0 written as 0 passes it
    (and is then refused by --prior wnoa, which takes no --turn)."""
    code, err = _run(capsys, ["consistency", "--prior", "wnoa", f"--turn={text}"])
    assert code == 2 and len(err.splitlines()) == 1, err
    assert "argument --turn:" in err and f"got {text!r}, which float64 cannot hold (it reads as 0)" in err, err
    for zero in ("0", "0e5", "-0"):
        code, err = _run(capsys, ["consistency", "--prior", "wnoa", f"--turn={zero}"])
        assert code == 2 and "--turn applies to" in err and "float64" not in err, err


@pytest.mark.parametrize("prior", ["wnoa", "wnoj"])
def test_a_singer_time_constant_with_another_prior_is_refused(monkeypatch, capsys, prior) -> None:
    monkeypatch.setattr("steam_ref.cli.fidelity.run_online", _never)
    code, err = _run(capsys, ["run", "--prior", prior, "--singer-time-constant", "2"])
    takers = "--prior singer or --prior se2-singer or --prior se3-singer"  # every prior with a Singer time constant
    assert code == 2 and f"--singer-time-constant applies to {takers} only, not --prior {prior}" in err


@pytest.mark.parametrize("command", ["selftest", "build"])
def test_a_conformance_data_dir_that_is_not_there_is_refused(capsys, tmp_path, command) -> None:
    (tmp_path / "a_file").write_text("x")
    for where, why in ((tmp_path / "nonexistent", "does not exist"), (tmp_path / "a_file", "not a folder")):
        code, err = _run(capsys, ["conformance", command, "--data-dir", str(where)])
        assert code == 2 and len(err.splitlines()) == 1 and "--data-dir" in err and why in err


# --- readings float64 cannot resolve --------------------------------------------------------------


@settings(max_examples=120, deadline=None, database=None)
@given(
    value=st.floats(-1e300, 1e300, allow_nan=False) | st.sampled_from([1e17, -1e17, 1e200, 5.0, 0.0, 1e16]),
    sigma=st.floats(1e-200, 1e3) | st.sampled_from([1e-150, 0.2, 16.0, 15.9]),
    kind=st.sampled_from(["bearing", "range", "bearing-range", "prior"]),
)
def test_a_reading_float64_cannot_resolve_to_its_sigma_is_refused(value: float, sigma: float, kind: str) -> None:
    value = abs(value) if kind in ("range", "bearing-range") else value
    value = math.fmod(value, 2 * math.pi) if kind == "bearing" else value  # a bearing within a full turn (radians)
    make = {
        "bearing": lambda: sr.BearingFactor.create(sr.X(0), sr.L(1), value, sigma),
        "range": lambda: sr.RangeFactor.create(sr.X(0), sr.L(1), value, sigma),
        "bearing-range": lambda: sr.BearingRangeFactor.create(sr.X(0), sr.L(1), 0.1, value, [0.05, sigma]),
        "prior": lambda: sr.PriorFactor.create(sr.L(9), [value, 0.0], sigma),
    }[kind]
    if mpmath.mpf(sigma) ** -2 > np.finfo(float).max:  # its information 1/sigma² overflows: refused before the value
        with pytest.raises(NumericalError, match=r"information, the inverse covariance, overflows"):
            make()
    elif math.ulp(abs(value)) > sigma:
        with pytest.raises(SteamError, match=r"float64 numbers there are .* apart, more than the sigma"):
            make()
    else:
        make()


def test_a_bearing_float64_cannot_resolve_to_its_sigma_names_the_spacing() -> None:
    with pytest.raises(SteamError, match=r"bearing = 6.0 with sigma 1e-16: float64 numbers there are 8.88e-16 apart"):
        sr.BearingFactor.create(sr.X(3), sr.L(1), 6.0, 1e-16)


def test_a_landmark_covariance_of_1e_300_is_blamed_on_the_covariance() -> None:
    with pytest.raises(SteamError, match=r"PriorFactor on l9: mean\[0\] = 5.0 with sigma 1e-150"):
        sr.PriorFactor.create(sr.L(9), [5.0, 2.0], np.eye(2) * 1e-300)


def test_a_landmark_covariance_of_1e_300_in_a_gtsam_file_is_refused_at_load(tmp_path) -> None:
    path = tmp_path / "tight.txt"
    path.write_text(
        "ODOMETRY 0 1 1.0 0 0 0.01 0 0 0.01 0 0.001\nLANDMARK 1 7 5.0 2.0 1e-300 0 1e-300\n"
        "ODOMETRY 1 2 1.0 0 0 0.01 0 0 0.01 0 0.001\n"
    )
    with pytest.raises(sr.DataError, match=r"line 2, bearing_ranges\[0, 2\] \(bearing\).*more than its sigma"):
        load_gtsam_2d(path)


# --- robust losses ------------------------------------------------------------------------------


@settings(max_examples=80, deadline=None, database=None)
@given(t=st.floats(5e-324, 1.7e308) | st.sampled_from([1e300, 1e154, 1.3e153, 1.4e153, 1e-154, 1e-160, 5e-324, 4.685]))
def test_a_loss_threshold_whose_square_overflows_is_refused(t: float) -> None:
    """The oracle: the threshold's square, and Tukey's c²/6, are finite, normal floats, and ρ at an outlier is finite."""
    representable = t * t / 6 >= 2.3e-308 and t * t * 100 < 1.8e308  # c²/6 normal; Huber at 10 k finite, with room
    for loss in (sr.Huber, sr.Tukey):
        if representable:
            rho = loss(t).rho(np.array([0.0, t / 2, 10 * t]))
            assert np.all(np.isfinite(rho)), (loss, t, rho)
        else:
            with pytest.raises(SteamError, match=r"threshold .*(overflows|underflows)"):
                loss(t)


def test_tukey_1e300_is_refused_naming_the_threshold() -> None:
    with pytest.raises(SteamError, match=r"Tukey threshold c=1e\+300: its square.* overflows float64"):
        sr.Tukey(1e300)
    with pytest.raises(SteamError, match=r"PaperSetup.tukey_c: Tukey threshold c=1e\+300"):
        sr.PaperSetup.plaza().replace(tukey_c=1e300)


# --- iSAM2 speaks of ill-conditioning as GN/LM do ------------------------------------------------


def _stiff_chain(scale: float):
    qc = np.diag([0.1, 0.2, 0.3]) * scale
    factors = [sr.PriorFactor.create(sr.X(0), np.zeros(6), 1.0)]
    values = {sr.X(0): np.zeros(6)}
    for i in range(1, 6):
        factors.append(sr.GPPriorFactor.wnoa(sr.X(i - 1), sr.X(i), 1.0, qc))
        factors.append(sr.RangeFactor.create(sr.X(i), sr.L(0), 5.0 + i, 0.3))
        values[sr.X(i)] = np.array([i, 0, 0, 1, 0, 0], float)
    factors.append(sr.PriorFactor.create(sr.L(0), [3.0, 4.0], 1.0))
    values[sr.L(0)] = np.array([3.0, 4.0])
    return factors, values


def test_isam2_calls_an_ill_conditioned_problem_ill_conditioned_as_gauss_newton_does() -> None:
    factors, values = _stiff_chain(1e-300)
    with pytest.raises(sr.UnderdeterminedError, match="too ill-conditioned for float64") as batch:
        sr.gauss_newton(sr.FactorGraph(factors), sr.Values(values))
    solver = sr.IncrementalSolver()
    with pytest.raises(sr.UnderdeterminedError, match="too ill-conditioned for float64") as incremental:
        solver.update(factors, values)
    assert "diagonal spans" in str(batch.value) and "diagonal spans" in str(incremental.value)
    assert len(solver) == 0  # rolled back


def test_isam2_still_says_not_constrained_when_no_factor_reaches_a_variable() -> None:
    factors, values = _stiff_chain(1.0)
    solver = sr.IncrementalSolver()
    solver.update(factors, values)
    with pytest.raises(sr.UnderdeterminedError, match="l5 is not constrained by the factors"):
        solver.update([sr.RangeFactor.create(sr.X(5), sr.L(5), 2.0, 0.3)], {sr.L(5): np.array([1.0, 1.0])})


# --- --converge-at-end with a 1e300 m range ------------------------------------------------------


def test_converge_at_end_with_a_1e300_m_range_is_one_line_without_runtime_warnings(tmp_path, capsys) -> None:
    arrays = generate_synthetic(n_steps=20, n_landmarks=3, seed=3, range_sigma=0.3).to_cmu_arrays()
    arrays["TD"][7, 3] = 1e300
    scipy.io.savemat(tmp_path / "huge.mat", arrays)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a numpy RuntimeWarning (overflow, NaN comparison) fails the test
        code, err = _run(
            capsys, ["run", "--dataset", str(tmp_path / "huge.mat"), "--preset", "synthetic", "--converge-at-end"]
        )
    assert code == 2 and len(err.splitlines()) == 1
    assert "ranges row 7: 1e+300 m: float64 numbers there are" in err and "RuntimeWarning" not in err


def test_converge_at_end_with_a_huge_resolvable_range_warns_only_of_the_reading(tmp_path, capsys) -> None:
    arrays = generate_synthetic(n_steps=20, n_landmarks=3, seed=3, range_sigma=0.3).to_cmu_arrays()
    arrays["TD"][7, 3] = 1e12  # float64 resolves it to 1.2e-4 m: a reading, an absurd one
    scipy.io.savemat(tmp_path / "huge.mat", arrays)
    argv = ["run", "--dataset", str(tmp_path / "huge.mat"), "--preset", "synthetic", "--converge-at-end", "--json"]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        code, err = _run(capsys, argv)
    assert code == 0, err
    assert not [w for w in caught if issubclass(w.category, RuntimeWarning)], [str(w.message) for w in caught]
    named = [str(w.message) for w in caught if issubclass(w.category, sr.DivergenceWarning)]
    assert named and "reading [1000000000000.0]" in named[0]
