"""What the package says about itself: one version, read at run time; the licence shipped; the typing
marker installed; the command's ``--version``."""

from __future__ import annotations

import importlib.metadata
import re

import pytest
from cli_runs import run_module
from requirements import REPO_ROOT

import steam_ref

tomllib = pytest.importorskip("tomllib", reason="tomllib is in the standard library from Python 3.11")
PYPROJECT = tomllib.loads((REPO_ROOT / "pyproject.toml").read_text())
PROJECT = PYPROJECT["project"]


def test_the_version_is_written_once_and_read_from_the_metadata():
    assert steam_ref.__version__ == importlib.metadata.version("steam_ref") == PROJECT["version"]
    literal = re.compile(rf"""["']{re.escape(PROJECT["version"])}["']""")
    sources = (REPO_ROOT / "steam_ref").rglob("*.py")
    written = [str(p.relative_to(REPO_ROOT)) for p in sources if literal.search(p.read_text())]
    assert not written, f"the version is written again in {written}; read steam_ref.__version__"


def test_steam_ref_version_prints_the_version():
    out = run_module("--version", timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == f"steam-ref {steam_ref.__version__}"


def test_the_licence_is_declared_and_shipped():
    assert PROJECT["license"] == "BSD-3-Clause"
    assert PROJECT["license-files"] == ["LICENSE"]
    text = (REPO_ROOT / "LICENSE").read_text()
    assert text.startswith("BSD 3-Clause License") and "the steam_ref developers" in text
    licence_classifiers = [c for c in PROJECT["classifiers"] if c.startswith("License ::")]
    assert not licence_classifiers, "the SPDX `license` replaces License classifiers (PEP 639)"


def test_the_typing_marker_is_part_of_the_package():
    assert (REPO_ROOT / "steam_ref" / "py.typed").is_file()
    assert "py.typed" in PYPROJECT["tool"]["setuptools"]["package-data"]["steam_ref"]
    assert "Typing :: Typed" in PROJECT["classifiers"]
