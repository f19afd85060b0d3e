"""The site's generated pages and its build-time choices (a local Sphinx extension of docs/conf.py).

- ``modules/``: one page per layer of ``architecture.md``'s table, each module's docstrings by
  autodoc. A module of the package that the table does not place is a build warning (so, with
  ``-W``, an error): the table is the map a reader follows, and it stays complete.
- ``cli/``: one page per ``steam-ref`` command holding its ``--help``, from ``steam_ref.cli.commands``'s own
  parser.
- ``equations.md``: "Equations → code", each equation of the paper and step of its Algorithm 1 with what it
  is and every documented module, class and function citing it (``equation_index.py``, which reads the
  citations through ``citations.py``); a citation of an equation the paper lacks, an equation nothing cites,
  or a link the API pages cannot resolve is a build warning.
- ``kit/readme.md``: the README ``steam-ref conformance export`` writes beside the kit (every suite's inputs,
  factor specs and outputs, the definitions they compute from), from its one source,
  ``steam_ref.conformance.readme``; conformance.md points to it.
- Pages listed in ``OPTIONAL_PAGES`` leave the landing page's table of contents while absent.
- Each tutorial declares what it needs in its metadata (``"steam_ref": {"needs": ["data:plaza"]}``).
  One whose needs are missing is not executed: its page shows the code without outputs and a note
  naming what is missing and the one command that gets it; STEAM_REF_REQUIRE_DATA=1 (or
  STEAM_REF_REQUIRE_OPTIONAL=1, for gtsam) stops the build instead (CI).

Generated files are written only when their text changes, so Sphinx rebuilds only what changed;
``modules/``, ``cli/``, ``kit/`` and ``equations.md`` are not tracked by git.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import io
import json
import os
import re
from pathlib import Path
from typing import Any

import equation_index
from sphinx.addnodes import pending_xref
from sphinx.application import Sphinx
from sphinx.environment import BuildEnvironment
from sphinx.util import logging

from steam_ref.cli.commands import build_parser
from steam_ref.conformance.readme import export_readme
from steam_ref.datasets.fetch import DATASETS, missing_needs

LOG = logging.getLogger(__name__)

DOCS = Path(__file__).resolve().parents[1]
PACKAGE = DOCS.parent / "steam_ref"
MATHJAX_FILE = "tex-svg-full.js"
# Pages that another line of work adds; listed in background.md, dropped from it while the file is absent.
OPTIONAL_PAGES = ("conformance",)
PAGES_LISTING_THEM = ("background",)
# Where a notebook's page says what it needs and how to get it (tests/test_docs_site.py looks for the class).
NEEDS_NOTE_CLASS = "steam-ref-needs"
# Notebooks left unexecuted by this build, by name, with the needs that were missing (set by conf.py).
UNEXECUTED: dict[str, list[str]] = {}


def notebook_needs(path: Path) -> list[str] | None:
    """What a notebook declares it needs in its metadata (``"steam_ref": {"needs": [...]}``), or None
    when it declares nothing: ``"data:NAME"`` (a data set of ``steam-ref data list``) or a package."""
    declared = json.loads(path.read_text()).get("metadata", {}).get("steam_ref", {})
    needs = declared.get("needs") if isinstance(declared, dict) else None
    return [str(n) for n in needs] if isinstance(needs, list) else None


def how_to_get(need: str) -> str:
    """The one command that provides ``need``."""
    kind, _, name = need.partition(":")
    if kind == "data" and name in DATASETS and DATASETS[name].fetchable:
        return f"steam-ref data fetch {name}"
    return "pip install gtsam" if kind == "data" or need == "gtsam" else f"pip install {need}"


# --- build-time choices (called from conf.py) -----------------------------------------------------


def default_data_dir(root: Path) -> None:
    """Point $STEAM_REF_DATA_DIR at ``<root>/../shared/data`` when it is unset and that folder exists."""
    shared = root.parent / "shared" / "data"
    if not os.environ.get("STEAM_REF_DATA_DIR") and shared.is_dir():
        os.environ["STEAM_REF_DATA_DIR"] = str(shared)


def notebooks_without_their_data(folder: Path) -> list[str]:
    """Patterns of the notebooks not to execute: those whose declared needs (their metadata) are absent.
    Their pages show the code without outputs and a note naming what is missing and how to get it.

    STEAM_REF_REQUIRE_DATA=1 makes a missing data set of the authors' repository stop the build, and
    STEAM_REF_REQUIRE_OPTIONAL=1 a missing package or gtsam's data (CI)."""
    UNEXECUTED.clear()
    for path in sorted(folder.glob("*.ipynb")):
        needs = notebook_needs(path)
        if needs is None:
            LOG.warning('%s declares no needs: add "steam_ref": {"needs": [...]} to its metadata', path.name)
            continue
        missing = missing_needs(needs)
        for need in missing:
            kind = "data" if how_to_get(need).startswith("steam-ref data fetch") else "optional"
            variable = f"STEAM_REF_REQUIRE_{kind.upper()}"
            if os.environ.get(variable) == "1":
                raise RuntimeError(f"{variable}=1 but {path.name} needs {need}, which is missing ({how_to_get(need)})")
        if missing:
            UNEXECUTED[path.stem] = missing
            LOG.info("steam_ref docs: %s not executed (missing %s)", path.name, ", ".join(missing))
    return [f"*{name}.ipynb" for name in UNEXECUTED]


def needs_note(missing: list[str]) -> str:
    """The Markdown of the note put at the top of a notebook built without what it needs."""
    what = ", ".join(f"`{n}`" for n in missing)
    commands = list(dict.fromkeys(how_to_get(n) for n in missing))
    fetch = [c for c in commands if c.startswith("steam-ref data fetch ")]
    if len(fetch) > 1:
        joined = "steam-ref data fetch " + " ".join(c.removeprefix("steam-ref data fetch ") for c in fetch)
        commands = [joined] + [c for c in commands if c not in fetch]
    lines = "\n".join(f"    {c}" for c in commands)
    return (
        f":::{{admonition}} Not run here: this build lacked {what}\n:class: warning {NEEDS_NOTE_CLASS}\n"
        "This page shows the tutorial's code without its outputs: the site was built without what the "
        f"tutorial needs ({what}). Get it with\n\n{lines}\n\nthen rebuild the site, or run the notebook.\n:::\n"
    )


def _mark_unexecuted(_app: Sphinx, docname: str, source: list[str]) -> None:
    """A notebook left unexecuted: outputs dropped, and the note after its title cell."""
    stem = docname.rpartition("/")[2]
    if not docname.startswith("tutorials/") or stem not in UNEXECUTED:
        return
    nb = json.loads(source[0])
    for cell in nb["cells"]:
        if cell["cell_type"] == "code":
            cell["outputs"], cell["execution_count"] = [], None
    note = {"cell_type": "markdown", "id": "steam-ref-needs", "metadata": {}, "source": needs_note(UNEXECUTED[stem])}
    nb["cells"].insert(1, note)
    source[0] = json.dumps(nb)


def local_mathjax() -> Path:
    """The file of MathJax 3 (SVG output, all TeX packages) shipped by the sphinx-mathjax-offline wheel."""
    spec = importlib.util.find_spec("sphinx-mathjax-offline")
    if spec is None or not spec.submodule_search_locations:
        raise RuntimeError("a local MathJax is needed: pip install -e '.[docs]' (sphinx-mathjax-offline)")
    return Path(next(iter(spec.submodule_search_locations))) / "static" / "mathjax" / MATHJAX_FILE


# --- the layers of architecture.md ----------------------------------------------------------------


def layers(architecture: str) -> list[tuple[str, list[str], str]]:
    """(layer, module files or folders, what they own) for each row of the table of ``architecture``."""
    rows = []
    for line in architecture.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 3 and re.fullmatch(r"\d+|leaf", cells[0]):
            rows.append((cells[0], re.findall(r"`([\w/]+(?:\.py|/))`", cells[1]), cells[2]))
    return rows


def modules_of(entry: str) -> list[str]:
    """Dotted module names of ``errors.py`` or a folder ``gp/`` (its ``__init__`` first, and a sub-package's
    before its modules), in steam_ref."""
    path = PACKAGE / entry
    files = (
        [path / "__init__.py"] + sorted(p for p in path.rglob("*.py") if p != path / "__init__.py")
        if entry.endswith("/")
        else [path]
    )
    return [_dotted(f) for f in files if f.is_file()]


def _dotted(path: Path) -> str:
    return ".".join(("steam_ref", *path.relative_to(PACKAGE).with_suffix("").parts)).removesuffix(".__init__")


def _folder_of(module: str) -> Path:
    return PACKAGE.joinpath(*module.split(".")[1:])


def _with_package(modules: list[str], placed: list[str]) -> list[str]:
    """``modules``, each preceded by its package's ``__init__`` when the table lists the package's files
    one by one (``paper/presets.py``): the package's docstring is documented with its first module."""
    out: list[str] = []
    for module in modules:
        package = module.rpartition(".")[0]
        if package not in ("", "steam_ref") and package not in placed and package not in out and package not in modules:
            out.append(package)
        out.append(module)
    return out


def all_modules() -> list[str]:
    return [_dotted(f) for f in sorted(PACKAGE.rglob("*.py")) if f.name != "__main__.py"]


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.is_file() or path.read_text() != text:
        path.write_text(text)


def write_reference(out: Path) -> list[str]:
    """Write ``out/index.md`` and one page per layer; return the modules no layer holds."""
    by_layer: dict[str, list[tuple[list[str], str]]] = {}
    for layer, entries, owns in layers((DOCS / "architecture.md").read_text()):
        by_layer.setdefault(layer, []).append((entries, owns))
    placed: list[str] = []
    intro = (
        "Generated from the docstrings, one page per layer of [the architecture](../architecture.md): "
        "a module imports only from the layers above it in this list. `import steam_ref as sr` "
        "gives the names a user types ([Public API](../api.md))."
    )
    index = ["# API reference", "", intro, "", "```{toctree}", ":maxdepth: 2", ""]
    for layer, rows in by_layer.items():
        slug = f"layer-{layer}"
        index.append(slug)
        names = ", ".join(f"`{e}`" for entries, _ in rows for e in entries)
        page = [f"# Layer {layer}: {names}", ""]
        for entries, owns in rows:
            page += [f"{', '.join(f'`{e}`' for e in entries)}: {owns}", ""]
        for entries, _ in rows:
            for module in (m for e in entries for m in _with_package(modules_of(e), placed)):
                placed.append(module)
                package = module == "steam_ref" or (_folder_of(module) / "__init__.py").is_file()
                # A package's __init__ re-exports its modules' names (its __all__): document only what
                # it defines itself; each name is documented once, in the module that defines it.
                options = ["   :members:", "   :show-inheritance:"] + (["   :ignore-module-all:"] if package else [])
                page += [f"## `{module}`", "", "```{eval-rst}", f".. automodule:: {module}", *options, "```", ""]
        _write(out / f"{slug}.md", "\n".join(page))
    _write(out / "index.md", "\n".join([*index, "```", ""]))
    return [m for m in all_modules() if m not in placed and m != "steam_ref"]


# --- the command's pages ---------------------------------------------------------------------------


def _help(parser: argparse.ArgumentParser) -> str:
    """``parser``'s ``--help`` text, wrapped at 100 columns whatever the terminal."""
    columns = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "100"  # argparse wraps to the terminal's width
    try:
        with contextlib.redirect_stdout(io.StringIO()) as text:
            parser.print_help()
    finally:
        if columns is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = columns
    return text.getvalue()


def _sentence(text: str) -> str:
    return f"{text[:1].upper()}{text[1:]}." if text else ""


def write_cli(out: Path) -> None:
    parser = build_parser()
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    helps = {a.dest: a.help for a in sub._choices_actions}
    index = [
        "# The `steam-ref` command",
        "",
        "Each page is the command's own `--help`.",
        "",
        "```text",
        _help(parser).rstrip(),
        "```",
        "",
        "```{toctree}",
        ":maxdepth: 1",
        "",
    ]
    for name, command in sub.choices.items():
        index.append(name)
        _write(
            out / f"{name}.md",
            "\n".join(
                [
                    f"# `steam-ref {name}`",
                    "",
                    _sentence(helps.get(name) or ""),
                    "",
                    "```text",
                    _help(command).rstrip(),
                    "```",
                    "",
                ]
            ),
        )
    _write(out / "index.md", "\n".join([*index, "```", ""]))


def write_kit_readme(out: Path) -> None:
    """The exported kit's README as the page ``out/readme.md``, exactly as ``export`` writes it."""
    _write(out / "readme.md", export_readme())


# --- Sphinx hooks ----------------------------------------------------------------------------------


def _generate(_app: Sphinx) -> None:
    unplaced = write_reference(DOCS / "modules")
    for module in unplaced:
        LOG.warning("%s is in no layer of docs/architecture.md's table: add it there", module)
    documented = [m for m in all_modules() if m not in unplaced]
    for problem in equation_index.write(DOCS / "equations.md", PACKAGE, DOCS / "derivations.md", documented):
        LOG.warning("equations page: %s", problem)
    write_cli(DOCS / "cli")
    write_kit_readme(DOCS / "kit")


def _drop_absent_optional_pages(_app: Sphinx, docname: str, source: list[str]) -> None:
    if docname in PAGES_LISTING_THEM:
        for page in OPTIONAL_PAGES:
            if not (DOCS / f"{page}.md").is_file():
                source[0] = re.sub(rf"^{page}\n", "", source[0], flags=re.M)


def _reread_when_needs_changed(_app: Sphinx, env: Any, _added: set, _changed: set, _removed: set) -> list[str]:
    """Tutorials whose needs were met at the last build and not now, or the reverse: read them again (their
    source did not change, so Sphinx would keep the page as it was, note or outputs)."""
    now = {f"tutorials/{stem}": missing for stem, missing in UNEXECUTED.items()}
    before = getattr(env, "steam_ref_unexecuted", None)
    env.steam_ref_unexecuted = now
    if before is None:
        return []
    return sorted(d for d in set(before) | set(now) if before.get(d) != now.get(d))


def _unresolved_on_the_equations_page(_app: Sphinx, _env: BuildEnvironment, node: pending_xref, _contnode: Any) -> None:
    """Sphinx drops an unresolved Python reference silently: on the equations page, each must resolve."""
    if node.get("refdoc") == "equations" and node.get("refdomain") == "py":
        LOG.warning("equations page: %s is not documented in the API pages", node.get("reftarget"), location=node)


def setup(app: Sphinx) -> dict[str, object]:
    app.connect("builder-inited", _generate)
    app.connect("source-read", _drop_absent_optional_pages)
    app.connect("source-read", _mark_unexecuted)
    app.connect("env-get-outdated", _reread_when_needs_changed)
    app.connect("missing-reference", _unresolved_on_the_equations_page)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
