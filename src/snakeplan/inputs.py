"""Strict checks of what users feed snakeplan: one function per concept (a number, a length, a 3-vector, a unit
vector, a rotation, points, names, plain JSON data) and the one JSON reader for input files.

Every check takes the field's JSON path (``obstacles[12].normal``) and raises a one-line ``ValueError`` that starts
with it, so the command line can print it as it is. Limits (stated here, documented in docs/ARCHITECTURE.md):

- numbers are real: ``int`` or ``float`` (or their NumPy kinds), never ``bool``, a string or null, and finite
  (NaN, Infinity, 1e400 or a 400-digit integer in a file is rejected by the field that holds it);
- coordinates and lengths lie within :data:`MAX_MM` in magnitude (so that sums and squares stay finite);
  positive lengths are at least :data:`MIN_LENGTH_MM`;
- a unit vector may have any finite non-zero length: it is scaled by a power of two before it is normalised,
  so [1e308, 0, 0] is [1, 0, 0]; zero is rejected;
- a rotation is orthonormal with determinant +1 to within :data:`ROTATION_TOL`;
- a name is 1 to :data:`MAX_NAME_CHARS` printable characters;
- an input file is at most :data:`MAX_INPUT_BYTES` long and nested at most :data:`MAX_DEPTH` levels deep.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Mapping
from typing import Any

import numpy as np

#: Largest input file (bytes) read from a path or standard input.
MAX_INPUT_BYTES = 64 * 2**20
#: Deepest nesting of JSON arrays and objects in an input file (a scene needs 5).
MAX_DEPTH = 64
#: Largest magnitude (mm) of a coordinate or a length: 1000 km.
MAX_MM = 1e9
#: Smallest positive length (mm): 1 nm.
MIN_LENGTH_MM = 1e-6
#: Largest entry of |R^T R - I| for a rotation matrix R.
ROTATION_TOL = 1e-6
#: Longest name (characters).
MAX_NAME_CHARS = 200
#: Longest integer literal (digits) read from JSON; a longer one cannot be a finite double.
_MAX_INT_DIGITS = 308

_REAL_TYPES = (int, float, np.integer, np.floating)
_UNIT_ULP = 4 * np.finfo(float).eps


def show(value: Any, limit: int = 60) -> str:
    """A short one-line rendering of ``value`` for an error message."""
    if isinstance(value, int) and not isinstance(value, bool) and value.bit_length() > 256:
        return f"an integer of about {int(value.bit_length() * math.log10(2)) + 1} digits"
    try:
        text = " ".join(repr(value).split())
    except ValueError:  # e.g. a list holding an integer too long for repr
        return f"a {type(value).__name__}"
    return text if len(text) <= limit else text[: limit - 3] + "..."


def point_text(p: Any) -> str:
    """A point or vector as a message shows it: ``[-300, 180, 100]`` (mm; six significant digits)."""
    return "[" + ", ".join(f"{float(v):g}" for v in p) + "]"


def real(value: Any, name: str, limit: float | None = None) -> float:
    """``value`` as a finite float; with ``limit``, also at most ``limit`` in magnitude."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, _REAL_TYPES):
        raise ValueError(f"{name}: expected a number, got {show(value)}")
    try:
        v = float(value)
    except OverflowError:
        raise ValueError(f"{name}: number out of range, got {show(value)}") from None
    if not math.isfinite(v):
        raise ValueError(f"{name}: expected a finite number, got {show(value)}")
    if limit is not None and abs(v) > limit:
        raise ValueError(f"{name}: must lie within +-{limit:g}, got {show(value)}")
    return v


def length(value: Any, name: str) -> float:
    """A positive length (mm) in [:data:`MIN_LENGTH_MM`, :data:`MAX_MM`]."""
    v = real(value, name, MAX_MM)
    if v < MIN_LENGTH_MM:
        raise ValueError(f"{name}: must be a positive length of at least {MIN_LENGTH_MM:g} mm, got {show(value)}")
    return v


def integer(value: Any, name: str, lo: int | None = None, hi: int | None = None) -> int:
    """``value`` as an int (not a bool, not a float) in ``[lo, hi]``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name}: expected an integer, got {show(value)}")
    v = int(value)
    if lo is not None and v < lo:
        raise ValueError(f"{name}: must be at least {lo}, got {show(v)}")
    if hi is not None and v > hi:
        raise ValueError(f"{name}: must be at most {hi}, got {show(v)}")
    return v


def text(value: Any, name: str, max_chars: int = MAX_NAME_CHARS) -> str:
    """A non-empty name of printable characters (no control characters, no lone surrogates)."""
    if not isinstance(value, str):
        raise ValueError(f"{name}: expected a string, got {show(value)}")
    if not value:
        raise ValueError(f"{name}: must not be empty")
    if len(value) > max_chars:
        raise ValueError(f"{name}: longer than {max_chars} characters ({len(value)})")
    bad = next((i for i, c in enumerate(value) if not c.isprintable()), None)
    if bad is not None:
        raise ValueError(f"{name}: character {bad} ({show(value[bad])}) is not printable text")
    return value


def mapping(value: Any, name: str, *, required: tuple[str, ...] = (), allowed: tuple[str, ...] | None = None,
            what: str = "an object") -> dict:
    """``value`` as a dict with string keys, every ``required`` key and, when ``allowed`` is given, no other."""
    if not isinstance(value, Mapping):
        raise ValueError(f"{name}: expected {what}, got {show(value)}")
    for key in value:
        if not isinstance(key, str):
            raise ValueError(f"{name}: keys must be strings, got {show(key)}")
    for key in required:
        if key not in value:
            raise ValueError(f"{member(name, key)}: missing")
    if allowed is not None:
        extra = [k for k in value if k not in allowed]
        if extra:
            raise ValueError(f"{member(name, extra[0])}: unknown field (known: {', '.join(allowed)})")
    return dict(value)


def member(name: str, key: str) -> str:
    """The JSON path of ``key`` in the object at ``name`` (``a.b``, or ``a["odd key"]``; ``b`` at the root ``""``)."""
    if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", key):
        return f"{name}.{key}" if name else key
    return f"{name}[{json.dumps(key)}]"


def items(value: Any, name: str, what: str = "a list") -> list:
    """``value`` as a list (a JSON array; a tuple or a 1-D NumPy array from Python)."""
    if isinstance(value, np.ndarray) and value.ndim >= 1:
        return list(value)
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"{name}: expected {what}, got {show(value)}")
    return list(value)


def _numeric_array(value: Any) -> np.ndarray | None:
    """``value`` when it is already a NumPy array of real numbers (the fast path for Python callers)."""
    if isinstance(value, np.ndarray) and value.dtype.kind in "iuf":
        return value.astype(float)
    return None


def _first_bad(arr: np.ndarray, name: str, limit: float) -> None:
    """Raise naming the first entry of ``arr`` that is not finite or exceeds ``limit`` in magnitude."""
    if arr.size == 0:
        return
    top = float(np.abs(arr).max())  # NaN when any entry is NaN
    if top <= limit and math.isfinite(top):  # one pass when all is well
        return
    bad = ~np.isfinite(arr) | (np.abs(arr) > limit)
    if np.any(bad):
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        where = name + "".join(f"[{i}]" for i in idx)
        real(float(arr[idx]), where, limit)


def vector(value: Any, name: str, n: int, limit: float = MAX_MM, shape: str = "[x, y, z]") -> np.ndarray:
    """``value`` as ``n`` finite numbers, each at most ``limit`` in magnitude."""
    arr = _numeric_array(value)
    if arr is not None:
        if arr.shape != (n,):
            raise ValueError(f"{name}: expected {shape}, got an array of shape {arr.shape}")
        _first_bad(arr, name, limit)
        return arr
    seq = items(value, name, shape)
    if len(seq) != n:
        raise ValueError(f"{name}: expected {shape}, got {show(value)}")
    return np.array([real(v, f"{name}[{i}]", limit) for i, v in enumerate(seq)], dtype=float)


def vec3(value: Any, name: str) -> np.ndarray:
    """A point or displacement [x, y, z] (mm)."""
    return vector(value, name, 3)


def unit(value: Any, name: str) -> np.ndarray:
    """A direction [dx, dy, dz] of any non-zero finite length, normalised without overflow: first scaled by the
    power of two nearest its largest component (exact), then divided by its norm. A vector whose norm is already 1
    to within 4 ulp is kept as it is, so that reading back a written unit vector gives the same bits."""
    v = vector(value, name, 3, limit=math.inf, shape="[dx, dy, dz]")
    top = float(np.max(np.abs(v)))
    if top == 0.0:
        raise ValueError(f"{name}: must be a non-zero vector")
    if 0.5 <= top <= 1.0 and abs(float(np.linalg.norm(v)) - 1.0) <= _UNIT_ULP:
        return v
    v = np.ldexp(v, -math.frexp(top)[1])
    return v / np.linalg.norm(v)


def rows(value: Any, name: str, width: int, *, min_rows: int = 0, max_rows: int | None = None,
         limit: float = MAX_MM, shape: str = "[x, y, z]") -> np.ndarray:
    """A list of ``width``-number rows (points, a matrix) as a float array ``(m, width)``."""
    arr = _numeric_array(value)
    if arr is not None:
        if arr.ndim != 2 or arr.shape[1] != width:
            raise ValueError(f"{name}: expected a list of {shape}, got an array of shape {arr.shape}")
        _first_bad(arr, name, limit)
        out = arr
    else:
        seq = items(value, name, f"a list of {shape}")
        _count(len(seq), name, min_rows, max_rows, shape)
        out = np.array([vector(r, f"{name}[{i}]", width, limit, shape) for i, r in enumerate(seq)],
                       dtype=float).reshape(-1, width)
    _count(len(out), name, min_rows, max_rows, shape)
    return np.ascontiguousarray(out)


def _count(n: int, name: str, lo: int, hi: int | None, shape: str) -> None:
    if lo == hi and n != lo:
        raise ValueError(f"{name}: expected {lo} entries {shape}, got {n}")
    if n < lo:
        raise ValueError(f"{name}: needs at least {lo} entries {shape}, got {n}")
    if hi is not None and n > hi:
        raise ValueError(f"{name}: more than {hi} entries ({n})")


def points(value: Any, name: str, min_count: int = 0) -> np.ndarray:
    """Points [[x, y, z], ...] (mm) as a float array ``(m, 3)``."""
    return rows(value, name, 3, min_rows=min_count)


def index_rows(value: Any, name: str, width: int, size: int, min_rows: int = 0) -> np.ndarray:
    """Rows of ``width`` integer indices into a list of ``size`` items, as an int64 array."""
    if isinstance(value, np.ndarray) and value.dtype.kind in "iu":
        arr = value.astype(np.int64)
        if arr.ndim != 2 or arr.shape[1] != width:
            raise ValueError(f"{name}: expected a list of {width} indices per row, got an array of shape "
                             f"{arr.shape}")
    else:
        seq = items(value, name, "a list of index rows")
        out = []
        for i, r in enumerate(seq):
            row = items(r, f"{name}[{i}]", f"{width} indices")
            if len(row) != width:
                raise ValueError(f"{name}[{i}]: expected {width} indices, got {show(r)}")
            out.append([integer(v, f"{name}[{i}][{j}]") for j, v in enumerate(row)])
        arr = np.array(out, dtype=np.int64).reshape(-1, width)
    if len(arr) < min_rows:
        raise ValueError(f"{name}: needs at least {min_rows} rows, got {len(arr)}")
    bad = np.argwhere((arr < 0) | (arr >= size))
    if bad.size:
        i, j = (int(k) for k in bad[0])
        raise ValueError(f"{name}[{i}][{j}]: index out of range [0, {size - 1}], got {arr[i, j]}")
    return arr


def rotation(value: Any, name: str) -> np.ndarray:
    """A 3x3 proper rotation matrix (rows), orthonormal with determinant +1 to within :data:`ROTATION_TOL`."""
    R = rows(value, name, 3, min_rows=3, max_rows=3, limit=math.inf, shape="[r0, r1, r2]")
    with np.errstate(over="ignore", invalid="ignore"):  # huge entries: err is inf, the matrix is refused
        err = float(np.max(np.abs(R.T @ R - np.eye(3))))
    if not err <= ROTATION_TOL:
        raise ValueError(f"{name}: not orthonormal (max |R^T R - I| = {err:.3g} > {ROTATION_TOL:g})")
    if np.linalg.det(R) < 0:
        raise ValueError(f"{name}: a reflection (determinant -1); a rotation has determinant +1")
    return R


def corners(lo: Any, hi: Any, name: str) -> tuple[np.ndarray, np.ndarray]:
    """An axis-aligned box ``name`` given by its ``min`` and ``max`` corners (mm), max > min on every axis."""
    a, b = vec3(lo, f"{name}.min"), vec3(hi, f"{name}.max")
    if np.any(b <= a):
        raise ValueError(f"{name}.max: must exceed {name}.min on every axis, got min {show(a.tolist())}, "
                         f"max {show(b.tolist())}")
    return a, b


def plain_json(value: Any, name: str, depth: int = 0) -> None:
    """Check that ``value`` is plain JSON data: objects with string keys, arrays, valid strings, finite numbers,
    booleans and null, nested at most :data:`MAX_DEPTH` deep."""
    if depth > MAX_DEPTH:
        raise ValueError(f"{name}: nested deeper than {MAX_DEPTH} levels")
    if value is None or isinstance(value, bool):
        return
    if isinstance(value, str):
        try:
            value.encode("utf-8")
        except UnicodeEncodeError as exc:
            raise ValueError(f"{name}: character {exc.start} is a lone surrogate, not text") from None
    elif isinstance(value, (int, float)):
        real(value, name)
    elif isinstance(value, Mapping):
        for key, v in mapping(value, name).items():
            plain_json(key, member(name, key), depth + 1)
            plain_json(v, member(name, key), depth + 1)
    elif isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            plain_json(v, f"{name}[{i}]", depth + 1)
    else:
        raise ValueError(f"{name}: expected JSON data, got {show(value)}")


# --- reading JSON files ---------------------------------------------------------------------------------------
class _OutOfRange(float):
    """A JSON number no finite double holds (NaN, Infinity, 1e400, a 400-digit integer), kept with its text so that
    the check of the field holding it can say what was written."""

    text: str

    def __new__(cls, text: str, value: float) -> _OutOfRange:
        obj = super().__new__(cls, value)
        obj.text = text if len(text) <= 24 else f"{text[:12]}...({len(text)} characters)"
        return obj

    def __repr__(self) -> str:
        return self.text


def _parse_constant(text: str) -> float:
    return _OutOfRange(text, float(text.replace("Infinity", "inf")))


def _parse_float(text: str) -> float:
    v = float(text)
    return v if math.isfinite(v) else _OutOfRange(text, v)


def _parse_int(text: str) -> int | float:
    if len(text.lstrip("-")) <= _MAX_INT_DIGITS:
        return int(text)
    return _OutOfRange(text, -math.inf if text.startswith("-") else math.inf)


_STRING = re.compile(r'"[^"\\]*(?:\\.[^"\\]*)*"', re.DOTALL)
_NOT_BRACKET = re.compile(r"[^\[\]{}]+")


def json_depth(text: str) -> int:
    """Deepest nesting of arrays and objects in JSON ``text`` (brackets inside strings do not count)."""
    brackets = _NOT_BRACKET.sub("", _STRING.sub("", text)).encode("ascii")
    b = np.frombuffer(brackets, dtype=np.uint8)
    step = np.where((b == ord("[")) | (b == ord("{")), 1, -1)
    return int(np.cumsum(step).max(initial=0))


def load_json(text: str, source: str) -> Any:
    """Parse JSON input ``text`` from ``source`` (an option or file name used in messages) within the limits.

    Numbers a double cannot hold (NaN, Infinity, 1e400, huge integers) are read as non-finite floats that remember
    their text; the check of the field that holds one rejects it by name.
    """
    if len(text) > MAX_INPUT_BYTES:
        raise ValueError(f"{source}: larger than the {MAX_INPUT_BYTES // 2**20} MiB limit")
    depth = json_depth(text)
    if depth > MAX_DEPTH:
        raise ValueError(f"{source}: JSON nested {depth} levels deep, more than the limit of {MAX_DEPTH}")
    try:
        return json.loads(text, parse_constant=_parse_constant, parse_float=_parse_float, parse_int=_parse_int)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{source}: malformed JSON at line {exc.lineno} column {exc.colno}: {exc.msg}") from None
