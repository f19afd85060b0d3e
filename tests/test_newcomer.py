"""A newcomer's first hour, as files the repository ships: each check is a friction one met.

The README read on a package index (links absolute, under the project's Source URL), the install that
fails without SuiteSparse explained, the virtual environment ignored, the extras that the tutorials
need, and the command's help naming every data set it accepts.
"""

from __future__ import annotations

import re
import subprocess

import pytest
from requirements import REPO_ROOT

from steam_ref.cli.commands import build_parser
from steam_ref.datasets import fetch

README = (REPO_ROOT / "README.md").read_text()
PYPROJECT = (REPO_ROOT / "pyproject.toml").read_text()  # read as text: tomllib needs Python 3.11


def _toml_list(key: str) -> str:
    """The text of the TOML list ``key = [...]`` of pyproject.toml."""
    (found,) = re.findall(rf"^{key} = \[(.*?)\]", PYPROJECT, flags=re.M | re.S)
    return found


def test_readme_links_work_on_a_package_index():
    """The long description is shown away from the repository: a relative link there leads nowhere."""
    links = re.findall(r"\]\(([^)]+)\)", README)
    assert links
    relative = [link for link in links if not re.match(r"https?://", link)]
    assert not relative, f"relative links in README.md: {relative}"
    (source,) = re.findall(r'^Source = "([^"]+)"', PYPROJECT, flags=re.M)
    for link in links:
        if "steam_ref" in link:
            assert link.startswith(source), link


def test_the_cholmod_build_failure_is_explained():
    for page in (README, (REPO_ROOT / "CONTRIBUTING.md").read_text()):
        assert "cholmod.h: No such file or directory" in " ".join(page.split())


def test_a_virtual_environment_is_ignored(tmp_path):
    if not (REPO_ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    out = subprocess.run(["git", "check-ignore", "-q", ".venv/bin/python"], cwd=REPO_ROOT, check=False)
    assert out.returncode == 0, ".venv is not in .gitignore"


def test_the_notebooks_extra_installs_what_the_tutorials_need():
    assert '"gtsam' in _toml_list("notebooks")  # tutorial 07 reads gtsam's Data/
    core = _toml_list("dependencies")
    assert '"pooch' in core and '"platformdirs' in core  # steam-ref data fetch after `pip install .`


@pytest.mark.parametrize("command", ["run", "batch"])
def test_the_dataset_help_names_every_data_set(command):
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    option = next(a for a in sub.choices[command]._actions if a.dest == "dataset")
    names = [n for n in fetch.DATASETS if not n.startswith("authors-")]
    missing = [n for n in [*names, "synthetic"] if n not in option.help]
    assert not missing, f"steam-ref {command} --dataset help omits {missing}"


def test_every_option_of_run_has_help():
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    bare = [a.option_strings[0] for a in sub.choices["run"]._actions if a.option_strings and not a.help]
    assert not bare, f"options of steam-ref run without help: {bare}"


def test_a_skip_for_missing_data_points_at_data_fetch():
    from requirements import data_dir_reason

    for folder in (None, "/somewhere"):
        reason = data_dir_reason(folder, ["Syn_theta_Plaza.mat"])
        assert "`steam-ref data fetch`" in reason and "STEAM_REF_DATA_DIR" in reason, reason
        assert "\n" not in reason


def test_the_suite_and_the_docs_build_say_how_long_they_take():
    """Where a newcomer starts each one, the time it takes (as newcomers measured them on 2 cores)."""
    contributing = (REPO_ROOT / "CONTRIBUTING.md").read_text()
    index = (REPO_ROOT / "docs" / "index.md").read_text()
    after_pytest = README.split("python3 -m pytest -q\n", 1)[1][:300]
    assert "6-12 minutes" in after_pytest
    before_sphinx = README.split("python3 -m sphinx -W docs docs/_build/html", 1)[0][-600:]
    assert "about 6 minutes" in before_sphinx
    for text in (contributing, index):
        assert "6-12 minutes" in text and "about 6 minutes" in text


NUMBERS = [
    "one",
    "two",
    "three",
    "four",
    "five",
    "six",
    "seven",
    "eight",
    "nine",
    "ten",
    "eleven",
    "twelve",
    "thirteen",
    "fourteen",
    "fifteen",
]


def test_no_page_counts_the_tutorials_and_the_readme_names_each():
    """A count of notebooks goes stale with the next one; the README's list of them is checked instead."""
    tutorials = sorted(p.stem for p in (REPO_ROOT / "tutorials").glob("*.ipynb"))
    for page in ("docs/tutorials.md", "docs/index.md", "README.md"):
        text = (REPO_ROOT / page).read_text().lower()
        counted = re.findall(rf"\b({'|'.join(NUMBERS)}|\d+) (?:notebooks|tutorials|topics)\b", text)
        assert not counted, f"{page} counts the tutorials: {counted}"
    (row,) = [line for line in README.splitlines() if line.startswith("| `tutorials/` |")]
    for stem in tutorials:
        assert re.search(rf"\b{stem[:2]} ", row), f"README's tutorials row does not name {stem}"


def test_the_readme_says_which_commands_need_a_clone():
    """A user of the wheel (no checkout) copying ``python benchmarks/batch.py`` or ``steam-ref homework handout
    tutorials/`` met a missing file: each top folder the README's commands read outside the package is not shipped
    (pyproject's packages are ``steam_ref*`` alone) and is named where the README says what needs a clone."""
    (include,) = re.findall(r"^include = \[(.*?)\]", PYPROJECT, flags=re.M)
    assert include.strip() == '"steam_ref*"', include
    read = set(re.findall(r"`[^`]*?\b(benchmarks|examples|tutorials)/[^`]*`", README))
    assert read == {"benchmarks", "examples", "tutorials"}, read
    (said,) = re.findall(
        r"The `steam-ref` rows work in any install.*?the wheel holds the package alone\.", README, re.S
    )
    for folder in read:
        assert f"`{folder}/`" in said, folder
    assert "`steam-ref homework`" in said and "`conformance build`" in said, said
