"""The tutorials as homework a teacher can mark (docs/tutorials.md, "For teachers").

- :mod:`.exercises`: a teacher's notebook read by its cell tags (each exercise's task, solution, check and
  marking checks), and the student's handout made from it;
- :mod:`.marking`: the marking run, each submission's answers between the teacher's own cells and checks, in a
  fresh kernel under a time limit per cell, scored per exercise;
- :mod:`.guard`: the lesson's names the checks read, kept around each answer: one an answer rebinds costs it;
- :mod:`.stopping`: Ctrl-C while marking, every run's kernel killed at once;
- :mod:`.kinds`: the kind each answer must be (a number, an array of reals, a function...), as its solution
  declares, and the one rule that refuses an answer of another type;
- :mod:`.command`: ``steam-ref homework handout`` and ``steam-ref homework mark``.

Running notebooks needs nbformat, nbclient and ipykernel (the ``notebooks`` extra); they load only when marking.
"""

from .exercises import Exercise, exercises, handout, read_notebook
from .marking import ExerciseMark, SubmissionMark, load_tutorials, mark_submission
from .stopping import Stopped, stop_marking

__all__ = [
    "Exercise",
    "exercises",
    "handout",
    "read_notebook",
    "ExerciseMark",
    "SubmissionMark",
    "load_tutorials",
    "mark_submission",
    "stop_marking",
    "Stopped",
]
