"""The one home of the syntax by which steam_ref cites the paper (Yan, Indelman, Boots: YIB).

A citation is a bracket on one line holding the tag ``YIB``, alone or among other sources::

    [YIB Eq. 17]   [YIB Eq. 24-25]   [YIB Eq. 2, 6, 26-27]   [YIB Eq. 13, 28; 18, 29]
    [YIB Alg. 1]   [YIB Alg. 1 step 7]   [YIB Alg. 1 steps 2-5]   [YIB step 6]   [YIB Eq. 25, step 6]
    [YIB Sec. III-A, Eq. 24-25]   [YIB Fig. 2-4]   [YIB Sec. IV, Table I]   [YIB]
    [DER 11.18; YIB Eq. 17]   [K12 Alg. 6, YIB steps 2-5]   [YIB Eq. 11; derivations §1]   [YIB Eq. 11: prose]

After ``YIB`` come items separated by commas or semicolons: ``Eq.`` with numbers and ranges (a bare number
or range after it continues the list), ``Alg. 1`` with its ``step``/``steps``, a bare ``step``/``steps`` (of
Algorithm 1, the paper's only algorithm), ``Sec.``, ``Fig.`` and ``Table`` (recognised, not indexed). The
YIB part ends at the bracket, at a colon (prose follows) or at another source's tag (``K12``, ``DER``,
``derivations``...). ``[YIB Eq. n]`` names the syntax itself and cites nothing. Anything else after ``YIB`` is
refused with a :class:`~steam_ref.errors.SteamError` naming the bracket, so a typo is never read as no citation.

Used by the docs build (``equation_index.py``: the page "Equations → code") and by
``tests/test_paper_equations_are_cited.py``. No Sphinx here.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

from steam_ref.errors import SteamError

TAG = "YIB"
PLACEHOLDER = "[YIB Eq. n]"  # how the docs name the syntax: cites nothing
ALGORITHM = 1  # the paper's only algorithm: a bare ``step k`` is one of its steps

_ROMAN = r"[IVX]+(?:-[A-Z])?"
_ITEM = re.compile(
    rf"""(?:
      Eq\.\s*(?P<eq>\d+(?:\s*-\s*\d+)?)
    | Alg\.\s*(?P<alg>\d+)(?:\s+steps?\s+(?P<alg_steps>\d+(?:\s*-\s*\d+)?))?
    | steps?\s+(?P<steps>\d+(?:\s*-\s*\d+)?)
    | Sec\.\s*{_ROMAN}
    | Fig\.\s*(?P<fig>\d+(?:\s*-\s*\d+)?)
    | Table\s+[IVX]+
    | (?P<more>\d+(?:\s*-\s*\d+)?)
    | (?P<more_sec>{_ROMAN})
    )""",
    re.X,
)
_OURS = re.compile(r"(?:eq|alg|sec|fig|table|step)", re.I)  # words that must parse as an item
_OTHER_SOURCE = re.compile(r"(?:[A-Z][\w.]*|derivations)\b")  # K12, DER, BTS, derivations...
_BRACKET = re.compile(r"\[([^\[\]\n]*)\]")
_MENTION = re.compile(rf"\b{TAG}\b")


@dataclass(frozen=True)
class Citation:
    """One citation: where it is, its text, and what of the paper it names."""

    path: Path
    line: int
    text: str  # the whole bracket
    equations: tuple[int, ...] = ()
    algorithms: tuple[int, ...] = ()
    steps: tuple[tuple[int, int], ...] = ()  # (algorithm, step)


def expand(numbers: str, where: str) -> list[int]:
    """``"9-11, 24"`` → [9, 10, 11, 24]; a range running backwards is refused (``where`` names the citation)."""
    out: list[int] = []
    for part in numbers.split(","):
        first, _, last = (p.strip() for p in part.partition("-"))
        lo, hi = int(first), int(last or first)
        if hi < lo:
            raise SteamError(f"{where}: the range {part.strip()!r} runs backwards")
        out.extend(range(lo, hi + 1))
    return out


def parse(text: str, path: Path = Path("<text>"), line: int = 0) -> Citation | None:
    """The citation in the bracket ``text`` (``"[YIB Eq. 9-11, 24]"``), None for the placeholder
    ``[YIB Eq. n]``; a bracket without the tag is refused, as is anything after the tag that is not an item."""
    match = _MENTION.search(text)
    if not text.startswith("[") or not text.endswith("]") or match is None:
        raise SteamError(f"{text!r} is not a bracket citing {TAG}")
    if text == PLACEHOLDER:
        return None
    where = f"{text} (line {line} of {path})" if line else text
    rest, pos = text[match.end() : -1], 0
    equations: list[int] = []
    algorithms: list[int] = []
    steps: list[tuple[int, int]] = []
    kind = ""  # what a bare number or range continues: "eq", "step" or "fig"; "sec" for a bare numeral
    first = True
    while True:
        pos += len(rest[pos:]) - len(rest[pos:].lstrip())
        if pos >= len(rest) or rest[pos] == ":":
            break
        item = _ITEM.match(rest, pos)
        if item is not None and item.group("more_sec") and kind != "sec":
            item = None  # a numeral continues only a list of sections
        if item is None:
            word = _OTHER_SOURCE.match(rest, pos)
            if not first and word is not None and not _OURS.match(word.group()):
                break  # another source's tag: the YIB part ends
            raise SteamError(f"{where}: cannot read {rest[pos:]!r} as a citation of {TAG}")
        groups, first = item.groupdict(), False
        if groups["eq"] or (groups["more"] and kind == "eq"):
            equations += expand(groups["eq"] or groups["more"], where)
            kind = "eq"
        elif groups["alg"]:
            if groups["alg_steps"]:  # steps of it, not the whole algorithm
                steps += [(int(groups["alg"]), s) for s in expand(groups["alg_steps"], where)]
            else:
                algorithms.append(int(groups["alg"]))
            kind = "step" if groups["alg_steps"] else ""
        elif groups["steps"] or (groups["more"] and kind == "step"):
            steps += [(ALGORITHM, s) for s in expand(groups["steps"] or groups["more"], where)]
            kind = "step"
        elif groups["fig"] or (groups["more"] and kind == "fig"):
            kind = "fig"
        elif groups["more"]:
            raise SteamError(f"{where}: the number {groups['more']!r} follows no Eq., step or Fig.")
        else:
            kind = "sec"
        pos = item.end()
        sep = re.match(r"\s*[,;]", rest[pos:])
        if sep is None:
            tail = rest[pos:].strip()
            if tail and not tail.startswith(":"):
                raise SteamError(f"{where}: cannot read {tail!r} as a citation of {TAG}")
            break
        pos += sep.end()
    return Citation(path, line, text, tuple(equations), tuple(algorithms), tuple(steps))


def citations_in(text: str, path: Path = Path("<text>")) -> Iterator[Citation]:
    """Every citation of ``text``, in order; a mention of the tag outside a bracket on one line is refused."""
    for number, line in enumerate(text.splitlines(), 1):
        brackets = [m for m in _BRACKET.finditer(line) if _MENTION.search(m.group(1))]
        covered = {i for m in brackets for i in range(m.start(), m.end())}
        loose = [m.start() for m in _MENTION.finditer(line) if m.start() not in covered]
        if loose:
            raise SteamError(f"line {number} of {path}: {TAG} outside a bracket on one line: {line.strip()!r}")
        for bracket in brackets:
            citation = parse(bracket.group(), path, number)
            if citation is not None:
                yield citation


# --- where a citation sits in the code ---------------------------------------------------------------


@dataclass(frozen=True)
class Site:
    """A citation and the innermost definition holding it: the module, and the chain of classes and
    functions (empty for the module itself), each part with its kind ("class" or "def")."""

    citation: Citation
    module: str
    chain: tuple[tuple[str, str], ...]


def _definitions(tree: ast.AST) -> list[tuple[int, int, tuple[tuple[str, str], ...]]]:
    """(first line, last line, chain) of every class and function, decorators included."""
    found: list[tuple[int, int, tuple[tuple[str, str], ...]]] = []

    def visit(node: ast.AST, chain: tuple[tuple[str, str], ...]) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                inner = (*chain, (child.name, "class" if isinstance(child, ast.ClassDef) else "def"))
                first = min([child.lineno] + [d.lineno for d in child.decorator_list])
                found.append((first, child.end_lineno or child.lineno, inner))
                visit(child, inner)
            else:
                visit(child, chain)

    visit(tree, ())
    return found


def module_name(path: Path, package: Path) -> str:
    """``steam_ref/gp/prior.py`` → ``steam_ref.gp.prior`` (a package's ``__init__`` is the package)."""
    parts = path.relative_to(package.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def sites_in(package: Path) -> list[Site]:
    """Every citation in the ``.py`` files of ``package``, each with the definition holding it."""
    sites: list[Site] = []
    for path in sorted(package.rglob("*.py")):
        text = path.read_text()
        found = list(citations_in(text, path))
        if not found:
            continue
        definitions = _definitions(ast.parse(text, str(path)))
        for citation in found:
            holding = [d for d in definitions if d[0] <= citation.line <= d[1]]
            chain = max(holding, key=lambda d: len(d[2]))[2] if holding else ()
            sites.append(Site(citation, module_name(path, package), chain))
    return sites
