"""The seam holds: outside the homes of the motion priors and of the Lie groups, no module tests which prior or
group it has, and no module is named after one.

A branch on a prior's or a group's name is how a second prior comes in as a tenant: every caller pays for the
next one again. This test parses every module of the package (without importing it) and reads the condition of
every ``if``, ``elif``, ``while``, conditional expression, comprehension filter and ``match`` case. A condition
may not

- compare with, or contain, a string that names a prior, a group or a residual ('se2', 'wnoa', 'simplified'...);
- read a name that spells one (``is_se2``, ``SE2_STATE``, ``se2_residual``, ``SE3``...);
- name a prior's or a group's class (``isinstance(p, LinearSDE)``, ``kind is GroupState(...)``...).

The names come from the package's own tables (``MOTION_PRIORS``, the residuals, every ``LieGroup`` subclass,
the closed-form SDE models), with the next groups (SE(3), SO(3)) added ahead of them.

The homes, where a prior or group may be told by name:

- ``steam_ref/motion/``: the priors, one object each, and the table of their names;
- ``steam_ref/lie/``: the groups, the state kind on a group, the GP on a group;
- ``steam_ref/gp/``: the maths of the vector-space priors (``LinearSDE``, the closed forms of WNOA, WNOJ and
  Singer's model by name, the one conversion of a Qc-or-SDE argument): the vector priors' home as ``lie/`` is
  the groups';
- the conformance kit's independent oracles (``conformance/oracle*.py``, ``conformance/expected.py``): they must
  not use the package (that is their worth as oracles), so they cannot ask its prior objects, and re-derive
  each model from the name the kit's case gives it.

``ALLOWED`` lists what is left outside them, each with its reason (at most 3, the issue's bar).
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from pathlib import Path

from steam_ref.gp import ClosedForm, LinearSDE
from steam_ref.gp.models import _FORMS
from steam_ref.lie import GroupState, LieGroup
from steam_ref.motion import MOTION_PRIORS, RESIDUALS, MotionPrior

PACKAGE = Path(__file__).resolve().parents[1] / "steam_ref"
HOMES = ("motion/", "lie/", "gp/")
ORACLES = re.compile(r"^conformance/(oracle\w*|expected)\.py$")  # the kit's independent oracles: their own home
AT_MOST = 3  # the bar


def _subclasses(cls: type) -> set[type]:
    out = set()
    for sub in cls.__subclasses__():
        out |= {sub} | _subclasses(sub)
    return out


# The names a user gives a prior, a group or a residual (as strings, lower case): the package's tables, and the
# next groups ahead of them.
NAMES = (
    set(MOTION_PRIORS)
    | set(RESIDUALS)
    | set(_FORMS)
    | {g.name for g in _subclasses(LieGroup) if isinstance(getattr(g, "name", None), str)}
    | {"lti", "se2", "se3", "so2", "so3"}
)
# The classes of the priors and the groups (their instances are what a caller would ask isinstance of).
CLASSES = {c.__name__ for c in _subclasses(MotionPrior) | _subclasses(LieGroup)} | {
    c.__name__ for c in (MotionPrior, LieGroup, GroupState, LinearSDE, ClosedForm)
}
# An identifier that spells a prior or a group: SE2, SE2_STATE, is_se2, se2_residual, WNOA_...
SPELLED = re.compile(
    r"(?i)(^|_)("
    + "|".join(sorted(re.escape(n.replace("-", "_")) for n in NAMES))
    + r")($|_)|^("
    + "|".join(CLASSES)
    + r")$"
)
# A module named after a group or a prior (GTSAM's Pose2 / Pose3 are SE(2) / SE(3)).
MODULE_NAMED = re.compile(
    r"(?i)(^|_)(" + "|".join(sorted(re.escape(n.replace("-", "_")) for n in NAMES)) + r"|pose2|pose3)($|_)"
)

# (module, a substring of the condition's source) -> why it may test a prior or group by name there.
ALLOWED: dict[tuple[str, str], str] = {}


def _modules() -> Iterator[tuple[str, Path]]:
    """Every module of the package outside the homes, as (its path under steam_ref/, the file)."""
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        if not rel.startswith(HOMES) and not ORACLES.match(rel):
            yield rel, path


def _conditions(tree: ast.AST) -> Iterator[ast.AST]:
    for node in ast.walk(tree):
        if isinstance(node, (ast.If, ast.IfExp, ast.While)):
            yield node.test
        elif isinstance(node, ast.comprehension):
            yield from node.ifs
        elif isinstance(node, ast.match_case):
            yield node.pattern
            if node.guard is not None:
                yield node.guard


def branches_on_a_name(test: ast.AST) -> bool:
    """True when the condition ``test`` names a prior, a group or a residual (module docstring)."""
    for node in ast.walk(test):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value.lower() in NAMES:
            return True
        if isinstance(node, ast.Name) and SPELLED.search(node.id):
            return True
        if isinstance(node, ast.Attribute) and SPELLED.search(node.attr):
            return True
        if isinstance(node, (ast.MatchClass,)) and isinstance(node.cls, ast.Name) and SPELLED.search(node.cls.id):
            return True
    return False


def name_tests(source: str, rel: str = "<source>") -> list[str]:
    """Every condition of ``source`` that tests a prior or group by name, as 'module:line: condition'."""
    found = []
    for test in _conditions(ast.parse(source)):
        if branches_on_a_name(test):
            text = ast.get_source_segment(source, test) or ast.dump(test)
            found.append(f"{rel}:{test.lineno}: {' '.join(text.split())[:100]}")
    return found


def test_no_module_outside_the_homes_tests_a_prior_or_group_by_name():
    found, used = [], set()
    for rel, path in _modules():
        for site in name_tests(path.read_text(encoding="utf-8"), rel):
            allowed = [(m, s) for (m, s) in ALLOWED if m == rel and s in site]
            used.update(allowed)
            if not allowed:
                found.append(site)
    assert not found, "a prior or group told by name outside the homes:\n" + "\n".join(found)
    assert len(ALLOWED) <= AT_MOST, f"{len(ALLOWED)} exceptions; the bar is {AT_MOST}"
    assert used == set(ALLOWED), f"exceptions no longer needed (remove them): {sorted(set(ALLOWED) - used)}"


def test_no_module_outside_the_homes_is_named_after_a_group_or_prior():
    named = [rel for rel, _ in _modules() if MODULE_NAMED.search(Path(rel).stem)]
    assert not named, f"modules named after a group or a prior outside the homes: {named}"


def test_the_homes_and_the_oracles_exist():
    """A renamed home would silently widen the scan's blind spot: each must still be there."""
    for home in HOMES:
        assert (PACKAGE / home).is_dir(), home
    oracles = [p for p in PACKAGE.rglob("*.py") if ORACLES.match(p.relative_to(PACKAGE).as_posix())]
    assert {p.stem for p in oracles} >= {"oracle", "oracle_lie", "expected"}
    for path in oracles:  # their exemption holds only while they do not use the package's priors or groups
        source = path.read_text(encoding="utf-8")
        assert not re.search(r"^from \.\.(motion|lie|gp)\b|^import steam_ref", source, re.M), path


def test_the_scan_flags_each_way_of_branching_on_a_prior_or_group():
    """The scan itself can fail: it flags each pattern it claims to find, and not a test of something else."""
    flagged = [
        "if setup.prior == 'se2': pass",
        "if prior.name in ('wnoa', 'wnoj'): pass",
        "x = 1 if setup.is_se2 else 2",
        "y = [k for k in keys if kinds[k] is SE2_STATE]",
        "if isinstance(p, LinearSDE): pass",
        "if isinstance(p, (VectorPrior, LieGroupWnoa)): pass",
        "if group is SE3: pass",
        "if model == 'local-variable': pass",
        "if self.se2_residual not in RESIDUALS: pass",
        "while kind is not GroupState(group): pass",
        "match prior.name:\n    case 'singer': pass",
        "match prior:\n    case LieGroupWnoa(): pass",
        "if sde.model.name == 'wnoa' and not v: pass",
    ]
    for code in flagged:
        assert name_tests(code), code
    for code in (
        "if prior.kind is not None: pass",
        "if name == 'plaza': pass",
        "x = [f for f in factors if f.loss is not None]",
        "if suite == 'gp': pass",
        "if self.setup.pose2_heading_rate_guess: pass",
    ):
        assert not name_tests(code), code
    assert MODULE_NAMED.search("se2_model") and MODULE_NAMED.search("pose2") and not MODULE_NAMED.search("presets")
