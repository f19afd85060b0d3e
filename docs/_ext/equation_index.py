"""The page "Equations → code" (``docs/equations.md``, written at build time by ``pages.py``).

For each equation of the paper and for Algorithm 1 and its steps: what it is (one line, written here), every
module, class and function whose source cites it (``citations.py`` reads the citations), each a link to its
entry in the API pages, and the sections of ``derivations.md`` that cite it. A citation is credited to the
innermost definition holding it that the API pages document (autodoc documents a public name with a
docstring, defined in its module and, outside a package's ``__init__``, listed in its ``__all__``); a link that
still does not resolve is a build warning (``pages.py``), so with ``-W`` the rule here cannot drift from
autodoc's. No Sphinx here: the tests import it.
"""

from __future__ import annotations

import importlib
import inspect
import re
import types
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import cast

from citations import ALGORITHM, Citation, Site, citations_in, sites_in
from myst_parser.slugs import github_slugify

# What each equation is, in a line (our words, not the paper's).
EQUATIONS: dict[int, str] = {
    1: "The trajectory x(t) is a Gaussian process with mean μ(t) and kernel 𝒦(t, t′).",
    2: "A measurement is a function h of a few variables plus Gaussian noise of covariance R.",
    3: "The states at the estimation times are jointly Gaussian: stacked mean μ, kernel matrix 𝒦.",
    4: "The landmarks' Gaussian prior, mean d and covariance W.",
    5: "The joint prior on θ = (states, landmarks): mean η and covariance 𝒫 = diag(𝒦, W).",
    6: "The MAP estimate θ* minimises the prior's and the measurements' squared Mahalanobis distances.",
    7: "All measurement functions stacked into h(θ).",
    8: "All measurement covariances, block-diagonal R.",
    9: "A measurement linearized about the current estimate θ̄ (its Jacobian H).",
    10: "The linearized least-squares problem in the update δθ.",
    11: "The normal equations 𝓘 δθ* = b, with information matrix 𝓘 = 𝒫⁻¹ + Hᵀ R⁻¹ H (one Gauss-Newton step).",
    12: "GP interpolation: the posterior mean at any time from the estimated states.",
    13: "A measurement at a time without a state of its own, linearized through the interpolated state.",
    14: "The linear time-varying SDE ẋ = A x + v + F w, white noise of power spectral density Qc, behind the prior.",
    15: "The information matrix in state, landmark and cross blocks (the sparsity the prior gives).",
    16: "𝒦(τ)𝒦⁻¹ is zero but for the two neighbouring states: the interpolation matrices Λ(τ), Ψ(τ).",
    17: "The process noise covariance Q accumulated over an interval (Q_τ, and Qᵢ over a whole step).",
    18: "The interpolated mean at τ from the two neighbouring states alone, in O(1).",
    19: "Measurement interpolation (Eq. 13) reduced to the two neighbouring states.",
    20: "The factor graph: the density as a product of factors.",
    21: "Gaussian factors: the whole problem as the sparse least squares of A θ − b.",
    22: "The GP prior factor between consecutive states, Φ xᵢ₋₁ + vᵢ − xᵢ weighted by Qᵢ⁻¹.",
    23: "The prior mean's input over one step, vᵢ = ∫ Φ(tᵢ, s) v(s) ds.",
    24: "The factor on a variable and its separator, formed before the variable is eliminated.",
    25: "The conditional density of a variable given its separator, left in the Bayes tree by elimination.",
    26: "A measurement factor on estimated variables.",
    27: "A measurement factor at a missing (interpolated) state.",
    28: "That factor linearized through 𝒦(τ)𝒦⁻¹.",
    29: "The interpolated measurement factor on the two neighbouring states, through Λ(τ) and Ψ(τ).",
    30: "The constant-velocity prior of the experiments, ẋ = A x + F w (white noise on acceleration).",
    31: "Its matrices A, F and the noise w of power spectral density Qc.",
    32: "The odometry reading: forward speed and turn rate in the robot's frame.",
    33: "The range reading: the distance from the robot's position to a landmark.",
}
ALGORITHM_1 = "BTGP: incremental sparse GP regression on the Bayes tree with GP prior factors."
STEPS: dict[int, str] = {
    1: "New readings become factors; a missing state is replaced by its neighbours, a new state gets its GP prior.",
    2: "Remove the cliques of the affected variables and their ancestors up to the root.",
    3: "Relinearize the factors of the removed part, interpolating missing states.",
    4: "Add the cached marginal factors of the orphaned subtrees.",
    5: "Eliminate the removed part under a new ordering into a Bayes tree; reattach the orphans.",
    6: "Update the estimate from the root, stopping where the updates fall below a threshold.",
    7: "Mark for relinearization the variables that moved past a threshold.",
}

_SECTION = re.compile(r"^## (\d+)\. (.*)$")


@dataclass(frozen=True)
class Entry:
    """A row of the page: the key ("Eq. 17", "Alg. 1", "Alg. 1, step 2"), what it is, the links to code and
    to derivations.md."""

    key: str
    what: str
    code: tuple[str, ...]
    derivations: tuple[str, ...]


def keys_of(citation: Citation) -> list[str]:
    """The rows a citation belongs to."""
    return (
        [f"Eq. {n}" for n in citation.equations]
        + [f"Alg. {a}" for a in citation.algorithms]
        + [f"Alg. {a}, step {s}" for a, s in citation.steps]
    )


def known_keys() -> list[str]:
    return [f"Eq. {n}" for n in EQUATIONS] + [f"Alg. {ALGORITHM}"] + [f"Alg. {ALGORITHM}, step {s}" for s in STEPS]


def documented_name(site: Site, documented_modules: Iterable[str]) -> str | None:
    """The dotted name of the innermost definition holding ``site`` that the API pages document, or None
    when its module is on no page."""
    if site.module not in set(documented_modules):
        return None
    module = importlib.import_module(site.module)
    package = Path(module.__file__ or "").name == "__init__.py"
    listed = getattr(module, "__all__", None)
    name, parent = site.module, cast(object, module)
    for part, _kind in site.chain:
        if part.startswith("_"):
            break
        if isinstance(parent, types.ModuleType):
            obj: object = parent.__dict__.get(part)
            if getattr(obj, "__module__", None) != site.module or (
                not package and listed is not None and part not in listed
            ):
                break
        elif isinstance(parent, type) and part in parent.__dict__:
            obj = getattr(parent, part)
        else:
            break  # inside a function: autodoc documents nothing there
        if not inspect.getdoc(obj):
            break
        name, parent = f"{name}.{part}", obj
    return name


def derivation_sections(text: str) -> dict[str, list[str]]:
    """Row key → Markdown links to the sections of derivations.md (``text``) whose text cites it."""
    found: dict[str, list[str]] = {}
    section = ""
    for line in text.splitlines():
        heading = _SECTION.match(line)
        if heading:
            title = line.removeprefix("## ")  # MyST's anchor is the slug of the heading's whole text
            section = f"[§{heading.group(1)}](derivations.md#{github_slugify(title)})"
        for citation in citations_in(line):
            for key in keys_of(citation):
                if section and section not in found.setdefault(key, []):
                    found[key].append(section)
    return found


def entries(package: Path, derivations: Path, documented_modules: Iterable[str]) -> tuple[list[Entry], list[str]]:
    """The page's rows, and the problems: a citation of a key the page does not know, a key nothing cites."""
    documented = list(documented_modules)
    code: dict[str, list[str]] = {key: [] for key in known_keys()}
    problems: list[str] = []
    for site in sites_in(package):
        name = documented_name(site, documented)
        link = (
            f"{{py:obj}}`{name.removeprefix('steam_ref.')} <{name}>`"
            if name
            else f"`{site.citation.path.relative_to(package.parent)}`"
        )
        for key in keys_of(site.citation):
            if key not in code:
                problems.append(
                    f"{site.citation.path}:{site.citation.line}: {site.citation.text} cites {key}, which the paper does not have"
                )
            elif link not in code[key]:
                code[key].append(link)
    problems += [f"nothing in {package.name}/ cites {key}" for key, links in code.items() if not links]
    derived = derivation_sections(derivations.read_text())
    what = {f"Eq. {n}": w for n, w in EQUATIONS.items()} | {f"Alg. {ALGORITHM}": ALGORITHM_1}
    what |= {f"Alg. {ALGORITHM}, step {s}": w for s, w in STEPS.items()}
    rows = [Entry(key, what[key], tuple(sorted(links)), tuple(derived.get(key, ()))) for key, links in code.items()]
    return rows, problems


def page(rows: list[Entry]) -> str:
    """The Markdown of the page: a section per row, so ``equations.html#eq-17`` opens Eq. 17."""
    lines = [
        "# Equations → code",
        "",
        "Each equation of the paper (Yan, Indelman and Boots) and each step of its Algorithm 1: what it is, every",
        "module, class and function of steam_ref whose source cites it (a link to its API entry), and the",
        "sections of [the derivations](derivations.md) that cite it. The code cites the paper as `[YIB Eq. 17]`,",
        "`[YIB Eq. 24-25]`, `[YIB Eq. 2, 6, 26-27]` or `[YIB Alg. 1 step 7]`. This page is generated from those",
        "citations when the site is built, so it lists what the code says today.",
        "",
    ]
    for row in rows:
        level = "###" if ", step " in row.key else "##"
        heading = row.key.replace(f"Alg. {ALGORITHM}, step", "Step").replace("Alg.", "Algorithm")
        lines += [f"{level} {heading}", "", row.what, ""]
        lines += [f"- Code: {', '.join(row.code)}"] if row.code else []
        lines += [f"- Derivations: {', '.join(row.derivations)}"] if row.derivations else []
        lines += [""]
    return "\n".join(lines)


def write(out: Path, package: Path, derivations: Path, documented_modules: Iterable[str]) -> list[str]:
    """Write the page to ``out`` (only when its text changes); return the problems (see :func:`entries`)."""
    rows, problems = entries(package, derivations, documented_modules)
    text = page(rows)
    if not out.is_file() or out.read_text() != text:
        out.write_text(text)
    return problems
