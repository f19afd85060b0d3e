"""The optional CHOLMOD backend: present where CI requires it, and not needed by the core."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

from steam_ref.linear import have_cholmod


def test_cholmod_present_when_required():
    if os.environ.get("STEAM_REF_REQUIRE_CHOLMOD") == "1":
        assert have_cholmod(), "CI requires scikit-sparse (CHOLMOD) but it does not import"
    else:
        assert isinstance(have_cholmod(), bool)


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
        from steam_ref.batch import make_ordering
        system = sr.LinearSystem.build(g.factors, v, make_ordering(g, v, "xl"))
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
