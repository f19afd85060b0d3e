"""Fixtures shared by every test file, and where the reference data are found.

The reference data (the paper's .mat files) are read through $STEAM_REF_DATA_DIR, as a user's run
would. If it is unset and ``<repository>/../shared/data`` exists (CI's layout), it is set to that
folder here, before any test runs; else, when ``steam-ref data fetch`` has put every file in the
user's cache folder, to that one. No test touches the user's cache: XDG_CACHE_HOME is a fresh
folder. Tests that read the files use the ``shared_data`` fixture or
the ``needs_data`` marker; both skip with one line saying where to put the files, or fail when
STEAM_REF_REQUIRE_DATA=1 (see ``requirements.py``, which also handles the optional packages).
"""

import atexit
import collections
import os
import shutil
import tempfile

import numpy as np
import pytest
import scipy.linalg  # noqa: F401  (its BLAS loaded before the limit below)
from requirements import DATA_DIR_ENV, DATA_FILES, SHARED_DATA, optional_import, reference_data_dir
from threadpoolctl import threadpool_limits

from steam_ref.datasets.search import data_cache_dir

# One BLAS thread for the tests' own dense algebra (the oracles' expm, quadrature and solves), as the solvers set for
# theirs (steam_ref.linear.threads, which sets its own limit inside and restores this one): the suite's two workers
# (`-n 2`, CI's two cores) with OpenBLAS's default of a thread a core each put four busy threads on two cores.
# A test that needs another count sets it (tests/test_threads.py starts at 2).
_ONE_BLAS_THREAD = threadpool_limits(limits=1)
# The processes the tests start (the command as `python -m steam_ref`, a tutorial's kernel, a benchmark script, a
# sweep's workers) too, as benchmarks/against_commit.py runs its trees: with OpenBLAS's default of a thread a core, a
# process beside the other worker waits on a thread that has no core. Measured: tutorial 02's dense solve took 13 s
# instead of 1 beside one busy process (the notebook 25 s, 8.7 s with one thread; alone, 7.7 s either way).
os.environ |= {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1"}

if not os.environ.get(DATA_DIR_ENV) and SHARED_DATA.is_dir():
    os.environ[DATA_DIR_ENV] = str(SHARED_DATA.resolve())
elif not os.environ.get(DATA_DIR_ENV) and all((data_cache_dir() / f).is_file() for f in DATA_FILES):
    os.environ[DATA_DIR_ENV] = str(data_cache_dir())  # a newcomer's `steam-ref data fetch`
# No test reads or writes the user's cache folder: XDG_CACHE_HOME is a fresh one (platformdirs on Linux).
# (removed at exit by atexit, not by a TemporaryDirectory's finalizer, whose ResourceWarning an xdist worker's
# warnings-as-errors would print as an error at its exit)
_CACHE = tempfile.mkdtemp(prefix="steam_ref_test_cache_")
atexit.register(shutil.rmtree, _CACHE, ignore_errors=True)
os.environ["XDG_CACHE_HOME"] = _CACHE


@pytest.fixture
def rng() -> np.random.Generator:
    """The one seeded generator every test draws from."""
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def shared_data():
    """The folder holding the paper's files (Syn_theta_Plaza.mat, Plaza1_..., authors/*.mat)."""
    return reference_data_dir()


@pytest.fixture(scope="session")
def small_mat(tmp_path_factory):
    """A small generated task (60 steps, 10 landmarks) written as a CMU .mat file: ``(path, data)``, for a
    command's ``--dataset PATH --preset synthetic``. Read-only."""
    import scipy.io

    from steam_ref.datasets import generate_synthetic

    data = generate_synthetic(n_steps=60, n_landmarks=10, seed=2, range_sigma=0.3)
    path = tmp_path_factory.mktemp("data") / "small.mat"
    scipy.io.savemat(path, data.to_cmu_arrays())
    return path, data


# A run of a whole tutorial is slow (up to ~45 s each), so each runs apart; every other test runs with its file.
RUNS_APART = "test_notebooks.py::test_notebook_executes["
# The groups that take longest, longest first (measured with `-n 2` on CI's 2 cores, quiet: 20-70 s each), which the
# workers start before all others. xdist's own order (most tests first) left the tutorials, one test each, for last:
# the run ended on one worker 30-47 s after the other. A group not named here, or renamed, follows in xdist's order.
LONGEST_FIRST = (
    "test_fixed_lag_memory", "test_fidelity", "test_docs_site", "test_wheel", "test_lie_groups", "06_motion_priors",
    "test_bad_interrupt", "07_victoria_park_turn", "test_online", "test_benchmarks", "test_victoria_park",
    "test_conformance_gate", "test_experiments", "04_incremental", "test_homework", "test_conformance", "test_fit_qc",
    "test_cli", "test_notebooks", "test_fixed_lag_stream", "10_vector_space_or_lie_group", "test_consistency",
    "test_isam", "test_conformance_v5_lie", "08_fixed_lag",
    # then shorter groups with few tests each, which xdist's order (most tests first) left to the end (6-15 s each in
    # a loaded `-n 2` run, 10-35 s alone beside other loads): the run ended with tutorials 09 and 11 queued on one
    # worker after the other had finished; it now ends on files of a second or two
    "test_conformance_se2", "test_bad_outputs", "test_rigid_runs", "test_converge", "test_synthetic_3d",
    "test_amalgamation", "test_threads", "11_vehicle_in_3d", "09_consistency", "02_batch_and_amd", "01_gp_prior",
    "00_solve_your_own_problem", "05_check_your_implementation", "03_bayes_tree", "test_lie_coefficients",
)  # fmt: skip


def _group(item) -> str:
    return item.get_closest_marker("xdist_group").args[0]


@pytest.hookimpl(tryfirst=True)  # before xdist's own hook reads the groups (``--dist loadgroup``, pyproject.toml)
def pytest_collection_modifyitems(config, items):
    """A test that uses ``shared_data`` is a ``needs_data`` test, so ``-m "not needs_data"`` works.

    Each test joins an ``xdist_group``, the unit a worker of ``-n 2 --dist loadgroup`` runs whole: its file, so that a
    module's fixtures are computed once, except a tutorial's run (``RUNS_APART``), its own unit, so that the slow
    tutorials spread over both workers rather than queueing on one. In a worker, the groups are in the order they are
    handed out (``--no-loadscope-reorder``): ``LONGEST_FIRST``, then the others with the most tests first, as xdist
    orders them; each group's tests keep their order.
    """
    for item in items:
        if "shared_data" in getattr(item, "fixturenames", ()) and not item.get_closest_marker("needs_data"):
            item.add_marker(pytest.mark.needs_data)
        if not item.get_closest_marker("xdist_group"):
            apart = RUNS_APART in item.nodeid  # its group: the tutorial's name (shown after an @ in the test's id)
            item.add_marker(pytest.mark.xdist_group(item.callspec.id if apart else item.path.stem))
    if hasattr(config, "workerinput"):  # an xdist worker: its order is the one the groups are handed out in
        size = collections.Counter(_group(item) for item in items)
        rank = {name: n for n, name in enumerate(LONGEST_FIRST)}
        items.sort(key=lambda item: (rank.get(_group(item), len(rank)), -size[_group(item)]))  # stable


def pytest_runtest_setup(item):
    """Markers checked before a test runs (skip, or fail when required; see requirements.py).

    ``needs_data``: the paper's files (e.g. a notebook that loads "plaza");
    ``needs_cholmod``: scikit-sparse's CHOLMOD (STEAM_REF_REQUIRE_CHOLMOD=1 makes it required).
    """
    if item.get_closest_marker("needs_data"):
        reference_data_dir()
    if item.get_closest_marker("needs_cholmod"):
        optional_import("sksparse.cholmod", "cholmod", kind="cholmod")


# --- the conformance kit (tests/test_conformance*.py): steam_ref's results of a kit, written as a port would ---------


@pytest.fixture(scope="session")
def kit_results():
    """``kit_results(kit, suite)``: steam_ref's results for every case of a kit's suite (case → the quantities it is
    checked on), as a results file holds them. Computed once per kit and suite; each call returns a fresh copy,
    which a test may edit into a wrong port's."""
    import json

    from steam_ref.conformance import run_case
    from steam_ref.conformance.kitio import dumps, read_suite

    computed: dict[tuple[str, str], str] = {}

    def results(kit, suite: str) -> dict:
        if (str(kit), suite) not in computed:
            out = {}
            for case in read_suite(kit, suite)["cases"]:
                got = json.loads(dumps(run_case(suite, case["name"], case["inputs"])))
                out[case["name"]] = {q: got[q] for q in case["tolerance"]}
            computed[str(kit), suite] = json.dumps(out)
        return json.loads(computed[str(kit), suite])

    return results


@pytest.fixture(scope="session")
def write_results():
    """``write_results(folder, suite, cases, version=KIT_VERSION)``: ``folder/<suite>/results.json`` as a port writes
    it (``version`` None: without a kit_version, as kit v1's results were); returns its path."""
    from steam_ref.conformance import KIT_VERSION
    from steam_ref.conformance.kitio import dumps

    def write(folder, suite: str, cases: dict, version: int | None = KIT_VERSION):
        (folder / suite).mkdir(parents=True, exist_ok=True)
        head = {} if version is None else {"kit_version": version}
        (folder / suite / "results.json").write_text(dumps({**head, "cases": cases}))
        return folder / suite / "results.json"

    return write


@pytest.fixture
def kit_copy(tmp_path):
    """A copy of the shipped kit (``tmp_path / "kit"``), for a test to edit."""
    import shutil

    from steam_ref.conformance import SHIPPED

    shutil.copytree(SHIPPED, tmp_path / "kit")
    return tmp_path / "kit"
