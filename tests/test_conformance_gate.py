"""Kit v2's checker: messages that point at the bug, conventions, v1 still
checkable, faults in the new blind spots, and hostile JSON answered with one line and exit 2.

The faulty results are written here from each case's inputs and steam_ref's correct results (a
wrapped GP heading, Λ off, a joint covariance stacked in the wrong order, every variable
relinearized); the alternative conventions are derived here independently (a sign flip, and
W = Σ^(-1/2) by SciPy's ``sqrtm``), not read from the kit's ``alternatives``.
"""

from __future__ import annotations

import copy
import json
import os
import pickle
import shutil
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
from cli_runs import runner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from steam_ref.conformance import KIT_VERSION, KITS, SHIPPED, SUITES, kitio, oracle_lag
from steam_ref.conformance.expected import fixed_lag_quantities
from steam_ref.conformance.kitio import dumps, kit_files, read_index, read_suite, sha256
from steam_ref.conformance.oracle_graph import stream
from steam_ref.conformance.oracle_lag import fixed_lag

cli = runner("conformance")


@pytest.fixture(scope="module")
def ours(kit_results) -> dict:
    return {s: kit_results(SHIPPED, s) for s in ("gp", "factors", "linear", "bayes_tree", "incremental")}


def inputs_of(suite: str) -> dict:
    return {c["name"]: c["inputs"] for c in read_suite(SHIPPED, suite)["cases"]}


# --- messages -------------------------------------------------------------------------------------


def test_a_nudged_number_prints_expected_and_got_and_the_first_failing_quantity_is_the_likely_cause(
    tmp_path, capsys, ours, write_results
):
    bad = copy.deepcopy(ours["gp"])
    lam = np.array(bad["interp_tau1.1"]["Lambda"])
    lam[0, 3] += 1e-3  # a wrong Λ shows up in x̄(τ) too, and more in it: Λ is still flagged first
    x1, x2 = (np.array(inputs_of("gp")["interp_tau1.1"][k]) for k in ("x1", "x2"))
    bad["interp_tau1.1"].update(
        Lambda=lam.tolist(), x_tau=(lam @ x1 + np.array(bad["interp_tau1.1"]["Psi"]) @ x2).tolist()
    )
    write_results(tmp_path, "gp", bad)
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "gp")
    lines = out.splitlines()
    head = next(line for line in lines if line.startswith("FAIL gp/interp_tau1.1"))
    assert code == 1 and ": Lambda worst |diff| 0.001 at [0, 3]" in head and "likely cause" in head, out
    kit = {c["name"]: c for c in read_suite(SHIPPED, "gp")["cases"]}
    expected = kit["interp_tau1.1"]["expected"]["Lambda"][0][3]
    assert f"    Lambda[0, 3]: expected {expected!r}, got {float(lam[0, 3])!r} (|diff| 0.001)" in lines
    assert any(line.startswith("  x_tau worst |diff|") for line in lines)  # every failing quantity, listed after
    assert any(line.startswith("    x_tau[0]: expected ") for line in lines)


def test_a_structure_mismatch_prints_the_differing_cliques_in_full(tmp_path, capsys, ours, write_results):
    bad = copy.deepcopy(ours["bayes_tree"])
    cliques = bad["bushy_cliques"]["cliques"]
    victim = next(c for c in cliques if c["frontals"] == ["l3"])
    victim["separator"] = ["x1"]
    write_results(tmp_path, "bayes_tree", bad)
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "bayes_tree")
    assert code == 1 and "FAIL bayes_tree/bushy_cliques: cliques differs (compared exactly)" in out
    assert '    expected, not got: {"frontals": ["l3"], "parent": "x1", "separator": ["x2"]}' in out
    assert '    got, not expected: {"frontals": ["l3"], "parent": "x1", "separator": ["x1"]}' in out


# --- v1 stays checkable ---------------------------------------------------------------------------


def computed_suites(kit: Path) -> list[str]:
    """The suites of ``kit`` computed from their inputs (all but paper)."""
    return [s for s in read_index(kit)["suites"] if s != "paper"]


def test_v1_results_without_a_kit_version_check_against_v1(tmp_path, capsys, kit_results, write_results):
    v1 = computed_suites(KITS[1])
    assert "fixed_lag" not in v1
    for suite in v1:
        write_results(tmp_path, suite, kit_results(KITS[1], suite), version=None)
    code, out, _ = cli(capsys, "check", tmp_path, "--only", *v1)
    assert code == 0 and out.strip().splitlines()[-1] == "50 passed, 0 failed", out
    assert "checked as kit v1 results against the shipped kit v1" in out
    write_results(tmp_path, "gp", kit_results(KITS[1], "gp"), version=2)  # a mix of versions is refused
    code, _, err = cli(capsys, "check", tmp_path, "--only", *v1)
    assert code == 2 and "different kit versions" in err
    code, _, err = cli(capsys, "check", tmp_path, "--only", "gp", "--kit", KITS[1])
    assert code == 2 and "kit_version 2" in err and "v1" in err


def test_v2_results_check_against_the_shipped_v2_which_has_no_fixed_lag_suite(
    tmp_path, capsys, kit_results, write_results
):
    v2 = computed_suites(KITS[2])
    assert v2 == [s for s in SUITES if s not in ("fixed_lag", "se2", "se3", "paper")]
    for suite in v2:
        write_results(tmp_path, suite, kit_results(KITS[2], suite), version=2)
    code, out, _ = cli(capsys, "check", tmp_path)  # the data-free suites are the gate; paper only with --paper
    lines = out.strip().splitlines()
    assert code == 0 and lines[-1] == "64 passed, 0 failed" and "add --paper" in out, out
    assert "fixed_lag" not in out
    code, out, _ = cli(capsys, "check", tmp_path, "--paper")
    assert code == 1 and out.strip().splitlines()[-1] == "64 passed, 0 failed, 2 missing", out
    code, out, _ = cli(capsys, "check", tmp_path, "--only", *v2)
    assert code == 0 and out.strip().splitlines()[-1] == "64 passed, 0 failed", out


def test_fixed_lag_results_for_kit_v2_or_v1_are_refused_not_passed_unchecked(
    tmp_path, capsys, kit_results, write_results
):
    write_results(tmp_path, "fixed_lag", kit_results(SHIPPED, "fixed_lag"), version=2)
    for args in ((), ("--only", "fixed_lag"), ("--allow-missing",)):
        code, out, err = cli(capsys, "check", tmp_path, *args)
        assert code == 2 and out == "" and "kit v2 has no suite 'fixed_lag'" in err and len(err.splitlines()) == 1, err
    write_results(tmp_path, "fixed_lag", kit_results(SHIPPED, "fixed_lag"), version=None)
    code, _, err = cli(capsys, "check", tmp_path, "--only", "fixed_lag")
    assert code == 2 and "kit v1 has no suite 'fixed_lag'" in err, err
    shutil.rmtree(tmp_path / "fixed_lag")
    write_results(tmp_path, "gp", kit_results(KITS[2], "gp"), version=2)
    code, _, err = cli(capsys, "check", tmp_path, "--only", "gp", "fixed_lag")
    assert code == 2 and "kit v2 has no suite 'fixed_lag'" in err, err


def test_results_of_the_shipped_kit_must_hold_the_fixed_lag_se2_and_se3_suites(
    tmp_path, capsys, ours, kit_results, write_results
):
    for suite in ("gp", "factors", "linear", "bayes_tree", "incremental"):
        write_results(tmp_path, suite, ours[suite])
    write_results(tmp_path, "batch", kit_results(SHIPPED, "batch"))
    code, out, _ = cli(capsys, "check", tmp_path)
    assert code == 1 and "MISSING: 6 cases of fixed_lag have no result: linear_two_at_once, " in out, out
    write_results(tmp_path, "fixed_lag", {})  # {"cases": {}} is no pass either
    code, out, _ = cli(capsys, "check", tmp_path)
    assert code == 1 and "MISSING: 6 cases of fixed_lag" in out, out
    write_results(tmp_path, "fixed_lag", kit_results(SHIPPED, "fixed_lag"))
    code, out, _ = cli(capsys, "check", tmp_path)
    n = {suite: len(read_suite(SHIPPED, suite)["cases"]) for suite in SUITES[:-1]}
    assert code == 1 and f"MISSING: {n['se2']} cases of se2 have no result: exp_near_zero, " in out, out
    write_results(tmp_path, "se2", kit_results(SHIPPED, "se2"))
    code, out, _ = cli(capsys, "check", tmp_path)
    assert code == 1 and f"MISSING: {n['se3']} cases of se3 have no result: so3_exp_near_zero, " in out, out
    write_results(tmp_path, "se3", kit_results(SHIPPED, "se3"))
    code, out, _ = cli(capsys, "check", tmp_path)
    assert code == 0 and out.strip().splitlines()[-1] == f"{sum(n.values())} passed, 0 failed", out


def test_v3_results_still_check_against_the_shipped_v3(tmp_path, capsys, kit_results, write_results):
    v3 = computed_suites(KITS[3])
    assert v3 == [s for s in SUITES if s not in ("se2", "se3", "paper")]
    for suite in v3:
        write_results(tmp_path, suite, kit_results(KITS[3], suite), version=3)
    code, out, _ = cli(capsys, "check", tmp_path)
    assert code == 0 and out.strip().splitlines()[-1] == "68 passed, 0 failed", out


def test_a_kit_version_written_as_an_integral_float_names_that_kit(tmp_path, capsys, kit_results):
    """JSON has one number type: ``"kit_version": 3.0`` (a writer that prints every number as a float) is kit v3;
    ``3.5`` names no kit and is refused, the message naming it as given."""
    results = {"kit_version": 3.0, "cases": kit_results(KITS[3], "gp")}
    (tmp_path / "gp").mkdir()
    (tmp_path / "gp" / "results.json").write_text(json.dumps(results))
    code, out, err = cli(capsys, "check", tmp_path, "--only", "gp")
    assert code == 0 and out.strip().splitlines()[-1] == "16 passed, 0 failed", out + err
    (tmp_path / "gp" / "results.json").write_text(json.dumps({**results, "kit_version": 3.5}))
    code, _, err = cli(capsys, "check", tmp_path, "--only", "gp")
    assert code == 2 and "kit_version 3.5, the kits are versions 1, 2, 3, 4" in err, err


def test_an_empty_results_path_is_refused_not_read_as_the_working_folder(tmp_path, capsys, monkeypatch, ours):
    results = {"kit_version": KIT_VERSION, "cases": ours["gp"]}
    (tmp_path / "gp").mkdir()
    (tmp_path / "gp" / "results.json").write_text(dumps(results))
    monkeypatch.chdir(tmp_path)  # the working folder holds results that pass
    for args in (["check", ""], ["check", " "], ["check", ".", "--only", "gp", "--kit", ""]):
        code, out, err = cli(capsys, *args)
        assert code == 2 and out == "" and len(err.strip().splitlines()) == 1 and "empty" in err, (args, out, err)
    assert cli(capsys, "check", ".", "--only", "gp")[0] == 0  # the working folder named is read


def conditioning_results(case: dict) -> dict:
    """A port that drops the Schur complement's correction: on the separator it keeps Λ = H_SS, η = g_S of the
    dropped variables' factors (it conditions on them instead of integrating them out), and solves the window
    with that factor (the dense replay with ``schur=False``)."""
    inputs = case["inputs"]
    isam2, stream = inputs["isam2"], inputs["stream"]
    replay = fixed_lag(
        stream["variables"], stream["updates"], inputs["lag"], float(isam2["relinearize_threshold"]), schur=False
    )
    out = fixed_lag_quantities(replay)
    return json.loads(dumps({q: out[q] for q in case["tolerance"]}))


def first_drop(case: dict) -> int:
    return min(int(q.rsplit("_", 1)[1]) for q in case["tolerance"] if q.startswith("separator_"))


def test_a_marginal_factor_without_the_schur_complement_fails_every_fixed_lag_case(tmp_path, capsys, write_results):
    cases = read_suite(SHIPPED, "fixed_lag")["cases"]
    write_results(tmp_path, "fixed_lag", {c["name"]: conditioning_results(c) for c in cases})
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "fixed_lag")
    lines = out.strip().splitlines()
    assert code == 1 and lines[-1] == f"0 passed, {len(cases)} failed", out
    for c in cases:
        k = first_drop(c)
        head = next(line for line in lines if line.startswith(f"FAIL fixed_lag/{c['name']}: "))
        assert f": marginal_information_{k} worst |diff|" in head and "likely cause" in head, head
        # conditioning is overconfident: the window's covariances are wrong from that update on
        assert any(line.startswith(f"  covariances_{k}/") and " worst |diff| " in line for line in lines), out


def test_a_marginal_factor_not_moved_with_its_linearization_point_fails_the_relinearizing_cases(
    tmp_path, capsys, monkeypatch, write_results
):
    """A port that keeps η fixed while θ̄ moves (no Eq. 10.4 shift: the frozen factor taken as a factor of the
    new δ′) fails where the separator is relinearized after a marginalization, and only there."""
    plain = oracle_lag.information

    def unshifted(specs, marginals, theta, order, dims, *space):
        here = [
            oracle_lag.Marginal(m.keys, m.info, m.vector, np.concatenate([theta[k] for k in m.keys])) for m in marginals
        ]
        return plain(specs, here, theta, order, dims, *space)

    monkeypatch.setattr(oracle_lag, "information", unshifted)
    cases = read_suite(SHIPPED, "fixed_lag")["cases"]
    results = {}
    for c in cases:
        inputs = c["inputs"]
        isam2, stream = inputs["isam2"], inputs["stream"]
        replay = oracle_lag.fixed_lag(
            stream["variables"], stream["updates"], inputs["lag"], float(isam2["relinearize_threshold"])
        )
        results[c["name"]] = json.loads(dumps({q: fixed_lag_quantities(replay)[q] for q in c["tolerance"]}))
    write_results(tmp_path, "fixed_lag", results)
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "fixed_lag")
    failed = {line.split()[1].rstrip(":") for line in out.splitlines() if line.startswith("FAIL ")}
    relinearizing = {f"fixed_lag/{c['name']}" for c in cases if c["inputs"]["isam2"]["relinearize_threshold"] != "inf"}
    assert code == 1 and failed == relinearizing and len(relinearizing) == 3, out


def test_deleting_the_old_variables_factors_fails_every_fixed_lag_case(tmp_path, capsys, kit_results, write_results):
    """Nothing left on the separator (Λ = 0, η = 0), everything else steam_ref's own right answer."""
    cases = read_suite(SHIPPED, "fixed_lag")["cases"]
    bad = kit_results(SHIPPED, "fixed_lag")
    for c in cases:
        for q in c["tolerance"]:
            if q.startswith(("marginal_information_", "marginal_vector_")):
                bad[c["name"]][q] = np.zeros_like(np.array(bad[c["name"]][q])).tolist()
    write_results(tmp_path, "fixed_lag", bad)
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "fixed_lag")
    lines = out.strip().splitlines()
    assert code == 1 and lines[-1] == f"0 passed, {len(cases)} failed", out
    for c in cases:
        head = next(line for line in lines if line.startswith(f"FAIL fixed_lag/{c['name']}: "))
        assert f": marginal_information_{first_drop(c)} worst |diff|" in head, head


# --- conventions ----------------------------------------------------------------------------------


def _gp_rows(problem: dict) -> list[tuple[int, int, dict]]:
    """(first row, rows, spec) of each factor of a linear case, in factor order."""
    out, r = [], 0
    for f in problem["factors"]:
        m = {"gp_prior": 6, "prior": len(f.get("mean", [])), "velocity": 3, "range": 1, "bearing": 1}.get(f["type"], 1)
        out.append((r, m, f))
        r += m
    return out


def test_paper_sign_results_fail_by_default_and_pass_with_conventions_paper_sign(tmp_path, capsys, ours, write_results):
    factors, linear = copy.deepcopy(ours["factors"]), copy.deepcopy(ours["linear"])
    finputs, linputs = inputs_of("factors"), inputs_of("linear")
    flipped = set()
    for name, res in factors.items():
        if finputs[name]["factor"]["type"] == "gp_prior":  # e = Φx₁ - x₂ as [YIB Eq. 22] writes it
            for q in res:
                if q.split("_")[0] in ("error", "whitened", "H", "A", "b"):
                    res[q] = (-np.array(res[q])).tolist()
            flipped.add(f"factors/{name}")
    for name, res in linear.items():
        A, b = np.array(res["A"]), np.array(res["b"])
        for r, m, spec in _gp_rows(linputs[name]["problem"]):
            if spec["type"] == "gp_prior":
                A[r : r + m], b[r : r + m] = -A[r : r + m], -b[r : r + m]
        res.update(A=A.tolist(), b=b.tolist())
        flipped.add(f"linear/{name}")
    write_results(tmp_path, "factors", factors)
    write_results(tmp_path, "linear", linear)
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "factors", "linear")
    failed = {line.split()[1].rstrip(":") for line in out.splitlines() if line.startswith("FAIL ")}
    assert code == 1 and failed == flipped and len(flipped) == 9, out
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "factors", "linear", "--conventions", "paper-sign")
    assert code == 0 and out.strip().splitlines()[-1] == "27 passed, 0 failed", out


def test_symmetric_whitener_results_pass_with_conventions_symmetric_whitener(tmp_path, capsys, ours, write_results):
    factors, finputs = copy.deepcopy(ours["factors"]), inputs_of("factors")
    changed = set()
    for name, res in factors.items():
        spec = finputs[name]["factor"]
        if spec["type"] == "gp_prior" or "covariance" in spec:
            if spec["type"] == "gp_prior":
                W = np.array(res["A_1"])  # A_1 = W H_1 with H_1 = I: Σ = Q = (WᵀW)⁻¹
                sigma = np.linalg.inv(W.T @ W)
            else:
                sigma = np.array(spec["covariance"])
            S = np.real(scipy.linalg.sqrtm(np.linalg.inv(sigma)))  # Σ^(-1/2), symmetric
            e = np.array(res["error"])
            res["whitened_error"], res["b"] = (S @ e).tolist(), (-S @ e).tolist()
            for k in range(len(spec["keys"])):
                res[f"A_{k}"] = (S @ np.array(res[f"H_{k}"])).tolist()
            changed.add(name)
    write_results(tmp_path, "factors", factors)
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "factors")
    failed = {line.split()[1].rstrip(":") for line in out.splitlines() if line.startswith("FAIL ")}
    assert code == 1 and failed == {f"factors/{n}" for n in changed} and len(changed) == 6, out
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "factors", "--conventions", "symmetric-whitener")
    assert code == 0 and out.strip().splitlines()[-1] == "22 passed, 0 failed", out


def test_every_case_marks_each_quantity_invariant_or_dependent_in_computation_order():
    for suite in SUITES:
        for c in read_suite(SHIPPED, suite)["cases"]:
            names = [q["name"] for q in c["quantities"]]
            assert names == list(c["tolerance"]), c["name"]
            depends = {q["name"]: q["depends_on"] for q in c["quantities"]}
            for q, conv in depends.items():
                dependent = suite in ("gp", "factors", "linear") and (
                    q in ("error", "whitened_error", "b", "A", "W") or q[:2] in ("H_", "A_")
                )
                half_turn = suite == "se2" and q in ("exp", "log", "log_of_exp", "exp_of_log")  # kit v5
                assert conv == (["half_turn"] if half_turn else conv), (c["name"], q)
                assert bool(conv) == (dependent or half_turn), (c["name"], q)
                assert set(conv) <= {"residual", "whitening", "half_turn"}, (c["name"], q)
            assert set(c.get("alternatives", {})) <= {
                "paper-sign",
                "symmetric-whitener",
                "paper-sign+symmetric-whitener",
                "signed-half-turn",
            }


# --- deliberate faults in the new blind spots -----------------------------------------------------


def _wrap(a: float) -> float:
    return (a + np.pi) % (2 * np.pi) - np.pi


def test_a_port_that_wraps_the_gp_priors_heading_error_fails(tmp_path, capsys, ours, write_results):
    factors, linear = copy.deepcopy(ours["factors"]), copy.deepcopy(ours["linear"])
    res = factors["gp_prior_heading_jump"]
    W, e = np.array(res["A_1"]), np.array(res["error"])  # A_1 = W (H_1 = I)
    e[2] = _wrap(e[2])
    res.update(
        error=e.tolist(), whitened_error=(W @ e).tolist(), b=(-W @ e).tolist(), cost=0.5 * float(np.sum((W @ e) ** 2))
    )
    lin = linear["gp_heading_jump"]
    A, b = np.array(lin["A"]), np.array(lin["b"])
    b[6:12] = -np.array(lin["A"])[6:12, 6:12] @ e  # the GP prior's rows: A's x1 block is its W
    info, rhs = A.T @ A, A.T @ b
    R = np.linalg.cholesky(info).T
    d = scipy.linalg.solve_triangular(R, rhs, trans="T")
    lin.update(b=b.tolist(), rhs=rhs.tolist(), d=d.tolist(), delta=scipy.linalg.solve_triangular(R, d).tolist())
    write_results(tmp_path, "factors", factors)
    write_results(tmp_path, "linear", linear)
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "factors", "linear")
    fails = [line for line in out.splitlines() if line.startswith("FAIL ")]
    assert code == 1 and len(fails) == 2, out
    assert any(line.startswith("FAIL factors/gp_prior_heading_jump: error worst") for line in fails)
    assert any(line.startswith("FAIL linear/gp_heading_jump: b worst") for line in fails)  # the cause, not δ


def test_a_joint_covariance_stacked_in_elimination_order_fails_the_bushy_case(tmp_path, capsys, ours, write_results):
    bad = copy.deepcopy(ours["bayes_tree"])
    cov = np.array(bad["bushy_joint_covariances"]["covariances"]["l4,l3,l2,l1,l0"])
    rev = np.arange(10).reshape(5, 2)[::-1].ravel()
    bad["bushy_joint_covariances"]["covariances"]["l4,l3,l2,l1,l0"] = cov[np.ix_(rev, rev)].tolist()
    write_results(tmp_path, "bayes_tree", bad)
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "bayes_tree")
    assert code == 1 and "FAIL bayes_tree/bushy_joint_covariances: covariances/l4,l3,l2,l1,l0 worst" in out


def test_relinearizing_every_variable_instead_of_those_over_beta_fails_the_partial_cases(
    tmp_path, capsys, ours, write_results
):
    bad = copy.deepcopy(ours["incremental"])
    for name in ("partial_relinearization_estimates", "partial_relinearization_skip2_estimates"):
        inputs = inputs_of("incremental")[name]
        estimates, moved = stream(inputs["stream"]["variables"], inputs["stream"]["updates"], 0.0, 1)
        for k, (est, m) in enumerate(zip(estimates, moved, strict=True), start=1):
            bad[name][f"estimate_{k}"] = {n: v.tolist() for n, v in est.items()}
            bad[name][f"relinearized_{k}"] = m
    write_results(tmp_path, "incremental", bad)
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "incremental")
    fails = {line.split()[1].rstrip(":") for line in out.splitlines() if line.startswith("FAIL ")}
    assert code == 1 and fails == {
        "incremental/partial_relinearization_estimates",
        "incremental/partial_relinearization_skip2_estimates",
    }
    heads = [line for line in out.splitlines() if line.startswith("FAIL ")]
    assert all(": relinearized_3 differs (compared exactly)" in line for line in heads), out  # the cause comes first


# --- hostile input: exit 2, one line naming the file and the problem -------------------------------


HOSTILE = {
    "an integer of 401 digits": '{"kit_version": 2, "cases": {"wnoa_dt0.1": {"Phi": ' + "9" * 401 + "}}}",
    "an integer of 5001 digits": '{"kit_version": 2, "cases": {"wnoa_dt0.1": {"Phi": ' + "9" * 5001 + "}}}",
    "nesting 100,000 deep": '{"kit_version": 2, "cases": {"wnoa_dt0.1": {"Phi": '
    + "[" * 100_000
    + "]" * 100_000
    + "}}}",
    "nesting 70 deep": '{"kit_version": 2, "cases": {"wnoa_dt0.1": {"Phi": ' + "[" * 70 + "]" * 70 + "}}}",
    "a number as a string": '{"kit_version": 2, "cases": {"wnoa_dt0.1": {"Phi": [["1.0"]]}}}',
    "a boolean as a number": '{"kit_version": 2, "cases": {"wnoa_dt0.1": {"Q": true}}}',
    "a case given twice": '{"kit_version": 2, "cases": {"wnoa_dt0.1": {}, "wnoa_dt0.1": {}}}',
    "NaN": '{"kit_version": 2, "cases": {"wnoa_dt0.1": {"Phi": NaN}}}',
    "1e999": '{"kit_version": 2, "cases": {"wnoa_dt0.1": {"Phi": 1e999}}}',
    "a list": "[1, 2, 3]",
    "a version as a string": '{"kit_version": "2", "cases": {}}',
    "a version as a list": '{"kit_version": [2], "cases": {}}',
    "a version as an object": '{"kit_version": {"v": 2}, "cases": {}}',
    "a version as a fraction": '{"kit_version": 2.5, "cases": {}}',
    "not UTF-8": b'{"cases": {"\xff": {}}}',
}


@pytest.mark.parametrize("what", list(HOSTILE))
def test_hostile_results_are_refused_with_one_line_naming_the_file(tmp_path, capsys, what):
    path = tmp_path / "gp" / "results.json"
    path.parent.mkdir()
    text = HOSTILE[what]
    path.write_bytes(text if isinstance(text, bytes) else text.encode())
    code, out, err = cli(capsys, "check", tmp_path, "--only", "gp")
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1 and "Traceback" not in err, (what, err)
    assert str(path) in err, err


@pytest.mark.parametrize("what", ["folder", "dangling link", "link loop", "pipe", "huge"])
def test_a_results_path_that_is_no_regular_file_is_refused_not_skipped(tmp_path, capsys, what):
    path = tmp_path / "gp" / "results.json"
    path.parent.mkdir()
    if what == "folder":
        path.mkdir()
    elif what == "dangling link":
        path.symlink_to(tmp_path / "nowhere.json")
    elif what == "link loop":
        path.symlink_to(path)
    elif what == "pipe":
        os.mkfifo(path)
    else:
        with open(path, "wb") as f:  # sparse: takes no disk space, and is refused before it is read
            f.truncate(kitio.MAX_BYTES + 1)
    code, _out, err = cli(capsys, "check", tmp_path, "--only", "gp")
    words = {
        "folder": "a folder",
        "dangling link": "link to nothing",
        "link loop": "cannot be opened",
        "pipe": "not a regular file",
        "huge": "bytes, more than",
    }
    assert code == 2 and words[what] in err and str(path) in err and len(err.strip().splitlines()) == 1, err


def hostile_kit(kit: Path, edit) -> Path:
    """The copy ``kit`` of the shipped kit, edited by ``edit(index, gp_cases)``, its sha256 sums made consistent again."""
    index = json.loads((kit / "index.json").read_text())
    gp = json.loads((kit / "gp" / "cases.json").read_text())
    edit(index, gp)
    (kit / "gp" / "cases.json").write_text(json.dumps(gp))
    if isinstance(index, dict) and isinstance(index.get("files"), dict):
        index["files"] = {n: sha256(kit / n) for n in kit_files(kit) if n in index["files"]}
    (kit / "index.json").write_text(json.dumps(index))
    return kit


KIT_EDITS = {
    "index.json a list": (lambda i, g: i.clear() or i.update(x=1), "expected a JSON object"),
    "no files list": (lambda i, g: i.pop("files"), "'files'"),
    "a tolerance that is a string": (
        lambda i, g: g["cases"][0].__setitem__("tolerance", {"Phi": "tight"}),
        "tolerance of 'Phi'",
    ),
    "a duplicate case": (lambda i, g: g["cases"].append(dict(g["cases"][0])), "listed twice"),
    "a case name with ANSI escapes": (
        lambda i, g: g["cases"][0].update(name="\x1b[31mred\nFAIL", tolerance="x"),
        "\\x1b[31mred\\nFAIL",
    ),
    "an unknown kit version": (lambda i, g: i.__setitem__("kit_version", 99), "kit version 99"),
    "a kit version as a list": (lambda i, g: i.__setitem__("kit_version", [3]), "kit version [3]"),
    "a kit version as an object": (lambda i, g: i.__setitem__("kit_version", {"v": 3}), "kit version {'v': 3}"),
    "alternatives that are a list": (lambda i, g: g["cases"][0].__setitem__("alternatives", [1]), "'alternatives'"),
    "an alternative value as a string": (
        lambda i, g: g["cases"][0].__setitem__("alternatives", {"symmetric-whitener": {"W": "0"}}),
        "is a str, not a number",
    ),
}


@pytest.mark.parametrize("what", list(KIT_EDITS))
def test_a_hostile_kit_is_refused_with_one_line(tmp_path, capsys, what, ours, write_results, kit_copy):
    edit, words = KIT_EDITS[what]
    if what == "index.json a list":
        kit = hostile_kit(kit_copy, lambda i, g: None)
        (kit / "index.json").write_text("[1, 2]")
    else:
        kit = hostile_kit(kit_copy, edit)
    write_results(tmp_path / "results", "gp", ours["gp"])
    code, out, err = cli(capsys, "check", tmp_path / "results", "--only", "gp", "--kit", kit)
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1 and words in err, err
    assert "\x1b" not in err


def test_control_characters_in_a_results_case_name_are_escaped_in_the_report(tmp_path, capsys, ours, write_results):
    forged = {**ours["gp"], "x\x1b[2J\nFAIL gp/wnoa_dt0.1: forged": {"Phi": 1.0}}
    write_results(tmp_path, "gp", forged)
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "gp")
    assert code == 0 and "\x1b" not in out and "\\x1b[2J\\nFAIL gp/wnoa_dt0.1: forged" in out
    assert not any(line.startswith("FAIL") for line in out.splitlines())


@pytest.mark.parametrize("where", ["an unknown case", "an unknown quantity", "a key holding a string"])
def test_a_megabyte_name_in_a_results_file_is_shown_cut_not_printed_whole(tmp_path, capsys, ours, write_results, where):
    """A name read from a results file is shown escaped and cut (kitio.shown): a 1 MB case name of escapes, well
    under the caps, was printed whole, 4 MB of '\\x1b' on one line of the report or of the one-line error."""
    name = "\x1b" * 2**20
    cases = copy.deepcopy(ours["gp"])
    if where == "an unknown case":
        cases[name] = {"Phi": 1.0}
    elif where == "an unknown quantity":
        cases["wnoa_dt0.1"][name] = 1.0
    else:
        cases["wnoa_dt0.1"]["Phi"] = {name: "text"}
    write_results(tmp_path, "gp", cases)
    code, out, err = cli(capsys, "check", tmp_path, "--only", "gp")
    assert code == (2 if where == "a key holding a string" else 0), (out[:300], err[:300])
    longest = max(len(line) for line in (out + err).splitlines())
    assert longest < 2000 and "\\x1b\\x1b" in out + err and "\x1b" not in out + err, longest


json_values = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=5),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=20,
)


@pytest.fixture
def kits_read_once(monkeypatch):
    """The check reads each kit once for the whole test, not once an example (its whole kit, every suite checked:
    ~0.1 s a call, most of a fuzz example's time); at the end each kit read is still what a fresh read gives."""
    from steam_ref.conformance import gate

    read, first = gate.load_kit, {}

    def load_kit(kit):
        if kit not in first:
            first[kit] = (read(kit), pickle.dumps(read(kit)))
        return first[kit][0]

    monkeypatch.setattr(gate, "load_kit", load_kit)
    yield
    assert first  # the check read a kit through it
    for kit, (kept, fresh) in first.items():
        assert pickle.dumps(kept) == fresh, f"the check changed what it read of {kit}"


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    body=st.one_of(
        json_values.map(json.dumps),
        st.dictionaries(st.sampled_from(["wnoa_dt0.1", "interp_tau1.1", "nope"]), json_values, max_size=3).map(
            lambda cases: json.dumps({"kit_version": 2, "cases": cases})
        ),
        st.binary(max_size=60).map(lambda b: b.decode("latin-1")),
    )
)
def test_any_malformed_results_file_is_a_verdict_or_one_line_with_exit_2_never_a_traceback(
    tmp_path, capsys, kits_read_once, body
):
    path = tmp_path / "gp" / "results.json"
    path.parent.mkdir(exist_ok=True)
    path.write_text(body, encoding="utf-8", errors="surrogateescape")
    code, out, err = cli(capsys, "check", tmp_path, "--only", "gp")
    if code == 2:
        assert out == "" and len(err.strip().splitlines()) == 1 and str(path) in err, err
    else:
        assert code == 1 and err == "" and out.strip().splitlines()[-1].endswith(" missing"), out


def test_the_checkers_memory_is_bounded_by_its_caps(tmp_path, capsys):
    """Parsed, a JSON number costs ~30x its text: the byte cap alone let a 63 MiB file take 1.9 GB.
    A file holding 250,000 values (12x the kit's largest, 1 MB of text) is refused before it is parsed;
    one just under the value cap is read within 96 MB (tracemalloc: 67 MB measured, ~340 B per value)."""
    import tracemalloc

    path = tmp_path / "gp" / "results.json"
    path.parent.mkdir()
    path.write_text('{"kit_version": 3, "cases": {"wnoa_dt0.1": {"Phi": [' + ",".join(["0.5"] * 250_000) + "]}}}")
    code, out, err = cli(capsys, "check", tmp_path, "--only", "gp")
    assert code == 2 and out == "" and "JSON values, more than" in err and err.count(str(path)) == 1, err
    path.write_text("[" + ",".join(["0.123456789"] * 199_000) + "]")
    tracemalloc.start()
    try:
        kitio.read_json(path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 96 * 2**20, peak
