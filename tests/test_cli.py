"""The steam-ref command: options, --json keys, --save-estimates, one-line errors with exit 2."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest
from cli_runs import run_module, runner
from requirements import optional_import, skip_or_fail

from steam_ref.cli.commands import main
from steam_ref.datasets import gtsam_data_dir
from steam_ref.errors import DivergenceWarning
from steam_ref.paper.online import run_online
from steam_ref.paper.presets import PaperSetup

JSON_KEYS = {
    "dataset",
    "method",
    "every",
    "skip",
    "interpolate",
    "n_estimated_states",
    "rmse_m",
    "total_s",
    "update_s_median",
    "update_s_p95",
    "peak_rss_mb",
}


_run = runner()


def _run_small(capsys, path, *args: object) -> tuple[int, str, str]:
    """``steam-ref run`` on the small task (conftest's ``small_mat``) with the synthetic preset, then ``args``."""
    return _run(capsys, "run", "--dataset", path, "--preset", "synthetic", *args)


def test_json_line_has_the_keys_and_sane_values(capsys, small_mat):
    path, data = small_mat
    code, out, err = _run_small(capsys, path, "--method", "pb", "--skip", "3", "--json")
    assert code == 0, err
    lines = out.strip().splitlines()
    assert len(lines) == 1
    row = json.loads(lines[0])
    assert set(row) >= JSON_KEYS
    assert row["method"] == "pb" and row["skip"] == 3 and row["every"] == 1 and row["interpolate"] is True
    assert row["n_estimated_states"] == len(set(range(0, data.n_poses, 3)) | {data.n_poses - 1})
    assert 0 < row["rmse_m"] < 1.0
    assert row["total_s"] > 0 and 0 < row["update_s_median"] <= row["update_s_p95"]
    assert 10 < row["peak_rss_mb"] < 4000


def test_no_interpolate_flag_reaches_the_run(capsys, small_mat):
    path, _ = small_mat
    code, out, _ = _run_small(
        capsys, path, "--method", "pbvr", "--skip", "4", "--no-interpolate", "--every", "10", "--json"
    )
    row = json.loads(out)
    assert code == 0 and row["interpolate"] is False and row["every"] == 10 and row["method"] == "pbvr"


def test_relinearization_flags_reach_the_run(capsys, small_mat):
    """--relinearize-threshold/--relinearize-skip give the library's run with those options."""
    from steam_ref.paper.online import run_online
    from steam_ref.paper.options import StreamOptions
    from steam_ref.paper.presets import PaperSetup

    path, data = small_mat
    setup = PaperSetup.synthetic()
    code, out, err = _run_small(capsys, path, "--relinearize-threshold", "0", "--relinearize-skip", "1", "--json")
    assert code == 0, err
    direct = run_online(data, setup.with_isam2(relinearize_threshold=0.0, relinearize_skip=1), StreamOptions())
    default = run_online(data, setup, StreamOptions())
    assert direct.rmse_m != default.rmse_m  # the flags change the run, so the comparison below means something
    assert json.loads(out)["rmse_m"] == round(direct.rmse_m, 6)


def test_save_estimates_writes_every_time_step(capsys, small_mat, tmp_path):
    path, data = small_mat
    target = tmp_path / "est.npz"
    code, _, err = _run_small(capsys, path, "--method", "pb", "--skip", "2", "--save-estimates", target)
    assert code == 0, err
    saved = np.load(target)
    n = data.n_poses
    assert saved["times"].shape == saved["x"].shape == saved["y"].shape == saved["theta"].shape == (n,)
    np.testing.assert_array_equal(saved["times"], data.times)  # the file's own stamps, in seconds
    err_xy = np.hypot(saved["x"] - data.ground_truth[:, 1], saved["y"] - data.ground_truth[:, 2])
    assert np.sqrt(np.mean(err_xy**2)) < 1.0
    assert sorted(saved["landmark_ids"].tolist()) == sorted(np.unique(data.ranges[:, 2]).astype(int).tolist())
    assert saved["landmarks"].shape == (len(saved["landmark_ids"]), 2)


@pytest.mark.parametrize("method", ["pb", "btgp"])
def test_save_estimates_writes_the_final_marginals(capsys, small_mat, tmp_path, method):
    """pose/velocity covariance at every time step and each landmark's: against a dense inverse of the
    information matrix of all the run's factors, linearized where the solver holds them (PB: at its
    estimate; BTGP: at its linearization point), interpolated between states (gp.interpolate_covariance)."""
    from steam_ref.gp.interpolate import interpolate_covariance
    from steam_ref.graph import FactorGraph
    from steam_ref.linear import LinearSystem
    from steam_ref.linear.ordering import xl_ordering
    from steam_ref.paper.online import StreamingEstimator
    from steam_ref.paper.options import StreamOptions
    from steam_ref.paper.presets import PaperSetup
    from steam_ref.paper.readings import Readings
    from steam_ref.variables import L, X

    path, data = small_mat
    target = tmp_path / "est.npz"
    code, _, err = _run_small(capsys, path, "--method", method, "--skip", "3", "--save-estimates", target)
    assert code == 0, err
    saved = np.load(target)
    setup = PaperSetup.synthetic()
    est = StreamingEstimator(Readings.from_dataset(data, setup), setup, StreamOptions(method=method, skip=3))
    while not est.done:
        est.step()
    if method == "pb":
        factors, point = est.solver.graph.factors, est.solver.estimate()
    else:
        factors, point = est.solver.inner.factors, est.solver.inner.linearization_point
    keys = FactorGraph(factors).keys()
    order = xl_ordering(keys, {k: point.dim(k) for k in keys})
    A, _ = LinearSystem.build(factors, point, order).to_dense()
    cov = np.linalg.inv(A.T @ A)

    def block(*ks):
        idx = np.concatenate([order.offset_of[k] + np.arange(point.dim(k)) for k in ks])
        return cov[np.ix_(idx, idx)]

    states = est.states
    for p in range(data.n_poses):
        if p in states:
            expected = block(X(p))
        else:
            a, b = max(s for s in states if s < p), min(s for s in states if s > p)
            expected = interpolate_covariance(a, b, p, setup.qc, block(X(a), X(b)))
        np.testing.assert_allclose(saved["pose_covariance"][p], expected[:3, :3], rtol=1e-6, atol=1e-10)
        np.testing.assert_allclose(saved["velocity_covariance"][p], expected[3:, 3:], rtol=1e-6, atol=1e-10)
    for i, lid in enumerate(saved["landmark_ids"]):
        np.testing.assert_allclose(saved["landmark_covariance"][i], block(L(int(lid))), rtol=1e-6, atol=1e-10)


def test_fidelity_command_prints_the_distance_to_the_authors_run_and_names_its_run_in_the_progress(capsys, shared_data):
    argv = ["fidelity", "--dataset", "paper-synthetic", "--data-dir", shared_data, "--json", "--progress"]
    code, out, err = _run(capsys, *argv)
    assert code == 0, err
    assert "paper-synthetic BTGP/1:" in err  # the bar names its data set and method (--progress beside --json)
    row = json.loads(out)
    assert row["dataset"] == "paper-synthetic" and row["n_states"] == 1501
    assert row["pose_max_m"] < 0.01 and row["pose_rms_m"] <= row["pose_max_m"]
    assert row["authors_rmse_m"] == pytest.approx(0.0697, abs=5e-5)
    read = [shared_data / "Syn_theta_Plaza.mat", shared_data / "authors" / "Syn_full_data_run.mat"]
    assert row["data_files"] == [
        {"path": str(p), "sha256": hashlib.sha256(p.read_bytes()).hexdigest()[:12]} for p in read
    ]  # which files were read, each with its hash


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["run", "--skip", "0"], "--skip"),
        (["run", "--every", "x"], "--every"),
        (["run", "--relinearize-threshold", "-1"], "--relinearize-threshold"),
        (["run", "--relinearize-skip", "0"], "--relinearize-skip"),
        (["run", "--method", "gtsam"], "gtsam"),
        (["fidelity", "--dataset", "moon"], "moon"),
        (["fidelity", "--plot", "out.txt"], "out.txt"),
        (["run", "--dataset", "no-such-thing.mat"], "no-such-thing.mat"),
        (["run", "--preset", "moon"], "moon"),
        (["run", "--save-estimates", "out.txt"], "out.txt"),
        (["frobnicate"], "frobnicate"),
    ],
)
def test_errors_are_one_line_and_exit_2(capsys, argv, needle):
    code, out, err = _run(capsys, *argv)
    assert code == 2
    assert out == ""
    assert len(err.strip().splitlines()) == 1 and needle in err and "Traceback" not in err


def test_malformed_data_file_is_one_line_exit_2(capsys, tmp_path):
    bad = tmp_path / "bad.mat"
    bad.write_bytes(b"this is not a MATLAB file")
    code, _, err = _run(capsys, "run", "--dataset", str(bad))
    assert code == 2 and len(err.strip().splitlines()) == 1 and "bad.mat" in err


def test_module_entry_point_runs(small_mat):
    path, _ = small_mat
    proc = run_module(
        "run", "--dataset", path, "--preset", "synthetic", "--method", "pb", "--skip", 5, "--json", timeout=120
    )
    assert proc.returncode == 0, proc.stderr
    assert set(json.loads(proc.stdout)) >= JSON_KEYS
    proc = run_module("run", "--skip", "-1", timeout=60)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1


def test_batch_command_matches_a_direct_gauss_newton(capsys, small_mat, tmp_path):
    """`steam-ref batch` reports the RMSE of the converged batch, which the library reproduces."""
    import steam_ref as sr
    from steam_ref.datasets import load_cmu_mat
    from steam_ref.paper.presets import PaperSetup
    from steam_ref.paper.problem import build_problem, sequential_batch
    from steam_ref.paper.results import position_rmse

    path, data = small_mat
    plot = tmp_path / "b.png"
    code, out, err = _run(
        capsys,
        "batch",
        "--dataset",
        str(path),
        "--preset",
        "synthetic",
        "--ordering",
        "xl",
        "--json",
        "--plot",
        str(plot),
    )
    assert code == 0, err
    row = json.loads(out.strip())
    problem = build_problem(load_cmu_mat(path), PaperSetup.synthetic())
    values = sr.gauss_newton(problem.graph, sequential_batch(problem, ordering="amd").values, ordering="xl").values
    positions = np.array([values[sr.X(i)][:2] for i in range(data.n_poses)])
    assert row["ordering"] == "xl" and row["n_states"] == data.n_poses
    assert abs(row["rmse_m"] - position_rmse(positions, data.ground_truth[:, 1:3])) < 1e-4
    assert plot.stat().st_size > 1000


@pytest.mark.parametrize(("ordering", "name"), [("xl", "PB"), ("amd", "PBVR")])
def test_batch_text_names_the_papers_method_and_where_the_plot_went(capsys, small_mat, tmp_path, ordering, name):
    """The README's names (PB: XL ordering, PBVR: AMD) in the command's own line, and the plot's full path."""
    path, _ = small_mat
    plot = tmp_path / "b.png"
    argv = ["batch", "--dataset", str(path), "--preset", "synthetic", "--ordering", ordering, "--plot", str(plot)]
    code, out, err = _run(capsys, *argv)
    assert code == 0, err
    assert out.startswith(f"batch {name} ({ordering.upper()} ordering) on {path}:")
    assert f"plot written to {plot.resolve()}" in out.splitlines()
    assert plot.stat().st_size > 1000
    code, out, err = _run(capsys, *argv, "--json")
    assert code == 0, err
    assert len(out.strip().splitlines()) == 1 and json.loads(out)["ordering"] == ordering  # --json: one line only


def test_fidelity_without_the_authors_files_is_one_line_and_exit_2(capsys, tmp_path, monkeypatch, shared_data):
    import shutil

    monkeypatch.delenv("STEAM_REF_DATA_DIR", raising=False)
    shutil.copy(shared_data / "Syn_theta_Plaza.mat", tmp_path)  # the data set, but no authors/ folder
    code, out, err = _run(capsys, "fidelity", "--dataset", "paper-synthetic", "--data-dir", str(tmp_path))
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1 and "authors/Syn_full_data_run.mat not found" in err


def test_departure_flags_reach_the_set_up(capsys, small_mat):
    """--departure NAME runs the preset departing from the scripts in that named way."""
    from steam_ref.paper.online import run_online
    from steam_ref.paper.options import StreamOptions
    from steam_ref.paper.presets import PaperSetup

    path, data = small_mat
    code, out, err = _run_small(
        capsys,
        path,
        "--skip",
        "3",
        "--departure",
        "plain-heading-rate",
        "--departure",
        "whole-state-relinearization",
        "--json",
    )
    assert code == 0, err
    row = json.loads(out)
    assert row["departures"] == ["plain-heading-rate", "whole-state-relinearization"]
    setup = PaperSetup.synthetic().replace(pose2_heading_rate_guess=False, relinearize_blocks=None)
    assert row["rmse_m"] == round(run_online(data, setup, StreamOptions(skip=3)).rmse_m, 6)
    for departure in ("plain-heading-rate", "whole-state-relinearization"):  # each one on its own reaches the run
        _, out, _ = _run_small(capsys, path, "--skip", "3", "--departure", departure, "--json")
        setup = PaperSetup.synthetic().departing(departure)
        assert json.loads(out)["rmse_m"] == round(run_online(data, setup, StreamOptions(skip=3)).rmse_m, 6)
    code, _, err = _run(capsys, "run", "--departure", "sorted-ranges")
    assert code == 2 and "sorted-ranges" in err


def test_prior_flags_reach_the_setup(capsys, small_mat, tmp_path):
    """--prior singer with --qc-scale is the same run as the API with that set-up, and saves accelerations (on the
    first 24 poses: PB re-solves every pose so far at each update, and the flags reach the run at the first)."""
    path, data = small_mat
    out_file = tmp_path / "singer.npz"
    code, out, err = _run_small(
        capsys,
        path,
        "--method",
        "pb",
        "--skip",
        "2",
        "--max-poses",
        "24",
        "--prior",
        "singer",
        "--qc-scale",
        "10",
        "--singer-time-constant",
        "3",
        "--json",
        "--save-estimates",
        out_file,
    )
    assert code == 0, err
    row = json.loads(out)
    assert row["prior"] == "singer" and row["qc_scale"] == 10.0
    base = PaperSetup.synthetic()
    setup = base.replace(prior="singer", qc=10 * base.qc, singer_time_constant=3.0)
    direct = run_online(data, setup, method="pb", skip=2, max_poses=24)
    saved = np.load(out_file)
    assert len(saved["x"]) == len(direct.trajectory) == 24
    np.testing.assert_allclose(saved["x"], direct.trajectory[:, 0], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(saved["thetaddot"], direct.trajectory[:, 8], rtol=1e-9, atol=1e-9)
    assert row["rmse_m"] == pytest.approx(direct.rmse_m, abs=1e-6)


DIVERGING = ["run", "--prior", "se2", "--qc-scale", "1e-8", "--max-poses", "12", "--json"]  # misses its prior


def test_a_diverging_run_warns_in_one_clean_line_and_counts_the_rest():
    """Not Python's `file:line: DivergenceWarning: ...` and its source line per update: the first warning as
    one line, the other nine counted at the end; the run completes (exit 0) and its JSON lists them."""
    proc = run_module(*DIVERGING)
    assert proc.returncode == 0, proc.stderr
    first, *rest = proc.stderr.splitlines()
    assert first.startswith("steam-ref: warning: update at pose 2: the estimate is diverging: it misses")
    assert ".py:" not in first and "DivergenceWarning" not in first
    assert rest == ["steam-ref: warning: 8 more DivergenceWarnings after the first (above), not shown"]
    assert len(json.loads(proc.stdout)["divergence"]) == 9


def test_the_clean_display_hides_no_warning_from_a_caller(capsys):
    with pytest.warns(DivergenceWarning) as caught:
        assert main(DIVERGING) == 0
    assert len([w for w in caught if w.category is DivergenceWarning]) == 9
    assert capsys.readouterr().err == ""  # recorded by the caller, so not shown


def _commands(parser, prefix=()):
    """Every (sub)command of ``parser`` as (its words, its parser), depth first."""
    import argparse

    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, child in action.choices.items():
                yield (*prefix, name), child
                yield from _commands(child, (*prefix, name))


def test_every_commands_help_says_what_it_does_and_gives_an_example_that_parses():
    """``steam-ref COMMAND --help`` opens with the line ``steam-ref --help`` lists for it and ends with
    ``example: steam-ref COMMAND ...``, which the command's own parser accepts as written."""
    import shlex

    from steam_ref.cli.commands import build_parser

    found = list(_commands(build_parser()))
    assert {words[0] for words, _ in found} >= {"run", "batch", "fidelity", "data", "conformance", "homework"}
    for words, parser in found:
        text = parser.format_help()
        assert parser.description and parser.description in text, words
        [example] = [line for line in text.splitlines() if line.startswith("example: ")]
        argv = shlex.split(example.removeprefix("example: "))
        assert argv[: 1 + len(words)] == ["steam-ref", *words], example
        build_parser(argv[1]).parse_args(argv[1:])  # raises SteamError if an option is misspelt


def test_batch_without_ground_truth_says_not_scored(capsys, tmp_path):
    """A data set without ground truth (Victoria Park's first 100 poses): batch printed 'RMSE None m'; it is not scored."""
    optional_import("gtsam", "gtsam")
    folder = gtsam_data_dir()
    if folder is None or not (folder / "victoria_park.txt").is_file():
        skip_or_fail("gtsam's Data/ folder has no victoria_park.txt; pip install gtsam", "optional")
    lines = (folder / "victoria_park.txt").read_text().splitlines()
    lines = lines[: [i for i, line in enumerate(lines) if line.startswith("ODOMETRY")][100]]  # 100 poses
    path = tmp_path / "vp100.txt"
    path.write_text("\n".join(lines) + "\n")
    code, out, err = _run(capsys, "batch", "--dataset", path, "--preset", "victoria-park")
    assert code == 0, err
    assert "None" not in out and "not scored" in out
    code, out, err = _run(capsys, "batch", "--dataset", path, "--preset", "victoria-park", "--json")
    assert code == 0, err
    assert json.loads(out)["rmse_m"] is None


def test_run_says_where_each_file_went(capsys, small_mat, tmp_path):
    """--save-estimates, --save-trajectory and --tree-dot wrote their files without a word; each now has a line
    with its full path, as --plot has (and --json keeps its one line)."""
    path, _ = small_mat
    files = {
        "--save-estimates": tmp_path / "e.npz",
        "--save-trajectory": tmp_path / "t.txt",
        "--tree-dot": tmp_path / "t.dot",
    }
    argv = [a for option, file in files.items() for a in (option, file)]
    code, out, err = _run_small(capsys, path, *argv)
    assert code == 0, err
    lines = out.splitlines()
    for what, file in zip(("estimates", "trajectory", "tree dot"), files.values(), strict=True):
        assert f"{what} written to {file.resolve()}" in lines
    code, out, err = _run_small(capsys, path, *argv, "--json")
    assert code == 0, err
    assert len(out.strip().splitlines()) == 1
    code, out, err = _run_small(capsys, path, *argv)  # every file there now: each line says it replaced one
    assert code == 0, err
    lines = out.splitlines()
    for what, file in zip(("estimates", "trajectory", "tree dot"), files.values(), strict=True):
        assert f"{what} written to {file.resolve()} (replaced the file there)" in lines


@pytest.mark.parametrize("command", ["data", "conformance", "homework"])
def test_a_command_given_without_its_subcommand_names_every_subcommand(capsys, command):
    """``steam-ref data`` alone said "required: data_command", the parser's internal name; each command with
    subcommands names them all (the parser's own choices, the oracle) in its one line."""
    import argparse

    from steam_ref.cli.commands import build_parser

    def subcommands(parser: argparse.ArgumentParser) -> argparse._SubParsersAction:
        (action,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        return action

    names = sorted(subcommands(subcommands(build_parser(command)).choices[command]).choices)
    code = main([command])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1, err
    assert all(name in err for name in names), (err, names)
