"""Kit v4: what an outsider implementing kit v3's ``fixed_lag`` suite from the docs alone ran into.

Each test here failed before kit v4: the gate (data-free suites by default, ``--paper`` opt-in, nothing passed
is no pass, an extra quantity a warning), a timestamp exactly at t_newest - lag, a landmark forgotten and seen
again, a singular marginal information said so, citations the exported kit holds, the tree-edit rule's
"holding" and "sorted", and the range with the robot at the landmark. The wrong ports are written here from
the dense replay oracle (a rule ``t <= t_newest - lag``, landmarks never stamped) or by hand (GTSAM's
``norm2`` Jacobian at 0), never from steam_ref's own results.
"""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path

import numpy as np
import pytest
from cli_runs import runner

from steam_ref.conformance import KIT_VERSION, KITS, SHIPPED
from steam_ref.conformance.expected import fixed_lag_quantities
from steam_ref.conformance.kitio import DATA_FREE, dumps, read_index, read_suite
from steam_ref.conformance.oracle_lag import fixed_lag
from steam_ref.conformance.readme import export_readme

cli = runner("conformance")


@pytest.fixture(scope="module")
def all_data_free(kit_results) -> dict:
    """steam_ref's results for every data-free suite of the shipped kit (they pass)."""
    return {s: kit_results(SHIPPED, s) for s in DATA_FREE}


def case_of(suite: str, name: str) -> dict:
    return next(c for c in read_suite(SHIPPED, suite)["cases"] if c["name"] == name)


def replay(case: dict, lag: float | None = None, updates: list | None = None) -> dict:
    """The dense oracle's quantities of a fixed_lag case, with another lag or other updates (a wrong port)."""
    inputs = case["inputs"]
    stream = inputs["stream"]
    out = fixed_lag_quantities(
        fixed_lag(
            stream["variables"],
            updates if updates is not None else stream["updates"],
            inputs["lag"] if lag is None else lag,
            float(inputs["isam2"]["relinearize_threshold"]),
        )
    )
    return json.loads(dumps({q: out[q] for q in case["tolerance"] if q in out}))


# --- the versions -----------------------------------------------------------------------------------


def test_kit_v4_ships_beside_v1_to_v3_which_are_unchanged():
    assert KIT_VERSION >= 4 and (KITS[4] / "index.json").is_file()  # v4 stays shipped beside the newer kits
    assert [read_index(KITS[v])["kit_version"] for v in (1, 2, 3, 4)] == [1, 2, 3, 4]
    v3, v4 = ({c["name"]: c for c in read_suite(KITS[v], "fixed_lag")["cases"]} for v in (3, 4))
    assert set(v4) - set(v3) == {"timestamp_at_the_boundary", "landmark_forgotten_and_seen_again"}
    for name, case in v3.items():  # v3's cases are v4's, inputs and expected values alike
        assert (v4[name]["inputs"], v4[name]["expected"]) == (case["inputs"], case["expected"]), name
    assert "derivations" in json.dumps(v3) and "(a landmark) never is" in json.dumps(read_index(KITS[3]))  # as shipped


# --- the gate ---------------------------------------------------------------------------------------


def test_the_data_free_suites_are_the_default_gate_and_the_paper_suite_is_opt_in(
    tmp_path, capsys, all_data_free, write_results
):
    for suite, results in all_data_free.items():
        write_results(tmp_path, suite, results)
    n = sum(map(len, all_data_free.values()))
    code, out, _ = cli(capsys, "check", tmp_path)  # no --only listing every suite but paper
    lines = out.strip().splitlines()
    assert code == 0 and lines[-1] == f"{n} passed, 0 failed", out
    assert "not checked: paper, which needs the paper's data files: add --paper" in out
    code, out, _ = cli(capsys, "check", tmp_path, "--paper")
    assert code == 1 and "MISSING: 2 cases of paper have no result: synthetic_btgp1, plaza_btgp1" in out, out
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "gp", "--paper")
    assert code == 1 and "MISSING: 2 cases of paper" in out and "not checked (--only): factors" in out, out
    write_results(tmp_path, "paper", {})
    code, out, _ = cli(capsys, "check", tmp_path)
    assert code == 0 and "not checked: paper (its results are here)" in out, out


def test_allow_missing_with_nothing_passed_is_not_a_pass(tmp_path, capsys, all_data_free, write_results):
    write_results(tmp_path, "gp", {})
    code, out, _ = cli(capsys, "check", tmp_path, "--allow-missing")
    lines = out.strip().splitlines()
    assert code == 1 and lines[-1].startswith("0 passed, 0 failed, ") and lines[-1].endswith(" missing"), out
    assert "no case was checked, so nothing passed: that is not a pass" in out
    write_results(tmp_path, "gp", {"wnoa_dt0.1": all_data_free["gp"]["wnoa_dt0.1"]})
    code, out, _ = cli(capsys, "check", tmp_path, "--allow-missing")
    assert code == 0 and out.strip().splitlines()[-1].startswith("1 passed, 0 failed, "), out


def test_a_quantity_the_case_does_not_have_is_a_warning_and_the_rest_is_checked(
    tmp_path, capsys, all_data_free, write_results
):
    gp = copy.deepcopy(all_data_free["gp"])
    gp["wnoa_dt0.1"]["Q_condition_number"] = 12.5  # an extra output a port writes
    gp["wnoa_dt0.5"]["Phi"][0][3] += 1e-3  # and a real fault elsewhere in the same file
    write_results(tmp_path, "gp", gp)
    code, out, err = cli(capsys, "check", tmp_path, "--only", "gp")
    lines = out.strip().splitlines()
    assert code == 1 and err == "" and lines[-1] == f"{len(gp) - 1} passed, 1 failed", out
    assert any(
        line.startswith("warning: ") and "cases/wnoa_dt0.1" in line and "'Q_condition_number'" in line for line in lines
    ), out
    assert any(line.startswith("FAIL gp/wnoa_dt0.5: Phi") for line in lines), out
    gp["wnoa_dt0.5"]["Phi"][0][3] -= 1e-3
    gp["wnoa_dt0.1"]["Phii"] = gp["wnoa_dt0.1"].pop("Phi")  # a typo still fails: the quantity it misspells is missing
    write_results(tmp_path, "gp", gp)
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "gp")
    assert code == 1 and "FAIL gp/wnoa_dt0.1: Phi is missing from the results" in out and "'Phii'" in out, out


# --- the fixed_lag suite -------------------------------------------------------------------------------


def test_a_port_that_forgets_at_t_equal_to_newest_minus_lag_fails_the_boundary_case(tmp_path, capsys, write_results):
    case = case_of("fixed_lag", "timestamp_at_the_boundary")
    lag = case["inputs"]["lag"]
    times = [t for u in case["inputs"]["stream"]["updates"] for t in u["timestamps"].values()]
    newest = np.maximum.accumulate(times)
    assert any(t == n - lag for t in times for n in newest)  # a timestamp exactly at the boundary, in binary
    assert case["expected"]["marginalized_3"] == [] and case["expected"]["marginalized_4"] == ["x0"]
    # t <= newest - lag is t < newest - lag' for any lag' a hair below lag (the timestamps are multiples of 0.5)
    write_results(tmp_path, "fixed_lag", {case["name"]: replay(case, lag=np.nextafter(lag, 0.0))})
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "fixed_lag", "--allow-missing")
    assert code == 1 and "FAIL fixed_lag/timestamp_at_the_boundary: marginalized_3 differs" in out, out
    write_results(tmp_path, "fixed_lag", {case["name"]: replay(case)})  # the oracle's own rule passes
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "fixed_lag", "--allow-missing")
    assert code == 0, out


def test_a_port_that_never_forgets_landmarks_fails_the_forgotten_landmark_case(tmp_path, capsys, write_results):
    case = case_of("fixed_lag", "landmark_forgotten_and_seen_again")
    assert case["expected"]["marginalized_4"] == ["x1", "l0"] and "l0" in case["expected"]["estimate_5"]
    updates = copy.deepcopy(case["inputs"]["stream"]["updates"])
    for u in updates:  # timestamps of states only: landmarks stay for ever
        u["timestamps"] = {k: t for k, t in u["timestamps"].items() if k.startswith("x")}
    write_results(tmp_path, "fixed_lag", {case["name"]: replay(case, updates=updates)})
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "fixed_lag", "--allow-missing")
    assert code == 1 and "FAIL fixed_lag/landmark_forgotten_and_seen_again: marginalized_4 differs" in out, out


def test_the_marginal_information_is_singular_where_the_docs_say_and_the_readme_says_how_to_store_it():
    """Measured on the kit: the null vector of each singular Λ lies on one landmark of the separator, across the
    line of sight from the dropped state (whose position the oracle replay gives)."""
    singular, total = {3: 0, 4: 0}, {3: 0, 4: 0}
    for version in (3, 4):
        for c in read_suite(KITS[version], "fixed_lag")["cases"]:
            if version == 4 and c["name"] in {x["name"] for x in read_suite(KITS[3], "fixed_lag")["cases"]}:
                continue
            thetas = fixed_lag(
                c["inputs"]["stream"]["variables"],
                c["inputs"]["stream"]["updates"],
                c["inputs"]["lag"],
                float(c["inputs"]["isam2"]["relinearize_threshold"]),
            )
            for q, info in c["expected"].items():
                if not q.startswith("marginal_information_"):
                    continue
                k = q.rsplit("_", 1)[1]
                w, V = np.linalg.eigh(np.array(info))
                total[version] += 1
                if w[0] > 1e-12 * w[-1]:
                    continue
                singular[version] += 1
                assert w[1] > 1e-6 * w[-1]  # one null direction
                sep, point = c["expected"][f"separator_{k}"], np.array(c["expected"][f"marginal_point_{k}"])
                off = np.cumsum([0] + [2 if s.startswith("l") else 6 for s in sep])
                null = V[:, 0]
                on = [s for i, s in enumerate(sep) if np.abs(null[off[i] : off[i + 1]]).max() > 1e-8]
                assert len(on) == 1 and on[0].startswith("l"), (c["name"], q, on)
                i = sep.index(on[0])
                (state,) = [d for d in c["expected"][f"marginalized_{k}"] if d.startswith("x")]
                # θ̄ of the dropped state at update k: its first value (never relinearized), else (relinearized
                # every update, β = 0) its estimate after update k - 1
                first = next(u["values"][state] for u in c["inputs"]["stream"]["updates"] if state in u["values"])
                never = c["inputs"]["isam2"]["relinearize_threshold"] == "inf"
                position = np.array(first if never else thetas[int(k) - 2]["estimate"][state])[:2]
                sight = point[off[i] : off[i] + 2] - position
                assert abs(np.dot(null[off[i] : off[i] + 2], sight)) < 1e-9 * np.linalg.norm(sight), (c["name"], q)
    assert (singular[3], total[3]) == (6, 13) and (singular[4], total[4]) == (3, 5)
    readme = export_readme()
    assert "Lambda may be singular" in readme and "(F.3)" in readme and "LDL^T with pivoting" in readme
    assert "never an unpivoted Cholesky" in readme and "6 of the 13 marginalizations" in readme
    assert "SINGULAR" in read_index(SHIPPED)["conventions"]["fixed_lag"]


def test_every_citation_of_the_exported_kit_is_in_the_exported_kit(tmp_path, capsys):
    code, _, _ = cli(capsys, "export", tmp_path / "kit")
    assert code == 0
    readme = (tmp_path / "kit" / "README.md").read_text()
    text = "".join(p.read_text() for p in (tmp_path / "kit").rglob("*.json"))
    assert "derivations" not in text.lower() and "Eq. 10." not in text
    for case in (c for s in DATA_FREE for c in read_suite(SHIPPED, s)["cases"]):
        for ref in re.findall(r"README '([^']+)'", case["equation"] + case["source"]):
            assert f"## {ref}" in readme, (case["name"], ref)
    cited = {
        q for s in DATA_FREE for c in read_suite(SHIPPED, s)["cases"] for q in re.findall(r"\(F\.\d\)", c["source"])
    }
    assert all(f"{ref}" in readme for ref in cited)


def test_the_tree_edit_rule_says_frontal_or_separator_and_what_sorted_applies_to():
    readme = export_readme()
    assert "holding a relinearized variable, as a frontal or in its separator" in readme
    assert "never to the frontals inside a clique" in readme
    assert "each clique named by the list of its frontals in elimination order (not sorted)" in readme
    docs = (Path(__file__).resolve().parents[1] / "docs" / "conformance.md").read_text()
    assert "as a frontal or\n   in its separator" in docs and "never to the frontals inside a clique" in docs


# --- the range at the landmark -------------------------------------------------------------------------


def test_a_range_at_the_landmark_is_minus_the_reading_with_zero_jacobian_rows(tmp_path, capsys, write_results):
    case = case_of("factors", "range_at_landmark")
    values = case["inputs"]["values"]
    assert values["x0"][:2] == values["l0"]  # exactly at the landmark
    r, sigma = case["inputs"]["factor"]["measured"], case["inputs"]["factor"]["sigma"]
    exp = case["expected"]
    assert exp["error"] == [-r] and exp["b"] == [r / sigma] and exp["cost"] == pytest.approx(0.5 * (r / sigma) ** 2)
    assert not np.any(exp["H_0"]) and not np.any(exp["H_1"]) and not np.any(exp["A_0"]) and not np.any(exp["A_1"])
    good = json.loads(dumps({q: exp[q] for q in case["tolerance"]}))
    write_results(tmp_path, "factors", {case["name"]: good})
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "factors", "--allow-missing")
    assert code == 0, out
    gtsam_like = copy.deepcopy(good)  # GTSAM's norm2 at 0: H = [1, 1] ("really infinity, why 1?")
    gtsam_like["H_1"] = [[1.0, 1.0]]
    write_results(tmp_path, "factors", {case["name"]: gtsam_like})
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "factors", "--allow-missing")
    assert code == 1 and "FAIL factors/range_at_landmark: H_1" in out, out
    assert "range_at_landmark" in read_index(SHIPPED)["conventions"]
