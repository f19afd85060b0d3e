"""Every tutorial notebook executes top to bottom, and its last code cell asserts (against a dense solve).
Each has at least two exercises whose checks assert, and the teachers' command of docs/tutorials.md hides
their solutions.

Executing needs nbformat, nbclient and ipykernel (the ``notebooks``/``test`` extras): without them
these tests skip, or fail when STEAM_REF_REQUIRE_OPTIONAL=1 (CI). A notebook that loads the
paper's files (``load_dataset("plaza")`` or ``"paper-synthetic"``) is a ``needs_data`` test; one that
loads a set from the gtsam wheel's ``Data/`` folder (``"victoria-park"``, ``"plaza2"``) needs gtsam, an
optional package, by the same rule.
"""

from __future__ import annotations

import ast
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest
from requirements import optional_import

TUTORIALS = sorted((Path(__file__).resolve().parents[1] / "tutorials").glob("*.ipynb"))
READS_REFERENCE_DATA = re.compile(r"""load_dataset\(\s*["'](plaza|paper-synthetic)["']|Syn_theta_Plaza|Plaza1_thrown""")
READS_GTSAM_DATA = re.compile(r"""load_dataset\(\s*["'](victoria-park|plaza2)["']""")


def _code_cells(path: Path) -> list[str]:
    cells = json.loads(path.read_text())["cells"]
    return [
        "".join(c["source"]) if isinstance(c["source"], list) else c["source"]
        for c in cells
        if c["cell_type"] == "code"
    ]


def _param(path: Path):
    reads = any(READS_REFERENCE_DATA.search(src) for src in _code_cells(path))
    return pytest.param(path, id=path.stem, marks=[pytest.mark.needs_data] if reads else [])


def _asserts(tree: ast.AST) -> list[str]:
    """Each ``assert`` statement and each call of ``np.testing.assert_*`` / ``numpy.testing.assert_*``."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Assert):
            found.append("assert")
        elif (
            isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr.startswith("assert_")
        ):
            owner = node.func.value
            if (
                isinstance(owner, ast.Attribute)
                and owner.attr == "testing"
                and isinstance(owner.value, ast.Name)
                and owner.value.id in ("np", "numpy")
            ):
                found.append(f"np.testing.{node.func.attr}")
    return found


def test_tutorials_exist():
    names = [p.stem for p in TUTORIALS]
    assert any(n.startswith("01_") for n in names) and any(n.startswith("02_") for n in names), names


def test_assertion_finder_tells_a_check_from_a_print():
    """The oracle below: it must see both kinds of check, and nothing in code that only prints."""
    assert sorted(_asserts(ast.parse("np.testing.assert_allclose(a, b)\nassert x < 1"))) == [
        "assert",
        "np.testing.assert_allclose",
    ]
    assert _asserts(ast.parse("print('all checks passed')\nx.assert_ok()\nself.assertEqual(a, b)")) == []


@pytest.mark.parametrize("path", TUTORIALS, ids=[p.stem for p in TUTORIALS])
def test_last_code_cell_asserts(path):
    """The notebook's closing claim is checked: its last code cell has an assert or np.testing.assert_*."""
    cells = _code_cells(path)
    assert cells, f"{path.name} has no code cell"
    assert _asserts(ast.parse(cells[-1])), f"{path.name}: the last code cell asserts nothing:\n{cells[-1]}"


@pytest.mark.parametrize("path", [_param(p) for p in TUTORIALS])
def test_notebook_executes(path):
    nbformat = optional_import("nbformat", "notebooks")
    nbclient = optional_import("nbclient", "notebooks")
    optional_import("ipykernel", "notebooks")
    if any(READS_GTSAM_DATA.search(src) for src in _code_cells(path)):
        optional_import("gtsam", "gtsam")  # its wheel's Data/ folder holds the data set
    nb = nbformat.read(path, as_version=4)
    assert all(not cell.get("outputs") for cell in nb.cells if cell.cell_type == "code"), (
        "commit notebooks with outputs stripped"
    )
    client = nbclient.NotebookClient(
        nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(path.parent)}}
    )
    client.execute()  # raises CellExecutionError on the first failing cell, the final assertions included


def _cells(path: Path) -> list[dict]:
    return json.loads(path.read_text())["cells"]


def _tags(cell: dict) -> set[str]:
    return set(cell.get("metadata", {}).get("tags", []))


def _source(cell: dict) -> str:
    return "".join(cell["source"]) if isinstance(cell["source"], list) else cell["source"]


@pytest.mark.parametrize("path", TUTORIALS, ids=[p.stem for p in TUTORIALS])
def test_at_least_two_checked_exercises(path):
    """docs/tutorials.md's convention: each exercise is a task (tag exercise), a solution (tags solution and
    hide-cell, folded on the site) and a check (tag check) that asserts."""
    cells = _cells(path)
    tasks = [i for i, c in enumerate(cells) if "exercise" in _tags(c)]
    assert len(tasks) >= 2, f"{path.name}: {len(tasks)} exercise(s)"
    for i in tasks:
        task, solution, check = cells[i : i + 3]
        assert task["cell_type"] == "markdown" and _source(task).startswith("### Exercise"), _source(task)[:80]
        assert solution["cell_type"] == "code" and {"solution", "hide-cell"} <= _tags(solution), solution["metadata"]
        assert check["cell_type"] == "code" and "check" in _tags(check), check["metadata"]
        assert _asserts(ast.parse(_source(check))), f"{path.name}: the check of {_source(task)[:40]!r} asserts nothing"
    assert sum("solution" in _tags(c) for c in cells) == len(tasks)  # no solution outside an exercise


def _teacher_command() -> str:
    """The command docs/tutorials.md gives teachers, as written there (one home: the test runs the page's text)."""
    page = (Path(__file__).resolve().parents[1] / "docs" / "tutorials.md").read_text()
    (command,) = [line for line in page.splitlines() if line.startswith("jupyter nbconvert") and "solution" in line]
    return command


def test_teacher_command_removes_the_solutions_and_keeps_the_exercises(tmp_path):
    optional_import("nbconvert", "notebooks")
    source = next(p for p in TUTORIALS if p.stem.startswith("01_"))
    (tmp_path / "tutorials").mkdir()
    (tmp_path / "tutorials" / source.name).write_bytes(source.read_bytes())
    command = _teacher_command().replace("jupyter ", f"{sys.executable} -m jupyter ", 1)
    done = subprocess.run(command, shell=True, cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    before, after = _cells(source), _cells(tmp_path / "handout" / source.name)
    assert any("solution" in _tags(c) for c in before)
    assert not any("solution" in _tags(c) for c in after)
    kept = [c["id"] for c in before if "solution" not in _tags(c)]
    assert [c["id"] for c in after] == kept  # the tasks, the checks and the lesson itself all stay, in order
    assert [_source(c) for c in after] == [_source(c) for c in before if "solution" not in _tags(c)]
