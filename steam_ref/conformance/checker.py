"""Compare results with the kit's expected values, case by case, within each quantity's tolerance.

A numeric quantity (a number, an array, or an object whose leaves are those) passes when, at
every leaf, ``max|got - expected| ≤ atol + rtol · max|expected|`` (normwise, as LAPACK's tests scale
by the norm of the answer) and the shapes agree. An ``exact`` quantity (names, clique structure)
must be equal; in it, lists of lists and lists of objects are compared as unordered collections,
lists of names in order. A case passes when all its quantities do.

Every failing quantity is reported with its worst entries (index, expected, got); the first one in
the case's computation order (its ``quantities`` list, else its ``tolerance`` order) is flagged as
the likely cause, since a wrong Φ also makes everything computed from it wrong. A quantity's pattern is named
when it has one: 2π k off, minus the expected value, its entries (columns, rows) in another order, a square
matrix's rows and columns both in another order by the same permutation (``expected[p][:, p]``: Φ, Q or a covariance
of a state stacked in another order), or another quantity's expected value (Λ for Ψ). A structure that
differs is printed in full: the items expected but not got, and got but not expected.

With conventions (``paper-sign``, ``symmetric-whitener``; kit v5 ``signed-half-turn``), a quantity that depends
on them is compared with the kit's ``alternatives`` for that combination instead (kit v2), the combination of
those given that the case's alternatives name (:func:`case_alternative`).
"""

from __future__ import annotations

import json
import math
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from .hints import pattern_hint
from .kitio import printable, shown

__all__ = [
    "Outcome",
    "Report",
    "compare_quantity",
    "check_cases",
    "computation_order",
    "convention_key",
    "case_alternative",
]

WORST = 3  # entries shown per failing numeric quantity
WIDTH = 2000  # characters of one structure item shown at most


@dataclass(frozen=True)
class Outcome:
    """The verdict on one case: its failing quantities in computation order, the first the likely cause."""

    suite: str
    case: str
    failures: tuple[tuple[float, str, tuple[str, ...]], ...] = ()  # (how far past tolerance, headline, details)

    @property
    def passed(self) -> bool:
        return not self.failures

    def line(self) -> str:
        """One line: suite, case, the first failing quantity in computation order, and how many more."""
        first = self.failures[0][1]
        more = len(self.failures) - 1
        tail = f" (likely cause: first failing in computation order; {more} more failing)" if more else ""
        return printable(f"FAIL {self.suite}/{self.case}: {first}{tail}")

    def lines(self) -> list[str]:
        """The headline, then every failing quantity with its worst entries."""
        out = [self.line()]
        for k, (_ratio, headline, details) in enumerate(self.failures):
            if k:
                out.append("  " + printable(headline))
            out += ["    " + printable(d) for d in details]
        return out


@dataclass
class Report:
    """Outcomes of a check, what had no result, and what was deliberately left out."""

    outcomes: list[Outcome] = field(default_factory=list)
    not_run: list[str] = field(default_factory=list)  # 'suite/case' of the kit with no result
    unknown: list[str] = field(default_factory=list)  # results for cases the kit does not have
    notes: list[str] = field(default_factory=list)  # anything else to say before the count
    allow_missing: bool = True  # missing results are not a failure (selftest, or --allow-missing)
    excluded: list[str] = field(default_factory=list)  # suites left out with --only
    warnings: list[str] = field(default_factory=list)  # harmless oddities of a results file (an unknown quantity)

    @property
    def passed(self) -> int:
        return sum(o.passed for o in self.outcomes)

    @property
    def failed(self) -> int:
        return sum(not o.passed for o in self.outcomes)

    @property
    def ok(self) -> bool:
        """Some case passed, none failed, and nothing of the kit is missing unless that was allowed: a check in
        which nothing passed showed nothing to conform, ``--allow-missing`` or not."""
        return self.passed > 0 and self.failed == 0 and (self.allow_missing or not self.not_run)

    def lines(self) -> list[str]:
        """Failing cases in full, then what was missing, left out or unknown, then 'N passed, N failed'."""
        out = [line for o in self.outcomes if not o.passed for line in o.lines()]
        if self.not_run:
            verdict = "skipped (allowed)" if self.allow_missing else "MISSING"
            by_suite: dict[str, list[str]] = {}
            for name in self.not_run:
                suite, _, case = name.partition("/")
                by_suite.setdefault(suite, []).append(case)
            for suite, cases in by_suite.items():
                out.append(printable(f"{verdict}: {len(cases)} cases of {suite} have no result: {', '.join(cases)}"))
            if not self.allow_missing:
                out.append(
                    "every case of the kit must have a result: add them, or pass --only SUITE... / --allow-missing"
                )
        if self.excluded:
            out.append(f"not checked (--only): {', '.join(self.excluded)}")
        if self.unknown:
            out.append(
                printable(
                    f"ignored: results for {len(self.unknown)} cases the kit does not have "
                    f"({', '.join(map(shown, self.unknown[:8]))})"
                )
            )
        out += [printable(f"warning: {w}") for w in self.warnings]
        out += [printable(n) for n in self.notes]
        if not self.outcomes:
            out.append("no case was checked, so nothing passed: that is not a pass")
        elif not self.passed:
            out.append("no case passed: that is not a pass")
        missing = f", {len(self.not_run)} missing" if self.not_run else ""
        out.append(f"{self.passed} passed, {self.failed} failed{missing}")
        return out


def _canonical(v):
    """``v`` as compared exactly: lists of lists or objects sorted, and an integral double read as the integer it
    is (JSON has one number type: a port's ``189.0`` is the kit's ``189``, as ``kit_version`` 4.0 names kit v4)."""
    if isinstance(v, float) and v.is_integer():
        return int(v)
    if isinstance(v, Mapping):
        return {k: _canonical(x) for k, x in v.items()}
    if isinstance(v, list):
        items = [_canonical(x) for x in v]
        if items and all(isinstance(x, (dict, list)) for x in items):
            items.sort(key=lambda x: json.dumps(x, sort_keys=True))
        return items
    return v


def _text(v) -> str:
    text = json.dumps(v, sort_keys=True, ensure_ascii=False)
    return text if len(text) <= WIDTH else text[: WIDTH - 3] + "..."


def _exact(expected, got, name: str) -> list[tuple[float, str, tuple[str, ...]]]:
    exp, g = _canonical(expected), _canonical(got)
    if json.dumps(exp, sort_keys=True) == json.dumps(g, sort_keys=True):
        return []
    if isinstance(exp, list) and isinstance(g, list) and exp and all(isinstance(x, (dict, list)) for x in exp):
        e_count = Counter(json.dumps(x, sort_keys=True) for x in exp)
        g_count = Counter(json.dumps(x, sort_keys=True) for x in g)
        only_e, only_g = e_count - g_count, g_count - e_count
        details = tuple(f"expected, not got: {_text(json.loads(x))}" for x in only_e.elements())
        details += tuple(f"got, not expected: {_text(json.loads(x))}" for x in only_g.elements())
        head = f"{name} differs (compared exactly): {sum(only_e.values())} expected items not got, {sum(only_g.values())} got not expected"
        return [(math.inf, head, details)]
    return [(math.inf, f"{name} differs (compared exactly)", (f"expected {_text(expected)}", f"got      {_text(got)}"))]


def _where(idx: tuple[int, ...]) -> str:
    return "[" + ", ".join(map(str, idx)) + "]" if idx else ""


Failure = tuple[float, str, tuple[str, ...]]  # (how far past tolerance, headline, detail lines)


def compare_quantity(expected, got, tolerance, name: str) -> list[Failure]:
    """Failures (ratio past tolerance, headline, detail lines) of one quantity; empty when it passes."""
    if tolerance == "exact":
        return _exact(expected, got, name)
    if isinstance(expected, Mapping):
        if not isinstance(got, Mapping):
            return [(math.inf, f"{name} should be an object with keys {sorted(expected)}, got {_text(got)[:60]}", ())]
        out: list[Failure] = [(math.inf, f"{name}/{k} is missing", ()) for k in expected if k not in got]
        out += [(math.inf, f"{name}/{k} is not an expected key", ()) for k in got if k not in expected]
        for k in expected:
            if k in got:
                out += compare_quantity(expected[k], got[k], tolerance, f"{name}/{k}")
        return out
    exp = np.asarray(expected, dtype=float)
    try:
        g = np.asarray(got, dtype=float)
    except (TypeError, ValueError, OverflowError):
        return [(math.inf, f"{name} is not numeric: {_text(got)[:60]}", ())]
    if g.shape != exp.shape:
        flipped = g.ndim == 2 and g.shape == exp.shape[::-1]
        hint = (
            ": transposed? (arrays are nested lists, row-major: a Jacobian has a row per error entry)"
            if flipped
            else ""
        )
        return [(math.inf, f"{name} has shape {g.shape}, expected {exp.shape}{hint}", ())]
    if not np.all(np.isfinite(g)):
        return [(math.inf, f"{name} holds NaN or inf", ())]
    if exp.size == 0:
        return []
    diff = np.abs(g - exp)
    worst, scale = float(diff.max()), float(np.abs(exp).max())
    atol, rtol = float(tolerance["atol"]), float(tolerance["rtol"])
    allowed = atol + rtol * scale
    if worst <= allowed:
        return []
    flat = np.argsort(-diff, axis=None, kind="stable")[:WORST]
    details = []
    for i in flat:
        idx = tuple(int(j) for j in np.unravel_index(int(i), diff.shape)) if diff.ndim else ()
        if diff[idx] <= allowed:
            break
        details.append(
            f"{name}{_where(idx)}: expected {float(exp[idx])!r}, got {float(g[idx])!r} (|diff| {float(diff[idx]):.3g})"
        )
    at = _where(tuple(int(j) for j in np.unravel_index(int(flat[0]), diff.shape))) if diff.ndim else ""
    bad = int(np.count_nonzero(diff > allowed))
    head = (
        f"{name} worst |diff| {worst:.3g}{' at ' + at if at else ''} > tolerance {allowed:.3g} "
        f"(atol {atol:g} + rtol {rtol:g} x max|expected| {scale:.3g}); {bad} of {diff.size} entries past it{pattern_hint(exp, g, worst, allowed)}"
    )
    return [(worst / allowed if allowed > 0 else math.inf, head, tuple(details))]


def _equals_another(case: Mapping, expected: Mapping, name: str, got) -> str:
    """'; equals the expected Psi: the two swapped?' when a failing quantity's value passes as another of the case's
    quantities (same tolerance rule, that quantity's tolerance); '' otherwise, and '' for a value that is minus its
    own expected one (b = -W e: a flipped whitened_error equals b, and the sign is the hint there)."""
    try:
        got = np.asarray(got, dtype=float)
    except (TypeError, ValueError, OverflowError):
        return ""  # not numbers: compare_quantity said so
    if np.shape(got) == np.shape(expected[name]) and not compare_quantity(
        -np.asarray(expected[name], float), got, case["tolerance"][name], name
    ):
        return ""
    for other in computation_order(case):
        tolerance = case["tolerance"][other]
        if other == name or tolerance == "exact" or isinstance(expected[other], Mapping):
            continue
        if np.shape(expected[other]) == np.shape(got) and not compare_quantity(expected[other], got, tolerance, other):
            return f"; equals the expected {other}: the two swapped?"
    return ""


def computation_order(case: Mapping) -> list[str]:
    """The case's quantities in the order they are computed (its 'quantities' list in kit v2, else its tolerance order)."""
    listed = case.get("quantities")
    if isinstance(listed, list):
        names = [q["name"] for q in listed if isinstance(q, Mapping) and q.get("name") in case["tolerance"]]
        return names + [q for q in case["tolerance"] if q not in names]
    return list(case["tolerance"])


def convention_key(conventions: Sequence[str]) -> str:
    """'paper-sign+symmetric-whitener': how the kit names the alternatives of a set of conventions."""
    return "+".join(sorted(set(conventions)))


def case_alternative(case: Mapping, conventions: Sequence[str]) -> Mapping:
    """A case's expected values under ``conventions``: its alternatives for those of them its alternatives name (a
    case stores only the combinations of the conventions that change it: an SE(2) Exp case has 'signed-half-turn',
    a factor case 'paper-sign' and 'paper-sign+symmetric-whitener'); {} when none applies."""
    stored = case.get("alternatives", {})
    named = {name for combination in stored for name in combination.split("+")}
    key = convention_key([c for c in conventions if c in named])
    return stored.get(key, {}) if key else {}


def check_cases(
    suite: str,
    kit_cases: Sequence[Mapping],
    results: Mapping[str, object],
    report: Report | None = None,
    conventions: Sequence[str] = (),
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
                Outcome(suite, case["name"], ((math.inf, "its result is not an object of quantities", ()),))
            )
            continue
        alternative = case_alternative(case, conventions)
        failures: list[Failure] = []
        for q in computation_order(case):
            if q not in got:
                failures.append((math.inf, f"{q} is missing from the results", ()))
            else:
                expected = alternative.get(q, case["expected"][q])
                failed = compare_quantity(expected, got[q], case["tolerance"][q], q)
                if len(failed) == 1 and not isinstance(expected, Mapping) and case["tolerance"][q] != "exact":
                    swapped = _equals_another(case, {**case["expected"], **alternative}, q, got[q])
                    failed = [(failed[0][0], failed[0][1] + swapped, failed[0][2])]
                failures += failed
        report.outcomes.append(Outcome(suite, case["name"], tuple(failures)))
    report.unknown += [f"{suite}/{name}" for name in results if name not in known]
    return report
