"""``steam-ref homework`` on a teacher's notebook of two tiny exercises: the handout keeps the tasks and the
checks and drops the solutions and the marking checks; the marking run scores a right answer, a wrong one, one
that raises, one that hangs and one that kills its kernel, each exercise on its own, and never stops on a bad
submission; bad input is one line and exit code 2. (The tutorials themselves: tests/test_notebooks.py.)
"""

from __future__ import annotations

import copy
import errno
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from processes import clean_up, command_line, descendants, left_running, popen_in_a_terminal_session
from requirements import optional_import

from steam_ref.cli.commands import main
from steam_ref.errors import SteamError
from steam_ref.homework import exercises, handout
from steam_ref.homework.marking import GRACE

LIMIT = 3  # seconds a marked cell may run (--timeout) in the marking test
DEAF = "import signal\nsignal.signal(signal.SIGINT, signal.SIG_IGN)\nwhile True:\n    pass"  # ignores the interrupt


def _cell(kind: str, cid: str, text: str, tags: tuple[str, ...] = (), answers: dict | None = None) -> dict:
    """A cell as a notebook file stores it: its source a list of lines; a solution's ``answers`` their kinds."""
    lines = text.splitlines(keepends=True)
    cell = {"cell_type": kind, "id": cid, "metadata": {"tags": list(tags)} if tags else {}, "source": lines}
    if answers is not None:
        cell["metadata"]["steam_ref"] = {"answers": answers}
    return {**cell, "outputs": [], "execution_count": None} if kind == "code" else cell


def _teacher() -> dict:
    """Exercise 1 asks for a number (its marking check knows it), exercise 2 for a function."""
    cells = [
        _cell("markdown", "intro", "# A tiny lesson"),
        _cell("code", "setup", "base = 3"),
        _cell("markdown", "t1", "### Exercise 1 · Square\n\nStore `base` squared in `square`.", ("exercise",)),
        _cell("code", "s1", "square = base**2", ("solution", "hide-cell"), {"square": "number"}),
        _cell("code", "c1", "assert isinstance(square, int), 'square must be a whole number'", ("check",)),
        _cell("code", "h1", "assert square == 9, 'square is not base times base'", ("hidden-check", "remove-cell")),
        _cell("markdown", "t2", "### Exercise 2 · Cube\n\nWrite `cube(x)`.", ("exercise",)),
        _cell("code", "s2", "def cube(x):\n    return x**3", ("solution", "hide-cell"), {"cube": "function"}),
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


def _marks(capsys) -> dict:
    """The marks ``homework mark --json`` printed, by submission (the name of its folder)."""
    return {m["submission"].split("/")[0]: m for m in json.loads(capsys.readouterr().out)["submissions"]}


def _scores(marks: dict) -> dict:
    """Each submission's (score, status) of every exercise."""
    return {name: [(e["score"], e["status"]) for e in m["exercises"]] for name, m in marks.items()}


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
    marks = _marks(capsys)
    got = _scores(marks)
    assert got == {
        "right": [(1, "passed"), (1, "passed")],
        "wrong": [(0, "failed"), (1, "passed")],
        "raises": [(0, "error"), (1, "passed")],
        "hangs": [(0, "timeout"), (1, "passed")],
        "exits": [(0, "not run"), (0, "not run")],
        "ignores-the-interrupt": [(0, "timeout"), (0, "not run")],  # its kernel is killed: the run ends
        "catches-the-interrupt": [(0, "timeout"), (0, "not run")],
        "hangs-twice": [(0, "timeout"), (1, "passed")],  # the second cell of the answer gets what is left: nothing
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


def test_an_answer_that_binds_the_right_value_then_raises_or_runs_over_its_limit_scores_0(course, capsys):
    """docs/tutorials.md: an answer that raises or runs over its time limit scores 0 for that exercise. An answer
    that bound the right value before it raised (scratch code left below it) or before it hung (a forgotten loop)
    scored its point: an exercise passed when its checks did, whatever its answer's own cells had done."""
    optional_import("nbclient", "notebooks")
    optional_import("ipykernel", "notebooks")
    cube = "cube = lambda x: x**3"
    _submit(course, "then-raises", {"s1": "square = base * base\nraise RuntimeError('not finished')", "s2": cube})
    _submit(course, "then-hangs", {"s1": "square = base * base\nwhile True:\n    pass", "s2": cube})
    _submit(course, "then-raises-in-a-cell-added", {"s1": "square = base * base", "s2": cube}, added={"s1": "1 / 0"})
    argv = ["--source", str(course / "teacher"), "--timeout", str(LIMIT), "--json"]
    assert main(["homework", "mark", str(course / "submitted"), *argv]) == 0
    marks = _marks(capsys)
    got = {name: [(e["score"], e["status"], e["message"]) for e in m["exercises"]] for name, m in marks.items()}
    assert got == {
        "then-raises": [(0, "error", "the answer raised RuntimeError: not finished"), (1, "passed", "")],
        "then-hangs": [(0, "timeout", f"the answer ran longer than {LIMIT} s and was stopped"), (1, "passed", "")],
        "then-raises-in-a-cell-added": [
            (0, "error", "the answer raised ZeroDivisionError: division by zero"),
            (1, "passed", ""),
        ],
    }


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
    os.mkfifo(course / "pipe.ipynb")  # exists, but not a file: said so, not "does not exist", and never read
    cases = {
        ("mark", str(course / "missing"), "--source", teacher): "'.*missing' does not exist",
        ("mark", str(course / "notes.txt"), "--source", teacher): "notes.txt' is not a notebook",
        ("mark", str(course / "empty"), "--source", teacher): "holds no notebook",
        ("mark", str(course / "pipe.ipynb"), "--source", teacher): "pipe.ipynb' is neither a file nor a folder",
        ("mark", str(course / "bad.ipynb"), "--source", teacher): "bad.ipynb' is not a notebook: not JSON",
        ("mark", str(course / "other.ipynb"), "--source", teacher): "not a handout of any of the teacher's notebooks",
        ("mark", str(course / "handout"), "--source", str(course / "nowhere")): "nowhere' does not exist",
        ("mark", str(course / "handout"), "--source", str(course / "empty")): "no notebook with exercises",
        ("mark", str(course / "handout"), "--source", teacher, "--timeout", "0"): "--timeout: expected an integer >= 1",
        # the one rule for numbers as text (choices.parse_decimal): int() read 1_0 as 10
        ("mark", str(course / "handout"), "--source", teacher, "--timeout", "1_0"): "--timeout: expected an integer",
        ("mark", str(course / "handout"), "--source", teacher, "--jobs", "two"): "--jobs: expected an integer > 0",
        ("handout", str(course / "missing")): "'.*missing' does not exist",
        ("handout", str(course / "other.ipynb"), "--out", ""): "expected a path, got an empty path",
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


@pytest.mark.parametrize("odd", ["pipe", "dangling link"])
@pytest.mark.parametrize("command", ["mark", "handout"])
def test_a_folder_holding_a_notebook_name_that_is_no_file_is_not_dropped(course, capsys, odd, command):
    """A folder's ``*.ipynb`` that is a pipe or a link to nothing was left out in silence (a student's submission
    missing from the marks, a teacher's notebook from the handout). Now, unread, a submission scores 0 saying why
    beside the others, marked; a teacher's notebook stops the handout in one line naming it, nothing written."""
    folder = course / "teacher" if command == "handout" else course / "submitted"
    if command == "mark":
        _submit(course, "ann", {"s1": "square = base**2"})
    bad = folder / "late.ipynb"
    if odd == "pipe":
        os.mkfifo(bad)
    else:
        bad.symlink_to(course / "nowhere.ipynb")
    why = "not a file" if odd == "pipe" else "No such file or directory"
    if command == "mark":
        code = main(["homework", "mark", str(folder), "--source", str(course / "teacher"), "--timeout", "60"])
        out, err = capsys.readouterr()
        assert code == 0, err
        assert f"late.ipynb: ?, 0/0 (cannot read '{bad}': {why})" in out.splitlines()
        assert "ann/tiny.ipynb: tiny, 1/2" in out.splitlines(), out
    else:
        code = main(["homework", "handout", str(folder), "--out", str(course / "out")])
        out, err = capsys.readouterr()
        assert (code, out) == (2, "") and len(err.strip().splitlines()) == 1, err
        assert f"cannot read '{bad}': {why}" in err
        assert not (course / "out").exists()


def test_two_notebooks_of_one_name_are_refused_not_one_handout_written_over_the_other(course, capsys):
    """Handouts are named as their notebooks: two teacher's notebooks named tiny.ipynb (in two folders, or given
    twice) made one handout, the last, while the command said "wrote 2 handouts". Now refused, nothing written."""
    other = _teacher()
    other["cells"][0]["source"] = ["# Another lesson"]
    (course / "teacher" / "b").mkdir()
    (course / "teacher" / "b" / "tiny.ipynb").write_text(json.dumps(other))
    a, b = course / "teacher" / "tiny.ipynb", course / "teacher" / "b" / "tiny.ipynb"
    both = f"'{b}' and '{a}' would both be written to '{course / 'out' / 'tiny.ipynb'}'"  # rglob's order: b/ first
    for given, said in (([course / "teacher"], both), ([a, a], f"'{a}' is given twice")):
        code = main(["homework", "handout", *map(str, given), "--out", str(course / "out")])
        out, err = capsys.readouterr()
        assert (code, out) == (2, "") and len(err.strip().splitlines()) == 1 and said in err, err
        assert not (course / "out").exists()


def test_two_submissions_of_one_name_are_refused_not_marked_under_one_name(course, capsys, monkeypatch):
    """``mark ann/ bob/``, each with tiny.ipynb: both were marked and reported as 'tiny.ipynb', which student scored
    what untold; a notebook given twice was marked twice. Now refused as the handout refuses them, before any marking."""
    optional_import("nbclient", "notebooks")
    optional_import("ipykernel", "notebooks")

    def never(*args, **kwargs):
        raise AssertionError("a submission was marked although the input was bad")

    monkeypatch.setattr("steam_ref.homework.command.mark_submission", never)
    ann, bob = (_submit(course, name, {}) for name in ("ann", "bob"))
    clash = f"'{ann}' and '{bob}' would both be reported as 'tiny.ipynb' (give the folder holding both"
    for given, said in (([ann.parent, bob.parent], clash), ([ann.parent, ann], f"'{ann}' is given twice")):
        code = main(["homework", "mark", *map(str, given), "--source", str(course / "teacher")])
        out, err = capsys.readouterr()
        assert (code, out) == (2, "") and len(err.strip().splitlines()) == 1 and f"error: mark: {said}" in err, err


@pytest.mark.parametrize("failure", ["a full disk", "an interrupt"])
def test_a_handout_cut_short_leaves_the_previous_file_and_no_temporary(course, monkeypatch, capsys, failure):
    """The handout's write fails half-way (``Path.write_text`` writes half the text, then raises): it was written in
    place, leaving half a handout and losing the one there. Now the handout there is as it was, no temporary is
    left, and the command answers in one line: exit code 2 naming --out and the file, or 130 for an interrupt."""
    previous = (course / "handout" / "tiny.ipynb").read_bytes()
    raised = OSError(errno.ENOSPC, os.strerror(errno.ENOSPC)) if failure == "a full disk" else KeyboardInterrupt()
    write_text = Path.write_text

    def half_then_fail(self, data, *args, **kwargs):
        write_text(self, data[: len(data) // 2], *args, **kwargs)
        raise raised

    monkeypatch.setattr(Path, "write_text", half_then_fail)
    code = main(["homework", "handout", str(course / "teacher"), "--out", str(course / "handout")])
    monkeypatch.undo()
    out, err = capsys.readouterr()
    assert (course / "handout" / "tiny.ipynb").read_bytes() == previous
    assert sorted(os.listdir(course / "handout")) == ["tiny.ipynb"]
    assert out == "" and len(err.strip().splitlines()) == 1, err
    if failure == "a full disk":
        assert code == 2 and f"--out: cannot write '{course / 'handout' / 'tiny.ipynb'}'" in err, err
        assert os.strerror(errno.ENOSPC) in err and "what was there is left as it was" in err, err
    else:
        assert code == 130 and "interrupted" in err, err


MALFORMED = {
    "a cell's metadata null": lambda nb: nb["cells"][3].__setitem__("metadata", None),
    "a cell's tags null": lambda nb: nb["cells"][3]["metadata"].__setitem__("tags", None),
    "a cell's tags one string": lambda nb: nb["cells"][3]["metadata"].__setitem__("tags", "answer"),
    "a cell's source lines not text": lambda nb: nb["cells"][3].__setitem__("source", [1, 2]),
    "the notebook's metadata a list": lambda nb: nb.__setitem__("metadata", []),
}


@pytest.mark.parametrize("kind", MALFORMED)
def test_a_submission_off_nbformat_scores_0_saying_why_and_never_stops_the_marking(course, capsys, kind):
    """A notebook whose JSON parses but whose cells are not nbformat 4's (a student's editor or a hand edit:
    metadata null, tags not a list of strings, source lines that are not text) is "not a notebook": given on
    the command line, one line and exit code 2; in a folder, it scores 0 saying why, and the marking goes on.
    Before, the marker read it and died with a traceback (AttributeError, TypeError), marking no one."""
    nb = json.loads((course / "handout" / "tiny.ipynb").read_text())
    assert nb["cells"][3]["id"] == "s1"  # the answer cell the cases break
    MALFORMED[kind](nb)
    path = course / "submitted" / "odd" / "tiny.ipynb"
    path.parent.mkdir(parents=True)
    path.write_text(json.dumps(nb))
    assert main(["homework", "mark", str(path), "--source", str(course / "teacher")]) == 2, kind
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, (kind, err)
    assert "tiny.ipynb' is not a notebook" in err, (kind, err)
    from steam_ref.homework.marking import load_tutorials, mark_submission

    mark = mark_submission(path, "odd/tiny.ipynb", load_tutorials(course / "teacher"), timeout=LIMIT)
    assert mark.tutorial == "tiny" and mark.score == 0 and "is not a notebook" in (mark.error or ""), (kind, mark)
    assert [e.status for e in mark.exercises] == ["not run", "not run"], (kind, mark)


def test_a_teachers_notebook_off_the_form_is_one_line_and_exit_code_2(tmp_path, capsys):
    """A task tagged with one string, not a list, went unseen (its solution then "belongs to no exercise", or with
    every tag a string, the handout kept the solution); a ``steam_ref`` metadata entry that is not an object
    stopped the handout with a TypeError."""
    tags_string, metadata_string = _teacher(), _teacher()
    tags_string["cells"][2]["metadata"]["tags"] = "exercise"
    metadata_string["metadata"]["steam_ref"] = "tiny"
    cases = {
        "tags": (tags_string, "tiny.ipynb' is not a notebook: cell 2's tags are not a list of strings"),
        "metadata": (metadata_string, "tiny.ipynb: its metadata 'steam_ref' is not an object"),
    }
    for kind, (nb, message) in cases.items():
        (tmp_path / kind).mkdir()
        (tmp_path / kind / "tiny.ipynb").write_text(json.dumps(nb))
        code = main(["homework", "handout", str(tmp_path / kind), "--out", str(tmp_path / kind / "out")])
        err = capsys.readouterr().err
        assert code == 2 and len(err.strip().splitlines()) == 1 and message in err, (kind, err)


def _teacher_reading_the_lesson() -> dict:
    """Marking checks that read the lesson, as the tutorials' do (a helper like chi2_band, a value like qc, an
    array, a builtin): exercise 1 asks for ``power(base, 2)``, exercise 2 for a cube at the lesson's points."""
    nb = _teacher()
    nb["cells"][1] = _cell(
        "code",
        "setup",
        "import numpy as np\nbase = 3\npoints = np.array([-2.0, 0.5])\n\n\ndef power(x, k):\n    return x**k",
    )
    nb["cells"][5] = _cell(
        "code", "h1", "assert abs(square - power(base, 2)) < 1e-12, 'square is not base squared'", ("hidden-check",)
    )
    nb["cells"][9] = _cell(
        "code", "h2", "assert np.allclose(cube(points), power(points, 3)), 'cube is wrong'", ("hidden-check",)
    )
    return nb


def _mark_the_lesson_readers(tmp_path: Path, capsys, submissions: dict[str, dict[str, str]]) -> dict[str, dict]:
    """Hand out :func:`_teacher_reading_the_lesson`, submit each student's answers (by answer cell id), mark them all
    and return each student's mark as ``--json`` gives it."""
    optional_import("nbclient", "notebooks")
    optional_import("ipykernel", "notebooks")
    (tmp_path / "teacher").mkdir()
    (tmp_path / "teacher" / "tiny.ipynb").write_text(json.dumps(_teacher_reading_the_lesson()))
    assert main(["homework", "handout", str(tmp_path / "teacher"), "--out", str(tmp_path / "handout")]) == 0
    capsys.readouterr()
    for name, answers in submissions.items():
        _submit(tmp_path, name, answers)
    argv = ["--source", str(tmp_path / "teacher"), "--timeout", "60", "--jobs", "2", "--json"]
    assert main(["homework", "mark", str(tmp_path / "submitted"), *argv]) == 0
    return _marks(capsys)


def test_an_answer_that_rebinds_a_name_the_marking_reads_scores_0_and_the_next_exercise_is_marked_fairly(
    tmp_path, capsys
):
    """The marking checks compare an answer with the lesson's own names (tutorial 09's chi2_band, 00's qc): an
    answer that rebinds one would make the check compare the answer with itself. A wrong square with its own
    wrong ``power`` (tutorial 09: a student's own chi2_band giving a 90 % band) scored full marks, and the right
    cube of exercise 2 then lost its point to the student's ``power``; rebinding ``base``, changing ``points``
    in place or shadowing the builtin ``abs`` passed a wrong answer too. Now each scores 0 naming the name, the
    lesson's value is put back, and exercise 2 is marked against it; an equal value bound again (``base = 3``, a
    second ``import numpy as np``) changes nothing."""
    cube = "import numpy as np\n\n\ndef cube(x):\n    return x**3"
    submissions = {
        "right": {"s1": "base = 3\nsquare = base * base", "s2": cube},
        "own-helper": {"s1": "def power(x, k):\n    return x * k\n\n\nsquare = power(base, 2)", "s2": cube},
        "rebinds": {"s1": "base = 4\nsquare = base * base", "s2": cube},
        "mutates": {"s1": "square = 9", "s2": "points[:] = 0.0\ncube = lambda x: x * x"},
        "shadows-a-builtin": {"s1": "abs = lambda x: 0\nsquare = 10", "s2": cube},
    }
    marks = _mark_the_lesson_readers(tmp_path, capsys, submissions)
    got = _scores(marks)
    assert got == {
        "right": [(1, "passed"), (1, "passed")],
        "own-helper": [(0, "failed"), (1, "passed")],
        "rebinds": [(0, "failed"), (1, "passed")],
        "mutates": [(1, "passed"), (0, "failed")],
        "shadows-a-builtin": [(0, "failed"), (1, "passed")],
    }, got
    said = {name: [e["message"] for e in m["exercises"] if e["score"] == 0] for name, m in marks.items()}
    for name, rebound in (
        ("own-helper", "power"),
        ("rebinds", "base"),
        ("mutates", "points"),
        ("shadows-a-builtin", "abs"),
    ):
        (message,) = said[name]
        assert f"the answer rebinds `{rebound}`" in message and "another name" in message, (name, message)
        assert not re.search(r"\d", message), message  # what is wrong, never a value


def _teacher_of_an_estimate() -> dict:
    """A lesson whose object holds arrays (as tutorial 00's ``batch.values`` holds the estimates): exercise 1 asks for a
    function ``twice`` and the estimate doubled, exercise 2 for the sum of the estimate."""
    setup = (
        "import numpy as np\nfrom types import SimpleNamespace\n\n"
        "estimate = SimpleNamespace(values={'x0': np.array([1.0, 2.0])})"
    )
    hidden1 = (
        "assert np.allclose(twice(np.array([1.0, -3.0])), [2.0, -6.0], rtol=0, atol=0), 'twice is not 2 x'\n"
        "assert np.allclose(doubled, 2 * estimate.values['x0'], rtol=0, atol=0), 'doubled is not twice the estimate'"
    )
    cells = [
        _cell("code", "setup", setup),
        _cell("markdown", "t1", "### Exercise 1 · Twice\n\nWrite `twice(x)`; store `doubled`.", ("exercise",)),
        _cell(
            "code",
            "s1",
            "def twice(x):\n    return 2 * x\n\n\ndoubled = twice(estimate.values['x0'])",
            ("solution", "hide-cell"),
            {"twice": "function", "doubled": "array"},
        ),
        _cell(
            "code", "c1", "assert np.shape(twice(estimate.values['x0'])) == (2,), 'twice keeps the shape'", ("check",)
        ),
        _cell("code", "h1", hidden1, ("hidden-check", "remove-cell")),
        _cell("markdown", "t2", "### Exercise 2 · Total\n\nStore the sum of the estimate in `total`.", ("exercise",)),
        _cell(
            "code", "s2", "total = float(estimate.values['x0'].sum())", ("solution", "hide-cell"), {"total": "number"}
        ),
        _cell("code", "c2", "assert isinstance(total, float), 'total is a float'", ("check",)),
        _cell(
            "code", "h2", "assert total == 3.0, 'total is not the sum of the estimate'", ("hidden-check", "remove-cell")
        ),
    ]
    kernel = {"name": "python3", "display_name": "Python 3", "language": "python"}
    return {"cells": cells, "metadata": {"kernelspec": kernel}, "nbformat": 4, "nbformat_minor": 5}


def test_a_function_that_changes_an_array_the_lesson_holds_costs_its_own_exercise_not_a_later_one(tmp_path, capsys):
    """An answer whose function changes its argument in place, called on an array an object of the lesson holds (tutorial
    00: a prior_error that did ``x_prev[:3] += dt * x_prev[3:]`` on ``batch.values[X(i)]``), changed the lesson's
    estimate: the guard kept the lesson's names and its top-level arrays only, so exercise 2's right answer, read off
    the changed estimate, scored 0 (tutorial 00's exercise 3 lost its point so). Now the arrays the lesson's objects
    hold are kept around each answer and its checks and put back, and the answer's own exercise scores 0, naming the
    object, whether the answer itself (``doubled = twice(...)``) or a check calling its function changed them."""
    optional_import("nbclient", "notebooks")
    optional_import("ipykernel", "notebooks")
    (tmp_path / "teacher").mkdir()
    (tmp_path / "teacher" / "tiny.ipynb").write_text(json.dumps(_teacher_of_an_estimate()))
    assert main(["homework", "handout", str(tmp_path / "teacher"), "--out", str(tmp_path / "handout")]) == 0
    capsys.readouterr()
    total = "total = float(estimate.values['x0'].sum())"
    in_place = "def twice(x):\n    x *= 2\n    return x\n\n\n"
    submissions = {
        "right": {"s1": "def twice(x):\n    return 2 * x\n\n\ndoubled = twice(estimate.values['x0'])", "s2": total},
        "changes-it-in-the-answer": {"s1": in_place + "doubled = twice(estimate.values['x0'])", "s2": total},
        "changes-it-in-the-check": {"s1": in_place + "doubled = 2 * estimate.values['x0']", "s2": total},
    }
    for name, answers in submissions.items():
        _submit(tmp_path, name, answers)
    argv = ["--source", str(tmp_path / "teacher"), "--timeout", "60", "--jobs", "2", "--json"]
    assert main(["homework", "mark", str(tmp_path / "submitted"), *argv]) == 0
    marks = _marks(capsys)
    got = _scores(marks)
    assert got == {
        "right": [(1, "passed"), (1, "passed")],
        "changes-it-in-the-answer": [(0, "failed"), (1, "passed")],
        "changes-it-in-the-check": [(0, "failed"), (1, "passed")],
    }, got
    said = marks["changes-it-in-the-answer"]["exercises"][0]["message"]
    assert said.startswith("the answer changes in place an array held by `estimate`"), said


def test_an_answer_that_sets_a_modules_function_the_marking_calls_scores_0_and_it_is_put_back(tmp_path, capsys):
    """An answer could set an attribute of a module the marking checks call (``np.allclose = lambda *a, **k:
    True``, ``builtins.abs = ...``) instead of rebinding a name: the guard kept only names, so the patch stood for the
    rest of the run and every later marking check passed, a wrong cube (x², 4 at -2 where x³ is -8) scoring full
    marks. Now the answer that sets it scores 0 naming it, and the lesson's function is put back for the checks
    after it."""
    wrong_cube = "def cube(x):\n    return x * x"  # x² is x³ at 0 (the check) and wrong at -2 (the marking check)
    submissions = {
        "patches-numpy": {"s1": "import numpy\nnumpy.allclose = lambda *a, **k: True\nsquare = 9", "s2": wrong_cube},
        "patches-a-builtin": {"s1": "import builtins\nbuiltins.abs = lambda x: 0\nsquare = 10", "s2": wrong_cube},
    }
    marks = _mark_the_lesson_readers(tmp_path, capsys, submissions)
    got = _scores(marks)
    assert got == {name: [(0, "failed"), (0, "failed")] for name in submissions}, got
    for name, patched in (("patches-numpy", "np.allclose"), ("patches-a-builtin", "builtins.abs")):
        first, second = (e["message"] for e in marks[name]["exercises"])
        said = f"the answer sets `{patched}`, which the marking checks call (put back for them): leave it as it is"
        assert said in first, (name, first)  # not "give yours another name": it set the module's own
        assert "cube is wrong" in second, (name, second)  # the lesson's np.allclose back for the cube's check


# Each case: the kind an exercise asks for, the right value, an answer holding it in some type, and what the marking
# says of that type (None: accepted). The marking check reads any of them as the right numbers (``close`` below), so
# before the kinds were checked every one scored its point.
ODD_TYPES = {
    "an int": ("number", "9", "9", None),
    "a float": ("number", "9", "9.0", None),
    "a NumPy float": ("number", "9", "np.float64(9)", None),
    "a NumPy int": ("number", "9", "np.int64(9)", None),
    "a NumPy float32": ("number", "9", "np.float32(9)", None),
    "a 0-d array": ("number", "9", "np.array(9.0)", None),
    "a complex number": ("number", "9", "9 + 0j", "a complex"),
    "a NumPy complex": ("number", "9", "np.complex128(9)", "a numpy.complex128"),
    "a bool": ("number", "1", "True", "a bool"),
    "a NumPy bool": ("number", "1", "np.bool_(True)", "a numpy.bool"),
    "a string of a number": ("number", "9", "'9'", "a str"),
    "a Fraction": ("number", "9", "Fraction(9)", "a fractions.Fraction"),
    "a Decimal": ("number", "9", "Decimal(9)", "a decimal.Decimal"),
    "a one-element array": ("number", "9", "np.array([9.0])", "a numpy.ndarray of dtype float64"),
    "a masked number": ("number", "9", "np.ma.masked_array(9.0)", "a numpy.ma.MaskedArray of dtype float64"),
    "a list of floats": ("array", "[1.0, 0.0, 2.0]", "[1.0, 0.0, 2.0]", None),
    "a list of ints": ("array", "[1.0, 0.0, 2.0]", "[1, 0, 2]", None),
    "a tuple of NumPy floats": ("array", "[1.0, 0.0, 2.0]", "tuple(np.array([1.0, 0.0, 2.0]))", None),
    "a float array": ("array", "[1.0, 0.0, 2.0]", "np.array([1.0, 0.0, 2.0])", None),
    "an int array": ("array", "[1.0, 0.0, 2.0]", "np.array([1, 0, 2])", None),
    "a float32 array": ("array", "[1.0, 0.0, 2.0]", "np.array([1, 0, 2], dtype=np.float32)", None),
    "a list of arrays": ("array", "[[1.0, 0.0], [2.0, 3.0]]", "[np.array([1.0, 0.0]), np.array([2.0, 3.0])]", None),
    "a complex array": (
        "array",
        "[1.0, 0.0, 2.0]",
        "np.array([1, 0, 2], dtype=complex)",
        "a numpy.ndarray of dtype complex128",
    ),
    "an object array": (
        "array",
        "[1.0, 0.0, 2.0]",
        "np.array([1.0, 0.0, 2.0], dtype=object)",
        "a numpy.ndarray of dtype object",
    ),
    "a bool array": ("array", "[1.0, 0.0, 1.0]", "np.array([True, False, True])", "a numpy.ndarray of dtype bool"),
    "a string array": ("array", "[1.0, 0.0, 2.0]", "np.array(['1', '0', '2'])", "a numpy.ndarray of dtype <U1"),
    "a masked array": ("array", "[1.0, 0.0, 2.0]", "np.ma.masked_array([1.0, 0.0, 2.0])", "a numpy.ma.MaskedArray"),
    "a matrix": ("array", "[1.0, 0.0, 2.0]", "np.matrix([1.0, 0.0, 2.0])", "a numpy.matrix of dtype float64"),
    "a list of strings": ("array", "[1.0, 0.0, 2.0]", "['1', '0', '2']", "a list holding a str"),
    "a list holding a complex": ("array", "[1.0, 0.0, 2.0]", "[1.0, 0j, 2.0]", "a list holding a complex"),
    "a list holding a bool": ("array", "[1.0, 0.0, 1.0]", "[1.0, 0.0, True]", "a list holding a bool"),
    "a number for an array": ("array", "[2.0, 2.0]", "2.0", "a float"),
    "a ragged list": (
        "array",
        "[[1.0, 0.0], [2.0, 3.0]]",
        "[[1.0, 0.0], [2.0]]",
        "a list of rows of different lengths",
    ),
    # numbers each, but NumPy's array of them is of objects: it was said to be "of rows of different lengths"
    "a list holding an int past 64 bits": (
        "array",
        "[2.0**70, 0.0, 2.0]",
        "[2**70, 0, 2]",
        "a list that NumPy reads as an array of dtype object",
    ),
    "a function": ("function", "8", "lambda x: x**3", None),
    "a partial": ("function", "8", "partial(pow, exp=3)", None),
    "a class": ("function", "8", "type('Cube', (float,), {'__new__': lambda c, x: float.__new__(c, x**3)})", "a type"),
}


def _teacher_of_every_kind() -> dict:
    """An exercise per case of ODD_TYPES: store the right value (call it at 2, for a function) in ``a<k>``."""
    lesson = (
        "import numpy as np\nfrom decimal import Decimal\nfrom fractions import Fraction\nfrom functools import partial"
        "\n\n\ndef close(x, want):\n    try:\n        return bool(np.allclose(np.array(x, dtype=float), want))\n"
        "    except (TypeError, ValueError):\n        return bool(np.allclose(x, want))"
    )
    cells = [_cell("code", "setup", lesson)]
    for k, (kind, right, _, _) in enumerate(ODD_TYPES.values()):
        read = f"a{k}(2.0)" if kind == "function" else f"a{k}"
        cells += [
            _cell("markdown", f"t{k}", f"### Exercise {k + 1} · {kind}", ("exercise",)),
            _cell("code", f"s{k}", f"a{k} = {right}", ("solution", "hide-cell"), {f"a{k}": kind}),
            _cell("code", f"c{k}", f"assert {read} is not None, 'a{k} is none'", ("check",)),
            _cell("code", f"h{k}", f"assert close({read}, {right}), 'a{k} is wrong'", ("hidden-check",)),
        ]
    return {**_teacher(), "cells": cells}


def test_an_answer_of_another_type_than_its_kind_scores_0_naming_both_types(tmp_path, capsys):
    """A complex array whose imaginary part is 0, an object, bool or string array, a masked array, a matrix, a
    string that reads as the number, a bool for 1: each compares equal to the right answer, so each scored its
    point. Now an answer is checked against the kind its solution declares (homework.kinds): a list or tuple of
    numbers for an array, any int or float (Python's or NumPy's) for a number and any callable for a function are
    taken; every other type scores 0, the message naming the type received and the kind asked for."""
    optional_import("nbclient", "notebooks")
    optional_import("ipykernel", "notebooks")
    (tmp_path / "teacher").mkdir()
    (tmp_path / "teacher" / "kinds.ipynb").write_text(json.dumps(_teacher_of_every_kind()))
    assert main(["homework", "handout", str(tmp_path / "teacher"), "--out", str(tmp_path / "handout")]) == 0
    nb = json.loads((tmp_path / "handout" / "kinds.ipynb").read_text())
    answers = {f"s{k}": f"a{k} = {given}" for k, (_, _, given, _) in enumerate(ODD_TYPES.values())}
    for cell in nb["cells"]:
        cell["source"] = answers.get(cell["id"], cell["source"])
    (tmp_path / "kinds.ipynb").write_text(json.dumps(nb))
    capsys.readouterr()
    argv = ["--source", str(tmp_path / "teacher"), "--timeout", "60", "--json"]
    assert main(["homework", "mark", str(tmp_path / "kinds.ipynb"), *argv]) == 0
    (mark,) = json.loads(capsys.readouterr().out)["submissions"]
    assert len(mark["exercises"]) == len(ODD_TYPES)
    expected = {"number": "a real number (an int or a float)", "function": "a function"}
    expected["array"] = "an array of real numbers (a NumPy array of ints or floats, or a list or tuple of numbers)"
    for k, (case, (kind, _, _, received), e) in enumerate(
        zip(ODD_TYPES, ODD_TYPES.values(), mark["exercises"], strict=True)
    ):
        if received is None:
            assert (e["score"], e["status"]) == (1, "passed"), (case, e)
        else:
            assert (e["score"], e["status"]) == (0, "failed"), (case, e)
            said = f"the answer's type is not the one asked for: `a{k}` is {received}"
            assert e["message"].startswith(said) and e["message"].endswith(f", not {expected[kind]}"), (case, e)


def test_a_solution_that_declares_no_kind_for_an_answer_is_one_line_and_exit_code_2(tmp_path, capsys):
    """The kind each answer must be is the teacher's to say (homework.kinds): a solution that declares none, an
    unknown kind or a kind for a name that is no answer stops the handout and the marking, naming the cell."""
    cases = {
        "none": (lambda meta: meta.pop("steam_ref"), "exercise 1's solution (cell 3) declares no kind for its answers"),
        "unknown": (
            lambda meta: meta["steam_ref"]["answers"].__setitem__("square", "integer"),
            "declares 'square' of kind 'integer': not one of number, array",
        ),
        "not a name": (  # a list is unhashable: `kind in KINDS` raised TypeError, a traceback
            lambda meta: meta["steam_ref"]["answers"].__setitem__("square", ["number"]),
            "declares 'square' of kind ['number']: not one of number, array",
        ),
        "stray": (
            lambda meta: meta["steam_ref"]["answers"].__setitem__("base", "number"),
            "declares a kind for 'base', no answer",
        ),
        "missing": (lambda meta: meta["steam_ref"].__setitem__("answers", {}), "declares no kind for square"),
    }
    for kind, (change, message) in cases.items():
        nb = _teacher()
        change(nb["cells"][3]["metadata"])
        (tmp_path / kind).mkdir()
        (tmp_path / kind / "tiny.ipynb").write_text(json.dumps(nb))
        for argv in (["handout", str(tmp_path / kind), "--out", str(tmp_path / kind / "out")],
                     ["mark", str(tmp_path / kind), "--source", str(tmp_path / kind)]):  # fmt: skip
            code = main(["homework", *argv])
            err = capsys.readouterr().err
            assert code == 2 and len(err.strip().splitlines()) == 1 and message in err, (kind, argv, err)


def test_a_notebook_over_the_size_limit_is_refused_unread_naming_its_size_and_the_limit(course, capsys):
    """A 2 GB file was read whole into memory before anything looked at it, and a notebook with one huge output was
    marked as it was. Now a notebook over MAX_BYTES (20 MiB) is refused from its size alone: given on the command
    line, one line and exit code 2 naming the file, its size and the limit; in a folder, it scores 0 saying so."""
    from steam_ref.homework.exercises import MAX_BYTES, read_notebook
    from steam_ref.homework.marking import load_tutorials, mark_submission

    huge = course / "huge" / "tiny.ipynb"
    huge.parent.mkdir()
    with huge.open("wb") as file:
        file.truncate(2 * 2**30)  # 2 GiB, sparse: nothing is written, and nothing must be read
    over = json.loads((course / "handout" / "tiny.ipynb").read_text())
    output = {"output_type": "stream", "name": "stdout", "text": "x" * MAX_BYTES}
    over["cells"][3]["outputs"] = [output]  # a right answer, but an output cell of 20 MiB
    over["cells"][3]["source"] = "square = base**2\nprint('x' * 20 * 2**20)"
    printed = course / "printed" / "tiny.ipynb"
    printed.parent.mkdir()
    printed.write_text(json.dumps(over))
    for path in (huge, printed):
        size = path.stat().st_size
        said = f"{str(path)!r} is {size:,} bytes, over the {MAX_BYTES:,}-byte limit for a notebook"
        assert main(["homework", "mark", str(path), "--source", str(course / "teacher")]) == 2, path
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and said in err, err
        with pytest.raises(SteamError) as raised:
            read_notebook(path)
        assert said in str(raised.value)
        mark = mark_submission(path, "tiny.ipynb", load_tutorials(course / "teacher"), timeout=LIMIT)
        assert mark.score == 0 and said in (mark.error or ""), mark
    at_limit = json.loads(printed.read_text())
    at_limit["cells"][3]["outputs"][0]["text"] = "x" * (MAX_BYTES - 2 * 2**10)  # just under: read as before
    printed.write_text(json.dumps(at_limit))
    assert MAX_BYTES - 2**12 < printed.stat().st_size <= MAX_BYTES
    assert read_notebook(printed)["cells"][3]["outputs"][0]["text"] == at_limit["cells"][3]["outputs"][0]["text"]


@pytest.mark.parametrize("depth", [101, 200_000])
def test_a_notebook_nested_too_deeply_is_refused_in_one_line(course, capsys, depth):
    """JSON nested 200,000 deep (a few hundred KB) stopped the marker with a RecursionError traceback; nested 101
    deep it was marked, copied and sent to a kernel. Now either is "not a notebook" (MAX_DEPTH levels at most), one
    line and exit code 2 given on the command line, and a 0 saying why in a folder."""
    from steam_ref.homework.exercises import MAX_DEPTH
    from steam_ref.homework.marking import load_tutorials, mark_submission

    assert MAX_DEPTH == 100
    text = (course / "handout" / "tiny.ipynb").read_text()
    nb = json.loads(text)
    nb["cells"][3]["metadata"]["deep"] = "@"
    # the cell's metadata is 4 levels down (notebook, cells, cell, metadata): the rest nests to ``depth`` in all
    nested = "[" * (depth - 4) + "]" * (depth - 4)
    path = course / "deep" / "tiny.ipynb"
    path.parent.mkdir()
    path.write_text(json.dumps(nb).replace('"@"', nested))
    assert main(["homework", "mark", str(path), "--source", str(course / "teacher")]) == 2
    err = capsys.readouterr().err
    said = f"tiny.ipynb' is not a notebook: its JSON is nested deeper than {MAX_DEPTH} levels"
    assert len(err.strip().splitlines()) == 1 and said in err and "Traceback" not in err, err
    mark = mark_submission(path, "tiny.ipynb", load_tutorials(course / "teacher"), timeout=LIMIT)
    assert mark.score == 0 and said in (mark.error or ""), mark
    path.write_text(json.dumps(nb).replace('"@"', "[" * (MAX_DEPTH - 4) + "]" * (MAX_DEPTH - 4)))
    assert main(["homework", "mark", str(path), "--source", str(course / "teacher"), "--timeout", "60"]) == 0


def test_a_notebook_holding_a_number_of_5000_digits_is_refused_in_one_line(course, capsys):
    """Python converts an integer of at most 4300 digits: json.loads raised a plain ValueError (not a JSONDecodeError)
    on one of 5000, a traceback from mark and handout, and in a folder it stopped the marking of every submission.
    Now it is "not a notebook", one line and exit code 2 on the command line, a 0 saying why in a folder."""
    from steam_ref.homework.marking import load_tutorials, mark_submission

    nb = json.loads((course / "handout" / "tiny.ipynb").read_text())
    nb["cells"][3]["metadata"]["n"] = "@"
    path = course / "long" / "tiny.ipynb"
    path.parent.mkdir()
    path.write_text(json.dumps(nb).replace('"@"', "9" * 5000))
    said = f"{str(path)!r} is not a notebook: Exceeds the limit (4300 digits) for integer string conversion"
    for argv in (["mark", str(path), "--source", str(course / "teacher")], ["handout", str(path)]):
        assert main(["homework", *argv]) == 2, argv
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and said in err and "Traceback" not in err, err
    mark = mark_submission(path, "tiny.ipynb", load_tutorials(course / "teacher"), timeout=LIMIT)
    assert mark.score == 0 and said in (mark.error or ""), mark


def test_an_answer_of_many_cells_shares_one_time_limit(course, capsys):
    """``--timeout`` limited each cell, so an answer of many cells could run the limit once per cell: 8 cells that
    loop for ever took 8 limits (24 s at 3 s; 100 such cells, at the default 300 s, 8 hours), and 8 cells of a second
    each then the right value ran to the end and passed, over a 3 s limit. Now an exercise's answer cells share its limit: each gets what the ones
    before it left, and once it is spent the rest do not run; the run goes on to the next exercise. Timed against a
    right submission marked just before, in the same sitting (the kernel's start under whatever load)."""
    optional_import("nbclient", "notebooks")
    optional_import("ipykernel", "notebooks")
    cube = "cube = lambda x: x**3"
    right = _submit(course, "right", {"s1": "square = base * base", "s2": cube})
    many = _submit(course, "many", {"s1": "while True:\n    pass", "s2": cube})
    nb = json.loads(many.read_text())
    at = next(i for i, c in enumerate(nb["cells"]) if c["id"] == "s1")
    nb["cells"][at + 1 : at + 1] = [_cell("code", f"more-{k}", "while True:\n    pass") for k in range(7)]
    many.write_text(json.dumps(nb))
    slow = _submit(course, "slow", {"s1": "import time\n\ntime.sleep(1)", "s2": cube})  # right, but at its end
    nb = json.loads(slow.read_text())
    at = next(i for i, c in enumerate(nb["cells"]) if c["id"] == "s1")
    naps = [_cell("code", f"nap-{k}", "time.sleep(1)") for k in range(7)]
    nb["cells"][at + 1 : at + 1] = [*naps, _cell("code", "last", "square = base * base")]
    slow.write_text(json.dumps(nb))
    argv = ["--source", str(course / "teacher"), "--timeout", str(LIMIT), "--json"]
    took, marks = [], []
    for path in (right, many, slow):
        began = time.perf_counter()
        assert main(["homework", "mark", str(path), *argv]) == 0
        took.append(time.perf_counter() - began)
        (mark,) = json.loads(capsys.readouterr().out)["submissions"]
        marks.append([(e["score"], e["status"], e["message"]) for e in mark["exercises"]])
    stopped = (0, "timeout", f"the answer ran longer than {LIMIT} s and was stopped")
    assert marks == [[(1, "passed", ""), (1, "passed", "")], [stopped, (1, "passed", "")], [stopped, (1, "passed", "")]]
    assert took[1] - took[0] < 2 * (LIMIT + GRACE) and took[2] - took[0] < 2 * (LIMIT + GRACE), took


def test_the_kind_check_cell_is_made_without_parsing_so_marking_threads_cannot_race_in_the_ast(monkeypatch):
    """Submissions are marked in threads, and CPython 3.11's ``ast.parse`` is not safe there (a run of this suite
    stopped two markings with ``SystemError: AST constructor recursion depth mismatch``): the check cell is the
    rule's source as written, its types in comments, which a kernel that lacks ``Any`` (or where a student rebound
    ``str``) runs as it is."""
    import ast

    from steam_ref.homework import kinds

    def no_parsing(*args, **kwargs):
        raise AssertionError("check_cell parsed source")

    monkeypatch.setattr(ast, "parse", no_parsing)
    cell = kinds.check_cell({"answer": "number", "values": "array"})
    scope: dict = {"answer": 3.0, "values": [1.0, 2.0], "str": None}  # a kernel without Any, str rebound
    exec(compile(cell, "<check>", "exec"), scope)
    assert not any(name.startswith("__steam_ref") for name in scope)
    scope = {"answer": 1 + 0j}
    with pytest.raises(AssertionError, match=r"`answer` is a complex, not a real number"):
        exec(compile(cell, "<check>", "exec"), scope)


def test_mark_csv_writes_a_grade_book_row_per_submission_with_each_exercises_points(course, capsys):
    """``--csv`` writes the marks as a grade book, one row per submission (its score and each exercise's points),
    replacing a file there whole; the rows are what the exercises' own answers give: base squared and a cube."""
    optional_import("nbclient", "notebooks")
    optional_import("ipykernel", "notebooks")
    cube = "cube = lambda x: x * x * x"
    _submit(course, "ann", {"s1": "square = base * base", "s2": cube})
    _submit(course, "bob", {"s1": "square = 2 * base", "s2": "cube = lambda x: x * x"})
    book = course / "grades.csv"
    book.write_text("last term's grades\n")
    argv = ["--source", str(course / "teacher"), "--timeout", "60", "--csv", str(book)]
    assert main(["homework", "mark", str(course / "submitted"), *argv]) == 0
    assert f"grade book written to {book.resolve()}" in capsys.readouterr().out.splitlines()
    import csv

    rows = {r["submission"].split("/")[0]: r for r in csv.DictReader(book.read_text().splitlines())}
    assert set(rows) == {"ann", "bob"}
    got = {name: (r["score"], r["out_of"], r["exercise 1"], r["exercise 2"]) for name, r in rows.items()}
    assert got == {"ann": ("2", "2", "1", "1"), "bob": ("0", "2", "0", "0")}
    assert rows["ann"]["lost"] == "" and rows["bob"]["lost"].startswith("exercise 1 failed: marking check: square is")
    assert "exercise 2 failed" in rows["bob"]["lost"] and rows["bob"]["tutorial"] == "tiny"


@pytest.mark.parametrize(
    ("csv_path", "says"),
    [("grades.txt", "--csv expects a .csv file name"), ("missing/grades.csv", "folder '.*missing' does not exist")],
)
def test_mark_csv_that_cannot_be_written_is_refused_before_any_kernel_starts(course, capsys, csv_path, says):
    assert main(["homework", "mark", str(course), "--csv", str(course / csv_path)]) == 2
    assert re.search(says, capsys.readouterr().err)


@pytest.mark.skipif(sys.platform != "linux", reason="reads the processes from /proc")
@pytest.mark.parametrize(("name", "code", "line"), [("SIGINT", 130, "interrupted"), ("SIGTERM", 143, "terminated")])
def test_marking_stopped_by_ctrl_c_or_sigterm_ends_at_once_and_leaves_no_kernel(course, name, code, line):
    """Two submissions whose answers sleep a minute, marked two at a time under a 100 s limit, stopped once both
    kernels run: the command's one line, its exit code, and every kernel gone within seconds. A kernel runs in a
    session of its own, which a terminal's Ctrl-C never reaches: before, the command waited for every cell to run
    out its limit (here a minute)."""
    optional_import("nbclient", "notebooks")
    optional_import("ipykernel", "notebooks")
    slow = {"s1": "import time\ntime.sleep(60)\nsquare = 9", "s2": "cube = lambda x: x**3"}
    _submit(course, "ann", slow)
    _submit(course, "bob", slow)
    argv = ["homework", "mark", str(course / "submitted"), "--source", str(course / "teacher"), "--timeout", "100"]
    proc = popen_in_a_terminal_session(
        [sys.executable, "-m", "steam_ref", *argv, "--jobs", "2"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    kernels: list[int] = []
    try:
        deadline = time.monotonic() + 60
        while len(kernels) < 2 and time.monotonic() < deadline:  # both kernels up (each starts in a second or two)
            kernels = [pid for pid in descendants(proc.pid) if "ipykernel" in command_line(pid)]
            assert proc.poll() is None, "the marking ended before it could be stopped"
            time.sleep(0.1)
        assert len(kernels) == 2, "the two kernels did not start within 60 s"
        time.sleep(2)  # the answers' cells are running
        began = time.monotonic()
        os.killpg(proc.pid, getattr(signal, name))  # Ctrl-C reaches the whole group; SIGTERM too, here
        _, err = proc.communicate(timeout=30)
        took = time.monotonic() - began
        left = left_running(kernels)
    finally:
        clean_up(proc, kernels)
    assert (proc.returncode, err) == (code, f"steam-ref: {line}\n")
    assert left == [], f"kernels still running after {name}: {left}"
    assert took < 15, f"the marking took {took:.1f} s to stop"  # a kernel's death is seen within a second or two


@pytest.mark.parametrize("stop", ["yes", True, 1])
def test_a_stop_that_is_not_an_event_is_refused_naming_it(course, stop):
    """``stop=`` of ``mark_submission`` and ``stop_marking``: a threading.Event; anything else was an AttributeError
    (``'str' object has no attribute 'set'``) from deep inside, or, for ``mark_submission``, only when it was read."""
    from steam_ref.homework import load_tutorials, mark_submission, stop_marking

    said = re.escape(f"stop must be a threading.Event or None, got stop={stop!r}")
    with pytest.raises(SteamError, match=said):
        stop_marking(stop)
    tutorials = load_tutorials(course / "teacher")
    path = _submit(course, "ann", {"s1": "square = 9", "s2": "cube = lambda x: x**3"})
    with pytest.raises(SteamError, match=said):
        mark_submission(path, "ann", tutorials, 10, stop=stop)
