"""Checks of the numbers and arrays the public API takes, in one place, so every entry point accepts the same things.

What counts as what (raising a :class:`~steam_ref.errors.SteamError` subclass that names the argument
and its value otherwise):

- a **number**: a Python ``int`` or ``float``, a NumPy integer or floating scalar, or a 0-d array of
  one; never a ``bool`` (``True`` is not a time step), a string (``"1"`` is not parsed), ``None``, a
  complex number or a sequence (``[1.0]`` is not ``1.0``);
- an **integer**: ``int`` or a NumPy integer, never a ``bool`` nor a float (``2.0`` included);
- an **array**: anything NumPy reads as integers or floats (lists, tuples, arrays), copied to
  float64; never strings, booleans, complex numbers, ``None`` entries or ragged lists;
- a **covariance**: a finite symmetric (n, n) array with no negative variance;
- a number **written as text** (a command-line value, a field of a text file): plain ASCII decimal,
  :data:`DECIMAL` (``-1.5``, ``.5``, ``2e-3``; an integer, :data:`DIGITS`), never what ``float()`` also
  reads: ``1_0`` (10), full-width ``５`` (5), ``inf``, ``nan`` or surrounding blanks.

Keys, lists of keys and estimates are checked in :mod:`steam_ref.variables` (``check_key``,
``key_list``, ``as_values``). This module imports nothing of steam_ref but its errors and :mod:`steam_ref.choices`, the home of
:data:`DECIMAL`, :data:`DIGITS` and :func:`parse_decimal` (read there without NumPy by the command's parser).
"""

from __future__ import annotations

import dataclasses
import math
import numbers
from typing import Any, TypeGuard, TypeVar

import numpy as np
from numpy.typing import NDArray

from .choices import DECIMAL, DIGITS, parse_decimal  # the rule for numbers as text: NumPy-free, for the parser
from .errors import ShapeError, SteamError

__all__ = [
    "number",
    "time_step",
    "integer",
    "is_integer",
    "flag",
    "replace_fields",
    "instance",
    "real_array",
    "finite",
    "asymmetric",
    "most_asymmetric",
    "check_covariance",
    "DECIMAL",
    "DIGITS",
    "parse_decimal",
]


def _show(value: object, limit: int = 80) -> str:
    """repr of a value, cut to ``limit`` characters."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _real(value: object) -> float | None:
    """``value`` as a float if it is a real number (not a bool, a string, a sequence...), else None."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        return None
    return float(value)


def number(name: str, value: object, *, finite: bool = True) -> float:
    """``value`` as a float; SteamError naming ``name`` for a bool, a string, a sequence, NaN (and ±inf if
    ``finite``)."""
    x = _real(value)
    if x is None:
        raise SteamError(f"{name} must be a real number, got {name}={_show(value)}")
    if math.isnan(x) or (finite and math.isinf(x)):
        raise SteamError(f"{name} must be a finite number, got {name}={x}")
    return x


def time_step(value: object, name: str = "dt", *, positive: bool = True) -> float:
    """A finite time step (> 0 when ``positive``) as a float."""
    what = "positive and finite" if positive else "finite"
    x = _real(value)
    if x is None:
        raise SteamError(f"time step must be a {what} number, got {name}={_show(value)}")
    if not math.isfinite(x) or (positive and x <= 0):
        raise SteamError(f"time step must be {what}, got {name}={x}")
    return x


def is_integer(value: object) -> TypeGuard[int | np.integer]:
    """Whether ``value`` is an integer: a Python ``int`` or a NumPy integer, never a ``bool`` (nor a float, ``2.0``
    included). The one statement of what an integer is; :func:`integer` and every count the package checks use it."""
    return isinstance(value, (int, np.integer)) and not isinstance(value, (bool, np.bool_))


def flag(name: str, value: object) -> bool:
    """``value`` as a bool: True or False (a NumPy bool too), never a stand-in read as one (1, "no", None, [])."""
    if not isinstance(value, (bool, np.bool_)):
        raise SteamError(f"{name} must be True or False, got {name}={_show(value)}")
    return bool(value)


def integer(name: str, value: object, minimum: int | None = None) -> int:
    """``value`` as an int (:func:`is_integer`), at least ``minimum``."""
    if not is_integer(value):
        raise SteamError(f"{name} must be an integer, got {name}={_show(value)}")
    if minimum is not None and value < minimum:
        raise SteamError(f"{name} must be an integer >= {minimum}, got {name}={int(value)}")
    return int(value)


_D = TypeVar("_D")


def replace_fields(instance: _D, changes: dict[str, Any]) -> _D:
    """A copy of the dataclass ``instance`` with ``changes`` applied (its ``__post_init__`` checks them again);
    SteamError naming the first field the class does not have, and the fields it does. The one home of every
    settings class's ``replace``."""
    names = [f.name for f in dataclasses.fields(instance)]  # type: ignore[arg-type]
    unknown = sorted(set(changes) - set(names))
    if unknown:
        raise SteamError(f"{type(instance).__name__} has no field {unknown[0]!r}; the fields are {sorted(names)}")
    return dataclasses.replace(instance, **changes)  # type: ignore[type-var]


def instance(name: str, value: object, cls: type[_D], how: str) -> _D:
    """``value`` itself when it is a ``cls`` (a set-up, a settings object); SteamError naming ``name``, the class and
    ``how`` one is made otherwise (a string, a dict or None given for one failed far from where it was given)."""
    if not isinstance(value, cls):
        raise SteamError(f"{name} must be a {cls.__name__} ({how}), got {name}={_show(value)}")
    return value


def real_array(name: str, value: object) -> NDArray:
    """A float64 copy of ``value``, which must hold integers or floats only (any shape)."""
    if isinstance(value, (str, bytes)):
        raise ShapeError(f"{name} must be an array of numbers, got the string {name}={_show(value)}")
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):  # a ragged list
        raise ShapeError(f"{name} must be an array of numbers, got {name}={_show(value)}") from None
    if a.dtype.kind not in "iuf":
        raise ShapeError(f"{name} must be an array of numbers, got {name}={_show(value)} (dtype {a.dtype})")
    return np.array(a, dtype=float)


def floats(name: str, value: object) -> NDArray:
    """``value`` itself when it is a float64 array (read, never written: a long trajectory is not copied at each
    figure), else :func:`real_array`'s checked float64 copy."""
    return value if type(value) is np.ndarray and value.dtype == np.float64 else real_array(name, value)


def finite(name: str, a: NDArray) -> NDArray:
    """``a`` itself; ShapeError naming the first NaN or inf entry otherwise."""
    if not np.isfinite(a).all():
        where = np.unravel_index(int(np.flatnonzero(~np.isfinite(a))[0]), a.shape)
        at = ", ".join(map(str, where))
        raise ShapeError(f"{name} must be finite, but {name}[{at}] = {a[where]}")
    return a


def asymmetric(P: NDArray) -> NDArray:
    """Which of the (..., n, n) matrices ``P`` are not symmetric to 1e-10 of their largest entry (a bool per matrix):
    the one symmetry rule of a covariance handed in."""
    return np.abs(P - np.swapaxes(P, -1, -2)).max(axis=(-2, -1)) > 1e-10 * np.abs(P).max(axis=(-2, -1))


def most_asymmetric(P: NDArray) -> tuple[int, int]:
    """The entry (i, j) of a square ``P`` where P and Pᵀ differ most (the one an error message names)."""
    i, j = np.unravel_index(int(np.argmax(np.abs(P - P.T))), P.shape)
    return int(i), int(j)


def check_covariance(name: str, P: NDArray, n: int) -> NDArray:
    """``P`` itself if it can be a covariance: (n, n), finite, symmetric (to 1e-10 of its largest entry),
    no negative variance. Positive definiteness is not checked: a computed covariance may be
    semidefinite to rounding."""
    if P.shape != (n, n):
        raise ShapeError(f"{name} must be a finite ({n}, {n}) matrix, got shape {P.shape}")
    finite(name, P)
    if asymmetric(P):
        i, j = most_asymmetric(P)
        raise SteamError(
            f"{name} must be symmetric, but {name}[{i}, {j}] = {float(P[i, j])!r} "
            f"and {name}[{j}, {i}] = {float(P[j, i])!r}"
        )
    diagonal = np.diagonal(P)
    if np.any(diagonal < 0):
        k = int(np.flatnonzero(diagonal < 0)[0])
        raise SteamError(f"{name} has a negative variance: {name}[{k}, {k}] = {float(diagonal[k])!r}")
    return P
