"""Reading a MATLAB v5 .mat file safely: its structure is walked before scipy reads it.

``scipy.io.loadmat`` trusts the file's element tags: a data-type code corrupted to a value no MAT
file uses (one flipped byte, e.g. miDOUBLE 9 read as 0xf509) makes scipy 1.17 index past a table in
compiled code and the process dies with a bus error or a segmentation fault, so no Python exception
is left to report. :func:`read_mat` therefore walks the file's data elements first (the 128-byte
header, then every tag: a known data-type code, a size that fits inside its parent, miMATRIX
elements recursively, miCOMPRESSED ones decompressed, which also checks their zlib checksum) and
raises :class:`DataError` naming the file and the byte offset at the first that is wrong. Only then
does scipy read the bytes. What a file may hold is bounded (a decompression bomb: 791 KB inflating to
1.6 GB): at most :data:`MAX_BYTES` (256 MiB; ``$STEAM_REF_MAX_MAT_MB`` or ``max_bytes`` sets another)
on disk plus inflated, and a compressed variable is refused on its declared size before it is inflated,
and never inflated past it. The walk checks the container, not the numbers in it: a corrupted byte
inside an uncompressed number still reads as some other number (the data set's own checks and the
files' compressed form, whose checksum covers the numbers, are what catch those).
"""

from __future__ import annotations

import io
import itertools
import math
import os
import struct
import zlib
from pathlib import Path

import scipy.io
from numpy.typing import NDArray

from ..errors import DataError

__all__ = ["read_mat", "check_mat_structure", "max_mat_bytes", "MAX_BYTES", "MAX_BYTES_ENV"]

_HEADER = 128
MAX_BYTES = 256 * 2**20  # a .mat file may hold at most this once inflated (the paper's files: under 2 MiB)
MAX_BYTES_ENV = "STEAM_REF_MAX_MAT_MB"  # environment variable: another limit, in MiB
_MATRIX, _COMPRESSED = 14, 15
# The MAT v5 data types: miINT8 .. miDOUBLE (1-7, 9), miINT64, miUINT64, miMATRIX, miCOMPRESSED, miUTF8-32.
_TYPES = frozenset({1, 2, 3, 4, 5, 6, 7, 9, 12, 13, 14, 15, 16, 17, 18})
_MAX_DEPTH = 32  # nested cells/structs deeper than this are refused
_INT8, _INT32, _UINT32 = 1, 5, 6
_ITEM = {1: 1, 2: 1, 3: 2, 4: 2, 5: 4, 6: 4, 7: 4, 9: 8, 12: 8, 13: 8}  # bytes per number of each numeric type
_NUMBERS = frozenset(_ITEM)
_CELL, _STRUCT, _OBJECT, _CHAR, _SPARSE = 1, 2, 3, 4, 5
_CLASSES = frozenset(range(1, 18))  # mxCELL_CLASS (1) .. mxOPAQUE_CLASS (17)
_NUMERIC_CLASSES = frozenset(range(6, 16))  # mxDOUBLE_CLASS .. mxUINT64_CLASS


def _walk(
    buf: bytes, start: int, end: int, order: str, depth: int, where: str, budget: list[int]
) -> list[tuple[int, int, int]]:
    """Check every data element in ``buf[start:end]``; DataError at the first bad one.

    Returns the elements as (data type, offset of the data, size of the data)."""
    if depth > _MAX_DEPTH:
        raise DataError(f"{where}: elements nested more than {_MAX_DEPTH} deep at byte {start}")
    found, off = [], start
    while off < end:
        if end - off < 8:
            raise DataError(f"{where}: element tag cut short at byte {off} ({end - off} of 8 bytes)")
        first, second = struct.unpack_from(order + "II", buf, off)
        if first >> 16:  # small data element: size in the upper half, data in the tag's second word
            kind, size = first & 0xFFFF, first >> 16
            if size > 4:
                raise DataError(f"{where}: small data element at byte {off} claims {size} bytes (at most 4)")
            data, next_off = off + 4, off + 8
        else:
            kind, size, data = first, second, off + 8
            next_off = data + size + (0 if kind == _COMPRESSED else (-size) % 8)
        if kind not in _TYPES:
            raise DataError(f"{where}: unknown MAT data type {kind} at byte {off}: the file is corrupt")
        if data + size > end:
            raise DataError(f"{where}: element at byte {off} claims {size} bytes, only {end - data} follow")
        if kind == _MATRIX:
            _check_matrix(buf, data, data + size, order, depth + 1, where, budget)
        elif kind == _COMPRESSED:
            if depth:
                raise DataError(f"{where}: compressed element inside another element at byte {off}")
            _walk_compressed(buf[data : data + size], order, off, where, budget)
        found.append((kind, data, size))
        if next_off > end and depth:
            raise DataError(f"{where}: element at byte {off} and its padding run past the end of its parent")
        off = min(next_off, end)  # at the top level, the file's last padding may be left out
    return found


def _check_matrix(buf: bytes, start: int, end: int, order: str, depth: int, where: str, budget: list[int]) -> None:
    """An miMATRIX body: array flags (miUINT32 x 2) with a known class, dimensions (miINT32), a name
    (miINT8), then the parts its class and complex flag call for, as many numbers (or sub-arrays)
    as its dimensions say. scipy 1.17 reads past the element, and crashes, when a part is missing
    (the complex flag set on a real array, a sparse class on dense data), and allocates what the
    dimensions say before it reads (a cell array of 10⁹ entries from a flipped byte), so both are
    checked here."""
    parts = _walk(buf, start, end, order, depth, where, budget)
    if not parts:
        return  # an empty miMATRIX: an empty cell entry
    at = f"array at byte {start - 8}"
    if (
        len(parts) < 3
        or parts[0][0] != _UINT32
        or parts[0][2] != 8
        or parts[1][0] != _INT32
        or parts[1][2] % 4
        or parts[1][2] < 8
        or parts[2][0] != _INT8
    ):
        raise DataError(f"{where}: {at} lacks its flags, dimensions or name")
    flags = struct.unpack_from(order + "I", buf, parts[0][1])[0]
    cls, n_complex = flags & 0xFF, int(bool(flags & 0x800))
    dims = struct.unpack_from(f"{order}{parts[1][2] // 4}i", buf, parts[1][1])
    if cls not in _CLASSES or min(dims) < 0:
        raise DataError(f"{where}: {at} has class {cls} and dimensions {dims}: not a MATLAB array")
    n = math.prod(dims)
    data = parts[3:]
    kinds = [kind for kind, _, _ in data]
    if cls in _NUMERIC_CLASSES:
        ok = len(data) == 1 + n_complex and all(k in _NUMBERS and size == n * _ITEM[k] for k, _, size in data)
    elif cls == _SPARSE:
        ok = (
            len(data) == 3 + n_complex
            and kinds[:2] == [_INT32, _INT32]
            and len(dims) == 2
            and all(k in _NUMBERS and size % _ITEM[k] == 0 for k, _, size in data[2:])
            and _sparse_indices_fit(buf, order, dims, data)
        )
    elif cls == _CELL:
        ok = len(kinds) == n and all(k == _MATRIX for k in kinds)
    elif cls == _CHAR:
        ok = len(data) == 1 and data[0][2] >= n
    elif cls in (_STRUCT, _OBJECT):
        ok = _struct_fits(buf, order, n, data[1:] if cls == _OBJECT else data)
    else:  # function handles, opaque objects: only their sub-arrays were walked above
        ok = True
    if not ok:
        sizes = [size for _, _, size in data]
        raise DataError(
            f"{where}: {at} (class {cls}{', complex' if n_complex else ''}, dimensions {dims}) holds parts "
            f"of types {kinds} and sizes {sizes}: not what its class and dimensions call for"
        )


def _struct_fits(buf: bytes, order: str, n: int, data: list[tuple[int, int, int]]) -> bool:
    """A struct's parts: the field-name length (miINT32), the names (miINT8), n x fields sub-arrays."""
    if len(data) < 2 or data[0][0] != _INT32 or data[0][2] != 4 or data[1][0] != _INT8:
        return False
    width = struct.unpack_from(order + "i", buf, data[0][1])[0]
    if width <= 0 or data[1][2] % width:
        return False
    fields = data[1][2] // width
    kinds = [k for k, _, _ in data[2:]]
    return len(kinds) == n * fields and all(k == _MATRIX for k in kinds) and (fields > 0 or n <= len(buf))


def _sparse_indices_fit(buf: bytes, order: str, dims: tuple[int, ...], data: list[tuple[int, int, int]]) -> bool:
    """ir (row of each entry) and jc (first entry of each column) of a sparse array fit its shape and data."""
    (_, ir_at, ir_size), (_, jc_at, jc_size) = data[0], data[1]
    ir = struct.unpack_from(f"{order}{ir_size // 4}i", buf, ir_at)
    jc = struct.unpack_from(f"{order}{jc_size // 4}i", buf, jc_at)
    values = [size // _ITEM[kind] for kind, _, size in data[2:]]
    if len(jc) != dims[1] + 1 or jc[0] != 0 or any(b < a for a, b in itertools.pairwise(jc)):
        return False
    n = jc[-1]
    return n <= len(ir) and all(0 <= r < dims[0] for r in ir[:n]) and all(v >= n for v in values)


def _walk_compressed(data: bytes, order: str, at: int, where: str, budget: list[int]) -> None:
    """Inflate one compressed variable, never more than its declared size nor the bytes left of ``budget``."""
    limit = budget[0]
    try:
        inflater = zlib.decompressobj()
        head = inflater.decompress(data, 8)  # the inner element's tag: its declared size
        if len(head) == 8:
            declared = 8 + struct.unpack_from(order + "I", head, 4)[0]
            if declared > limit:
                raise DataError(
                    f"{where}: compressed element at byte {at} declares {declared:,} bytes once inflated, more than "
                    f"the {limit:,} bytes left of the limit on what a .mat file may inflate to ({_limit_note()})"
                )
            limit = declared
        inner = head + inflater.decompress(inflater.unconsumed_tail, max(1, limit + 1 - len(head)))
    except zlib.error as err:
        raise DataError(f"{where}: compressed element at byte {at} does not decompress ({err})") from None
    if len(inner) > limit:
        raise DataError(f"{where}: compressed element at byte {at} inflates to more than its declared {limit:,} bytes")
    if not inflater.eof:
        raise DataError(f"{where}: compressed element at byte {at} is cut short")
    budget[0] -= len(inner)
    _walk(inner, 0, len(inner), order, 1, f"{where} (compressed element at byte {at})", budget)


def _limit_note() -> str:
    return f"set ${MAX_BYTES_ENV} (MiB) or read_mat(max_bytes=...) to allow more"


def max_mat_bytes() -> int:
    """The limit on what a .mat file may hold once inflated: ${MAX_BYTES_ENV} MiB, else :data:`MAX_BYTES`."""
    text = os.environ.get(MAX_BYTES_ENV, "").strip()
    if not text:
        return MAX_BYTES
    try:
        mib = float(text)
    except ValueError:
        mib = math.nan
    if not (math.isfinite(mib) and mib > 0):
        raise DataError(f"${MAX_BYTES_ENV} must be a number of MiB > 0, got {text!r}")
    return int(mib * 2**20)


def check_mat_structure(raw: bytes, where: str, max_bytes: int | None = None) -> None:
    """DataError unless ``raw`` is a MATLAB v5 file whose element tags are all sound (see the module),
    and which holds at most ``max_bytes`` (default :func:`max_mat_bytes`) once its variables are inflated."""
    limit = max_mat_bytes() if max_bytes is None else max_bytes
    if len(raw) > limit:
        raise DataError(f"{where}: {len(raw):,} bytes, more than the limit of {limit:,} bytes ({_limit_note()})")
    if len(raw) < _HEADER:
        raise DataError(f"{where}: {len(raw)} bytes, shorter than a MATLAB v5 header ({_HEADER} bytes)")
    mark = raw[126:128]
    if mark not in (b"IM", b"MI"):
        raise DataError(f"{where}: not a MATLAB v5 .mat file (no endian mark 'IM' or 'MI' at byte 126)")
    order = "<" if mark == b"IM" else ">"
    version = struct.unpack_from(order + "H", raw, 124)[0]
    if version != 0x0100:
        hint = " (v7.3, HDF5: save it with -v7, which scipy reads)" if version == 0x0200 else ""
        raise DataError(f"{where}: MAT file version {version:#06x} at byte 124, not 0x0100 (v5){hint}")
    _walk(raw, _HEADER, len(raw), order, 0, where, [limit - len(raw)])


def read_mat(path: str | os.PathLike, max_bytes: int | None = None) -> dict[str, NDArray]:
    """The arrays of a MATLAB v5 file (names starting with ``__`` left out; a logical matrix as booleans, which
    scipy reads as uint8); DataError naming the file
    when it is missing, not a file, larger than ``max_bytes`` on disk or once inflated (default
    :func:`max_mat_bytes`), corrupt (:func:`check_mat_structure`) or unreadable by scipy."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: {'not a file' if path.exists() else 'no such file'}")
    limit = max_mat_bytes() if max_bytes is None else max_bytes
    try:
        size = path.stat().st_size
        if size > limit:
            raise DataError(f"{path}: {size:,} bytes, more than the limit of {limit:,} bytes ({_limit_note()})")
        raw = path.read_bytes()
    except OSError as err:
        raise DataError(f"{path}: cannot read it ({type(err).__name__}: {err})") from None
    check_mat_structure(raw, str(path), limit)
    try:
        content = scipy.io.loadmat(io.BytesIO(raw))
        logical = {name for name, _, cls in scipy.io.whosmat(io.BytesIO(raw)) if cls == "logical"}
    except Exception as err:  # scipy raises ValueError, OSError, TypeError, zlib errors, MemoryError...
        reason = f"{type(err).__name__}: {err}"
        raise DataError(f"{path}: cannot read it as a MATLAB .mat file ({reason})") from None
    for name in logical & content.keys():  # scipy reads a logical matrix as uint8: it is booleans, not numbers
        content[name] = content[name].astype(bool)
    return {k: v for k, v in content.items() if not k.startswith("__") and isinstance(k, str)}
