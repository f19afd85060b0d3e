"""The package's shape, read from its source with ``ast`` (nothing is imported): no import cycle
between steam_ref modules, no function-local import of a steam_ref module outside an explicit
allow-list, and no module over 400 lines outside an explicit allow-list.

Edges are module-level imports (``if TYPE_CHECKING:`` blocks excluded; class bodies and top-level
``if``/``try`` count, since they run on import). ``from . import x`` is an edge to module ``x``
when ``x`` is a module, else to the package; importing a package is an edge to its ``__init__``.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "steam_ref"
MAX_LINES = 400

# Modules allowed to import steam_ref modules inside functions, each with its reason (none today).
LOCAL_IMPORTS_ALLOWED: dict[str, str] = {}
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


# --- the package ----------------------------------------------------------------------------------


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
