"""The generated 3-D data set by name: ``steam-ref run --dataset synthetic-3d`` solves it with each SE(3) prior in
batch, by BTGP and fixed-lag, and scores the estimate against the generator's true states; a planar prior on a 3-D
set (or a 3-D prior on a planar one) is refused in one line naming what each runs with.

Oracles: SciPy's rotations for the APE on SE(3) (the angle of Rᵀ R̂, the translation's distance); the χ² law of a
state's NEES; the yardsticks a run must beat (the prior's predictions from the first state, a straight line between
the position fixes); the registry and the prior table for what a refusal must name.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from cli_runs import runner
from requirements import optional_import
from scipy.spatial.transform import Rotation

from steam_ref.datasets.registry import DATASETS, loadable
from steam_ref.datasets.rigid import RIGID_QC, generate_rigid
from steam_ref.datasets.search import load_dataset
from steam_ref.evaluate import chi2_quantile, group_ape, read_kitti, read_tum
from steam_ref.lie import SE3V
from steam_ref.lie.points import point_dim
from steam_ref.lie.state import GroupState
from steam_ref.manifold import VECTOR
from steam_ref.motion import MOTION_PRIORS, motion_prior
from steam_ref.paper.rigid import solve_rigid

run = runner("run")


def test_group_ape_is_the_distance_and_the_angle_of_the_relative_rotation():
    rng = np.random.default_rng(3)
    truth, estimate = SE3V.exp(rng.normal(size=(7, 6))), SE3V.exp(rng.normal(size=(7, 6)))
    error = group_ape(SE3V, truth, estimate)
    T, E = SE3V.matrix(truth), SE3V.matrix(estimate)
    np.testing.assert_allclose(error.translation, np.linalg.norm(E[:, :3, 3] - T[:, :3, 3], axis=1), rtol=1e-12)
    relative = Rotation.from_matrix(np.einsum("nji,njk->nik", T[:, :3, :3], E[:, :3, :3]))
    np.testing.assert_allclose(error.heading, relative.magnitude(), rtol=1e-10)


def test_the_generated_set_by_name_holds_the_generators_truth_and_every_other_fix_held_out():
    data = load_dataset("synthetic-3d", seed=2)
    again = generate_rigid(seed=2)
    np.testing.assert_array_equal(data.truth, again.truth)
    assert data.kind is GroupState(SE3V) and data.truth.shape == (41, 12) and data.initial_states is None
    np.testing.assert_array_equal(data.qc, RIGID_QC)
    assert len(data.positions) == 5 and len(data.held_out) == 4  # fixes every 5 s, every other one held out
    # a held-out fix is the true position at its state's time plus the fixes' noise (0.1 m): within 5 sigma
    at = np.searchsorted(data.state_times, data.held_out[:, 0])
    true = SE3V.matrix(data.truth[at, :6])[:, :3, 3]
    assert np.max(np.abs(data.held_out[:, 1:] - true)) < 5 * data.sigmas["position"]
    assert DATASETS["synthetic-3d"].dimensions == 3 and not DATASETS["synthetic-3d"].files


@pytest.mark.parametrize("prior", ["se3", "se3-wnoj"])
def test_a_run_on_the_generated_set_beats_its_yardsticks_and_lies_within_a_few_sigma_of_the_truth(capsys, prior):
    """30 steps, seed 1: every method's translation and rotation RMSE beat dead reckoning, and its translation the
    straight line between the fixes, at the states and at the held-out fixes; batch (from BTGP's estimate) and BTGP
    agree; the mean pose NEES of batch and BTGP is inside the central 99.9 % of one state's χ²₆ (a covariance 4
    times too small or large falls outside)."""
    code, out, err = run(
        capsys, "--dataset", "synthetic-3d", "--prior", prior, "--steps", 30, "--seed", 1, "--lag", 5, "--json"
    )
    assert code == 0, err
    summary = json.loads(out)
    assert (summary["dataset"], summary["prior"], summary["states"]) == ("synthetic-3d", prior, 31)
    assert summary["batch"]["converged"] and summary["batch"]["start"] == "btgp"
    truth = summary["against_truth"]
    dead, line = truth["dead_reckoning"], truth["straight_line"]["translation_rmse_m"]
    lo, hi = chi2_quantile(0.0005, 6), chi2_quantile(0.9995, 6)
    for method in ("batch", "btgp", "fixed-lag"):
        f = truth[method]
        assert f["translation_rmse_m"] < min(line, dead["translation_rmse_m"]) / 3, (method, f, line, dead)
        assert f["rotation_rmse_rad"] < dead["rotation_rmse_rad"] / 3, (method, f, dead)
        assert summary[method]["rmse_m"] < summary["straight_line"]["rmse_m"], method
        assert summary[method]["dropped_readings"] == 0
        if method != "fixed-lag":
            assert lo < f["pose_anees"] < hi, (method, f["pose_anees"], (lo, hi))
    for key in ("translation_rmse_m", "rotation_rmse_rad", "pose_anees"):
        assert truth["batch"][key] == pytest.approx(truth["btgp"][key], rel=0.05), key
    assert "fixed-lag" in summary and "pose_anees" not in truth["fixed-lag"]


def test_a_runs_report_counts_every_table_of_readings_it_reads(capsys):
    """The JSON's ``readings`` count each table the set gives the solvers (fixes, gyro, ranges, landmark points), as
    the generator with the same steps and seed holds them: a table left out of the report read as none."""
    code, out, err = run(capsys, "--dataset", "synthetic-3d", "--steps", 12, "--seed", 1, "--json")
    assert code == 0, err
    data = generate_rigid(12, seed=1)
    tables = {
        "position_fixes": data.positions,
        "gyro": data.gyro,
        "ranges": data.ranges,
        "landmark_points": data.points,
    }
    assert json.loads(out)["readings"] == {name: len(rows) for name, rows in tables.items()}
    assert len(data.ranges) > 0 and len(data.points) > 0  # the generated set has both


def test_the_text_report_says_the_figures_against_the_truth(capsys):
    code, out, _ = run(capsys, "--dataset", "synthetic-3d", "--steps", 8)
    assert code == 0
    assert "against the true states" in out and "dead_reckoning" in out and "NEES" in out


@pytest.mark.parametrize(("dataset", "prior"), [("synthetic", "se3"), ("plaza", "se3-wnoj"), ("kitti", "wnoa")])
def test_a_prior_of_other_dimensions_than_the_set_is_refused_naming_what_each_runs_with(capsys, dataset, prior):
    code, out, err = run(capsys, "--dataset", dataset, "--prior", prior, "--max-poses", 5)
    assert code == 2 and not out and err.count("\n") == 1, err
    wanted, space = MOTION_PRIORS[prior].dimensions, DATASETS[dataset].dimensions
    sets = [n for n in loadable() if DATASETS[n].dimensions == wanted]
    priors = [p for p, c in MOTION_PRIORS.items() if c.dimensions == space]
    assert f"--prior {prior} runs on --dataset {' | '.join(sets)}" in err, err
    assert f"--dataset {dataset} runs with --prior {' | '.join(priors)}" in err, err


@pytest.mark.parametrize("name", list(MOTION_PRIORS))
def test_each_priors_dimensions_are_those_its_states_move_in(name):
    """``PriorChoice.dimensions`` (what the refusal reads) agrees with the prior built: 2 for the vector priors'
    [x, y, θ], the dimension of the points its group moves otherwise."""
    choice = MOTION_PRIORS[name]
    prior = motion_prior(name, np.eye(3 if choice.dimensions == 2 else 6))
    assert choice.dimensions == (2 if prior.kind is VECTOR else point_dim(prior.kind.group))


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["--dataset", "synthetic-3d"], "--dataset synthetic-3d: fit-qc fits Qc to the planar poses"),
        (["--dataset", "plaza", "--prior", "se3"], "--prior se3 moves a body in 3-D and --dataset plaza is 2-D"),
    ],
)
def test_fit_qc_refuses_a_3d_set_or_prior_in_one_line(capsys, argv, says):
    code, out, err = runner("fit-qc")(capsys, *argv)
    assert code == 2 and not out and err.count("\n") == 1 and says in err, err


@pytest.mark.parametrize("prior", ["se3", "se3-simplified", "se3-wnoj"])
def test_a_singer_time_constant_for_a_3d_prior_without_one_is_refused_not_ignored(capsys, prior):
    """--singer-time-constant on a 3-D run with a prior that has no time constant was dropped without a word (the run
    printed the prior's figures as if it had been read); the planar run refuses it, and so must the 3-D one."""
    code, out, err = run(
        capsys, "--dataset", "synthetic-3d", "--steps", 3, "--prior", prior, "--singer-time-constant", 3
    )
    assert code == 2 and not out and err.count("\n") == 1, err
    assert "--singer-time-constant applies to" in err and "--prior se3-singer" in err and f"not --prior {prior}" in err


def test_a_singer_time_constant_reaches_the_3d_singer_prior(capsys):
    """The time constant given is the one the run's prior has: its JSON figures are those of ``solve_rigid`` with
    ``motion_prior('se3-singer', RIGID_QC, singer_time_constant=5)`` on the same generated set, and differ from the
    default's."""
    from steam_ref.paper.rigid import solve_rigid

    code, out, _ = run(capsys, "--dataset", "synthetic-3d", "--steps", 4, "--prior", "se3-singer",
                       "--singer-time-constant", 5, "--json")  # fmt: skip
    assert code == 0
    figures = json.loads(out)["against_truth"]["btgp"]
    data = generate_rigid(4, seed=0)
    for tau, equal in ((5.0, True), (1.0, False)):
        prior = motion_prior("se3-singer", RIGID_QC, singer_time_constant=tau)
        states = solve_rigid(data, prior, "btgp").states
        truth = data.on(prior.kind).truth
        rmse = float(np.sqrt(np.mean(group_ape(SE3V, truth[:, :6], states[:, :6]).translation ** 2)))
        assert (rmse == pytest.approx(figures["translation_rmse_m"], rel=1e-12)) is equal


# -- --save-trajectory on a 3-D run: the estimate of the run's method (BTGP; with --lag the fixed-lag smoother's) --


def _solved(method: str, steps: int = 12, seed: int = 1, lag: float = 10.0) -> tuple[np.ndarray, np.ndarray]:
    """The API's estimate of the CLI's run: the states' times and the poses (n, 6) of ``solve_rigid`` by ``method``."""
    data = generate_rigid(steps, seed=seed)
    solved = solve_rigid(data, motion_prior("se3", data.qc), method, lag=lag)
    return data.state_times, solved.states[:, :6]


@pytest.mark.parametrize(("method", "lag"), [("btgp", []), ("fixed-lag", ["--lag", 4])])
def test_a_3d_run_writes_its_methods_poses_as_tum_and_kitti_and_evo_reads_them(capsys, tmp_path, method, lag):
    """Refused until now ("--save-trajectory does not apply"). The file holds the estimate of the run's method: BTGP's
    (the planar run's default --method, the only one a 3-D run takes), with --lag the fixed-lag smoother's, at the
    states' times: the API's solve_rigid of the same task to 1e-12, the times exact; evo reads the same poses."""
    file_interface = optional_import("evo.tools.file_interface", "evo")
    tum, kitti = tmp_path / "estimate.txt", tmp_path / "estimate.kitti"
    argv = ["--dataset", "synthetic-3d", "--steps", 12, "--seed", 1, *lag, "--json"]
    code, out, err = run(capsys, *argv, "--save-trajectory", tum)
    assert code == 0, err
    assert method in json.loads(out)
    code, _, err = run(capsys, *argv, "--save-trajectory", kitti, "--trajectory-format", "kitti")
    assert code == 0, err
    times, poses = _solved(method, lag=float(lag[1]) if lag else 10.0)
    read_times, tum_poses = read_tum(tum, group=SE3V)
    np.testing.assert_array_equal(read_times, times)
    want = SE3V.matrix(poses)
    for back in (tum_poses, read_kitti(kitti, group=SE3V)):
        np.testing.assert_allclose(SE3V.matrix(back), want, rtol=0, atol=1e-12)
    theirs = file_interface.read_tum_trajectory_file(str(tum))
    np.testing.assert_array_equal(theirs.timestamps, times)
    np.testing.assert_allclose(np.array(theirs.poses_se3), want, rtol=0, atol=1e-12)
    if method == "btgp":  # not batch's estimate, which the run also solves (from BTGP's): the two differ
        data = generate_rigid(12, seed=1)
        start = solve_rigid(data, motion_prior("se3", RIGID_QC), "btgp").states  # the run's batch starts there
        batch = solve_rigid(data, motion_prior("se3", RIGID_QC), "batch", initial=start)
        assert np.max(np.abs(SE3V.matrix(batch.states[:, :6]) - want)) > 1e-6


def test_a_3d_run_replaces_an_existing_trajectory_file_as_the_planar_run_does(capsys, tmp_path):
    """The planar rule (cli/paths.py: a regular file that can be written is replaced after the run, in one step)."""
    saved = tmp_path / "estimate.txt"
    for dataset in ("synthetic", "synthetic-3d"):
        saved.write_text("old\n")
        code, _, err = run(capsys, "--dataset", dataset, "--steps", 6, "--save-trajectory", saved)
        assert code == 0, err
        assert "old" not in saved.read_text() and len(read_tum(saved, group=SE3V)[0]) == 7


@pytest.mark.parametrize(
    ("argv", "says"),
    [
        (["--save-trajectory", "{d}/no/t.txt"], "--save-trajectory: cannot write '{d}/no/t.txt': folder '{d}/no' does"),
        (["--save-trajectory", "{d}"], "--save-trajectory: '{d}' is a folder, not a file"),
        (["--save-trajectory", ""], "--save-trajectory: expected a file name, got ''"),
        (["--trajectory-format", "kitti"], "--trajectory-format kitti is the format of --save-trajectory FILE"),
    ],
)
def test_a_3d_runs_bad_trajectory_output_is_refused_in_one_line_before_the_run(capsys, tmp_path, argv, says):
    argv = [a.format(d=tmp_path) for a in argv]
    code, out, err = run(capsys, "--dataset", "synthetic-3d", "--steps", 6, *argv)
    assert code == 2 and out == "" and err.count("\n") == 1, err
    assert says.format(d=tmp_path) in err, err
    assert list(tmp_path.iterdir()) == []
