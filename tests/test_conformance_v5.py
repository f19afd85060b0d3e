"""Kit v5: the se3 suite and what kit v4 missed. Every wrong port here is the independent oracle
(:mod:`steam_ref.conformance.oracle_rigid`, :mod:`steam_ref.conformance.oracle_lie`) with one piece swapped, or GTSAM's
own numbers, never steam_ref's code: J_r where J_r⁻¹ belongs, a left retraction, GTSAM's truncated Jacobian, STEAM's
first-order WNOJ term, a covariance whose eigenvalues are floored, forward differences, ``>`` for ``≥``.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.linalg
from requirements import optional_import

from steam_ref.conformance import KIT_VERSION, KITS, SHIPPED
from steam_ref.conformance import oracle_rigid as o
from steam_ref.conformance.build import _write_suite
from steam_ref.conformance.checker import check_cases
from steam_ref.conformance.expected import oracle_case
from steam_ref.conformance.kitio import dumps, read_json, read_suite
from steam_ref.conformance.readme import export_readme
from steam_ref.errors import DataError

CASES = {c["name"]: c for c in read_suite(SHIPPED, "se3")["cases"]}


def port(case: dict, suite: str = "se3") -> dict:
    out = oracle_case(suite, case["name"], case["inputs"])
    return json.loads(dumps({q: out[q] for q in case["tolerance"]}))


def failing(names: list[str], results: dict, suite: str = "se3") -> list[str]:
    cases = CASES if suite == "se3" else {c["name"]: c for c in read_suite(SHIPPED, suite)["cases"]}
    report = check_cases(suite, [cases[n] for n in names], results)
    return [outcome.line() for outcome in report.outcomes if not outcome.passed]


def test_kit_v5_ships_beside_v1_to_v4_with_an_se3_suite_of_25_independent_cases():
    assert KIT_VERSION == 5 and KITS[5] == SHIPPED and all((KITS[v] / "index.json").is_file() for v in range(1, 5))
    assert len(CASES) >= 25 and all(c["independent"] for c in CASES.values())
    assert {c["inputs"].get("model") for c in CASES.values() if c["inputs"]["kind"] == "prior"} == {
        "local-variable",
        "simplified",
    }
    for case in CASES.values():  # 1e-9 or tighter everywhere
        assert all(t == "exact" or t["rtol"] <= 1e-9 for t in case["tolerance"].values()), case["name"]
    assert "gtsam" in CASES["prior_local_variable_residual_diagonal_qc"]["notes"]
    assert all(c["inputs"]["t1"] != 0 for c in CASES.values() if "tau" in c["inputs"])


@pytest.mark.parametrize(
    ("swap", "names", "first"),
    [
        ("jr_for_inverse", ["so3_right_jacobian", "prior_local_variable_fast"], "Jr_inv"),
        ("first_order_wnoj", ["wnoj_prior_fast"], "error"),
        ("forward_differences", ["prior_local_variable_slow", "between"], "H_0"),
    ],
)
def test_a_wrong_port_fails_the_se3_suite(monkeypatch, swap, names, first):
    if swap == "jr_for_inverse":
        monkeypatch.setattr(o, "right_jacobian_inverse", o.right_jacobian)
    elif swap == "first_order_wnoj":  # STEAM: D(J_r^-1 v)[u] kept to its term of order 0 in xi, 1/2 ad(u) v
        monkeypatch.setattr(o, "jr_inverse_times_derivative", lambda xi, v, u: 0.5 * o.ad(u) @ v)
    else:

        def forward(g, n, h=1e-8):
            g0 = np.asarray(g(np.zeros(n)))
            return np.column_stack([(np.asarray(g(h * e)) - g0) / h for e in np.eye(n)])

        monkeypatch.setattr(o, "derivative", forward)
    lines = failing(names, {n: port(CASES[n]) for n in names})
    assert len(lines) == len(names), lines
    assert first in lines[0].split(":")[1], lines[0]


def test_a_left_retraction_fails(monkeypatch):
    def retract(x, delta):
        x, delta = np.asarray(x, float), np.asarray(delta, float)
        pose = o.pose_of(scipy.linalg.expm(o.hat(delta[:6])) @ o.matrix(x[:12]))  # Exp(δ) T
        return np.concatenate([pose, x[12:] + delta[6:]])

    def local(x0, x):
        x0, x = np.asarray(x0, float), np.asarray(x, float)
        xi = o.log_matrix(o.matrix(x[:12]) @ np.linalg.inv(o.matrix(x0[:12])))
        return np.concatenate([xi, x[12:] - x0[12:]])

    monkeypatch.setattr(o, "retract", retract)
    monkeypatch.setattr(o, "local", local)
    names = ["prior_local_variable_slow", "state_prior"]
    lines = failing(names, {n: port(CASES[n]) for n in names})
    assert lines[0].startswith("FAIL se3/prior_local_variable_slow: H_0"), lines
    assert lines[1].startswith("FAIL se3/state_prior: error"), lines


def test_a_covariance_with_its_eigenvalues_floored_fails(monkeypatch):
    real = o.interpolation_quantities

    def floored(inputs):
        out = real(inputs)
        if "cov_tau" in out:
            s, U = np.linalg.eigh(out["cov_tau"])
            out["cov_tau"] = (U * np.maximum(s, 1e-5 * s.max())) @ U.T  # a floor: 1e-5 of the largest
        return out

    monkeypatch.setattr(o, "interpolation_quantities", floored)
    monkeypatch.setitem(
        __import__("steam_ref.conformance.expected", fromlist=["ORACLES"]).ORACLES, "se3/interpolation", floored
    )
    name = "interpolation_covariance_near_a_state"
    lines = failing([name], {name: port(CASES[name])})
    assert len(lines) == 1 and lines[0].startswith(f"FAIL se3/{name}: cov_tau"), lines


gtsam = optional_import("gtsam", "gtsam")
PERM = np.r_[3:6, 0:3]  # ours [ρ; φ] -> GTSAM's [ω; v]


def _gtsam(case: dict) -> tuple[np.ndarray, float, list[np.ndarray]]:
    """GTSAM 4.3's WnoaMotionFactorPose3 on a case: its error, cost and Jacobians in our order."""
    inputs = case["inputs"]
    qc = np.asarray(inputs["qc"], float)
    factor = gtsam.WnoaMotionFactorPose3(
        gtsam.StateData(1, 2, 0.0), gtsam.StateData(3, 4, inputs["dt"]), np.diag(qc)[PERM]
    )
    H = [np.zeros((12, 6), order="F") for _ in range(4)]
    args, values = [], gtsam.Values()
    for x in (np.asarray(inputs["x1"]), np.asarray(inputs["x2"])):
        args += [gtsam.Pose3(o.matrix(x[:12])), x[12:][PERM]]
    for key, value in zip((1, 2, 3, 4), args, strict=True):
        values.insert(key, value)
    e = np.asarray(factor.evaluateError(*args, *H))
    back = np.argsort(np.r_[PERM, 6 + PERM])
    return e[back], factor.error(values), [np.hstack(H[2 * k : 2 * k + 2])[back][:, back] for k in (0, 1)]


def test_gtsam_passes_what_it_computes_exactly_and_its_truncated_jacobian_fails_the_exact_tier():
    name = "prior_local_variable_residual_diagonal_qc"
    e, cost, _ = _gtsam(CASES[name])
    assert failing([name], {name: {"error": e.tolist(), "cost": cost}}) == []
    name = "prior_local_variable_fast"  # H_k = de/dδ does not depend on Qc: GTSAM's with the diagonal of ours
    case = {**CASES[name], "inputs": {**CASES[name]["inputs"], "qc": np.diag(np.diag(CASES[name]["inputs"]["qc"]))}}
    _, _, (H0, H1) = _gtsam(case)
    results = {**port(CASES[name]), "H_0": H0.tolist(), "H_1": H1.tolist()}
    lines = failing([name], {name: results})
    assert len(lines) == 1 and lines[0].startswith(f"FAIL se3/{name}: H_0"), lines


def test_relinearizing_only_past_the_tie_fails():
    case = next(c for c in read_suite(SHIPPED, "incremental")["cases"] if c["name"] == "relinearize_on_the_tie")
    assert case["expected"]["relinearized_2"] == ["x0"]
    wrong = {**case["expected"], "relinearized_2": []}  # max|δ| > β: x0's δ = β = 0.25 is not moved
    lines = failing(["relinearize_on_the_tie"], {"relinearize_on_the_tie": wrong}, "incremental")
    assert len(lines) == 1 and "relinearized_2" in lines[0], lines


def test_absolute_times_fail_the_interpolation_cases_with_t1_not_zero():
    for suite, name in (("se3", "interpolation_local_variable"), ("se2", "interpolation_local_variable_late")):
        case = next(c for c in read_suite(SHIPPED, suite)["cases"] if c["name"] == name)
        inputs = case["inputs"]
        shifted = {**inputs, "t1": 0.0, "t2": inputs["t2"] - inputs["t1"], "tau": inputs["tau"]}  # τ, not τ - t1
        out = oracle_case(suite, name, shifted)
        lines = failing([name], {name: json.loads(dumps({q: out[q] for q in case["tolerance"]}))}, suite)
        assert len(lines) == 1, (suite, lines)


def test_a_nan_in_a_results_file_is_refused_naming_the_case(tmp_path):
    path = tmp_path / "results.json"
    path.write_text(
        '{"kit_version": 5, "cases": {"between": {"between": [1.0, 2.0]}, "state_prior": {"error": [0, NaN]}}}'
    )
    with pytest.raises(DataError, match=r"NaN is not a JSON number .* in case 'state_prior', quantity 'error'\[1\]"):
        read_json(path)


def test_a_rebuild_within_a_thousandth_of_each_tolerance_leaves_the_kit_be(tmp_path):
    for name in ("cases.json", "expected.npz"):
        (tmp_path / "se3").mkdir(exist_ok=True)
        (tmp_path / "se3" / name).write_bytes((SHIPPED / "se3" / name).read_bytes())
    records = read_suite(tmp_path, "se3")["cases"]
    before = (tmp_path / "se3" / "cases.json").read_bytes()
    nudged = json.loads(json.dumps(records))
    nudged[0]["expected"]["exp"][4][0] *= 1 + 4e-16  # another machine's last digit
    _write_suite(tmp_path, "se3", nudged)
    assert (tmp_path / "se3" / "cases.json").read_bytes() == before
    nudged[0]["expected"]["exp"][4][0] *= 1 + 1e-12  # a real change (past a thousandth of rtol 1e-12)
    _write_suite(tmp_path, "se3", nudged)
    assert (tmp_path / "se3" / "cases.json").read_bytes() != before


def test_the_readme_defines_what_the_se3_suite_needs():
    readme = export_readme()
    assert "self-contained" not in readme and "derivations.md" in readme
    for phrase in ("## SE(3)", "H_a = d Log(B^-1", "**The exact tier.**", "tau - t1 and t2 - tau", "xi_ddot"):
        assert phrase in readme, phrase
