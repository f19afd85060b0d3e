"""The conformance kit: golden inputs and expected outputs that other implementations check against.

The kit (``v4/``, shipped in the package beside the older ``v1/`` to ``v3/``, which stay checkable) has one
folder per suite (gp, factors, linear, batch, bayes_tree, incremental, fixed_lag, se2, paper), each a ``cases.json``
any language reads and an ``expected.npz``,
and an ``index.json`` with the conventions, provenance and sha256 sums. ``steam-ref conformance``
exports it, checks results laid out like it, and checks the installed code against it
(docs/conformance.md).

- :mod:`.kitio`: the file format; :mod:`.conventions`: the conventions, written once;
- :mod:`.cases`: the cases and their inputs; :mod:`.paper`: the paper suite (from the data files);
- :mod:`.oracle`, :mod:`.oracle_graph`, :mod:`.oracle_lag`, :mod:`.oracle_se2`, :mod:`.expected`: independent
  expected values;
- :mod:`.spec`, :mod:`.runner`, :mod:`.runner_se2`: steam_ref's own results for a case;
- :mod:`.checker`: comparison within tolerance; :mod:`.gate`: a results folder against a whole kit
  (nothing missing); :mod:`.validate`: the form of kit and results files; :mod:`.readme`, :mod:`.readme_se2`:
  the exported README; :mod:`.build`: building the kit and ``selftest``;
- :mod:`.command`: the ``steam-ref conformance`` subcommands.
"""

from .build import build_kit, selftest
from .checker import Report, check_cases
from .gate import check_directory
from .kitio import KIT_VERSION, KITS, SHIPPED, SUITES
from .runner import run_case

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
