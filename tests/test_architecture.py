"""The package's shape, read from its source with ``ast`` (nothing is imported): every module in a
layer and no import of a higher layer (``LAYERS``, the table docs/architecture.md draws), no import
cycle between steam_ref modules, no function-local import of a steam_ref module outside an explicit
allow-list, no module over 400 lines outside an explicit allow-list, at most 14 modules at the top.
And, in a fresh interpreter, that ``import steam_ref`` loads neither matplotlib nor the paper layer.

Edges are module-level imports (``if TYPE_CHECKING:`` blocks excluded; class bodies and top-level
``if``/``try`` count, since they run on import). ``from . import x`` is an edge to module ``x``
when ``x`` is a module, else to the package; importing a package is an edge to its ``__init__``.
"""

from __future__ import annotations

import ast
import importlib
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "steam_ref"
MAX_LINES = 400

# The layers, lowest first: a module may import its own layer's modules and lower layers', never a higher
# one. A module's layer is that of the longest entry that is it or a package holding it. This table is
# the one statement of the rule; docs/architecture.md draws it.
LAYERS: dict[str, int] = {
    # the algorithm
    "steam_ref._package": 0,  # the installed version and the lazy-name rule every lazy package uses; stdlib only
    "steam_ref.errors": 0,
    "steam_ref.arguments": 0,
    "steam_ref.files": 0,  # a file written whole or not at all (temporary, then os.replace): imports only errors
    "steam_ref.choices": 0,  # the names a user picks from and the defaults help quotes; imports nothing: the CLI's parser reads it
    "steam_ref.plot": 1,  # a leaf: draws plain arrays, imports only errors, so any layer may draw
    "steam_ref.manifold": 1,  # how an estimate moves (x ⊕ δ, x ⊖ x0), a variable's kind: imports only errors
    "steam_ref.variables": 1,
    "steam_ref.lie": 1,  # the LieGroup protocol (group.py), SE(2), the state kind on any group, the local GP; imports gp, manifold (1)
    "steam_ref.dead_reckoning": 1,
    "steam_ref.robust": 1,
    "steam_ref.gp": 1,
    "steam_ref.factors": 2,
    "steam_ref.linear": 3,
    "steam_ref.motion": 3,  # the motion priors, one object each: imports factors (2), gp, lie, manifold (1)
    "steam_ref.graph": 4,
    "steam_ref.covariance": 4,
    "steam_ref.batch": 5,
    "steam_ref.bayes_tree": 5,
    "steam_ref.trajectory": 5,
    "steam_ref.finish": 6,  # an incremental solve to the batch optimum: the solver's public API and batch's check
    "steam_ref.datasets": 6,
    "steam_ref.evaluate": 6,  # APE/RPE, trajectory files, NEES: reads trajectory (5), never the paper layer
    # the paper's experiments, in the order data flows
    "steam_ref.paper.presets": 7,
    "steam_ref.paper.readings": 8,
    "steam_ref.paper.converge": 8,
    "steam_ref.paper.frontend": 9,
    "steam_ref.paper.problem": 10,
    "steam_ref.paper.rigid": 10,  # a 3-D run: timed readings to factors, batch / iSAM2 / fixed-lag, held-out scores
    "steam_ref.paper.online_solver": 10,  # what a stream asks of every solver, how a forgotten past is read
    "steam_ref.paper.solvers": 10,
    "steam_ref.paper.options": 10,
    "steam_ref.paper.results": 10,
    "steam_ref.paper.divergence": 10,
    "steam_ref.paper.online": 11,
    "steam_ref.paper.fidelity": 11,
    "steam_ref.paper.experiments": 12,
    "steam_ref.paper.sweep": 7,  # joblib / Dask runs of any picklable function; imports errors and linear.threads
    "steam_ref.paper.progress": 7,  # the progress display every long command uses; imports no steam_ref module
    "steam_ref.paper.consistency": 12,  # NEES over Monte Carlo runs of the solvers
    "steam_ref.paper": 12,  # its __init__ re-exports the layer's main names
    # tools
    "steam_ref.conformance": 13,
    "steam_ref.homework": 13,  # the tutorials as markable homework: handouts and the marking run; imports errors, files (0)
    "steam_ref.cli": 14,
    "steam_ref.__main__": 14,
    "steam_ref": 15,  # the facade: names load lazily from the layers; nothing imports it
}
MAX_TOP_LEVEL_MODULES = (
    14  # 12 until manifold.py, the seam every solver goes through; 13 until choices.py, the CLI's names
)
# Entries that place only themselves, never the modules inside them: the root (else every new module would be
# layer 15 and could import anything) and paper/ (each of its modules has its own layer).
EXACT_ONLY = {"steam_ref", "steam_ref.paper"}

# Modules allowed to import steam_ref modules inside functions, each with its reason.
LOCAL_IMPORTS_ALLOWED: dict[str, str] = {
    "steam_ref.cli": "the console script's entry point answers --version before the commands (and SciPy) load",
    "steam_ref.conformance.command": "the kit's builder (the solvers, the oracles) loads only for selftest and build",
    "steam_ref.cli.commands": "the BLAS limit loads with the command's module, once its arguments are parsed",
    "steam_ref.cli.parsers.run": "--amalgamation-zeros' check loads its home (with NumPy) only when the option is given",
    "steam_ref.datasets.registry": "each set's reader loads its loader when the set is read: the CLI's parser reads the "
    "registry without NumPy",
    "steam_ref.datasets.search": "the readers load when a file is read: the CLI's parser reads --data-dir's help here "
    "without NumPy",
    "steam_ref.cli.paths": "the trajectory writers load with the run: a command checks its outputs before its solvers load",
}
# Modules allowed over MAX_LINES, each with its reason (none today).
LONG_MODULES_ALLOWED: dict[str, str] = {}


@dataclass(frozen=True)
class ImportSite:
    module: str  # the importing module
    target: str  # the steam_ref module imported
    line: int
    local: bool  # inside a function


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def _targets(node: ast.Import | ast.ImportFrom, module: str, modules: dict[str, Path]) -> list[str]:
    """The steam_ref modules an import statement in ``module`` loads (``modules``: name -> file)."""
    if isinstance(node, ast.Import):
        names = [alias.name for alias in node.names]
    else:
        if node.level:
            package = module if modules[module].name == "__init__.py" else module.rpartition(".")[0]
            for _ in range(node.level - 1):
                package = package.rpartition(".")[0]
            base = f"{package}.{node.module}" if node.module else package
        else:
            base = node.module or ""
        names = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base for alias in node.names]
    found = []
    for name in names:
        while name and name not in modules:  # `import steam_ref.linear.system as s` etc.
            name = name.rpartition(".")[0]
        if name.startswith("steam_ref") and name not in found:
            found.append(name)
    return found


def import_sites(module: str, tree: ast.AST, modules: dict[str, Path] = MODULES) -> list[ImportSite]:
    sites: list[ImportSite] = []

    def visit(node: ast.AST, local: bool) -> None:
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            for child in node.orelse:
                visit(child, local)
            return
        if isinstance(node, (ast.Import, ast.ImportFrom)):
            sites.extend(ImportSite(module, t, node.lineno, local) for t in _targets(node, module, modules))
            return
        inner = local or isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda))
        for child in ast.iter_child_nodes(node):
            visit(child, inner)

    visit(tree, False)
    return sites


def all_sites() -> list[ImportSite]:
    return [s for m, p in MODULES.items() for s in import_sites(m, ast.parse(p.read_text(), str(p)))]


def find_cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """One cycle (a → ... → a) per strongly connected component that has one (Tarjan)."""
    index, low, stack, on_stack, sccs, counter = {}, {}, [], set(), [], [0]

    def strong(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                strong(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            scc = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                scc.append(w)
                if w == v:
                    break
            sccs.append(set(scc))

    for v in sorted(edges):
        if v not in index:
            strong(v)
    cycles = []
    for scc in sccs:
        start = min(scc)
        if len(scc) == 1 and start not in edges.get(start, ()):
            continue
        path, seen = [start], {start}  # walk inside the component back to start (breadth-first)
        parents, frontier = {start: None}, [start]
        while frontier and start not in [w for v in frontier for w in edges[v]]:
            nxt = []
            for v in frontier:
                for w in sorted(edges[v] & scc):
                    if w not in seen:
                        seen.add(w)
                        parents[w] = v
                        nxt.append(w)
            frontier = nxt
        last = next(v for v in frontier if start in edges[v])
        path = []
        while last is not None:
            path.append(last)
            last = parents[last]
        cycles.append(path[::-1] + [start])
    return cycles


def module_graph(sites: list[ImportSite]) -> dict[str, set[str]]:
    edges: dict[str, set[str]] = {m: set() for m in MODULES}
    for s in sites:
        if not s.local:
            edges[s.module].add(s.target)
    return edges


# --- the checker checks what it should ----------------------------------------------------------


def test_the_import_parser_resolves_relative_imports_and_skips_type_checking():
    files = {
        "steam_ref": "__init__.py",
        "steam_ref.a": "a.py",
        "steam_ref.pkg": "__init__.py",
        "steam_ref.pkg.b": "b.py",
        "steam_ref.pkg.c": "c.py",
    }
    modules = {name: Path(file) for name, file in files.items()}
    source = (
        "from typing import TYPE_CHECKING\nimport numpy\nfrom . import c\nfrom .. import a\nfrom ..a import f\n"
        "from .b import g\nimport steam_ref.pkg\nif TYPE_CHECKING:\n    from .c import T\n"
        "class K:\n    from . import b\ndef f():\n    from steam_ref import a\n"
    )
    sites = import_sites("steam_ref.pkg.b", ast.parse(source), modules)
    got = {(s.target, s.local) for s in sites}
    assert got == {
        ("steam_ref.pkg.c", False),
        ("steam_ref.a", False),
        ("steam_ref.pkg.b", False),
        ("steam_ref.pkg", False),
        ("steam_ref.a", True),
    }
    assert [s.line for s in sites if s.local] == [13]


def test_the_cycle_finder_names_a_cycle_and_ignores_a_diamond():
    assert find_cycles({"a": {"b", "c"}, "b": {"d"}, "c": {"d"}, "d": set()}) == []
    assert find_cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c", "a"]]
    assert find_cycles({"a": {"a"}}) == [["a", "a"]]


def layer(module: str) -> int:
    """The layer of a module: that of the longest entry of LAYERS that is it or holds it."""
    name = module
    while name not in LAYERS or (name != module and name in EXACT_ONLY):
        if "." not in name:
            raise KeyError(f"{module} is in no layer: add it to LAYERS (and to docs/architecture.md)")
        name = name.rpartition(".")[0]
    return LAYERS[name]


def upward_imports(sites: list[ImportSite]) -> list[str]:
    return [
        f"{MODULES[s.module].relative_to(PACKAGE.parent)}:{s.line} imports {s.target} "
        f"(layer {layer(s.target)} > {layer(s.module)})"
        for s in sites
        if layer(s.target) > layer(s.module)
    ]


def test_the_layer_check_catches_an_import_that_runs_back_up():
    up = ImportSite("steam_ref.linear.system", "steam_ref.paper.online", 7, False)
    down = ImportSite("steam_ref.paper.online", "steam_ref.linear.system", 7, False)
    with_root = ImportSite("steam_ref.cli.args", "steam_ref", 3, False)
    found = upward_imports([up, down, with_root])
    with pytest.raises(KeyError, match=r"steam_ref\.newmod is in no layer"):
        layer("steam_ref.newmod")
    with pytest.raises(KeyError, match=r"steam_ref\.paper\.newmod is in no layer"):
        layer("steam_ref.paper.newmod")
    assert len(found) == 2
    assert "imports steam_ref.paper.online (layer 11 > 3)" in found[0]
    assert "imports steam_ref (layer 15 > 14)" in found[1]


# --- the package ----------------------------------------------------------------------------------


def test_every_module_is_in_a_layer():
    unplaced = []
    for module in MODULES:
        try:
            layer(module)
        except KeyError:
            unplaced.append(module)
    assert not unplaced, f"modules in no layer of LAYERS: {unplaced}"


def test_no_import_of_a_higher_layer():
    up = upward_imports(all_sites())
    assert not up, "imports that run back up: " + "; ".join(up)


def test_the_layer_table_names_only_modules_that_exist():
    stale = [name for name in LAYERS if name not in MODULES]
    assert not stale, f"LAYERS names modules that do not exist: {stale}"


def test_the_top_of_the_package_holds_at_most_14_modules():
    top = sorted(p.name for p in PACKAGE.glob("*.py") if p.name != "__init__.py")
    assert len(top) <= MAX_TOP_LEVEL_MODULES, f"{len(top)} modules at the top: {top}"


def test_import_steam_ref_loads_neither_matplotlib_nor_the_paper_layer():
    code = (
        "import sys, steam_ref\n"
        "heavy = [m for m in sys.modules if m.split('.')[0] in ('matplotlib', 'tqdm') or m.startswith("
        "('steam_ref.paper', 'steam_ref.conformance', 'steam_ref.datasets', 'steam_ref.plot', 'steam_ref.cli'))]\n"
        "print(','.join(heavy))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "", f"import steam_ref loaded {out.stdout.strip()}"


def test_the_command_loads_pooch_and_tqdm_only_when_a_download_or_a_bar_needs_them():
    """pooch (with requests and ssl, ~4 MB) and tqdm were loaded by every run through the data module."""
    code = "import sys, steam_ref.cli.commands\nprint(','.join(m for m in ('pooch', 'requests', 'tqdm') if m in sys.modules))\n"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "", f"the command loaded {out.stdout.strip()}"


def test_the_lazy_names_of_the_package_are_its_public_names_and_resolve():
    import steam_ref

    assert set(steam_ref._HOMES) | {n for n in steam_ref.__all__ if n not in steam_ref._HOMES} == set(steam_ref.__all__)
    eager = set(steam_ref.__all__) - set(steam_ref._HOMES)
    assert all(hasattr(steam_ref.errors, n) for n in eager), eager
    for name, home in steam_ref._HOMES.items():
        module = importlib.import_module(f"steam_ref.{home}")
        assert getattr(steam_ref, name) is getattr(module, name), name
    with pytest.raises(AttributeError, match="no attribute 'nothing_here'"):
        _ = steam_ref.nothing_here


def test_no_import_cycle_between_steam_ref_modules():
    cycles = find_cycles(module_graph(all_sites()))
    assert not cycles, "import cycles: " + "; ".join(" -> ".join(c) for c in cycles)


def test_no_function_local_import_of_a_steam_ref_module_outside_the_allow_list():
    local = [s for s in all_sites() if s.local and s.module not in LOCAL_IMPORTS_ALLOWED]
    assert not local, "function-local imports: " + "; ".join(
        f"{MODULES[s.module].relative_to(PACKAGE.parent)}:{s.line} imports {s.target}" for s in local
    )


def test_the_local_import_allow_list_is_not_stale():
    users = {s.module for s in all_sites() if s.local}
    assert set(LOCAL_IMPORTS_ALLOWED) <= users, f"no longer needed: {sorted(set(LOCAL_IMPORTS_ALLOWED) - users)}"


@pytest.mark.parametrize("path", sorted(MODULES.values()), ids=lambda p: str(p.relative_to(PACKAGE.parent)))
def test_module_is_at_most_400_lines(path):
    name = str(path.relative_to(PACKAGE.parent))
    n = len(path.read_text().splitlines())
    if name in LONG_MODULES_ALLOWED:
        assert n > MAX_LINES, f"{name} has {n} lines: remove it from LONG_MODULES_ALLOWED"
    else:
        assert n <= MAX_LINES, f"{name} has {n} lines (> {MAX_LINES}): split it by job"


def test_the_bayes_tree_package_is_at_most_2000_lines():
    # The solver a student reads beside K12 and the paper: every behaviour in at most 2,000 lines, all files counted.
    n = sum(len(p.read_text().splitlines()) for p in (PACKAGE / "bayes_tree").glob("*.py"))
    assert n <= 2000, f"steam_ref/bayes_tree/ has {n} lines (> 2,000)"


ORACLE = (
    "steam_ref.conformance.oracle",
    "steam_ref.conformance.oracle_graph",
    "steam_ref.conformance.oracle_lag",
    "steam_ref.conformance.oracle_lie",
    "steam_ref.conformance.oracle_rigid",
    "steam_ref.conformance.expected",
    "steam_ref.conformance.kitio",  # the file format (a case's type), which the oracle's table reads: errors only
)


def test_the_conformance_oracle_imports_nothing_of_steam_ref_but_its_errors():
    """Every import form counts: relative (``from . import x``, ``from ..errors import E``), absolute
    (``import steam_ref.x``, ``from steam_ref.x import y``), in functions and class bodies too."""
    allowed = {"steam_ref.errors", *ORACLE}
    for module in ORACLE:
        path = MODULES[module]
        targets = {s.target for s in import_sites(module, ast.parse(path.read_text(), str(path)))}
        assert targets <= allowed, f"{module} imports {sorted(targets - allowed)}"


def test_the_oracle_check_sees_every_import_form():
    forms = [
        "from ..linear import system",
        "from .. import batch",
        "import steam_ref.graph",
        "from steam_ref.factors import Factor",
        "def f():\n    from ..covariance import tree_marginal_covariances",
        "class C:\n    import steam_ref.gp.prior as p",
    ]
    for source in forms:
        targets = {s.target for s in import_sites(ORACLE[0], ast.parse(source))}
        assert targets and not targets <= {"steam_ref.errors", *ORACLE}, source


def test_the_type_checking_imports_of_the_root_are_its_lazy_names():
    """``steam_ref/__init__.py`` states each public name's home twice: ``_HOMES`` (run time) and the
    ``if TYPE_CHECKING:`` imports (type checkers, IDEs). They must say the same thing."""
    import steam_ref

    tree = ast.parse(MODULES["steam_ref"].read_text())
    block = next(n for n in tree.body if isinstance(n, ast.If) and _is_type_checking(n.test))
    typed = {alias.name: node.module for node in block.body if isinstance(node, ast.ImportFrom) for alias in node.names}
    assert typed == steam_ref._HOMES


# Underscore names that are public API elsewhere (NamedTuple's), not another class's private members.
# argparse's subparsers type has no public name (annotations only).
FOREIGN_UNDERSCORE_API = {"_replace", "_asdict", "_fields", "_make", "_field_defaults", "_SubParsersAction"}


def _owned_private_names(tree: ast.Module) -> set[str]:
    """The private names a module defines: members its classes assign through self/cls or define in their body."""
    owned: set[str] = set()
    for cls in (n for n in ast.walk(tree) if isinstance(n, ast.ClassDef)):
        for node in ast.walk(cls):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node in cls.body:
                owned.add(node.name)
            elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store):
                if isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"):
                    owned.add(node.attr)
            elif isinstance(node, (ast.Assign, ast.AnnAssign)) and node in cls.body:
                targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                owned.update(t.id for t in targets if isinstance(t, ast.Name))
    return {name for name in owned if name.startswith("_")}


def private_access(path: Path, module: str) -> list[str]:
    """Each place ``module`` reads a private member of something it does not own: ``obj._x`` where no class of
    the module defines ``_x`` (``self``/``cls``/``super()`` excepted)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    owned = _owned_private_names(tree)
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute):
            name = node.attr
            if not name.startswith("_") or name.startswith("__") or name in owned or name in FOREIGN_UNDERSCORE_API:
                continue
            base = node.value
            if isinstance(base, ast.Name) and base.id in ("self", "cls"):
                continue
            if isinstance(base, ast.Call) and isinstance(base.func, ast.Name) and base.func.id == "super":
                continue
            out.append(f"{module}:{node.lineno} reads .{name}")
    return out


def test_the_private_access_check_catches_a_foreign_private_member(tmp_path):
    source = tmp_path / "m.py"
    source.write_text(
        "class A:\n    def __init__(self):\n        self._mine = 1\n    def f(self, other):\n"
        "        return self._mine + other._mine + other._theirs\n"
        "def g(solver):\n    return solver._dims\n"
    )
    found = private_access(source, "steam_ref.m")
    assert sorted(found) == ["steam_ref.m:5 reads ._theirs", "steam_ref.m:7 reads ._dims"]


def test_no_module_reads_another_class_private_members():
    found = [line for module, path in MODULES.items() for line in private_access(path, module)]
    assert not found, "private members read across classes or modules:\n" + "\n".join(found)
