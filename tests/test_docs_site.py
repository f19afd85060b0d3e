"""The built site, read as a reader reads it: in a browser with no network.

The site is built by the README's docs command into ``docs/_build/html`` (or the folder
$STEAM_REF_DOCS_HTML names). Each page below is opened in headless Chromium with every remote address
made unreachable; a script added to a copy of the page waits for the page and its math, then records
what the browser shows: each image and whether it decoded (its natural width), the rendered formulas,
and the links of the navigation. Without a built site or Chromium these tests skip, saying what to do;
STEAM_REF_REQUIRE_DOCS=1 (CI, after building the site) makes that a failure.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import pytest
from requirements import REPO_ROOT, required, skip_or_fail

from steam_ref.datasets.fetch import missing_needs

pytestmark = pytest.mark.slow

SITE = Path(os.environ.get("STEAM_REF_DOCS_HTML") or REPO_ROOT / "docs" / "_build" / "html")
BROWSERS = ("chromium", "chromium-browser", "google-chrome")
TUTORIALS = sorted(p.stem for p in (REPO_ROOT / "tutorials").glob("*.ipynb"))
README = (REPO_ROOT / "README.md").read_text()

# Appended to a copy of a page: once the page has loaded and MathJax has typeset it, write what the
# browser sees into the document, where --dump-dom prints it.
PROBE = """
<script>
window.addEventListener("load", async () => {
  if (window.MathJax && MathJax.startup && MathJax.startup.promise) { await MathJax.startup.promise; }
  const seen = {
    images: [...document.images].map(i => ({src: i.getAttribute("src"), width: i.naturalWidth})),
    formulas: document.querySelectorAll("mjx-container svg").length,
    untypeset: [...document.querySelectorAll(".math")].filter(e => !e.querySelector("mjx-container svg")).length,
    errors: document.querySelectorAll("mjx-merror, [data-mjx-error]").length,
    navbar: [...document.querySelectorAll(".bd-header .navbar-nav a")].map(a => a.textContent.trim()),
    sidebar: [...document.querySelectorAll(".bd-sidenav a")].map(a => a.textContent.trim()),
    needs: [...document.querySelectorAll(".steam-ref-needs")].map(e => e.textContent.trim()),
  };
  const out = document.createElement("pre");
  out.id = "reader-probe";
  out.textContent = JSON.stringify(seen);
  document.body.appendChild(out);
});
</script>
"""


def _browser() -> str:
    found = next((shutil.which(b) for b in BROWSERS if shutil.which(b)), None)
    if found is None:
        skip_or_fail("no headless browser to open the site with: apt-get install chromium", "docs")
    return found


def _site() -> Path:
    if not (SITE / "index.html").is_file():
        skip_or_fail(
            f"the site is not built ({SITE} has no index.html): "
            "pip install -e '.[docs]' && python3 -m sphinx -W docs docs/_build/html",
            "docs",
        )
    return SITE


class _Probe(HTMLParser):
    """The text of the element with id ``reader-probe``."""

    def __init__(self) -> None:
        super().__init__()
        self.inside, self.text = False, ""

    def handle_starttag(self, tag, attrs):
        self.inside = self.inside or dict(attrs).get("id") == "reader-probe"

    def handle_endtag(self, tag):
        if self.inside and tag == "pre":
            self.inside = False

    def handle_data(self, data):
        if self.inside:
            self.text += data


def read_page(page: str) -> dict:
    """What headless Chromium shows of ``page`` (a path inside the site), with the network cut off."""
    browser, site = _browser(), _site()
    source = site / page
    assert source.is_file(), f"{page} is not in the site"
    copy = source.with_name(f"_reader_probe_{source.name}")  # same folder: relative links resolve alike
    copy.write_text(source.read_text().replace("</body>", PROBE + "</body>"))
    try:
        out = subprocess.run(
            [
                browser,
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--no-first-run",
                "--proxy-server=http://127.0.0.1:9",
                "--host-resolver-rules=MAP * ~NOTFOUND",
                "--window-size=1300,1000",
                "--virtual-time-budget=20000",
                "--dump-dom",
                copy.as_uri(),
            ],
            capture_output=True,
            text=True,
            timeout=120,
        )
    finally:
        copy.unlink()
    probe = _Probe()
    probe.feed(out.stdout)
    assert probe.text, f"the browser recorded nothing for {page} (exit {out.returncode}): {out.stderr[-2000:]}"
    return json.loads(probe.text)


def _has_latex(tutorial: str) -> bool:
    cells = json.loads((REPO_ROOT / "tutorials" / f"{tutorial}.ipynb").read_text())["cells"]
    return any("$" in "".join(c["source"]) for c in cells if c["cell_type"] == "markdown")


def _decoded_pngs(seen: dict) -> list[str]:
    return [i["src"] for i in seen["images"] if i["src"].endswith(".png") and i["width"] > 0]


def test_the_landing_page_shows_its_figure_and_the_sections():
    seen = read_page("index.html")
    broken = [i["src"] for i in seen["images"] if i["width"] == 0]
    assert not broken, f"images that did not load: {broken}"
    assert any("fig4" in src for src in _decoded_pngs(seen)), seen["images"]
    assert {"Tutorials", "Background", "Reference"} <= set(seen["navbar"]), seen["navbar"]


def _declared_needs(tutorial: str) -> list[str]:
    metadata = json.loads((REPO_ROOT / "tutorials" / f"{tutorial}.ipynb").read_text())["metadata"]
    return metadata["steam_ref"]["needs"]


def _check_needs_note(name: str, note: str) -> None:
    """A page built without what its tutorial needs is accepted only while those are absent here too,
    and never in CI's build with the data (STEAM_REF_REQUIRE_DATA=1): it names each missing need and
    the command that gets it."""
    missing = missing_needs(_declared_needs(name))
    assert missing, f"{name}: the page says it was built without its needs, but they are present: rebuild the site"
    assert not required("data"), f"{name} was built without {missing} although STEAM_REF_REQUIRE_DATA=1"
    for need in missing:
        assert need in note, f"{name}'s note does not name {need}: {note!r}"
    assert "steam-ref data fetch" in note or "pip install gtsam" in note, note


@pytest.mark.parametrize("name", TUTORIALS)
def test_each_tutorial_page_shows_figures_math_and_its_neighbours(name):
    """Every tutorial was run at build time: its page has plots (decoded PNGs), its LaTeX typeset by
    the local MathJax, and the section's navigation listing every tutorial. A tutorial whose data were
    absent at build time shows instead, without outputs, a note saying what it needs (accepted only
    while they are absent)."""
    seen = read_page(f"tutorials/{name}.html")
    broken = [i["src"] for i in seen["images"] if i["width"] == 0]
    assert not broken, f"images that did not load: {broken}"
    if seen["needs"]:
        _check_needs_note(name, " ".join(seen["needs"]))
        assert not _decoded_pngs(seen), f"{name}: outputs shown although the notebook was not run"
    else:
        assert _decoded_pngs(seen), f"{name}: no figure on the page and no note saying why (was it executed?)"
    assert seen["untypeset"] == 0 and seen["errors"] == 0, seen
    if _has_latex(name):
        assert seen["formulas"] > 0, f"{name}'s LaTeX was not typeset"
    assert len(seen["sidebar"]) >= len(TUTORIALS), seen["sidebar"]
    assert {"Tutorials", "Background", "Reference"} <= set(seen["navbar"]), seen["navbar"]


def test_no_page_loads_anything_from_the_network():
    """No script, style sheet, image or frame of any page points off the site."""
    remote = re.compile(r"<(?:script|link|img|iframe|source)\b[^>]*\b(?:src|href)=[\"']((?:https?:)?//[^\"']*)", re.I)
    found = {str(p.relative_to(_site())): remote.findall(p.read_text()) for p in _site().rglob("*.html")}
    assert not {page: urls for page, urls in found.items() if urls}


def test_the_readme_docs_command_is_a_line_of_ci():
    (command,) = re.findall(r"^    (.*-m sphinx.*)$", README, flags=re.M)
    ci = (REPO_ROOT / ".ci" / "run").read_text()
    assert command in ci.splitlines()
    # ... and CI builds the site once more as a newcomer would: no data, gtsam hidden, then reads it
    sphinx = command.rpartition("&& ")[2]
    assert sum(line.strip().endswith(sphinx) for line in ci.splitlines()) == 2, ci
    assert "unset STEAM_REF_DATA_DIR" in ci and "git clone" in ci and "tests/test_docs_site.py" in ci


def test_every_tutorial_declares_what_it_needs_and_its_header_says_how_to_get_it():
    """The rule the docs build and this file read: a notebook's ``steam_ref.needs`` metadata, checked
    against its parsed code (a data set loaded by name is declared) and its title cell (how to get it)."""
    loads = re.compile(r"""load_dataset\(\s*["']([\w-]+)["']""")
    for name in TUTORIALS:
        nb = json.loads((REPO_ROOT / "tutorials" / f"{name}.ipynb").read_text())
        needs = _declared_needs(name)
        code = "\n".join("".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "code")
        for data in set(loads.findall(code)) - {"synthetic"}:
            assert f"data:{data}" in needs, f"{name} loads {data!r} but does not declare data:{data}"
        if "load_authors_run" in code:
            assert any(n.startswith("data:authors-") for n in needs), f"{name} reads an authors' run undeclared"
        header = "".join(nb["cells"][0]["source"])
        assert "**Needs.**" in header, f"{name}'s first cell does not say what it needs"
        for need in needs:
            data = need.removeprefix("data:")
            assert data in header or "gtsam" in header, f"{name}'s header does not say how to get {need}"


def test_no_table_cell_of_the_docs_splits_inline_code():
    """A ``|`` inside backticks ends a Markdown table cell: the page then shows raw backticks."""
    broken = []
    for page in sorted((REPO_ROOT / "docs").glob("*.md")) + [REPO_ROOT / "README.md"]:
        for number, line in enumerate(page.read_text().splitlines(), 1):
            if line.startswith("|"):
                cells = re.split(r"(?<!\\)\|", line.strip().strip("|"))
                broken += [f"{page.name}:{number}" for cell in cells if cell.count("`") % 2]
    assert not broken, f"a table cell with an odd number of backticks: {broken}"


def test_the_build_leaves_unexecuted_exactly_the_tutorials_whose_data_are_absent(tmp_path, monkeypatch):
    """The rule the docs build applies (docs/_ext/pages.py), without a build: with no data folder, an
    empty cache and no gtsam, the tutorials declaring a data set are left unexecuted (the rule once
    searched the raw .ipynb text, where quotes are escaped, and never matched load_dataset("plaza"))."""
    from requirements import optional_import

    optional_import("sphinx", "docs", kind="docs")
    monkeypatch.syspath_prepend(str(REPO_ROOT / "docs" / "_ext"))
    import pages

    from steam_ref.datasets import search

    for variable in ("STEAM_REF_DATA_DIR", "STEAM_REF_REQUIRE_DATA", "STEAM_REF_REQUIRE_OPTIONAL"):
        monkeypatch.delenv(variable, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    monkeypatch.setattr(search, "gtsam_data_dir", lambda: None)
    declared = {name: _declared_needs(name) for name in TUTORIALS}
    expected = sorted(f"*{name}.ipynb" for name, needs in declared.items() if any(n.startswith("data:") for n in needs))
    assert sorted(pages.notebooks_without_their_data(REPO_ROOT / "tutorials")) == expected
    assert "*04_incremental.ipynb" in expected and "*06_motion_priors.ipynb" in expected
    note = pages.needs_note(pages.UNEXECUTED["04_incremental"])
    assert "    steam-ref data fetch plaza\n" in note and pages.NEEDS_NOTE_CLASS in note  # 04 reads Plaza alone
    monkeypatch.setenv("STEAM_REF_REQUIRE_DATA", "1")
    with pytest.raises(RuntimeError, match=r"STEAM_REF_REQUIRE_DATA=1 but 04_incremental\.ipynb needs data:plaza"):
        pages.notebooks_without_their_data(REPO_ROOT / "tutorials")


def test_the_equations_page_links_each_equation_and_step_to_the_api_entries_citing_it():
    """The page "Equations → code" (docs/_ext/equation_index.py): a section per equation of the paper and per step
    of its Algorithm 1 (``equations.html#eq-17``, ``#step-6``), each linking into the API pages, and every such
    link lands on an anchor that page has (an object autodoc documented)."""
    from test_paper_equations_are_cited import PAPER_EQUATIONS, PAPER_STEPS

    page = _site() / "equations.html"
    assert page.is_file(), "the site has no equations.html (docs/_ext/pages.py writes docs/equations.md)"
    sections = {}
    for chunk in page.read_text().split('<section id="')[1:]:
        anchor, _, body = chunk.partition('"')
        sections[anchor] = body
    expected = [f"eq-{n}" for n in PAPER_EQUATIONS] + ["algorithm-1"] + [f"step-{s}" for _, s in PAPER_STEPS]
    assert [a for a in expected if a not in sections] == []
    for anchor in expected:
        links = re.findall(r'href="(modules/[\w-]+\.html)#([^"]+)"', sections[anchor])
        assert links, f"{anchor}: no link into the API pages"
        for target, name in set(links):
            assert f'id="{name}"' in (_site() / target).read_text(), f"{anchor} links {target}#{name}, not there"


# --- what the pages say, read beside the code (no browser) ------------------------------------------------------

PAGES = ["README.md"] + [
    f"docs/{name}.md"
    for name in ("api", "architecture", "background", "bayes_tree", "conformance", "derivations", "index", "tutorials")
]
# A section of derivations.md named from another page: "derivations §16", "[derivations.md](...), section 12".
_SECTION_REFERENCE = re.compile(r"derivations[^§\n]{0,90}?(?:§ ?|section )(\d+)")
# Words that name one derivation, and the words its section's title holds.
_TOPICS = {
    "fit_qc": "Qc from data",
    "fit-qc": "Qc from data",
    "maximum likelihood": "Qc from data",
    "maximum-likelihood": "Qc from data",
    "runs_needed": "Monte Carlo runs",
    "MAX_CONDITION": "smallest time gap",
}


def _derivation_titles() -> dict[int, str]:
    text = (REPO_ROOT / "docs" / "derivations.md").read_text()
    return {int(n): title for n, title in re.findall(r"^## (\d+)\. (.*)$", text, flags=re.M)}


def test_each_section_of_the_derivations_a_page_names_is_the_one_about_its_topic():
    """A reference to a section of derivations.md names a section that exists; after a name of one derivation
    (fit_qc, runs_needed, MAX_CONDITION) on the same line, the next reference names that derivation's section
    (api.md and architecture.md sent the Qc fit to §14, the priors with an acceleration, when it is §16)."""
    titles = _derivation_titles()
    assert any("Qc from data" in t for t in titles.values()), titles
    checked = 0
    for page in PAGES:
        for number, line in enumerate((REPO_ROOT / page).read_text().splitlines(), 1):
            references = [(m.start(), int(m.group(1))) for m in _SECTION_REFERENCE.finditer(line)]
            for _, section in references:
                assert section in titles, f"{page}:{number} names derivations §{section}, which does not exist"
            for word, topic in _TOPICS.items():
                for hit in re.finditer(re.escape(word), line):
                    after = [section for start, section in references if start > hit.start()]
                    if after:
                        checked += 1
                        assert topic in titles[after[0]], (
                            f"{page}:{number}: {word} is derived in the section on {topic!r}, "
                            f"not §{after[0]} ({titles[after[0]]})"
                        )
    assert checked >= 3, "the references to the derivations were not found"


def test_the_api_page_gives_the_se3_priors_state_as_the_prior_holds_it():
    """api.md's "On SE(3)" names the group the 'se3' prior is built on and its state's size: a pose of SE3V
    ([t; φ], as many numbers as its tangent) and its body twist, 6 + 6 numbers (it said SE3 and 18)."""
    import numpy as np

    import steam_ref as sr
    from steam_ref.lie import SE3V, GroupState

    text = (REPO_ROOT / "docs" / "api.md").read_text()
    bullet = re.search(r"\*\*On SE\(3\)\*\*.*?(?=\n- )", text, flags=re.S)
    assert bullet, "api.md has no bullet on SE(3)"
    said = re.search(r"LieGroupWnoa\((\w+), qc, residual\).*?(\d+) numbers", bullet.group(0), re.S)
    assert said, "api.md's bullet on SE(3) does not name the prior's class and its state's size"
    group, numbers = said.groups()
    assert group == "SE3V" and int(numbers) == SE3V.size + SE3V.dim == 12
    prior = sr.motion_prior("se3", np.eye(6))
    assert prior.kind is GroupState(SE3V) and prior.state_dim == int(numbers)


def test_the_conformance_page_counts_the_plaza_states_the_paper_case_stores():
    """conformance.md's paper suite stores Plaza's estimate "at every 10th state and the last, N of 9,658": states
    0, 10, ..., 9,650 and 9,657, 967 (it said 966), as many as the shipped case holds."""
    import numpy as np

    from steam_ref.conformance import KIT_VERSION, KITS

    text = (REPO_ROOT / "docs" / "conformance.md").read_text()
    said = re.search(r"every 10th state and the last, ([\d,]+) of ([\d,]+)\)", text)
    assert said, "conformance.md no longer says how many Plaza states the paper case stores"
    stored, total = (int(n.replace(",", "")) for n in said.groups())
    assert total == 9658
    assert stored == len(set(range(0, total, 10)) | {total - 1}) == 967
    with np.load(KITS[KIT_VERSION] / "paper" / "expected.npz") as expected:
        assert expected["plaza_btgp1/poses"].shape == (stored, 3)


def test_the_conformance_pages_failing_case_is_what_check_prints(tmp_path):
    """conformance.md's "Messages point at the bug" block is what `check` prints for a port whose Λ[0, 3] of
    gp/interp_tau1.1 is 0.001 off (and x̄(τ)[0] 0.0008): results made from the current kit's own expected values
    (the oracle's), those two entries moved. The block's expected values were kit v4's, a few ulps from v5's."""
    import json

    import numpy as np

    from steam_ref.conformance import KIT_VERSION, SHIPPED, check_directory

    text = (REPO_ROOT / "docs" / "conformance.md").read_text()
    block = re.search(r"\n\n(    FAIL gp/interp_tau1\.1:.*?)\n\n", text, flags=re.S)
    assert block, "conformance.md's failing-case example was not found"
    with np.load(SHIPPED / "gp" / "expected.npz") as expected:
        got = {key.split("/", 1)[1]: expected[key].copy() for key in expected.files if key.startswith("interp_tau1.1/")}
    got["Lambda"][0, 3] += 0.001
    got["x_tau"][0] += 0.0008
    (tmp_path / "gp").mkdir()
    results = {"kit_version": KIT_VERSION, "cases": {"interp_tau1.1": {k: v.tolist() for k, v in got.items()}}}
    (tmp_path / "gp" / "results.json").write_text(json.dumps(results))
    printed = check_directory(tmp_path, only=["gp"], allow_missing=True).lines()
    for line in block.group(1).splitlines():
        shown = re.escape(line[4:]).replace(re.escape("(...)"), r"\(.*")
        assert any(re.fullmatch(shown, p) for p in printed), f"check does not print {line[4:]!r}:\n" + "\n".join(
            printed
        )
