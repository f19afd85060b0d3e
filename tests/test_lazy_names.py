"""The one rule by which a package loads its public names on first use (PEP 562): ``steam_ref._package.lazy_names``.

Each package that loads names lazily (the root, ``datasets/``, ``linear/``, ``lie/``, ``conformance/``) binds its
``__getattr__`` and ``__dir__`` from it (tests/test_one_home.py refuses a loader written again). Checked here, in fresh
interpreters where it matters: a name's module is not imported until the name is touched, and then the name is kept;
``dir`` lists every public name without loading one; an unknown name raises the AttributeError Python raises for a
plain module (the oracle: ``types.ModuleType``'s own).
"""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
import textwrap
import types

import pytest
from cli_runs import ROOT

# Each lazy package, one of its lazy names, and the module that name lives in (not loaded by the package itself).
LAZY = [
    ("steam_ref", "PaperSetup", "steam_ref.paper.presets"),
    ("steam_ref.datasets", "generate_synthetic", "steam_ref.datasets.synthetic"),
    ("steam_ref.linear", "SparseCholesky", "steam_ref.linear.cholesky"),
    ("steam_ref.lie", "SO3", "steam_ref.lie.so3"),
    ("steam_ref.conformance", "run_case", "steam_ref.conformance.runner"),
]
PACKAGES = [package for package, _, _ in LAZY]

_PROBE = """
import json, sys
package, name, home = sys.argv[1:]
module = __import__(package, fromlist=["_"])
seen = {"after_import": home in sys.modules}
listed = dir(module)
seen["after_dir"] = home in sys.modules
seen["listed"] = name in listed
value = getattr(module, name)
seen["after_use"] = home in sys.modules
seen["same"] = value is getattr(sys.modules[home], name)
seen["kept"] = vars(module).get(name) is value
print(json.dumps(seen))
"""


def _fresh(code: str, *argv: str, path: str = str(ROOT)) -> str:
    done = subprocess.run(
        [sys.executable, "-c", code, *argv],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": path},
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


@pytest.mark.parametrize(("package", "name", "home"), LAZY)
def test_a_lazy_name_loads_its_module_only_when_touched_and_is_kept(package, name, home):
    seen = json.loads(_fresh(_PROBE, package, name, home))
    assert seen == {
        "after_import": False,  # importing the package does not load the name's module
        "after_dir": False,  # nor does listing it
        "listed": True,
        "after_use": True,
        "same": True,  # the module's own object
        "kept": True,  # kept in the package: the next use is a plain lookup
    }


@pytest.mark.parametrize("package", PACKAGES)
def test_an_unknown_name_raises_pythons_own_attribute_error(package):
    module = importlib.import_module(package)
    with pytest.raises(AttributeError) as ours:
        module.no_such_name  # noqa: B018
    with pytest.raises(AttributeError) as python:
        types.ModuleType(package).no_such_name  # noqa: B018
    assert str(ours.value) == str(python.value) == f"module {package!r} has no attribute 'no_such_name'"
    assert (ours.value.name, ours.value.obj) == ("no_such_name", module)
    assert not hasattr(module, "no_such_name") and getattr(module, "no_such_name", 7) == 7


@pytest.mark.parametrize("package", PACKAGES)
def test_dir_lists_every_public_name_and_resolves_each(package):
    module = importlib.import_module(package)
    listed = dir(module)
    assert listed == sorted(listed)
    assert set(module.__all__) <= set(listed), sorted(set(module.__all__) - set(listed))
    assert set(module._HOMES) <= set(module.__all__), sorted(set(module._HOMES) - set(module.__all__))
    for name, home in module._HOMES.items():
        assert getattr(module, name) is getattr(importlib.import_module(f"{package}.{home}"), name), name


def test_the_rule_on_a_package_of_its_own(tmp_path):
    """The helper alone, on a package the test writes: its name's module loads at the first use only, once."""
    pkg = tmp_path / "toypkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text(
        "from steam_ref._package import lazy_names\n"
        "_HOMES = {'thing': 'sub', 'other': 'deep.mod'}\n"
        "__all__ = ['thing', 'other']\n"
        "__getattr__, __dir__ = lazy_names(globals(), _HOMES)\n"
    )
    (pkg / "sub.py").write_text(
        "import builtins\nbuiltins.LOADS = getattr(builtins, 'LOADS', 0) + 1\nthing = object()\n"
    )
    (pkg / "deep").mkdir()
    (pkg / "deep" / "__init__.py").write_text("")
    (pkg / "deep" / "mod.py").write_text("other = 'deep'\n")
    code = textwrap.dedent(
        """
        import builtins, json, sys
        import toypkg
        out = {"dir": dir(toypkg), "loaded": "toypkg.sub" in sys.modules or "toypkg.deep.mod" in sys.modules}
        first, second = toypkg.thing, toypkg.thing
        out["once"] = first is second and builtins.LOADS == 1
        out["other"] = toypkg.other
        try:
            toypkg.nope
        except AttributeError as e:
            out["error"] = [str(e), e.name, e.obj is toypkg]
        print(json.dumps(out))
        """
    )
    out = json.loads(_fresh(code, path=os.pathsep.join([str(tmp_path), str(ROOT)])))
    assert out["loaded"] is False
    assert {"thing", "other", "_HOMES", "__all__"} <= set(out["dir"]) and out["dir"] == sorted(out["dir"])
    assert out["once"] is True and out["other"] == "deep"
    assert out["error"] == ["module 'toypkg' has no attribute 'nope'", "nope", True]


def test_the_rules_home_loads_no_numpy():
    """Layer 0: the parser's light packages (datasets/, linear/) read it without NumPy."""
    code = "import sys, steam_ref._package, steam_ref.datasets, steam_ref.linear\nprint('numpy' in sys.modules)\n"
    assert _fresh(code).strip() == "False"
