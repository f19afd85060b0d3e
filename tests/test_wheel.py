"""The wheel: what `pip install steam_ref` or `pip install .` gives a user, where the rest of the suite
runs on the editable install.

The wheel is built from a copy of the files git tracks (offline: the installed setuptools, with
``--no-build-isolation --no-deps --no-index``). It must hold every file git tracks under steam_ref/,
every module and every package-data file (the conformance kits' JSON and .npz files, py.typed), and
nothing else of the repository but its metadata, which names the console script. Installed into a
folder of its own inside another project's git repository and run from there, the command answers,
the lazy names resolve from the installed copy, the shipped kit passes its selftest and exports, and
a kit built there does not claim that project's commit as steam_ref's.
"""

from __future__ import annotations

import configparser
import json
import os
import re
import shutil
import subprocess
import sys
import zipfile
from email.parser import Parser
from pathlib import Path

import pytest
import tomllib
from requirements import REPO_ROOT, optional_import, skip_or_fail

from steam_ref.conformance.build import _commit
from steam_ref.conformance.kitio import KITS, SHIPPED, kit_files, read_index
from steam_ref.errors import SteamError

PYPROJECT = tomllib.loads((REPO_ROOT / "pyproject.toml").read_text())
PROJECT = PYPROJECT["project"]
DIST_INFO = f"steam_ref-{PROJECT['version']}.dist-info/"
# Every public name resolved, then the file of every steam_ref module that loaded, one a line.
LOADED = """
import sys, steam_ref as sr
[getattr(sr, name) for name in sr.__all__]
print(*sorted({m.__file__ for m in list(sys.modules.values()) if m.__name__.split('.')[0] == 'steam_ref'}), sep='\\n')
"""


def _git(*args: str, cwd: Path) -> str:
    out = subprocess.run(["git", *args], cwd=cwd, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, f"git {' '.join(args)}: {out.stderr}"
    return out.stdout


def _tracked() -> list[str]:
    """The files git tracks in the repository (those present in the work tree), relative paths."""
    if not (REPO_ROOT / ".git").exists():
        pytest.skip("not a git checkout: which files the wheel must hold is what git tracks")
    names = _git("ls-files", "-z", cwd=REPO_ROOT).split("\0")
    return [n for n in names if n and (REPO_ROOT / n).is_file()]


def _setuptools_or_fail() -> None:
    """The build backend pyproject.toml names, at the version it asks for (else skip, or fail in CI)."""
    setuptools = optional_import("setuptools", "test")
    (requirement,) = [r for r in PYPROJECT["build-system"]["requires"] if r.startswith("setuptools")]
    minimum = int(re.fullmatch(r"setuptools>=(\d+)", requirement).group(1))
    if int(setuptools.__version__.split(".")[0]) < minimum:
        skip_or_fail(
            f"setuptools {setuptools.__version__} < {minimum} cannot build the wheel; pip install -e '.[test]'",
            "optional",
        )


@pytest.fixture(scope="module")
def tracked() -> list[str]:
    return _tracked()


@pytest.fixture(scope="module")
def wheel(tmp_path_factory, tracked) -> Path:
    """The wheel built from a copy of the tracked files (no build/ or egg-info of the work tree leaks in)."""
    _setuptools_or_fail()
    root = tmp_path_factory.mktemp("wheel")
    source = root / "source"
    for name in tracked:
        (source / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(REPO_ROOT / name, source / name)
    command = [sys.executable, "-m", "pip", "wheel", str(source), "--no-deps", "--no-build-isolation", "--no-index"]
    out = subprocess.run(
        [*command, "--no-cache-dir", "--disable-pip-version-check", "-q", "-w", str(root / "dist")],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert out.returncode == 0, out.stderr
    (built,) = (root / "dist").glob("*.whl")
    return built


def test_the_wheel_holds_every_tracked_file_of_the_package_and_nothing_else(wheel, tracked):
    names = zipfile.ZipFile(wheel).namelist()
    package = {n for n in names if n.startswith("steam_ref/")}
    expected = {n for n in tracked if n.startswith("steam_ref/")}
    assert not expected - package, f"tracked but not in the wheel: {sorted(expected - package)}"
    assert not package - expected, f"in the wheel but not tracked: {sorted(package - expected)}"
    others = [n for n in names if not n.startswith(("steam_ref/", DIST_INFO))]
    assert not others, f"outside the package in the wheel: {others}"
    # what the kit and the type checkers read, by each kit's own index, so that a failure names what a user misses
    for version, kit in KITS.items():
        suites = read_index(kit)["suites"]
        shipped = [f"v{version}/index.json"] + [
            f"v{version}/{s}/{f}" for s in suites for f in ("cases.json", "expected.npz")
        ]
        missing = [n for n in shipped if f"steam_ref/conformance/{n}" not in package]
        assert len(suites) >= 7 and not missing, f"kit v{version} lacks {missing} in the wheel"
    assert "steam_ref/py.typed" in package


def test_the_wheel_metadata_names_the_console_script_the_version_and_the_licence(wheel):
    archive = zipfile.ZipFile(wheel)
    entry_points = configparser.ConfigParser()
    entry_points.read_string(archive.read(DIST_INFO + "entry_points.txt").decode())
    assert dict(entry_points["console_scripts"]) == PROJECT["scripts"] == {"steam-ref": "steam_ref.cli:main"}
    metadata = Parser().parsestr(archive.read(DIST_INFO + "METADATA").decode())
    assert metadata["Name"] == "steam_ref" and metadata["Version"] == PROJECT["version"]
    assert metadata["Requires-Python"] == PROJECT["requires-python"]
    assert metadata["License-Expression"] == PROJECT["license"]
    assert DIST_INFO + "licenses/LICENSE" in archive.namelist()
    core = {re.match(r"[\w.-]+", r).group(0) for r in metadata.get_all("Requires-Dist") if "extra ==" not in r}
    assert core == {re.match(r"[\w.-]+", r).group(0) for r in PROJECT["dependencies"]}


def test_the_installed_wheel_works_away_from_the_repository(wheel, tmp_path):
    """Installed into another project's git repository (its .venv), run from that project's folder."""
    project = tmp_path / "project"
    project.mkdir()
    _git("init", "-q", cwd=project)
    _git("-c", "user.name=u", "-c", "user.email=u@example.org", "commit", "-q", "--allow-empty", "-m", "x", cwd=project)
    site = project / ".venv" / "site-packages"
    install = [sys.executable, "-m", "pip", "install", "--no-deps", "--no-index", "--no-cache-dir", "-q"]
    out = subprocess.run([*install, "--target", str(site), str(wheel)], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "STEAM_REF_DATA_DIR")}
    env["PYTHONPATH"] = str(site)  # ahead of the editable install, whose finder comes after the path

    def start(*command: str) -> subprocess.Popen:
        return subprocess.Popen(
            command, cwd=project, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )

    def finish(process: subprocess.Popen) -> str:
        try:
            out, err = process.communicate(timeout=300)
        except subprocess.TimeoutExpired:
            process.kill()
            process.communicate()
            raise
        assert process.returncode == 0, f"{process.args}: {err}"
        return out

    def run(*command: str) -> str:
        return finish(start(*command))

    script = str(site / "bin" / "steam-ref")  # the console script pip wrote
    assert run(script, "--version").strip() == f"steam-ref {PROJECT['version']}"
    files = run(sys.executable, "-c", LOADED).split()
    assert files and all(Path(f).is_relative_to(site) for f in files), files
    selftest = start(script, "conformance", "selftest")  # beside the export and the build (it writes nothing)
    try:
        run(script, "conformance", "export", "kit")
        assert sorted(kit_files(project / "kit")) == sorted([*kit_files(SHIPPED), "README.md"])
        run(script, "conformance", "build", "--out", "built")
        index = json.loads((project / "built" / "index.json").read_text())
        assert index["generated_by"]["commit"] == "unknown", "the project's commit is not steam_ref's"
        # the README's `steam-ref conformance build` copied into this install: refused, the installed kit untouched
        installed = site / "steam_ref" / "conformance" / f"v{max(KITS)}"
        before = {n: (installed / n).read_bytes() for n in kit_files(installed)}
        into_package = subprocess.run(
            [script, "conformance", "build"], cwd=project, env=env, capture_output=True, text=True, timeout=300
        )
        assert into_package.returncode == 2 and len(into_package.stderr.strip().splitlines()) == 1, into_package
        assert str(installed) in into_package.stderr and "--out DIR" in into_package.stderr, into_package.stderr
        assert {n: (installed / n).read_bytes() for n in kit_files(installed)} == before
        assert finish(selftest).splitlines()[-1].endswith(" passed, 0 failed")
    finally:
        if selftest.poll() is None:
            selftest.kill()
            selftest.communicate()


def test_the_kit_names_a_commit_only_from_the_top_of_a_git_work_tree(tmp_path):
    _git("init", "-q", cwd=tmp_path)
    _git(
        "-c", "user.name=u", "-c", "user.email=u@example.org", "commit", "-q", "--allow-empty", "-m", "x", cwd=tmp_path
    )
    head = _git("rev-parse", "HEAD", cwd=tmp_path).strip()
    (tmp_path / "lib" / "site-packages").mkdir(parents=True)
    assert _commit(tmp_path) == head
    assert _commit(tmp_path / "lib" / "site-packages") == "unknown"


def test_the_packages_own_kit_is_rebuilt_only_in_a_source_checkout(monkeypatch, tmp_path):
    """Where the package is not a checkout's (``_commit`` says 'unknown': an installed wheel), ``build_kit()`` into
    the package's folder is refused before a file is written, naming the folder and ``out``; ``out`` still works."""
    from steam_ref.conformance import build

    monkeypatch.setattr(build, "_commit", lambda root=build.SOURCE_ROOT: "unknown")
    before = {n: (SHIPPED / n).read_bytes() for n in kit_files(SHIPPED)}
    with pytest.raises(
        SteamError, match=r"is an installed copy, not a source checkout's.*--out DIR \(out= in Python\)"
    ):
        build.build_kit()
    assert {n: (SHIPPED / n).read_bytes() for n in kit_files(SHIPPED)} == before
    index = build.build_kit(tmp_path / "elsewhere")
    assert index["generated_by"]["commit"] == "unknown" and (tmp_path / "elsewhere" / "index.json").is_file()
