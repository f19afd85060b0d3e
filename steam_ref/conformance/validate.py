"""The form of what the checker reads: a kit's cases and a results file, refused with one line when wrong.

Kit and results files are written by other people's programs, so every field the checker uses is
checked before it is used: a malformed file is a :class:`~steam_ref.errors.DataError` naming the
file and the problem (exit 2 in the CLI), never a traceback, and never a verdict ("passed", "failed")
on something that was not compared. What counts as malformed:

- a kit case without a string ``name``, a ``tolerance`` object whose values are ``"exact"`` or
  ``{"atol": a, "rtol": r}`` with finite non-negative numbers, or an ``expected`` value for each of
  its quantities; a case name given twice;
- a results file that is not ``{"kit_version": N, "cases": {case: {quantity: value}}}``; a value of a
  numeric quantity whose leaves are not JSON numbers (a string ``"1.0"`` or ``true`` is not read as a
  number).

A quantity the case does not have (an extra output a port writes, or a typo) is not malformed: it is a
warning line naming it, and the rest of the file is checked (a typo still fails, as the quantity it
misspells is then missing).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from ..errors import DataError
from .kitio import KITS, kit_version, printable, shown

RESULTS_KEYS = ("kit_version", "cases")  # the keys of a results file: {"kit_version": N, "cases": {...}}

__all__ = ["kit_cases", "results_cases", "results_version", "numeric_leaf_problem"]


def _finite_nonnegative(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and x >= 0


def kit_cases(where: str, cases: object) -> list[dict]:
    """A suite's case list, checked (see the module docstring)."""
    if not isinstance(cases, list):
        raise DataError(f"{where}: 'cases' must be a list")
    seen: set[str] = set()
    for i, case in enumerate(cases):
        if not isinstance(case, Mapping) or not isinstance(case.get("name"), str):
            raise DataError(f"{where}: cases[{i}] is not an object with a string 'name'")
        name = shown(case["name"])
        if case["name"] in seen:
            raise DataError(f"{where}: the case '{name}' is listed twice")
        seen.add(case["name"])
        tolerance, expected = case.get("tolerance"), case.get("expected")
        if not isinstance(tolerance, Mapping) or not tolerance or not isinstance(expected, Mapping):
            raise DataError(f"{where}: case '{name}' needs a 'tolerance' object and an 'expected' object")
        for q, t in tolerance.items():
            numeric = (
                isinstance(t, Mapping) and set(t) == {"atol", "rtol"} and all(map(_finite_nonnegative, t.values()))
            )
            if t != "exact" and not numeric:
                raise DataError(
                    f"{where}: case '{name}', tolerance of '{shown(q)}' is {printable(repr(t))[:80]}: "
                    'expected "exact" or {"atol": a, "rtol": r} with finite a, r >= 0'
                )
            if q not in expected:
                raise DataError(f"{where}: case '{name}' has a tolerance for '{shown(q)}' but no expected value")
            if t != "exact":
                problem = numeric_leaf_problem(expected[q])
                if problem:
                    raise DataError(f"{where}: case '{name}', expected {shown(q)}{problem}")
        _alternatives(where, name, case)
    return [dict(c) for c in cases]


def _alternatives(where: str, name: str, case: Mapping) -> None:
    """A case's 'alternatives': convention name → quantity of the case → a value of the quantity's kind."""
    alternatives = case.get("alternatives", {})
    if not isinstance(alternatives, Mapping):
        raise DataError(f"{where}: case '{name}', 'alternatives' must be an object")
    for key, values in alternatives.items():
        if not isinstance(values, Mapping):
            raise DataError(f"{where}: case '{name}', alternatives/{shown(key)} must be an object")
        for q, v in values.items():
            t = case["tolerance"].get(q)
            if t is None:
                raise DataError(f"{where}: case '{name}', alternatives/{shown(key)} names an unknown quantity")
            problem = "" if t == "exact" else numeric_leaf_problem(v)
            if problem:
                raise DataError(f"{where}: case '{name}', alternatives/{shown(key)}/{shown(q)}{problem}")


def numeric_leaf_problem(value) -> str:
    """'' when every leaf of ``value`` (lists, objects) is a JSON number; else where and what the first other leaf is."""
    stack: list[tuple[object, str]] = [(value, "")]
    while stack:
        v, path = stack.pop()
        if isinstance(v, Mapping):
            stack.extend((x, f"{path}/{shown(k)}") for k, x in reversed(list(v.items())))
        elif isinstance(v, list):
            stack.extend((x, f"{path}[{i}]") for i, x in reversed(list(enumerate(v))))
        elif isinstance(v, bool) or not isinstance(v, (int, float)):
            what = "true/false" if isinstance(v, bool) else ("null" if v is None else f"a {type(v).__name__}")
            return f"{path} is {what}, not a number"
    return ""


def results_version(where: str, data: object) -> int | None:
    """The ``kit_version`` a results file names (None when it names none: results written for kit v1); an integral
    float (3.0) names that kit."""
    if not isinstance(data, Mapping) or not isinstance(data.get("cases"), Mapping):
        raise DataError(
            f'{where}: expected an object {{"kit_version": N, "cases": {{case name: {{quantity: value}}}}}}'
        )
    given = data.get("kit_version")
    if given is None:
        return None
    version = kit_version(given)
    if version is None:
        raise DataError(
            f"{where}: kit_version {printable(repr(given))[:40]}, the kits are versions {', '.join(map(str, KITS))}"
        )
    return version


def results_cases(where: str, data: Mapping, kit: Sequence[Mapping], warnings: list[str] | None = None) -> dict:
    """The results of the kit's cases, each checked against its case's quantities and their kinds; a quantity
    a case does not have is left out and named in ``warnings``."""
    by_name = {c["name"]: c for c in kit}
    if warnings is not None:  # a misspelt 'kit_version' would otherwise make the file kit v1's without a word
        warnings += [
            f"{where}: '{shown(key)}' is not a key of a results file, not read (its keys: {', '.join(RESULTS_KEYS)})"
            for key in data
            if key not in RESULTS_KEYS
        ]
    out = {}
    for name, got in data["cases"].items():
        case = by_name.get(name)
        if case is None:
            out[name] = got  # a case the kit does not have: reported, not judged
            continue
        if not isinstance(got, Mapping):
            raise DataError(f"{where}: cases/{shown(name)} must be an object of quantity -> value")
        extra = [q for q in got if q not in case["tolerance"]]
        if extra and warnings is not None:
            listed = ", ".join(f"'{shown(q)}'" for q in extra[:8]) + (", ..." if len(extra) > 8 else "")
            warnings.append(
                f"{where}: cases/{shown(name)} has quantities the case does not have, not checked: {listed} "
                f"(it has {', '.join(case['tolerance'])})"
            )
        for q, value in got.items():
            if q in extra:
                continue
            if case["tolerance"][q] != "exact":
                problem = numeric_leaf_problem(value)
                if problem:
                    raise DataError(f"{where}: cases/{shown(name)}/{shown(q)}{problem}")
        out[name] = {q: v for q, v in got.items() if q not in extra}
    return out
