"""What kind of value each answer must be, and the one rule that refuses an answer of another type.

A teacher's solution cell declares the kind of each name its checks read (cell metadata ``steam_ref.answers``,
``{"prior_cost": "function", "prior_costs": "array"}``: docs/tutorials.md, "Exercises"). The marking run
(:mod:`.marking`) checks each answer against its kind, with :func:`refused`, after the answer and before its
checks: an answer of another type scores 0 for that exercise, the message naming the type received and the kind
expected, however right its values (a complex array whose imaginary part is 0 compares equal to the real one, and
``np.allclose`` reads the string ``"9"`` or ``True`` as a number). What a teacher accepts for each kind:

- ``number``: one real number: an int or a float, Python's or NumPy's (``np.float64``, ``np.int64``...), or a 0-d
  NumPy array of one; never a bool, a complex (whatever its imaginary part), a string, a Fraction or a Decimal;
- ``array``: real numbers in an array: a NumPy ``ndarray`` (the class itself) of integers or floats, or a list or
  tuple (nested as deep as the array) of numbers as ``number`` accepts them, which NumPy reads as one array of ints
  or floats (not ragged; an int past 64 bits makes it an object array); never a bool, complex, object or string
  array, a masked array, a ``np.matrix`` (whose ``*`` and indexing differ from an array's), a sparse matrix;
- ``function``: anything callable but a class;
- ``set``, ``list``, ``dict``: that container (a subclass too: ``collections.Counter`` is a dict); its items are
  the checks' business;
- ``any``: whatever the checks accept (an object of the library, such as a solver's report).

A list of floats for an array is the same numbers, which any NumPy call takes as they are; a bool or a complex is
another kind of number, a string a number's text, a masked array or a matrix another algebra: the checks might
read them as the right numbers, but they are not the answer asked for.
"""

from __future__ import annotations

from typing import Any, Optional  # noqa: F401 (read by mypy in refused's type comments)

__all__ = ["KINDS", "check_cell", "refused"]

KINDS = {
    "number": "a real number (an int or a float)",
    "array": "an array of real numbers (a NumPy array of ints or floats, or a list or tuple of numbers)",
    "function": "a function",
    "set": "a set",
    "list": "a list",
    "dict": "a dict",
    "any": "any value the checks accept",
}


def refused(value, kind):  # type: (Any, str) -> Optional[str]
    """What ``value`` is, by its type ("a str", "a numpy.ndarray of dtype complex128"), if it is no answer of
    ``kind`` (a key of KINDS); None if it is one.

    Self-contained (its helpers inside, NumPy taken only if the kernel has loaded it), as the marking run sends its
    source to the kernel (:func:`check_cell`) as it is written: its types are comments, which the kernel does not
    evaluate (an annotation would name ``Any``, which the kernel lacks, or a name the student has rebound), and no
    parser rewrites it (``ast.parse`` in the marking's threads broke CPython 3.11's AST recursion count:
    ``SystemError: AST constructor recursion depth mismatch``)."""
    import sys

    numpy = sys.modules.get("numpy")

    def named(v):  # type: (Any) -> str
        t = type(v)
        name = t.__qualname__ if t.__module__ == "builtins" else f"{t.__module__}.{t.__qualname__}"
        if numpy is not None and isinstance(v, numpy.ndarray):
            name += f" of dtype {v.dtype}"
        return ("an " if name[0] in "aeiou" else "a ") + name

    def real_array(v):  # type: (Any) -> bool
        return numpy is not None and type(v) is numpy.ndarray and v.dtype.kind in "iuf"

    def number(v):  # type: (Any) -> bool
        if type(v) in (int, float):
            return True
        if numpy is not None and isinstance(v, numpy.generic):
            return v.dtype.kind in "iuf"
        return real_array(v) and v.ndim == 0

    def odd_item(v):  # type: (Any) -> Any
        """The first item of a (nested) list or tuple that is no number nor real array, or None."""
        todo = [v]
        while todo:
            item = todo.pop()
            if type(item) in (list, tuple):
                todo += list(item)
            elif not number(item) and not real_array(item):
                return item
        return None

    if kind == "any":
        return None
    if kind == "number":
        ok = number(value)
    elif kind == "array" and type(value) in (list, tuple):
        odd = odd_item(value)
        if odd is not None:
            return f"{named(value)} holding {named(odd)}"
        try:
            dtype = None if numpy is None else numpy.asarray(value).dtype
        except ValueError:  # ragged
            return f"{named(value)} of rows of different lengths"
        if dtype is not None and dtype.kind not in "iuf":  # an int past 64 bits: NumPy holds it as an object
            return f"{named(value)} that NumPy reads as an array of dtype {dtype}"
        ok = True
    elif kind == "array":
        ok = real_array(value) and value.ndim > 0
    elif kind == "function":
        ok = callable(value) and not isinstance(value, type)
    else:
        ok = (
            isinstance(value, (set, frozenset))
            if kind == "set"
            else isinstance(value, list if kind == "list" else dict)
        )
    return None if ok else named(value)


CHECK = """\
{function}

def __steam_ref_kinds__(kinds, described, scope):
    wrong = []
    for name, kind in kinds.items():
        if name in scope:  # unbound: the check says so (NameError)
            got = __steam_ref_refused__(scope[name], kind)
            if got is not None:
                wrong.append(f"`{{name}}` is {{got}}, not {{described[kind]}}")
    assert not wrong, "the answer's type is not the one asked for: " + "; ".join(wrong)


try:
    __steam_ref_kinds__({kinds!r}, {described!r}, globals())
finally:
    del __steam_ref_kinds__, __steam_ref_refused__
"""


def check_cell(kinds: dict[str, str]) -> str:
    """The marking run's cell that checks each name of ``kinds`` bound by the answer against its kind
    (:func:`refused`), failing with every refusal; it leaves no name behind."""
    import inspect  # here: only marking needs it, and the CLI loads this module for any homework command

    function = inspect.getsource(refused).replace("def refused(", "def __steam_ref_refused__(", 1)
    described = {kind: KINDS[kind] for kind in kinds.values()}
    return CHECK.format(function=function, kinds=dict(kinds), described=described)
