"""Checks that came after the run (or never), and errors that came from NumPy or blamed the wrong thing:
each is now a SteamError before any work, naming the option or the value, or the right answer.

The CLI cases replace the run with a function that fails the test if it is reached; the API cases
check the exception's type and what its message names."""

from __future__ import annotations

import importlib.abc
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.io
from cli_runs import runner

import steam_ref as sr
from steam_ref.batch import check_stationarity
from steam_ref.cli import main as entry
from steam_ref.cli.streams import json_line
from steam_ref.datasets import generate_synthetic, load_dataset
from steam_ref.errors import DataError, ShapeError, SteamError
from steam_ref.factors import GPPriorFactor
from steam_ref.linear import make_ordering
from steam_ref.paper.consistency import ConsistencyStudy, run_seed, summarize
from steam_ref.paper.online import run_online
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.sweep import run_sweep
from steam_ref.variables import L, X

SMALL = generate_synthetic(n_steps=12, n_landmarks=3, seed=3, range_sigma=0.3)


def _never(*args, **kwargs):
    raise AssertionError("the run started although the input was bad")


_cli = runner()


# -- the command line: refused before the run, naming the option --


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["run", "--dataset", "victoria-park", "--lag", "5", "--score-against-optimum"], "--lag forgets"),
        (["run", "--steps", "20001"], "argument --steps: expected an integer > 0 and <= 20000"),
        (["run", "--steps", "10000000000"], "argument --steps"),
        (["consistency", "--seeds", str(10**12)], "argument --seeds: expected an integer > 0 and <= 100000"),
        (["consistency", "--steps", "10000000"], "argument --steps"),
        (["consistency", "--landmarks", "10000000"], "argument --landmarks"),
        (["run", "--lag", "1_0"], "argument --lag: expected a finite number > 0, got '1_0'"),
        (["run", "--lag", "５"], "argument --lag: expected a finite number > 0, got '５'"),
        (["run", "--every", "１"], "argument --every"),
        (["run", "--seed", "1_0"], "argument --seed"),
        (["run", "--qc-scale", "1_0"], "argument --qc-scale"),
        (["run", "--lag", " 5"], "argument --lag"),
    ],
)
def test_refused_before_the_run_naming_the_option(capsys, monkeypatch, argv, needle):
    for name in ("StreamingEstimator", "score_against_batch", "generate_synthetic"):
        monkeypatch.setattr(f"steam_ref.cli.run.{name}", _never)
    monkeypatch.setattr("steam_ref.cli.consistency.run_sweep", _never)
    code, out, err = _cli(capsys, *argv)
    assert (code, out) == (2, "") and len(err.splitlines()) == 1
    assert needle in err


def test_the_one_rule_for_numbers_still_reads_every_plain_decimal(capsys, monkeypatch):
    """The rule refuses what float() reads too generously, nothing a user writes on purpose."""
    seen = {}

    def record(readings, setup, options, **kwargs):
        seen["lag"] = options.lag
        raise SteamError("stop here")

    monkeypatch.setattr("steam_ref.cli.run.StreamingEstimator", record)
    for text, value in (("10", 10.0), ("2.5", 2.5), (".5", 0.5), ("5.", 5.0), ("1e1", 10.0), ("+3E-1", 0.3)):
        code, _, err = _cli(capsys, "run", "--lag", text)
        assert code == 2 and "stop here" in err and seen["lag"] == value


def test_out_of_memory_says_so(capsys, monkeypatch):
    def empty(*args, **kwargs):
        raise MemoryError  # what Python raises with no message: it printed "error: (no message)"

    monkeypatch.setattr("steam_ref.cli.run.generate_synthetic", empty)
    code, _, err = _cli(capsys, "run", "--steps", "5")
    assert code == 2 and err == "steam-ref: error: out of memory\n"


def test_ctrl_c_while_the_commands_load_is_one_line_and_130(capsys, monkeypatch):
    """An interrupt while NumPy and SciPy load (half a second a user may well cut short) was a 44-line traceback."""

    class Interrupt(importlib.abc.MetaPathFinder):
        def find_spec(self, name, path=None, target=None):
            if name == "steam_ref.cli.commands":
                raise KeyboardInterrupt
            return

    monkeypatch.delitem(sys.modules, "steam_ref.cli.commands")
    monkeypatch.setattr(sys, "meta_path", [Interrupt(), *sys.meta_path])
    assert entry(["run"]) == 130
    out = capsys.readouterr()
    assert (out.out, out.err) == ("", "steam-ref: interrupted\n")


def test_a_deleted_working_folder_is_named(tmp_path, capsys, monkeypatch):
    gone = tmp_path / "gone"
    gone.mkdir()
    monkeypatch.chdir(gone)
    monkeypatch.setenv("PWD", str(gone))
    gone.rmdir()
    monkeypatch.setattr("steam_ref.cli.run.StreamingEstimator", _never)
    code, _, err = _cli(capsys, "run", "--steps", "4", "--save-trajectory", "t.txt")
    assert code == 2
    assert err.strip() == (
        f"steam-ref: error: --save-trajectory: 't.txt' is relative to the working folder {str(gone)!r}, which no "
        "longer exists: give an absolute path, or change to a folder that exists"
    )


def test_a_figure_that_is_not_finite_is_refused_naming_it_never_written_as_infinity():
    with pytest.raises(SteamError, match=r"evaluation\.ape\.rmse = inf is not finite"):
        json_line({"n": 3, "evaluation": {"ape": {"rmse": math.inf}}})
    assert json.loads(json_line({"rmse": 1e300, "list": [1.0, None]})) == {"rmse": 1e300, "list": [1.0, None]}


@pytest.mark.parametrize("column", ["GT", "DRp"])
def test_a_truth_or_dead_reckoning_at_1e300_gives_its_figures(tmp_path, capsys, column):
    """Squared distances of 1e300 overflowed: the JSON line carried Infinity (ground truth), or the run failed
    after its end (dead reckoning). The RMSE over 13 poses with one distance d dominating is d / √13."""
    arrays = SMALL.to_cmu_arrays()
    arrays[column][5, 1] = 1e300
    scipy.io.savemat(tmp_path / "far.mat", arrays)
    code, out, err = _cli(capsys, "run", "--dataset", str(tmp_path / "far.mat"), "--preset", "synthetic", "--json")
    assert code == 0, err
    summary = json.loads(out)
    key = "rmse_m" if column == "GT" else "dead_reckoning_rmse_m"
    assert summary[key] == pytest.approx(1e300 / math.sqrt(13), rel=1e-6)


# -- the API: before the work, naming the value --


def test_run_online_with_a_lag_and_covariances_is_refused_before_the_run(monkeypatch):
    monkeypatch.setattr("steam_ref.paper.online.StreamingEstimator.step", _never)
    with pytest.raises(SteamError, match=r"covariances=True .* lag=2 forgets"):
        run_online(SMALL, PaperSetup.named("synthetic"), lag=2, covariances=True)


def test_a_prior_of_another_size_than_its_states_names_both():
    factor = GPPriorFactor.wnoa(X(0), X(1), 1.0, np.eye(2))  # a 2-D position: states of size 4
    with pytest.raises(ShapeError, match=r"states of size 4 got states of shapes \(6,\) and \(6,\)"):
        factor.whitened_error(np.zeros(6), np.ones(6))


def test_a_subnormal_qc_is_blamed_not_the_time_step():
    with pytest.raises(SteamError, match=r"Qc's smallest eigenvalue 5e-324 is below float64's normal range"):
        GPPriorFactor.wnoa(X(0), X(1), 1.0, 5e-324 * np.eye(3))


def test_run_seed_refuses_a_negative_index():
    with pytest.raises(SteamError, match=r"index must be an integer >= 0, got index=-1"):
        run_seed(ConsistencyStudy(), -1)


def test_summarize_names_the_run_without_an_estimator():
    study = ConsistencyStudy()
    with pytest.raises(SteamError, match=rf"run 3 has no result for estimator {study.estimators[0]!r}"):
        summarize({3: {}}, study.estimators)


def _not_json(item):
    return {"item": item, "value": {1, 2}}  # a set


def test_run_sweep_names_the_item_whose_result_is_not_json(tmp_path):
    with pytest.raises(SteamError, match=r"the result for item 0 is not JSON"):
        run_sweep(_not_json, range(2), log=tmp_path / "log.jsonl", study={})
    # without a log nothing is written, and any picklable result comes back as it is (reproduce's RunResults)
    assert run_sweep(_not_json, range(2)) == {"0": _not_json(0), "1": _not_json(1)}


@pytest.mark.parametrize("name", ["n_steps", "n_landmarks", "n_nearest"])
def test_generate_synthetic_counts_are_integers(name):
    with pytest.raises(SteamError, match=rf"{name} must be a positive integer, got 2.0"):
        generate_synthetic(**{name: 2.0})


@pytest.mark.parametrize("value", [None, 3, b"plaza"])
def test_load_dataset_of_something_not_a_name_nor_a_path(value):
    with pytest.raises(DataError, match=rf"the data set must be a name or a path, got {value!r}"):
        load_dataset(value)


def test_a_range_before_the_first_pose_is_refused(tmp_path: Path, capsys):
    arrays = SMALL.to_cmu_arrays()
    arrays["TD"][0, 0] = arrays["GT"][0, 0] - 5  # it was attached to pose 0 in silence
    scipy.io.savemat(tmp_path / "early.mat", arrays)
    code, _, err = _cli(capsys, "run", "--dataset", str(tmp_path / "early.mat"), "--preset", "synthetic")
    assert code == 2
    assert err == "steam-ref: error: range row 0 at t=-4.0 is before the first pose (t=1.0): no pose to attach it to\n"


# --- check_stationarity: its arguments named, as gauss_newton names them ---------------------------


def _two_variables():
    """Two states' worth of factors (a prior on each, a range between): a well-posed problem, its ordering."""
    factors = [
        sr.PriorFactor.create(sr.X(0), np.zeros(6), 0.1),
        sr.PriorFactor.create(sr.L(0), np.array([3.0, 4.0]), 0.5),
        sr.RangeFactor.create(sr.X(0), sr.L(0), 5.1, 0.2),
    ]
    values = {sr.X(0): np.full(6, 0.01), sr.L(0): np.array([3.1, 3.9])}
    graph = sr.FactorGraph(factors)
    return factors, values, make_ordering("amd", graph.keys(), sr.Values(values).dims(), [f.keys for f in graph])


def test_check_stationarity_takes_a_list_of_factors_and_a_mapping_as_gauss_newton_does():
    factors, values, ordering = _two_variables()
    expected = check_stationarity(sr.FactorGraph(factors), sr.Values(values), ordering)
    found = check_stationarity(factors, values, ordering)  # was AttributeError: 'list' object has no ... 'factors'
    exact = ("cost", "predicted_decrease", "gradient_norm")  # the condition is a randomized estimate (onenormest)
    assert [getattr(found, f) for f in exact] == [getattr(expected, f) for f in exact]
    with pytest.raises(SteamError, match=r"factors must be a factor or an iterable of factors, got factors=None"):
        check_stationarity(None, values, ordering)
    with pytest.raises(SteamError, match=r"values must be a Values or a mapping"):
        check_stationarity(factors, list(values.values()), ordering)


def test_check_stationarity_refuses_a_value_no_factor_names():
    """A value without a factor was left out of the check, which then certified nothing about it."""
    factors, values, ordering = _two_variables()
    with pytest.raises(SteamError, match=r"check_stationarity: variable x7 has a value but no factor names it"):
        check_stationarity(factors, {**values, X(7): np.zeros(6)}, ordering)
    wider = make_ordering("natural", [X(0), L(0), X(7)], {X(0): 6, L(0): 2, X(7): 6}, [[X(0), L(0), X(7)]])
    with pytest.raises(SteamError, match=r"x7"):  # an ordering of a variable no factor names: named too
        check_stationarity(factors, values, wider)


def test_check_stationarity_takes_an_ordering_by_name_as_gauss_newton_does():
    """docs/api.md lists ``check_stationarity(graph, values, ordering)`` beside ``gauss_newton(..., ordering='amd')``;
    a name was refused ("ordering must be an Ordering"). By name it checks exactly what the named ordering checks."""
    factors, values, _ = _two_variables()
    graph = sr.FactorGraph(factors)
    exact = ("cost", "predicted_decrease", "gradient_norm")  # the condition is a randomized estimate (onenormest)
    for name in ("natural", "xl", "amd"):
        ordering = make_ordering(name, graph.keys(), sr.Values(values).dims(), [f.keys for f in graph])
        expected = check_stationarity(factors, values, ordering)
        found = check_stationarity(factors, values, name)
        assert [getattr(found, f) for f in exact] == [getattr(expected, f) for f in exact], name
    with pytest.raises(SteamError, match=r"unknown ordering 'colamd'"):
        check_stationarity(factors, values, "colamd")
