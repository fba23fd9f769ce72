"""The compile decorators of snakeplan's kernels (``kernel``, ``leaf``, ``inlined``), and the kernels compiled
ahead of time.

``kernel`` is ``numba.njit(cache=True)``: compiled on its first call with each new set of argument types, and kept
in numba's cache for later processes.

``leaf``: numba counts references to every array a compiled function holds, with an atomic increment and
decrement each; in a function with loops and branches its pruning pass cannot pair them away, and a kernel that
only reads a dozen arrays then spends about 150 ns a call on them (measured: the candidate search of one link,
150 ns with counting, 12 ns without), more than its arithmetic. A kernel that allocates no array and keeps none
it is given needs no counting: the arrays belong to its caller for the whole call. ``leaf`` compiles such a kernel
without it (numba's ``_nrt`` target option, off). Only for such kernels: one that allocates, or returns or stores
an array, must use plain ``kernel``. Mark the functions a leaf kernel calls ``leaf`` too: numba compiles a callee
without counting only when it compiles it fresh for that caller, and reuses a version compiled or cached for
another, so a helper's own decorator is what guarantees it.

Ahead of time. A command that loads its kernels from numba's cache still imports numba and starts its compiler
(about 0.6 s on the 2-core machine, more than the plan it makes). ``snakeplan compile``
(:mod:`snakeplan.precompile`) therefore compiles every kernel the commands call from Python, once per set of
argument types they were called with, into one extension module in :func:`compiled_dir`. While that folder
holds a module built from these very sources (a digest of the package's Python files, NumPy's version and the
CPU), kernels are :class:`Kernel` proxies: a call looks its arguments' types up in the module's table and runs the
compiled function, and a process that calls only compiled signatures never imports numba. A call with types the
module lacks runs the kernel's numba dispatcher (numba imported then): the same code, from numba's cache or
compiled. Without the module (or with ``SNAKEPLAN_KERNELS=numba``) the decorators return numba's dispatchers.
Each side keeps its own random stream (``np.random`` inside kernels), seeded by the kernels of that side.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import os
import pickle
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

#: Environment variable: ``numba`` ignores the compiled module; ``record`` makes every kernel a proxy that
#: records the argument types it is called with (``snakeplan compile``'s workload).
ENV_MODE = "SNAKEPLAN_KERNELS"
#: Environment variable: the cache folder (default ``$XDG_CACHE_HOME/snakeplan``, else ``~/.cache/snakeplan``).
ENV_DIR = "SNAKEPLAN_CACHE_DIR"
#: The table of the compiled module, beside it: which function runs which kernel for which argument types.
MANIFEST = "kernels.pkl"
#: NumPy's flag bits that decide numba's type of an array: C_CONTIGUOUS and F_CONTIGUOUS (its layout: C when
#: C-contiguous, else F when F-contiguous, else A), ALIGNED and WRITEABLE.
_C, _F, _ALIGNED_WRITEABLE = 0x1, 0x2, 0x100 | 0x400


def compiled_dir() -> Path:
    """The folder of the kernels compiled ahead of time."""
    root = os.environ.get(ENV_DIR) or os.path.join(
        os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"), "snakeplan")
    return Path(root) / "kernels"


def mode() -> str:
    """``"numba"``, ``"record"``, or ``""`` (the compiled module where it matches, else numba)."""
    value = os.environ.get(ENV_MODE, "")
    if value not in ("", "numba", "record"):
        raise ValueError(f"{ENV_MODE}: expected 'numba' or 'record' (or unset), got {value!r}")
    return value


_MODE = mode()
#: Whether the decorators make proxies: when recording, or when a compiled module may match.
_PROXIES = _MODE == "record" or (_MODE == "" and (compiled_dir() / MANIFEST).is_file())
#: Every proxy made in this process, in order.
KERNELS: list[Kernel] = []
#: The compiled module's table once loaded ({kernel name: its {argument key: function name}, pickled}; each
#: kernel unpickles its own at its first call, so that loading imports no module its keys name); None before, {}
#: when no module matches.
_compiled: dict[str, bytes] | None = None
_module = None


#: The last tuple argument and its key: kernels are called again and again with the same packed obstacle set
#: (eleven arrays), whose key would otherwise be most of a call's overhead. Held, so its identity is not reused.
_last_tuple: list = [None, None]


def _arg_key(a: Any) -> Any:
    t = type(a)
    if t is np.ndarray:
        flags = a.flags.num
        return (a.dtype, a.ndim, flags & _C or flags & _F, flags & _ALIGNED_WRITEABLE)
    if t is tuple:
        if a is _last_tuple[0]:
            return _last_tuple[1]
        key = tuple([_arg_key(b) for b in a])
        _last_tuple[:] = a, key
        return key
    if isinstance(a, tuple):  # a named tuple: numba types its class and each field
        return (t, tuple([_arg_key(b) for b in a]))
    return t


def arg_key(args: tuple) -> tuple:
    """What decides numba's types of ``args``: each array's dtype, dimensions, layout (C, F or A, as numba
    reads it) and whether it is aligned and writeable; each tuple's elements (a named tuple's with its class); each
    other value's Python type."""
    return tuple([_arg_key(a) for a in args])


def name_of(fn: Callable) -> str:
    """A kernel's name in the compiled module's table: ``module.qualname``."""
    return f"{fn.__module__}.{fn.__qualname__}"


class Kernel:
    """A kernel that runs its compiled function where one matches its arguments' types, else its numba
    dispatcher. numba sees it as that dispatcher (``py_func``, ``targetoptions`` and a ``typeof`` entry), so
    kernels call and inline each other through proxies as they would through dispatchers."""

    def __init__(self, fn: Callable, options: dict) -> None:
        functools.update_wrapper(self, fn)
        self.py_func = fn
        self.options = options
        #: What numba's inliner reads of a callee (``inline``).
        self.targetoptions = {k: v for k, v in options.items() if k != "cache"}
        #: Record mode: {argument key: numba argument types} of the calls from Python.
        self.calls: dict[tuple, tuple] = {}
        self._dispatcher = None
        self._table: dict[tuple, Callable] = {}
        self._resolved = False
        KERNELS.append(self)

    def __call__(self, *args):
        fn = self._table.get(arg_key(args))
        if fn is None:
            fn = self._missing(args)
        return fn(*args)

    def _missing(self, args: tuple) -> Callable:
        if not self._resolved:
            self._resolved = True
            if _compiled is None:
                _load_compiled()
            raw = _compiled.get(name_of(self.py_func))
            if raw is not None:
                self._table = {key: getattr(_module, symbol) for key, symbol in pickle.loads(raw).items()}
                fn = self._table.get(arg_key(args))
                if fn is not None:
                    return fn
        dispatcher = self.dispatcher
        if _MODE == "record":
            self.calls.setdefault(arg_key(args), tuple(dispatcher.typeof_pyval(a) for a in args))
        return dispatcher

    @property
    def dispatcher(self):
        """The numba dispatcher (numba is imported on first use)."""
        if self._dispatcher is None:
            self._dispatcher = _njit(self.options)(self.py_func)
        return self._dispatcher

    def __repr__(self) -> str:
        return f"<kernel {name_of(self.py_func)}>"


@functools.cache
def _numba():
    """numba, imported, with proxies typed as their dispatchers."""
    import numba
    from numba.core import types
    from numba.core.typing.typeof import typeof_impl

    @typeof_impl.register(Kernel)
    def _typeof_kernel(val: Kernel, c) -> types.Dispatcher:
        return types.Dispatcher(val.dispatcher)

    return numba


def _njit(options: dict) -> Callable:
    numba = _numba()
    from numba.core.cpu import CPUTargetOptions

    if not hasattr(CPUTargetOptions, "_nrt"):  # a numba without the option: leaf is plain njit, same results
        options = {k: v for k, v in options.items() if k != "_nrt"}
    return numba.njit(**options)


def _decorator(**options: Any) -> Callable[[Callable], Callable]:
    options = {"cache": True, **options}

    def decorate(fn: Callable) -> Callable:
        return Kernel(fn, options) if _PROXIES else _njit(options)(fn)

    return decorate


def kernel(fn: Callable | None = None, **options: Any):
    """``njit(cache=True)``; ``@kernel(inline="always")`` passes numba options."""
    return _decorator(**options) if fn is None else _decorator()(fn)


#: ``njit(cache=True)`` without reference counting, for a kernel that allocates and keeps no array.
leaf = _decorator(_nrt=False)
#: A :func:`leaf` kernel that numba inlines into each caller, for the per-evaluation helpers that take the packed
#: obstacle set: a call that passes it (eleven arrays, passed field by field) costs more than the helper's
#: arithmetic (measured: crawl checks 21 % and range rays 11 % cheaper with the distance of one obstacle and the
#: least over candidates inlined; inlining the larger kernels too made both slower).
inlined = _decorator(inline="always", _nrt=False)


def _machine() -> str:
    """The CPU the compiled module is built for (its code uses this CPU's instructions)."""
    try:
        with open("/proc/cpuinfo") as f:
            lines = []
            for line in f:
                if not line.strip():
                    break
                if line.startswith(("vendor_id", "model name", "flags")):
                    lines.append(line)
            return "".join(lines)
    except OSError:
        import platform

        return f"{platform.machine()} {platform.processor()}"


def source_digest(files: list[str]) -> str:
    """What a compiled module must have been built from: the package's Python files and ``files`` (kernels
    defined outside it), Python's and NumPy's versions and the CPU."""
    h = hashlib.blake2b(digest_size=16)
    h.update(f"{sys.version}\n{np.__version__}\n{_machine()}".encode())
    package = Path(__file__).parent
    for path in sorted(package.rglob("*.py")) + [Path(f) for f in files]:
        h.update(str(path.relative_to(package) if path.is_relative_to(package) else path).encode())
        try:
            h.update(path.read_bytes())
        except OSError:
            h.update(b"missing")
    return h.hexdigest()


def compiled_in_use() -> bool:
    """Whether this process loaded a compiled module (it loads one, if any matches, at its first kernel call)."""
    return bool(_compiled)


def _load_compiled() -> None:
    """Load the compiled module and its table if they match these sources."""
    global _compiled, _module
    _compiled = {}
    if _MODE == "record":
        return
    folder = compiled_dir()
    try:
        manifest = pickle.loads((folder / MANIFEST).read_bytes())
        if manifest["digest"] != source_digest(manifest["files"]):
            return
        spec = importlib.util.spec_from_file_location(manifest["module"], folder / manifest["filename"])
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
    except (OSError, ImportError, EOFError, KeyError, TypeError, AttributeError, pickle.UnpicklingError):
        return  # no usable module: numba compiles, as without one
    _compiled, _module = manifest["table"], module
