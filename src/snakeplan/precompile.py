"""``snakeplan compile``: compile the kernels the commands call ahead of time, so that commands start without numba.

The workload is the commands themselves: ``snakeplan plan`` on seed 1 of each scene family with its default planner
(also with sensed knowledge where its planner takes it), and each registered planner on fuel-tank, run in this
process with every kernel a recording proxy (``SNAKEPLAN_KERNELS=record``, :mod:`snakeplan.jit`). Each kernel called
from Python is then compiled, once per set of argument types it was called with, into one extension module (numba's
ahead-of-time compiler, ``numba.pycc``, for this CPU; a C compiler is needed), written with its table into
:func:`snakeplan.jit.compiled_dir`. Kernels called only by other kernels are compiled into their callers. A later
process whose sources match loads it (:mod:`snakeplan.jit`); an edit to any of snakeplan's Python files retires it
until the next compile.

``snakeplan compile [--scene NAME ...]`` records in a fresh interpreter (``python -m snakeplan.cli compile`` with
``SNAKEPLAN_KERNELS=record``), since the recording must start before any kernel is defined; there the command hands
:func:`main` its entry point to run the workload through, so this module imports no other command-line module.
``snakeplan compile --remove`` deletes the module.
The recording compiles each kernel afresh (numba's cache may hold a callee's code from before an edit of its
module), and the sources must not change until the module is written.
"""

from __future__ import annotations

import contextlib
import copy
import io
import os
import pickle
import shutil
import subprocess
import sys
import tempfile
import time
import uuid
import warnings
from collections.abc import Callable, Iterator

from snakeplan import jit
from snakeplan.files import atomic_write
from snakeplan.interrupt import EXIT_INTERRUPTED

#: The planner seed and scene seed of the workload's plans.
WORKLOAD_SEED = 1


def workload(scenes: list[str] | None = None) -> list[list[str]]:
    """The commands whose kernels are compiled: each scene family's default plan (also with sensed knowledge where
    its planner takes it; of the scanned families, fuel-tank-scan's alone) and, where fuel-tank is among ``scenes``
    (default: all families), every registered planner that reaches, on it, and as-rrt and sac-her through the depth
    camera."""
    from snakeplan.planners import planner_names
    from snakeplan.planners.registry import PLANNERS
    from snakeplan.scenes import scene_names, scene_spec

    names = scene_names() if scenes is None else scenes
    commands = []
    for name in names:
        if scene_spec(name).made_from and name != "fuel-tank-scan":
            continue  # a scan's kernels are its family's and a cloud's: one scanned family records them all
        spec = scene_spec(name)
        plan = ["plan", "--scene", name, "--seed", str(WORKLOAD_SEED)]
        sensed = spec.task == "reach" and not PLANNERS.get(spec.planner).needs_full_scene
        commands += [plan, plan + ["--knowledge", "sensed"]] if sensed else [plan]
    if "fuel-tank" in names:
        commands += [["plan", "--scene", "fuel-tank", "--seed", str(WORKLOAD_SEED), "--planner", planner]
                     for planner in planner_names("reach")]
        commands += [["plan", "--scene", "fuel-tank", "--seed", str(WORKLOAD_SEED), "--planner", planner,
                      "--knowledge", "sensed", "--sensor", "depth"] for planner in ("as-rrt", "sac-her")]
    return commands


def record(commands: list[list[str]], run: Callable[[list[str]], int]) -> tuple[list[jit.Kernel], list[str]]:
    """Run ``commands`` through ``run`` (the command line's entry point; their output discarded); the kernels they
    called from Python, and a line for each command that failed (exit status other than 0, or 1 for an infeasible
    plan)."""
    if not jit.RECORDING:
        raise RuntimeError(f"recording needs {jit.ENV_MODE}=record before snakeplan's kernels are defined")
    failed = []
    for argv in commands:
        sink = io.StringIO()
        with contextlib.redirect_stdout(sink), contextlib.redirect_stderr(sink):
            status = run(argv)
        if status == EXIT_INTERRUPTED:
            raise KeyboardInterrupt
        if status not in (0, 1):
            last = sink.getvalue().strip().splitlines()
            failed.append(f"'snakeplan {' '.join(argv)}' exited {status}: {last[-1] if last else ''}")
    return [k for k in jit.KERNELS if k.calls], failed


@contextlib.contextmanager
def _fresh_flags() -> Iterator[None]:
    """numba's ahead-of-time compiler passes one flags object to every function it compiles, and compiling one
    can change it for the next (a literal integer then fails to unify with int64); give each its own copy."""
    from numba.pycc import compiler

    original = compiler.compile_extra

    def compile_extra(typingctx, targetctx, func, args, return_type, flags, **kwargs):
        return original(typingctx, targetctx, func, args, return_type, copy.deepcopy(flags), **kwargs)

    compiler.compile_extra = compile_extra
    try:
        yield
    finally:
        compiler.compile_extra = original


def build(kernels: list[jit.Kernel], folder=None, recorded_from: str | None = None) -> dict:
    """Compile ``kernels`` for the argument types they were called with into one module in ``folder`` (default
    :func:`snakeplan.jit.compiled_dir`) with its table, replacing any module there. ``recorded_from``: the
    package's digest when the recording began; the sources must not change from then until the module is written.
    Returns a summary."""
    from numba.pycc import CC

    names = [jit.name_of(k.py_func) for k in kernels]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise RuntimeError(f"two kernels named {twice[0]}: the table tells kernels apart by module and name")
    folder = jit.compiled_dir() if folder is None else folder
    files = sorted({os.path.abspath(sys.modules[k.py_func.__module__].__file__) for k in kernels})
    package = os.path.dirname(os.path.abspath(jit.__file__))
    outside = [f for f in files if not f.startswith(package + os.sep)]
    digest = jit.source_digest(outside)
    # a name of its own per build, so that a table only ever names the module built with it
    module = f"snakeplan_kernels_{digest[:12]}_{uuid.uuid4().hex[:8]}"
    cc = CC(module)
    cc.target_cpu = "host"
    cc.verbose = False
    table: dict[str, dict[tuple, str]] = {}
    signatures = 0
    for k in kernels:
        symbols: dict[tuple, str] = {}
        for key, argtypes in k.calls.items():
            if argtypes not in symbols:
                symbols[argtypes] = f"k{signatures}"
                cc.export(symbols[argtypes], k.dispatcher.overloads[argtypes].signature)(k.py_func)
                signatures += 1
            table.setdefault(jit.name_of(k.py_func), {})[key] = symbols[argtypes]
    os.makedirs(folder, exist_ok=True)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(dir=folder) as tmp, _fresh_flags(), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        cc.output_dir = tmp
        cc.compile()
        if jit.source_digest(outside) != digest or (recorded_from and jit.source_digest([]) != recorded_from):
            raise RuntimeError("snakeplan's sources changed while compiling; run snakeplan compile again")
        filename = os.path.basename(cc.output_file)
        shutil.move(os.path.join(tmp, filename), os.path.join(folder, filename))
    manifest = {"digest": digest, "files": outside, "module": module, "filename": filename,
                "table": {name: pickle.dumps(entries) for name, entries in table.items()}}
    atomic_write(os.path.join(folder, jit.MANIFEST), pickle.dumps(manifest))
    for old in os.listdir(folder):
        if old.startswith("snakeplan_kernels_") and old != filename:
            os.remove(os.path.join(folder, old))
    return {"folder": str(folder), "file": filename, "kernels": len(table), "signatures": signatures,
            "compile_s": time.perf_counter() - start}


def remove(folder=None) -> bool:
    """Delete the compiled module and its table; whether there was one."""
    folder = jit.compiled_dir() if folder is None else folder
    found = False
    for name in os.listdir(folder) if os.path.isdir(folder) else []:
        if os.path.isdir(os.path.join(folder, name)):  # a build's temporary folder, left by a killed compile
            shutil.rmtree(os.path.join(folder, name))
        elif name == jit.MANIFEST or name.startswith("snakeplan_kernels_"):
            os.remove(os.path.join(folder, name))
            found = True
    return found


def main(scenes: list[str] | None, run: Callable[[list[str]], int]) -> int:
    """Record the workload of ``scenes`` (None: all families), running its commands through ``run`` (the command
    line's entry point), and compile it; in a fresh interpreter (``snakeplan compile`` again) unless this one is
    recording. Returns the exit status."""
    if not jit.RECORDING:
        command = [sys.executable, "-m", "snakeplan.cli", "compile"]
        for name in scenes or []:
            command += ["--scene", name]
        return subprocess.run(command, env={**os.environ, jit.ENV_MODE: "record"}).returncode
    try:
        return _record_and_build(scenes, run)
    except KeyboardInterrupt:  # Ctrl-C reaches the parent 'snakeplan compile' too, which says so; the table is
        return EXIT_INTERRUPTED  # written last, so the module in use before stays in use


def _record_and_build(scenes: list[str] | None, run: Callable[[list[str]], int]) -> int:
    start = time.perf_counter()
    sources = jit.source_digest([])
    commands = workload(scenes)
    kernels, failed = record(commands, run)
    recorded = time.perf_counter() - start
    for line in failed:
        sys.stderr.write(f"snakeplan: warning: {line}; its kernels are compiled only as far as it ran\n")
    if not kernels:
        sys.stderr.write("snakeplan: error: the commands called no kernel; nothing to compile\n")
        return 1
    try:
        summary = build(kernels, recorded_from=sources)
    except Exception as exc:  # numba's compiler, the C compiler, the cache folder: say which, in one line
        sys.stderr.write(f"snakeplan: error: compiling the kernels failed: {type(exc).__name__}: "
                         f"{str(exc).strip().splitlines()[0] if str(exc).strip() else ''}\n")
        return 1
    sys.stdout.write(f"compiled {summary['kernels']} kernels ({summary['signatures']} signatures) from "
                     f"{len(commands)} commands into {summary['folder']}/{summary['file']}: recording "
                     f"{recorded:.0f} s, compiling {summary['compile_s']:.0f} s\n")
    return 0
