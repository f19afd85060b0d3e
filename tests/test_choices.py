"""The command line's choices (``steam_ref.choices``, read by the parser without NumPy) agree with the real tables.

Each choice the parser offers is checked against what owns it, read from the owner's own module: a prior it names
builds (``motion.MOTION_PRIORS``), a preset is one ``PaperSetup.named`` knows, a departure one ``departing``
applies, a method one the solvers run, a batch ordering one ``make_ordering`` knows, a consistency study one of
``paper.consistency.STUDIES``, a suite and a convention of the conformance kit the checker's; the defaults its help
quotes are the defaults the code uses. A name added to one side alone fails here.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from steam_ref import choices
from steam_ref.bayes_tree import ISAM2Params
from steam_ref.cli.commands import build_parser
from steam_ref.conformance import gate, kitio
from steam_ref.datasets import registry
from steam_ref.errors import SteamError
from steam_ref.linear.ordering import ORDERING_NAMES
from steam_ref.motion import MOTION_PRIORS, RESIDUALS, motion_prior
from steam_ref.motion.table import _MAKERS
from steam_ref.paper.consistency import STUDIES
from steam_ref.paper.presets import DEPARTURES, PAPER_AMALGAMATION_ZEROS, PRESETS, PaperSetup
from steam_ref.paper.solvers import METHODS, make_solver


def _option(command: str, dest: str, *sub: str):
    """The argparse action of ``steam-ref COMMAND [SUB...]``'s option ``dest``."""
    parser = build_parser()
    for name in (command, *sub):
        parser = next(a for a in parser._actions if a.choices and name in a.choices).choices[name]
    return next(a for a in parser._actions if a.dest == dest)


def test_the_priors_offered_are_the_priors_that_build():
    assert list(MOTION_PRIORS) == list(choices.MOTION_PRIOR_NAMES) == list(_MAKERS)  # no constructor unnamed
    for name, choice in MOTION_PRIORS.items():
        named = choices.MOTION_PRIOR_NAMES[name]
        assert (choice.options, choice.what, choice.dimensions) == (named.options, named.what, named.dimensions)
    for command in ("run", "fit-qc"):
        assert list(_option(command, "prior").choices) == list(MOTION_PRIORS), command
        assert list(_option(command, "se2_residual").choices) == list(RESIDUALS), command
    for name in _option("run", "prior").choices:  # each builds
        qc = np.eye(6 if choices.MOTION_PRIOR_NAMES[name].dimensions == 3 else 3)
        assert motion_prior(name, qc).state_dim > 0, name
    with pytest.raises(SteamError, match="unknown motion prior 'nope'"):
        motion_prior("nope", np.eye(3))


def test_the_presets_departures_methods_and_orderings_offered_are_the_codes():
    for command in ("run", "batch", "fit-qc"):
        assert list(_option(command, "preset").choices) == list(PRESETS), command
    for name in _option("run", "preset").choices:
        assert isinstance(PaperSetup.named(name), PaperSetup)
    with pytest.raises(SteamError, match="unknown preset"):
        PaperSetup.named("nope")
    assert list(_option("run", "departure").choices) == list(DEPARTURES)
    for name in DEPARTURES:  # each changes the fields it names, to the values it names
        changed = PaperSetup.named("plaza").departing(name)
        for field, value in DEPARTURES[name].items():
            assert getattr(changed, field) == value, (name, field)
    assert list(_option("run", "method").choices) == list(METHODS)
    for method in METHODS:
        assert make_solver(method) is not None, method
    with pytest.raises(SteamError):
        make_solver("nope")
    orderings = list(_option("batch", "ordering").choices)
    assert orderings == list(choices.BATCH_ORDERINGS) and set(orderings) <= set(ORDERING_NAMES)


def test_the_studies_suites_and_conventions_offered_are_the_codes():
    assert list(_option("consistency", "prior").choices) == list(STUDIES) == list(choices.CONSISTENCY_STUDIES)
    assert list(_option("consistency", "se2_residual").choices) == list(RESIDUALS)
    assert list(_option("conformance", "only", "check").choices) == list(kitio.SUITES)
    assert list(_option("conformance", "suite", "check").choices) == list(kitio.SUITES)
    assert list(_option("conformance", "conventions", "check").choices) == list(gate.CONVENTION_NAMES)


def test_the_defaults_the_help_quotes_are_the_codes():
    isam2 = ISAM2Params()
    assert f"GTSAM's is {isam2.relinearize_threshold})" in _option("run", "relinearize_threshold").help
    assert f"GTSAM's is {isam2.relinearize_skip})" in _option("run", "relinearize_skip").help
    assert (
        f"the preset's, {PaperSetup.named('plaza').singer_time_constant})"
        in _option("run", "singer_time_constant").help
    )
    zeros = PaperSetup.named("plaza").isam2.amalgamation_zeros
    assert zeros == PAPER_AMALGAMATION_ZEROS and f"the preset's, {zeros};" in _option("run", "amalgamation_zeros").help
    takers = [name for name, choice in MOTION_PRIORS.items() if "singer_time_constant" in choice.options]
    assert f"(--prior {' or '.join(takers)} only)" in _option("run", "singer_time_constant").help


def test_the_data_sets_offered_are_the_registrys():
    listed = _option("run", "dataset").help.split(", or a PATH")[0]
    shown = [name.removesuffix(" (generated)") for name in listed.split(", ")]
    assert shown == registry.loadable()
    generated = [n for n in registry.loadable() if not registry.DATASETS[n].files]
    assert generated and all(f"{n} (generated)" in _option("batch", "dataset").help for n in generated)


def test_the_text_rule_for_numbers_has_one_home():
    from steam_ref import arguments

    assert (arguments.DECIMAL, arguments.DIGITS, arguments.parse_decimal) == (
        choices.DECIMAL,
        choices.DIGITS,
        choices.parse_decimal,
    )
    assert choices.parse_decimal("1_0") is None and choices.parse_decimal("-1e-3") == -1e-3


def test_a_lazy_package_offers_every_name_it_lists():
    """datasets/ and linear/ load their names on first use (PEP 562): each table agrees with ``__all__`` and every
    name resolves to its module's own object."""
    import importlib

    for package in ("steam_ref.datasets", "steam_ref.linear"):
        module = importlib.import_module(package)
        assert sorted(module._HOMES) == sorted(module.__all__), package
        for name, home in module._HOMES.items():
            assert getattr(module, name) is getattr(importlib.import_module(f"{package}.{home}"), name), name
        with pytest.raises(AttributeError):
            module.no_such_name  # noqa: B018


def test_a_prior_record_is_frozen():
    with pytest.raises(dataclasses.FrozenInstanceError):
        choices.MOTION_PRIOR_NAMES["wnoa"].what = "x"  # type: ignore[misc]


@pytest.mark.parametrize("ordering", ["natural", "AMD", None])
def test_a_periodic_batch_solver_orders_by_xl_or_amd_only_and_is_named_by_it(ordering):
    """PB is the XL ordering and PBVR AMD (choices.BATCH_ORDERINGS). Any other ordering was taken and the solver
    named 'pbvr' in its figures, whatever it ordered by; now it is refused, naming it."""
    from steam_ref.paper.solvers import PeriodicBatchSolver

    assert [PeriodicBatchSolver(o).name for o in ("xl", "amd")] == ["pb", "pbvr"]
    assert [make_solver(m).name for m in ("pb", "pbvr")] == ["pb", "pbvr"]
    assert [make_solver(m).ordering for m in ("pb", "pbvr")] == ["xl", "amd"]
    with pytest.raises(SteamError, match=f"got ordering={ordering!r}"):
        PeriodicBatchSolver(ordering)
