"""``steam-ref homework`` on a teacher's notebook of two tiny exercises: the handout keeps the tasks and the
checks and drops the solutions and the marking checks; the marking run scores a right answer, a wrong one, one
that raises, one that hangs and one that kills its kernel, each exercise on its own, and never stops on a bad
submission; bad input is one line and exit code 2. (The tutorials themselves: tests/test_notebooks.py.)
"""

from __future__ import annotations

import copy
import json
import re
import time
from pathlib import Path

import pytest
from requirements import optional_import

from steam_ref.cli.commands import main
from steam_ref.errors import SteamError
from steam_ref.homework import exercises, handout
from steam_ref.homework.marking import GRACE

LIMIT = 3  # seconds a marked cell may run (--timeout) in the marking test
DEAF = "import signal\nsignal.signal(signal.SIGINT, signal.SIG_IGN)\nwhile True:\n    pass"  # ignores the interrupt


def _cell(kind: str, cid: str, text: str, tags: tuple[str, ...] = ()) -> dict:
    """A cell as a notebook file stores it: its source a list of lines."""
    lines = text.splitlines(keepends=True)
    cell = {"cell_type": kind, "id": cid, "metadata": {"tags": list(tags)} if tags else {}, "source": lines}
    return {**cell, "outputs": [], "execution_count": None} if kind == "code" else cell


def _teacher() -> dict:
    """Exercise 1 asks for a number (its marking check knows it), exercise 2 for a function."""
    cells = [
        _cell("markdown", "intro", "# A tiny lesson"),
        _cell("code", "setup", "base = 3"),
        _cell("markdown", "t1", "### Exercise 1 · Square\n\nStore `base` squared in `square`.", ("exercise",)),
        _cell("code", "s1", "square = base**2", ("solution", "hide-cell")),
        _cell("code", "c1", "assert isinstance(square, int), 'square must be a whole number'", ("check",)),
        _cell("code", "h1", "assert square == 9, 'square is not base times base'", ("hidden-check", "remove-cell")),
        _cell("markdown", "t2", "### Exercise 2 · Cube\n\nWrite `cube(x)`.", ("exercise",)),
        _cell("code", "s2", "def cube(x):\n    return x**3", ("solution", "hide-cell")),
        _cell("code", "c2", "assert cube(0) == 0, 'cube(0) must be 0'", ("check",)),
        _cell(
            "code",
            "h2",
            "assert cube(-2) == -8, 'cube is wrong for a negative number'",
            ("hidden-check", "remove-cell"),
        ),
    ]
    kernel = {"name": "python3", "display_name": "Python 3", "language": "python"}
    return {"cells": cells, "metadata": {"kernelspec": kernel}, "nbformat": 4, "nbformat_minor": 5}


@pytest.fixture
def course(tmp_path):
    """The teacher's folder and the handout made from it by the command."""
    (tmp_path / "teacher").mkdir()
    (tmp_path / "teacher" / "tiny.ipynb").write_text(json.dumps(_teacher()))
    assert main(["homework", "handout", str(tmp_path / "teacher"), "--out", str(tmp_path / "handout")]) == 0
    return tmp_path


def _submit(course: Path, name: str, answers: dict[str, str], added: dict[str, str] | None = None) -> Path:
    """A student's copy of the handout with the answer cells (by their ids) filled in, and a code cell ``added``
    below the cell of each id given."""
    nb = json.loads((course / "handout" / "tiny.ipynb").read_text())
    for cell in nb["cells"]:
        cell["source"] = answers.get(cell["id"], cell["source"])
    for cid, text in (added or {}).items():
        at = next(i for i, c in enumerate(nb["cells"]) if c["id"] == cid)
        nb["cells"].insert(at + 1, _cell("code", f"{cid}-more", text))
    path = course / "submitted" / name / "tiny.ipynb"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(nb))
    return path


def test_the_handout_has_empty_answers_where_the_solutions_were_and_no_marking_check(course):
    nb = json.loads((course / "handout" / "tiny.ipynb").read_text())
    teacher = _teacher()["cells"]
    assert [c["id"] for c in nb["cells"]] == [c["id"] for c in teacher if c["id"] not in ("h1", "h2")]
    answers = [c for c in nb["cells"] if c["id"] in ("s1", "s2")]
    assert [c["metadata"]["tags"] for c in answers] == [["answer"], ["answer"]]
    assert "`square`" in answers[0]["source"] and "`cube`" in answers[1]["source"]  # what the checks read
    assert "base**2" not in json.dumps(nb) and "x**3" not in json.dumps(nb) and "== 9" not in json.dumps(nb)
    kept = {c["id"]: c["source"] for c in teacher}
    assert all(c["source"] == kept[c["id"]] for c in nb["cells"] if c["id"] not in ("s1", "s2"))
    assert nb["metadata"]["steam_ref"]["handout_of"] == "tiny"


def test_a_notebook_off_the_convention_is_refused_naming_the_cell():
    nb = _teacher()
    del nb["cells"][4]  # exercise 1 without its check
    with pytest.raises(SteamError, match=r"tiny.ipynb: exercise 1 \(cell 2\) is not followed by its check"):
        exercises(nb, "tiny.ipynb")
    nb = _teacher()
    nb["cells"][1]["metadata"] = {"tags": ["solution"]}  # a solution outside any exercise
    with pytest.raises(SteamError, match="cell 1 is tagged 'solution' but belongs to no exercise"):
        handout(nb, "tiny.ipynb")


def test_marking_scores_each_exercise_on_its_own_and_never_stops_on_a_bad_submission(course, capsys):
    optional_import("nbclient", "notebooks")
    optional_import("ipykernel", "notebooks")
    cube = "cube = lambda x: x * x * x"
    _submit(course, "right", {"s1": "square = base * base", "s2": cube})
    _submit(course, "wrong", {"s1": "square = 2 * base", "s2": cube})  # passes the check, not the marking check
    _submit(course, "raises", {"s1": "square = 1 // 0", "s2": cube})
    _submit(course, "hangs", {"s1": "while True:\n    pass", "s2": cube})
    _submit(course, "exits", {"s1": "import os\nos._exit(3)", "s2": cube})
    _submit(course, "ignores-the-interrupt", {"s1": DEAF, "s2": cube})
    catches = (
        "while True:\n    try:\n        while True:\n            pass\n    except KeyboardInterrupt:\n        pass"
    )
    _submit(course, "catches-the-interrupt", {"s1": catches, "s2": cube})
    _submit(course, "hangs-twice", {"s1": "while True:\n    pass", "s2": cube}, added={"s1": "while True:\n    pass"})
    _submit(course, "edits-the-check", {"s1": "square = 10", "s2": cube, "c1": "pass", "h1": "pass"})
    _submit(course, "blank", {"s2": cube})  # exercise 1's answer cell left as handed out
    (course / "submitted" / "broken").mkdir()
    (course / "submitted" / "broken" / "tiny.ipynb").write_text('{"cells": [')
    # A cell's limit of 3 s: the test is about what a timeout says and scores, not its length (each passing cell is
    # one line of arithmetic, milliseconds even on a loaded machine); a cell that ignores the interrupt costs 3 s more.
    argv = ["--source", str(course / "teacher"), "--timeout", str(LIMIT), "--jobs", "3", "--json"]
    assert main(["homework", "mark", str(course / "submitted"), *argv]) == 0
    marks = {m["submission"].split("/")[0]: m for m in json.loads(capsys.readouterr().out)["submissions"]}
    got = {name: [(e["score"], e["status"]) for e in m["exercises"]] for name, m in marks.items()}
    assert got == {
        "right": [(1, "passed"), (1, "passed")],
        "wrong": [(0, "failed"), (1, "passed")],
        "raises": [(0, "error"), (1, "passed")],
        "hangs": [(0, "timeout"), (1, "passed")],
        "exits": [(0, "not run"), (0, "not run")],
        "ignores-the-interrupt": [(0, "timeout"), (0, "not run")],  # its kernel is killed: the run ends
        "catches-the-interrupt": [(0, "timeout"), (0, "not run")],
        "hangs-twice": [(0, "timeout"), (1, "passed")],  # two timeouts in a row, each interrupt obeyed: the run goes on
        "edits-the-check": [(0, "failed"), (1, "passed")],  # the teacher's checks run, not the student's copy
        "broken": [(0, "not run"), (0, "not run")],
        "blank": [(0, "no answer"), (1, "passed")],
    }
    assert marks["right"]["score"] == marks["right"]["out_of"] == 2
    said = {name: m["exercises"][0]["message"] for name, m in marks.items()}
    assert said["wrong"] == "marking check: square is not base times base"  # what is wrong, not the value
    assert "ZeroDivisionError" in said["raises"] and f"longer than {LIMIT} s" in said["hangs"]
    for deaf in ("ignores-the-interrupt", "catches-the-interrupt"):
        assert "ignored the interrupt" in said[deaf] and "kernel was killed" in said[deaf], said[deaf]
        after = marks[deaf]["exercises"][1]["message"]
        assert after.startswith("the run stopped: exercise 1's answer ignored the interrupt"), after
    assert said["hangs-twice"] == f"the answer ran longer than {LIMIT} s and was stopped"
    assert "kernel died" in said["exits"] and "not a notebook" in said["broken"] and "no code" in said["blank"]
    assert "9" not in said["wrong"] + said["edits-the-check"]  # the value the marking check knows is never shown


def test_a_cell_that_ignores_the_interrupt_costs_its_limit_and_the_grace_then_its_kernel_is_killed(course, capsys):
    """A submission whose answer ignores SIGINT is marked in a right submission's time (measured just before, in
    the same sitting: the kernel's start under whatever load) plus its cell's limit and GRACE seconds; the report
    names the cell and says why the rest did not run. Before, it waited out a second cell's limit, nbclient's 4 s
    wait for output after each, and a graceful shutdown of the busy kernel: 13.4-13.6 s more than the right one for
    a 2 s limit, against 3.9 s now (two runs each on a loaded 2-core machine)."""
    optional_import("nbclient", "notebooks")
    optional_import("ipykernel", "notebooks")
    limit = 2
    right = _submit(course, "right", {"s1": "square = base * base", "s2": "cube = lambda x: x**3"})
    deaf = _submit(course, "deaf", {"s1": DEAF, "s2": "cube = lambda x: x**3"})
    argv = ["--source", str(course / "teacher"), "--timeout", str(limit), "--json"]
    took, marks = [], []
    for path in (right, deaf):
        began = time.perf_counter()
        assert main(["homework", "mark", str(path), *argv]) == 0
        took.append(time.perf_counter() - began)
        (mark,) = json.loads(capsys.readouterr().out)["submissions"]
        marks.append([(e["score"], e["status"], e["message"]) for e in mark["exercises"]])
    assert marks[0] == [(1, "passed", ""), (1, "passed", "")]
    why = f"the answer ran longer than {limit} s, ignored the interrupt (still running {GRACE} s later)"
    stopped = f"the run stopped: exercise 1's answer ignored the interrupt at its {limit} s limit"
    assert marks[1] == [
        (0, "timeout", f"{why}, and its kernel was killed"),
        (0, "not run", f"{stopped}, so the kernel was killed"),
    ]
    assert took[1] - took[0] < 2 * (limit + GRACE), took  # the limit and the grace, twice over for the load
    page = (Path(__file__).resolve().parents[1] / "docs" / "tutorials.md").read_text()
    assert f"costs its limit plus {GRACE} s" in " ".join(page.split())  # the teachers' page states this bound


def test_the_text_report_has_a_line_per_submission_and_per_exercise(course, capsys):
    optional_import("nbclient", "notebooks")
    optional_import("ipykernel", "notebooks")
    path = _submit(course, "ann", {"s1": "square = 2 * base", "s2": "def cube(x):\n    return x**3"})
    assert main(["homework", "mark", str(path), "--source", str(course / "teacher")]) == 0
    assert capsys.readouterr().out.splitlines() == [
        "tiny.ipynb: tiny, 1/2",
        "  Exercise 1 · Square: 0/1 failed: marking check: square is not base times base",
        "  Exercise 2 · Cube: 1/1",
    ]


def test_bad_input_is_one_line_and_exit_code_2(course, capsys):
    teacher = str(course / "teacher")
    (course / "notes.txt").write_text("not a notebook")
    (course / "empty").mkdir()
    stranger = copy.deepcopy(_teacher())
    (course / "other.ipynb").write_text(json.dumps(stranger))
    (course / "bad.ipynb").write_text("{")
    (course / "linked").mkdir()
    (course / "linked" / "tiny.ipynb").symlink_to(course / "nowhere" / "tiny.ipynb")  # a dangling link
    cases = {
        ("mark", str(course / "missing"), "--source", teacher): "'.*missing' does not exist",
        ("mark", str(course / "notes.txt"), "--source", teacher): "notes.txt' is not a notebook",
        ("mark", str(course / "empty"), "--source", teacher): "holds no notebook",
        ("mark", str(course / "bad.ipynb"), "--source", teacher): "bad.ipynb' is not a notebook: not JSON",
        ("mark", str(course / "other.ipynb"), "--source", teacher): "not a handout of any of the teacher's notebooks",
        ("mark", str(course / "handout"), "--source", str(course / "nowhere")): "nowhere' does not exist",
        ("mark", str(course / "handout"), "--source", str(course / "empty")): "no notebook with exercises",
        ("mark", str(course / "handout"), "--source", teacher, "--timeout", "0"): "--timeout: expected a whole number",
        ("mark", str(course / "handout"), "--source", teacher, "--jobs", "two"): "--jobs: expected a whole number",
        ("handout", str(course / "missing")): "'.*missing' does not exist",
        ("handout", str(course / "other.ipynb"), "--out", ""): "expected a path, got an empty one",
        ("handout", teacher, "--out", teacher): "would overwrite the teacher's notebook",
        ("handout", str(course / "bad.ipynb")): "is not a notebook",
        ("handout", teacher, "--out", str(course / "linked")): "tiny.ipynb' is a link",
    }
    for argv, message in cases.items():
        code = main(["homework", *argv])
        out, err = capsys.readouterr()
        assert code == 2, (argv, out, err)
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, (argv, err)
        assert re.search(message, err), (argv, err)
