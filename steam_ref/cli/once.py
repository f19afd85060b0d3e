"""An option given twice with two values: refused, not the last one kept.

argparse's ``store`` keeps the last value of an option given twice, dropping the first in silence (``--lag 1
--lag 2`` ran with a lag of 2 s), and ``--progress --no-progress`` is the last of the two. :class:`StoreOnce`, which
:class:`~steam_ref.cli.args.Parser` registers as its ``store``, and :class:`SwitchOnce`, the ``--X`` / ``--no-X``
switches' action, refuse the second value when it differs from the first, naming the option and both values; the
same value twice changes nothing and is taken. An option whose values add up says so itself (``--departure``:
``append``; ``conformance check --only``: ``extend``).
"""

from __future__ import annotations

import argparse
from typing import Any

__all__ = ["StoreOnce", "SwitchOnce"]


def _once(action: argparse.Action, namespace: argparse.Namespace, value: Any, shown: str) -> None:
    """Set ``action``'s value in ``namespace``: an ArgumentError (the parser's one-line error, exit code 2) when this
    parse gave it another value before (each parse's namespace is told by identity)."""
    given: list[tuple[argparse.Namespace, Any, str]] = action.__dict__.setdefault("_given", [])
    first = next(((value_, shown_) for seen, value_, shown_ in given if seen is namespace), None)
    if first is not None and first[0] != value:
        raise argparse.ArgumentError(action, f"given twice, {first[1]} and {shown}: give it once")
    given.append((namespace, value, shown))
    setattr(namespace, action.dest, value)


class StoreOnce(argparse.Action):
    """argparse's ``store`` (the value, as its type and choices made it), once per parse."""

    def __call__(  # argparse's Action signature: parser and option unread
        self,
        parser: argparse.ArgumentParser,  # noqa: ARG002
        namespace: argparse.Namespace,
        values: Any,
        option: Any = None,  # noqa: ARG002
    ) -> None:
        _once(self, namespace, values, repr(values))


class SwitchOnce(argparse.BooleanOptionalAction):
    """argparse's ``--X`` / ``--no-X`` switch, once per parse: ``--X --no-X`` is refused."""

    def __call__(  # argparse's Action signature: parser unread
        self,
        parser: argparse.ArgumentParser,  # noqa: ARG002
        namespace: argparse.Namespace,
        values: Any,  # noqa: ARG002
        option: str | None = None,
    ) -> None:
        if option in self.option_strings:
            _once(self, namespace, not str(option).startswith("--no-"), str(option))
