"""The teacher's marking run: each submission's answers run between the teacher's own cells and checks.

A submission contributes only its answers (the code cells between each task and its check). The notebook that runs
is the teacher's: its lesson cells, the student's answer where the solution was, then the teacher's check and
marking checks, so an edited or deleted check changes nothing; the lesson's names the checks read (:mod:`.guard`)
are kept around each answer and its checks, and one it rebinds, changes in place (an array, or one an object holds)
or shadows (a builtin) is put back and costs that exercise, named, so no check compares an answer with the answer's
own helper; an answer of another type than the kind its solution declares (:mod:`.kinds`: a complex array for an
array of reals, a string for a number) costs that exercise too, naming both. It runs in a fresh kernel (nbclient) in
the teacher's notebook's folder, every cell of the teacher's under a time limit and each answer too, its cells
sharing it (however many a student adds, an answer runs the limit at most); a cell that raises or runs over it is
recorded and the run goes on, so one exercise's failure costs that exercise only. An exercise scores its point when
its answer ran without an error or a timeout and its check and marking checks ran without an error. A kernel that
dies (``os._exit``) ends the run, and so does a cell that ignores the interrupt at its time limit (it catches
KeyboardInterrupt, ignores SIGINT or blocks where a signal cannot reach it): a kernel not idle ``GRACE`` seconds
after the interrupt is killed, so such a cell costs its limit plus ``GRACE`` seconds, and what had not run scores 0,
saying why.
"""

from __future__ import annotations

import copy
import re
import subprocess
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import SteamError
from . import stopping
from .exercises import Exercise, answer_cells, exercises, handout_of, read_notebook, source
from .guard import KEEP, KEPT, PUT_BACK, guarded
from .kinds import check_cell

__all__ = [
    "ExerciseMark",
    "SubmissionMark",
    "Tutorial",
    "load_tutorials",
    "mark_submission",
    "requirements",
    "tutorial_of",
]

TIMEOUT = "CellTimeoutError"  # the error name a cell stopped at its time limit is recorded under
IGNORED = "InterruptIgnored"  # ... and a cell that ran on after that interrupt, its kernel then killed
GRACE = 3  # seconds a cell interrupted at its time limit has to stop before its kernel is killed
MAX_MESSAGE = 300


def requirements() -> None:
    """SteamError saying what to install unless nbformat, nbclient and ipykernel are importable."""
    import importlib.util

    missing = [m for m in ("nbformat", "nbclient", "ipykernel") if importlib.util.find_spec(m) is None]
    if missing:
        raise SteamError(f"marking runs notebooks and needs {', '.join(missing)}: pip install 'steam_ref[notebooks]'")


@dataclass(frozen=True)
class Tutorial:
    """A teacher's notebook: its name (file stem), its folder (the kernel's working folder), its exercises."""

    name: str
    folder: Path
    notebook: dict[str, Any]
    exercises: tuple[Exercise, ...]


def load_tutorials(folder: Path) -> dict[str, Tutorial]:
    """Every notebook with exercises in ``folder``, by name; SteamError if there is none."""
    if not folder.is_dir():
        what = "does not exist" if not folder.exists() else "is not a folder"
        raise SteamError(f"the teacher's notebooks: {str(folder)!r} {what} (give their folder with --source)")
    found = {}
    for path in sorted(folder.glob("*.ipynb")):
        nb = read_notebook(path)
        listed = tuple(exercises(nb, path.name))
        if listed:
            found[path.stem] = Tutorial(path.stem, path.parent.resolve(), nb, listed)
    if not found:
        raise SteamError(f"no notebook with exercises in {str(folder)!r} (give the teacher's notebooks with --source)")
    return found


@dataclass(frozen=True)
class ExerciseMark:
    """One exercise of a submission as marked: its score out of its points, and why it lost any."""

    number: int
    title: str
    score: int
    out_of: int
    status: str  # passed, failed, error, timeout, not run, no answer
    message: str  # what went wrong, never the expected value (the checks' messages say what, not how much)


@dataclass(frozen=True)
class SubmissionMark:
    """A submitted notebook as marked: the tutorial it answers, each exercise's mark, or why it could not be marked."""

    submission: str
    tutorial: str | None
    exercises: tuple[ExerciseMark, ...] = ()
    error: str | None = None  # why the submission could not be marked at all
    notes: tuple[str, ...] = field(default=())  # a cell of the teacher's lesson that failed: the set-up's fault

    @property
    def score(self) -> int:
        """Points scored over every exercise."""
        return sum(e.score for e in self.exercises)

    @property
    def out_of(self) -> int:
        """Points available over every exercise."""
        return sum(e.out_of for e in self.exercises)

    def as_dict(self) -> dict[str, Any]:
        """The mark as JSON-ready data (``steam-ref homework mark --json``)."""
        return {
            "submission": self.submission,
            "tutorial": self.tutorial,
            "score": self.score,
            "out_of": self.out_of,
            "error": self.error,
            "notes": list(self.notes),
            "exercises": [e.__dict__ for e in self.exercises],
        }


def _one_line(text: str) -> str:
    line = " ".join(str(text).split())
    line = re.sub(r"\x1b\[[0-9;]*m", "", line)  # IPython's colours
    return line if len(line) <= MAX_MESSAGE else line[: MAX_MESSAGE - 3] + "..."


@dataclass
class _Cell:
    cell: dict[str, Any]
    exercise: int | None  # the exercise's position among the tutorial's, for its answer and checks
    role: str  # lesson, answer, check, hidden, guard (the lesson's names kept around an answer: KEEP, PUT_BACK;
    # the answer's kinds checked after it: .kinds.check_cell)


def _code(text: str) -> dict[str, Any]:
    """A code cell of the marking run's own."""
    return {"cell_type": "code", "metadata": {}, "source": text, "outputs": [], "execution_count": None}


def _written(cells: list[dict] | None) -> str | None:
    """Why an answer is missing (no task cell, nothing but comments), or None if there is code to run."""
    if cells is None:
        return "the submission has no task cell for this exercise, so no answer"
    code = [
        line for c in cells for line in source(c).splitlines() if line.strip() and not line.lstrip().startswith("#")
    ]
    return None if code else "the answer cell holds no code"


def _assemble(tutorial: Tutorial, submission: dict) -> tuple[list[_Cell], dict[int, str | None]]:
    """The cells of the marking run, and for each exercise why it has no answer (None: it has one)."""
    role_of: dict[int, tuple[int | None, str]] = {}
    for n, e in enumerate(tutorial.exercises):
        role_of[e.solution] = (n, "answer")
        role_of[e.check] = (n, "check")
        role_of.update(dict.fromkeys(e.hidden, (n, "hidden")))
    cells: list[_Cell] = []
    missing: dict[int, str | None] = {}
    kept = guarded(tutorial.exercises)
    last_check = {(e.hidden or (e.check,))[-1]: n for n, e in enumerate(tutorial.exercises)}
    for i, cell in enumerate(tutorial.notebook["cells"]):
        k, role = role_of.get(i, (None, "lesson"))
        if role != "answer":
            cells.append(_Cell(copy.deepcopy(cell), k, role))
            if i in last_check:  # the checks called the answer's functions on the lesson's values: put them back
                cells.append(_Cell(_code(PUT_BACK.format(kept=KEPT, forget=f", {KEPT}")), k, "guard"))
            continue
        assert k is not None
        answer = answer_cells(submission, tutorial.exercises[k], k)
        missing[k] = _written(answer)
        cells.append(_Cell(_code(KEEP.format(kept=KEPT, names=kept)), k, "guard"))
        cells += [_Cell(copy.deepcopy(c), k, "answer") for c in answer or []]
        cells.append(_Cell(_code(PUT_BACK.format(kept=KEPT, forget="")), k, "guard"))
        cells.append(_Cell(_code(check_cell(dict(tutorial.exercises[k].kinds))), k, "guard"))
    for n, c in enumerate(cells):
        c.cell["id"] = f"marking-{n}"  # unique, whatever the student copied
        c.cell["source"] = source(c.cell)  # nbformat's list of lines as the one string a kernel runs
        if c.cell.get("cell_type") == "code":
            c.cell["outputs"], c.cell["execution_count"] = [], None
    return cells, missing


DIED = "the run stopped: the kernel died (did the answer exit Python?)"


def _named(cells: list[_Cell], tutorial: Tutorial, i: int) -> str:
    """Cell ``i`` of the marking run as the report names it: whose it is and, for an exercise's, which."""
    c = cells[i]
    if c.exercise is None:
        return "a cell of the teacher's lesson"
    role = {"answer": "answer", "check": "check"}.get(c.role, "marking check")
    return f"exercise {tutorial.exercises[c.exercise].number}'s {role}"


def _run(
    cells: list[_Cell], tutorial: Tutorial, timeout: int, stop: threading.Event | None = None
) -> tuple[dict[int, tuple[str, str] | None], str | None]:
    """Run the cells in a fresh kernel: for each code cell that ran, None (no error) or (error name, message);
    and why the run stopped early, if it did. :class:`~.stopping.Stopped` once ``stop`` is set
    (:func:`~.stopping.stop_marking`)."""
    import asyncio  # here, not at the top: a run of the CLI loads this module and need not load asyncio

    import nbclient
    import nbformat
    from jupyter_core.utils import ensure_async
    from nbclient.exceptions import DeadKernelError

    nb = copy.deepcopy({k: v for k, v in tutorial.notebook.items() if k != "cells"})
    nb["cells"] = [c.cell for c in cells]
    nb["nbformat"], nb["nbformat_minor"] = 4, max(5, int(nb.get("nbformat_minor", 5)))
    outcomes: dict[int, tuple[str, str] | None] = {}
    after_timeout = False
    # An exercise's answer cells share one limit: however many cells a student adds, an answer runs ``timeout``
    # seconds at most, and a run at most its limit per answer and per cell of the teacher's.
    spent: dict[int, float] = {}  # seconds each exercise's answer cells have run
    began: dict[int, float] = {}
    index = {c.cell["id"]: i for i, c in enumerate(cells)}

    def left(i: int) -> float:
        """Seconds cell ``i`` may run: the limit, less what its exercise's answer has run if it is an answer's."""
        c = cells[i]
        return timeout - spent.get(c.exercise, 0.0) if c.role == "answer" and c.exercise is not None else timeout

    class DeafCell(Exception):  # a cell ran on after the interrupt at its limit: its kernel was killed
        pass

    async def alive() -> bool:
        return client.km is not None and bool(await ensure_async(client.km.is_alive()))

    async def start(cell: Any, cell_index: int) -> None:
        if after_timeout and not await alive():
            raise DeadKernelError("the kernel died")  # a death taken for a cell's timeout, under load
        if left(cell_index) < 1:  # the answer has run its limit: its later cells do not run
            cell.source = ""
            outcomes[cell_index] = (TIMEOUT, f"the answer's cells ran {timeout} s in all")
        began[cell_index] = time.monotonic()

    async def executed(cell: Any, cell_index: int, execute_reply: dict | None) -> None:
        nonlocal after_timeout
        c = cells[cell_index]
        if c.role == "answer" and c.exercise is not None:
            spent[c.exercise] = spent.get(c.exercise, 0.0) + time.monotonic() - began[cell_index]
        content = (execute_reply or {}).get("content", {})
        after_timeout = content.get("status") == "error" and content.get("ename") == TIMEOUT
        if content.get("status") == "error":
            outcomes[cell_index] = (str(content.get("ename", "Error")), _one_line(content.get("evalue", "")))
        else:
            outcomes[cell_index] = None
        # At the limit nbclient interrupts the kernel and waits up to its iopub_timeout (GRACE) for the cell's "idle"
        # status, recorded in the cell's execution metadata (record_timing); none: the cell runs on, deaf to the
        # interrupt, and every later cell would wait behind it.
        if after_timeout and "iopub.status.idle" not in cell.get("metadata", {}).get("execution", {}):
            if not await alive():
                raise DeadKernelError("the kernel died")
            outcomes[cell_index] = (IGNORED, f"still running {GRACE} s after the interrupt; the kernel was killed")
            assert client.km is not None  # alive
            await ensure_async(client.km.shutdown_kernel(now=True))
            raise DeafCell(cell_index)

    async def up(notebook: Any) -> None:  # noqa: ARG001 (nbclient's hook: the kernel is up, no cell has run)
        if stop is not None:
            stopping.started(stop, id(client), client.km)

    client = nbclient.NotebookClient(
        nbformat.from_dict(nb),
        timeout=timeout,
        timeout_func=lambda cell: int(left(index[cell["id"]])),  # at least 1: a cell with less left does not run
        kernel_name="python3",
        allow_errors=True,
        interrupt_on_timeout=True,
        error_on_timeout={"ename": TIMEOUT, "evalue": f"ran longer than {timeout} s and was stopped", "traceback": []},
        iopub_timeout=GRACE,
        record_timing=True,
        resources={"metadata": {"path": str(tutorial.folder)}},
        on_notebook_start=up,
        on_cell_start=start,
        on_cell_executed=executed,
    )
    stopped = None
    try:
        # a loop of its own, closed at the end, in whichever thread marks; the kernel's log lines go nowhere
        asyncio.run(client.async_execute(stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
    except DeafCell as ended:
        deaf = _named(cells, tutorial, ended.args[0])
        stopped = f"the run stopped: {deaf} ignored the interrupt at its {timeout} s limit, so the kernel was killed"
    except DeadKernelError:
        stopped = DIED
    except Exception as exc:  # the marker reports any failure of the run itself, never stops on it
        # a kernel that dies while nbclient (re)connects is a RuntimeError "Kernel died before replying ..."
        died = "kernel died" in str(exc).lower()
        stopped = DIED if died else _one_line(f"the run stopped: {type(exc).__name__}: {exc}")
    finally:
        stopping.ended(id(client))
    if stop is not None and stop.is_set():  # its kernel killed by stop_marking: no mark, whatever the run said
        raise stopping.Stopped
    return outcomes, stopped


def _verdict(
    k: int, cells: list[_Cell], outcomes: dict[int, tuple[str, str] | None], stopped: str | None, timeout: int
) -> tuple[str, str]:
    """(status, message) of exercise ``k`` from what its cells did: passed when its answer ran without an error
    or a timeout and every check ran without an error; else the first of its cells that failed (the answer's error
    or timeout, then a check's), else why its checks did not run. An answer that binds the right values and then
    raises or runs over its limit scores 0 too (docs/tutorials.md: an answer that raises or runs over its time
    limit scores 0)."""
    mine = [(i, c.role) for i, c in enumerate(cells) if c.exercise == k]
    checks = [i for i, role in mine if role in ("check", "hidden", "guard")]
    answered = all(outcomes.get(i) is None for i, role in mine if role == "answer")  # a cell not run: none failed
    if answered and all(i in outcomes and outcomes[i] is None for i in checks):
        return "passed", ""
    failed = [(i, role, outcomes[i]) for i, role in mine if outcomes.get(i) is not None]
    if not failed:
        return "not run", stopped or "its check did not run"
    _, role, error = failed[0]
    assert error is not None
    name, message = error
    if name in (TIMEOUT, IGNORED):
        what = f"{'the answer' if role == 'answer' else 'a check'} ran longer than {timeout} s"
        if name == TIMEOUT:
            return "timeout", f"{what} and was stopped"
        return "timeout", f"{what}, ignored the interrupt (still running {GRACE} s later), and its kernel was killed"
    if role == "answer":
        return "error", _one_line(f"the answer raised {name}: {message}")
    said = message if name == "AssertionError" and message else f"{name}: {message}".rstrip(": ")
    if role == "guard":  # the answer rebound a name of the lesson the checks read
        return "failed", _one_line(said)
    return "failed", _one_line(f"{'check' if role == 'check' else 'marking check'}: {said}")


def tutorial_of(path: Path, nb: dict | None, tutorials: dict[str, Tutorial]) -> str | None:
    """The teacher's notebook a submission answers: the one its metadata names, else the one its file name holds."""
    named = handout_of(nb) if nb is not None else None
    if named in tutorials:
        return named
    return next((name for name in sorted(tutorials, key=len, reverse=True) if name in path.stem), None)


def mark_submission(
    path: Path, shown: str, tutorials: dict[str, Tutorial], timeout: int, *, stop: threading.Event | None = None
) -> SubmissionMark:
    """Mark the notebook at ``path`` (named ``shown`` in the report); never raises for a bad submission. With a
    ``stop``, :func:`~.stopping.stop_marking` ends the run at once, and this raises :class:`~.stopping.Stopped`."""
    stopping.check_stop(stop)
    try:
        nb: dict | None = read_notebook(path)
        problem = None
    except SteamError as exc:
        nb, problem = None, str(exc)
    name = tutorial_of(path, nb, tutorials)
    if name is None:
        why = problem or "not a handout of any of the teacher's notebooks (no steam_ref.handout_of metadata)"
        return SubmissionMark(shown, None, error=_one_line(why))
    tutorial = tutorials[name]
    if nb is None:
        zero = tuple(
            ExerciseMark(e.number, e.title, 0, 1, "not run", _one_line(problem or "")) for e in tutorial.exercises
        )
        return SubmissionMark(shown, name, zero, error=_one_line(problem or ""))
    cells, missing = _assemble(tutorial, nb)
    outcomes, stopped = _run(cells, tutorial, timeout, stop)
    marks = []
    for k, e in enumerate(tutorial.exercises):
        status, message = _verdict(k, cells, outcomes, stopped, timeout)
        if missing.get(k) and status != "passed":
            status, message = "no answer", str(missing[k])
        marks.append(ExerciseMark(e.number, e.title, int(status == "passed"), 1, status, message))
    notes: list[str] = []
    for i, c in enumerate(cells):
        error = outcomes.get(i)
        if c.role == "lesson" and error is not None:  # the teacher's own cell: the marking set-up is at fault
            notes.insert(0, _one_line(f"a cell of the teacher's notebook raised {error[0]}: {error[1]}"))
            break
    return SubmissionMark(shown, name, tuple(marks), notes=tuple(notes))
