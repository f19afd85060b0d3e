"""Kit v5's additions on groups: the se2 suite's readings, retraction, prediction and fixed-lag cases, the se3 suite's
batch and incremental cases, and the 'signed-half-turn' convention alternative. Each wrong port is the independent
oracle (:mod:`steam_ref.conformance.oracle_lie`, :mod:`.oracle_rigid`, :mod:`.oracle_lag`) with one piece swapped, or
GTSAM's own numbers, never steam_ref's code; each fails the case written for it and passes where it is right.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from requirements import optional_import

from steam_ref.cli import main
from steam_ref.conformance import KIT_VERSION, KITS, SHIPPED, run_case
from steam_ref.conformance import oracle as base
from steam_ref.conformance import oracle_lie as o
from steam_ref.conformance import oracle_rigid as rigid
from steam_ref.conformance.checker import check_cases
from steam_ref.conformance.expected import fixed_lag_quantities, oracle_case
from steam_ref.conformance.kitio import dumps, read_suite
from steam_ref.conformance.oracle_graph import Space
from steam_ref.conformance.oracle_lag import fixed_lag
from steam_ref.errors import SteamError

SE2 = {c["name"]: c for c in read_suite(SHIPPED, "se2")["cases"]}
SE3 = {c["name"]: c for c in read_suite(SHIPPED, "se3")["cases"]}
NEW_SE2 = [
    "range_reading",
    "bearing_reading_wrapped",
    "bearing_range_reading_full_covariance",
    "body_velocity_reading",
    "interpolated_bearing_range_late",
    "interpolated_velocity_simplified",
    "retract_across_pi",
    "extrapolation_local_variable",
    "extrapolation_simplified",
    "fixed_lag_through_the_half_turn",
]


def plain(value) -> dict:
    return json.loads(dumps(value))


def port(suite: str, case: dict, inputs: dict | None = None) -> dict:
    out = oracle_case(suite, case["name"], case["inputs"] if inputs is None else inputs)
    return plain({q: out[q] for q in case["tolerance"]})


def failing(suite: str, names: list[str], results: dict, conventions: tuple[str, ...] = ()) -> list[str]:
    cases = SE2 if suite == "se2" else SE3
    report = check_cases(suite, [cases[n] for n in names], results, conventions=conventions)
    return [outcome.line() for outcome in report.outcomes if not outcome.passed]


def test_the_new_cases_ship_independent_and_steam_ref_and_the_oracle_pass_them():
    assert set(NEW_SE2) <= set(SE2) and all(SE2[n]["independent"] for n in NEW_SE2)
    assert {"batch_three_states", "incremental_three_updates"} <= set(SE3)
    kinds = {SE2[n]["inputs"]["kind"] for n in NEW_SE2}
    assert kinds == {"reading", "retract", "extrapolation", "fixed_lag"}
    types = {SE2[n]["inputs"]["factor"]["type"] for n in NEW_SE2 if SE2[n]["inputs"]["kind"] == "reading"}
    assert types == {"se2_range", "se2_bearing", "se2_bearing_range", "se2_velocity", "se2_interpolated"}
    for suite, names in (("se2", NEW_SE2), ("se3", ["batch_three_states", "incremental_three_updates"])):
        cases = SE2 if suite == "se2" else SE3
        ours = {n: plain(run_case(suite, n, cases[n]["inputs"])) for n in names}
        assert failing(suite, names, ours) == []
        assert failing(suite, names, {n: port(suite, cases[n]) for n in names}) == []
    relinearized = [SE3["incremental_three_updates"]["expected"][f"relinearized_{k}"] for k in (1, 2, 3)]
    assert relinearized == [[], ["x0"], ["x1"]]  # the SE(3) stream does relinearize


# --- readings of SE(2) states --------------------------------------------------------------------------


def _vector_retract(x, delta):
    """A port that moves an SE(2) state as a vector: [p + dρ, θ + dφ] (no R(θ) on the position)."""
    x, delta = np.asarray(x, float), np.asarray(delta, float)
    return x + delta


def test_a_port_moving_the_pose_as_a_vector_fails_the_pose_readings(monkeypatch):
    monkeypatch.setattr(o, "retract", _vector_retract)
    names = ["range_reading", "bearing_range_reading_full_covariance", "body_velocity_reading"]
    lines = failing("se2", names, {n: port("se2", SE2[n]) for n in names})
    assert [line.split(":")[0] for line in lines] == [f"FAIL se2/{n}" for n in names[:2]], lines
    assert all(line.split(": ")[1].startswith("H_0") for line in lines), lines  # the twist reading is [0 I] either way


def test_a_bearing_left_unwrapped_fails(monkeypatch):
    monkeypatch.setattr(base, "_wrap", lambda a: a)
    names = ["bearing_reading_wrapped", "bearing_range_reading_full_covariance"]
    lines = failing("se2", names, {n: port("se2", SE2[n]) for n in names})
    assert len(lines) == 1 and lines[0].startswith("FAIL se2/bearing_reading_wrapped: error"), lines


def test_a_twist_reading_in_the_world_frame_fails(monkeypatch):
    real = o.factor_error

    def world(spec, xs):
        if spec["type"] != "se2_velocity":
            return real(spec, xs)
        x = np.asarray(xs[0], float)
        c, s = np.cos(x[2]), np.sin(x[2])
        return np.array([c * x[3] - s * x[4], s * x[3] + c * x[4], x[5]]) - np.asarray(spec["measured"], float)

    monkeypatch.setattr(o, "factor_error", world)
    names = ["body_velocity_reading", "interpolated_velocity_simplified"]
    lines = failing("se2", names, {n: port("se2", SE2[n]) for n in names})
    assert [line.split(": ")[1].split()[0] for line in lines] == ["error", "error"], lines


def test_an_interpolated_reading_with_absolute_times_or_the_other_model_fails(monkeypatch):
    late, simplified = "interpolated_bearing_range_late", "interpolated_velocity_simplified"
    swapped = {**SE2[simplified]["inputs"]["factor"], "model": "local-variable"}
    wrong = port("se2", SE2[simplified], {**SE2[simplified]["inputs"], "factor": swapped})
    real = o.interpolate
    monkeypatch.setattr(o, "interpolate", lambda t1, t2, tau, qc, model: real(0.0, t2, tau, qc, model))
    lines = failing("se2", [late, simplified], {late: port("se2", SE2[late]), simplified: wrong})
    assert [line.split(":")[0] for line in lines] == [f"FAIL se2/{late}", f"FAIL se2/{simplified}"], lines


# --- the retraction, the prediction ------------------------------------------------------------------


def test_a_retraction_that_leaves_the_heading_unwrapped_fails(monkeypatch):
    real = o.retract

    def unwrapped(x, delta):
        out = real(x, delta)
        if len(out) == 6:
            out[2] = float(np.asarray(x, float)[2] + np.asarray(delta, float)[2])  # θ + φ, never brought back
        return out

    monkeypatch.setattr(o, "retract", unwrapped)
    name = "retract_across_pi"
    lines = failing("se2", [name], {name: port("se2", SE2[name])})
    assert len(lines) == 1 and lines[0].startswith(f"FAIL se2/{name}: retract"), lines


def test_the_local_variable_map_used_for_the_simplified_prediction_fails():
    """steam_ref's extrapolate_covariance took the local-variable N for either model until kit v5's case."""
    name = "extrapolation_simplified"
    case = SE2[name]
    wrong = port("se2", case, {**case["inputs"], "model": "local-variable"})
    lines = failing("se2", [name], {name: wrong})
    assert len(lines) == 1 and lines[0].startswith(f"FAIL se2/{name}: cov_t"), lines  # x_t and J_1 are the same


# --- fixed lag on SE(2) --------------------------------------------------------------------------------


def _replay(case: dict, space: Space, schur: bool = True) -> dict:
    inputs = case["inputs"]
    isam2 = inputs["isam2"]
    replay = fixed_lag(
        inputs["stream"]["variables"],
        inputs["stream"]["updates"],
        float(inputs["lag"]),
        float(isam2["relinearize_threshold"]),
        int(isam2["relinearize_skip"]),
        schur,
        space=space,
    )
    return plain({q: v for q, v in fixed_lag_quantities(replay).items() if q in case["tolerance"]})


def test_a_fixed_lag_port_that_subtracts_stored_states_or_skips_the_schur_complement_fails():
    name = "fixed_lag_through_the_half_turn"
    case = SE2[name]
    assert _replay(case, o.LIE) == port("se2", case)
    assert case["expected"]["marginal_point_2"][2] == 3.05 and case["expected"]["estimate_2"]["x1"][2] < -3.1
    subtracting = Space(o.LIE.retract, o.LIE.linearize)  # θ̄' - θ̄⁰ of the stored numbers: 2π off past ±π
    lines = failing("se2", [name], {name: _replay(case, subtracting)})
    assert len(lines) == 1 and lines[0].startswith(f"FAIL se2/{name}: marginal_vector_3"), lines  # η − Λ 2π
    lines = failing("se2", [name], {name: _replay(case, o.LIE, schur=False)})
    assert len(lines) == 1 and lines[0].startswith(f"FAIL se2/{name}: marginal_information_2"), lines


# --- SE(3) batch and incremental ------------------------------------------------------------------------


def test_an_se3_port_with_j_r_in_place_of_its_inverse_fails_the_solves(monkeypatch):
    monkeypatch.setattr(rigid, "right_jacobian_inverse", rigid.right_jacobian)
    names = ["batch_three_states", "incremental_three_updates"]
    lines = failing("se3", names, {n: port("se3", SE3[n]) for n in names})
    assert [line.split(":")[0] for line in lines] == [f"FAIL se3/{n}" for n in names], lines


# --- the half turn: gtsam.Pose2 and --conventions signed-half-turn -------------------------------------


def test_the_half_turn_cases_store_the_signed_alternative_and_nothing_else_does():
    for name, case in SE2.items():
        alternatives = case.get("alternatives", {})
        if name in ("exp_near_half_turn", "log_near_half_turn"):
            assert set(alternatives) == {"signed-half-turn"}, name
            assert {q["name"]: q["depends_on"] for q in case["quantities"]} == {
                key: ["half_turn"] for key in case["tolerance"]
            }
        else:
            assert not alternatives, name
    signed = SE2["exp_near_half_turn"]["alternatives"]["signed-half-turn"]["exp"]
    assert signed[2][2] == -np.pi and SE2["exp_near_half_turn"]["expected"]["exp"][2][2] == np.pi


def test_a_convention_a_kit_does_not_have_is_refused(tmp_path):
    from steam_ref.conformance.gate import check_directory

    (tmp_path / "se2").mkdir()
    (tmp_path / "se2" / "results.json").write_text(dumps({"kit_version": 4, "cases": {}}))
    with pytest.raises(SteamError, match="kit v4 has no convention alternative 'signed-half-turn'"):
        check_directory(tmp_path, KITS[4], only=["se2"], conventions=["signed-half-turn"])


gtsam = optional_import("gtsam", "gtsam")


def _pose(p) -> list[float]:
    return [p.x(), p.y(), p.theta()]


def test_gtsam_pose2_passes_the_half_turn_with_signed_half_turn_and_fails_without(tmp_path, capsys):
    """gtsam.Pose2's own Expmap and Logmap (no -π read as +π), checked through the CLI."""
    exp_case, log_case = SE2["exp_near_half_turn"]["inputs"], SE2["log_near_half_turn"]["inputs"]
    poses = [gtsam.Pose2.Expmap(np.asarray(xi, float)) for xi in exp_case["xi"]]
    logs = [gtsam.Pose2.Logmap(gtsam.Pose2(*p)) for p in log_case["poses"]]
    results = {
        "exp_near_half_turn": {"exp": [_pose(p) for p in poses], "log_of_exp": [gtsam.Pose2.Logmap(p) for p in poses]},
        "log_near_half_turn": {"log": logs, "exp_of_log": [_pose(gtsam.Pose2.Expmap(t)) for t in logs]},
    }
    (tmp_path / "se2").mkdir()
    (tmp_path / "se2" / "results.json").write_text(dumps({"kit_version": KIT_VERSION, "cases": results}))
    code = main(["conformance", "check", str(tmp_path), "--only", "se2", "--allow-missing"])
    out = capsys.readouterr().out
    assert code == 1 and "FAIL se2/exp_near_half_turn: exp" in out and "FAIL se2/log_near_half_turn: log" in out, out
    for conventions in (["signed-half-turn"], ["signed-half-turn", "paper-sign"]):
        code = main(
            ["conformance", "check", str(tmp_path), "--only", "se2", "--allow-missing", "--conventions", *conventions]
        )
        out = capsys.readouterr().out
        assert code == 0 and "2 passed, 0 failed" in out.strip().splitlines()[-1], out
