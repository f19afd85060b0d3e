"""Every tutorial notebook executes top to bottom (its solutions, checks and marking checks with it, each solution's
answers of the kinds it declares), and its last code cell asserts. Each has at least two exercises, each a task, a
solution, a check that gives nothing of the answer away and a marking check; the teachers' commands of
docs/tutorials.md build the handouts (no solution, no marking check) and mark a right and a wrong submission. A
tutorial imports past the public API only saying why.

Executing needs nbformat, nbclient and ipykernel (the ``notebooks``/``test`` extras): without them
these tests skip, or fail when STEAM_REF_REQUIRE_OPTIONAL=1 (CI). A notebook that loads the
paper's files (``load_dataset("plaza")`` or ``"paper-synthetic"``) is a ``needs_data`` test; one that
loads a set from the gtsam wheel's ``Data/`` folder (``"victoria-park"``, ``"plaza2"``, ``"kitti"``) needs gtsam, an
optional package, by the same rule.
"""

from __future__ import annotations

import ast
import json
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from requirements import optional_import

import steam_ref
from steam_ref.homework.exercises import ANSWER, HIDDEN, SOLUTION, exercises, source, tags
from steam_ref.homework.guard import guarded
from steam_ref.homework.kinds import check_cell
from steam_ref.homework.marking import load_tutorials

TUTORIALS = sorted((Path(__file__).resolve().parents[1] / "tutorials").glob("*.ipynb"))
READS_REFERENCE_DATA = re.compile(r"""load_dataset\(\s*["'](plaza|paper-synthetic)["']|Syn_theta_Plaza|Plaza1_thrown""")
READS_GTSAM_DATA = re.compile(r"""load_dataset\(\s*["'](victoria-park|plaza2|kitti)["']""")


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
    # each solution's answers checked against the kinds it declares, as the marking run checks a student's
    for e in reversed(exercises(json.loads(path.read_text()), path.name)):
        nb.cells.insert(e.solution + 1, nbformat.v4.new_code_cell(check_cell(dict(e.kinds))))
    client = nbclient.NotebookClient(
        nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(path.parent)}}
    )
    client.execute()  # raises CellExecutionError on the first failing cell, the final assertions included


def _cells(path: Path) -> list[dict]:
    return json.loads(path.read_text())["cells"]


@pytest.mark.parametrize("path", TUTORIALS, ids=[p.stem for p in TUTORIALS])
def test_at_least_two_exercises_each_with_its_solution_check_and_marking_check(path):
    """docs/tutorials.md's convention, read by the marking machinery itself: each exercise is a task (tag
    exercise), a solution (tags solution and hide-cell, folded on the site), a check (tag check) and one marking
    check (tags hidden-check and remove-cell: left off the site and out of the handout), and every check asserts."""
    nb = json.loads(path.read_text())
    found = exercises(nb, path.name)  # refuses a solution, check or marking check outside an exercise
    assert len(found) >= 2, f"{path.name}: {len(found)} exercise(s)"
    assert [e.number for e in found] == list(range(1, len(found) + 1)), [e.label for e in found]
    for e in found:
        assert e.title and len(e.hidden) == 1, f"{path.name}: {e.label} has {len(e.hidden)} marking checks"
        assert {SOLUTION, "hide-cell"} <= tags(nb["cells"][e.solution]), e.label
        assert {HIDDEN, "remove-cell"} <= tags(nb["cells"][e.hidden[0]]), e.label
        for i in (e.check, *e.hidden):
            assert _asserts(ast.parse(source(nb["cells"][i]))), f"{path.name}: a check of {e.label} asserts nothing"
        assert e.names, f"{path.name}: the checks of {e.label} read nothing its solution defines"
        unnamed = [n for n in e.names if not re.search(rf"\b{n}\b", source(nb["cells"][e.task]))]
        assert not unnamed, f"{path.name}: the checks of {e.label} read {unnamed}, which its task does not ask for"


CLOSE = ("allclose", "isclose", "assert_allclose")  # NumPy's comparisons, each with default tolerances


def _unwritten_tolerances(code: str) -> list[str]:
    """Each call of np.allclose, np.isclose or np.testing.assert_allclose in ``code`` that leaves its rtol or its
    atol to NumPy's default (1e-5 and 1e-8; assert_allclose's 1e-7 and 0), as the call's text."""
    found = []
    for node in ast.walk(ast.parse(code)):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in CLOSE:
            named = {k.arg for k in node.keywords}
            if not {"rtol", "atol"} <= named:
                found.append(ast.get_source_segment(code, node) or node.func.attr)
    return found


def test_the_tolerance_finder_sees_a_default_left_to_numpy():
    found = _unwritten_tolerances(
        "np.allclose(a, b, atol=1e-12)\nnp.isclose(a, b, rtol=1e-9)\nnp.testing.assert_allclose(a, b)\n"
        "np.allclose(a, b, rtol=1e-12, atol=0)\nnp.isclose(a, b, 1e-9, 0)"
    )
    assert found == [
        "np.allclose(a, b, atol=1e-12)",
        "np.isclose(a, b, rtol=1e-9)",
        "np.testing.assert_allclose(a, b)",
        "np.isclose(a, b, 1e-9, 0)",  # positional tolerances are not written out by name: refused too
    ]


@pytest.mark.parametrize("path", TUTORIALS, ids=[p.stem for p in TUTORIALS])
def test_each_marking_check_writes_out_both_tolerances_of_each_comparison(path):
    """docs/tutorials.md: a marking check compares at the precision a right answer reaches, each tolerance written in
    it, so an answer right to a few digits fails. A comparison that names only ``atol=1e-12`` compares at NumPy's
    unseen rtol of 1e-5 as well: tutorial 00's velocity_jacobian off by a relative 1e-6 scored its point
    (test_a_teacher_marks_a_right_and_a_wrong_submission_of_tutorial_00), and a teacher reading the check saw 1e-12."""
    nb = json.loads(path.read_text())
    for e in exercises(nb, path.name):
        for i in e.hidden:
            unwritten = _unwritten_tolerances(source(nb["cells"][i]))
            assert not unwritten, f"{path.name}: {e.label}'s marking check leaves a tolerance to NumPy: {unwritten}"


def _size(node: ast.AST) -> int:
    return sum(1 for n in ast.walk(node) if not isinstance(n, ast.expr_context))


def _answers(solution: ast.AST) -> list[ast.expr]:
    """The expressions a solution computes its answers with: every assigned or returned value of some size."""
    values = [
        n.value for n in ast.walk(solution) if isinstance(n, (ast.Assign, ast.AugAssign, ast.AnnAssign, ast.Return))
    ]
    return [v for v in values if v is not None and _size(v) >= 6]


def _giveaways(check: str, solution: str) -> list[str]:
    """What in a check cell would give the answer away (empty when none): an np.testing assertion (its failure
    prints the desired value), an assert without a message or with one computed from values, a loop or function
    (a whole algorithm), an expression of the solution."""
    tree, found = ast.parse(check), []
    found += [f"{a} (its failure prints the expected value)" for a in _asserts(tree) if a.startswith("np.testing")]
    for node in ast.walk(tree):
        if isinstance(node, ast.Assert) and not (
            isinstance(node.msg, ast.Constant) and isinstance(node.msg.value, str)
        ):
            found.append(f"line {node.lineno}: an assert whose message is not a plain sentence")
        if isinstance(node, (ast.For, ast.While, ast.FunctionDef, ast.Lambda, ast.ClassDef)):
            found.append(
                f"line {node.lineno}: a {type(node).__name__} (a check states properties, it computes no algorithm)"
            )
    inside = {ast.dump(n) for n in ast.walk(tree) if isinstance(n, ast.expr)}
    found += [f"the solution's {ast.unparse(v)!r}" for v in _answers(ast.parse(solution)) if ast.dump(v) in inside]
    return found


def test_the_giveaway_finder_sees_each_kind_of_leak():
    """The oracle of the test below: each leak it must find, and a clean check it must pass."""
    solution = "Q = np.block([[dt**3 / 3 * qc, dt**2 / 2 * qc], [dt**2 / 2 * qc, dt * qc]])"
    leaks = {
        "np.testing.assert_allclose(Q, Q.T)": "np.testing",
        "assert Q.shape == (6, 6)": "not a plain sentence",
        "assert Q.shape == (6, 6), f'got {Q.shape}'": "not a plain sentence",
        "for i in range(3):\n    assert Q[i, i] > 0, 'a variance is not positive'": "For",
        "assert np.allclose(Q, np.block([[dt**3 / 3 * qc, dt**2 / 2 * qc], [dt**2 / 2 * qc, dt * qc]])), 'no'": "solution",
    }
    for check, kind in leaks.items():
        assert any(kind in g for g in _giveaways(check, solution)), check
    clean = "assert Q.shape == (6, 6), 'Q must be 6 x 6'\nassert np.allclose(Q, Q.T), 'Q is not symmetric'"
    assert _giveaways(clean, solution) == []


@pytest.mark.parametrize("path", TUTORIALS, ids=[p.stem for p in TUTORIALS])
def test_no_check_gives_the_answer_away(path):
    """A check (and a marking check, whose message the marking report shows) fails with a sentence saying what
    is wrong, never with the expected value; the handout's check holds no expression of the solution, no
    loop and no function: properties a right answer has, not a second solution."""
    nb = json.loads(path.read_text())
    for e in exercises(nb, path.name):
        solution = source(nb["cells"][e.solution])
        leaks = _giveaways(source(nb["cells"][e.check]), solution)
        assert not leaks, f"{path.name}, the check of {e.label}: {leaks}"
        for i in e.hidden:
            said = [g for g in _giveaways(source(nb["cells"][i]), solution) if "np.testing" in g or "message" in g]
            assert not said, f"{path.name}, the marking check of {e.label}: {said}"


@pytest.mark.parametrize("path", TUTORIALS, ids=[p.stem for p in TUTORIALS])
def test_a_tutorial_reaches_past_the_public_api_only_saying_why(path):
    """Names of the public API (``import steam_ref as sr``) come from steam_ref itself; a tutorial that imports
    a module beneath it says why in a comment (the machinery it is about) on the first such import of a cell."""
    public = set(steam_ref.__all__)
    for cell in _code_cells(path):
        tree, lines = ast.parse(cell), cell.splitlines()
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("steam_ref."):
                named = {a.name for a in node.names} & public
                assert not named, (
                    f"{path.name}: {sorted(named)} are public: import them from steam_ref (sr.{min(named)})"
                )
        inner = [n for n in tree.body if isinstance(n, (ast.Import, ast.ImportFrom)) and _submodule(n)]
        if inner:  # the reason: a comment on the line above the first such import, or at its end
            line, above = lines[inner[0].lineno - 1], lines[inner[0].lineno - 2] if inner[0].lineno > 1 else ""
            assert above.lstrip().startswith("#") or "  # " in line, (
                f"{path.name}: {line!r} without a comment saying why"
            )


def _submodule(node: ast.Import | ast.ImportFrom) -> bool:
    """An import of a steam_ref module beneath the public API (``from steam_ref import plot`` is one)."""
    if isinstance(node, ast.ImportFrom):
        module = node.module or ""
        return module.startswith("steam_ref.") or (
            module == "steam_ref" and not {a.name for a in node.names} <= set(steam_ref.__all__)
        )
    return any(a.name.startswith("steam_ref.") for a in node.names)


def _homework_command(verb: str) -> str:
    """The command docs/tutorials.md gives teachers for ``verb`` (one home: the tests run the page's text)."""
    page = (Path(__file__).resolve().parents[1] / "docs" / "tutorials.md").read_text()
    (command,) = [line for line in page.splitlines() if line.startswith(f"steam-ref homework {verb} ")]
    return command


def _run_command(command: str, cwd: Path, timeout: int) -> subprocess.CompletedProcess:
    argv = [sys.executable, "-m", "steam_ref", *shlex.split(command)[1:]]
    return subprocess.run(argv, cwd=cwd, capture_output=True, text=True, timeout=timeout)


@pytest.fixture(scope="module")
def handouts(tmp_path_factory):
    """docs/tutorials.md's handout command, run as written on a copy of every tutorial."""
    work = tmp_path_factory.mktemp("course")
    shutil.copytree(TUTORIALS[0].parent, work / "tutorials", ignore=shutil.ignore_patterns(".ipynb_checkpoints"))
    done = _run_command(_homework_command("handout"), work, timeout=120)
    assert done.returncode == 0, done.stderr
    return work


@pytest.mark.parametrize("path", TUTORIALS, ids=[p.stem for p in TUTORIALS])
def test_the_handout_keeps_the_lesson_tasks_and_checks_and_nothing_of_the_answers(handouts, path):
    nb = json.loads(path.read_text())
    given = json.loads((handouts / "handout" / path.name).read_text())
    found = exercises(nb, path.name)
    answer_of = {e.solution: e for e in found}
    hidden = {i for e in found for i in e.hidden}
    expected = [(i, c) for i, c in enumerate(nb["cells"]) if i not in hidden]
    assert [c["id"] for c in given["cells"]] == [c["id"] for _, c in expected]  # in order; the answer takes its id
    for (i, mine), theirs in zip(expected, given["cells"], strict=True):
        if i in answer_of:
            assert tags(theirs) == {ANSWER} and source(theirs).startswith("# Your answer"), theirs
            assert all(f"`{n}`" in source(theirs) for n in answer_of[i].names), source(theirs)
        else:
            assert source(theirs) == source(mine) and tags(theirs) == tags(mine), f"{path.name} cell {i}"
        assert not theirs.get("outputs")
    assert not any(tags(c) & {SOLUTION, HIDDEN, "hide-cell", "remove-cell"} for c in given["cells"])
    assert given["metadata"]["steam_ref"]["handout_of"] == path.stem


def test_a_teacher_marks_a_right_and_a_wrong_submission_of_tutorial_00(handouts):
    """A right answer to every exercise scores full marks; a plausible wrong one (exercise 1's error with its
    sign flipped, which the handout's check cannot see: the cost is the same) scores 0 there and full marks
    elsewhere, with a message that says what is wrong without the expected value; so does exercise 2's Jacobian
    off by a relative 1e-6, which the handout's check (central differences) passes and the marking check compared at
    NumPy's unseen rtol of 1e-5, and exercise 1's cost returned as a 1 × 1 matrix (the right number, boxed)."""
    optional_import("nbclient", "notebooks")
    optional_import("ipykernel", "notebooks")
    name = "00_solve_your_own_problem.ipynb"
    teacher = json.loads((handouts / "tutorials" / name).read_text())
    solutions = {c["id"]: source(c) for c in teacher["cells"] if SOLUTION in tags(c)}
    flipped = solutions["exercise-1-solution"].replace(
        "return x_next - transition_matrix(dt) @ x_prev", "return transition_matrix(dt) @ x_prev - x_next"
    )
    assert flipped != solutions["exercise-1-solution"]
    # exercise 2's Jacobian right to 6 digits: its check (central differences) passes, the marking check must not
    nearly = solutions["exercise-2-solution"] + (
        "\n_exact_jacobian = velocity_jacobian\n\n\ndef velocity_jacobian(x):\n    return _exact_jacobian(x) * (1 + 1e-6)\n"
    )
    # exercise 1's cost as a 1 × 1 matrix (eᵀ Q⁻¹ e of a row and a column), prior_costs flattened: the numbers are
    # right, the handout's check (abs, isclose) takes it, the task asks for a number
    boxed = (
        solutions["exercise-1-solution"]
        .replace("return 0.5 * e @ np.linalg.solve(Q, e)", "return 0.5 * e[None, :] @ np.linalg.solve(Q, e[:, None])")
        .replace("prior_costs = np.array(", "prior_costs = np.ravel(")
    )
    assert boxed.count("e[None, :]") == 1 and boxed.count("np.ravel(") == 1
    students = (
        ("right", solutions),
        ("wrong", {**solutions, "exercise-1-solution": flipped}),
        ("nearly", {**solutions, "exercise-2-solution": nearly}),
        ("boxed", {**solutions, "exercise-1-solution": boxed}),
    )
    for student, answers in students:
        nb = json.loads((handouts / "handout" / name).read_text())
        for cell in nb["cells"]:
            cell["source"] = answers.get(cell["id"], cell["source"])
        (handouts / "submitted" / student).mkdir(parents=True)
        (handouts / "submitted" / student / name).write_text(json.dumps(nb))
    command = _homework_command("mark").replace("submitted/", "submitted/ --json --jobs 2")
    done = _run_command(command, handouts, timeout=900)
    assert done.returncode == 0, done.stderr
    marks = {m["submission"].split("/")[0]: m for m in json.loads(done.stdout)["submissions"]}
    assert [(e["number"], e["score"]) for e in marks["right"]["exercises"]] == [(1, 1), (2, 1), (3, 1)], marks["right"]
    assert [(e["number"], e["score"]) for e in marks["wrong"]["exercises"]] == [(1, 0), (2, 1), (3, 1)], marks["wrong"]
    nearly_marks = marks["nearly"]["exercises"]
    assert [(e["number"], e["score"]) for e in nearly_marks] == [(1, 1), (2, 0), (3, 1)], nearly_marks
    said = nearly_marks[1]["message"]
    assert said.startswith("marking check: velocity_jacobian is not ∂e/∂x"), said
    boxed_marks = marks["boxed"]["exercises"]
    assert [(e["number"], e["score"]) for e in boxed_marks] == [(1, 0), (2, 1), (3, 1)], boxed_marks
    assert boxed_marks[0]["message"] == "marking check: prior_cost must return one number, not an array of one"
    message = marks["wrong"]["exercises"][0]["message"]
    assert message.startswith("marking check: prior_error is not Eq. 22's") and not re.search(r"\d\.\d", message)


def test_a_students_own_chi2_band_in_tutorial_09_is_not_what_the_marking_checks_compare_with(handouts):
    """Tutorial 09's marking checks compare band_200 with the lesson's chi2_band. A student who writes their own
    helper under that name, wrongly (a 90 % band), scored full marks for exercise 1 (the check compared the
    answer with itself), and their right exercise 2 then lost its point to the wrong helper. Now exercise 1 scores
    0 saying which name it rebinds, and exercise 2 is marked against the lesson's chi2_band."""
    optional_import("nbclient", "notebooks")
    optional_import("ipykernel", "notebooks")
    name = "09_consistency.ipynb"
    teacher = json.loads((handouts / "tutorials" / name).read_text())
    solutions = {c["id"]: source(c) for c in teacher["cells"] if SOLUTION in tags(c)}
    (first, _) = [e.solution_id for e in exercises(teacher, name)]
    own = (
        "def chi2_band(n_runs, dof=3):  # 90 %, not 95 %\n"
        "    return chi2.ppf(0.05, dof * n_runs) / n_runs, chi2.ppf(0.95, dof * n_runs) / n_runs\n\n\n"
        "band_200 = chi2_band(200)\n"
        "n_runs_10pct = next(n for n in range(1, 10_000) if chi2_band(n)[0] >= 2.7 and chi2_band(n)[1] <= 3.3)\n"
    )
    nb = json.loads((handouts / "handout" / name).read_text())
    for cell in nb["cells"]:
        cell["source"] = {**solutions, first: own}.get(cell["id"], cell["source"])
    (handouts / "own-band").mkdir()
    (handouts / "own-band" / name).write_text(json.dumps(nb))
    done = _run_command("steam-ref homework mark own-band/ --source tutorials/ --json", handouts, timeout=600)
    assert done.returncode == 0, done.stderr
    (mark,) = json.loads(done.stdout)["submissions"]
    assert [(e["number"], e["score"]) for e in mark["exercises"]] == [(1, 0), (2, 1)], mark
    assert mark["exercises"][0]["message"].startswith("the answer rebinds `chi2_band`"), mark


def _rebound(code: str) -> set[str]:
    """The global names a cell binds: what it assigns, defines or imports outside functions, classes and
    comprehensions (whose names are their own)."""
    found: set[str] = set()
    todo: list[ast.AST] = [ast.parse(code)]
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            found.add(node.name)
            continue
        if isinstance(node, (ast.Lambda, ast.ListComp, ast.SetComp, ast.DictComp, ast.GeneratorExp)):
            continue
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            found |= {(a.asname or a.name).split(".")[0] for a in node.names}
        if isinstance(node, ast.Name) and isinstance(node.ctx, (ast.Store, ast.Del)):
            found.add(node.id)
        todo += list(ast.iter_child_nodes(node))
    return found


def test_the_rebinding_finder_sees_assignments_loops_defs_and_imports_but_not_locals():
    code = "a = 1\nfor b in x:\n    pass\ndef c(d):\n    e = d\nimport f.g\nh = [i for i in x]\nwith x as j:\n    del k"
    assert _rebound(code) == {"a", "b", "c", "f", "h", "j", "k"}


def test_no_solution_rebinds_a_name_the_marking_keeps():
    """The marking fails an answer that rebinds a name of the lesson the checks read (``marking.guarded``): no
    tutorial's own solution does, or its right answer would score 0."""
    for name, tutorial in load_tutorials(TUTORIALS[0].parent).items():
        kept = set(guarded(tutorial.exercises))
        for e in tutorial.exercises:
            clash = _rebound(source(tutorial.notebook["cells"][e.solution])) & kept
            assert not clash, f"{name}: the solution of {e.label} rebinds {sorted(clash)}, which the marking keeps"
