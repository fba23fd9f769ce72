"""Output files: checked before the work that fills them starts, and written atomically.

A command checks every output path it was given before it plans, judges or trains, so a mistyped ``--plot`` costs
nothing; a file appears whole or not at all (written next to its final name, then renamed over it), so an
interrupted command never leaves half a picture, table or weight file behind. Folders are created only where a
command's documentation says so (results folders such as ``bench --out``); an output file's folder must exist.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


def check_output(path: str | os.PathLike, field: str, suffixes: tuple[str, ...] = ()) -> Path:
    """``path`` as an output file the command may write: its folder exists and is writable, it is not a folder,
    and its suffix is one of ``suffixes`` (any when empty); ValueError naming ``field`` otherwise."""
    out = Path(path)
    if suffixes and out.suffix.lower() not in suffixes:
        raise ValueError(f"{field}: expected a {' or '.join(suffixes)} file, got {str(out)!r}")
    if out.is_dir():
        raise ValueError(f"{field}: {out} is a folder, not a file")
    folder = out.parent
    if not folder.is_dir():
        raise ValueError(f"{field}: folder {str(folder)!r} does not exist (create it first)")
    if not os.access(folder, os.W_OK):
        raise ValueError(f"{field}: folder {str(folder)!r} is not writable")
    return out


@contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """A temporary path beside ``path`` (same suffix, so writers that pick a format by suffix keep it) to write
    to; when the block ends normally it is fsync'ed and renamed over ``path`` (readers see the old file or the
    new one, never a part), otherwise removed."""
    out = Path(path)
    tmp = out.with_name(f".{out.stem}.{os.getpid()}.tmp{out.suffix}")
    try:
        yield tmp
        with open(tmp, "rb+") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, out)
    finally:
        tmp.unlink(missing_ok=True)


#: Environment variable: the cache folder (default ``$XDG_CACHE_HOME/snakeplan``, else ``~/.cache/snakeplan``).
ENV_CACHE_DIR = "SNAKEPLAN_CACHE_DIR"


def cache_root() -> Path:
    """The folder of snakeplan's caches (compiled kernels, what oracles computed): ``$SNAKEPLAN_CACHE_DIR``, else
    ``$XDG_CACHE_HOME/snakeplan``, else ``~/.cache/snakeplan``."""
    return Path(os.environ.get(ENV_CACHE_DIR) or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "snakeplan"))


def atomic_write(path: str | os.PathLike, data: str | bytes) -> Path:
    """Write ``data`` (text as UTF-8) to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data.encode() if isinstance(data, str) else data)
    return Path(path)
