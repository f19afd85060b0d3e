"""``steam-ref --help``, each command's help and a bad argument's one-line answer load no solver.

The parser reads only :mod:`steam_ref.choices`, the data sets' registry and :mod:`steam_ref.cli.args`; a command's
own module (and NumPy, SciPy and the solvers with it) loads once its arguments are parsed. Each case runs in a fresh
interpreter on this tree and reports what it loaded, so a module-level import that drags the solvers back into
parsing fails here, not silently in the user's start-up time (``python benchmarks/import_time.py`` measures it).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from cli_runs import ROOT

# What parsing must not load: the solvers (steam_ref.linear and what imports it), SciPy's sparse matrices, NumPy.
HEAVY = ("scipy", "numpy", "steam_ref.linear", "steam_ref.paper", "steam_ref.motion", "steam_ref.bayes_tree")

_PROBE = """
import contextlib, io, json, sys
from steam_ref.cli import main
out, err = io.StringIO(), io.StringIO()
with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
    try:
        code = main(sys.argv[1:])
    except SystemExit as exc:  # argparse's --help exits 0
        code = exc.code
loaded = sorted(m for m in sys.modules if m.startswith(%r))
print(json.dumps({"code": code, "out": out.getvalue(), "err": err.getvalue(), "loaded": loaded}))
"""


def _parse_only(*argv: str) -> dict:
    """``steam-ref ARGV`` in a fresh interpreter: its exit code, stdout, stderr and the heavy modules it loaded."""
    done = subprocess.run(
        [sys.executable, "-c", _PROBE % (HEAVY,), *argv],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT), "COLUMNS": "100"},
    )
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


HELPS = [
    ("--help",),
    ("run", "--help"),
    ("batch", "--help"),
    ("fidelity", "--help"),
    ("reproduce", "--help"),
    ("conformance", "--help"),
    ("conformance", "check", "--help"),
    ("conformance", "selftest", "--help"),
    ("data", "--help"),
    ("data", "fetch", "--help"),
    ("consistency", "--help"),
    ("fit-qc", "--help"),
    ("homework", "--help"),
    ("homework", "mark", "--help"),
]


@pytest.mark.parametrize("argv", HELPS, ids=" ".join)
def test_help_loads_neither_scipy_sparse_nor_the_solvers(argv):
    got = _parse_only(*argv)
    assert got["code"] == 0 and got["out"].startswith("usage: steam-ref"), got
    assert not got["loaded"], f"steam-ref {' '.join(argv)} loaded {got['loaded'][:8]}"


BAD = [
    (("run", "--nonsense"), "unrecognized arguments: --nonsense"),
    (("run", "--prior", "nope"), "argument --prior: invalid choice: 'nope'"),
    (("run", "--amalgamation-zeros", "1"), "argument --amalgamation-zeros: expected a fraction >= 0 and < 1, got '1'"),
    (("run", "--max-poses", "1_0"), "argument --max-poses: expected an integer >= 2, got '1_0'"),
    (("batch", "--ordering", "natural"), "argument --ordering: invalid choice: 'natural'"),
    (("consistency", "--prior", "singer"), "argument --prior: invalid choice: 'singer'"),
    (("conformance", "check", "results", "--only", "nope"), "argument --only: invalid choice: 'nope'"),
    (("homework", "mark", "x", "--jobs", "0"), "argument --jobs: expected an integer > 0 and <= 64"),
    (("nonsense",), "invalid choice: 'nonsense'"),
    # found by run's checks before its machinery loads (cli.parsers.run.check): neither a set nor a file
    (("run", "--dataset", "nonsense"), "data set 'nonsense' (not one of synthetic, paper-synthetic, plaza"),
    (("run", "--plot", "out.txt"), "--plot"),
    # --steps with a set read from a file: the 3-D one was refused once the solvers had loaded, in other words
    (
        ("run", "--dataset", "kitti", "--steps", "30"),
        "--steps generates the synthetic task: it needs --dataset synthetic | synthetic-3d, got 'kitti'",
    ),
    (("run", "--dataset", "plaza", "--steps", "30"), "it needs --dataset synthetic | synthetic-3d, got 'plaza'"),
    # batch's and fit-qc's checks before their machinery loads (cli.parsers.batch.check, cli.parsers.fit_qc.check)
    (("batch", "--dataset", "nonsense"), "data set 'nonsense' (not one of synthetic, paper-synthetic, plaza"),
    (("batch", "--plot", "out.txt"), "--plot"),
    (("batch", "--plot", "same.png", "--save-trajectory", "same.png"), "same.png"),
    (("fit-qc", "--dataset", "nonsense"), "data set 'nonsense' (not one of synthetic, paper-synthetic, plaza"),
    (("fit-qc", "--dataset", "kitti"), "this set is 3-D (a Qc fit on SE(3) is not built yet)"),
    (("fit-qc", "--prior", "se3"), "--prior se3"),
]


@pytest.mark.parametrize(("argv", "says"), BAD, ids=[" ".join(a) for a, _ in BAD])
def test_a_bad_argument_is_one_line_and_exit_2_without_scipy_sparse_or_the_solvers(argv, says):
    got = _parse_only(*argv)
    assert got["code"] == 2 and got["out"] == "", got
    assert got["err"].count("\n") == 1 and got["err"].startswith("steam-ref: error: ") and says in got["err"], got
    # --amalgamation-zeros' check is its home's, linear.amalgamation (NumPy with it), loaded when the option is given
    allowed = (
        {"numpy", "steam_ref.linear", "steam_ref.linear.amalgamation"} if "--amalgamation-zeros" in argv else set()
    )
    loaded = [m for m in got["loaded"] if m not in allowed and not m.startswith("numpy.")]
    assert not [m for m in loaded if m.startswith(("scipy.sparse", "steam_ref.linear"))], loaded
    assert not loaded, f"steam-ref {' '.join(argv)} loaded {loaded[:8]}"


BEFORE = (
    "unrecognized arguments: {} before a command: a command comes first, its options after it "
    "(as in 'steam-ref run --max-poses 200'; see 'steam-ref --help')"
)
UNKNOWN = [
    (("run", "extra"), "unrecognized arguments: extra (see 'steam-ref run --help')"),
    (("run", "--nonsense"), "unrecognized arguments: --nonsense (see 'steam-ref run --help')"),
    (("conformance", "check", "a", "b"), "unrecognized arguments: b (see 'steam-ref conformance check --help')"),
    (("data", "fetch", "plaza", "--bogus"), "unrecognized arguments: --bogus (see 'steam-ref data fetch --help')"),
    (("--bogus",), BEFORE.format("--bogus")),  # it said: the following arguments are required: command
    (("--dataset", "plaza"), BEFORE.format("--dataset")),  # it said: invalid choice: 'plaza' (choose from ...)
]


@pytest.mark.parametrize(("argv", "says"), UNKNOWN, ids=[" ".join(a) for a, _ in UNKNOWN])
def test_an_unknown_argument_points_at_its_own_commands_help(argv, says):
    """argparse hands a subcommand's unknown arguments up to the top parser, whose line said
    ``(see 'steam-ref --help')``: the page that lists the commands, not the options the user was typing."""
    got = _parse_only(*argv)
    assert got["code"] == 2 and got["out"] == "" and got["err"] == f"steam-ref: error: {says}\n", got


def test_the_probe_sees_what_a_command_that_runs_loads():
    """The check above could pass by looking at nothing: a command that runs loads the solvers, and the probe says so."""
    # refused by run's module, once loaded: --lag forgets the covariances --save-estimates writes
    got = _parse_only("run", "--dataset", "synthetic", "--lag", "5", "--save-estimates", "never-written.npz")
    assert got["code"] == 2 and "--save-estimates writes every marginal covariance" in got["err"], got
    assert "scipy.sparse" in got["loaded"] and "steam_ref.linear" in got["loaded"]
