"""The steam-ref command on bad input: every error is one line on stderr and exit code 2,
never a traceback, and it comes before any run: the solver, the batch, the experiments and the
comparison are replaced here by functions that fail the test if they are reached. Most calls run
in-process (``steam_ref.cli.commands.main``); two run the module as a user would."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import scipy.io
from cli_runs import run_module, runner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from steam_ref.datasets import generate_synthetic

SMALL = generate_synthetic(n_steps=4, n_landmarks=2, seed=3, range_sigma=0.3)


def _never(*args, **kwargs):
    raise AssertionError("the run started although the input was bad")


@pytest.fixture(autouse=True)
def no_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    for name in (
        "run.StreamingEstimator",
        "batch.sequential_batch",
        "reproduce.reproduce",
        "fidelity.compare",
        "consistency.run_sweep",
    ):
        monkeypatch.setattr(f"steam_ref.cli.{name}", _never)
    monkeypatch.setattr("steam_ref.cli.batch.build_problem", _never)


@pytest.fixture(scope="module")
def places(tmp_path_factory) -> dict[str, str]:
    root = tmp_path_factory.mktemp("cli")
    (root / "a_file").write_text("x")
    (root / "dir.png").mkdir()
    (root / "dir.npz").mkdir()
    arrays = SMALL.to_cmu_arrays()
    scipy.io.savemat(root / "good.mat", arrays)
    one = dict(arrays, GT=arrays["GT"][:1], DR=arrays["DR"][:0], DRp=arrays["DRp"][:1], TD=arrays["TD"][:1])
    scipy.io.savemat(root / "one.mat", one)
    negative = SMALL.to_cmu_arrays()
    negative["TD"][2, 3] = -1.5
    scipy.io.savemat(root / "negative.mat", negative)
    nan = SMALL.to_cmu_arrays()
    nan["GT"][3, 2] = np.nan
    scipy.io.savemat(root / "nan.mat", nan)
    crash = bytearray((root / "good.mat").read_bytes())
    crash[crash.index(b"\x01\x00\x02\x00TD\x00\x00") + 9] ^= 0xF5  # TD's data type: scipy died of a bus error
    (root / "crash.mat").write_bytes(bytes(crash))
    cut = root / "cut"
    cut.mkdir()
    np.savetxt(cut / "T_DR.txt", SMALL.odometry, fmt="%.17g", delimiter="\t")
    td = "".join("\t".join(f"{float(v)!r}" for v in row) + "\n" for row in SMALL.ranges)
    (cut / "T_TD.txt").write_text(td[: len(td) - 5])
    scipy.io.savemat(cut / "T_.mat", dict(GT=arrays["GT"], TL=arrays["TL"]))
    files = {
        "a_file": "a_file",
        "dir_png": "dir.png",
        "dir_npz": "dir.npz",
        "good": "good.mat",
        "one": "one.mat",
        "negative": "negative.mat",
        "nan": "nan.mat",
        "crash": "crash.mat",
        "cut": "cut",
    }
    return {k: str(root / v) for k, v in files.items()} | {"root": str(root), "missing": str(root / "missing")}


# name -> (argv with {places} filled in, text the error must contain)
BAD = {
    "seed-negative": (["run", "--seed", "-1"], "--seed"),
    "seed-batch": (["batch", "--seed", "-5"], "--seed"),
    "seed-fraction": (["run", "--seed", "1.5"], "--seed"),
    "seed-word": (["batch", "--seed", "one"], "--seed"),
    "dataset-empty": (["run", "--dataset", ""], "--dataset"),
    "dataset-blank": (["batch", "--dataset", "  "], "--dataset"),
    "dataset-missing": (["run", "--dataset", "{missing}.mat"], "missing.mat"),
    "dataset-a-file": (["run", "--dataset", "{a_file}"], "a_file"),
    "data-dir-missing": (["run", "--data-dir", "{missing}"], "--data-dir"),
    "data-dir-file": (["batch", "--data-dir", "{a_file}"], "--data-dir"),
    "data-dir-empty": (["fidelity", "--data-dir", ""], "--data-dir"),
    "data-dir-reproduce": (["reproduce", "--data-dir", "{missing}"], "--data-dir"),
    "max-poses-1": (["run", "--max-poses", "1"], "--max-poses"),
    "every-nan": (["run", "--every", "nan"], "--every"),
    "every-negative": (["run", "--every", "-3"], "--every"),
    "skip-fraction": (["run", "--skip", "2.5"], "--skip"),
    "skip-huge-float": (["run", "--skip", "1e400"], "--skip"),
    "budget-inf": (["run", "--time-budget", "inf"], "--time-budget"),
    "budget-zero": (["run", "--time-budget", "0"], "--time-budget"),
    "threshold-nan": (["run", "--relinearize-threshold", "nan"], "--relinearize-threshold"),
    "relin-skip-float": (["run", "--relinearize-skip", "1e9"], "--relinearize-skip"),
    "method": (["run", "--method", "isam"], "isam"),
    "plot-folder": (["run", "--plot", "{dir_png}"], "is a folder"),
    "plot-under-a-file": (["run", "--plot", "{a_file}/x.png"], "--plot"),
    "plot-suffix": (["batch", "--plot", "x.pdf"], "x.pdf"),
    "save-folder": (["run", "--save-estimates", "{dir_npz}"], "is a folder"),
    "save-missing-folder": (["run", "--save-estimates", "{missing}/x.npz"], "does not exist"),
    "batch-plot-folder": (["batch", "--dataset", "{good}", "--plot", "{dir_png}"], "--plot"),
    "fidelity-plot-folder": (["fidelity", "--plot", "{dir_png}"], "--plot"),
    "out-a-file": (["reproduce", "--out", "{a_file}"], "--out"),
    "out-under-a-file": (["reproduce", "--out", "{a_file}/results"], "--out"),
    "out-empty": (["reproduce", "--out", ""], "--out"),
    "one-pose-run": (["run", "--dataset", "{one}", "--preset", "synthetic"], "at least two poses"),
    "one-pose-batch": (["batch", "--dataset", "{one}", "--preset", "plaza"], "at least two poses"),
    "negative-range": (["run", "--dataset", "{negative}", "--preset", "plaza"], "ranges[2, 3] (range) = -1.5"),
    "nan": (["batch", "--dataset", "{nan}", "--preset", "plaza"], "GT[3, 2] (y) is nan"),
    "crashed-scipy": (["run", "--dataset", "{crash}", "--preset", "plaza"], "unknown MAT data type"),
    "score-with-ground-truth": (["run", "--score-against-optimum"], "'synthetic' has ground truth"),
    "path-without-preset-run": (
        ["run", "--dataset", "{good}"],
        "is a path: say which parameters it runs with, --preset",
    ),
    "path-without-preset-batch": (["batch", "--dataset", "{good}"], "is a path: say which parameters"),
    "cut-text": (["run", "--dataset", "{cut}", "--preset", "synthetic"], "T_TD.txt line 5: the last line does not end"),
    # BTGP's own options with a method that has no Bayes tree and no iSAM2: refused, not passed over
    "relinearize-threshold-pb": (["run", "--method", "pb", "--relinearize-threshold", "0.1"], "needs --method btgp"),
    "relinearize-skip-pbvr": (["run", "--method", "pbvr", "--relinearize-skip", "3"], "--relinearize-skip sets"),
    "amalgamation-zeros-pb": (["run", "--method", "pb", "--amalgamation-zeros", "0"], "--amalgamation-zeros sets"),
    # --turn by the one rule for numbers, as every other number (it was float(): 0.1_5 ran as 0.15)
    "turn-underscore": (["consistency", "--prior", "se2", "--turn", "0.1_5", "--seeds", "1"], "--turn"),
    "turn-blank": (["consistency", "--prior", "se2", "--turn", " 0.5", "--seeds", "1"], "--turn"),
    # an option given twice with two values: argparse kept the last, the first dropped in silence
    "lag-twice": (["run", "--lag", "1", "--lag", "2"], "argument --lag: given twice, 1.0 and 2.0: give it once"),
    "dataset-twice": (["batch", "--dataset", "plaza", "--dataset", "synthetic"], "--dataset: given twice"),
    "out-twice": (["reproduce", "--out", "{root}/a", "--out", "{root}/b"], "--out: given twice"),
    "switch-both-ways": (
        ["run", "--interpolate", "--no-interpolate"],
        "given twice, --interpolate and --no-interpolate",
    ),
    "progress-both-ways": (
        ["conformance", "selftest", "--no-progress", "--progress"],
        "--progress/--no-progress: given",
    ),
    "newline-in-value": (["run", "--every", "1", "x\ny"], "x\\ny"),
    "subcommand": (["frobnicate"], "frobnicate"),
}


_cli = runner()


def _assert_one_line_exit_2(code: int, out: str, err: str, needle: str) -> None:
    assert code == 2, err
    assert out == ""
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("steam-ref: error: "), err
    assert needle in err and "Traceback" not in err


@pytest.mark.parametrize("name", list(BAD))
def test_bad_input_is_one_line_and_exit_2_before_any_run(capsys, places, name: str) -> None:
    argv, needle = BAD[name]
    argv = [a.format(**places) for a in argv]
    _assert_one_line_exit_2(*_cli(capsys, *argv), needle.format(**places))


def test_an_output_check_leaves_no_file_behind(capsys, places) -> None:
    """The check of --save-estimates/--plot makes nothing at the path (nothing is opened or made there)."""
    target = Path(places["root"]) / "est.npz"
    code, _, err = _cli(capsys, "run", "--dataset", places["missing"] + ".mat", "--save-estimates", target)
    assert code == 2 and "missing.mat" in err and not target.exists()


VALUE = st.one_of(
    st.text(max_size=8),
    st.integers(-(10**30), 10**30).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(["0", "-0", "1e400", "nan", "-inf", "1_000", "0x10", "", " ", "--", "-1", "2.0"]),
)
OPTION = st.sampled_from(
    [
        "--every",
        "--skip",
        "--max-poses",
        "--seed",
        "--time-budget",
        "--relinearize-threshold",
        "--relinearize-skip",
        "--method",
        "--preset",
        "--departure",
        "--dataset",
        "--data-dir",
    ]
)


@settings(max_examples=80, deadline=None, database=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(option=OPTION, value=VALUE)
def test_any_value_of_any_option_gives_one_line_and_exit_2(capsys, places, option: str, value: str) -> None:
    """The data set is missing, so a valid value still ends in its one-line error, before any run."""
    dataset = [] if option == "--dataset" else ["--dataset", places["missing"] + ".mat"]
    code, out, err = _cli(capsys, "run", *dataset, option, value)
    _assert_one_line_exit_2(code, out, err, "")


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["run", "--seed", "-1"], "--seed"),
        (["batch", "--dataset", "one.mat", "--preset", "plaza"], "at least two poses"),
    ],
)
def test_the_module_as_a_user_runs_it(places, argv, needle) -> None:
    argv = [places["one"] if a == "one.mat" else a for a in argv]
    proc = run_module(*argv, timeout=120)
    assert proc.returncode == 2 and proc.stdout == ""
    assert len(proc.stderr.splitlines()) == 1 and needle in proc.stderr and "Traceback" not in proc.stderr


def test_an_option_given_twice_with_one_value_is_taken_and_each_parse_is_its_own() -> None:
    """The same value twice loses nothing: taken. A parser parses again from nothing: a value of an earlier parse is
    not a first value of the next."""
    from steam_ref.cli.commands import build_parser

    parser = build_parser("run")
    assert parser.parse_args(["run", "--lag", "1", "--lag", "1"]).lag == 1.0
    assert parser.parse_args(["run", "--lag", "2"]).lag == 2.0
    assert parser.parse_args(["run", "--no-progress", "--no-progress"]).progress is False
    assert parser.parse_args(["run", "--progress"]).progress is True
