"""The kit on disk: JSON that any language reads, an .npz copy, sha256 sums, ``index.json``.

Floats are written as the shortest decimal that reads back to the same IEEE-754 double (Python's
``repr``: at most 17 significant digits, so ``%.17g`` would read back the same), which a C++
``strtod``, Rust's ``str::parse::<f64>`` or NumPy parse exactly. NaN and inf are refused. Arrays are
nested lists (row-major); their shapes are implied. The .npz copy holds every numeric array of the
expected values under ``<case>/<quantity>[/<sub-key>]``.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import stat
import zipfile
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..errors import DataError, NumericalError

__all__ = [
    "shown",
    "KIT_VERSION",
    "KITS",
    "SUITES",
    "DATA_FREE",
    "SHIPPED",
    "MAX_BYTES",
    "MAX_DEPTH",
    "MAX_VALUES",
    "kit_version",
    "case_type",
    "printable",
    "plain",
    "dumps",
    "read_json",
    "write_json",
    "write_npz",
    "sha256",
    "read_index",
    "read_suite",
    "kit_files",
]

KIT_VERSION = 5  # the version this steam_ref builds; older ones stay shipped and checkable (never edited)
# every kit inside the installed package: data (JSON and .npz), read by the one checker and runner
KITS = {v: Path(__file__).resolve().parent / f"v{v}" for v in range(1, KIT_VERSION + 1)}
SHIPPED = KITS[KIT_VERSION]
# every suite of any kit (v1, v2: all but fixed_lag, se2, se3; v3 all but se2, se3; v4 all but se3); 'paper' last: it is built from the data files.
# A new suite goes before 'paper'; check's default gate is every suite of a kit but 'paper'.
SUITES = ("gp", "factors", "linear", "batch", "bayes_tree", "incremental", "fixed_lag", "se2", "se3", "paper")
DATA_FREE = SUITES[:-1]  # the suites any port can run: check's default gate (the paper suite needs the data files)
MAX_BYTES = 64 * 2**20  # a kit or results file larger than this is refused, not read (the kit's largest is ~1 MB)
MAX_DEPTH = 64  # JSON nesting deeper than this is refused (the kit's deepest is 8)
MAX_VALUES = (
    200_000  # JSON values a file may hold (the kit's largest holds ~20,000, 10x fewer): bounds the parse's memory
)
NAME_WIDTH = 200  # characters of a name from a file shown at most (the kit's longest case name has 41)
MAX_DIGITS = 18  # an integer literal longer than this is refused (the kit's integers are counts and ids)


def printable(text: object) -> str:
    """``text`` with control characters and escapes written as ``\\xNN``: a name from a file cannot forge output."""
    return "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii") for c in str(text))


def shown(name: object) -> str:
    """A name read from a file (a case, a quantity, a key) as a report or an error shows it: :func:`printable`, and
    cut to :data:`NAME_WIDTH` characters, so a file under the caps cannot fill a report line with megabytes."""
    text = printable(name)
    return text if len(text) <= NAME_WIDTH else text[: NAME_WIDTH - 3] + "..."


def plain(value):
    """``value`` with NumPy arrays and scalars turned into lists, floats, ints and bools; NaN/inf refused."""
    if isinstance(value, Mapping):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, np.ndarray):
        return plain(value.tolist())
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        x = float(value)
        if not math.isfinite(x):
            raise NumericalError(f"the kit holds finite numbers only, got {x}")
        return x
    if value is None or isinstance(value, str):
        return value
    raise DataError(f"cannot write a {type(value).__name__} to the kit")


def _is_row(v) -> bool:
    return isinstance(v, list) and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)


def _number(x) -> str:
    return repr(x) if isinstance(x, float) else json.dumps(x)


def _dump(v, indent: int) -> str:
    pad, inner = " " * indent, " " * (indent + 1)
    if isinstance(v, dict):
        if not v:
            return "{}"
        items = [f"{inner}{json.dumps(k, ensure_ascii=False)}: {_dump(x, indent + 1)}" for k, x in v.items()]
        return "{\n" + ",\n".join(items) + "\n" + pad + "}"
    if _is_row(v) or (isinstance(v, list) and all(isinstance(x, str) or x is None for x in v)):
        return (
            "["
            + ", ".join(_number(x) if isinstance(x, (int, float)) else json.dumps(x, ensure_ascii=False) for x in v)
            + "]"
        )
    if isinstance(v, list):
        return "[\n" + ",\n".join(inner + _dump(x, indent + 1) for x in v) + "\n" + pad + "]"
    if isinstance(v, float):
        return repr(v)
    return json.dumps(v, ensure_ascii=False)


def dumps(value) -> str:
    """Kit JSON: indented objects, one matrix row per line, floats that round-trip exactly."""
    return _dump(plain(value), 0) + "\n"


def write_json(path: Path, value) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(dumps(value), encoding="utf-8")


def _no_duplicates(pairs: list) -> dict:
    out: dict = {}
    for k, v in pairs:
        if k in out:
            raise DataError(f"the key '{shown(k)}' appears twice in one object")
        out[k] = v
    return out


def _integer(text: str) -> int:
    if len(text.lstrip("-")) > MAX_DIGITS:
        raise DataError(f"an integer literal of {len(text.lstrip('-'))} digits (at most {MAX_DIGITS})")
    return int(text)


def _float(text: str) -> float:
    x = float(text)
    if not math.isfinite(x):
        raise DataError(f"the number {printable(text[:40])} is out of the range of a double")
    return x


class _NonFinite(DataError):
    """NaN, Infinity or -Infinity where a JSON number belongs (located afterwards: :func:`_locate`)."""


def _constant(text: str):
    raise _NonFinite(f"{text} is not a JSON number (the kit holds finite numbers only)")


class _Marker:
    """What a NaN or Infinity parses to while :func:`_locate` looks for it."""


def _locate(text: str) -> str:
    """Where the first NaN/Infinity of a JSON text sits: 'case 'name', quantity 'q' at [i][j]' in a results or
    suite file, else the path of keys and indices."""
    value = json.loads(text, parse_constant=lambda _t: _Marker())
    stack: list = [(value, ())]
    while stack:
        v, path = stack.pop(0)
        if isinstance(v, _Marker):
            break
        if isinstance(v, dict):
            stack.extend((x, (*path, k)) for k, x in v.items())
        elif isinstance(v, list):
            stack.extend((x, (*path, i)) for i, x in enumerate(v))
    else:
        return "somewhere"
    if len(path) >= 3 and path[0] == "cases" and isinstance(path[1], str):  # a results file: cases -> name -> q
        rest = "".join(f"[{i}]" if isinstance(i, int) else f"/{i}" for i in path[3:])
        return f"case '{shown(path[1])}', quantity '{shown(path[2])}'{shown(rest)}"
    return "at " + shown("".join(f"[{i}]" if isinstance(i, int) else f"/{i}" for i in path))


def _depth(value) -> int:
    """Deepest nesting of lists and objects, without recursion."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        v, d = stack.pop()
        if isinstance(v, (list, dict)):
            if d > MAX_DEPTH:
                return d
            deepest = max(deepest, d)
            stack.extend((x, d + 1) for x in (v.values() if isinstance(v, dict) else v))
    return deepest


def _regular_file(path: Path) -> int:
    """The size of ``path``; DataError unless it is a regular file (or a link to one)."""
    try:
        info = os.stat(path)
    except FileNotFoundError:
        if os.path.lexists(path):
            raise DataError(f"{printable(path)}: a symbolic link to nothing") from None
        raise DataError(f"{printable(path)}: no such file") from None
    except OSError as err:  # a link loop (ELOOP), a name too long, no permission
        raise DataError(f"{printable(path)}: cannot be opened ({printable(err.strerror)})") from None
    if stat.S_ISDIR(info.st_mode):
        raise DataError(f"{printable(path)}: a folder, not a file")
    if not stat.S_ISREG(info.st_mode):
        raise DataError(f"{printable(path)}: not a regular file (a pipe, socket or device is not read)")
    return info.st_size


def read_json(path: Path, max_bytes: int | None = None):
    """A kit or results JSON file; DataError naming the file and the problem when it is anything else.

    Refused: a missing file, a folder, a dangling link or a link loop, anything but a regular file,
    a file over ``max_bytes`` or holding over :data:`MAX_VALUES` values (so the memory a file can take is
    bounded: its bytes, twice, and the values), malformed JSON, NaN/Infinity, numbers beyond a double, integer
    literals over 18 digits, a key given twice in one object, nesting deeper than 64.
    """
    path = Path(path)
    max_bytes = MAX_BYTES if max_bytes is None else max_bytes
    size = _regular_file(path)
    if size > max_bytes:
        raise DataError(f"{printable(path)}: {size} bytes, more than the {max_bytes} a kit or results file may have")
    try:
        with open(path, "rb") as f:
            raw = f.read(max_bytes + 1)
    except OSError as err:
        raise DataError(f"{printable(path)}: not readable ({printable(err.strerror or err)})") from None
    if len(raw) > max_bytes:
        raise DataError(f"{printable(path)}: more than the {max_bytes} bytes a kit or results file may have")
    # Every JSON value but the first follows a '[', ',' or ':', so this bounds their number from above (a
    # string holding those characters only raises it): parsed, each costs ~30-100 bytes, 30x its text.
    values = raw.count(b"[") + raw.count(b",") + raw.count(b":") + 1
    if values > MAX_VALUES:
        raise DataError(
            f"{printable(path)}: about {values:,} JSON values, more than the {MAX_VALUES:,} a kit or results "
            "file may hold"
        )
    try:  # the hooks' DataErrors name no file: the path is put before them here, once
        value = json.loads(
            raw.decode("utf-8"),
            object_pairs_hook=_no_duplicates,
            parse_int=_integer,
            parse_float=_float,
            parse_constant=_constant,
        )
    except _NonFinite as err:
        try:
            where = _locate(raw.decode("utf-8"))
        except (ValueError, RecursionError):
            where = "somewhere"
        raise DataError(f"{printable(path)}: {err}, in {where}") from None
    except DataError as err:
        raise DataError(f"{printable(path)}: {err}") from None
    except RecursionError:
        raise DataError(f"{printable(path)}: JSON nested too deeply (at most {MAX_DEPTH} levels)") from None
    except (OSError, UnicodeDecodeError, ValueError) as err:  # JSONDecodeError is a ValueError
        raise DataError(f"{printable(path)}: not readable as JSON ({printable(err)})") from None
    if _depth(value) > MAX_DEPTH:
        raise DataError(f"{printable(path)}: JSON nested too deeply (at most {MAX_DEPTH} levels)")
    return value


def _arrays(prefix: str, value, out: dict) -> None:
    if isinstance(value, Mapping):
        for k, v in value.items():
            _arrays(f"{prefix}/{k}", v, out)
        return
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return  # names and structure: JSON only
    out[prefix] = a


def write_npz(path: Path, cases: list[dict]) -> None:
    """The expected values' numeric arrays as an .npz (byte-for-byte reproducible: fixed zip dates)."""
    arrays: dict = {}
    for case in cases:
        for q, v in case["expected"].items():
            _arrays(f"{case['name']}/{q}", v, arrays)
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as z:
        for name in sorted(arrays):
            buf = io.BytesIO()
            np.lib.format.write_array(buf, np.ascontiguousarray(arrays[name]), allow_pickle=False)
            info = zipfile.ZipInfo(name + ".npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            z.writestr(info, buf.getvalue())


def sha256(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def kit_version(value: object) -> int | None:
    """The shipped kit ``value`` names, or None: an int, or a float with an integral value (JSON has one number
    type, and a writer may print 3 as 3.0), that is a key of :data:`KITS`. A bool, a string, a list or an object
    names none (a lookup in :data:`KITS` would match ``True`` as 1, or refuse a list with a TypeError)."""
    if type(value) is float and value.is_integer():
        value = int(value)
    return value if type(value) is int and value in KITS else None


def case_type(suite: str, inputs: Mapping) -> str:
    """What a case computes: the key of the runner's and the oracle's tables (``runner.RUNNERS``,
    ``expected.ORACLES``). It is the case's suite, and the ``kind`` its inputs name where a suite's cases compute
    different things: ``gp/wnoa``, ``se2/exp``, ``se2/batch`` (Gauss-Newton as the batch suite's, on SE(2)
    states); ``batch``."""
    kind = inputs.get("kind")
    return suite if kind is None else f"{suite}/{kind}"


def kit_files(kit: Path) -> list[str]:
    """Every file of a kit folder but index.json, as sorted relative POSIX paths."""
    kit = Path(kit)
    return sorted(p.relative_to(kit).as_posix() for p in kit.rglob("*") if p.is_file() and p.name != "index.json")


def read_index(kit: Path) -> dict:
    """A kit's index.json, after checking its form, its version and every file's sha256."""
    kit = Path(kit)
    where = printable(kit / "index.json")
    index = read_json(kit / "index.json")
    if not isinstance(index, Mapping):
        raise DataError(f"{where}: expected a JSON object, got a {type(index).__name__}")
    version = kit_version(index.get("kit_version"))
    if version is None:
        raise DataError(
            f"{where}: kit version {printable(repr(index.get('kit_version')))}, this steam_ref reads versions "
            f"{', '.join(map(str, KITS))}"
        )
    files = index.get("files")
    if not isinstance(files, Mapping) or not files:
        raise DataError(f"{where}: no 'files' object of file name -> sha256, so the kit cannot be verified")
    for name, digest in files.items():
        if not isinstance(digest, str) or Path(name).is_absolute() or ".." in Path(name).parts:
            raise DataError(f"{where}: files/{printable(name)} is not a relative name with a sha256 string")
        if not (kit / name).is_file():
            raise DataError(f"{printable(kit)}: {printable(name)} is listed in index.json but missing")
        if sha256(kit / name) != digest:
            raise DataError(
                f"{printable(kit)}: {printable(name)} does not match its sha256 in index.json (edited or damaged)"
            )
    unlisted = [n for n in kit_files(kit) if n not in files and n != "README.md"]
    if unlisted:
        raise DataError(f"{printable(kit)}: {printable(unlisted[0])} is not listed in index.json")
    suites = index.get("suites")
    if not isinstance(suites, Mapping) or not suites or not set(suites) <= set(SUITES):
        raise DataError(f"{where}: 'suites' must be an object naming suites of {', '.join(SUITES)}")
    return {**index, "kit_version": version}


def read_suite(kit: Path, suite: str) -> dict:
    """A suite's cases.json (its form is checked by :func:`steam_ref.conformance.validate.kit_cases`)."""
    data = read_json(Path(kit) / suite / "cases.json")
    if not isinstance(data, Mapping) or not isinstance(data.get("cases"), list):
        raise DataError(f"{printable(Path(kit) / suite / 'cases.json')}: expected an object with a 'cases' list")
    return dict(data)
