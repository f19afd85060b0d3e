"""The lesson's names an answer must leave as they are, kept around each answer of the marking run.

A marking check compares an answer with the lesson's own names (tutorial 09's ``chi2_band``, 00's ``qc``): an answer
that rebound one would be compared with itself, and a wrong answer with its own wrong helper would pass. The marking
run (:mod:`.marking`) puts a cell of KEEP before each answer and one of PUT_BACK after it: PUT_BACK puts back what the
answer rebound, changed in place (an array), shadowed (a builtin the checks call) or set (a module's function the
checks call) and fails naming it, so that exercise scores 0 and its checks and the exercises after it see the
lesson's values. PUT_BACK runs again after the exercise's checks (``forget``: the kept values then let go), which
call the answer's functions on the lesson's values: a function that changes its argument in place costs its own
exercise there, not a later one. The same holds for a module's
attribute the checks read (``np.allclose = lambda *a, **k: True`` would pass every later check) and for a builtin
set on the builtins module. An equal value bound again (``n = 24`` where the lesson has 24, ``import numpy as np``)
is no change. An array an object of the lesson holds is kept too (``batch.values``' estimates, a list of readings:
through dicts, lists, tuples, sets and instance attributes, six levels deep, 200,000 arrays at most): an answer whose
function changes its argument in place (``x_prev[:3] += dt * x_prev[3:]`` given ``batch.values[X(0)]``) changed the
lesson's estimate, and a right answer to a later exercise then failed its checks; now that costs the answer's own
exercise, naming the object, and the arrays are put back.
"""

from __future__ import annotations

from collections.abc import Sequence

from .exercises import Exercise

__all__ = ["KEEP", "KEPT", "PUT_BACK", "guarded"]

KEPT = "__steam_ref_kept__"
KEEP = """\
def __steam_ref_held__(value, depth=6, most=200_000):
    # the writeable NumPy arrays an object holds (batch.values' estimates, a list of readings), each with a copy:
    # through dicts, lists, tuples, sets and instance attributes, depth levels deep, most arrays at most
    import sys
    import types
    numpy = sys.modules.get("numpy")
    if numpy is None:
        return []
    opaque = (types.ModuleType, type, types.FunctionType, types.BuiltinFunctionType, types.MethodType, str, bytes)
    opaque += (bool, int, float, complex, type(None), numpy.generic)  # a number holds no array: not walked into
    held, seen, todo = [], set(), [(value, 0)]
    while todo and len(held) < most:
        item, level = todo.pop()
        if id(item) in seen or isinstance(item, opaque):
            continue
        seen.add(id(item))
        if isinstance(item, numpy.ndarray):
            if item.dtype != object and item.flags.writeable:
                held.append((item, item.copy()))
            continue
        if level >= depth:
            continue
        try:  # an object whose attributes cannot be read (a proxy's __getattr__ raising) holds nothing we keep
            if isinstance(item, dict):
                inner = list(item.values())
            elif isinstance(item, (list, tuple, set, frozenset)):
                inner = list(item)
            else:
                inner = list(getattr(item, "__dict__", {{}}).values())
                slots = [n for k in type(item).__mro__ for n in getattr(k, "__slots__", ()) if isinstance(n, str)]
                inner += [getattr(item, n) for n in slots if n not in ("__dict__", "__weakref__") and hasattr(item, n)]
        except Exception:
            continue
        todo += [(x, level + 1) for x in inner if not isinstance(x, opaque)]
    return held


def __steam_ref_keep__(names, scope):
    import builtins
    import types
    kept = {{}}
    for name in names:
        root, *path = name.split(".")
        if path:  # an attribute chain: each link a module holds (np.allclose, np.linalg), as (module, attribute, value)
            owner = scope.get(root)
            for i, attribute in enumerate(path):
                if not isinstance(owner, types.ModuleType) or not hasattr(owner, attribute):
                    break
                value = getattr(owner, attribute)
                kept[".".join([root, *path[: i + 1]])] = (owner, attribute, value)
                owner = value
        elif name in scope:
            value = scope[name]
            saved = value.copy() if type(value).__name__ == "ndarray" and hasattr(value, "copy") else None
            kept[name] = (value, saved, __steam_ref_held__(value) if saved is None else [])
        elif hasattr(builtins, name):
            kept[name] = None
            kept["builtins." + name] = (builtins, name, getattr(builtins, name))
    return kept


{kept} = __steam_ref_keep__({names!r}, globals())
del __steam_ref_keep__, __steam_ref_held__
"""
PUT_BACK = """\
def __steam_ref_put_back__(kept, scope):
    try:
        import numpy
    except ImportError:
        numpy = None
    plain = (bool, int, float, complex, str, bytes, type(None)) + ((numpy.generic,) if numpy else ())
    changed, patched, altered = [], [], []
    for name, was in kept.items():
        if "." in name:  # a module's attribute: the answer must not set it
            owner, attribute, value = was
            if getattr(owner, attribute, kept) is not value:
                patched.append(name)
                setattr(owner, attribute, value)
            continue
        if was is None:  # a builtin: the answer must not shadow it
            if name in scope:
                changed.append(name)
                del scope[name]
            continue
        value, saved, held = was
        now = scope.get(name, kept)  # kept: a stand-in for "no longer bound"
        if saved is not None:
            same = type(now) is type(saved) and now.shape == saved.shape and now.dtype == saved.dtype
            try:
                same = same and bool(numpy.array_equal(now, saved, equal_nan=True))
            except TypeError:  # not numbers: NaN means nothing
                same = same and bool(numpy.array_equal(now, saved))
            if not same and value.flags.writeable:
                value[...] = saved
        else:
            same = now is value or (type(now) is type(value) and isinstance(value, plain) and bool(now == value))
        if not same:
            changed.append(name)
            scope[name] = value
        inside = False  # an array the object holds, changed in place (batch.values[X(0)][:] = ...): put back
        for array, copy in held:
            try:
                equal = bool(numpy.array_equal(array, copy, equal_nan=True))
            except TypeError:
                equal = bool(numpy.array_equal(array, copy))
            if not equal:
                inside = True
                try:
                    array[...] = copy
                except ValueError:  # made read-only since: nothing to put back into
                    pass
        if inside and same:
            altered.append(name)
    said = []
    if changed:
        named = ", ".join(f"`{{name}}`" for name in changed)
        said.append(
            f"the answer rebinds {{named}}, which the marking checks read from the lesson (put back for them): "
            "give yours another name and leave the lesson's as they are"
        )
    if altered:
        named = ", ".join(f"`{{name}}`" for name in altered)
        said.append(
            f"the answer changes in place an array held by {{named}}, which the marking checks read from the lesson "
            "(put back for them): does a function of yours change its arguments? work on a copy (x = x.copy())"
        )
    if patched:
        named = ", ".join(f"`{{name}}`" for name in patched)
        said.append(f"the answer sets {{named}}, which the marking checks call (put back for them): leave it as it is")
    assert not said, "; ".join(said)


try:
    __steam_ref_put_back__({kept}, globals())
finally:
    del __steam_ref_put_back__{forget}
"""


def guarded(exercises: Sequence[Exercise]) -> tuple[str, ...]:
    """The lesson's names an answer must leave as they are: those any of a tutorial's ``exercises``' checks read, none
    an answer's, and the attribute chains the checks read off them (``np.allclose``)."""
    answers = {n for e in exercises for n in e.names}
    return tuple(sorted({n for e in exercises for n in e.reads if n.split(".")[0] not in answers}))
