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
import zipfile
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ..errors import DataError, NumericalError

__all__ = [
    "KIT_VERSION",
    "SUITES",
    "SHIPPED",
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

KIT_VERSION = 1
SUITES = ("gp", "factors", "linear", "batch", "bayes_tree", "incremental", "paper")
SHIPPED = Path(__file__).resolve().parent / f"v{KIT_VERSION}"  # the kit inside the installed package


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


def read_json(path: Path):
    """A kit or results JSON file; DataError naming the file when it is missing or malformed."""
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise DataError(f"{path}: no such file") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise DataError(f"{path}: not readable as JSON ({err})") from None


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


def kit_files(kit: Path) -> list[str]:
    """Every file of a kit folder but index.json, as sorted relative POSIX paths."""
    kit = Path(kit)
    return sorted(p.relative_to(kit).as_posix() for p in kit.rglob("*") if p.is_file() and p.name != "index.json")


def read_index(kit: Path) -> dict:
    """A kit's index.json, after checking its version and every file's sha256."""
    kit = Path(kit)
    index = read_json(kit / "index.json")
    if index.get("kit_version") != KIT_VERSION:
        raise DataError(f"{kit}: kit version {index.get('kit_version')!r}, this steam_ref reads version {KIT_VERSION}")
    for name, digest in index.get("files", {}).items():
        if not (kit / name).is_file():
            raise DataError(f"{kit}: {name} is listed in index.json but missing")
        if sha256(kit / name) != digest:
            raise DataError(f"{kit}: {name} does not match its sha256 in index.json (edited or damaged)")
    return index


def read_suite(kit: Path, suite: str) -> dict:
    """A suite's cases.json."""
    return read_json(Path(kit) / suite / "cases.json")
