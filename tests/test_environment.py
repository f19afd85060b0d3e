"""The optional CHOLMOD backend: present where CI requires it, and not needed by the core."""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
import textwrap

import pytest
from requirements import REQUIRE_ENV, required

from steam_ref.linear import have_cholmod, sparse_backend


def _cholmod_imports() -> bool:
    """The oracle: does ``import sksparse.cholmod`` succeed in this interpreter?"""
    try:
        importlib.import_module("sksparse.cholmod")
    except ImportError:
        return False
    return True


def test_cholmod_present_when_required():
    if required("cholmod"):
        assert _cholmod_imports(), f"{REQUIRE_ENV['cholmod']}=1 but scikit-sparse (CHOLMOD) does not import"


def test_have_cholmod_and_the_default_backend_follow_what_imports(monkeypatch: pytest.MonkeyPatch):
    importable = _cholmod_imports()
    assert have_cholmod() is importable
    monkeypatch.delenv("STEAM_REF_SPARSE_BACKEND", raising=False)
    assert sparse_backend() == ("cholmod" if importable else "superlu")
    monkeypatch.setenv("STEAM_REF_SPARSE_BACKEND", "superlu")
    assert sparse_backend() == "superlu"  # the variable overrides the default


def test_core_runs_with_scikit_sparse_hidden():
    """In a fresh interpreter where `import sksparse` fails: AMD ordering, batch solve, marginals."""
    script = textwrap.dedent(
        """
        import sys
        sys.modules["sksparse"] = None  # makes `import sksparse` raise ImportError
        import numpy as np
        import steam_ref as sr
        from steam_ref.linear import have_cholmod, sparse_backend
        assert not have_cholmod() and sparse_backend() == "superlu"
        qc = np.diag([0.1, 0.1, 0.2])
        keys = [sr.X(i) for i in range(30)]
        g = sr.FactorGraph(sr.gp_prior_factors(keys, np.arange(30.0), qc))
        g.add(sr.PriorFactor.create(keys[0], np.zeros(6), np.ones(6)))
        for i, k in enumerate(keys):
            g.add(sr.VelocityFactor.create(k, [1.0, 0.0, 0.05], [0.1, 0.1, 0.1]))
            g.add(sr.RangeFactor.create(k, sr.L(i % 4), 5.0 + 0.1 * i, 0.5))
        for j in range(4):
            g.add(sr.PriorFactor.create(sr.L(j), [10.0 * j, 5.0], 1.0))
        v = sr.Values({k: np.zeros(6) + 0.01 * i for i, k in enumerate(keys)})
        for j in range(4):
            v.insert(sr.L(j), np.array([10.0 * j, 5.0]))
        r = sr.gauss_newton(g, v, ordering="amd", max_iterations=1)
        assert r.backend == "superlu"
        from steam_ref.linear.ordering import make_ordering
        system = sr.LinearSystem.build(g.factors, v, make_ordering("xl", g.keys(), v.dims(), [f.keys for f in g]))
        A, b = system.to_dense()
        step = system.split(np.linalg.solve(A.T @ A, A.T @ b))
        for k in step:
            np.testing.assert_allclose(r.values[k], v[k] + step[k], rtol=1e-9, atol=1e-10)
        print("ok", r.factor_nnz)
        """
    )
    env = dict(os.environ, STEAM_REF_SPARSE_BACKEND="")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=env, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("ok")
