"""Qc from data (steam_ref.evaluate.fit_qc, ``steam-ref fit-qc``): the maximum-likelihood diagonal Qc of a prior.

- Recovery: poses drawn from each prior's own model (``MotionPrior.sample_states``) at a known Qc, the fit started
  far from it: every fitted entry lies within 4 standard errors of the truth. The fitted Qc_jj times dof / Qc_jj is
  χ² with dof = N - 1 degrees of freedom (derivations §16.2: exact for the vector prior, to first order on SE(2)),
  so its relative standard error is sqrt(2 / dof); 4 of them fail a correct fit once in ~16,000 per entry.
- Exactness: on the vector WNOA prior the fit is the restricted maximum likelihood of the second differences of
  the positions, d = p₊ - 2p + p₋, whose covariance at Qc_jj = 1 and equal steps h is tridiagonal (2h³/3 on the
  diagonal, h³/6 beside it) [DER 16.5]: Qc_jj = dᵀ K⁻¹ d / (N - 1), computed here by a dense Cholesky solve,
  no steam_ref code. The fit holds the poses to 1e-4 of the prior's sigma, so the two agree to ~1e-7.
- Units: Qc's unit is what rescaling the data says it is (dimensional analysis): poses in lengths a times larger
  and times b times longer fit a Qc a² / b^(2k - 1) times as large for x and y and 1 / b^(2k - 1) for θ, with the
  powers read from ``qc_units`` (m²/s³ and rad²/s³ under WNOA, [YIB Eq. 14, 30-31]; the jerk's under WNOJ).
- Bad input: no ground truth, mismatched lengths, times that do not increase, a non-diagonal Qc, too few poses:
  the project's error naming the value; the command's bad input: one line, exit code 2.
"""

from __future__ import annotations

import json
import shlex

import numpy as np
import pytest
import scipy.io
import scipy.linalg
from cli_runs import runner

from steam_ref.datasets import generate_synthetic, load_dataset
from steam_ref.errors import ConvergenceWarning, DataError, ShapeError, SteamError
from steam_ref.evaluate.fit_qc import fit_qc, qc_units
from steam_ref.gp.clock import Clock
from steam_ref.motion import motion_prior

QC = np.diag([0.02, 0.05, 0.01])  # the truth the tasks are drawn at
START = 10.0  # the fit starts from Qc ten times too large
fit_cli = runner("fit-qc")
run_cli = runner("run")


def _drawn(name: str, n: int, dt: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(times, poses) of n states drawn from the prior ``name`` at QC, ``dt`` apart."""
    prior = motion_prior(name, QC)
    sigmas = [np.full(3, 1e-3), np.full(3, 1e-3)]
    states = prior.sample_states(np.random.default_rng(seed), n, dt, np.array([1.0, 0.0, 0.0]), sigmas)
    return np.arange(n) * dt, prior.world_states(states)[:, :3]


def _reml_second_differences(poses: np.ndarray, h: float) -> np.ndarray:
    """(3,) dᵀ K⁻¹ d / (N - 1) of each coordinate's second differences, K their covariance at Qc = 1 (dense)."""
    d = poses[2:] - 2.0 * poses[1:-1] + poses[:-2]
    m = len(d)
    K = h**3 * (
        np.diag(np.full(m, 2.0 / 3.0)) + np.diag(np.full(m - 1, 1.0 / 6.0), 1) + np.diag(np.full(m - 1, 1.0 / 6.0), -1)
    )
    factor = scipy.linalg.cho_factor(K)
    return np.array([d[:, j] @ scipy.linalg.cho_solve(factor, d[:, j]) for j in range(3)]) / m


@pytest.mark.parametrize("name", ["wnoa", "se2"])
def test_the_fit_recovers_the_qc_the_poses_were_drawn_at(name: str) -> None:
    times, poses = _drawn(name, 3001, 0.2, seed=7)
    fit = fit_qc(motion_prior(name, START * QC), times, poses, refit=lambda qc: motion_prior(name, qc))
    assert fit.dof == 2999 and fit.intervals == 3000 and fit.blocks == 2
    relative = np.diag(fit.qc) / np.diag(QC) - 1.0
    assert np.all(np.abs(relative) < 4.0 * np.sqrt(2.0 / fit.dof)), relative
    assert np.allclose(fit.standard_error, np.diag(fit.qc) * np.sqrt(2.0 / fit.dof))
    assert np.all(fit.qc == np.diag(np.diag(fit.qc)))  # diagonal


def test_on_the_vector_prior_it_is_the_reml_of_the_second_differences() -> None:
    h = 0.25
    times, poses = _drawn("wnoa", 801, h, seed=3)
    oracle = _reml_second_differences(poses, h)
    for start in (START * QC, 0.01 * QC):  # the velocities it smooths do not depend on the Qc it starts at
        fit = fit_qc(motion_prior("wnoa", start), times, poses)
        assert fit.rounds == 1
        np.testing.assert_allclose(np.diag(fit.qc), oracle, rtol=1e-6)


def _scale_of(unit: str, length: float, time: float) -> float:
    """What a quantity in ``unit`` ('m^2/s^3') is multiplied by when lengths are ``length`` times and times ``time``
    times what they were (an angle is not a length: unchanged)."""
    top, bottom = unit.split("/")
    base, power = top.split("^")
    clock, time_power = bottom.split("^")
    assert base in ("m", "rad") and clock in ("s", "step"), unit
    return (length if base == "m" else 1.0) ** int(power) / time ** int(time_power)


@pytest.mark.parametrize(("name", "units"), [("wnoa", "m^2/s^3"), ("wnoj", "m^2/s^5")])
def test_the_units_of_qc_are_how_it_scales_with_the_data(name: str, units: str) -> None:
    rng = np.random.default_rng(4)
    prior = motion_prior(name, QC)
    h, n = 0.3, 401
    sigmas = [np.full(3, 1e-3)] * prior.state_dim
    states = prior.sample_states(rng, n, h, np.array([1.0, 0.0, 0.0]), sigmas)
    times, poses = np.arange(n) * h, prior.world_states(states)[:, :3]
    length, time = 3.0, 2.0  # lengths and times in other units (both powers tell: 2 and 3 or 5)
    fit = fit_qc(prior, times, poses)
    scaled = fit_qc(prior, times * time, poses * np.array([length, length, 1.0]))
    got = qc_units(fit.blocks, Clock.of(times))
    assert got == (units, units, units.replace("m", "rad", 1))
    want = [_scale_of(u, length, time) for u in got]
    np.testing.assert_allclose(np.diag(scaled.qc) / np.diag(fit.qc), want, rtol=1e-6)
    np.testing.assert_allclose(scaled.standard_error / fit.standard_error, want, rtol=1e-6)
    pretty = qc_units(fit.blocks, Clock.of(times), superscripts=True)
    assert pretty[0] == ("m²/s³" if name == "wnoa" else "m²/s⁵") and pretty[2].startswith("rad²/s")
    assert qc_units(2, Clock.of(times, "pose-index")) == ("m^2/step^3", "m^2/step^3", "rad^2/step^3")


def test_headings_are_read_unwrapped() -> None:
    """A heading given in (-π, π] (a file's) fits as the continuous one: each step turns less than half a turn."""
    times, poses = _drawn("wnoa", 401, 0.2, seed=11)
    poses[:, 2] += np.linspace(0.0, 40.0, len(poses))  # many turns
    wrapped = poses.copy()
    wrapped[:, 2] = np.angle(np.exp(1j * wrapped[:, 2]))
    a, b = (fit_qc(motion_prior("wnoa", QC), times, p) for p in (poses, wrapped))
    np.testing.assert_allclose(np.diag(a.qc), np.diag(b.qc), rtol=1e-9)


def test_bad_input_is_refused_naming_the_value() -> None:
    prior = motion_prior("wnoa", QC)
    times, poses = np.arange(5.0), np.zeros((5, 3))
    with pytest.raises(DataError, match="needs ground truth"):
        fit_qc(prior, times, None)
    with pytest.raises(ShapeError, match="got 5 times and 4 poses"):
        fit_qc(prior, times, poses[:4])
    with pytest.raises(ShapeError, match=r"\(n, 3\).*got shape \(5, 2\)"):
        fit_qc(prior, times, poses[:, :2])
    with pytest.raises(DataError, match=r"times\[2\] = 2.0 and times\[3\] = 2.0"):
        fit_qc(prior, [0.0, 1.0, 2.0, 2.0, 3.0], poses)
    with pytest.raises(ShapeError, match=r"poses\[1, 0\] = nan"):
        fit_qc(prior, times, np.where(np.arange(15).reshape(5, 3) == 3, np.nan, 0.0))
    with pytest.raises(SteamError, match="diagonal Qc"):
        fit_qc(motion_prior("se2", QC + 0.001 * (1 - np.eye(3))), times, poses)
    with pytest.raises(DataError, match="more than 1 steps"):
        fit_qc(prior, times[:2], poses[:2])
    with pytest.raises(DataError, match=r"more than 1 steps between poses.*got 0"):
        fit_qc(prior, times[:1], poses[:1])
    with pytest.raises(DataError, match=r"more than 2 steps between poses.*got 0"):  # it said 1: WNOA's, guessed
        fit_qc(motion_prior("wnoj", QC), times[:1], poses[:1])
    with pytest.raises(DataError, match=r"more than 2 steps between poses.*got 2"):
        fit_qc(motion_prior("wnoj", QC), times[:3], poses[:3])
    with pytest.raises(SteamError, match=r"rounds must be an integer >= 1, got rounds=0"):
        fit_qc(prior, times, poses, rounds=0)


def test_a_fit_that_has_not_settled_says_so() -> None:
    times, poses = _drawn("se2", 201, 0.2, seed=5)
    with pytest.warns(ConvergenceWarning, match="after 1 smoothings the fitted Qc still moved"):
        fit = fit_qc(motion_prior("se2", START * QC), times, poses, refit=lambda qc: motion_prior("se2", qc), rounds=1)
    assert fit.rounds == 1 and np.array_equal(fit.smoothed_at, START * QC)


def test_the_command_fits_the_ground_truth_of_a_data_set(capsys, shared_data) -> None:
    """paper-synthetic's first 300 poses, on its pose-index clock (h = 1): the vector prior's fit is the REML of
    the ground truth's second differences; the text prints it and the `run --qc` that uses it."""
    code, out, err = fit_cli(capsys, "--dataset", "paper-synthetic", "--max-poses", 300, "--json")
    assert code == 0, err
    figures = json.loads(out)
    truth = load_dataset("paper-synthetic").ground_truth[:300, 1:4].copy()
    truth[:, 2] = np.unwrap(truth[:, 2])
    np.testing.assert_allclose(figures["qc_diagonal"], _reml_second_differences(truth, 1.0), rtol=1e-6)
    assert figures["dof"] == 298 and figures["prior"] == "wnoa" and figures["driven"] == ["xdot", "ydot", "thetadot"]
    assert figures["qc_units"] == ["m^2/step^3", "m^2/step^3", "rad^2/step^3"]  # its preset's pose-index clock
    qc = ",".join(f"{q:.6g}" for q in figures["qc_diagonal"])
    assert figures["run"] == f"steam-ref run --dataset paper-synthetic --prior wnoa --qc {qc}"
    code, out, _ = fit_cli(capsys, "--dataset", "paper-synthetic", "--max-poses", 300)
    assert code == 0 and f"--qc {qc}" in out and "± " in out
    assert [line.split()[5] for line in out.splitlines() if line.startswith("  d/dt ")] == [
        "m²/step³",
        "m²/step³",
        "rad²/step³",
    ]
    code, out, err = run_cli(capsys, "--dataset", "paper-synthetic", "--max-poses", 30, "--qc", qc, "--json")
    assert code == 0, err
    np.testing.assert_allclose(np.diag(json.loads(out)["qc"]), [float(q) for q in qc.split(",")])


def test_the_run_it_prints_runs_on_the_data_it_was_fitted_to(capsys, tmp_path) -> None:
    """The printed ``steam-ref run`` dropped --preset (a PATH needs it: that run was refused, and the Qc is on that
    preset's clock), --seed (another synthetic task) and did not quote a path with a space. Read as a shell reads
    it, it now runs on the same data with the fitted Qc."""
    path = tmp_path / "my task.mat"
    scipy.io.savemat(path, generate_synthetic(n_steps=40, n_landmarks=6, seed=2).to_cmu_arrays())
    for given in (["--dataset", str(path), "--preset", "synthetic"], ["--dataset", "synthetic", "--seed", "4"]):
        code, out, err = fit_cli(capsys, *given, "--max-poses", 30, "--json")
        assert code == 0, err
        figures = json.loads(out)
        words = shlex.split(figures["run"])
        assert words[:2] == ["steam-ref", "run"] and words[2:6] == given, words
        code, out, err = run_cli(capsys, *words[2:], "--max-poses", 30, "--json")
        assert code == 0, err
        np.testing.assert_allclose(np.diag(json.loads(out)["qc"]), [float(q) for q in words[-1].split(",")])


def test_a_data_set_without_ground_truth_is_one_line_and_exit_2(capsys, tmp_path) -> None:
    path = tmp_path / "odometry.txt"
    path.write_text("ODOMETRY 0 1 1.0 0 0 0.01 0 0 0.01 0 0.001\nODOMETRY 1 2 1.0 0 0 0.01 0 0 0.01 0 0.001\n")
    code, out, err = fit_cli(capsys, "--dataset", path, "--preset", "victoria-park")
    assert code == 2 and out == ""
    assert err.count("\n") == 1 and "has no ground truth" in err and "odometry.txt" in err


@pytest.mark.parametrize(
    ("command", "args", "needle"),
    [
        (fit_cli, ("--prior", "wnoa", "--se2-residual", "simplified"), "--se2-residual applies to --prior se2 only"),
        (fit_cli, ("--max-poses", "2"), "argument --max-poses"),
        # a jerk prior's state has 3 blocks: --max-poses 3 passed --max-poses' check (WNOA's 3) and failed in the fit
        # ("fit_qc needs more than 2 steps between poses ..., got 2"), naming no option
        (
            fit_cli,
            ("--dataset", "synthetic", "--prior", "singer", "--max-poses", "3"),
            "--max-poses 3: --prior singer needs 4 poses or more",
        ),
        (
            fit_cli,
            ("--dataset", "synthetic", "--prior", "se2-wnoj", "--max-poses", "3"),
            "--prior se2-wnoj needs 4 poses",
        ),
        (fit_cli, ("--prior", "nope"), "argument --prior"),
        (run_cli, ("--qc", "1,2"), "expected three numbers > 0 separated by commas"),
        (run_cli, ("--qc", "1,-2,3"), "got '1,-2,3'"),
        (run_cli, ("--qc", "1,nan,3"), "got '1,nan,3'"),
    ],
)
def test_bad_arguments_are_one_line_and_exit_2(capsys, command, args, needle) -> None:
    code, out, err = command(capsys, *args)
    assert code == 2 and out == "" and err.count("\n") == 1 and needle in err, err
