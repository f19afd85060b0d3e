"""The gate against the ways a port goes wrong, each failure naming what an engineer needs to find the bug.

Each test edits steam_ref's correct results into a wrong port's (a Jacobian block of the wrong sign, a value off by
ten times its tolerance, a heading 2π off, a transposed Jacobian, a flipped sign, Jacobian columns in another
order, Φ and Q of a state stacked axis by axis, Λ and Ψ swapped) and checks that ``check`` fails the case and names
the case, the quantity, the entry, the expected and the got value and the tolerance; and the other way, that what
is right within the documented rules passes: a value off by half its tolerance, an integral count written as a
double (``189.0``: JSON has one number type). The tolerance is recomputed here from the kit's ``{atol, rtol}`` and
the documented rule, atol + rtol max abs(expected), not read from the checker.
"""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest
from cli_runs import runner

from steam_ref.conformance import KIT_VERSION, KITS, SHIPPED
from steam_ref.conformance.checker import compare_quantity
from steam_ref.conformance.kitio import read_suite
from steam_ref.conformance.readme import export_readme

cli = runner("conformance")


def kit_case(suite: str, name: str) -> dict:
    return next(c for c in read_suite(SHIPPED, suite)["cases"] if c["name"] == name)


def allowed(suite: str, name: str, quantity: str) -> float:
    """The documented tolerance of a numeric quantity: atol + rtol max abs(expected)."""
    case = kit_case(suite, name)
    tol = case["tolerance"][quantity]
    return tol["atol"] + tol["rtol"] * float(np.abs(np.asarray(case["expected"][quantity], float)).max())


def check(tmp_path, capsys, suite: str, cases: dict) -> tuple[int, list[str]]:
    """Write ``cases`` as a port's JSON (Python's json, floats as doubles) and check that suite alone."""
    (tmp_path / suite).mkdir(parents=True, exist_ok=True)
    (tmp_path / suite / "results.json").write_text(json.dumps({"kit_version": KIT_VERSION, "cases": cases}))
    code, out, err = cli(capsys, "check", tmp_path, "--only", suite)
    assert err == "", err
    return code, out.splitlines()


def fail_line(lines: list[str], suite: str, name: str) -> str:
    heads = [line for line in lines if line.startswith(f"FAIL {suite}/{name}: ")]
    assert len(heads) == 1, lines
    return heads[0]


def test_one_jacobian_block_of_the_wrong_sign_fails_naming_the_block_and_its_entries(tmp_path, capsys, kit_results):
    results = kit_results(SHIPPED, "factors")
    good = np.array(results["range"]["H_1"])
    results["range"]["H_1"] = (-good).tolist()  # the landmark's block flipped, the robot's right
    code, lines = check(tmp_path, capsys, "factors", results)
    head = fail_line(lines, "factors", "range")
    assert code == 1 and lines[-1] == f"{len(results) - 1} passed, 1 failed", lines
    assert head.startswith("FAIL factors/range: H_1 worst |diff| ") and "H_0" not in head, head
    assert f"> tolerance {allowed('factors', 'range', 'H_1'):.3g}" in head, head
    expected = kit_case("factors", "range")["expected"]["H_1"]
    k = np.unravel_index(np.argmax(np.abs(good)), good.shape)
    assert (
        f"    H_1[{k[0]}, {k[1]}]: expected {expected[k[0]][k[1]]!r}, got {float(-good[k])!r} (|diff| {2 * abs(float(good[k])):.3g})"
        in lines
    ), lines


@pytest.mark.parametrize(("times", "fails"), [(10.0, True), (0.5, False)])
def test_a_value_off_by_ten_times_its_tolerance_fails_and_by_half_of_it_passes(
    tmp_path, capsys, kit_results, times, fails
):
    results = kit_results(SHIPPED, "factors")
    tol = allowed("factors", "bearing", "error")
    got = results["bearing"]["error"][0] + times * tol
    results["bearing"]["error"][0] = got
    code, lines = check(tmp_path, capsys, "factors", results)
    if not fails:
        assert code == 0 and lines[-1] == f"{len(results)} passed, 0 failed", lines
        return
    head = fail_line(lines, "factors", "bearing")
    assert code == 1 and head.startswith("FAIL factors/bearing: error worst |diff| "), head
    assert f"> tolerance {tol:.3g} (atol " in head and "1 of 1 entries past it" in head, head
    expected = kit_case("factors", "bearing")["expected"]["error"][0]
    assert any(line.startswith(f"    error[0]: expected {expected!r}, got {got!r}") for line in lines), lines


@pytest.mark.parametrize(
    ("suite", "name", "quantity"),
    [("se2", "exp_near_half_turn", "exp"), ("se2", "retract_across_pi", "retract")],
)
def test_an_se2_heading_two_pi_off_fails_as_the_readme_promises_headings_in_minus_pi_to_pi(
    tmp_path, capsys, kit_results, suite, name, quantity
):
    """The README: 'headings of poses and states in (-pi, pi]'; a heading 2π off is the same rotation, and a port
    that leaves it there is told so at the entry, 6.28 off, and that it is 2π off (the hint came with this test)."""
    results = kit_results(SHIPPED, suite)
    rows = np.array(results[name][quantity])
    rows[0, 2] += 2 * math.pi
    results[name][quantity] = rows.tolist()
    code, lines = check(tmp_path, capsys, suite, results)
    head = fail_line(lines, suite, name)
    assert code == 1 and head.startswith(f"FAIL {suite}/{name}: {quantity} worst |diff| 6.28 at [0, 2] > "), head
    assert head.endswith("1 x 2 pi off: an angle brought into another range (README conventions 'angles', 'se2')"), head


def test_a_value_of_1e308_is_not_called_a_whole_number_of_turns_off(tmp_path, capsys, kit_results):
    """Float64's spacing at 1e308 is about 2e292: every value there is a multiple of 2π to float64's precision, so
    the hint cannot tell a turn from anything else (it said "1591549430918953...x 2 pi off"); no hint claims it."""
    results = kit_results(SHIPPED, "factors")
    results["bearing"]["error"][0] = 1e308
    code, lines = check(tmp_path, capsys, "factors", results)
    head = fail_line(lines, "factors", "bearing")
    assert code == 1 and head.startswith("FAIL factors/bearing: error worst |diff| 1e+308 at [0] > "), head
    assert "pi off" not in head and head.endswith("1 of 1 entries past it"), head


def test_a_transposed_jacobian_fails_square_by_its_entries_and_rectangular_by_its_shape(tmp_path, capsys, kit_results):
    se2 = kit_results(SHIPPED, "se2")
    h0 = np.array(se2["prior_local_variable_fast"]["H_0"])
    assert not np.allclose(h0, h0.T)  # else a transpose would be right
    se2["prior_local_variable_fast"]["H_0"] = h0.T.tolist()
    code, lines = check(tmp_path / "square", capsys, "se2", se2)
    head = fail_line(lines, "se2", "prior_local_variable_fast")
    assert code == 1 and head.startswith("FAIL se2/prior_local_variable_fast: H_0 worst |diff| "), lines
    assert TRANSPOSED_HINT in head, head  # the old check printed the entries and no hint
    factors = kit_results(SHIPPED, "factors")
    factors["range"]["H_0"] = np.array(factors["range"]["H_0"]).T.tolist()
    code, lines = check(tmp_path / "rectangular", capsys, "factors", factors)
    assert code == 1 and fail_line(lines, "factors", "range") == (
        "FAIL factors/range: H_0 has shape (6, 1), expected (1, 6): transposed? (arrays are nested lists, row-major: "
        "a Jacobian has a row per error entry)"
    )


TRANSPOSED_HINT = "; it is the expected matrix transposed (got = expected^T): a transposed Jacobian, whitener or R"


@pytest.mark.parametrize(("name", "quantity"), [("gp_prior_diag_qc", "H_0"), ("bearing_range", "H_1")])
def test_a_square_transposed_jacobian_of_the_factors_suite_is_named_as_transposed(
    tmp_path, capsys, kit_results, name, quantity
):
    """An outside port wrote H_0 of the GP prior as -Phi^T and the 2 x 2 landmark block of bearing_range
    transposed. The old check named the first a state stacked in another order (-Phi^T is -Phi's block rows and
    columns swapped, p = [3, 4, 5, 0, 1, 2]) and gave the second no hint at all."""
    factors = kit_results(SHIPPED, "factors")
    h = np.array(factors[name][quantity])
    assert h.shape[0] == h.shape[1] and not np.allclose(h, h.T)
    factors[name][quantity] = h.T.tolist()
    code, lines = check(tmp_path, capsys, "factors", factors)
    head = fail_line(lines, "factors", name)
    assert code == 1 and head.startswith(f"FAIL factors/{name}: {quantity} worst |diff| "), head
    assert TRANSPOSED_HINT in head and "stacked in another order" not in head, head


def test_q_with_the_wrong_power_of_dt_is_named_as_one_common_factor(tmp_path, capsys, kit_results):
    """A port writing WNOA's Q position block dt^2/3 Qc for dt^3/3 Qc [YIB Eq. 17] scales exactly the failing
    entries by 1/dt (2 at dt = 0.5); the old check printed them with no hint. Q is written out here from Eq. 17,
    not read from the kit."""
    gp = kit_results(SHIPPED, "gp")
    case = kit_case("gp", "wnoa_dt0.5")
    dt, qc = case["inputs"]["dt"], np.array(case["inputs"]["qc"])
    wrong = np.kron([[dt**2 / 3, dt**2 / 2], [dt**2 / 2, dt]], qc)
    gp["wnoa_dt0.5"]["Q"] = wrong.tolist()
    code, lines = check(tmp_path, capsys, "gp", gp)
    head = fail_line(lines, "gp", "wnoa_dt0.5")
    assert code == 1 and head.startswith("FAIL gp/wnoa_dt0.5: Q worst |diff| "), head
    assert "; the 3 failing entries are the expected ones times 2 (one common factor): a wrong constant or power" in (
        head
    ), head


def test_a_result_rounded_through_float32_is_named_as_single_precision(tmp_path, capsys, kit_results):
    """A port that keeps Phi in float32 writes 0.10000000149011612 for 0.1: off by 1.5e-9, past rtol 1e-13. The
    old check printed the entries alone; every entry being a float32 number is what says where to look."""
    gp = kit_results(SHIPPED, "gp")
    phi = np.array(gp["wnoa_dt0.1"]["Phi"])
    gp["wnoa_dt0.1"]["Phi"] = phi.astype(np.float32).astype(float).tolist()
    code, lines = check(tmp_path, capsys, "gp", gp)
    head = fail_line(lines, "gp", "wnoa_dt0.1")
    assert code == 1 and head.startswith("FAIL gp/wnoa_dt0.1: Phi worst |diff| 1.49e-09 at [0, 3] "), head
    assert "; every entry got is a float32 value: single precision somewhere" in head, head
    assert "    Phi[0, 3]: expected 0.1, got 0.10000000149011612 (|diff| 1.49e-09)" in lines, lines


def test_an_integral_count_written_as_a_double_is_the_same_json_number_and_passes(tmp_path, capsys, kit_results):
    """nnz_k and the like are compared exactly; JSON has one number type, and a port whose JSON library writes a
    double (nlohmann's 189.0, a JAX float) gives the same number: it passed 'kit_version': 4.0 but failed
    nnz_3: 189.0 ('expected 189, got 189.0')."""
    results = kit_results(SHIPPED, "incremental")
    counted = [(name, q) for name, case in results.items() for q in case if q.startswith("nnz_")]
    assert counted
    doubled = copy.deepcopy(results)
    for name, q in counted:
        doubled[name][q] = float(results[name][q])
    code, lines = check(tmp_path / "doubles", capsys, "incremental", doubled)
    assert code == 0 and lines[-1] == f"{len(results)} passed, 0 failed", lines
    name, q = counted[0]
    doubled[name][q] = results[name][q] + 0.5  # not the same number: still a failure, naming both
    code, lines = check(tmp_path / "off", capsys, "incremental", doubled)
    assert code == 1 and fail_line(lines, "incremental", name).endswith(f": {q} differs (compared exactly)"), lines
    assert f"    got      {results[name][q] + 0.5}" in lines, lines
    assert "JSON has one number type, so a count written 189.0 is 189" in " ".join(
        export_readme().split()
    )  # what a port reads


def test_a_misspelt_kit_version_key_is_named_not_silently_read_as_kit_v1(tmp_path, capsys, kit_results):
    """'kit_verison': 5 is a key the layout does not have; the file then names no kit_version and is checked as kit
    v1's (its rule for files written before the field existed). The check says so, and names the key it did not
    read, instead of passing the gp results against v1 with only the v1 note."""
    (tmp_path / "gp").mkdir()
    results = {"kit_verison": KIT_VERSION, "cases": kit_results(KITS[1], "gp")}
    (tmp_path / "gp" / "results.json").write_text(json.dumps(results))
    code, out, err = cli(capsys, "check", tmp_path, "--only", "gp")
    assert code == 0 and err == "" and "checked as kit v1 results" in out, out
    assert (
        f"warning: {tmp_path / 'gp' / 'results.json'}: 'kit_verison' is not a key of a results file, not read "
        "(its keys: kit_version, cases)" in out.splitlines()
    ), out


SIGN_HINT = (
    "every entry is minus the expected one: a flipped sign (README conventions 'residual': e = h(theta) - y, the GP "
    "prior's e = x_i - Phi x_(i-1) - v_i; --conventions paper-sign takes [YIB Eq. 22]'s for gp_prior)"
)


def test_a_flipped_sign_is_named_as_one_and_not_as_a_swap_with_b(tmp_path, capsys, kit_results):
    """A port with Eq. 22's sign for the SE(2) prior (no paper-sign alternative there) or a measurement written
    y - h: every entry is minus the expected one, and the line says so. b = -W e, so a flipped whitened_error is
    also the expected b: the sign, not a swap, is the hint there."""
    se2 = kit_results(SHIPPED, "se2")
    case = se2["prior_local_variable_fast"]
    for q in ("error", "H_0", "H_1"):
        case[q] = (-np.array(case[q])).tolist()
    code, lines = check(tmp_path / "se2", capsys, "se2", se2)
    head = fail_line(lines, "se2", "prior_local_variable_fast")
    assert code == 1 and head.startswith("FAIL se2/prior_local_variable_fast: error worst |diff| "), head
    assert head.endswith(f"; {SIGN_HINT} (likely cause: first failing in computation order; 2 more failing)"), head
    factors = kit_results(SHIPPED, "factors")
    factors["range"]["whitened_error"] = (-np.array(factors["range"]["whitened_error"])).tolist()
    code, lines = check(tmp_path / "factors", capsys, "factors", factors)
    head = fail_line(lines, "factors", "range")
    assert code == 1 and head.endswith(SIGN_HINT) and "swapped" not in head, head


def test_jacobian_columns_in_another_order_are_named_with_the_permutation(tmp_path, capsys, kit_results):
    """A port whose state is [y, x, ...] (or whose Jacobian columns are permuted): the columns it wrote are the
    expected ones in another order, and the line gives the order."""
    factors = kit_results(SHIPPED, "factors")
    h0 = np.array(factors["range"]["H_0"])
    assert h0[0, 0] != h0[0, 1]  # else the swap would be right
    factors["range"]["H_0"] = h0[:, [1, 0, 2, 3, 4, 5]].tolist()
    code, lines = check(tmp_path, capsys, "factors", factors)
    head = fail_line(lines, "factors", "range")
    assert code == 1 and head.startswith("FAIL factors/range: H_0 worst |diff| "), head
    assert head.endswith(
        "; its columns are the expected columns [1, 0, 2, 3, 4, 5] in that order: an ordering differs (README "
        "conventions 'state', 'jacobians': a state is [x, y, theta, x_dot, y_dot, theta_dot], H_k for the k-th key)"
    ), head


AXIS_BY_AXIS = "; its rows and columns are the expected ones in the order p = {} (the same permutation on both): a "
AXIS_BY_AXIS_WHY = (
    "state stacked in another order (README conventions 'state': x = [p; p_dot] block by block, p = [x, y, theta], "
    "not axis by axis)"
)


def named_symmetric_permutation(message: str) -> list[int]:
    """The p of the symmetric-permutation hint in a failure's headline."""
    assert message.endswith(AXIS_BY_AXIS_WHY), message
    return json.loads(message.split("in the order p = ")[1].split(" (the same")[0])


def test_phi_q_and_qinv_of_a_state_stacked_axis_by_axis_are_named_with_the_permutation(tmp_path, capsys, kit_results):
    """A port whose WNOJ state is [x, x_dot, x_ddot, y, ...] (axis by axis) rather than the kit's [p; p_dot; p_ddot]
    writes Φ, Q, Q⁻¹ with rows and columns both permuted, got = expected[p][:, p]; no one-axis order fits, and
    Φ's diagonal is all ones (a diagonal match cannot place a row): the line names p."""
    gp = kit_results(SHIPPED, "gp")
    case = gp["wnoj_dt0.4"]
    p = [0, 3, 6, 1, 4, 7, 2, 5, 8]  # got's k-th entry is the kit's p[k]-th: x, x_dot, x_ddot, y, ...
    for q in ("Phi", "Q", "Qinv"):
        case[q] = np.array(case[q])[np.ix_(p, p)].tolist()
    code, lines = check(tmp_path, capsys, "gp", gp)
    head = fail_line(lines, "gp", "wnoj_dt0.4")
    assert code == 1 and head.startswith("FAIL gp/wnoj_dt0.4: Phi worst |diff| "), head
    assert head.endswith(
        AXIS_BY_AXIS.format(p)
        + AXIS_BY_AXIS_WHY
        + " (likely cause: first failing in computation order; 2 more failing)"
    ), head
    for q in ("Q", "Qinv"):
        assert any(
            line.startswith(f"  {q} ") and line.endswith(AXIS_BY_AXIS.format(p) + AXIS_BY_AXIS_WHY) for line in lines
        )


def test_an_isotropic_qc_repeating_the_diagonal_still_names_a_permutation_that_reproduces_the_port(tmp_path):
    """Q of WNOA with Qc = q I [YIB Eq. 17] (written out here: Q = [[dt^3/3, dt^2/2], [dt^2/2, dt]] kron q I) has each
    diagonal value three times, and relabelling the axes leaves it unchanged, so more than one p is right: the one
    named must be a permutation that reproduces the port's matrix within tolerance, checked here by indexing."""
    dt, q = 0.7, 0.3
    expected = np.kron([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]], q * np.eye(3))
    got = expected[np.ix_([4, 1, 5, 2, 3, 0], [4, 1, 5, 2, 3, 0])]  # [y_dot, y, theta_dot, theta, x_dot, x]
    tolerance = {"atol": 0.0, "rtol": 1e-12}
    ((_, head, _),) = compare_quantity(expected.tolist(), got.tolist(), tolerance, "Q")
    named = named_symmetric_permutation(head)
    assert sorted(named) == list(range(6)) and named != list(range(6)), head
    assert np.abs(got - expected[np.ix_(named, named)]).max() <= 1e-12 * np.abs(expected).max(), head


def test_a_thirty_by_thirty_matrix_is_searched_and_one_with_no_permutation_fails_fast_with_no_hint():
    """To the kit's largest square quantity (linear's 28 x 28): a permuted random 30 x 30 is named; the same with
    one entry off, and a 3-regular graph's adjacency against another's (a Möbius ladder and a prism, not
    isomorphic: the search is graph isomorphism there, millions of partial orders) fail within a second, no hint."""
    import time

    rng = np.random.default_rng(7)
    n, tolerance = 30, {"atol": 1e-12, "rtol": 0.0}
    expected = rng.standard_normal((n, n))
    p = [int(i) for i in rng.permutation(n)]
    got = expected[np.ix_(p, p)]
    ((_, head, _),) = compare_quantity(expected.tolist(), got.tolist(), tolerance, "R")
    assert head.endswith(AXIS_BY_AXIS.format(p) + AXIS_BY_AXIS_WHY), head
    off = got.copy()
    off[3, 5] += 1e-3

    def ring(edges) -> np.ndarray:
        a = np.zeros((n, n))
        for i, j in edges:
            a[i, j] = a[j, i] = 1.0
        return a

    moebius = ring([(i, (i + 1) % n) for i in range(n)] + [(i, i + 15) for i in range(15)])
    prism = ring(
        [(i, (i + 1) % 15) for i in range(15)]
        + [(15 + i, 15 + (i + 1) % 15) for i in range(15)]
        + [(i, i + 15) for i in range(15)]
    )
    for exp, wrong in ((expected, off), (moebius, prism)):
        start = time.perf_counter()
        ((_, head, _),) = compare_quantity(exp.tolist(), wrong.tolist(), tolerance, "R")
        assert time.perf_counter() - start < 1.0 and head.endswith("entries past it"), head


def test_lambda_and_psi_swapped_are_named_as_a_swap(tmp_path, capsys, kit_results):
    """Λ and Ψ of Eq. 16/18 handed in each other's place: Lambda fails first, and equals the expected Psi."""
    gp = kit_results(SHIPPED, "gp")
    case = gp["interp_tau1.1"]
    case["Lambda"], case["Psi"] = case["Psi"], case["Lambda"]
    code, lines = check(tmp_path, capsys, "gp", gp)
    head = fail_line(lines, "gp", "interp_tau1.1")
    assert code == 1 and head.startswith("FAIL gp/interp_tau1.1: Lambda worst |diff| "), head
    assert head.endswith(
        "; equals the expected Psi: the two swapped? (likely cause: first failing in computation order; 1 more failing)"
    ), head
    assert any(
        line.startswith("  Psi ") and line.endswith("; equals the expected Lambda: the two swapped?") for line in lines
    )
