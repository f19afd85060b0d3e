"""Kit v4's ``se2`` suite: it ships with its independent oracle, steam_ref passes it, and wrong ports fail it.

The wrong ports are the independent oracle (:mod:`steam_ref.conformance.oracle_lie`) with one piece swapped,
never steam_ref's own code: J_r where J_r⁻¹ belongs, a left retraction, a Log whose angle is wrapped to
[-π, π) (the half turn -π), ξ taken from the unwrapped heading difference, and the simplified residual
handed in for the local-variable one.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import scipy.linalg

from steam_ref.cli import main
from steam_ref.conformance import KIT_VERSION, SHIPPED, run_case
from steam_ref.conformance import oracle_lie as o
from steam_ref.conformance.checker import check_cases
from steam_ref.conformance.expected import oracle_case
from steam_ref.conformance.kitio import dumps, read_suite
from steam_ref.conformance.readme import export_readme

CASES = {c["name"]: c for c in read_suite(SHIPPED, "se2")["cases"]}


def port(case: dict, inputs: dict | None = None) -> dict:
    """The oracle's answer to a case (with other inputs, for a port that misreads them), as a results file holds it."""
    out = oracle_case("se2", case["name"], case["inputs"] if inputs is None else inputs)
    return json.loads(dumps({q: out[q] for q in case["tolerance"]}))


def failing(names: list[str], results: dict) -> list[str]:
    """The first failing line of each named case checked with ``results`` (case → quantities)."""
    report = check_cases("se2", [CASES[n] for n in names], results)
    return [outcome.line() for outcome in report.outcomes if not outcome.passed]


def test_the_suite_has_at_least_15_independent_cases_covering_each_part():
    assert len(CASES) >= 15 and all(c["independent"] for c in CASES.values())
    kinds = {c["inputs"]["kind"] for c in CASES.values()}
    assert kinds >= {"exp", "log", "jacobians", "prior", "interpolation", "batch", "incremental"}
    models = {c["inputs"].get("model") for c in CASES.values() if c["inputs"]["kind"] == "prior"}
    assert models == {"local-variable", "simplified"}
    assert any("cov_tau" in c["tolerance"] for c in CASES.values())
    relinearized = CASES["incremental_relinearize"]["expected"]
    assert any(relinearized[f"relinearized_{k}"] for k in range(1, 6))  # the stream does relinearize
    # the half turn comes back +π from either side
    logs = np.array(CASES["log_near_half_turn"]["expected"]["log"])
    assert logs[0, 2] == logs[1, 2] == np.pi


def test_steam_ref_and_the_oracle_pass_every_case(tmp_path, capsys):
    ours = {n: json.loads(dumps(run_case("se2", n, c["inputs"]))) for n, c in CASES.items()}
    assert failing(list(CASES), ours) == []
    assert failing(list(CASES), {n: port(c) for n, c in CASES.items()}) == []
    (tmp_path / "se2").mkdir()
    (tmp_path / "se2" / "results.json").write_text(dumps({"kit_version": KIT_VERSION, "cases": ours}))
    code = main(["conformance", "check", str(tmp_path), "--only", "se2"])
    assert code == 0 and capsys.readouterr().out.strip().splitlines()[-1] == f"{len(CASES)} passed, 0 failed"


def test_a_port_with_j_r_in_place_of_its_inverse_fails(monkeypatch):
    monkeypatch.setattr(o, "right_jacobian_inverse", o.right_jacobian)
    names = ["right_jacobian_small", "prior_local_variable_fast", "interpolation_local_variable"]
    lines = failing(names, {n: port(CASES[n]) for n in names})
    assert len(lines) == 3, lines
    assert lines[0].startswith("FAIL se2/right_jacobian_small: Jr_inv")
    assert lines[1].startswith("FAIL se2/prior_local_variable_fast: error")


def _left_retract(x, delta):
    x, delta = np.asarray(x, float), np.asarray(delta, float)
    if len(x) == 2:
        return x + delta
    pose = o.pose_of(scipy.linalg.expm(o.hat(delta[:3])) @ o.matrix(x[:3]))  # Exp(δ) T: on the left
    return np.concatenate([pose, x[3:] + delta[3:]])


def _left_local(x0, x):
    x0, x = np.asarray(x0, float), np.asarray(x, float)
    if len(x) == 2:
        return x - x0
    xi = o.log_matrix(o.matrix(x[:3]) @ np.linalg.inv(o.matrix(x0[:3])))
    return np.concatenate([xi, x[3:] - x0[3:]])


def test_a_port_with_a_left_retraction_fails(monkeypatch):
    monkeypatch.setattr(o, "retract", _left_retract)
    monkeypatch.setattr(o, "local", _left_local)
    names = ["prior_local_variable_slow", "prior_simplified_slow", "state_prior_across_pi", "batch_turning_with_ranges"]
    lines = failing(names, {n: port(CASES[n]) for n in names})
    assert [line.split(":")[0] for line in lines] == [f"FAIL se2/{n}" for n in names[:3]], lines
    assert lines[0].startswith("FAIL se2/prior_local_variable_slow: H_0")
    assert lines[2].startswith("FAIL se2/state_prior_across_pi: error")  # x - mean is Log(M^-1 T), not Log(T M^-1)
    # Gauss-Newton's iterates alone cannot tell: Exp(Ad(T) d) T = T Exp(d), so a port whose Jacobians match its
    # (left) retraction takes the same steps; the Jacobian and error cases are what catch it.


def test_a_port_whose_log_wraps_the_half_turn_to_minus_pi_fails(monkeypatch):
    def angle(M, half_turn=None):  # atan2's range [-π, π) : the half turn -π
        a = float(np.arctan2(M[1, 0], M[0, 0]))
        return -np.pi if a >= np.pi else a

    monkeypatch.setattr(o, "_angle", angle)
    names = ["log_near_half_turn", "exp_near_half_turn", "right_jacobian_small"]
    lines = failing(names, {n: port(CASES[n]) for n in names})
    assert lines == [line for line in lines if "half_turn" in line] and len(lines) == 2, lines
    assert lines[0].startswith("FAIL se2/log_near_half_turn: log")


def test_a_port_taking_xi_from_the_unwrapped_heading_difference_fails(monkeypatch):
    def xi_from_headings(M):  # φ = θ₂ - θ₁ as stored, not the angle of T₁⁻¹T₂
        return np.array([*np.linalg.solve(o._V(state["dphi"]), M[:2, 2]), state["dphi"]])

    state: dict = {}
    real = o.prior_error

    def prior_error(x1, x2, dt, model):
        state["dphi"] = float(x2[2] - x1[2])
        with monkeypatch.context() as m:
            m.setattr(o, "log_matrix", xi_from_headings)
            return real(x1, x2, dt, model)

    monkeypatch.setattr(o, "prior_error", prior_error)
    slow, across = "prior_local_variable_slow", "prior_local_variable_across_pi"
    lines = failing([slow, across], {n: port(CASES[n]) for n in (slow, across)})
    assert len(lines) == 1 and lines[0].startswith(f"FAIL se2/{across}: error"), lines  # the same away from ±π


@pytest.mark.parametrize("name", ["prior_local_variable_fast", "prior_local_variable_near_half_turn"])
def test_the_simplified_residual_checked_as_the_local_variable_one_fails(name):
    case = CASES[name]
    wrong = port(case, {**case["inputs"], "model": "simplified"})
    lines = failing([name], {name: wrong})
    assert len(lines) == 1 and lines[0].startswith(f"FAIL se2/{name}: error"), lines


def test_the_exported_readme_writes_the_se2_conventions():
    readme = export_readme()
    assert "## SE(2)" in readme
    for phrase in ("translation first", "+pi at the half", "the **right**", "body twist", "[x, y, theta, vx, vy, w]"):
        assert phrase in readme, phrase
