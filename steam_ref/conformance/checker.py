"""Compare results with the kit's expected values, case by case, within each quantity's tolerance.

A numeric quantity (a number, an array, or an object whose leaves are those) passes when, at
every leaf, ``max|got - expected| ≤ atol + rtol · max|expected|`` (normwise, as LAPACK's tests scale
by the norm of the answer) and the shapes agree. An ``exact`` quantity (names, clique structure)
must be equal; in it, lists of lists and lists of objects are compared as unordered collections,
lists of names in order. A case passes when all its quantities do.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import DataError, SteamError
from .kitio import SUITES, read_json, read_suite

__all__ = ["Outcome", "Report", "compare_quantity", "check_cases", "check_directory", "load_results"]


@dataclass(frozen=True)
class Outcome:
    """The verdict on one case."""

    suite: str
    case: str
    failures: tuple[
        tuple[float, str], ...
    ] = ()  # (how far past its tolerance, message) per failing quantity, worst first

    @property
    def passed(self) -> bool:
        return not self.failures

    def line(self) -> str:
        """One line: suite, case, the worst quantity and its difference against its tolerance."""
        worst = self.failures[0][1]
        more = f" (and {len(self.failures) - 1} more quantities)" if len(self.failures) > 1 else ""
        return f"FAIL {self.suite}/{self.case}: {worst}{more}"


@dataclass
class Report:
    """Outcomes of a check, and the cases that had no result."""

    outcomes: list[Outcome] = field(default_factory=list)
    not_run: list[str] = field(default_factory=list)  # 'suite/case'
    unknown: list[str] = field(default_factory=list)  # results for cases the kit does not have
    notes: list[str] = field(default_factory=list)  # anything else to say before the count

    @property
    def passed(self) -> int:
        return sum(o.passed for o in self.outcomes)

    @property
    def failed(self) -> int:
        return sum(not o.passed for o in self.outcomes)

    def lines(self) -> list[str]:
        """Failing cases, then what was not run or not known, then 'N passed, N failed'."""
        out = [o.line() for o in self.outcomes if not o.passed]
        if self.not_run:
            shown = ", ".join(self.not_run[:8]) + (", ..." if len(self.not_run) > 8 else "")
            out.append(f"not run: {len(self.not_run)} cases of these suites have no result ({shown})")
        if self.unknown:
            out.append(
                f"ignored: results for {len(self.unknown)} cases the kit does not have ({', '.join(self.unknown[:8])})"
            )
        out += self.notes
        out.append(f"{self.passed} passed, {self.failed} failed")
        return out


def _canonical(v):
    if isinstance(v, Mapping):
        return {k: _canonical(x) for k, x in v.items()}
    if isinstance(v, list):
        items = [_canonical(x) for x in v]
        if items and all(isinstance(x, (dict, list)) for x in items):
            items.sort(key=lambda x: json.dumps(x, sort_keys=True))
        return items
    return v


def _short(v, width: int = 90) -> str:
    text = json.dumps(v, sort_keys=True)
    return text if len(text) <= width else text[: width - 3] + "..."


def compare_quantity(expected, got, tolerance, name: str) -> list[tuple[float, str]]:
    """Failures (ratio past tolerance, message) of one quantity; empty when it passes."""
    if tolerance == "exact":
        if json.dumps(_canonical(expected), sort_keys=True) == json.dumps(_canonical(got), sort_keys=True):
            return []
        return [(math.inf, f"{name} differs (compared exactly): expected {_short(expected)}, got {_short(got)}")]
    if isinstance(expected, Mapping):
        if not isinstance(got, Mapping):
            return [(math.inf, f"{name} should be an object with keys {sorted(expected)}, got {_short(got, 40)}")]
        out = [(math.inf, f"{name}/{k} is missing") for k in expected if k not in got]
        out += [(math.inf, f"{name}/{k} is not an expected key") for k in got if k not in expected]
        for k in expected:
            if k in got:
                out += compare_quantity(expected[k], got[k], tolerance, f"{name}/{k}")
        return sorted(out, key=lambda f: -f[0])
    exp = np.asarray(expected, dtype=float)
    try:
        g = np.asarray(got, dtype=float)
    except (TypeError, ValueError):
        return [(math.inf, f"{name} is not numeric: {_short(got, 40)}")]
    if g.shape != exp.shape:
        return [(math.inf, f"{name} has shape {g.shape}, expected {exp.shape}")]
    if not np.all(np.isfinite(g)):
        return [(math.inf, f"{name} holds NaN or inf")]
    if exp.size == 0:
        return []
    diff = np.abs(g - exp)
    worst, scale = float(diff.max()), float(np.abs(exp).max())
    allowed = float(tolerance["atol"]) + float(tolerance["rtol"]) * scale
    if worst <= allowed:
        return []
    where = np.unravel_index(int(diff.argmax()), diff.shape) if diff.ndim else ()
    at = f" at {tuple(int(i) for i in where)}" if where else ""
    return [
        (
            worst / allowed if allowed > 0 else math.inf,
            (
                f"{name} worst |diff| {worst:.3g}{at} > tolerance {allowed:.3g} "
                f"(atol {float(tolerance['atol']):g} + rtol {float(tolerance['rtol']):g} x max|expected| {scale:.3g})"
            ),
        )
    ]


def check_cases(
    suite: str, kit_cases: Sequence[Mapping], results: Mapping[str, object], report: Report | None = None
) -> Report:
    """Check ``results`` (case name → quantity → value) against a suite's kit cases."""
    report = Report() if report is None else report
    known = {c["name"] for c in kit_cases}
    for case in kit_cases:
        got = results.get(case["name"])
        if got is None:
            report.not_run.append(f"{suite}/{case['name']}")
            continue
        if not isinstance(got, Mapping):
            report.outcomes.append(
                Outcome(suite, case["name"], ((math.inf, "its result is not an object of quantities"),))
            )
            continue
        failures = []
        for q, tolerance in case["tolerance"].items():
            if q not in got:
                failures.append((math.inf, f"{q} is missing from the results"))
            else:
                failures += compare_quantity(case["expected"][q], got[q], tolerance, q)
        failures.sort(key=lambda f: -f[0])
        report.outcomes.append(Outcome(suite, case["name"], tuple(failures)))
    report.unknown += [f"{suite}/{name}" for name in results if name not in known]
    return report


def load_results(results_dir: Path, suite: str) -> dict:
    """``RESULTS_DIR/<suite>/results.json`` as case name → quantities; DataError when malformed."""
    path = Path(results_dir) / suite / "results.json"
    data = read_json(path)
    cases = data.get("cases") if isinstance(data, Mapping) else None
    if not isinstance(cases, Mapping):
        raise DataError(f'{path}: expected an object {{"cases": {{case name: {{quantity: value}}}}}}')
    return dict(cases)


def check_directory(kit: Path, results_dir: Path, suite: str | None = None) -> Report:
    """Check every suite that ``results_dir`` has results for (or just ``suite``) against the kit."""
    results_dir = Path(results_dir)
    if not results_dir.is_dir():
        raise SteamError(f"results folder {str(results_dir)!r} does not exist")
    if suite is not None and suite not in SUITES:
        raise SteamError(f"unknown suite {suite!r}; the suites are {', '.join(SUITES)}")
    present = [s for s in SUITES if (results_dir / s / "results.json").is_file()]
    if suite is not None:
        if suite not in present:
            raise SteamError(f"no results for suite {suite!r}: expected {results_dir / suite / 'results.json'}")
        present = [suite]
    if not present:
        raise SteamError(
            f"no results in {str(results_dir)!r}: expected <suite>/results.json for a suite of {', '.join(SUITES)}"
        )
    report = Report()
    for s in present:
        check_cases(s, read_suite(kit, s)["cases"], load_results(results_dir, s), report)
    return report
