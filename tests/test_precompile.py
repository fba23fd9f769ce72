"""Kernels compiled ahead of time (``snakeplan compile``): the same plans as numba's, without importing numba."""

from __future__ import annotations

import itertools
import json
import os
import pickle
import shutil
import subprocess
import sys
import sysconfig
from pathlib import Path
from typing import NamedTuple

import numba
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from snakeplan import jit
from snakeplan.bench.runner import untimed

PLANNERS = ("sac-her", "rrt-star", "sp-rrt", "as-rrt")
#: Runs a command in-process and says on stderr whether numba was imported.
RUN = ("import sys; from snakeplan.cli import main; rc = main(sys.argv[1:]); "
       "sys.stderr.write(f'numba imported: {\"numba\" in sys.modules}\\n'); sys.exit(rc)")


class Pair(NamedTuple):
    first: np.ndarray
    second: np.ndarray


def _arrays(draw) -> np.ndarray:
    dtype = draw(st.sampled_from([np.float64, np.float32, np.int64, np.bool_]))
    shape = tuple(draw(st.lists(st.integers(0, 3), min_size=1, max_size=3)))
    a = np.zeros(shape, dtype=dtype, order=draw(st.sampled_from("CF")))
    if draw(st.booleans()) and a.ndim > 1:
        a = a.T
    if draw(st.booleans()):
        a = a[::2]
    if draw(st.booleans()):
        a = a.copy()
        a.flags.writeable = False
    return a


@settings(max_examples=60, deadline=None)
@given(st.lists(st.composite(_arrays)(), min_size=2, max_size=6))
def test_argument_keys_tell_apart_exactly_what_numba_types_apart(arrays):
    """The compiled function a proxy runs is chosen by ``arg_key``: two arrays share a key exactly when numba
    gives them the same type (dtype, dimensions, C/F/A layout, writeable, aligned): a shared key with different
    types would run code compiled for another layout, and different keys for one type would miss."""
    for a, b in itertools.combinations(arrays, 2):
        assert (jit.arg_key((a,)) == jit.arg_key((b,))) == (numba.typeof(a) == numba.typeof(b)), (a.flags, b.flags)
    packed = tuple(arrays)
    assert jit.arg_key((packed,)) == jit.arg_key((tuple(a for a in arrays),))
    assert jit.arg_key((packed, 1.0, 2)) != jit.arg_key((packed, 1, 2))
    pairs = [Pair(a, b) for a, b in itertools.pairwise(arrays)]  # named tuples: their fields count too
    for p, q in itertools.combinations(pairs, 2):
        assert (jit.arg_key((p,)) == jit.arg_key((q,))) == (numba.typeof(p) == numba.typeof(q))
    assert jit.arg_key((pairs[0],)) != jit.arg_key((tuple(pairs[0]),))


def _env(cache: Path, **extra: str) -> dict:
    return {**os.environ, jit.ENV_DIR: str(cache), **extra}


def _run(cache: Path, *argv: str, **extra: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", RUN, *argv], env=_env(cache, **extra), capture_output=True,
                          text=True, timeout=600)


def _plan(cache: Path, planner: str, **extra: str) -> tuple[dict, bool]:
    """The plan/1 document of ``planner`` on fuel-tank seed 1 (its timings, in seconds, dropped) and whether numba
    was imported."""
    proc = _run(cache, "plan", "--scene", "fuel-tank", "--seed", "1", "--planner", planner, "--json", **extra)
    assert proc.returncode in (0, 1), proc.stderr
    doc = json.loads(proc.stdout)
    doc.pop("compute_time_s")
    doc["details"] = untimed(doc["details"])
    return doc, "numba imported: True" in proc.stderr


@pytest.fixture(scope="module")
def compiled(tmp_path_factory) -> Path:
    """A cache folder holding the kernels of fuel-tank's commands, compiled."""
    if shutil.which((sysconfig.get_config_var("CC") or "cc").split()[0]) is None:
        pytest.skip("no C compiler: snakeplan compile needs one")
    cache = tmp_path_factory.mktemp("cache")
    proc = subprocess.run([sys.executable, "-m", "snakeplan.cli", "compile", "--scene", "fuel-tank"],
                          env=_env(cache), capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("compiled "), proc.stdout
    return cache


@pytest.mark.parametrize("planner", PLANNERS)
def test_compiled_kernels_plan_exactly_as_numba_without_importing_it(compiled, planner):
    """Each planner's plan and judged report on fuel-tank seed 1 are the same with the compiled module as with
    numba's kernels, number for number (rrt-star's random stream included), and numba is never imported."""
    ahead, imported = _plan(compiled, planner)
    jitted, _ = _plan(compiled, planner, **{jit.ENV_MODE: "numba"})
    assert not imported
    assert ahead == jitted


def test_arguments_the_module_lacks_run_numba(compiled):
    """A call with argument types that were not compiled (a strided array) runs numba's kernel, with the same
    result as the compiled one on the same values."""
    code = ("import sys, numpy as np; from snakeplan.geometry.polyline import cumulative_unchecked as f; "
            "p = np.array([[0., 0, 0], [3, 4, 0], [3, 4, 12], [0, 0, 0]]); a = f(p); "
            "print('numba' in sys.modules); b = f(np.repeat(p, 2, axis=0)[::2]); print('numba' in sys.modules); "
            "print(a.tolist() == b.tolist() == [0.0, 5.0, 17.0, 30.0])")
    proc = subprocess.run([sys.executable, "-c", code], env=_env(compiled), capture_output=True, text=True)
    assert proc.stdout.split() == ["False", "True", "True"], proc.stderr


def test_a_module_built_from_other_sources_is_not_used(compiled, tmp_path):
    """The table records the sources' digest; a module whose digest differs (an edited source) is ignored and
    numba compiles instead, with the same plan."""
    stale = tmp_path / "cache"
    shutil.copytree(compiled, stale)
    manifest_path = stale / "kernels" / jit.MANIFEST
    manifest = pickle.loads(manifest_path.read_bytes())
    manifest["digest"] = "0" * 32
    manifest_path.write_bytes(pickle.dumps(manifest))
    doc, imported = _plan(stale, "as-rrt")
    assert imported
    assert doc == _plan(compiled, "as-rrt")[0]


def test_the_plan_command_uses_only_compiled_kernels(compiled):
    """``snakeplan plan --scene fuel-tank --seed 1`` (the start-up figure) finds every kernel it calls compiled."""
    proc = _run(compiled, "plan", "--scene", "fuel-tank", "--seed", "1")
    assert proc.stdout.startswith("sac-her on fuel-tank (seed 1)")
    assert "numba imported: False" in proc.stderr


def test_compile_refuses_an_unknown_scene_and_removes_its_module(compiled, tmp_path):
    proc = subprocess.run([sys.executable, "-m", "snakeplan.cli", "compile", "--scene", "fuel-tnak"],
                          env=_env(tmp_path), capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.startswith("snakeplan: error: --scene: unknown scene family 'fuel-tnak'")
    assert len(proc.stderr.splitlines()) == 1
    copy = tmp_path / "copy"
    shutil.copytree(compiled, copy)
    proc = subprocess.run([sys.executable, "-m", "snakeplan.cli", "compile", "--remove"], env=_env(copy),
                          capture_output=True, text=True)
    assert proc.returncode == 0 and proc.stdout.startswith("removed"), proc.stderr
    assert os.listdir(copy / "kernels") == []


def test_ctrl_c_stops_compile_with_one_line_and_no_table(tmp_path):
    """Ctrl-C (SIGINT to the terminal's process group) while the commands are being recorded: one line, exit
    130, and no table in the cache folder."""
    import signal
    import time

    # a test run started as a background job inherits SIGINT ignored; the command is started as from a terminal
    proc = subprocess.Popen([sys.executable, "-m", "snakeplan.cli", "compile", "--scene", "fuel-tank"],
                            env=_env(tmp_path), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    time.sleep(3)
    os.killpg(proc.pid, signal.SIGINT)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert err == "snakeplan: interrupted\n" and out == ""
    assert not (tmp_path / "kernels" / jit.MANIFEST).exists()


def test_only_keys_that_fix_numba_types_are_recorded():
    """A list's numba type depends on its contents, which its key (the class) does not hold: such calls are not
    compiled ahead of time; arrays, tuples, named tuples and numbers are."""
    a = np.zeros((2, 3))
    assert jit._exact(jit.arg_key((a, (a, a), Pair(a, a), 1.0, 2, True, np.float32(1), None)))
    assert not jit._exact(jit.arg_key(([1.0, 2.0],)))
    assert not jit._exact(jit.arg_key(((a, {"k": 1}),)))


def test_a_fallback_to_numba_seeds_numbas_stream_as_the_compiled_side_was(compiled):
    """rrt-star's stream is seeded by a compiled kernel; once a call falls back to numba, numba's stream is
    seeded with the same seed, so a numba kernel then draws NumPy's legacy sequence for that seed."""
    code = ("import numpy as np, sys; from snakeplan.planners.tip_rrt_star import seed_stream; "
            "from snakeplan.geometry.polyline import cumulative_unchecked as f; seed_stream(5); "
            "print('numba' in sys.modules); f(np.zeros((4, 3))[::2]); import numba; "
            "draw = numba.njit(lambda: np.random.random()); "
            "print(draw() == np.random.RandomState(5).random_sample())")
    proc = subprocess.run([sys.executable, "-c", code], env=_env(compiled), capture_output=True, text=True)
    assert proc.stdout.split() == ["False", "True"], proc.stderr


def test_a_kernel_not_yet_compiled_is_told_apart_and_plan_says_it_will_compile(tmp_path, monkeypatch, capsys):
    """The newcomer's first plan took 6-19 s while printing 'found in 0.004 s': a kernel with nothing on disk is
    recognised (numba's cache index), plan says it compiles first, and prints its wall time beside the planner's."""
    import importlib
    import sys

    import snakeplan.world.validity as validity
    from snakeplan.cli import main
    from snakeplan.jit import compiled_on_disk

    (tmp_path / "fresh_kernel_mod.py").write_text(
        "import numba\n\n@numba.njit(cache=True)\ndef twice(x):\n    return 2 * x\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    mod = importlib.import_module("fresh_kernel_mod")
    try:
        assert compiled_on_disk(mod.twice) is False
        assert mod.twice(3) == 6 and compiled_on_disk(mod.twice) is True
    finally:
        sys.modules.pop("fresh_kernel_mod", None)
    monkeypatch.setattr(validity, "kernels_ready", lambda: False)
    assert main(["plan", "--seed", "1", "--planner", "as-rrt"]) == 0
    out, err = capsys.readouterr()
    assert err.startswith("snakeplan: compiling the planning kernels on first use (about a minute")
    assert " s wall, judging and loading included)" in out.splitlines()[0]


#: A worker of the compile-once test: waits for its sibling (a file barrier), calls a kernel of its own module,
#: and prints how many kernels it compiled.
_WORKER = """
import sys, time
from pathlib import Path
sys.path.insert(0, sys.argv[1])
Path(sys.argv[1], 'ready-' + sys.argv[2]).touch()
while len(list(Path(sys.argv[1]).glob('ready-*'))) < 2:
    time.sleep(0.01)
import chain_kernels
chain_kernels.run(3)
print(sum(sum(d.stats.cache_misses.values()) for d in chain_kernels.KERNELS))
"""


def _chain_module(decorator: str) -> str:
    """Twenty cached kernels, each calling the one before: about a second of compiling, so two workers overlap."""
    return (f"import numba\nfrom snakeplan import jit\n\n" + "".join(
        f"@{decorator}\ndef k{i}(x):\n    return {'x' if i == 0 else f'k{i - 1}(x)'} * 2 + {i}\n\n"
        for i in range(20)) + "KERNELS = [" + ", ".join(f"k{i}" for i in range(20)) + "]\nrun = k19\n")


@pytest.mark.parametrize("decorator", ["jit.kernel", "numba.njit(cache=True)"])
def test_workers_starting_together_compile_each_kernel_once_per_machine(tmp_path, decorator):
    """On a cold cache, N workers of one machine each compiled the same kernels at once (bench table2, 16
    workers: 120 s against 42 s warm). snakeplan's kernels compile under a lock per kernel: of two workers that
    need the same chain of kernels at once, one compiles it and the other loads it from numba's cache; plain
    numba kernels (the control) compile in both."""
    (tmp_path / "chain_kernels.py").write_text(_chain_module(decorator))
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "SNAKEPLAN_CACHE_DIR": str(tmp_path / "sp"),
           "SNAKEPLAN_KERNELS": "numba"}
    procs = [subprocess.Popen([sys.executable, "-c", _WORKER, str(tmp_path), str(i)], env=env,
                              stdout=subprocess.PIPE, text=True) for i in range(2)]
    compiled = sorted(int(p.communicate(timeout=120)[0].split()[-1]) for p in procs)
    if decorator == "jit.kernel":
        assert compiled == [0, 20]
    else:  # both compile, each perhaps loading a few kernels the other had finished
        assert min(compiled) > 0 and sum(compiled) > 20


def test_a_kernel_compiles_unguarded_where_the_cache_folder_cannot_be_written(tmp_path):
    """The compile lock lives in the cache folder; a home that cannot be written (here a folder under a file)
    must not stop a kernel compiling."""
    (tmp_path / "chain_kernels.py").write_text(_chain_module("jit.kernel"))
    (tmp_path / "ready-1").touch()  # no sibling to wait for
    (tmp_path / "a-file").write_text("")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "numba"), "SNAKEPLAN_KERNELS": "numba",
           "SNAKEPLAN_CACHE_DIR": str(tmp_path / "a-file" / "cache")}
    proc = subprocess.run([sys.executable, "-c", _WORKER, str(tmp_path), "0"], env=env, capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout.split()[-1] == "20", proc.stderr[-500:]
