"""Variables and their current estimates.  [YIB Sec. III-A]

Variables are named by small keys: ``X(i)`` is the trajectory state x(tᵢ) at pose i (the paper's front end
keys a state by its pose's index, so with a layout that skips poses only some i have one; in a problem of
one's own, any integer) and ``L(j)`` is landmark ℓⱼ. :class:`Values` maps keys
to estimates (1-D float arrays), each moved by the :class:`~steam_ref.manifold.Manifold` of its kind
(a vector space unless told otherwise). This module sits at the bottom of the package: it imports
nothing of steam_ref but its errors, :mod:`.arguments` and :mod:`.manifold`.
"""

from __future__ import annotations

import math
from collections.abc import Container, Iterable, Iterator, Mapping
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from .arguments import is_integer
from .errors import KindError, NumericalError, ShapeError, SteamError, UnknownVariableError
from .manifold import VECTOR, Manifold, by_kind

__all__ = [
    "Key",
    "X",
    "L",
    "INDEX_BITS",
    "Values",
    "check_key",
    "check_symbol",
    "check_roles",
    "key_list",
    "as_values",
    "check_new_values",
    "kind_clash",
]


# The field `index` shadows tuple.index on purpose (a key's index is the paper's subscript). mypy reports
# that shadowing, in the class syntax of NamedTuple, as an incompatible override; in the functional
# syntax it does not, hence the functional syntax here (and UP014 off for this line).
_KeyFields = NamedTuple("_KeyFields", [("symbol", str), ("index", int)])  # noqa: UP014


class Key(_KeyFields):
    """The name of a variable: a symbol ('x' for states, 'l' for landmarks, GTSAM's ``Symbol.chr()``) and an
    integer index. (What space the variable lives in is its *kind*, a :class:`~steam_ref.manifold.Manifold`.)"""

    __slots__ = ()

    def __new__(cls, symbol: str, index: int) -> Key:
        """The rules of :func:`X` and :func:`L` for any symbol: one character of 8 bits (GTSAM's ``Symbol.chr()``)
        and an integer index of magnitude below 2⁵⁶ (:data:`INDEX_BITS`)."""
        return super().__new__(cls, check_symbol(symbol), _index("Key", index))

    def __repr__(self) -> str:
        return f"{self.symbol}{self.index}"

    def __str__(self) -> str:
        return f"{self.symbol}{self.index}"


def check_symbol(symbol: object, what: str = "a key's symbol") -> str:
    """``symbol`` if a :class:`Key` can have it: one character of 8 bits (GTSAM's ``Symbol.chr()``); SteamError
    naming ``what`` and the value otherwise. What a key, and every table keyed by a key's symbol, takes."""
    if not isinstance(symbol, str) or len(symbol) != 1 or ord(symbol) > 255:
        raise SteamError(f"{what} is one character of 8 bits (GTSAM's Symbol.chr()), got {symbol!r:.40}")
    return symbol


# GTSAM's Symbol packs a key into 64 bits: its character in the top 8, its index in the low 56
# (``bayes_tree.dot.gtsam_key``). An index of magnitude 2⁵⁶ or more has no such key (it would run into the
# character's bits), so it is refused. Negative indices are kept (down to -(2⁵⁶ - 1)): ``X(-1)`` is by design the
# placeholder key of an interpolated reading's inner measurement, and any negative index still gives each key its
# own integer there (GTSAM has no Symbol for one, whatever its size).
INDEX_BITS = 56


def _index(name: str, i: int) -> int:
    """A key's index: an int or a NumPy integer (a bool, a float, even 2.0, or a string is refused) of magnitude below
    2⁵⁶ (:data:`INDEX_BITS`)."""
    if not is_integer(i):
        raise SteamError(f"{name} takes an integer index, got {i!r}")
    index = int(i)
    if abs(index) >> INDEX_BITS:
        raise SteamError(
            f"{name} takes an index of magnitude below 2**{INDEX_BITS} (GTSAM's Symbol keeps {INDEX_BITS} bits for "
            f"it beside an 8-bit character), got {name}({index})"
        )
    return index


def X(i: int) -> Key:
    """The key of the trajectory state at pose i (an integer, of magnitude below 2⁵⁶): the variable x(tᵢ).

    With the vector-space priors, x(tᵢ) = [x, y, θ, ẋ, ẏ, θ̇]: [x, y] is the position (m) and θ the heading
    (rad, counter-clockwise from the world's x axis, never wrapped) in the world frame; [ẋ, ẏ, θ̇] their time
    derivatives, **the velocity in the world frame** (m/s, rad/s), not the robot's. The WNOJ and Singer priors
    append [ẍ, ÿ, θ̈]. On SE(2) (:data:`~steam_ref.lie.SE2_STATE`) it is the pose and its body twist,
    [px, py, θ, vx, vy, ω]. Conventions: docs/api.md.
    """
    return Key("x", _index("X", i))


def L(j: int) -> Key:
    """The key of landmark number j (an integer, of magnitude below 2⁵⁶): the variable ℓ = [x, y], its position in the
    world frame (m)."""
    return Key("l", _index("L", j))


def _checked_vector(key: Key, value: object) -> NDArray:
    """``value`` as a float copy, or ShapeError unless it is a non-empty finite 1-D vector of numbers."""
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):  # a ragged list
        a = np.asarray(None)
    if a.dtype.kind not in "iuf":  # not strings, bools, None or objects
        raise ShapeError(f"estimate of {key} must be a vector of numbers, got {value!r}")
    v = np.array(a, dtype=float)
    if v.ndim != 1 or v.shape[0] == 0:
        raise ShapeError(f"estimate of {key} must be a non-empty 1-D vector, got shape {v.shape}")
    if not np.isfinite(v).all():
        raise ShapeError(f"estimate of {key} is not finite: {v}")
    return v


FLOAT64 = np.dtype(np.float64)  # an array of floats already, told by ``a.dtype is FLOAT64`` (cheaper than ==)


def _check_kind(key: Key, kind: object) -> Manifold:
    if not isinstance(kind, Manifold):
        raise SteamError(f"the kind of {key!r} must be a Manifold (steam_ref.manifold), got {kind!r:.80}")
    return kind


def kind_clash(key: Key, first: Manifold, by_first: str, second: Manifold, by_second: str) -> KindError:
    """The error for a variable given two kinds: names the key, both kinds and who gave each."""
    return KindError(
        f"the kind of {key!r} is given twice and differs: {first.name} by {by_first}, {second.name} by {by_second}"
    )


class Values(Mapping):
    """Current estimates: key → 1-D float64 array, each with its kind (:class:`~steam_ref.manifold.Manifold`).

    A kind is given with ``kinds`` (or :meth:`insert`), or by a solver from the factors naming the key
    (a plain mapping of estimates is enough: its factors say what each variable is); a variable no one gave a
    kind reads as :data:`~steam_ref.manifold.VECTOR`. A value given a kind is checked against it (an SE(2) state
    is six numbers, its heading in (-π, π]). Unknown keys raise :class:`UnknownVariableError`."""

    def __init__(
        self,
        items: Mapping[Key, NDArray] | Iterable[tuple[Key, NDArray]] = (),
        kinds: Mapping[Key, Manifold] | None = None,
    ):
        self._data: dict[Key, NDArray] = {}
        self._kinds: dict[Key, Manifold] = {}  # the kinds given (VECTOR included): every other key reads as VECTOR
        pairs: object = items.items() if isinstance(items, Mapping) else items  # checked, as given at run time
        if isinstance(pairs, (str, bytes)) or not isinstance(pairs, Iterable):
            raise SteamError(f"Values takes a mapping key -> vector or (key, vector) pairs, got {items!r}")
        for pair in pairs:
            if not isinstance(pair, tuple) or len(pair) != 2:
                raise SteamError(f"Values takes (key, vector) pairs, got the item {pair!r}")
            key, value = pair
            if key in self._data:
                raise SteamError(f"Values given two estimates of {key!r}")
            self.insert(key, value)
        if kinds is not None:
            if not isinstance(kinds, Mapping):
                raise SteamError(f"Values takes kinds as a mapping key -> Manifold, got {kinds!r:.80}")
            for key, kind in kinds.items():
                if key not in self._data:
                    raise UnknownVariableError(f"kinds names {key!r}, which has no estimate")
                self._set_kind(key, kind, self._data[key])

    def _set_kind(self, key: Key, kind: object, value: NDArray) -> None:
        _check_kind(key, kind).check(f"the estimate of {key!r}", value)
        self._kinds[key] = kind  # type: ignore[assignment]

    def kind(self, key: Key) -> Manifold:
        """How ``key``'s estimate moves (:data:`~steam_ref.manifold.VECTOR` unless it was given another)."""
        if key not in self._data:
            raise UnknownVariableError(f"no estimate for variable {key!r}")
        return self._kinds.get(key, VECTOR)

    def kinds(self) -> dict[Key, Manifold]:
        """The kind of every variable that was given one, VECTOR included (a copy; a solver's estimate gives
        every variable its kind)."""
        return dict(self._kinds)

    def check_kinds(self, kinds: Mapping[Key, Manifold], by: str) -> None:
        """KindError for a variable whose given kind differs from its kind in ``kinds`` (what ``by`` says)."""
        for key, kind in self._kinds.items():
            other = kinds.get(key, kind)
            if other is not kind and other != kind:
                raise kind_clash(key, kind, "its value (Values(kinds=))", other, by)

    def with_kinds(self, kinds: Mapping[Key, Manifold], by: str) -> Values:
        """A copy whose variables named in ``kinds`` have those kinds (what ``by`` says, their factors say);
        :class:`KindError` for one given another kind here, each value checked against its new kind."""
        self.check_kinds(kinds, by)
        out = self.copy()
        for key, kind in kinds.items():
            value = self._data.get(key)
            if value is not None and self._kinds.get(key) is not kind:
                out._set_kind(key, kind, value)
        return out

    def insert(self, key: Key, value: NDArray, kind: Manifold | None = None) -> None:
        """Add (or replace) the estimate of one variable; checks the key and that the value is a finite vector
        (of the kind's size and rules). ``kind`` None keeps the key's kind (none given, for a new key)."""
        if not isinstance(key, Key):
            raise SteamError(f"{key!r} is not a variable key (make one with X(i) or L(j))")
        if type(value) is np.ndarray and value.dtype is FLOAT64 and value.ndim == 1 and value.size:
            v = value.copy()  # a float vector (what a front end gives): one copy, one sum of floats to check it finite
            if not math.isfinite(sum(v.tolist())):  # NaN, inf, or a sum that overflowed: each check
                v = _checked_vector(key, value)
        else:
            v = _checked_vector(key, value)
        old = self._data.get(key)
        if old is not None and old.shape != v.shape:
            raise ShapeError(f"estimate of {key} changes size from {old.shape[0]} to {v.shape[0]}")
        kind = self._kinds.get(key) if kind is None else kind
        if kind is not None:
            self._set_kind(key, kind, v)
        self._data[key] = v

    def __getitem__(self, key: Key) -> NDArray:
        try:
            return self._data[key]
        except KeyError:
            raise UnknownVariableError(f"no estimate for variable {key!r}") from None

    def __iter__(self) -> Iterator[Key]:
        return iter(self._data)

    def __len__(self) -> int:
        return len(self._data)

    def __contains__(self, key: object) -> bool:
        return key in self._data

    def copy(self) -> Values:
        """An independent copy (the arrays are copied too)."""
        out = Values()
        out._data = {k: v.copy() for k, v in self._data.items()}
        out._kinds = dict(self._kinds)
        return out

    def dim(self, key: Key) -> int:
        """Size of one variable."""
        return self[key].shape[0]

    def dims(self) -> dict[Key, int]:
        """Size of every variable (what an ordering needs: :func:`steam_ref.linear.ordering.make_ordering`)."""
        return {k: v.shape[0] for k, v in self._data.items()}

    def remove(self, key: Key) -> None:
        """Drop the estimate of one variable (UnknownVariableError if it has none)."""
        if key not in self._data:
            raise UnknownVariableError(f"no estimate for variable {key!r}")
        del self._data[key]
        self._kinds.pop(key, None)

    @classmethod
    def adopt(cls, arrays: Mapping[Key, NDArray], kinds: Mapping[Key, Manifold] | None = None) -> Values:
        """A Values holding ``arrays`` themselves: no copy, no check. Only for a caller whose arrays are
        finite 1-D float vectors by construction and never written in place (a solver's read-only
        estimates); anyone else builds a ``Values(mapping)``, which checks and copies. ``kinds``: each key's kind
        (copied)."""
        return cls._holding(dict(arrays), dict(kinds) if kinds else {})

    @classmethod
    def view(cls, arrays: dict[Key, NDArray], kinds: dict[Key, Manifold] | None = None) -> Values:
        """A Values reading the dicts ``arrays`` and ``kinds`` themselves: no copy, no check, later changes to the
        dicts show through. Only for a solver handing its own store to a reader (linearization at θ̄) that never
        writes into it."""
        return cls._holding(arrays, {} if kinds is None else kinds)

    @classmethod
    def _holding(cls, data: dict[Key, NDArray], kinds: dict[Key, Manifold]) -> Values:
        """A Values whose stores are ``data`` and ``kinds`` themselves, made without ``__init__``'s checks of items."""
        out = cls.__new__(cls)
        out._data, out._kinds = data, kinds
        return out

    def stack(self, keys: Iterable[Key]) -> NDArray:
        """Estimates of several variables of one size as rows of an (n, dim) array."""
        try:
            rows = list(map(self._data.__getitem__, keys))  # a call of __getitem__ per key costs twice this
        except KeyError as exc:
            raise UnknownVariableError(f"no estimate for variable {exc.args[0]!r}") from None
        try:
            out = np.array(rows)  # np.stack's result at a fifth of its call cost (a linearization's hot path)
        except ValueError:  # a ragged list
            out = None
        if out is None or out.ndim != 2:  # sizes differ (or no keys): name them only then, at no cost to a good call
            sizes = sorted({r.shape[0] for r in rows})
            raise ShapeError(f"Values.stack needs variables of one size, got sizes {sizes}") from None
        return out

    def retract(self, delta: Mapping[Key, NDArray]) -> Values:
        """θ̄ ⊕ δθ: a new Values with each variable moved by its kind's retraction, one call per kind.  [YIB Eq. 11]"""
        steps = {}
        for key, step in delta.items():
            step = np.asarray(step)
            if step.shape != self[key].shape:
                raise ShapeError(f"the update of {key!r} has shape {step.shape}, its estimate {self[key].shape}")
            steps[key] = step
        data = {k: v if k in steps else v.copy() for k, v in self._data.items()}  # a moved one is replaced below
        for kind, keys in by_kind(steps, self._kinds):
            moved = kind.retract_many([self._data[k] for k in keys], [steps[k] for k in keys])
            if moved and not np.isfinite(np.concatenate(moved)).all():  # one check per kind; the key only then
                key = next(k for k, x in zip(keys, moved, strict=True) if not np.all(np.isfinite(x)))
                raise NumericalError(f"the update of {key!r} is not finite: {self[key]} ⊕ {steps[key]}")
            data.update(zip(keys, moved, strict=True))
        return self._holding(data, dict(self._kinds))

    def local(self, other: Mapping[Key, NDArray]) -> dict[Key, NDArray]:
        """other ⊖ self for each key of ``other``, by this Values' kinds, one call per kind."""
        out = {}
        for kind, keys in by_kind(other, self._kinds):
            for key, d in zip(
                keys, kind.local_many([self[k] for k in keys], [np.asarray(other[k]) for k in keys]), strict=True
            ):
                out[key] = d
        return {k: out[k] for k in other}

    def states(self) -> list[Key]:
        """The trajectory-state keys, in index order."""
        return sorted((k for k in self._data if k.symbol == "x"), key=lambda k: k.index)

    def landmarks(self) -> list[Key]:
        """The landmark keys, in index order."""
        return sorted((k for k in self._data if k.symbol == "l"), key=lambda k: k.index)

    def __repr__(self) -> str:
        return f"Values({len(self)} variables)"


# --- checks of the keys and estimates the public API takes -------------------------------------------


def check_key(name: str, value: object) -> Key:
    """``value`` itself if it is a variable key."""
    if not isinstance(value, Key):
        raise SteamError(f"{name} must be a variable key (make one with X(i) or L(j)), got {name}={value!r:.80}")
    return value


def check_roles(owner: str, keys: tuple[Key, ...], n_states: int) -> None:
    """SteamError naming every key unless the first ``n_states`` of ``keys`` are state keys ``X(i)`` and the rest
    landmark keys ``L(j)``: what a factor reading states and landmarks (``owner``) takes. Keys in the wrong roles
    (a range from ``L(0)`` to ``X(0)``) would make a problem of another shape without a word."""
    wrong = [(i, k) for i, k in enumerate(keys) if k.symbol != ("x" if i < n_states else "l")]
    if wrong:
        roles = ", ".join("state X(i)" if i < n_states else "landmark L(j)" for i in range(len(keys)))
        given = ", ".join(map(repr, keys))
        which = ", ".join(f"{k!r} is not a {'state' if i < n_states else 'landmark'} key" for i, k in wrong)
        raise SteamError(f"{owner} takes keys ({roles}), got ({given}): {which}")


def key_list(name: str, keys: object, *, distinct: bool = False) -> list[Key]:
    """The keys of any iterable (a list, a tuple, a generator, a mapping's keys), as a list. A single key
    is refused with a hint, since iterating it would read its kind and index as two keys. ``distinct``: a key
    given twice is refused too, naming it (where the answer is a mapping by key, which cannot hold it twice)."""
    if isinstance(keys, Key):
        raise SteamError(f"{name} must be a list of keys, got the single key {keys!r}: write [{keys!r}]")
    if isinstance(keys, (str, bytes)) or not isinstance(keys, Iterable):
        raise SteamError(f"{name} must be a list of variable keys, got {name}={keys!r:.80}")
    out = list(keys)
    for i, k in enumerate(out):
        if not isinstance(k, Key):
            raise SteamError(f"{name}[{i}] = {k!r:.80} is not a variable key (make one with X(i) or L(j))")
    if distinct and len(set(out)) < len(out):  # found below only then
        i = next(i for i, k in enumerate(out) if k in out[:i])
        raise SteamError(f"{name} names {out[i]!r} twice ({name}[{out.index(out[i])}] and {name}[{i}])")
    return out


def check_new_values(new_values: object, held: Container[Key] = ()) -> None:
    """SteamError unless ``new_values`` is a mapping key → vector or None (what a solver's update accepts) giving no
    variable of ``held`` (those the solver has) a value: an update brings the first estimates of new variables."""
    if new_values is not None and not isinstance(new_values, Mapping):
        raise SteamError(f"new_values must be a mapping key -> vector (a dict or a Values) or None, got {new_values!r}")
    for k in new_values or ():
        if k in held:
            raise SteamError(f"variable {k!r} already has a value; an update cannot give it a new one")


def as_values(name: str, values: object) -> Values:
    """``values`` if it is a Values; a mapping key → vector copied into one (so its checks apply); an error
    otherwise."""
    if isinstance(values, Values):
        return values
    if isinstance(values, Mapping):
        return Values(values)
    raise SteamError(f"{name} must be a Values or a mapping key -> vector, got {name}={values!r:.80}")
