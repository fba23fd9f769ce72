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
argument types they were called with, into one extension module in :func:`compiled_dir`. When that folder holds
a table, kernels are :class:`Kernel` proxies. At the first kernel call the process loads the module if it was
built from these very sources (a digest of the package's Python files, NumPy's version and the CPU); a call then
looks its arguments' types up in the module's table and runs the compiled function, and a process that calls only
compiled signatures never imports numba. A call with types the module lacks, or any call when the module does
not match, runs the kernel's numba dispatcher (numba imported then): the same code, from numba's cache or
compiled. Without a table (or with ``SNAKEPLAN_KERNELS=numba``) the decorators return numba's dispatchers. Each
side keeps its own random stream (``np.random`` inside kernels); see ``kernel(seeds=True)``.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import os
import pickle
import re
import sys
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from snakeplan.files import ENV_CACHE_DIR, cache_root

#: Environment variable: ``numba`` ignores the compiled module; ``record`` makes every kernel a proxy that
#: records the argument types it is called with (``snakeplan compile``'s workload).
ENV_MODE = "SNAKEPLAN_KERNELS"
#: Environment variable: the cache folder (:func:`snakeplan.files.cache_root`).
ENV_DIR = ENV_CACHE_DIR
#: The table of the compiled module, beside it: which function runs which kernel for which argument types.
MANIFEST = "kernels.pkl"
#: NumPy's flag bits that decide numba's type of an array: C_CONTIGUOUS and F_CONTIGUOUS (its layout: C when
#: C-contiguous, else F when F-contiguous, else A), ALIGNED and WRITEABLE.
_C, _F, _ALIGNED_WRITEABLE = 0x1, 0x2, 0x100 | 0x400


def compiled_dir() -> Path:
    """The folder of the kernels compiled ahead of time."""
    return cache_root() / "kernels"


def mode() -> str:
    """``"numba"``, ``"record"``, or ``""`` (the compiled module where it matches, else numba)."""
    value = os.environ.get(ENV_MODE, "")
    if value not in ("", "numba", "record"):
        raise ValueError(f"{ENV_MODE}: expected 'numba' or 'record' (or unset), got {value!r}")
    return value


_MODE = mode()
#: Whether this process records the argument types of its kernels' calls (``snakeplan compile``'s workload).
RECORDING = _MODE == "record"
#: Whether the decorators make proxies: when recording, or when a compiled module may match (a table exists;
#: whether it matches these sources is checked at the first kernel call).
_PROXIES = RECORDING or (_MODE == "" and (compiled_dir() / MANIFEST).is_file())
#: Every proxy made in this process, in order.
KERNELS: list[Kernel] = []
#: The compiled module's table once loaded ({kernel name: its {argument key: function name}, pickled}; each
#: kernel unpickles its own at its first call, so that loading imports no module its keys name); None before, {}
#: when no module matches.
_compiled: dict[str, bytes] | None = None
_module = None


#: The last tuple argument and its key, as one pair: kernels are called again and again with the same packed
#: obstacle set (eleven arrays), whose key would otherwise be most of a call's overhead. Held, so its identity is
#: not reused; swapped whole, so that a thread never pairs one tuple with another's key.
_last_tuple: tuple = (None, None)
#: Python types whose values numba types by their type alone (a key of only these, arrays and tuples is exact).
_SCALARS = (bool, int, float, complex, np.bool_, np.integer, np.floating, np.complexfloating, type(None))


def _arg_key(a: Any) -> Any:
    global _last_tuple
    t = type(a)
    if t is np.ndarray:
        flags = a.flags.num
        return (a.dtype, a.ndim, flags & _C or flags & _F, flags & _ALIGNED_WRITEABLE)
    if t is tuple:
        last = _last_tuple
        if a is last[0]:
            return last[1]
        key = tuple([_arg_key(b) for b in a])
        _last_tuple = (a, key)
        return key
    if isinstance(a, tuple):  # a named tuple: numba types its class and each field
        return (t, tuple([_arg_key(b) for b in a]))
    if isinstance(a, np.ndarray):  # a subclass: its class, then as an array
        return (t, _arg_key(a.view(np.ndarray)))
    return t


def arg_key(args: tuple) -> tuple:
    """What decides numba's types of ``args``: each array's dtype, dimensions, layout (C, F or A, as numba
    reads it) and whether it is aligned and writeable; each tuple's elements (a named tuple's with its class); each
    other value's Python type."""
    return tuple([_arg_key(a) for a in args])


def _exact(key: Any) -> bool:
    """Whether ``key`` determines numba's types: arrays, tuples and scalars only (a list's or a dict's type
    depends on its contents, which the key does not hold)."""
    if isinstance(key, tuple):
        if key and isinstance(key[0], np.dtype):
            return True
        return all(_exact(k) for k in key)
    return isinstance(key, type) and (issubclass(key, _SCALARS) or issubclass(key, (tuple, np.ndarray)))


def name_of(fn: Callable) -> str:
    """A kernel's name in the compiled module's table: ``module.qualname``."""
    return f"{fn.__module__}.{fn.__qualname__}"


#: Guards loading the module and each proxy's first look at its table (planners may run in threads).
_LOCK = threading.Lock()
#: The last call of each kernel that seeds ``np.random`` (``kernel(seeds=True)``).
_SEED_CALLS: dict[Kernel, tuple] = {}
#: Whether a kernel has fallen back to numba while compiled kernels run: numba's random stream, apart from the
#: compiled module's, is then seeded too, by every seeding call.
_numba_side = False


class Kernel:
    """A kernel that runs its compiled function where one matches its arguments' types, else its numba
    dispatcher. numba sees it as that dispatcher (``py_func``, ``targetoptions``, ``_numba_type_``), so kernels
    call and inline each other through proxies as they would through dispatchers."""

    def __init__(self, fn: Callable, options: dict, seeds: bool = False) -> None:
        functools.update_wrapper(self, fn)
        self.py_func = fn
        self.options = options
        self.seeds = seeds
        #: What numba's inliner reads of a callee (``inline``).
        self.targetoptions = {k: v for k, v in options.items() if k != "cache"}
        #: Record mode: {argument key: numba argument types} of the calls from Python.
        self.calls: dict[tuple, tuple] = {}
        self._dispatcher = None
        self._table: dict[tuple, Callable] = {}
        self._resolved = False
        KERNELS.append(self)

    def __call__(self, *args):
        key = arg_key(args)
        fn = self._table.get(key)
        if fn is None:
            fn = self._missing(key, args)
        if self.seeds:
            self._seeded(args)
        return fn(*args)

    def _missing(self, key: tuple, args: tuple) -> Callable:
        """The function for ``key`` (compiled, else the dispatcher), kept in the table for the next call."""
        global _numba_side
        with _LOCK:
            if not self._resolved:
                if _compiled is None:
                    _load_compiled()
                raw = _compiled.get(name_of(self.py_func))
                try:
                    table = {} if raw is None else {k: getattr(_module, s) for k, s in pickle.loads(raw).items()}
                except Exception:  # a table this module does not match: numba for this kernel
                    table = {}
                self._table = table
                self._resolved = True
            fn = self._table.get(key)
            if fn is not None:
                return fn
            fn = self.dispatcher
            if RECORDING:
                if _exact(key):
                    self.calls[key] = tuple(fn.typeof_pyval(a) for a in args)
            elif _compiled and not _numba_side:
                _numba_side = True
                for k, seed_args in _SEED_CALLS.items():
                    k.dispatcher(*seed_args)
            self._table[key] = fn
            return fn

    def _seeded(self, args: tuple) -> None:
        """Remember a seeding call; seed numba's stream too once kernels run on both sides."""
        _SEED_CALLS[self] = args
        if _numba_side:
            self.dispatcher(*args)

    @property
    def dispatcher(self):
        """The numba dispatcher (numba is imported on first use). Recording compiles afresh, without numba's
        cache: its callees' cached code may predate an edit of their module, and the compiled module would keep
        it."""
        if self._dispatcher is None:
            options = {**self.options, "cache": False} if RECORDING else self.options
            self._dispatcher = njit(options)(self.py_func)
        return self._dispatcher

    @property
    def _numba_type_(self):
        """numba's type of this kernel as a value: its dispatcher's."""
        from numba.core import types

        return types.Dispatcher(self.dispatcher)

    def __repr__(self) -> str:
        return f"<kernel {name_of(self.py_func)}>"


def njit(options: dict) -> Callable:
    """numba's ``njit`` with ``options`` (numba imported now); ``_nrt`` dropped where this numba lacks it (``leaf``
    is then plain ``njit``: the same results, without the saving). A cached kernel compiles once per machine
    (:func:`_compile_once`)."""
    import numba
    from numba.core.cpu import CPUTargetOptions

    if not hasattr(CPUTargetOptions, "_nrt"):
        options = {k: v for k, v in options.items() if k != "_nrt"}
    decorate = numba.njit(**options)
    if not options.get("cache"):
        return decorate

    def cached(fn: Callable):
        dispatcher = decorate(fn)
        _DISPATCHERS.append(dispatcher)
        _compile_once(dispatcher, f"{fn.__module__}.{fn.__qualname__}")
        return dispatcher

    return cached


#: Every cached numba dispatcher made in this process (a proxy's on its first use).
_DISPATCHERS: list = []
#: The kernels whose compile lock this process holds (a kernel compiling itself for other types meanwhile
#: must not wait for itself).
_HELD: set[str] = set()


def _lock_folder() -> Path:
    """The folder of the machine's compile locks, one per numba cache (so that a test's own cache waits for no
    one else)."""
    key = hashlib.blake2b(os.environ.get("NUMBA_CACHE_DIR", "").encode(), digest_size=6).hexdigest()
    return compiled_dir().parent / "locks" / key


def _compile_once(dispatcher, name: str) -> None:
    """Make ``dispatcher`` compile under the machine's lock for ``name`` (flock on a file in the cache folder), so
    that each kernel compiles once per machine, not once in every process that needs it at the same time (the
    workers of a benchmark on a cold cache): a process that finds the lock held waits, then numba loads what the
    holder wrote to its cache instead of compiling it again. Different kernels compile at once in different
    processes; a kernel's callees take their own locks after it, so waits follow the call graph and never close
    a cycle. Unguarded without flock, or where the cache folder cannot be written."""
    try:
        import fcntl
    except ImportError:
        return
    compile_now = dispatcher.compile
    path = _lock_folder() / (re.sub(r"[^A-Za-z0-9_.-]", "_", name)[-100:] + ".lock")

    def compile(sig):
        if name in _HELD:
            return compile_now(sig)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            handle = open(path, "a")
        except OSError:  # no writable cache folder (a read-only home): compile unguarded, as numba alone does
            return compile_now(sig)
        with handle:
            fcntl.flock(handle, fcntl.LOCK_EX)
            _HELD.add(name)
            try:
                return compile_now(sig)  # numba's cache first: what a process compiled while this one waited
            finally:
                _HELD.discard(name)

    dispatcher.compile = compile


def _decorator(seeds: bool = False, **options: Any) -> Callable[[Callable], Callable]:
    options = {"cache": True, **options}

    def decorate(fn: Callable) -> Callable:
        return Kernel(fn, options, seeds) if _PROXIES else njit(options)(fn)

    return decorate


def compilations() -> int:
    """How many kernel signatures this process has compiled (not loaded from numba's cache or the compiled
    module): numba's count of cache misses, each a compilation."""
    return sum(sum(d.stats.cache_misses.values()) for d in _DISPATCHERS)


def kernel(fn: Callable | None = None, *, seeds: bool = False, **options: Any):
    """``njit(cache=True)``; ``@kernel(inline="always")`` passes numba options. ``seeds=True`` marks a kernel that
    seeds ``np.random``: compiled kernels and numba's each keep a random stream, and once a call falls back to
    numba while compiled kernels run, its stream is seeded with the last seeding call's arguments and by every
    later one, so that draws stay a function of the seed."""
    return _decorator(seeds, **options) if fn is None else _decorator(seeds)(fn)


def compiled_on_disk(fn: Callable) -> bool:
    """Whether a kernel's machine code is kept on disk: compiled ahead of time, or in numba's cache (its index file
    exists). One that is not compiles on its first call, which costs seconds to a minute."""
    if isinstance(fn, Kernel):
        return True
    index = getattr(getattr(getattr(fn, "_cache", None), "_cache_file", None), "_index_path", None)
    return index is None or os.path.exists(index)


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
    """Load the compiled module and its table if they match these sources (under :data:`_LOCK`)."""
    global _compiled, _module
    if RECORDING:
        _compiled = {}
        return
    folder = compiled_dir()
    try:
        manifest = pickle.loads((folder / MANIFEST).read_bytes())
        if manifest["digest"] != source_digest(manifest["files"]):
            _compiled = {}
            return
        spec = importlib.util.spec_from_file_location(manifest["module"], folder / manifest["filename"])
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        table = dict(manifest["table"])
    except Exception:  # no usable module (missing, half-written, another build's): numba compiles, as without one
        _compiled = {}
        return
    _module = module
    _compiled = table
