"""What a test needs beyond the core install, and the one rule for when it is missing: skip, or fail.

A new user's ``python -m pytest`` skips, with a one-line reason saying what to install or where to
put files, the tests whose reference data or optional package is absent. CI sets the variables
below to 1, and then the same absence is a failure, so nothing is skipped there:

    STEAM_REF_REQUIRE_DATA=1      the paper's files (see DATA_FILES) must be in $STEAM_REF_DATA_DIR
    STEAM_REF_REQUIRE_OPTIONAL=1  gtsam, nbformat and nbclient must import
    STEAM_REF_REQUIRE_CHOLMOD=1   scikit-sparse (CHOLMOD) must import
    STEAM_REF_REQUIRE_DOCS=1      the built site (docs/_build/html) and a headless Chromium must be there

``conftest.py`` points $STEAM_REF_DATA_DIR at ``<repository>/../shared/data`` when it is unset and
that folder exists (test code may know the repository's layout; library code may not).
"""

from __future__ import annotations

import importlib
import os
from pathlib import Path
from types import ModuleType

import pytest

DATA_DIR_ENV = "STEAM_REF_DATA_DIR"  # the library's own variable (steam_ref.datasets.DATA_DIR_ENV)
REQUIRE_ENV = {
    "data": "STEAM_REF_REQUIRE_DATA",
    "optional": "STEAM_REF_REQUIRE_OPTIONAL",
    "cholmod": "STEAM_REF_REQUIRE_CHOLMOD",
    "docs": "STEAM_REF_REQUIRE_DOCS",
}
# The paper's files, as the authors published them; all in one folder.
DATA_FILES = (
    "Syn_theta_Plaza.mat",
    "Plaza1_thrown_away_some_range.mat",
    "authors/Syn_full_data_run.mat",
    "authors/Plaza1_full_data_run.mat",
)
REPO_ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO_ROOT.parent / "shared" / "data"  # where CI keeps the files, beside the clone


def required(kind: str) -> bool:
    """True when the environment says ``kind`` ("data", "optional", "cholmod", "docs") must be present."""
    return os.environ.get(REQUIRE_ENV[kind]) == "1"


def skip_or_fail(reason: str, kind: str) -> None:
    """Skip with ``reason`` (one line); fail instead when ``kind`` is required.

    Usable in a test, a fixture, or at module level (then a failure is a collection error).
    """
    if required(kind):
        pytest.fail(f"{reason} [{REQUIRE_ENV[kind]}=1 makes this a failure]", pytrace=False)
    pytest.skip(reason, allow_module_level=True)


def optional_import(module: str, extra: str, kind: str = "optional") -> ModuleType:
    """``importlib.import_module(module)``, or skip/fail saying which extra installs it."""
    try:
        return importlib.import_module(module)
    except ImportError as err:
        skip_or_fail(f"{module} is not installed ({err}); pip install -e '.[{extra}]'", kind)
        raise  # not reached: skip_or_fail always raises


def data_dir_reason(folder: str | None, missing: list[str]) -> str:
    """One line: what is wrong, and where to put the files."""
    more = f" and {len(missing) - 1} more" if len(missing) > 1 else ""
    where = f"{folder} lacks {missing[0]}{more}" if folder else f"{DATA_DIR_ENV} is unset"
    return (
        f"reference data not found ({where}): run `steam-ref data fetch` (the tests then find the files in your "
        f"cache folder), or set {DATA_DIR_ENV} to a folder holding {DATA_FILES[0]}, {DATA_FILES[1]} and "
        "authors/*_full_data_run.mat (CI uses ../shared/data)"
    )


def reference_data_dir() -> Path:
    """The folder $STEAM_REF_DATA_DIR names, holding every file of DATA_FILES; else skip/fail."""
    folder = os.environ.get(DATA_DIR_ENV) or None
    missing = [f for f in DATA_FILES if folder is None or not (Path(folder) / f).is_file()]
    if missing:
        skip_or_fail(data_dir_reason(folder, missing), "data")
    return Path(folder).resolve()
