"""Reading weight files (``.npz``: a zip of ``.npy`` arrays) from anyone, without pickle and within bounds.

A learned planner's policy file may come from a colleague or a download, so its bytes are untrusted: they are
read with ``allow_pickle=False``, the file and its unpacked arrays are bounded in size, and any failure of the
zip or NumPy readers becomes one ``ValueError`` that starts with the caller's field name (``policy: ...``,
``agent_path: ...``). The library's own words are passed on only where they cannot mislead (NumPy's advice to
load a file "unsafely" is never shown). What the arrays must hold is the caller's to check.
"""

from __future__ import annotations

import io
import stat
import zipfile
import zlib
from pathlib import Path

import numpy as np

#: Largest weights file, and largest total of its unpacked arrays (bytes); the shipped ones are ~0.2-1 MB.
MAX_WEIGHTS_BYTES = 64 * 2**20
#: How a zip archive (an ``.npz``) starts: a local file header, or the end record of an empty archive.
ZIP_MAGIC = (b"PK\x03\x04", b"PK\x05\x06")
#: Library errors whose message describes the damage and may be shown.
_TELLING = (zipfile.BadZipFile, EOFError, zlib.error)


def read_weights_file(path: str | Path, field: str) -> bytes:
    """The bytes of the regular file ``path``; ValueError ``"<field>: ..."`` when it is missing, unreadable,
    not a regular file or larger than :data:`MAX_WEIGHTS_BYTES`."""
    p = Path(path)
    try:
        info = p.stat()
        if not stat.S_ISREG(info.st_mode):
            raise ValueError(f"{field}: {p} is not a regular file")
        if info.st_size > MAX_WEIGHTS_BYTES:
            raise ValueError(f"{field}: {p} has {info.st_size} bytes, more than a weights file may have "
                             f"({MAX_WEIGHTS_BYTES})")
        return p.read_bytes()
    except FileNotFoundError:
        raise ValueError(f"{field}: no such file {p}") from None
    except OSError as exc:
        raise ValueError(f"{field}: cannot read {p}: {exc.strerror or type(exc).__name__}") from None


def _why(exc: Exception) -> str:
    return f"{type(exc).__name__}: {exc}" if isinstance(exc, _TELLING) else type(exc).__name__


def read_npz(data: bytes, field: str) -> dict[str, np.ndarray]:
    """Every array of the ``.npz`` archive ``data`` by name, read without pickle; ValueError ``"<field>: ..."``
    for anything that is not such an archive of plain ``.npy`` arrays within :data:`MAX_WEIGHTS_BYTES`."""
    if len(data) > MAX_WEIGHTS_BYTES:
        raise ValueError(f"{field}: {len(data)} bytes, more than a weights file may have ({MAX_WEIGHTS_BYTES})")
    if not data.startswith(ZIP_MAGIC):
        raise ValueError(f"{field}: not an .npz archive (expected a zip of .npy arrays, as training writes)")
    try:
        archive = np.load(io.BytesIO(data), allow_pickle=False)
        unpacked = sum(info.file_size for info in archive.zip.infolist())
    except Exception as exc:  # noqa: BLE001 - any failure of the zip reader on foreign bytes is the file's
        raise ValueError(f"{field}: damaged .npz archive ({_why(exc)})") from None
    arrays: dict[str, np.ndarray] = {}
    with archive:
        if unpacked > MAX_WEIGHTS_BYTES:
            raise ValueError(f"{field}: its arrays unpack to {unpacked} bytes, more than a weights file may hold "
                             f"({MAX_WEIGHTS_BYTES})")
        for name in archive.files:
            try:
                value = archive[name]
            except Exception as exc:  # noqa: BLE001 - damaged data, or an object (pickled) array, never loaded
                raise ValueError(f"{field}: array {name!r} is not a readable plain .npy array ({_why(exc)})"
                                 ) from None
            if not isinstance(value, np.ndarray):  # a member that is not .npy comes back as bytes
                raise ValueError(f"{field}: member {name!r} is not an .npy array")  # noqa: TRY004 - bad input
            arrays[name] = value
    return arrays
