"""The conformance kit: what it ships, that the checker catches faults, that GTSAM passes it.

The oracles here are independent of steam_ref's numerics: deliberate faults written from each
case's inputs (Q with Δt² for Δt³, Λ and Ψ swapped, a flipped Jacobian, the cost without its ½)
must each fail, naming the case; GTSAM 4.3 (``examples/conformance_gtsam.py``) must pass every case
it computes; the paper suite's expected values must be the authors' saved runs as scipy reads them.
"""

from __future__ import annotations

import argparse
import ast
import copy
import fnmatch
import json
import math
import re
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import pytest
import scipy.io
import scipy.linalg
import tomllib
from cli_runs import runner
from requirements import optional_import

from steam_ref.bayes_tree import FixedLagSmoother, IncrementalSolver
from steam_ref.cli.commands import build_parser
from steam_ref.conformance import KIT_VERSION, KITS, SHIPPED, SUITES, spec
from steam_ref.conformance.cases import suite_cases
from steam_ref.conformance.cases.base import EXACT, LIE_CHECKS, Case, tol
from steam_ref.conformance.checker import compare_quantity
from steam_ref.conformance.kitio import dumps, kit_files, plain, read_index, read_suite
from steam_ref.conformance.oracle_graph import Problem, dense_system
from steam_ref.conformance.readme import SUITE_INPUTS, export_readme
from steam_ref.errors import DataError, SteamError
from steam_ref.variables import L, X

ROOT = Path(__file__).resolve().parents[1]


cli = runner("conformance")


@pytest.fixture(scope="module")
def ours(kit_results) -> dict:
    """steam_ref's results for the gp, factors and batch suites, from the shipped inputs (they pass)."""
    return {s: kit_results(SHIPPED, s) for s in ("gp", "factors", "linear", "batch", "bayes_tree")}


# --- the kit as shipped ---------------------------------------------------------------------------


def test_index_lists_every_file_with_its_sha256_the_conventions_and_the_provenance_of_every_case():
    index = read_index(SHIPPED)  # raises if a file's sha256 differs
    assert sorted(index["files"]) == kit_files(SHIPPED)
    assert index["kit_version"] == KIT_VERSION == 5 and set(index["suites"]) == set(SUITES)
    assert read_index(KITS[1])["kit_version"] == 1  # v1 stays shipped, verified
    assert read_index(KITS[2])["kit_version"] == 2 and "fixed_lag" not in read_index(KITS[2])["suites"]  # v2 too
    assert read_index(KITS[3])["kit_version"] == 3 and read_index(KITS[3])["suites"]["fixed_lag"]["cases"] == 4  # v3
    assert sum(s["cases"] for s in index["suites"].values()) >= 73 and index["suites"]["fixed_lag"]["cases"] >= 6
    assert "t < t_newest - lag" in index["conventions"]["fixed_lag"]
    for word in ("state", "units", "residual", "whitening", "cost", "robust", "angles", "floats", "tolerance"):
        assert index["conventions"][word], word
    assert "1/2 sum" in index["conventions"]["cost"] and "upper-triangular" in index["conventions"]["whitening"]
    for suite in SUITES:
        cases = read_suite(SHIPPED, suite)["cases"]
        listed = index["suites"][suite]
        assert sorted(listed["independent"] + listed["produced_by_steam_ref"]) == sorted(c["name"] for c in cases)
        for c in cases:
            assert isinstance(c["independent"], bool) and c["source"] and set(c["tolerance"]) <= set(c["expected"]), c[
                "name"
            ]
    assert sorted(index["suites"]["incremental"]["produced_by_steam_ref"]) == [
        "no_relinearization_tree_edits",
        "partial_relinearization_tree_edits",
        "relinearize_every_update_tree_edits",
    ]
    assert all(not s["produced_by_steam_ref"] for n, s in index["suites"].items() if n != "incremental")
    assert sum(p.stat().st_size for p in SHIPPED.rglob("*") if p.is_file()) < 5e6


def test_pyproject_ships_every_kit_file_as_package_data():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    patterns = config["tool"]["setuptools"]["package-data"]["steam_ref.conformance"]
    for name in kit_files(SHIPPED) + ["index.json"]:
        path = f"{SHIPPED.name}/{name}"
        assert any(fnmatch.fnmatch(path, p) and path.count("/") == p.count("/") for p in patterns), path


def test_kit_json_reads_back_every_double_exactly(rng):
    x = np.concatenate(
        [
            rng.normal(size=200) * 10.0 ** rng.integers(-300, 300, size=200),
            [0.1, 1 / 3, 5e-324, -0.0, 1.7976931348623157e308],
        ]
    )
    back = np.array(json.loads(dumps({"x": x}))["x"])
    assert np.array_equal(back.view(np.int64), x.view(np.int64))


def test_the_oracle_imports_nothing_of_steam_ref_but_its_errors():
    oracle = {"oracle", "oracle_graph", "oracle_lag", "oracle_lie", "oracle_rigid", "expected", "kitio", "differences"}
    for module in oracle:
        tree = ast.parse((SHIPPED.parent / f"{module}.py").read_text())
        imported = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.level}
        assert imported <= {"errors", None, *oracle}, (module, imported)


def test_every_case_of_every_shipped_kit_has_one_runner_and_one_oracle_by_its_type():
    """The kits v1-v4 are data: the one runner and the one oracle read every version's cases through one table
    each, keyed by case type (suite, and the kind its inputs name), and the two tables name the same types."""
    from steam_ref.conformance.expected import ORACLES
    from steam_ref.conformance.kitio import case_type
    from steam_ref.conformance.runner import RUNNERS

    assert set(RUNNERS) == set(ORACLES)
    seen = set()
    for version, kit in KITS.items():
        for suite in read_index(kit)["suites"]:
            for c in read_suite(kit, suite)["cases"] if suite != "paper" else ():
                kind = case_type(suite, c["inputs"])
                assert kind in RUNNERS and (kind in ORACLES or not c["independent"]), (version, suite, c["name"])
                seen.add(kind)
    assert seen == set(RUNNERS)  # no row for a type no kit has


def test_no_module_of_the_kit_is_named_after_a_group_or_a_kit_version_and_the_kits_hold_no_code():
    package = SHIPPED.parent
    modules = [p.relative_to(package).as_posix() for p in package.rglob("*.py")]
    for name in modules:
        stem = Path(name).stem
        assert not any(group in stem for group in ("se2", "se3", "so2", "so3", "pose2", "pose3")), name
        assert not re.search(r"(^|_)v\d+$", stem), name  # graphs_v2.py: a case belongs to its idea's module
    assert not [n for n in modules if n.split("/")[0] in {kit.name for kit in KITS.values()}]  # data, not modules


def test_no_case_can_change_the_tolerances_of_another():
    """Cases are built from shared tables (LIE_CHECKS, FACTOR_TOL, one tol() for many quantities): each case's
    tolerances are its own copy, read-only at both levels (quantity → tolerance, tolerance → atol and rtol)."""
    cases = [c for s in SUITES if s != "paper" for c in suite_cases(s)]
    for case in cases:
        with pytest.raises(TypeError):
            case.tolerance["added"] = EXACT
        for t in case.tolerance.values():
            if t != EXACT:
                with pytest.raises(TypeError):
                    t["rtol"] = 1.0
    priors = [c for c in suite_cases("se3") if c.inputs.get("kind") == "prior"]  # both from LIE_CHECKS["prior"]
    assert len(priors) >= 2 and priors[0].tolerance == priors[1].tolerance == LIE_CHECKS["prior"]
    with pytest.raises(TypeError):
        LIE_CHECKS["prior"]["H_0"]["rtol"] = 1.0
    table = {"x": tol(1e-9)}
    case = Case("c", "[YIB Eq. 1]", "d", {}, table, True)
    table["x"] = EXACT
    assert case.tolerance == {"x": {"atol": 0.0, "rtol": 1e-9}}


def _read_only_everywhere(value, path: str) -> None:
    """Every container in ``value`` (a case's inputs or notes) refuses a write; every leaf is immutable."""
    if isinstance(value, np.ndarray):
        assert not value.flags.writeable, path
        with pytest.raises(ValueError, match="read-only"):
            value[...] = 0
    elif isinstance(value, Mapping):
        with pytest.raises(TypeError):
            value["added"] = 0  # type: ignore[index]
        for k, v in value.items():
            _read_only_everywhere(v, f"{path}.{k}")
    elif isinstance(value, (list, tuple)):
        assert isinstance(value, tuple), f"{path} is a {type(value).__name__}"
        for i, v in enumerate(value):
            _read_only_everywhere(v, f"{path}[{i}]")
    else:
        assert value is None or isinstance(value, (str, int, float, np.generic)), path


def test_no_case_can_change_the_inputs_of_another():
    """Cases are built from shared numbers (QC_DIAG, X1, a problem's landmarks...): each case's inputs and notes
    are its own read-only deep copy (mappings read-only, lists tuples, arrays read-only copies), so neither a case
    nor the table it was built from can change another case's inputs; the kit stores them as the lists it did."""
    for suite in SUITES:
        for case in suite_cases(suite) if suite != "paper" else []:
            _read_only_everywhere(case.inputs, f"{suite}/{case.name}.inputs")
            _read_only_everywhere(case.notes, f"{suite}/{case.name}.notes")
    qc, x, why = [[0.5, 0.0], [0.0, 0.2]], np.array([1.0, 2.0]), ["a note"]
    a = Case("a", "[YIB Eq. 1]", "d", {"qc": qc, "x": x}, {}, True, notes={"why": why})
    b = Case("b", "[YIB Eq. 1]", "d", {"qc": qc, "x": x}, {}, True, notes={"why": why})
    qc[0][0], x[0], why[0] = 9.0, 9.0, "changed"
    for case in (a, b):
        assert plain(case.inputs) == {"qc": [[0.5, 0.0], [0.0, 0.2]], "x": [1.0, 2.0]}
        assert plain(case.notes) == {"why": ["a note"]}
    assert a.inputs["x"] is not b.inputs["x"]
    with pytest.raises(DataError, match="set"):
        Case("c", "[YIB Eq. 1]", "d", {"kinds": {"prior"}}, {}, True)  # nothing the kit cannot store


def _factor_specs(value) -> set[str]:
    """The ``type`` of every factor spec in a case's inputs (a mapping with a type and keys, or an inner reading)."""
    if isinstance(value, dict):
        own = {value["type"]} if "type" in value and ("keys" in value or "inner" in value) else set()
        return own.union(*(_factor_specs(v) for v in value.values()))
    return set().union(*(_factor_specs(v) for v in value)) if isinstance(value, list) else set()


def test_the_readme_names_every_kind_input_and_factor_spec_of_every_shipped_case():
    """Each suite's inputs and the factor specs are written once, in the exported README's sections Inputs and
    Factors (readme.py: SUITE_INPUTS, FACTOR_TABLE), which docs/conformance.md points to: every ``kind``, every
    input and every factor spec of every case the current kit ships is named there, the se2 and se3 suites' too."""
    readme = export_readme()
    inputs = readme[readme.index("\n## Inputs\n") : readme.index("\n## Factors\n")]
    factors = readme[readme.index("\n## Factors\n") : readme.index("\n## Outputs\n")]
    by_suite = {suite: text for key, text in SUITE_INPUTS.items() for suite in key.split(", ")}
    assert list(by_suite) == list(SUITES) and all(f"**: {text}\n" in inputs for text in SUITE_INPUTS.values())
    absent = []
    for suite in SUITES:
        named = by_suite[suite]
        for case in read_suite(SHIPPED, suite)["cases"]:
            given, kind = case["inputs"], case["inputs"].get("kind")
            if kind is not None and f"'{kind}'" not in named:
                absent.append(f"{suite} kind {kind}")
            absent += [f"{suite} input {k}" for k in given if not re.search(rf"(?<![\w']){k}(?![\w'])", named)]
            absent += [
                f"{suite} spec {t}" for t in _factor_specs(given) if f"| `{t}` |" not in factors and t not in named
            ]
    assert not absent, sorted(set(absent))


@pytest.mark.parametrize("version", sorted(KITS))
def test_the_readmes_interpolation_and_prediction_as_written_give_every_wnoa_case_of_the_gp_suite(version):
    """The README said "[YIB Eq. 16, 18]" for Lambda, Psi, x_tau, cov_tau and the prediction and wrote none of them
    out, though it says a port needs nothing outside the kit (an outsider porting the interpolation had to open the
    paper, and guess from which end tau is measured and what cov_tau adds). Its section 'Interpolation and
    prediction' writes them out; computed here as written, they give the kit's independent expected values (the
    dense kernel's conditioning, not Eq. 16) within each tolerance."""
    readme = export_readme()
    section = readme[readme.index("\n## Interpolation and prediction\n") : readme.index("\n## Outputs\n")]
    for line in (
        "Psi(tau)    = Q(tau - t1) Phi(t2 - tau)^T Q(t2 - t1)^-1",
        "Lambda(tau) = Phi(tau - t1) - Psi(tau) Phi(t2 - t1)",
        "x_tau       = Lambda(tau) x1 + Psi(tau) x2",
        "cov_tau = [Lambda Psi] P [Lambda Psi]^T + Q(tau - t1) - Psi(tau) Phi(t2 - tau) Q(tau - t1)",
        "x_t = Phi(t - t1) x1, cov_t = Phi(t - t1) cov1 Phi(t - t1)^T + Q(t - t1)",
    ):
        assert line in section, line

    def phi(s):
        return np.block([[np.eye(3), s * np.eye(3)], [np.zeros((3, 3)), np.eye(3)]])

    def q(s, qc):
        return np.kron(np.array([[s**3 / 3, s**2 / 2], [s**2 / 2, s]]), np.asarray(qc, float))

    checked = []
    for case in read_suite(KITS[version], "gp")["cases"]:
        i = case["inputs"]
        if i["kind"] in ("interpolation", "interpolation_covariance"):
            t1, t2, tau, qc = i["t1"], i["t2"], i["tau"], i["qc"]
            psi = q(tau - t1, qc) @ phi(t2 - tau).T @ np.linalg.inv(q(t2 - t1, qc))
            lam = phi(tau - t1) - psi @ phi(t2 - t1)
            if i["kind"] == "interpolation":
                got = {"Lambda": lam, "Psi": psi, "x_tau": lam @ i["x1"] + psi @ i["x2"]}
            else:
                both = np.hstack([lam, psi])
                cond = q(tau - t1, qc) - psi @ phi(t2 - tau) @ q(tau - t1, qc)
                got = {"cov_tau": both @ np.asarray(i["joint_cov"]) @ both.T + cond}
        elif i["kind"] == "extrapolation":
            f = phi(i["t"] - i["t1"])
            got = {"x_t": f @ i["x1"], "cov_t": f @ np.asarray(i["cov1"]) @ f.T + q(i["t"] - i["t1"], i["qc"])}
        else:
            continue
        for name, value in got.items():
            assert not compare_quantity(case["expected"][name], value.tolist(), case["tolerance"][name], name), (
                case["name"],
                name,
            )
            checked.append(f"{case['name']}/{name}")
    assert len(checked) == 3 * 3 + 2 + 2, checked


def _as_python(formula: str) -> str:
    """A README formula as Python: ``s^3`` is ``s**3``, ``s^5 S_pp`` and ``2 x E`` products."""
    return re.sub(r"(?<=[\w)]) (?=[\w(])", "*", formula.replace("^", "**"))


def _readme_motion_priors() -> tuple[str, dict[str, dict[str, tuple[str, str]]], dict[str, str]]:
    """The README's section 'Motion priors' and its matrices as written: for each model, each
    ``NAME = [[...]] (x) RIGHT`` (NAME Phi(s), Q(s), Q(s)^-1 or A) as (Python expression, RIGHT), and Singer's S_kl
    lines the same way, read as Python with ``^`` as ``**`` and a product written ``a b`` as ``a*b``. Nothing here
    comes from steam_ref's gp/ code."""
    readme = export_readme()
    section = readme[readme.index("\n## Motion priors\n") : readme.index("\n## Interpolation and prediction\n")]
    models: dict[str, dict[str, tuple[str, str]]] = {}
    for chunk in re.split(r"\n(?=\*\*)", section)[1:]:  # one paragraph group per model, from its bold name
        found = re.findall(r"(Phi\(s\)|Q\(s\)\^-1|Q\(s\)|A) *= (\[\[[^=]*?\]\]) \(x\)\s*(I|Qc\^-1|Qc)\b", chunk)
        models[chunk[2 : chunk.index("**", 2)]] = {name: (_as_python(m), right) for name, m, right in found}
    singer_s = {
        name: _as_python(expr)
        for line in section.splitlines()
        if line.startswith("    S_")
        for name, expr in (part.split(" = ") for part in re.split(r" {3,}", line.strip()))
    }
    return section, models, singer_s


@pytest.mark.parametrize("version", sorted(KITS))
def test_the_readmes_motion_priors_as_written_give_every_wnoa_wnoj_singer_and_lti_case_of_the_gp_suite(version):
    """The README wrote out the WNOA prior's Phi and Q only (conventions, gp_prior) and cited [YIB Eq. 14, 16-17, 23]
    for the rest, though it says a port needs nothing outside the kit: the gp suite's WNOA Q^-1 and W, WNOJ's Phi,
    Q, Q^-1, Singer's Phi and Q (and what its alpha is: a rate, not a time constant), a general LTI SDE's Q and v_i,
    and Singer's interpolation had no formula a port could compute them from, nor the block order of the state.
    Its section 'Motion priors' writes them out; read here as written (each matrix evaluated from the README's own
    text, W, Van Loan and the series transcribed), they give every such case's expected values, the dense oracle's
    expm and quadrature (not these closed forms), within each tolerance, in every kit; and each Phi is expm(A s) of
    the A the README writes."""
    section, models, singer_s = _readme_motion_priors()
    assert set(models) == {"WNOA", "WNOJ", "Singer", "General LTI"}, models
    for name in ("WNOA", "WNOJ"):
        assert set(models[name]) >= {"Phi(s)", "Q(s)", "Q(s)^-1"}, (name, models[name])
    assert set(models["Singer"]) >= {"Phi(s)", "Q(s)", "A"} and set(models["WNOJ"]) >= {"A"}, models
    assert set(singer_s) == {"S_pp", "S_pv", "S_pa", "S_vv", "S_va", "S_aa"}, singer_s
    for line in (
        "expm([[-A, F Qc F^T], [0, A^T]] s) = [[E11, E12], [0, E22]],   Q(s) = E22^T E12",
        "expm([[A, v], [0, 0]] s) = [[Phi(s), v_i], [0, 1]]",
        "the transpose\nof the lower Cholesky factor L of Q(s)^-1 = L L^T (equivalently U^-1 for Q(s) = U U^T with U upper",
        "S_kl(z) = sum_n (-z)^n / (k + l + n + 1) sum_(i=0..n) 1 / ((i + k)! (n - i + l)!), with k, l = 2, 1, 0",
    ):
        assert line in section, line

    def matrix(model: str, name: str, s: float, qc, alpha: float = 0.0) -> np.ndarray:
        env: dict[str, float] = {"s": s, "alpha": alpha, "z": alpha * s, "E": np.exp(-alpha * s)}
        if model == "Singer":
            env |= {n: eval(e, {"__builtins__": {}}, env) for n, e in singer_s.items()}
        expr, right = models[model][name]
        qc = np.asarray(qc, float)
        factor = {"I": np.eye(3), "Qc": qc, "Qc^-1": np.linalg.inv(qc)}[right]
        return np.kron(np.array(eval(expr, {"__builtins__": {}}, env), float), factor)

    def singer_q_by_series(alpha: float, s: float, qc) -> np.ndarray:
        """Q(s) of Singer's model by the README's series for S_kl (24 terms), k, l = 2, 1, 0 for p, v, a."""
        z, order = alpha * s, (2, 1, 0)
        S = [
            [
                sum(
                    (-z) ** n
                    / (k + l + n + 1)
                    * sum(1 / (math.factorial(i + k) * math.factorial(n - i + l)) for i in range(n + 1))
                    for n in range(24)
                )
                * s ** (k + l + 1)
                for l in order
            ]
            for k in order
        ]
        return np.kron(np.array(S), np.asarray(qc, float))

    checked = []
    for case in read_suite(KITS[version], "gp")["cases"]:
        i = case["inputs"]
        kind = i["kind"]
        if kind == "wnoa":
            qinv = matrix("WNOA", "Q(s)^-1", i["dt"], i["qc"])
            w = np.linalg.cholesky(qinv).T
            q = matrix("WNOA", "Q(s)", i["dt"], i["qc"])
            u = np.linalg.cholesky(q[::-1, ::-1])[::-1, ::-1]  # Q = U U^T, U upper
            np.testing.assert_allclose(np.linalg.inv(u), w, rtol=1e-9, atol=1e-9 * abs(w).max())
            got = {"Phi": matrix("WNOA", "Phi(s)", i["dt"], i["qc"]), "Q": q, "Qinv": qinv, "W": w}
        elif kind == "wnoj":
            got = {
                n: matrix("WNOJ", f, i["dt"], i["qc"])
                for n, f in (("Phi", "Phi(s)"), ("Q", "Q(s)"), ("Qinv", "Q(s)^-1"))
            }
        elif kind == "singer":
            got = {n: matrix("Singer", f, i["dt"], i["qc"], i["alpha"]) for n, f in (("Phi", "Phi(s)"), ("Q", "Q(s)"))}
            if i["alpha"] * i["dt"] <= 1:  # where the README says to sum the series
                by_series = singer_q_by_series(i["alpha"], i["dt"], i["qc"]).tolist()
                assert not compare_quantity(case["expected"]["Q"], by_series, case["tolerance"]["Q"], "Q"), case
                checked.append(f"{case['name']}/Q by the series")
        elif kind == "lti":
            A, F, qc, v, dt = (np.asarray(i[k], float) for k in ("A", "F", "qc", "v", "dt"))
            n = len(A)
            e = scipy.linalg.expm(np.block([[-A, F @ qc @ F.T], [np.zeros((n, n)), A.T]]) * dt)
            aug = scipy.linalg.expm(np.block([[A, v[:, None]], [np.zeros((1, n + 1))]]) * dt)
            got = {"Phi": scipy.linalg.expm(A * dt), "Q": e[n:, n:].T @ e[:n, n:], "v_i": aug[:n, n]}
            np.testing.assert_allclose(aug[:n, :n], got["Phi"], rtol=1e-14)
        elif kind == "singer_interpolation":
            t1, t2, tau = i["t1"], i["t2"], i["tau"]
            phi_, q_ = (
                {s: matrix("Singer", f, s, i["qc"], i["alpha"]) for s in (tau - t1, t2 - tau, t2 - t1)}
                for f in ("Phi(s)", "Q(s)")
            )
            psi = q_[tau - t1] @ phi_[t2 - tau].T @ np.linalg.inv(q_[t2 - t1])
            lam = phi_[tau - t1] - psi @ phi_[t2 - t1]
            got = {"Lambda": lam, "Psi": psi, "x_tau": lam @ i["x1"] + psi @ i["x2"]}
        else:
            continue
        if kind in ("wnoj", "singer"):  # Phi(s) as written is expm(A s) of the A the README writes
            a = matrix(kind.upper() if kind == "wnoj" else "Singer", "A", 1.0, i["qc"], i.get("alpha", 0.0))
            np.testing.assert_allclose(got["Phi"], scipy.linalg.expm(a * i["dt"]), rtol=1e-13, atol=1e-15)
        for name, value in got.items():
            assert not compare_quantity(case["expected"][name], value.tolist(), case["tolerance"][name], name), (
                case["name"],
                name,
            )
            checked.append(f"{case['name']}/{name}")
    assert len(checked) == 4 * 4 + 3 + 2 * 2 + 1 + 2 * 3 + 3, checked


def test_the_readme_says_where_each_numbered_quantity_counts_from_as_the_kit_numbers_them():
    """A port names its quantities as the kit does, and the kit counts two ways: H_k, A_k from 0 over a factor's
    keys (H_0 the first key), estimate_k and every per-update quantity from 1 over the updates (J_1, J_2 are of
    x1, x2). The README's Outputs said 'for each key k in order' and 'after update k', the base of neither, so a
    port writing H_1, H_2 read its first block as missing. The numbering is read here off the shipped cases."""
    readme = export_readme()
    outputs = readme[readme.index("\n## Outputs\n") : readme.index("\n## The ordering rule")]
    keyed, updated = set(), set()
    for suite in SUITES:
        for case in read_suite(SHIPPED, suite)["cases"]:
            factor = case["inputs"].get("factor")
            if factor is not None:
                keyed.add(
                    sorted(int(q[2:]) for q in case["tolerance"] if q.startswith("H_")) == [*range(len(factor["keys"]))]
                )
            updates = case["inputs"].get("stream", {}).get("updates")
            if updates is not None:
                counted = {int(m[1]) for q in case["tolerance"] if (m := re.fullmatch(r"[a-z_]+_(\d+)", q))}
                updated.add(counted == set(range(1, len(updates) + 1)))
    assert keyed == {True} and updated == {True}, (keyed, updated)
    assert "H_0 the first key" in outputs and "A_k the same k" in outputs, outputs
    assert "k counts the updates from 1 (estimate_1 after the first)" in outputs, outputs
    assert "Ad_a = Ad(T_a)" in outputs, outputs


def test_the_docs_show_the_kits_readme_and_point_to_its_inputs_factors_and_groups(tmp_path, monkeypatch):
    """The docs build renders the exported README as the page kit/readme (docs/_ext/pages.py), the text
    ``export`` writes, and docs/conformance.md points to its sections rather than repeating them."""
    optional_import("sphinx", "docs", kind="docs")
    monkeypatch.syspath_prepend(str(ROOT / "docs" / "_ext"))
    import pages

    pages.write_kit_readme(tmp_path)
    assert (tmp_path / "readme.md").read_text() == export_readme()
    docs = (ROOT / "docs" / "conformance.md").read_text()
    for section in ("inputs", "factors", "outputs", "se-2", "se-3", "motion-priors", "interpolation-and-prediction"):
        assert f"(kit/readme.md#{section})" in docs, section
    assert "kit/readme\n```" in docs  # in the page's toctree
    assert "| `gp_prior` |" not in docs  # the factor table lives in the README alone


# --- selftest, export, check ----------------------------------------------------------------------


def _data_dir_helps(parser: argparse.ArgumentParser, command: str = "") -> dict[str, str]:
    """The help of --data-dir in every command (and subcommand) of ``parser`` that has one, by command."""
    helps = {}
    for action in parser._actions:
        if "--data-dir" in action.option_strings:
            helps[command] = str(action.help)
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                helps |= _data_dir_helps(sub, f"{command} {name}".strip())
    return helps


def test_the_conformance_commands_data_dir_help_names_the_whole_search_path_as_every_command_does():
    """selftest and build read the paper suite's files from the data search path (find_named): their --data-dir
    help names all of it in its order, in the words every other command's help uses."""
    helps = _data_dir_helps(build_parser())
    assert {"conformance selftest", "conformance build", "run", "fidelity"} <= set(helps)
    tails = set()
    for command, text in helps.items():
        places = [text.find(p) for p in ("before", "$STEAM_REF_DATA_DIR", "fetched files' cache", "gtsam's Data/")]
        assert -1 not in places and places == sorted(places), (command, text)
        tails.add(text[places[0] :])
    assert len(tails) == 1, tails


def test_selftest_passes_on_the_installed_code(capsys):
    code, out, _ = cli(capsys, "selftest")
    last = out.strip().splitlines()[-1]
    assert code == 0 and last.endswith(" passed, 0 failed") and int(last.split()[0]) >= 63, out
    assert "paper suite not run (synthetic_btgp1, plaza_btgp1" in out  # not by default, and it says so


def test_export_writes_the_kit_and_a_readme_and_refuses_a_non_empty_folder(tmp_path, capsys):
    code, _, _ = cli(capsys, "export", tmp_path / "kit")
    readme = (tmp_path / "kit" / "README.md").read_text()
    assert code == 0 and '"kit_version": 5' in readme and "--allow-missing" in readme and "--paper" in readme
    assert "**fixed_lag**" in readme and "t < t_newest - lag" in readme and "marginal_information_k" in readme
    # self-contained: every factor type with its error, the details an outside port got wrong, the ordering rule
    for factor in ("gp_prior", "prior", "odometry", "velocity", "range", "bearing", "bearing_range", "interpolated"):
        assert f"| `{factor}` |" in readme, factor
    assert "v_lat" in readme and "-sin(th) x_dot + cos(th) y_dot - v_lat" in readme  # the lateral row
    assert "a constant input v" in readme and "times (key -> time stamp" in readme
    assert "without the robust weight" in readme and "**paper-sign**" in readme
    assert "Order: x0, l1, l0, x1, x2." in readme and "ties go to the variable earlier in the list" in readme
    assert "**range_attachment**" in readme and "Outputs: the final [x, y, theta]" in readme.replace("\n", " ")
    for name in kit_files(SHIPPED) + ["index.json"]:
        assert (tmp_path / "kit" / name).read_bytes() == (SHIPPED / name).read_bytes(), name
    code, out, err = cli(capsys, "export", tmp_path / "kit")
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1 and "empty" in err


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (("check", "{tmp}/nowhere"), "does not exist"),
        (("check", "{tmp}"), "no results"),
        (("check", "{tmp}", "--suite", "gp"), "no results in"),
        (("check", "{tmp}", "--only", "gp", "nope"), "invalid choice"),
        (("check", "{tmp}", "--conventions", "upside-down"), "invalid choice"),
        (("check", "{tmp}", "--suite", "nope"), "invalid choice"),
        (("check", "{bad}"), "not readable as JSON"),
        (("check", "{tmp}", "--kit", "{tmp}/nowhere"), "index.json"),
        ((), "required"),
    ],
)
def test_check_answers_bad_input_with_one_line_and_exit_2(tmp_path, capsys, args, words):
    bad = tmp_path / "bad"
    (bad / "gp").mkdir(parents=True)
    (bad / "gp" / "results.json").write_text("{not json")
    (tmp_path / "empty").mkdir()
    code, _out, err = cli(capsys, *(a.format(tmp=tmp_path / "empty", bad=bad) for a in args))
    assert code == 2 and len(err.strip().splitlines()) == 1 and words in err and "Traceback" not in err, err


def test_check_is_a_gate_missing_cases_fail_unless_only_or_allow_missing_says_so(tmp_path, capsys, ours, write_results):
    write_results(tmp_path, "gp", {k: v for k, v in ours["gp"].items() if k.startswith("wnoa")})
    code, out, _ = cli(capsys, "check", tmp_path)
    lines = out.strip().splitlines()
    assert code == 1 and lines[-1].startswith("4 passed, 0 failed, ") and "MISSING: 12 cases of gp" in out, out
    assert "MISSING: 22 cases of factors have no result: " in out  # absent suites too
    assert "paper have no result" not in out and "add --paper" in out  # the paper suite only when asked
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "gp")
    assert code == 1 and "MISSING: 12 cases of gp" in out and "not checked (--only): factors" in out
    code, out, _ = cli(capsys, "check", tmp_path, "--allow-missing")
    assert code == 0 and "skipped (allowed): 12 cases of gp have no result: lti_dt0.3" in out, out
    write_results(tmp_path, "gp", ours["gp"])
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "gp")
    assert code == 0 and out.strip().splitlines()[-1] == "16 passed, 0 failed", out
    write_results(tmp_path, "gp", {})  # {"cases": {}} is not a pass
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "gp")
    assert code == 1 and out.strip().splitlines()[-1] == "0 passed, 0 failed, 16 missing", out


# --- deliberate faults must fail, naming the case -------------------------------------------------


def failing_cases(write_results, tmp_path, capsys, suite: str, results: dict) -> dict[str, str]:
    write_results(tmp_path, suite, results)
    code, out, _ = cli(capsys, "check", tmp_path, "--suite", suite)
    lines = out.strip().splitlines()
    failed = {line.split()[1].rstrip(":"): line for line in lines if line.startswith("FAIL ")}
    assert lines[-1] == f"{len(results) - len(failed)} passed, {len(failed)} failed"
    assert code == (1 if failed else 0)
    return failed


def test_q_with_dt_squared_instead_of_dt_cubed_fails_every_wnoa_case(tmp_path, capsys, ours, write_results):
    bad = copy.deepcopy(ours["gp"])
    cases = {c["name"]: c["inputs"] for c in read_suite(SHIPPED, "gp")["cases"]}
    for name, inputs in cases.items():
        if inputs["kind"] == "wnoa":
            dt, qc = inputs["dt"], np.array(inputs["qc"])
            bad[name]["Q"] = np.block([[dt**2 / 3 * qc, dt**2 / 2 * qc], [dt**2 / 2 * qc, dt * qc]]).tolist()
    failed = failing_cases(write_results, tmp_path, capsys, "gp", bad)
    assert set(failed) == {f"gp/{n}" for n, i in cases.items() if i["kind"] == "wnoa"}
    assert all(": Q worst |diff|" in line for line in failed.values()), failed


def test_lambda_and_psi_swapped_fails_every_interpolation_case(tmp_path, capsys, ours, write_results):
    bad = copy.deepcopy(ours["gp"])
    cases = {c["name"]: c["inputs"] for c in read_suite(SHIPPED, "gp")["cases"]}
    swapped = [n for n, i in cases.items() if i["kind"] in ("interpolation", "singer_interpolation")]
    for name in swapped:
        lam, psi = np.array(bad[name]["Lambda"]), np.array(bad[name]["Psi"])
        x1, x2 = np.array(cases[name]["x1"]), np.array(cases[name]["x2"])
        bad[name].update(Lambda=psi.tolist(), Psi=lam.tolist(), x_tau=(psi @ x1 + lam @ x2).tolist())
    failed = failing_cases(write_results, tmp_path, capsys, "gp", bad)
    assert set(failed) == {f"gp/{n}" for n in swapped} and len(swapped) == 4


def test_a_flipped_jacobian_sign_fails_the_factor(tmp_path, capsys, ours, write_results):
    bad = copy.deepcopy(ours["factors"])
    for name in ("range", "velocity", "gp_prior_diag_qc"):
        bad[name]["H_0"] = (-np.array(bad[name]["H_0"])).tolist()
    failed = failing_cases(write_results, tmp_path, capsys, "factors", bad)
    assert set(failed) == {"factors/range", "factors/velocity", "factors/gp_prior_diag_qc"}
    assert all(": H_0 worst |diff|" in line for line in failed.values()), failed


def test_the_cost_without_its_half_fails_every_factor_and_batch_case(tmp_path, capsys, ours, write_results):
    bad = copy.deepcopy(ours["factors"])
    for name in bad:
        bad[name]["cost"] = float(np.sum(np.square(bad[name]["whitened_error"])))  # ‖We‖² instead of ½‖We‖² (or ρ)
    failed = failing_cases(write_results, tmp_path, capsys, "factors", bad)
    assert set(failed) == {f"factors/{n}" for n in bad} and all(": cost worst" in line for line in failed.values()), (
        failed
    )
    batch = copy.deepcopy(ours["batch"])
    for result in batch.values():
        result["costs"] = (2 * np.array(result["costs"])).tolist()
    failed = failing_cases(write_results, tmp_path, capsys, "batch", batch)
    assert set(failed) == {
        f"batch/{n}" for n in batch if np.any(batch[n]["costs"])
    }  # twice 0 is 0 (at_optimum) and all(": costs worst" in line for line in failed.values())


def test_compare_is_normwise_and_exact_quantities_ignore_the_order_of_cliques():
    tol = {"atol": 1e-3, "rtol": 1e-2}  # allowed: 1e-3 + 1e-2 · 10 = 0.101
    assert compare_quantity([10.0, 1.0], [10.0, 1.1], tol, "q") == []
    (fail,) = compare_quantity([10.0, 1.0], [10.0, 1.102], tol, "q")
    assert "q worst |diff| 0.102 at [1]" in fail[1] and fail[2] == ("q[1]: expected 1.0, got 1.102 (|diff| 0.102)",)
    a = [
        {"frontals": ["x1", "x2"], "separator": [], "parent": None},
        {"frontals": ["x0"], "separator": ["x1"], "parent": "x1"},
    ]
    assert compare_quantity(a, a[::-1], "exact", "cliques") == []
    swapped = [dict(a[0], frontals=["x2", "x1"]), a[1]]
    assert compare_quantity(a, swapped, "exact", "cliques")  # frontal order is elimination order


def test_only_and_conventions_given_twice_keep_both_lists(tmp_path, capsys, write_results, kit_results):
    """``--only gp --only factors`` checks both suites (the second list replaced the first in silence: gp went
    unchecked), and ``--conventions A --conventions B`` compares under both, as ``--conventions A B`` does."""
    from steam_ref.conformance.checker import case_alternative

    write_results(tmp_path, "gp", kit_results(SHIPPED, "gp"))
    code, out, _ = cli(capsys, "check", tmp_path, "--only", "gp", "--only", "factors", "--allow-missing")
    n_gp, n_factors = (len(read_suite(SHIPPED, s)["cases"]) for s in ("gp", "factors"))
    assert code == 0 and out.splitlines()[-1] == f"{n_gp} passed, 0 failed, {n_factors} missing", out
    both = ["paper-sign", "symmetric-whitener"]
    port = {}  # a port under both alternatives: the kit's expected values for them
    for case in read_suite(SHIPPED, "factors")["cases"]:
        alternative = case_alternative(case, both)
        port[case["name"]] = {q: alternative.get(q, case["expected"][q]) for q in case["tolerance"]}
    write_results(tmp_path / "port", "factors", port)
    one = cli(capsys, "check", tmp_path / "port", "--only", "factors", "--conventions", "symmetric-whitener")
    assert one[0] == 1  # under one of the two it fails: the check below means something
    code, out, _ = cli(
        capsys, "check", tmp_path / "port", "--only", "factors", "--conventions", both[0], "--conventions", both[1]
    )
    assert code == 0 and out.splitlines()[-1] == f"{n_factors} passed, 0 failed", out


# --- GTSAM and the authors ------------------------------------------------------------------------


def test_gtsam_passes_every_case_it_computes(tmp_path, capsys):
    optional_import("gtsam", "gtsam")  # skips here, fails in CI (STEAM_REF_REQUIRE_OPTIONAL=1)
    run = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "conformance_gtsam.py"), str(tmp_path), "--kit", str(SHIPPED)],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=ROOT,
    )
    assert run.returncode == 0, run.stderr
    code, out, _ = cli(capsys, "check", tmp_path, "--allow-missing", "--conventions", "signed-half-turn")
    last = out.strip().splitlines()[-1]
    assert code == 0 and " passed, 0 failed" in last and int(last.split()[0]) >= 50, out
    computed = {s: set(json.loads((tmp_path / s / "results.json").read_text())["cases"]) for s in GTSAM_SUITES}
    assert {
        "trajectory_xl_cliques",
        "trajectory_interleaved_conditionals",
        "beacons_states_first_covariances",
    } <= computed["bayes_tree"]
    assert computed["incremental"] == {
        "relinearize_every_update_estimates",
        "no_relinearization_estimates",
        "partial_relinearization_estimates",
        "partial_relinearization_skip2_estimates",
        "relinearize_on_the_tie",  # kit v5: GTSAM relinearizes at max|delta| >= beta too
    }
    assert {"bushy_cliques", "bushy_conditionals", "bushy_joint_covariances"} <= computed["bayes_tree"]
    assert {"gp_prior_heading_jump", "range_huber_at_threshold", "range_tukey_at_threshold"} <= computed["factors"]
    assert {"at_optimum_zero_increment", "gp_heading_jump"} <= computed["linear"]
    # GTSAM's IncrementalFixedLagSmoother, an implementation independent of the oracle, passes the fixed_lag cases
    # without relinearization (it holds a marginal factor's variables at their linearization point: the others differ)
    # ... and with it the case of a timestamp exactly at t_newest - lag: GTSAM's rule is strictly less too
    assert computed["fixed_lag"] == {"linear_two_at_once", "mid_clique_no_relinearization", "timestamp_at_the_boundary"}
    assert "range_at_landmark" in computed["factors"]
    assert {"wnoa_dt0.1", "interp_tau1.1", "interp_tau1.55"} <= computed["gp"] and "interpolated_range" in computed[
        "factors"
    ]
    # kit v4's se2 suite: gtsam.Pose2 passes Exp/Log at the half turn, J_r and J_r^-1 away from 0, between and its
    # Jacobians, the state prior, and WnoaMotionFactorPose2's residual and cost; its pose Jacobians (a truncated
    # series) and its closed forms near phi = 0 are left out
    assert computed["se2"] == {
        "exp_near_half_turn",
        "log_near_half_turn",
        "right_jacobian_large",
        "between_across_half_turn",
        "state_prior_across_pi",
        "prior_local_variable_residual_diagonal_qc",
    }


GTSAM_SUITES = ("gp", "factors", "linear", "batch", "bayes_tree", "incremental", "fixed_lag", "se2")


@pytest.mark.needs_data
def test_the_paper_suite_holds_the_authors_saved_runs(shared_data):
    for case in read_suite(SHIPPED, "paper")["cases"]:
        saved = scipy.io.loadmat(shared_data / case["inputs"]["authors_file"])
        rows = np.searchsorted(saved["estStateInds"].ravel(), case["inputs"]["state_poses"])
        np.testing.assert_array_equal(saved["estStateInds"].ravel()[rows], case["inputs"]["state_poses"])
        np.testing.assert_array_equal(np.array(case["expected"]["poses"]), saved["XYT"][rows])
        np.testing.assert_array_equal(np.array(case["expected"]["velocities"]), saved["XYT_dot"][rows])
        rmse = np.sqrt(
            np.mean(np.sum(saved["diff"] ** 2, axis=1))
        )  # 'diff' is ground truth minus estimate at the states
        assert case["expected"]["rmse_m"] == pytest.approx(rmse, rel=1e-12)
        assert case["independent"] and "authors" in case["source"]


def test_the_paper_suites_set_up_is_written_as_the_kit_states_it():
    """The builder writes the set-up flat, field for field as SETUP_FIELDS documents it, and equal to the
    shipped kit's inputs: the schedule's fields are the set-up's schedule (``PaperSetup.schedule``),
    not fields of their own."""
    from steam_ref.conformance.kitio import plain
    from steam_ref.conformance.paper import setup_inputs
    from steam_ref.conformance.paper_spec import SETUP_FIELDS
    from steam_ref.paper.presets import PaperSetup

    shipped = json.loads((KITS[2] / "paper" / "cases.json").read_text())["cases"]
    assert len(shipped) == 2
    for case in shipped:
        written = plain(setup_inputs(PaperSetup.named(case["inputs"]["setup"]["name"])))
        assert list(written) == list(SETUP_FIELDS)
        assert json.loads(json.dumps(written)) == case["inputs"]["setup"]
    with pytest.raises(SteamError, match="couples the seeding batch solve"):
        setup_inputs(PaperSetup.plaza().with_schedule(initial_batch=False))


# --- the fixed_lag suite (kit v3) -----------------------------------------------------------------


def test_the_linear_fixed_lag_case_is_the_dense_batch_posterior_over_every_factor_ever_given():
    """The kit's expected window marginals, and its marginal factors, from the batch posterior over all factors.

    No Schur complement here: the batch over every factor given so far (none forgotten) has mean μ and
    covariance P; over the window w its information is P_ww⁻¹, so the marginal factor must be P_ww⁻¹ less
    the information of the factors wholly in the window, and η = P_ww⁻¹ (μ_w − θ̄_w) less theirs.
    """
    case = next(c for c in read_suite(SHIPPED, "fixed_lag")["cases"] if c["name"] == "linear_two_at_once")
    stream, expected = case["inputs"]["stream"], case["expected"]
    assert case["inputs"]["isam2"]["relinearize_threshold"] == "inf"  # θ̄ = the values first given
    factors, theta, checked = [], {}, 0
    for k, u in enumerate(stream["updates"], start=1):
        factors += u["factors"]
        theta.update({n: np.array(v) for n, v in u["values"].items()})
        order = [n for n in stream["variables"] if n in theta]
        A, b, _ = dense_system(Problem({"variables": stream["variables"], "factors": factors}), theta, order)
        P = np.linalg.inv(A.T @ A)
        mean = np.concatenate([theta[n] for n in order]) + P @ (A.T @ b)
        window = list(expected[f"estimate_{k}"])
        assert window == [n for n in order if not any(n in expected[f"marginalized_{j}"] for j in range(1, k + 1))]
        cols = {n: 6 * order.index(n) + np.arange(6) for n in order}
        w = np.concatenate([cols[n] for n in window])
        for n in window:
            np.testing.assert_allclose(expected[f"estimate_{k}"][n], mean[cols[n]], rtol=0, atol=1e-10)
            np.testing.assert_allclose(
                expected[f"covariances_{k}"][n], P[np.ix_(cols[n], cols[n])], rtol=1e-9, atol=1e-14
            )
        if f"separator_{k}" in expected:
            info = np.linalg.inv(P[np.ix_(w, w)])
            eta = info @ (mean[w] - np.concatenate([theta[n] for n in window]))
            inside = [f for f in factors if set(f["keys"]) <= set(window)]
            A_in, b_in, _ = dense_system(Problem({"variables": stream["variables"], "factors": inside}), theta, window)
            sep = [6 * window.index(n) + np.arange(6) for n in expected[f"separator_{k}"]]
            s = np.concatenate(sep)
            rest = np.setdiff1d(np.arange(len(w)), s)
            left, left_eta = info - A_in.T @ A_in, eta - A_in.T @ b_in
            scale = np.abs(info).max()
            np.testing.assert_allclose(
                left[np.ix_(s, s)], expected[f"marginal_information_{k}"], rtol=0, atol=1e-9 * scale
            )
            np.testing.assert_allclose(left_eta[s], expected[f"marginal_vector_{k}"], rtol=0, atol=1e-9 * scale)
            assert np.abs(left[rest]).max() <= 1e-9 * scale and np.abs(left_eta[rest]).max() <= 1e-9 * scale
            checked += 1
    assert checked == 2  # after update 4 (x0) and update 5 (x1 and x2 together)


def test_the_mid_clique_cases_marginalize_variables_that_are_not_leaves_of_steam_refs_tree():
    """The cases say what they exercise: after update 2, x0 is a frontal of the root beside l0 and x1 (what
    GTSAM's marginalizeLeaves refuses), so steam_ref re-eliminates (marginalize step 3) rather than cutting a leaf;
    and so at every later step."""
    case = next(c for c in read_suite(SHIPPED, "fixed_lag")["cases"] if c["name"] == "mid_clique_no_relinearization")
    params = dict(relinearize_threshold=np.inf, relinearize_skip=1, wildfire_threshold=0.0)
    updates = case["inputs"]["stream"]["updates"]

    def feed(solver, u, **timed):
        solver.update(
            [spec.factor(f) for f in u["factors"]], {spec.key(n): np.array(v) for n, v in u["values"].items()}, **timed
        )

    plain_isam2 = IncrementalSolver(**params)  # the smoother's tree before its first marginalization
    for u in updates[:2]:
        feed(plain_isam2, u)
    clique = plain_isam2.tree.cliques[plain_isam2.tree.frontal_of[X(0)]]
    assert set(clique.frontals) == {X(0), L(0), X(1)} and not clique.separator
    smoother, leaves = FixedLagSmoother(case["inputs"]["lag"], **params), []
    for u in updates:
        feed(smoother, u, timestamps={spec.key(n): t for n, t in u["timestamps"].items()})
        if smoother.last_marginalization is not None:
            leaves.append(smoother.last_marginalization.leaves)
    assert leaves == [False, False, False, False]


def test_an_export_that_fails_midway_leaves_nothing_and_a_retry_works(tmp_path, capsys, monkeypatch):
    """A full disk while the README is written (after every kit file): nothing is left at the target or beside
    it, the error is one line naming the folder and the cause, and the retry writes the kit."""
    import errno

    from steam_ref.conformance import command

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(command, "export_readme", full)
    code, out, err = cli(capsys, "export", tmp_path / "kit")
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1, err
    assert f"cannot export the kit to '{tmp_path / 'kit'}': No space left on device" in err
    assert list(tmp_path.iterdir()) == []  # no partial kit, no temporary folder
    monkeypatch.undo()
    code, _, err = cli(capsys, "export", tmp_path / "kit")
    assert code == 0 and (tmp_path / "kit" / "README.md").is_file() and (tmp_path / "kit" / "index.json").is_file(), err
    (tmp_path / "empty").mkdir()
    assert cli(capsys, "export", tmp_path / "empty")[0] == 0 and (tmp_path / "empty" / "index.json").is_file()


def test_an_export_onto_a_full_disk_says_so_in_one_line_naming_the_destination(tmp_path, capsys, monkeypatch):
    """A full disk while the kit's files are copied: one line naming the folder and the cause, not the copy's list of
    (source, destination, error) tuples with the installed package's paths; nothing is left behind."""
    import errno
    import shutil

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(shutil, "copyfile", full)
    code, out, err = cli(capsys, "export", tmp_path / "kit")
    assert code == 2 and out == "" and len(err.strip().splitlines()) == 1, err
    assert f"cannot export the kit to '{tmp_path / 'kit'}': No space left on device" in err, err
    assert str(SHIPPED) not in err and "[(" not in err, err
    assert list(tmp_path.iterdir()) == []
