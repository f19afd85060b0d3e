"""PB and PBVR analyse CHOLMOD's pattern once per Gauss-Newton run and refactor numerically after.

The analysis depends on the pattern only, so reusing it must give the very same factor: the
estimates of whole streams are compared bit for bit against fresh factorizations at every iteration.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from steam_ref.batch import gauss_newton, levenberg_marquardt
from steam_ref.datasets import generate_synthetic
from steam_ref.linear.cholesky import Symbolic
from steam_ref.paper.online import run_online
from steam_ref.paper.presets import PaperSetup
from steam_ref.paper.problem import build_problem

pytestmark = pytest.mark.needs_cholmod
SETUP = PaperSetup.synthetic()


class Counting(Symbolic):
    """Symbolic that counts numeric factorizations too."""

    factorizations = 0
    analysed = 0

    def factor(self, info):
        before = self.analyses
        out = super().factor(info)
        Counting.factorizations += 1
        Counting.analysed += self.analyses - before
        return out


class Fresh(Symbolic):
    """The old way: analyse and factor anew every time."""

    def factor(self, info):
        from sksparse.cholmod import cholesky

        return cholesky(info, ordering_method="natural")


@pytest.fixture(scope="module")
def data():
    return generate_synthetic(n_steps=40, n_landmarks=5, seed=3)


@pytest.mark.parametrize("method", ["pb", "pbvr"])
def test_reused_analysis_gives_the_same_stream(data, method, monkeypatch):
    monkeypatch.setattr("steam_ref.batch.Symbolic", Counting)
    Counting.factorizations = Counting.analysed = 0
    reused = run_online(data, SETUP, method=method)
    assert Counting.analysed < Counting.factorizations  # the analysis really was reused
    monkeypatch.setattr("steam_ref.batch.Symbolic", Fresh)
    fresh = run_online(data, SETUP, method=method)
    np.testing.assert_array_equal(reused.trajectory, fresh.trajectory)
    assert reused.rmse_m == fresh.rmse_m


@pytest.mark.parametrize("optimizer", [gauss_newton, levenberg_marquardt])
def test_reused_analysis_gives_the_same_batch_optimum(data, optimizer, monkeypatch):
    problem = build_problem(data, SETUP)
    monkeypatch.setattr("steam_ref.batch.Symbolic", Fresh)
    fresh = optimizer(problem.graph, problem.initial, check=False)
    monkeypatch.undo()
    reused = optimizer(problem.graph, problem.initial, check=False)
    assert len(reused.iterations) == len(fresh.iterations) > 1
    for k in fresh.values:
        np.testing.assert_array_equal(reused.values[k], fresh.values[k])


def test_a_new_pattern_is_analysed_anew(rng):
    symbolic = Symbolic()
    a = sp.csc_matrix(np.array([[4.0, 1.0, 0.0], [1.0, 3.0, 0.0], [0.0, 0.0, 2.0]]))
    b = sp.csc_matrix(np.array([[4.0, 0.0, 1.0], [0.0, 3.0, 0.0], [1.0, 0.0, 2.0]]))
    for m, expected in ((a, 1), (2 * a, 1), (b, 2), (b, 2)):
        f = symbolic.factor(m)
        assert symbolic.analyses == expected
        x = rng.normal(size=3)
        np.testing.assert_allclose(f(m @ x), x, rtol=1e-12)
