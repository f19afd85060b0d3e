"""The site's generated pages and its build-time choices (a local Sphinx extension of docs/conf.py).

- ``modules/``: one page per layer of ``architecture.md``'s table, each module's docstrings by
  autodoc. A module of the package that the table does not place is a build warning (so, with
  ``-W``, an error): the table is the map a reader follows, and it stays complete.
- ``cli/``: one page per ``steam-ref`` command holding its ``--help``, from ``steam_ref.cli.commands``'s own
  parser.
- Pages listed in ``OPTIONAL_PAGES`` leave the landing page's table of contents while absent.
- Notebooks that read the paper's files are not executed when the files are missing (a note is
  logged), unless STEAM_REF_REQUIRE_DATA=1, when the build stops instead (CI).

Generated files are written only when their text changes, so Sphinx rebuilds only what changed;
``modules/`` and ``cli/`` are not tracked by git.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import io
import os
import re
from pathlib import Path

from sphinx.application import Sphinx
from sphinx.util import logging

from steam_ref.cli.commands import build_parser
from steam_ref.datasets import gtsam_data_dir

LOG = logging.getLogger(__name__)

DOCS = Path(__file__).resolve().parents[1]
PACKAGE = DOCS.parent / "steam_ref"
MATHJAX_FILE = "tex-svg-full.js"
# Pages that another line of work adds; listed in background.md, dropped from it while the file is absent.
OPTIONAL_PAGES = ("conformance",)
PAGES_LISTING_THEM = ("background",)
# Files a notebook needs when its code names them (the same rule as tests/test_notebooks.py).
READS_REFERENCE_DATA = re.compile(
    r"""load_dataset\(\s*["'](plaza|paper-synthetic)["']|Syn_theta_Plaza|Plaza1_thrown|load_authors_run"""
)
# ... and the sets that ship in the gtsam wheel's Data/ folder (tests/test_notebooks.py has the same rules).
READS_GTSAM_DATA = re.compile(r"""load_dataset\(\s*["'](victoria-park|plaza2)["']""")
DATA_FILES = (
    "Syn_theta_Plaza.mat",
    "Plaza1_thrown_away_some_range.mat",
    "authors/Syn_full_data_run.mat",
    "authors/Plaza1_full_data_run.mat",
)


# --- build-time choices (called from conf.py) -----------------------------------------------------


def default_data_dir(root: Path) -> None:
    """Point $STEAM_REF_DATA_DIR at ``<root>/../shared/data`` when it is unset and that folder exists."""
    shared = root.parent / "shared" / "data"
    if not os.environ.get("STEAM_REF_DATA_DIR") and shared.is_dir():
        os.environ["STEAM_REF_DATA_DIR"] = str(shared)


def notebooks_without_their_data(folder: Path) -> list[str]:
    """Patterns of the notebooks not to execute: those reading the paper's files while they are absent,
    and those reading a set from the gtsam wheel's ``Data/`` folder while gtsam is not installed."""
    return _paper_readers_without_files(folder) + _gtsam_readers_without_gtsam(folder)


def _gtsam_readers_without_gtsam(folder: Path) -> list[str]:
    if gtsam_data_dir() is not None:
        return []
    readers = sorted(p.name for p in folder.glob("*.ipynb") if READS_GTSAM_DATA.search(p.read_text()))
    if readers and os.environ.get("STEAM_REF_REQUIRE_OPTIONAL") == "1":
        raise RuntimeError(
            f"STEAM_REF_REQUIRE_OPTIONAL=1 but gtsam (its Data/ folder) is missing, which these tutorials read: "
            f"{', '.join(readers)}"
        )
    if readers:
        LOG.info(
            "steam_ref docs: %s not executed (pip install gtsam: its Data/ folder has the set)", ", ".join(readers)
        )
    return [f"*{name}" for name in readers]


def _paper_readers_without_files(folder: Path) -> list[str]:
    where = os.environ.get("STEAM_REF_DATA_DIR")
    missing = [f for f in DATA_FILES if not where or not (Path(where) / f).is_file()]
    if not missing:
        return []
    readers = sorted(p.name for p in folder.glob("*.ipynb") if READS_REFERENCE_DATA.search(p.read_text()))
    if readers and os.environ.get("STEAM_REF_REQUIRE_DATA") == "1":
        folder = where or "$STEAM_REF_DATA_DIR (unset)"
        raise RuntimeError(
            f"STEAM_REF_REQUIRE_DATA=1 but the paper's files are missing ({missing[0]} in {folder}), "
            f"which these tutorials read: {', '.join(readers)}"
        )
    if readers:
        LOG.info(
            "steam_ref docs: %s not executed (the paper's files are missing: set STEAM_REF_DATA_DIR, "
            "see data/README.md)",
            ", ".join(readers),
        )
    return [f"*{name}" for name in readers]


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
            for module in (m for e in entries for m in modules_of(e)):
                placed.append(module)
                package = (PACKAGE / module.removeprefix("steam_ref.").replace(".", "/") / "__init__.py").is_file()
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


# --- Sphinx hooks ----------------------------------------------------------------------------------


def _generate(_app: Sphinx) -> None:
    unplaced = write_reference(DOCS / "modules")
    for module in unplaced:
        LOG.warning("%s is in no layer of docs/architecture.md's table: add it there", module)
    write_cli(DOCS / "cli")


def _drop_absent_optional_pages(_app: Sphinx, docname: str, source: list[str]) -> None:
    if docname in PAGES_LISTING_THEM:
        for page in OPTIONAL_PAGES:
            if not (DOCS / f"{page}.md").is_file():
                source[0] = re.sub(rf"^{page}\n", "", source[0], flags=re.M)


def setup(app: Sphinx) -> dict[str, object]:
    app.connect("builder-inited", _generate)
    app.connect("source-read", _drop_absent_optional_pages)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
