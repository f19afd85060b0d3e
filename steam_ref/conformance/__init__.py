"""The conformance kit: golden inputs and expected outputs that other implementations check against.

The kit (``v4/``, shipped in the package beside the older ``v1/`` to ``v3/``, data that stay checkable) has one
folder per suite (gp, factors, linear, batch, bayes_tree, incremental, fixed_lag, se2, paper), each a ``cases.json``
any language reads and an ``expected.npz``,
and an ``index.json`` with the conventions, provenance and sha256 sums. ``steam-ref conformance``
exports it, checks results laid out like it, and checks the installed code against it
(docs/conformance.md).

- :mod:`.kitio`: the file format (and a case's type); :mod:`.conventions`: the conventions, written once;
- :mod:`.cases`: the cases and their inputs; :mod:`.paper`: the paper suite (from the data files);
- :mod:`.oracle` (the GP prior, the factors), :mod:`.oracle_graph` (problems, in a space: Gauss-Newton and iSAM2
  replayed with a retraction), :mod:`.oracle_lag` (fixed lag), :mod:`.oracle_lie` (a Lie group) and
  :mod:`.expected` (the table of case type → oracle): independent expected values;
- :mod:`.differences`: the 8th-order central-difference stencil the tests and benchmarks check Jacobians with;
- :mod:`.spec` (every suite's specs), :mod:`.runner` (the table of case type → steam_ref's answer),
  :mod:`.solvers` (steam_ref's solvers on a case's problem): steam_ref's own results for a case;
- :mod:`.checker`: comparison within tolerance (:mod:`.hints`: the pattern a failing quantity is named by);
  :mod:`.gate`: a results folder against a whole kit (nothing missing); :mod:`.validate`: the form of kit and
  results files; :mod:`.readme`: the exported README;
  :mod:`.build`: building the kit and ``selftest``;
- :mod:`.command`: the ``steam-ref conformance`` subcommands.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._package import lazy_names

# Each public name's module, loaded when the name is first used: the kit's machinery (the solvers, the oracles)
# loads only for a command or a test that needs it, not for every ``steam-ref`` run.
_HOMES = {
    "KIT_VERSION": "kitio",
    "KITS": "kitio",
    "SHIPPED": "kitio",
    "SUITES": "kitio",
    "build_kit": "build",
    "selftest": "build",
    "check_directory": "gate",
    "check_cases": "checker",
    "Report": "checker",
    "run_case": "runner",
}
__all__ = [
    "KIT_VERSION",
    "KITS",
    "SHIPPED",
    "SUITES",
    "build_kit",
    "selftest",
    "check_directory",
    "check_cases",
    "Report",
    "run_case",
]


__getattr__, __dir__ = lazy_names(globals(), _HOMES)


if TYPE_CHECKING:  # what a type checker sees: the same names, imported eagerly
    from .build import build_kit, selftest
    from .checker import Report, check_cases
    from .gate import check_directory
    from .kitio import KIT_VERSION, KITS, SHIPPED, SUITES
    from .runner import run_case
