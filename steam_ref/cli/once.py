"""An option given twice with two values: refused, not the last one kept.

argparse's ``store`` keeps the last value of an option given twice, dropping the first in silence (``--lag 1
--lag 2`` ran with a lag of 2 s). :class:`StoreOnce`, which :class:`~steam_ref.cli.args.Parser` registers as its
``store``, refuses the second value when it differs from the first, naming the option and both values; the same
value twice changes nothing and is taken. An option whose values add up says so itself (``--departure``:
``append``; ``conformance check --only``: ``extend``).
"""

from __future__ import annotations

import argparse
from typing import Any

__all__ = ["StoreOnce"]


class StoreOnce(argparse.Action):
    """argparse's ``store`` (the value, as its type and choices made it), once per parse: a second, different value
    is an ArgumentError (the parser's one-line error, exit code 2)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._given: list[tuple[argparse.Namespace, Any]] = []  # each parse's namespace, by identity, and its value

    def __call__(  # argparse's Action signature: parser and option unread
        self,
        parser: argparse.ArgumentParser,  # noqa: ARG002
        namespace: argparse.Namespace,
        values: Any,
        option: Any = None,  # noqa: ARG002
    ) -> None:
        first = next((value for seen, value in self._given if seen is namespace), self)  # self: not given yet
        if first is not self and first != values:
            raise argparse.ArgumentError(self, f"given twice, {first!r} and {values!r}: give it once")
        self._given.append((namespace, values))
        setattr(namespace, self.dest, values)
