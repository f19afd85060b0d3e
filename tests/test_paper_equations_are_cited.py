"""Every equation of the paper is cited in steam_ref/, and every citation there names one the paper has.

The citations (``[YIB Eq. 17]``, ``[YIB Eq. 24-25]``, ``[YIB Alg. 1 step 7]``...) are read by the one parser of
their syntax, ``docs/_ext/citations.py``, which the docs build also uses for the page "Equations → code"
(``docs/_ext/equation_index.py``). The paper's numbering is stored below; when the paper's text is present
(beside the repository, ``../shared/paper``), it is read again and must agree.
"""

from __future__ import annotations

import importlib
import os
import re
import sys
from pathlib import Path

import pytest
from requirements import REPO_ROOT, optional_import, skip_or_fail

from steam_ref.errors import SteamError

PACKAGE = REPO_ROOT / "steam_ref"
PAPER_NAME = "incremental-sparse-gp-steam.md"
# The paper's numbered display equations, (1) to (33), and the numbered steps of its Algorithm 1 (BTGP), as
# read from ../shared/paper/incremental-sparse-gp-steam.md (each display ends "\quad (n)$$"; the steps follow
# the line "Algorithm 1 ..."). test_the_stored_numbering_is_the_papers re-reads them when the file is there.
PAPER_EQUATIONS = tuple(range(1, 33 + 1))
PAPER_ALGORITHMS = (1,)
PAPER_STEPS = tuple((1, step) for step in range(1, 7 + 1))


def _docs_module(name: str):
    """A module of the docs' extension folder (Sphinx-free), imported without leaving it on sys.path."""
    sys.path.insert(0, str(REPO_ROOT / "docs" / "_ext"))
    try:
        return importlib.import_module(name)
    finally:
        sys.path.remove(str(REPO_ROOT / "docs" / "_ext"))


@pytest.fixture(scope="module")
def citations():
    return _docs_module("citations")


@pytest.fixture(scope="module")
def sites(citations):
    return citations.sites_in(PACKAGE)


def _paper() -> Path | None:
    """The paper's text beside the repository (or beside $STEAM_REF_DATA_DIR), None when absent."""
    places = [REPO_ROOT.parent / "shared" / "paper" / PAPER_NAME]
    if os.environ.get("STEAM_REF_DATA_DIR"):
        places.append(Path(os.environ["STEAM_REF_DATA_DIR"]).parent / "paper" / PAPER_NAME)
    return next((p for p in places if p.is_file()), None)


def unknown(sites) -> list[str]:
    """The citations naming an equation, algorithm or step the paper does not have."""
    return [
        f"{s.citation.path}:{s.citation.line}: {s.citation.text}"
        for s in sites
        if not set(s.citation.equations) <= set(PAPER_EQUATIONS)
        or not set(s.citation.algorithms) <= set(PAPER_ALGORITHMS)
        or not set(s.citation.steps) <= set(PAPER_STEPS)
    ]


def test_the_stored_numbering_is_the_papers():
    paper = _paper()
    if paper is None:
        skip_or_fail(
            f"the paper's text ({PAPER_NAME}) is not in ../shared/paper: the stored numbering is used alone", "data"
        )
    text = paper.read_text()
    numbers = [int(n) for n in re.findall(r"\((\d+)\)\s*\$\$\s*$", text, flags=re.M)]
    assert numbers == sorted(set(numbers)), "the paper's equation numbers repeat or run out of order"
    assert tuple(numbers) == PAPER_EQUATIONS
    algorithm = text[text.index("\nAlgorithm 1 ") : text.index("\nIV. EXPERIMENTAL RESULTS")]
    steps = [int(n) for n in re.findall(r"^\s*(\d+)\. ", algorithm, flags=re.M)]
    assert tuple((1, s) for s in steps) == PAPER_STEPS


def test_every_equation_and_step_of_the_paper_is_cited_in_steam_ref(sites):
    equations = {n for s in sites for n in s.citation.equations}
    steps = {k for s in sites for k in s.citation.steps}
    algorithms = {a for s in sites for a in s.citation.algorithms}
    assert not set(PAPER_EQUATIONS) - equations, f"never cited: Eq. {sorted(set(PAPER_EQUATIONS) - equations)}"
    assert not set(PAPER_STEPS) - steps, f"steps of Algorithm 1 never cited: {sorted(set(PAPER_STEPS) - steps)}"
    assert set(PAPER_ALGORITHMS) <= algorithms


def test_every_citation_in_steam_ref_names_what_the_paper_has(sites):
    """Reading the package also checks every bracket after the tag parses (a malformed one raises)."""
    assert len(sites) > 100  # the package cites the paper hundreds of times: the scan found them
    assert not unknown(sites), "citations of what the paper does not have:\n" + "\n".join(unknown(sites))


def test_a_citation_of_an_equation_the_paper_lacks_is_caught(citations, tmp_path):
    package = tmp_path / "steam_ref"
    package.mkdir()
    (package / "__init__.py").write_text('"""A package.  [YIB Eq. 17]"""\n')
    (package / "typo.py").write_text(
        '"""A module."""\n\n\nclass Model:\n    def step(self):\n        """One step.  [YIB Eq. 53]"""\n'
    )
    sites = citations.sites_in(package)
    assert unknown(sites) == [f"{package / 'typo.py'}:6: [YIB Eq. 53]"]
    assert [s.chain for s in sites if s.module == "steam_ref.typo"] == [(("Model", "class"), ("step", "def"))]
    assert unknown(citations.sites_in(package)[:1]) == []  # the package's own citation is fine
    # ... a range reaching past the last equation, and a step Algorithm 1 does not have
    assert unknown([citations.Site(citations.parse("[YIB Eq. 30-34]"), "m", ())]) == ["<text>:0: [YIB Eq. 30-34]"]
    assert unknown([citations.Site(citations.parse("[YIB step 8]"), "m", ())]) == ["<text>:0: [YIB step 8]"]
    assert unknown([citations.Site(citations.parse("[YIB Alg. 2]"), "m", ())]) == ["<text>:0: [YIB Alg. 2]"]


@pytest.mark.parametrize(
    ("text", "equations", "algorithms", "steps"),
    [
        ("[YIB Eq. 17]", (17,), (), ()),
        ("[YIB Eq. 24-25]", (24, 25), (), ()),
        ("[YIB Eq. 2, 6, 26-27]", (2, 6, 26, 27), (), ()),
        ("[YIB Eq. 16-18, 22, 30-31]", (16, 17, 18, 22, 30, 31), (), ()),
        ("[YIB Eq. 13, 28; 18, 29]", (13, 28, 18, 29), (), ()),
        ("[YIB Eq. 25, step 6]", (25,), (), ((1, 6),)),
        ("[YIB step 3, Eq. 9]", (9,), (), ((1, 3),)),
        ("[YIB Alg. 1]", (), (1,), ()),
        ("[YIB Alg. 1 step 7]", (), (), ((1, 7),)),
        ("[YIB Alg. 1 steps 2-5]", (), (), ((1, 2), (1, 3), (1, 4), (1, 5))),
        ("[YIB Alg. 1, Eq. 9-11, 24; derivations Eq. 10.1-10.4]", (9, 10, 11, 24), (1,), ()),
        ("[K12 Alg. 6, YIB steps 2-5]", (), (), ((1, 2), (1, 3), (1, 4), (1, 5))),
        ("[DER 11.10-11.12; YIB Eq. 17, 22]", (17, 22), (), ()),
        ("[YIB Eq. 24-25, K12 Alg. 1-2]", (24, 25), (), ()),
        ("[YIB Eq. 16, 29; DER 11.16]", (16, 29), (), ()),
        ("[YIB Eq. 11: cov δθ* = 𝓘⁻¹]", (11,), (), ()),
        ("[YIB Sec. III-A, Eq. 24-25]", (24, 25), (), ()),
        ("[YIB Sec. III, IV, K12 Sec. 4.2]", (), (), ()),
        ("[YIB Sec. IV, Table I]", (), (), ()),
        ("[YIB Fig. 2-4]", (), (), ()),
        ("[YIB]", (), (), ()),
    ],
)
def test_the_parser_expands_ranges_and_lists(citations, text, equations, algorithms, steps):
    got = citations.parse(text)
    assert (got.equations, got.algorithms, got.steps) == (equations, algorithms, steps)


@pytest.mark.parametrize(
    "text",
    [
        "[YIB Eq 17]",  # no dot
        "[YIB eq. 17]",
        "[YIB Eq. 17a]",
        "[YIB Eq. 10.2]",  # not the paper's numbering
        "[YIB Eq. 25-24]",  # backwards
        "[YIB Eq. 3, x]",
        "[YIB Sec. II, 4]",  # a number after a section
        "[YIB Equation 3]",
        "[YIB stp 6]",
    ],
)
def test_the_parser_refuses_what_it_cannot_read_naming_it(citations, text):
    with pytest.raises(SteamError, match=re.escape(text)):
        citations.parse(text)


def test_the_scan_refuses_the_tag_outside_a_one_line_bracket_and_skips_the_placeholder(citations):
    assert list(citations.citations_in("the code cites [YIB Eq. n] as the syntax")) == []
    found = list(citations.citations_in("x = 1  # [YIB Eq. 22]\ny = 2  # [t; φ] and [YIB Eq. 4, 33]\n"))
    assert [(c.line, c.equations) for c in found] == [(1, (22,)), (2, (4, 33))]
    with pytest.raises(SteamError, match="line 2 of <text>"):
        list(citations.citations_in("ok\n# see YIB Eq. 17\n"))
    with pytest.raises(SteamError, match="line 1 of <text>"):
        list(citations.citations_in("# [YIB Eq. 17,\n#  22]\n"))


def test_the_equations_page_describes_exactly_the_papers_equations_and_steps():
    optional_import("myst_parser", "docs", kind="docs")
    equation_index = _docs_module("equation_index")
    assert tuple(equation_index.EQUATIONS) == PAPER_EQUATIONS
    assert tuple((equation_index.ALGORITHM, s) for s in equation_index.STEPS) == PAPER_STEPS
    rows, problems = equation_index.entries(PACKAGE, REPO_ROOT / "docs" / "derivations.md", ["steam_ref.gp.sde"])
    assert problems == []
    row = {r.key: r for r in rows}["Eq. 3"]
    # gp/sde.py's dense_kernel cites Eq. 3 in its docstring: credited to it; an undocumented module is its file
    assert "{py:obj}`gp.sde.dense_kernel <steam_ref.gp.sde.dense_kernel>`" in row.code
    assert "`steam_ref/motion/base.py`" in row.code
