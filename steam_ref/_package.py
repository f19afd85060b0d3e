"""The package as a package, apart from its maths: its installed version, and how its packages load their names.

- ``__version__``: the installed version, read from the package metadata (written once, in pyproject.toml).
- :func:`lazy_names`: the one rule by which the root and each package that loads its names on first use (PEP 562:
  ``steam_ref``, ``datasets/``, ``linear/``, ``lie/``, ``conformance/``) answer ``package.name`` and ``dir(package)``
  from its table of homes, name → module.

Why here: the rule is needed by packages of every layer, from ``lie/`` (1) to the root (15), and by the light ones
the command's parser reads without NumPy (``datasets/``, ``linear/``), so its home is a layer-0 module that imports
only the standard library; this one is loaded by ``import steam_ref`` already (the first thing Python does for any
``import steam_ref.x``), so no package pays for the rule with an import, and the top of the package holds no more
modules. Both halves are about the package itself, not what it computes.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Mapping, MutableMapping
from importlib import metadata as _metadata
from typing import Any

try:
    __version__ = _metadata.version("steam_ref")
except _metadata.PackageNotFoundError:  # the source folder on sys.path, never installed
    __version__ = "0+unknown"

__all__ = ["__version__", "lazy_names"]


def lazy_names(
    namespace: MutableMapping[str, Any], homes: Mapping[str, str]
) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """A package's ``__getattr__`` and ``__dir__`` (PEP 562), for ``__getattr__, __dir__ = lazy_names(globals(), _HOMES)``.

    ``namespace`` is the package's ``globals()``; ``homes`` maps each name loaded on first use to its module,
    relative to the package (``"ordering"``, ``"paper.presets"``). The first use of a name imports its module and
    keeps the name in the package, so the next is a plain lookup; a name not in ``homes`` raises the AttributeError
    Python raises for a module (its message, ``name`` and ``obj``). ``dir(package)`` lists the package's own names
    and every name of ``homes``, loaded or not, sorted.
    """
    package = namespace["__name__"]

    def __getattr__(name: str) -> Any:
        home = homes.get(name)
        if home is None:
            raise AttributeError(
                f"module {package!r} has no attribute {name!r}", name=name, obj=sys.modules.get(package)
            )
        value = getattr(importlib.import_module(f".{home}", package), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(homes))

    return __getattr__, __dir__
