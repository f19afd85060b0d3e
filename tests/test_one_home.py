"""One home for each idea: the data sets, what an integer is, a settings class's ``replace``, and no tracker numbers.

- **The registry is the one list of data sets** (``datasets/registry.py``): a record added there, and only
  there, is found by the search path, offered by the command's ``--dataset`` help, listed by ``data list``,
  run with its preset, and refused by ``data fetch`` with the reason; the fetcher's names, fidelity's
  authors' runs and the conformance kit's as-published copy of the file names agree with it.
- **What an integer is** is stated once, ``arguments.is_integer``; no module of the package spells the
  check again (the conformance kit's oracle and its file format keep their own code, by design).
- **A settings class's replace with an unknown-field check** is ``arguments.replace_fields``.
- **What a symmetric covariance is** (to 1e-10 of its largest entry) is ``arguments.asymmetric``.
- **A package's lazy names** (PEP 562: a name loaded from its module on first use) are ``_package.lazy_names``'; no
  package writes its own ``__getattr__`` or ``__dir__`` (tests/test_lazy_names.py checks the rule itself).
- **A file written whole or not at all** (a temporary beside it, then ``os.replace``) is ``files.replace_file``:
  the command's outputs and the homework's handouts both write through it.
- **A stream's fixed-lag rule** (what is stamped when, a forgotten landmark's re-entry) is ``paper.solvers``'.
- **No tracker numbers** in code, tests, docs, benchmarks or tutorials: a clone cannot open them.
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
import re
from pathlib import Path

import numpy as np
import pytest

from steam_ref import arguments
from steam_ref.datasets import generate_synthetic, load_dataset, registry
from steam_ref.errors import DataError, SteamError

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "steam_ref"


def _toy_loader(path, name, seed):
    """A data set read from a CMU .mat file the test writes (any loader of the registry's signature)."""
    from steam_ref.datasets import load_cmu_mat

    return load_cmu_mat(path, name=name)


@pytest.fixture
def toy(tmp_path, monkeypatch):
    """A data set 'toy' added to the registry alone, its one file in a folder given as $STEAM_REF_DATA_DIR."""
    import scipy.io

    data = generate_synthetic(n_steps=6, n_landmarks=2, seed=1)
    scipy.io.savemat(tmp_path / "toy.mat", data.to_cmu_arrays())
    record = registry.DataSet(
        "toy",
        "a toy set for the test",
        (registry.DataFile("toy.mat", "toy.mat", "", 0),),
        "written by the test",
        "none",
        fetchable=False,
        loader=_toy_loader,
        preset="synthetic",
    )
    monkeypatch.setitem(registry.DATASETS, "toy", record)
    monkeypatch.setenv("STEAM_REF_DATA_DIR", str(tmp_path))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    return data


def test_a_data_set_added_to_the_registry_alone_is_found_listed_offered_and_run(toy, capsys):
    from steam_ref.cli import main
    from steam_ref.cli.commands import build_parser
    from steam_ref.datasets import fetch

    got = load_dataset("toy")  # the search path, by the record's loader
    assert got.name == "toy" and np.array_equal(got.ground_truth, toy.ground_truth)
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    for command in ("run", "batch"):
        option = next(a for a in sub.choices[command]._actions if a.dest == "dataset")
        assert "toy" in option.help, f"steam-ref {command} --dataset help omits a registered set"
    assert main(["data", "list"]) == 0
    assert re.search(r"^toy\s.*present", capsys.readouterr().out, flags=re.M)
    with pytest.raises(DataError, match="'toy' is not fetched: it ships in written by the test"):
        fetch.fetch(["toy"])
    assert main(["run", "--dataset", "toy", "--json", "--no-progress"]) == 0  # its preset, from the record
    assert '"preset": "synthetic"' in capsys.readouterr().out


def test_every_reader_of_the_data_sets_agrees_with_the_registry():
    from steam_ref.cli.commands import build_parser
    from steam_ref.conformance.paper import DATA_FILES
    from steam_ref.datasets import fetch
    from steam_ref.paper.fidelity import AUTHORS_RUNS
    from steam_ref.paper.presets import PRESETS

    names = registry.loadable()
    assert {"synthetic", "paper-synthetic", "plaza", "victoria-park", "plaza2"} <= set(names)  # and any set added
    with pytest.raises(DataError, match=re.escape(f"not one of {', '.join(names)}, nor a file")):
        load_dataset("no-such-set-here")
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    fidelity = next(a for a in sub.choices["fidelity"]._actions if a.dest == "dataset")
    assert list(fidelity.choices) == [*registry.with_authors_run(), "all"]
    assert {
        n: Path(registry.DATASETS[s.authors_run].files[0].local).name
        for n, s in registry.DATASETS.items()
        if s.authors_run
    } == AUTHORS_RUNS
    for name in names:
        assert registry.DATASETS[name].preset in PRESETS or registry.DATASETS[name].rigid, name  # 3-D: no preset
    for s in registry.DATASETS.values():
        if s.fetchable:
            assert s.files and all(re.fullmatch(r"[0-9a-f]{64}", f.sha256) and f.size > 0 for f in s.files), s.name
    with pytest.raises(DataError, match="the names are: paper-synthetic, plaza, authors-synthetic"):
        fetch.fetch(["nope"])
    # the kit keeps its own as-published copy of the file names: the two must agree
    for name, file in DATA_FILES.items():
        assert [f.local for f in registry.DATASETS[name].files] == [file], name


def _python_files() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def _spelled_outside_arguments(pattern: str) -> list[str]:
    """file:line of each line of the package outside arguments.py matching ``pattern`` (the conformance kit's oracle
    shares no code, by design)."""
    spelled = re.compile(pattern)
    return [
        f"{p.relative_to(ROOT)}:{n}"
        for p in _python_files()
        if p.name != "arguments.py" and "conformance" not in p.parts
        for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
        if spelled.search(line)
    ]


def test_what_an_integer_is_is_stated_once():
    """``isinstance(x, bool) or not isinstance(x, (int, np.integer))`` and its variants, outside arguments.py."""
    found = _spelled_outside_arguments(r"isinstance\([^()]*,\s*\(?\s*(?:int\s*,\s*np\.integer|np\.integer\s*,\s*int)\b")
    assert not found, f"what an integer is, written again (use arguments.is_integer): {found}"
    assert [arguments.is_integer(v) for v in (3, np.int64(3), True, np.bool_(True), 3.0, "3", None)] == [
        True,
        True,
        False,
        False,
        False,
        False,
        False,
    ]


def test_what_a_flag_is_is_stated_once():
    """``isinstance(x, (bool, np.bool_))``, outside arguments.py: an argument that must be True or False is checked
    by ``arguments.flag`` (a dataclass field stays a plain bool, for JSON: its own check)."""
    found = _spelled_outside_arguments(r"isinstance\([^()]*,\s*\(\s*bool\s*,\s*np\.bool_\s*\)\)")
    assert not found, f"what a flag is, written again (use arguments.flag): {found}"
    assert [arguments.flag("f", v) for v in (True, np.bool_(False))] == [True, False]
    for v in (1, "no", None, [], 0.0):
        with pytest.raises(SteamError, match=f"^f must be True or False, got f={re.escape(repr(v))}$"):
            arguments.flag("f", v)


def test_what_a_symmetric_covariance_is_is_stated_once():
    """``abs(P - P.T)`` (or with ``swapaxes`` / ``transpose``) and ``allclose(P, P.T)``, outside arguments.py: a matrix
    handed in as a covariance, a factor's noise, Qc or the authors' saved marginals is judged by
    ``arguments.asymmetric``, 1e-10 of its largest entry."""
    found = _spelled_outside_arguments(
        r"abs\(\s*(\w+)\s*-\s*(?:\1\.T\b|np\.swapaxes\(\s*\1\b|\1\.transpose\()|allclose\(\s*(\w+)\s*,\s*\2\.T\b"
    )
    assert not found, f"the symmetry rule of a covariance, written again (use arguments.asymmetric): {found}"
    P = np.array([[[2.0, 1.0], [1.0, 3.0]], [[2.0, 1.0], [1.0 + 5e-10, 3.0]], [[2.0, 1.0], [1.0 + 2e-10, 3.0]]])
    assert arguments.asymmetric(P).tolist() == [False, True, False]  # 5e-10 and 2e-10 against 1e-10 x 3


def test_replace_with_an_unknown_field_check_is_written_once():
    from steam_ref.bayes_tree import ISAM2Params
    from steam_ref.paper.options import StreamOptions
    from steam_ref.paper.presets import PaperSetup, Schedule

    found = [
        f"{p.relative_to(ROOT)}:{n}"
        for p in _python_files()
        if p.name != "arguments.py"
        for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
        if "has no field" in line
    ]
    assert not found, f"an unknown-field check written again (use arguments.replace_fields): {found}"
    for value in (StreamOptions(), PaperSetup.synthetic(), Schedule(), ISAM2Params()):
        name = type(value).__name__
        with pytest.raises(SteamError, match=rf"^{name} has no field 'nope'; the fields are \["):
            value.replace(nope=1)
        field = dataclasses.fields(value)[0].name
        copy = value.replace(**{field: getattr(value, field)})
        assert type(copy) is type(value) and getattr(copy, field) == getattr(value, field)


def _module_level(tree: ast.Module) -> list[ast.stmt]:
    """The statements a module runs on import: its body and what its top-level ``if``/``try`` blocks hold."""
    out, todo = [], list(tree.body)
    while todo:
        node = todo.pop(0)
        out.append(node)
        if isinstance(node, (ast.If, ast.Try)):
            todo += [*node.body, *node.orelse, *getattr(node, "finalbody", []), *getattr(node, "handlers", [])]
        elif isinstance(node, ast.ExceptHandler):
            todo += node.body
    return out


def _lazy_loaders_written_again(source: str) -> list[int]:
    """Lines of a module-level ``__getattr__`` or ``__dir__`` not bound from ``lazy_names``."""
    found = []
    for node in _module_level(ast.parse(source)):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.name in ("__getattr__", "__dir__"):
            found.append(node.lineno)
        elif isinstance(node, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names = {n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name)}
            call = node.value
            from_rule = isinstance(call, ast.Call) and isinstance(call.func, ast.Name) and call.func.id == "lazy_names"
            if names & {"__getattr__", "__dir__"} and not from_rule:
                found.append(node.lineno)
    return found


def test_the_lazy_name_check_catches_a_loader_written_again():
    own = "import importlib\ndef __getattr__(name):\n    return importlib.import_module('.x', __name__)\n"
    hidden = "try:\n    pass\nexcept ImportError:\n    def __dir__():\n        return []\n"
    bound = "__getattr__ = lambda name: None\n"
    method = "class P:\n    def __getattr__(self, name):\n        return 1\n"
    rule = "__getattr__, __dir__ = lazy_names(globals(), _HOMES)\n"
    assert [_lazy_loaders_written_again(s) for s in (own, hidden, bound, method, rule)] == [[2], [4], [1], [], []]


def test_a_packages_lazy_names_are_loaded_by_the_one_rule():
    """``__getattr__``/``__dir__`` at a module's top level are ``lazy_names``' alone: the root, datasets/, linear/
    and conformance/ each wrote the loader out, and lie/ a fourth variant (no ``__dir__``, nothing kept)."""
    found = [
        f"{p.relative_to(ROOT)}:{n}"
        for p in _python_files()
        for n in _lazy_loaders_written_again(p.read_text(encoding="utf-8"))
    ]
    assert not found, f"a lazy-name loader written again (use _package.lazy_names): {found}"
    lazy = [
        module_name
        for p in _python_files()
        if p.name == "__init__.py" and "lazy_names(" in p.read_text(encoding="utf-8")
        for module_name in [".".join(p.relative_to(ROOT).parent.parts)]
    ]
    assert {"steam_ref", "steam_ref.datasets", "steam_ref.linear", "steam_ref.lie", "steam_ref.conformance"} <= set(
        lazy
    )
    for name in lazy:
        package = importlib.import_module(name)
        assert package.__getattr__.__qualname__ == "lazy_names.<locals>.__getattr__", name
        assert package.__dir__.__qualname__ == "lazy_names.<locals>.__dir__", name


def test_a_file_written_whole_is_written_by_replace_file_alone():
    """``os.replace`` is called in ``files/replace.py`` and nowhere else but the conformance kit's export, which moves
    a whole staged folder (no file), so a writer that must not leave half a file reuses ``files.replace_file``."""
    found = [
        f"{p.relative_to(ROOT)}:{n}"
        for p in _python_files()
        if p.relative_to(PACKAGE).as_posix() not in ("files/replace.py", "conformance/command.py")
        for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
        if "os.replace(" in line
    ]
    assert not found, f"a temporary-and-replace write written again (use files.replace_file): {found}"


def test_a_streams_fixed_lag_rule_is_written_once_for_both_streams():
    """A stream's timestamps (a state's time, a landmark's last reading) and the re-entry of a forgotten landmark are
    ``paper.solvers``' alone (``FixedLagTreeSolver.update``, ``forget_landmarks``): the 3-D run had its own, which
    stamped states only, so its landmarks never left the window (tests/test_rigid_fixed_lag_landmarks.py)."""
    home = PACKAGE / "paper" / "solvers.py"
    rule = re.compile(r"timestamps\s*=|\.forgotten\(\)|FixedLagSmoother\(")
    found = [
        f"{p.relative_to(ROOT)}:{n}"
        for p in sorted((PACKAGE / "paper").rglob("*.py"))
        if p != home
        for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
        if rule.search(line)
    ]
    assert not found, f"a stream's fixed-lag rule written again (use paper.solvers): {found}"


def test_the_roles_of_a_factors_keys_are_checked_by_the_factor_base_alone():
    """A factor family declares ``n_states`` (and ``roles_of_states_only``); ``variables.check_roles`` is called in
    factors/base.py's ``Factor.__post_init__`` only, so no family checks its keys' roles its own way, or forgets to."""
    called = [
        f"{p.relative_to(ROOT)}:{n}"
        for p in _python_files()
        for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
        if re.search(r"\bcheck_roles\(", line) and not line.lstrip().startswith("def check_roles(")
    ]
    assert [f.partition(":")[0] for f in called] == ["steam_ref/factors/base.py"], called


# The word issue (or issues) and a number, in any brackets, or a hash and a number: a tracker's numbers, which a
# clone cannot open.
TRACKER = re.compile(r"\bissues? ?#?\d+|(?<![\w&/#])#\d+\b", re.IGNORECASE)
# Another project's tracker, cited as such, stays: evo's (evaluate/metrics.py), GTSAM's (docs/conformance.md).
EXTERNAL = re.compile(r"its issue[ ]746|gtsam #\d+(?:, #\d+)*")


def test_no_tracker_numbers_in_code_tests_docs_benchmarks_or_tutorials():
    files = [
        p
        for folder in ("steam_ref", "tests", "docs", "benchmarks", "tutorials", "examples")
        for pattern in ("*.py", "*.md", "*.ipynb")
        for p in (ROOT / folder).rglob(pattern)
        if "_build" not in p.parts and ".ipynb_checkpoints" not in p.parts
    ] + [ROOT / "README.md", ROOT / "CONTRIBUTING.md"]
    found = []
    for p in files:
        if p == Path(__file__).resolve():
            continue
        for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1):
            found += [f"{p.relative_to(ROOT)}:{n}: {m.group()}" for m in TRACKER.finditer(EXTERNAL.sub("", line))]
    assert not found, "tracker numbers (say what was meant):\n" + "\n".join(found)


def test_a_cmu_sets_range_sigma_is_every_ranges_own():
    """``Readings.range_sigma`` holds a sigma per range: a CMU file gives none, so each is the set-up's."""
    from steam_ref.paper.presets import PaperSetup
    from steam_ref.paper.readings import Readings

    setup = PaperSetup.synthetic().replace(range_sigma=0.25)
    r = Readings.from_dataset(generate_synthetic(n_steps=20, n_landmarks=4, seed=2), setup)
    assert r.range_sigma.shape == r.range_value.shape and np.all(r.range_sigma == 0.25)
    p = r.prefix(10)
    assert p.range_sigma.shape == p.range_value.shape and np.all(p.range_sigma == 0.25)


def test_every_data_dir_option_is_the_one_folder_type():
    """Every command's --data-dir is :func:`steam_ref.cli.args.add_data_dir`'s (an existing folder, args.folder):
    the conformance subcommands had a copy of the rule of their own, with its own messages."""
    import argparse

    from steam_ref.cli.args import folder
    from steam_ref.cli.commands import build_parser

    found, todo = [], [build_parser()]
    while todo:
        parser = todo.pop()
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                todo += list(action.choices.values())
            elif "--data-dir" in action.option_strings:
                found.append((parser.prog, action.type))
    assert len(found) >= 7, found  # run, batch, fidelity, reproduce, fit-qc, conformance selftest and build
    assert [prog for prog, kind in found if kind is not folder] == []
