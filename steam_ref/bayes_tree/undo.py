"""One undo log for everything an incremental solver changes: an update, a marginalization, or both.

Each change is recorded *before* it is made, as (undo function, arguments) putting back what was there: a
key's old value, a list's old length, or a whole ordered store (copied once per transaction). Every entry
restores an absolute value, so :meth:`UndoLog.rollback` applies them newest first, dropping each, and can start
again after a second Ctrl-C (:func:`until_done`). Transactions nest; the outermost commits or rolls back.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, MutableMapping
from contextlib import contextmanager
from typing import Any

__all__ = ["UndoLog", "until_done"]

_ABSENT = object()  # a key the store did not have


def _put(store: Any, key: object, old: object) -> None:
    """Undo ``store[key] = new``: the old value back, or no key when it had none."""
    if old is _ABSENT:
        store.pop(key, None)
    else:
        store[key] = old


def _restore(store: MutableMapping, saved: dict) -> None:
    """Undo every change of an ordered store since it was copied: its content and order back."""
    store.clear()
    store.update(saved)


def _put_all(store: dict, olds: list[tuple]) -> None:
    """Undo a run of ``store[key] = new`` of keys it held: each old value back, newest first."""
    for key, old in reversed(olds):
        store[key] = old


def _truncate(seq: list, n: int) -> None:
    """Undo appends to a list of length ``n``."""
    del seq[n:]


def until_done(undo: Callable[[], None]) -> None:
    """Run ``undo`` (idempotent) to its end: a second Ctrl-C during it starts it again, rather than
    leaving it half done; an error in it (a bug) propagates."""
    while True:
        try:
            undo()
            return
        except Exception:
            raise
        except BaseException:
            continue


class UndoLog:
    """The changes of the running transaction, newest last; outside one, writes are simply made."""

    def __init__(self) -> None:
        self.entries: list[tuple] = []  # (undo function, *arguments), oldest first
        self.depth = 0  # transactions open (nested); 0: none
        self.kept: set[int] = set()  # ids of the stores copied whole in this transaction

    def set(self, store: Any, key: object, value: object) -> None:
        """``store[key] = value`` (a dict, or a list and an index), recorded."""
        if self.depth:
            self.entries.append((_put, store, key, store.get(key, _ABSENT) if isinstance(store, dict) else store[key]))
        store[key] = value

    def delete(self, store: dict, key: object) -> None:
        """``del store[key]``, recorded (put back at the end of the store: :meth:`keep` an ordered one first)."""
        if self.depth:
            self.entries.append((_put, store, key, store[key]))
        del store[key]

    def old_values(self, store: dict) -> list[tuple]:
        """A list to append ``(key, old value)`` to before each ``store[key] = new`` of a held key: one entry for a
        hot loop (back-substitution), a list append a write."""
        olds: list[tuple] = []
        if self.depth:
            self.entries.append((_put_all, store, olds))
        return olds

    def extend(self, seq: list, items: list) -> None:
        """``seq.extend(items)``, recorded."""
        if self.depth:
            self.entries.append((_truncate, seq, len(seq)))
        seq.extend(items)

    def keep(self, store: dict) -> None:
        """Copy ``store`` whole, once per transaction, before a change whose undo must restore its order too."""
        if self.depth and id(store) not in self.kept:
            self.kept.add(id(store))
            self.entries.append((_restore, store, dict(store)))

    def record(self, undo: Callable[..., None], *args: object) -> None:
        """Record any other undo: ``undo(*args)`` must put back an absolute state (idempotent)."""
        if self.depth:
            self.entries.append((undo, *args))

    @contextmanager
    def transaction(self) -> Iterator[None]:
        """Everything recorded inside is undone if it raises (any BaseException, Ctrl-C too); nested
        transactions belong to the outermost one. The entries of a committed transaction are dropped when the
        next one begins, so that committing is one step: an interruption before it undoes, after it keeps."""
        if not (depth := self.depth):
            self.entries.clear()
            self.kept.clear()
        try:  # the depth raised inside: an interruption before the try is entered would leave it raised for good
            self.depth = depth + 1
            yield
            self.depth = depth  # committed (the outermost) or handed to the outer transaction
        except BaseException:
            self.depth = depth
            if not depth:
                until_done(self.rollback)
            raise

    def rollback(self) -> None:
        """Apply the entries newest first, dropping each once applied (idempotent: see :func:`until_done`)."""
        entries = self.entries
        while entries:
            undo, *args = entries[-1]
            undo(*args)
            entries.pop()
        self.kept.clear()
