"""Crash-safe state folders for long jobs (training): atomic files, a manifest written last, two generations.

A state folder ``root`` holds::

    root/state.json          the manifest, written last
    root/ckpt-<step>/NAME    one folder per generation (step with 8 digits): the files the manifest lists
    root/.lock               held (flock) while a job uses the folder (:func:`lock_folder`, also the
                             benchmark runner's lock on its results folder)

The manifest::

    {"format": "snakeplan.checkpoint/1",
     "run": {...},                              # whose state this is; a job of another run is refused
     "generations": [                           # newest first, at most two
       {"folder": "ckpt-00000300", "step": 300,
        "files": {"model.zip": {"bytes": 81234, "sha256": "<hex>"}, ...},
        "record": {...}},                       # the job's own bookkeeping at that step (JSON)
       ...]}

:meth:`StateFolder.save` writes each file of the new generation to a temporary file beside it, flushes and
fsyncs it and ``os.replace``\\ s it into place, fsyncs the folder, then writes the manifest the same way, naming
the new generation first and the one it continues from second; only then are other generation folders deleted.
A process killed at any moment thus leaves the old manifest or the new one, each naming complete generations.
:meth:`StateFolder.load` checks the named generations' files (sizes, sha256) and takes the newest that agrees:
a damaged newest generation falls back to the previous one.

:func:`checkpoint_interval` is the default interval of the trainers; :func:`sb3_files` and :func:`sb3_restore`
checkpoint a Stable-Baselines3 off-policy model so that training resumes exactly where it stopped. This module
imports nothing from snakeplan but :mod:`snakeplan.files`, so any layer may use it (Stable-Baselines3 and torch
only inside those two).
"""

from __future__ import annotations

import hashlib
import json
import os
import pickle
import random
import re
import shutil
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from snakeplan.files import atomic_path, atomic_write

FORMAT = "snakeplan.checkpoint/1"
MANIFEST = "state.json"
_FOLDER = re.compile(r"ckpt-\d{8,}")
_TEMP = ".*.tmp*"


def checkpoint_interval(steps: int) -> int:
    """The default checkpoint interval (steps) of a run of ``steps``: a tenth of the run, at least 1,000 and at
    most 10,000 steps, and never more than the run itself (so a run killed midway resumes from a checkpoint)."""
    return max(1, min(10_000, max(1_000, steps // 10), steps))


class StateError(ValueError):
    """Saved state that cannot be resumed: an unreadable manifest, another run's state, nothing intact, or a
    folder another job is using; ``advice`` says what the user can do about it."""

    def __init__(self, message: str, advice: str = "rerun with --fresh to start over"):
        super().__init__(message)
        self.advice = advice


def _digest(path: Path) -> dict:
    """Size and sha256 of the file at ``path``."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
        return {"bytes": f.tell(), "sha256": h.hexdigest()}


def fsync_dir(path: str | Path) -> None:
    """Make a folder's entries (renames, new files) durable."""
    if os.name != "posix":
        return
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _replace_with(dest: Path, write: Callable[[Path], object]) -> dict:
    """Write ``dest`` atomically through ``write(tmp)``; its size and sha256."""
    with atomic_path(dest) as tmp:
        write(tmp)
        digest = _digest(tmp)
    return digest


@dataclass(frozen=True)
class Generation:
    """One complete checkpoint: its folder, step, files (name -> bytes, sha256) and the job's record."""

    folder: Path
    step: int
    files: dict = field(default_factory=dict)
    record: dict = field(default_factory=dict)

    def path(self, name: str) -> Path:
        return self.folder / name

    def entry(self) -> dict:
        return {"folder": self.folder.name, "step": self.step, "files": self.files, "record": self.record}


def _plain(obj):
    """``obj`` as it reads back from JSON (tuples become lists)."""
    return json.loads(json.dumps(obj))


def _differences(saved, ours, prefix: str = "") -> list[str]:
    """The fields where two run descriptions differ: ``["seed: 1 here, 0 there", "config.tau: ..."]``."""
    if not (isinstance(saved, dict) and isinstance(ours, dict)):
        return [f"{prefix.rstrip('.') or 'run'}: {ours!r} here, {saved!r} there"]
    found = []
    for key in sorted(set(saved) | set(ours), key=str):
        a, b = saved.get(key), ours.get(key)
        if a != b:
            found += (_differences(a, b, f"{prefix}{key}.") if isinstance(a, dict) and isinstance(b, dict)
                      else [f"{prefix}{key}: {b!r} here, {a!r} there"])
    return found


class StateFolder:
    """The state folder ``root`` of run ``run`` (a JSON-able description compared on load); see the module doc.

    ``current`` is the generation loaded or last saved; ``warnings`` says which damaged generations
    :meth:`load` passed over."""

    def __init__(self, root: str | Path, run: dict):
        self.root = Path(root)
        self.run = _plain(run)
        self.current: Generation | None = None
        self.warnings: list[str] = []

    @property
    def manifest(self) -> Path:
        return self.root / MANIFEST

    @contextmanager
    def locked(self) -> Iterator[None]:
        """Hold the folder's lock for the block; :class:`StateError` when another process holds it."""
        with lock_folder(self.root):
            yield

    def load(self) -> Generation | None:
        """The newest generation whose files agree with the manifest (also ``current``); None when nothing was
        saved. :class:`StateError` when the manifest is unreadable, belongs to another run or names nothing
        intact."""
        self.current, self.warnings = None, []
        if not self.manifest.exists():
            return None
        try:
            data = json.loads(self.manifest.read_text())
        except (OSError, UnicodeDecodeError, ValueError) as exc:
            raise StateError(f"{self.manifest}: unreadable ({exc.__class__.__name__})") from None
        if not (isinstance(data, dict) and data.get("format") == FORMAT and isinstance(data.get("generations"), list)):
            raise StateError(f"{self.manifest}: not a {FORMAT} manifest (another program's, or an older snakeplan's)")
        if data.get("run") != self.run:
            differences = ", ".join(_differences(data.get("run"), self.run))
            raise StateError(f"{self.root} holds the state of another run ({differences})")
        problems = []
        for entry in data["generations"]:
            generation, problem = self._verify(entry)
            if generation is not None:
                self.current = generation
                self.warnings = [f"checkpoint {p}; resuming from {generation.folder.name}" for p in problems]
                return generation
            problems.append(problem)
        raise StateError(f"{self.root}: no intact checkpoint ({'; '.join(problems) or 'none listed'})")

    def _verify(self, entry) -> tuple[Generation | None, str]:
        if not isinstance(entry, dict):
            return None, "a malformed entry"
        folder, step, files, record = (entry.get(k) for k in ("folder", "step", "files", "record"))
        if not (isinstance(folder, str) and _FOLDER.fullmatch(folder) and type(step) is int and step >= 0
                and isinstance(files, dict) and isinstance(record, dict)):
            return None, f"{folder!r} is a malformed entry"
        for name, want in files.items():
            path = self.root / folder / name
            if Path(name).name != name or name.startswith(".") or not isinstance(want, dict):
                return None, f"{folder} lists a malformed file {name!r}"
            if not path.is_file():
                return None, f"{folder} is damaged ({name} is missing)"
            size = path.stat().st_size
            if size != want.get("bytes"):
                return None, f"{folder} is damaged ({name} has {size} bytes, the manifest says {want.get('bytes')})"
            if _digest(path)["sha256"] != want.get("sha256"):
                return None, f"{folder} is damaged ({name} does not match its sha256)"
        return Generation(self.root / folder, step, files, record), ""

    def save(self, step: int, writers: Mapping[str, Callable[[Path], object]], record: dict) -> Generation:
        """Write generation ``step``: each ``writers[name](path)`` writes file ``name`` at ``path``; ``record``
        (JSON) is kept in the manifest. Returns the new ``current``."""
        if self.current is not None and step <= self.current.step:
            raise ValueError(f"step: a checkpoint at step {self.current.step} exists, got {step}")
        folder = self.root / f"ckpt-{step:08d}"
        if folder.exists():  # a partial generation of a killed job
            shutil.rmtree(folder)
        folder.mkdir(parents=True)
        files = {name: _replace_with(folder / name, write) for name, write in writers.items()}
        fsync_dir(folder)
        new = Generation(folder, int(step), files, _plain(record))
        kept = [new] + ([self.current] if self.current is not None else [])
        manifest = {"format": FORMAT, "run": self.run, "generations": [g.entry() for g in kept]}
        atomic_write(self.manifest, json.dumps(manifest, indent=1))
        fsync_dir(self.root)
        self.current = new
        self._prune({g.folder.name for g in kept})
        return new

    def clear(self) -> None:
        """Forget every generation: the manifest first, then the folders."""
        self.manifest.unlink(missing_ok=True)
        if self.root.is_dir():
            fsync_dir(self.root)
            self._prune(set())
        self.current = None

    def _prune(self, keep: set[str]) -> None:
        """Delete generation folders not in ``keep`` and temporary files left by killed jobs."""
        for child in self.root.iterdir():
            if child.is_dir() and _FOLDER.fullmatch(child.name) and child.name not in keep:
                shutil.rmtree(child, ignore_errors=True)
        for tmp in self.root.glob(_TEMP):
            if tmp.is_file():
                tmp.unlink(missing_ok=True)


@contextmanager
def lock_folder(root: str | Path, field: str = "") -> Iterator[None]:
    """Hold ``root/.lock`` (flock, released when the process dies) for the block, creating ``root``;
    :class:`StateError` when another process holds it (its message starts with ``field:`` when given)."""
    try:
        import fcntl
    except ImportError:  # no flock on this platform: unguarded
        yield
        return
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    with open(root / ".lock", "a") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            advice = "wait for it to finish, or choose another --out"
            raise StateError(f"{field + ': ' if field else ''}{root} is in use by another job"
                             + (f"; {advice}" if field else ""), advice) from None
        yield


def _pickle(path: Path, obj) -> None:
    with open(path, "wb") as f:
        pickle.dump(obj, f, protocol=pickle.HIGHEST_PROTOCOL)


def _unpickle(path: Path):
    with open(path, "rb") as f:
        return pickle.load(f)


def sb3_files(model) -> dict[str, Callable[[Path], object]]:
    """Writers (for :meth:`StateFolder.save`) of an SB3 off-policy model on a ``DummyVecEnv``, captured now:
    ``model.zip`` (parameters, optimisers, counters, last observation), ``replay.pkl`` (the replay buffer),
    ``envs.pkl`` (the environments, mid-episode) and ``rng.pkl`` (the torch, NumPy, Python and action-space
    generator states). Take them at the start of a rollout, where the last transition is stored and trained on."""
    import torch

    rngs = {"torch": torch.get_rng_state().numpy(), "numpy": np.random.get_state(), "python": random.getstate(),
            "action_space": model.action_space.np_random.bit_generator.state}
    envs = model.env.envs
    return {"model.zip": model.save, "replay.pkl": model.save_replay_buffer,
            "envs.pkl": lambda path: _pickle(path, envs), "rng.pkl": lambda path: _pickle(path, rngs)}


def sb3_restore(cls, generation: Generation):
    """The model of class ``cls`` that :func:`sb3_files` saved in ``generation``, with its environments, replay
    buffer and generator states as they were: ``learn(..., reset_num_timesteps=False)`` then continues exactly
    as the uninterrupted run would have. The files are pickles: restore only your own."""
    import torch
    from stable_baselines3.common.vec_env import DummyVecEnv

    envs = _unpickle(generation.path("envs.pkl"))
    venv = DummyVecEnv([lambda env=env: env for env in envs])
    model = cls.load(generation.path("model.zip"), env=venv, device="cpu", force_reset=False)
    model.load_replay_buffer(generation.path("replay.pkl"), truncate_last_traj=False)
    venv._reset_seeds()  # load() seeded the environments anew; the saved ones carry their own generators
    rngs = _unpickle(generation.path("rng.pkl"))
    torch.set_rng_state(torch.from_numpy(rngs["torch"]))
    np.random.set_state(rngs["numpy"])
    random.setstate(rngs["python"])
    model.action_space.np_random.bit_generator.state = rngs["action_space"]
    return model
