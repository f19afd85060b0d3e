"""``steam-ref homework``: the student's handouts from the teacher's notebooks, and the marks of their answers::

    steam-ref homework handout NOTEBOOK_OR_FOLDER... [--out DIR]
    steam-ref homework mark SUBMISSION_OR_FOLDER... [--source DIR] [--timeout SECONDS] [--jobs N] [--json]
                                                    [--csv FILE]

``handout`` writes each teacher's notebook (a folder: every notebook in it) to ``DIR`` (default ``handout``)
with each solution an empty answer cell and no marking check (:func:`~steam_ref.homework.exercises.handout`).
``mark`` marks every notebook given or found under a folder against the teacher's notebooks in ``--source``
(default ``tutorials``), ``--jobs`` at once: one line per submission with its score, one per exercise with its point and, if it
lost it, why; ``--json`` prints the same as one JSON document; ``--csv`` also writes a grade book, one row per
submission (:func:`grade_book`). Exit code 0 once every submission is marked
(a submission that cannot be read scores 0, saying why), 2 on bad input: a path that does not exist, a file
given that is not a notebook (one over ``exercises.MAX_BYTES`` too, refused unread) or a handout of none of the
teacher's notebooks, a folder with no notebook.
"""

from __future__ import annotations

import argparse
import csv
import io
import json
import sys
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from ..errors import SteamError
from ..files import replace_file
from .exercises import handout, read_notebook
from .marking import SubmissionMark, Tutorial, load_tutorials, mark_submission, requirements, tutorial_of
from .stopping import stop_marking

__all__ = ["run", "grade_book"]


def _notebooks(paths: list[str], what: str, clash: Callable[[Path, str], str]) -> list[tuple[Path, str]]:
    """Each notebook given or under a folder given, with the name the report shows; SteamError for a path that
    does not exist, a file that is not a .ipynb, a folder with none. A folder's .ipynb that is no file (a pipe, a link
    to nothing) is kept: reading it says so (a submission scores 0 saying why; a teacher's notebook is refused).

    Each notebook once, under its own name: a file given twice, or two files whose ``clash(path, shown)`` is the same
    text (what the command makes of each: a handout's file, a mark's report line) is a SteamError naming both."""
    found = _found(paths, what)
    first: dict[str, Path] = {}
    for path, shown in found:
        seen = first.setdefault(clash(path, shown), path)
        if seen is not path:
            twice = (
                f"{str(path)!r} is given twice"
                if seen.resolve() == path.resolve()
                else f"{str(seen)!r} and {str(path)!r} {clash(path, shown)}"
            )
            raise SteamError(f"{what}: {twice}; give each notebook once, under its own name")
    return found


def _found(paths: list[str], what: str) -> list[tuple[Path, str]]:
    """The notebooks of :func:`_notebooks`, as given."""
    found = []
    for text in paths:
        path = Path(text)
        if path.is_dir():
            # a pipe or a link to nothing is kept, never left out in silence: read_notebook says what it is, unread
            inside = sorted(p for p in path.rglob("*.ipynb") if ".ipynb_checkpoints" not in p.parts and not p.is_dir())
            if not inside:
                raise SteamError(f"{what}: the folder {text!r} holds no notebook (.ipynb)")
            found += [(p, str(p.relative_to(path))) for p in inside]
        elif path.is_file():
            if path.suffix != ".ipynb":
                raise SteamError(f"{what}: {text!r} is not a notebook (.ipynb)")
            found.append((path, path.name))
        elif path.exists():  # a pipe, a socket, a device: reading it could block or never end
            raise SteamError(f"{what}: {text!r} is neither a file nor a folder")
        else:
            raise SteamError(f"{what}: {text!r} does not exist")
    return found


def _writer(text: str) -> Callable[[str], object]:
    """What writes ``text`` to a file of the given name (for :func:`~steam_ref.files.replace_file`)."""
    return lambda name: Path(name).write_text(text, encoding="utf-8")


def _handout(args: argparse.Namespace) -> int:
    out = Path(args.out)
    # each handout is named as its notebook: two of one name would leave one, in silence
    sources = _notebooks(
        args.notebooks, "handout", lambda path, _: f"would both be written to {str(out / path.name)!r}"
    )
    made = [(path, handout(read_notebook(path), path.name)) for path, _ in sources]  # all checked before any write
    if out.exists() and not out.is_dir():
        raise SteamError(f"--out {args.out!r} is a file, not a folder")
    for path, _ in made:
        if (out / path.name).resolve() == path.resolve():
            raise SteamError(f"--out {args.out!r} would overwrite the teacher's notebook {str(path)!r}")
        if (out / path.name).is_symlink():  # written through, a link would put the handout wherever it points
            raise SteamError(
                f"--out {args.out!r}: {str(out / path.name)!r} is a link; remove it or choose another folder"
            )
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SteamError(f"cannot write the handouts to {args.out!r}: {exc.strerror or exc}") from None
    for path, nb in made:  # each whole or not at all: a full disk or an interrupt leaves the file that was there
        replace_file(out / path.name, _writer(json.dumps(nb, indent=1, ensure_ascii=False) + "\n"), "--out")
    print(f"wrote {len(made)} handout{'s' * (len(made) != 1)} to {out} (answers empty, no solution, no marking check)")
    return 0


def _check_given(given: list[str], tutorials: dict[str, Tutorial]) -> None:
    """A notebook named on the command line must be one, and a handout of one of the teacher's notebooks."""
    for text in given:
        path = Path(text)
        if path.is_file():
            nb = read_notebook(path)
            if tutorial_of(path, nb, tutorials) is None:
                raise SteamError(f"{text!r} is not a handout of any of the teacher's notebooks in --source")


def _print(marks: list[SubmissionMark]) -> None:
    for m in marks:
        head = f"{m.submission}: {m.tutorial or '?'}, {m.score}/{m.out_of}"
        print(head + (f" ({m.error})" if m.error else ""), flush=True)
        for e in m.exercises:
            lost = f" {e.status}: {e.message}" if e.score < e.out_of else ""
            print(f"  Exercise {e.number} · {e.title}: {e.score}/{e.out_of}{lost}")
        for note in m.notes:
            print(f"  note: {note}")


def grade_book(marks: list[SubmissionMark]) -> str:
    """The marks as CSV, one row per submission, to paste into a grade book: ``submission``, ``tutorial``,
    ``score``, ``out_of``, the points of each exercise (``exercise N``: empty where the submission's tutorial has no
    exercise N), ``lost`` (each exercise that lost a point, its status and why, joined by " | ") and ``error`` (why
    the submission could not be marked at all)."""
    numbers = sorted({e.number for m in marks for e in m.exercises})
    out = io.StringIO()
    rows = csv.writer(out, lineterminator="\n")
    rows.writerow(["submission", "tutorial", "score", "out_of", *(f"exercise {n}" for n in numbers), "lost", "error"])
    for m in marks:
        points = {e.number: e.score for e in m.exercises}
        lost = " | ".join(f"exercise {e.number} {e.status}: {e.message}" for e in m.exercises if e.score < e.out_of)
        rows.writerow(
            [
                m.submission,
                m.tutorial or "",
                m.score,
                m.out_of,
                *(points.get(n, "") for n in numbers),
                lost,
                m.error or "",
            ]
        )
    return out.getvalue()


def _mark(args: argparse.Namespace) -> int:
    requirements()
    tutorials = load_tutorials(Path(args.source))
    # a submission is reported by its name: two of one name (alice/01.ipynb, bob/01.ipynb) could not be told apart
    files = _notebooks(
        args.submissions,
        "mark",
        lambda _, shown: (
            f"would both be reported as {shown!r} (give the folder holding both: each is then shown by its path in it)"
        ),
    )
    _check_given(args.submissions, tutorials)
    marks = []
    stop = threading.Event()
    pool = ThreadPoolExecutor(max_workers=args.jobs)  # each submission runs in its own kernel process
    try:
        for mark in pool.map(lambda f: mark_submission(f[0], f[1], tutorials, args.timeout, stop=stop), files):
            marks.append(mark)
            if not args.json:
                _print([mark])
    except BaseException:  # Ctrl-C, SIGTERM: no kernel runs on, no submission starts
        stop_marking(stop)
        raise
    finally:
        pool.shutdown(cancel_futures=True)
    if args.csv is not None:  # whole or not at all: an interrupt or a full disk leaves the file that was there
        replace_file(Path(args.csv), _writer(grade_book(marks)), "--csv")
    if args.json:
        total = {"submissions": [m.as_dict() for m in marks]}
        json.dump(total, sys.stdout, ensure_ascii=False)
        print()
    elif args.csv is not None:
        print(f"grade book written to {Path(args.csv).resolve()}")
    return 0


def run(args: argparse.Namespace) -> int:
    """Run a parsed ``steam-ref homework ...`` command; returns the exit code."""
    return _handout(args) if args.homework_command == "handout" else _mark(args)
