"""A teacher's notebook and its exercises, read by cell tags; the student's handout made from it.

A teacher's notebook (each tutorial in ``tutorials/``) holds every exercise as consecutive cells, found by
their tags (docs/tutorials.md, "Exercises"):

==================  ============================  =======================================================
cell                tags                          in the handout
==================  ============================  =======================================================
the task            ``exercise`` (Markdown,       kept
                    headed ``### Exercise k``)
the solution        ``solution``, ``hide-cell``   replaced by an empty answer cell (tag ``answer``, the
                    (its metadata ``steam_ref.    solution's cell id), naming what the checks read and
                    answers``: each answer's      the kind of each
                    kind, :mod:`.kinds`)
the check           ``check``                     kept: properties any right answer has, never the answer
the marking checks  ``hidden-check``,             removed: the teacher's marking run adds them back
                    ``remove-cell``
==================  ============================  =======================================================

``hide-cell`` folds a solution and ``remove-cell`` leaves a marking check off the documentation site; running
the teacher's notebook runs all of them, so every check is tested against the solution.
"""

from __future__ import annotations

import ast
import copy
import json
import re
import stat
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import SteamError
from .kinds import KINDS

__all__ = [
    "ANSWER",
    "CHECK",
    "HIDDEN",
    "MAX_BYTES",
    "MAX_DEPTH",
    "SOLUTION",
    "TASK",
    "Exercise",
    "answer_cells",
    "exercises",
    "handout",
    "handout_of",
    "read_notebook",
    "source",
    "tags",
]

TASK, SOLUTION, CHECK, HIDDEN, ANSWER = "exercise", "solution", "check", "hidden-check", "answer"
HEADING = re.compile(r"###\s*Exercise\s+(\d+)\s*(?:[·:.-]\s*)?(.*)")
METADATA = "steam_ref"  # the notebook metadata key the tutorials already use; a handout adds "handout_of"
MAX_BYTES = 20 * 2**20  # the largest notebook read (read_notebook says why)
MAX_DEPTH = 100  # the deepest nesting of lists and objects read
ANSWERS = "answers"  # ... and a solution cell's, under METADATA, the kind of each answer (.kinds)


@dataclass(frozen=True)
class Exercise:
    """One exercise of a teacher's notebook: the positions of its cells and what its checks read."""

    number: int  # k of "### Exercise k"
    title: str
    task: int  # index of the task cell
    solution: int  # index of the solution cell
    check: int  # index of the check cell
    hidden: tuple[int, ...]  # indices of the marking checks (none, or the cells right after the check)
    task_id: str  # the cells' ids, which the handout keeps (the answer cell takes the solution's)
    solution_id: str
    check_id: str
    names: tuple[str, ...]  # what the solution defines and the checks read: what the answer must define
    reads: tuple[str, ...] = ()  # every name the checks read, and attribute chain (np.allclose) off one, sorted
    kinds: tuple[tuple[str, str], ...] = ()  # each of names with its kind (.kinds.KINDS), as the solution declares

    @property
    def label(self) -> str:
        return f"Exercise {self.number}" + (f" · {self.title}" if self.title else "")


def source(cell: dict) -> str:
    """A cell's source as one string (nbformat stores a list of lines or a string)."""
    text = cell.get("source", "")
    return "".join(text) if isinstance(text, list) else str(text)


def tags(cell: dict) -> set[str]:
    return set(cell.get("metadata", {}).get("tags", []))


def read_notebook(path: Path) -> dict[str, Any]:
    """The notebook at ``path`` as nbformat 4 JSON; SteamError naming the file if it is not one, or is larger than
    MAX_BYTES (its size checked before it is read, and never more than MAX_BYTES + 1 bytes read) or nested deeper
    than MAX_DEPTH.

    Why 20 MiB: the largest teacher's notebook (tutorial 11) is 42 KB with its outputs stripped, and the largest run
    with its figures (tutorial 01) 384 KB; 20 MiB is fifty times that, room for a student's extra figures, while a
    2 GB file (or one huge output) never reaches memory. Why 100 levels: nbformat nests about ten (a cell's output's
    data), and JSON nested some thousands deep stops the parser with a RecursionError."""
    try:
        found = path.stat()
        size = found.st_size
        if not stat.S_ISREG(found.st_mode):  # a pipe or a device: reading it could block or never end
            raise SteamError(f"cannot read {str(path)!r}: not a file")
        if size > MAX_BYTES:
            raise SteamError(_too_large(path, f"{size:,} bytes"))
        with path.open("rb") as file:
            data = file.read(MAX_BYTES + 1)
        if len(data) > MAX_BYTES:  # it grew since, or its size is not what stat says
            raise SteamError(_too_large(path, f"more than {MAX_BYTES:,} bytes"))
        text = data.decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SteamError(f"cannot read {str(path)!r}: {getattr(exc, 'strerror', None) or exc}") from None
    deep = f"{str(path)!r} is not a notebook: its JSON is nested deeper than {MAX_DEPTH} levels"
    try:
        nb = json.loads(text)
    except json.JSONDecodeError as exc:
        raise SteamError(f"{str(path)!r} is not a notebook: not JSON ({exc.msg} at line {exc.lineno})") from None
    except RecursionError:  # deeper than the parser goes, so deeper than MAX_DEPTH
        raise SteamError(deep) from None
    except ValueError as exc:  # an integer of more digits than Python converts (4300): "Exceeds the limit ..."
        raise SteamError(f"{str(path)!r} is not a notebook: {str(exc).split(';')[0]}") from None
    if _deeper_than(nb, MAX_DEPTH):
        raise SteamError(deep)
    cells = nb.get("cells") if isinstance(nb, dict) else None
    if not isinstance(cells, list) or nb.get("nbformat") != 4 or not all(isinstance(c, dict) for c in cells):
        raise SteamError(f"{str(path)!r} is not a notebook: no nbformat 4 'cells' list")
    wrong = _off_the_form(nb)
    if wrong:
        raise SteamError(f"{str(path)!r} is not a notebook: {wrong}")
    return nb


def _too_large(path: Path, size: str) -> str:
    return (
        f"{str(path)!r} is {size}, over the {MAX_BYTES:,}-byte limit for a notebook "
        "(clear its outputs, Kernel > Restart and Clear Outputs, and submit it again)"
    )


def _deeper_than(value: Any, depth: int) -> bool:
    """Whether JSON ``value`` nests lists and objects more than ``depth`` levels deep (without recursion)."""
    todo = [(value, 1)]
    while todo:
        item, level = todo.pop()
        if isinstance(item, (dict, list)):
            if level > depth:
                return True
            todo += [(v, level + 1) for v in (item.values() if isinstance(item, dict) else item)]
    return False


def _off_the_form(nb: dict[str, Any]) -> str | None:
    """What in the parts of a notebook the homework reads breaks nbformat 4's form, or None: the metadata an
    object, each cell's metadata an object, its tags a list of strings, its source a string or a list of them."""
    if not isinstance(nb.get("metadata", {}), dict):
        return "its 'metadata' is not an object"
    for i, cell in enumerate(nb["cells"]):
        meta = cell.get("metadata", {})
        if not isinstance(meta, dict):
            return f"cell {i}'s 'metadata' is not an object"
        found = meta.get("tags", [])
        if not isinstance(found, list) or not all(isinstance(t, str) for t in found):
            return f"cell {i}'s tags are not a list of strings"
        text = cell.get("source", "")
        if not isinstance(text, str) and not (isinstance(text, list) and all(isinstance(s, str) for s in text)):
            return f"cell {i}'s source is not text (a string or a list of strings)"
    return None


def _bound(body: list[ast.stmt]) -> list[str]:
    """Names a block binds for later cells (assignments, functions, classes, imports), loop variables left out."""
    names: list[str] = []
    for node in body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.append(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names += [(a.asname or a.name).split(".")[0] for a in node.names]
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names += [n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name)]
        for field in ("body", "orelse", "finalbody"):  # inside if, for, while, with, try
            inner = getattr(node, field, None)
            if isinstance(inner, list) and not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                names += _bound(inner)
    return names


def _read(code: str) -> set[str]:
    """Names a cell reads that it does not bind itself (nor as a loop or comprehension variable, a function's
    parameter, a function or class it defines, a name it imports), and each attribute chain it reads off one
    (``np.allclose``, ``np.linalg.slogdet``)."""
    tree = ast.parse(code)
    nodes = [n for n in ast.walk(tree) if isinstance(n, ast.Name)]
    bound = {n.id for n in nodes if isinstance(n.ctx, ast.Store)} | {
        a.arg for a in ast.walk(tree) if isinstance(a, ast.arg)
    }
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            bound.add(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            bound |= {(a.asname or a.name).split(".")[0] for a in node.names}
    read = {n.id for n in nodes if isinstance(n.ctx, ast.Load)} - bound
    chains = {_chain(a) for a in ast.walk(tree) if isinstance(a, ast.Attribute) and isinstance(a.ctx, ast.Load)}
    return read | {c for c in chains if c and c.split(".")[0] in read}


def _chain(node: ast.expr) -> str | None:
    """``np.linalg.slogdet`` for that attribute read off a name, None for one read off anything else (a call's
    result, a subscript)."""
    if isinstance(node, ast.Name):
        return node.id
    if isinstance(node, ast.Attribute):
        root = _chain(node.value)
        return None if root is None else f"{root}.{node.attr}"
    return None


def _reads(nb: dict, checks: list[int]) -> set[str]:
    """The names the check cells ``checks`` read (none if one is not Python)."""
    try:
        return set().union(*(_read(source(nb["cells"][i])) for i in checks))
    except SyntaxError:
        return set()


def _names(nb: dict, solution: int, read: set[str]) -> tuple[str, ...]:
    try:
        return tuple(dict.fromkeys(n for n in _bound(ast.parse(source(nb["cells"][solution])).body) if n in read))
    except SyntaxError:
        return ()


def _kinds(nb: dict, solution: int, names: tuple[str, ...], name: str, number: str) -> tuple[tuple[str, str], ...]:
    """The kind of each of ``names`` that the solution cell declares (its metadata ``steam_ref.answers``, a name to
    a key of KINDS); SteamError naming the cell if a name has none, a kind is unknown or a name is not an answer."""
    where = f"{name}: exercise {number}'s solution (cell {solution})"
    meta = nb["cells"][solution].get("metadata", {}).get(METADATA, {})
    declared = meta.get(ANSWERS) if isinstance(meta, dict) else None
    if not isinstance(declared, dict):
        raise SteamError(
            f"{where} declares no kind for its answers: give its metadata {METADATA!r} an {ANSWERS!r} object, "
            f"each of {', '.join(names) or 'its answers'} to one of {', '.join(KINDS)}"
        )
    for answer, kind in declared.items():
        if answer not in names:
            raise SteamError(
                f"{where} declares a kind for {answer!r}, no answer (a name the solution binds and the checks read)"
            )
        if not isinstance(kind, str) or kind not in KINDS:  # a list or an object is no kind (and unhashable)
            raise SteamError(f"{where} declares {answer!r} of kind {kind!r}: not one of {', '.join(KINDS)}")
    missing = [n for n in names if n not in declared]
    if missing:
        raise SteamError(f"{where} declares no kind for {', '.join(missing)} (one of {', '.join(KINDS)})")
    return tuple((n, str(declared[n])) for n in names)


def exercises(nb: dict, name: str) -> list[Exercise]:
    """The exercises of a teacher's notebook, in order; SteamError naming ``name`` and the cell if one is
    not a task followed by its solution and its check (docs/tutorials.md's convention)."""
    cells = nb["cells"]
    found = []
    for i, cell in enumerate(cells):
        if TASK not in tags(cell):
            continue
        heading = HEADING.match(source(cell).lstrip())
        if cell.get("cell_type") != "markdown" or heading is None:
            raise SteamError(f"{name}: cell {i} is tagged {TASK!r} but is not a Markdown cell headed '### Exercise k'")
        parts = cells[i + 1 : i + 3]
        wanted = ((SOLUTION, "its solution"), (CHECK, "its check"))
        for offset, (tag, what) in enumerate(wanted, start=1):
            if (
                len(parts) < offset
                or parts[offset - 1].get("cell_type") != "code"
                or tag not in tags(parts[offset - 1])
            ):
                raise SteamError(
                    f"{name}: exercise {heading[1]} (cell {i}) is not followed by {what}, a code cell tagged {tag!r}"
                )
        hidden = []
        j = i + 3
        while j < len(cells) and HIDDEN in tags(cells[j]) and cells[j].get("cell_type") == "code":
            hidden.append(j)
            j += 1
        read = _reads(nb, [i + 2, *hidden])
        names = _names(nb, i + 1, read)
        found.append(
            Exercise(
                number=int(heading[1]),
                title=heading[2].strip(),
                task=i,
                solution=i + 1,
                check=i + 2,
                hidden=tuple(hidden),
                task_id=str(cell.get("id", "")),
                solution_id=str(cells[i + 1].get("id", "")),
                check_id=str(cells[i + 2].get("id", "")),
                names=names,
                reads=tuple(sorted(read)),
                kinds=_kinds(nb, i + 1, names, name, heading[1]),
            )
        )
    placed = {k for e in found for k in (e.solution, e.check, *e.hidden)}
    for i, cell in enumerate(cells):
        stray = tags(cell) & {SOLUTION, CHECK, HIDDEN}
        if stray and i not in placed:
            raise SteamError(f"{name}: cell {i} is tagged {sorted(stray)[0]!r} but belongs to no exercise")
    return found


def _answer_cell(exercise: Exercise) -> dict:
    wanted = ", ".join(f"`{n}` ({kind})" for n, kind in exercise.kinds) or "the names the task asks for"
    text = (
        f"# Your answer to exercise {exercise.number}: define {wanted} (the check below reads them);"
        " leave the lesson's names as they are\n"
    )
    cell: dict[str, Any] = {"cell_type": "code", "execution_count": None, "metadata": {"tags": [ANSWER]}, "outputs": []}
    if exercise.solution_id:
        cell["id"] = exercise.solution_id
    return {**cell, "source": text}


def handout(nb: dict, name: str) -> dict:
    """The student's copy of a teacher's notebook: each solution an empty answer cell, no marking check, no
    output; the notebook's metadata names the tutorial (``steam_ref.handout_of``), which the marking run reads."""
    found = exercises(nb, name)
    if not found:
        raise SteamError(f"{name} has no exercise (no Markdown cell tagged {TASK!r})")
    by_solution = {e.solution: e for e in found}
    hidden = {i for e in found for i in e.hidden}
    cells = []
    for i, cell in enumerate(nb["cells"]):
        if i in hidden:
            continue
        if i in by_solution:
            cells.append(_answer_cell(by_solution[i]))
            continue
        kept = copy.deepcopy(cell)
        if kept.get("cell_type") == "code":
            kept["outputs"], kept["execution_count"] = [], None
        cells.append(kept)
    out = copy.deepcopy({k: v for k, v in nb.items() if k != "cells"})
    meta = out.setdefault("metadata", {})
    if not isinstance(meta.get(METADATA, {}), dict):
        raise SteamError(f"{name}: its metadata {METADATA!r} is not an object")
    meta[METADATA] = {**meta.get(METADATA, {}), "handout_of": Path(name).stem}
    return {**out, "cells": cells}


def handout_of(nb: dict) -> str | None:
    """The tutorial a handout (or a student's copy of it) was made from, as its metadata says."""
    meta = nb.get("metadata", {}).get(METADATA, {})
    found = meta.get("handout_of") if isinstance(meta, dict) else None
    return found if isinstance(found, str) else None


def answer_cells(submission: dict, exercise: Exercise, position: int) -> list[dict] | None:
    """The student's answer to ``exercise`` in ``submission``: the code cells between its task cell and the
    check below it. The task is found by its cell id, else as the ``position``-th task cell (0-based); None if
    the submission has no such task."""
    cells = submission["cells"]
    start = next((i for i, c in enumerate(cells) if exercise.task_id and c.get("id") == exercise.task_id), None)
    if start is None:
        tasks = [i for i, c in enumerate(cells) if TASK in tags(c)]
        start = tasks[position] if position < len(tasks) else None
    if start is None:
        return None
    answer = []
    for cell in cells[start + 1 :]:
        if tags(cell) & {CHECK, TASK, HIDDEN} or (exercise.check_id and cell.get("id") == exercise.check_id):
            break
        if cell.get("cell_type") == "code":
            answer.append(cell)
    return answer
