"""Sphinx configuration of the steam_ref site.

Build it from the repository root with ``python3 -m sphinx -W docs docs/_build/html`` (README). The build
needs nothing from the network: no intersphinx, MathJax served from a local copy, the theme's own
assets. The tutorials in ``tutorials/`` are the pages under ``tutorials/`` here (``docs/tutorials``
is a symbolic link to that folder, which Sphinx follows); they run at build time and their outputs
are cached in ``docs/_build/.jupyter_cache``, so a rebuild runs only the notebooks that changed.
The API reference and the command pages are written by ``_ext/pages.py`` from the docstrings, the
layer table of ``architecture.md``, and the command's own ``--help``.
"""

from __future__ import annotations

import importlib.metadata
import os
import sys
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(DOCS / "_ext"))

import pages  # noqa: E402  (the local extension, found through the path set just above)

# The paper's files: $STEAM_REF_DATA_DIR, else the folder beside the clone where the tests and CI
# keep them. The notebooks' kernels inherit this process's environment.
pages.default_data_dir(ROOT)
# Figures in the notebooks come from the kernel's inline backend; a backend chosen for the shell
# (CI exports MPLBACKEND=Agg) would make plt.show() draw nothing on the pages.
os.environ.pop("MPLBACKEND", None)

project = "steam_ref"
author = "the steam_ref developers"
copyright = "2026, the steam_ref developers"
try:
    release = importlib.metadata.version("steam_ref")
except importlib.metadata.PackageNotFoundError:  # a checkout on sys.path without an install
    release = "unknown"

extensions = [
    "myst_nb",
    "sphinx.ext.autodoc",
    "numpydoc",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "sphinx_copybutton",
    "pages",
]

# Pages: Markdown (MyST) and notebooks; nothing else under docs/ is a page.
exclude_patterns = ["_build", "_ext", "Thumbs.db", ".DS_Store", "**.ipynb_checkpoints"]
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3

# Notebooks: executed at build time, outputs cached by jupyter-cache (keyed on the code cells).
nb_execution_mode = "cache"
nb_execution_timeout = 900
nb_execution_raise_on_error = True
nb_execution_show_tb = True
nb_execution_excludepatterns = pages.notebooks_without_their_data(ROOT / "tutorials")
nb_merge_streams = True

# Docstrings are prose with Sphinx roles, with no numpydoc sections so far. numpydoc renders such prose
# as written (napoleon would read a property's "θ̄: what it is" as a type) and renders numpydoc
# sections where one is added. Class members are documented by autodoc's :members:, so numpydoc's
# own member tables are off.
autodoc_member_order = "bysource"
autodoc_typehints = "signature"
autodoc_preserve_defaults = True
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False

# Math from a local copy of MathJax 3 (SVG output: one file, no web fonts, every TeX package).
html_static_path = [str(pages.local_mathjax())]
mathjax_path = pages.MATHJAX_FILE
# Its context menu could switch on speech, which fetches data from a CDN: leave the menu out.
mathjax3_config = {"options": {"enableMenu": False}}

html_theme = "pydata_sphinx_theme"
html_title = f"steam_ref {release}"
html_last_updated_fmt = None
html_show_sourcelink = False
html_theme_options = {
    "navbar_align": "left",
    "show_toc_level": 2,
    "navigation_with_keys": False,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
html_context = {"default_mode": "light"}
