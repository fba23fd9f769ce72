"""The one benchmark runner: episodes (scene families or scene files x seeds) x planners (+ options), planned and
judged through :func:`snakeplan.episode.run_episode`, one JSON Lines row per run in a results folder, whatever the
scene's task: a planner runs in the scenes whose task it does, and an inspect row's metrics are the judge's
(the mission's map error and uncertainty curves, the share of views the arm holds).

A results folder ``DIR`` holds::

    DIR/runs.jsonl          one snakeplan.run/1 row per run, appended whole (one write of one line, fsync'ed)
    DIR/paths/<sha256>.json a path longer than PATH_INLINE_POINTS points (the row keeps its hash)
    DIR/invocations.jsonl   one line per finished invocation: backend, runs, wall time, load averages
    DIR/.lock               held (flock) while a runner writes the folder

A row names its run (scene, seed, robot, planner and options, time limit, knowledge), the judge's verdict and
metrics (and, for a family made from another, a scan, the verdict in that family's scene: ``made_from``), the
plan's status, details and compute time, the path, and its provenance (snakeplan version, git commit
when the package runs from a checkout, Python, platform, the host that planned it, the invocation's start time
and settings). Its ``key`` is a digest of the run's identity: a rerun of the same command skips every key the
folder holds (resume), and a torn last line (a writer killed mid-line) is cut off before anything is appended.
A second runner on the same folder is refused with one line.

Backends (:class:`snakeplan.parallel.Backend`): ``serial`` (in this process), ``processes`` (a local process
pool, the default, one worker per usable core) and ``ray`` (``local`` starts a Ray instance for the run; ``auto``
or an address joins a cluster; the ``cluster`` extra). Work goes out in chunks of runs (:func:`chunks`), each
worker with BLAS/OpenMP pinned to one thread; only this process writes, so the rows are the same on every backend, timing aside
(:func:`comparable`). Each worker process plans every (planner, scene) pair once untimed before its first timed
run (jit caches, policy files), so no run pays for loading. On a cold cache a machine compiles each kernel once
(a lock per kernel, :func:`snakeplan.jit.njit`): a worker that needs a kernel another is compiling waits and then
loads it from numba's cache, instead of every worker compiling the same kernels at once; a row's
``provenance.kernels_compiled`` counts the kernels its worker compiled for its warm-up. A planner marked ``stateful`` (a learning planner)
keeps one instance over its runs in seed order, in one chunk, as the papers run it.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import platform
import socket
import subprocess
import sys
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from datetime import datetime, timezone
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from snakeplan.checkpoints import fsync_dir, lock_folder
from snakeplan.files import atomic_write
from snakeplan.jit import compilations
from snakeplan.jsonable import jsonable
from snakeplan.parallel import Backend, streamed, usable_cores

if TYPE_CHECKING:
    from snakeplan.scenes.registry import SceneSpec

SCHEMA = "snakeplan.run/1"
RUNS_FILE = "runs.jsonl"
INVOCATIONS_FILE = "invocations.jsonl"
PATHS_FOLDER = "paths"
#: Paths with more points than this go to a sidecar file named by their hash.
PATH_INLINE_POINTS = 400
#: Seed of the untimed warm-up plan each worker makes per (planner, scene) before timing (not a benchmark seed).
WARMUP_SEED = 10_000
#: Budget (s) of a warm-up plan, at most.
WARMUP_TIME_LIMIT_S = 2.0
#: Most runs in one task; fewer when there are few runs per worker.
CHUNK_MAX = 8
#: Fields of a row that measure time or place rather than the result.
TIMING_FIELDS = ("compute_time_s", "provenance")


@dataclass(frozen=True)
class Run:
    """One run: a scene (a registered family and seed, or a scene file) planned by ``planner`` with ``options``
    from ``seed``. ``scene_file`` runs carry the file's text (``scene_json``), its folder (``scene_dir``, where the
    mesh and cloud files it names are read from) so that any worker can plan them, and the SHA-256 of each file
    it names (``files_sha256``: (name as written, digest) pairs, taken once when the sweep listed its runs); so do
    the trained policy its planner reads (``policy_sha256``: the digest of :meth:`Planner.policy_file
    <snakeplan.planners.base.Planner.policy_file>`, named by ``policy=`` or the planner's default; empty for a
    planner that reads none)."""

    scene: str
    seed: int
    planner: str
    robot: str
    time_limit_s: float
    options: tuple[tuple[str, object], ...] = ()
    knowledge: str = "full"
    scene_json: str = ""
    stateful: bool = False
    config: str = ""
    task: str = "reach"
    robot_json: str = ""
    sensor: str = "exact"
    scene_dir: str = ""
    files_sha256: tuple[tuple[str, str], ...] = ()
    policy_sha256: str = ""

    def identity(self) -> dict:
        """What makes this run this run (the key's preimage; a scene file, the files it names, a robot file and
        the policy file its planner reads count by content, so a folder whose scene files name their files relative to
        themselves keys the same wherever it is moved, and a policy retrained in place is planned again; a sensed
        run's sensor when it is not the exact one)."""
        ident = {"scene": self.scene, "seed": self.seed, "robot": self.robot, "planner": self.planner,
                 "options": dict(self.options), "time_limit_s": self.time_limit_s, "knowledge": self.knowledge}
        if self.sensor != "exact":
            ident["sensor"] = self.sensor
        if self.scene_json:
            ident["scene_sha256"] = hashlib.sha256(self.scene_json.encode()).hexdigest()
            if self.files_sha256:
                ident["files_sha256"] = dict(self.files_sha256)
        if self.policy_sha256:
            ident["policy_sha256"] = self.policy_sha256
        if self.robot_json:
            ident["robot_sha256"] = hashlib.sha256(self.robot_json.encode()).hexdigest()
        return ident

    def arm(self):
        """The run's robot: its preset, or the robot its file described (carried as robot/1 JSON)."""
        return _arm(self.robot, self.robot_json)

    def make_scene(self, seed: int | None = None):
        """The run's scene: its file's, or its family's at its seed (or at ``seed``) sized to the run's arm
        (:mod:`snakeplan.scenes.sizing`)."""
        from snakeplan.scenes import Scene
        from snakeplan.scenes.sizing import arm_sizing, sized_scene

        if self.scene_json:
            return Scene.from_json(self.scene_json, "scenes", self.scene_dir or None)
        return sized_scene(self.scene, self.seed if seed is None else seed, arm_sizing(self.scene, self.arm()))

    @property
    def key(self) -> str:
        return hashlib.sha256(json.dumps(self.identity(), sort_keys=True).encode()).hexdigest()[:24]

    @property
    def label(self) -> str:
        return f"{self.scene} seed {self.seed} {self.planner}"


def _named_files(scene_json: str, folder: str) -> tuple[tuple[str, str], ...]:
    """(name as written, SHA-256) of each mesh or cloud file a scene file's obstacles name (read from ``folder``)."""
    doc = json.loads(scene_json)
    names = [o["file"] for o in doc.get("obstacles", ()) if isinstance(o, dict) and isinstance(o.get("file"), str)]
    out = []
    for name in dict.fromkeys(names):
        with open(Path(folder) / name, "rb") as fh:
            out.append((name, hashlib.file_digest(fh, "sha256").hexdigest()))
    return tuple(out)


def _policy_digest(planner: str, options: dict, spec, robot) -> str:
    """The SHA-256 of the trained policy ``planner`` made with ``options`` reads to plan ``robot`` in ``spec``'s
    family (:meth:`~snakeplan.planners.base.Planner.policy_file`: the file ``policy=`` names, else its default),
    "" for a planner that reads none. A run is keyed by it, so a policy retrained in place (``--out DIR``,
    ``policy=DIR/policy.npz``) is planned again, not skipped as planned."""
    from snakeplan.planners.registry import PLANNERS, get_planner

    if not PLANNERS.get(planner).takes_policy:
        return ""
    try:
        path = get_planner(planner, **options).policy_file(spec, robot)
    except ValueError:  # a policy that does not load: the run's worker says so, as for any planning error
        return ""
    if path is None or not path.is_file():
        return ""
    with open(path, "rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


@functools.lru_cache(maxsize=16)
def _arm(robot: str, robot_json: str):
    """A run's robot, made once per worker however many runs share it."""
    from snakeplan.robots import get_robot, load_robot

    return load_robot(json.loads(robot_json)) if robot_json else get_robot(robot)


def check_robot(name: str, field: str = "robot") -> None:
    """A sweep's robot (when one is given) is a preset or a robot file (as ``plan --robot`` takes it): ValueError
    naming ``field`` otherwise."""
    _robot_source(name, field)


def _robot_source(name: str, field: str = "robot") -> tuple[str, str]:
    """(the robot's name, its robot/1 JSON when it comes from a file, else "") of a sweep's robot."""
    from snakeplan.robots import load_robot, robot_names

    if name in robot_names():
        return name, ""
    try:
        chain = load_robot(name)
    except ValueError as exc:
        raise ValueError(f"{field}: {exc.args[0]}") from None
    return chain.name, json.dumps(chain.to_dict(), sort_keys=True)


@dataclass(frozen=True)
class Sweep:
    """Episodes x planners: every ``scenes`` entry (a family name, or a ``.json`` scene file) with every seed,
    planned by every ``planners`` entry ``(name, options)``; ``robot`` empty: each scene's own (its spec).
    ``include(scene, planner, options)`` may leave entries out (Table 2 compares a learned planner with a family's
    policy only where that policy ships). ``stateful(planner, options)`` says which planners keep one instance over their runs in a scene, in
    seed order (a planner that learns from run to run). ``knowledge``: one mode ("full", "sensed") or several,
    each run once per mode; where a mode is "sensed", a planner that needs the whole scene runs with full
    knowledge instead (paper 000's setting: the sampling planners know the tank), once. Listing the runs reads
    the scene files' named files and the policy file each run's planner reads (:func:`_policy_digest`) to key
    them."""

    name: str
    scenes: tuple[str, ...]
    seeds: tuple[int, ...]
    planners: tuple[tuple[str, dict], ...]
    time_limit_s: float = 10.0
    robot: str = ""
    knowledge: str | tuple[str, ...] = "full"
    task: str = ""
    stateful: Callable[[str, dict], bool] | None = field(default=None, compare=False)
    include: Callable[[str, str, dict], bool] | None = field(default=None, compare=False)
    sensor: str = "exact"

    def runs(self) -> list[Run]:
        """Every run, scene by scene, planner by planner, seed by seed; a planner runs only in the scenes whose
        task it does (a tip planner where targets are to be reached, an inspection planner where a surface is to
        be inspected), and one that does no scene's task is a ValueError naming ``planners``."""
        out = []
        fitted: set[str] = set()
        robot_file = _robot_source(self.robot) if self.robot else None
        for scene in self.scenes:
            source = _scene_source(scene)
            family, spec = source.name, source.spec
            task = self.task or spec.task
            robot, robot_json = robot_file or (spec.robot, "")
            for planner, options in self.planners:
                if not _does_task(planner, task):
                    continue
                fitted.add(planner)
                if self.include is not None and not self.include(family, planner, options):
                    continue
                policy = _policy_digest(planner, options, source.spec, _arm(robot, robot_json))
                for knowledge in dict.fromkeys(self.knowledge_of(planner)):
                    for seed in self.seeds:
                        out.append(Run(family, seed, planner, robot, self.time_limit_s,
                                       tuple(sorted(options.items())), knowledge, source.text,
                                       self.stateful is not None and self.stateful(planner, options),
                                       self.name, task, robot_json,
                                       self.sensor if knowledge == "sensed" else "exact", source.folder,
                                       source.files, policy))
        idle = [p for p, _ in self.planners if p not in fitted]
        if idle:
            raise ValueError(f"planners: {', '.join(idle)} can do none of these scenes' tasks "
                             f"({', '.join(self.scenes)}): a tip planner reaches targets, an inspection planner "
                             f"inspects a surface (station)")
        return out


    def knowledge_of(self, planner: str) -> tuple[str, ...]:
        """The knowledge of each of ``planner``'s runs per seed, one per mode (see the class doc)."""
        modes = (self.knowledge,) if isinstance(self.knowledge, str) else tuple(self.knowledge)
        return tuple("full" if mode == "sensed" and _needs_full_scene(planner) else mode for mode in modes)


def _needs_full_scene(planner: str) -> bool:
    """Whether ``planner`` (a registered name) plans only with the whole scene."""
    from snakeplan.planners.registry import PLANNERS

    return PLANNERS.get(planner).needs_full_scene


class SceneSource(NamedTuple):
    """A sweep's scene entry: a scene file's text, the absolute folder it names its files from and their
    :func:`_named_files` (all empty for a family), the family or the file's scene name, and its spec (robot,
    task)."""

    text: str
    folder: str
    files: tuple[tuple[str, str], ...]
    name: str
    spec: SceneSpec


def _scene_source(scene: str) -> SceneSource:
    """The :class:`SceneSource` of a sweep's scene entry: a registered family, or a scene file (``.json``)."""
    from snakeplan.scenes import Scene, scene_spec, spec_for

    if scene.endswith(".json"):
        try:
            text = Path(scene).read_text()
        except OSError as exc:
            raise ValueError(f"scenes: cannot read {scene} ({exc.__class__.__name__})") from None
        folder = str(Path(scene).resolve().parent)
        made = Scene.from_json(text, "scenes", folder)
        return SceneSource(text, folder, _named_files(text, folder), made.name, spec_for(made))
    return SceneSource("", "", (), scene, scene_spec(scene))  # KeyError naming the known families


def _does_task(planner: str, task: str) -> bool:
    """Whether ``planner`` does a scene's task (the tasks it declares)."""
    from snakeplan.planners.registry import PLANNERS

    return task in PLANNERS.get(planner).tasks


# --- tasks ------------------------------------------------------------------------------------------------
def chunks(runs: Sequence[Run], slots: int) -> list[list[Run]]:
    """Runs grouped into tasks: a stateful planner's runs in one scene stay together in seed order; the rest one
    by one for a single worker (each row logged as soon as it is judged), else in chunks of at most
    :data:`CHUNK_MAX`, about four tasks per worker."""
    groups: dict[tuple, list[Run]] = {}
    for r in runs:
        groups.setdefault((r.scene, r.planner, r.options, r.knowledge) if r.stateful else (r.key,), []).append(r)
    units = list(groups.values())
    size = 1 if slots == 1 else max(1, min(CHUNK_MAX, math.ceil(len(runs) / (4 * slots))))
    out: list[list[Run]] = []
    current: list[Run] = []
    for unit in units:
        if unit[0].stateful:
            out.append(unit)
            continue
        current += unit
        if len(current) >= size:
            out.append(current)
            current = []
    if current:
        out.append(current)
    return out


# --- planning one chunk (in a worker) ------------------------------------------------------------------------
_WARM: set[tuple] = set()


def run_chunk(task: list[Run], stamp: dict) -> list[dict]:
    """Plan and judge every run of ``task`` (in a worker); its rows, each stamped with ``stamp`` (provenance)
    and this host."""
    from snakeplan.episode import run_episode
    from snakeplan.planners import Problem, get_planner
    from snakeplan.scenes import scene_spec

    host = {"host": socket.gethostname(), "pid": os.getpid()}
    rows = []
    shared: dict[tuple, object] = {}
    for run in task:
        robot = run.arm()
        options = dict(run.options)
        warm = (run.scene, run.scene_json, run.scene_dir, run.robot, run.robot_json, run.planner, run.options,
                run.knowledge, run.sensor)
        compiled = 0
        if warm not in _WARM:
            before = compilations()
            run_episode(Problem(run.make_scene(WARMUP_SEED), robot, min(run.time_limit_s, WARMUP_TIME_LIMIT_S),
                                knowledge=run.knowledge, task=run.task, sensor=run.sensor),
                        get_planner(run.planner, **options), seed=WARMUP_SEED)
            compiled = compilations() - before
            _WARM.add(warm)
        if run.stateful:
            planner = shared.setdefault((run.planner, run.options, run.knowledge), get_planner(run.planner, **options))
        else:
            planner = get_planner(run.planner, **options)
        problem = Problem(run.make_scene(), robot, run.time_limit_s, knowledge=run.knowledge, task=run.task,
                          sensor=run.sensor)
        episode = run_episode(problem, planner, seed=run.seed)
        rows.append(make_row(run, episode, {**stamp, **host, "kernels_compiled": compiled}))
        source = "" if run.scene_json else scene_spec(run.scene).made_from
        if source:
            rows[-1]["made_from"] = judged_in_source(source, run, episode.plan.path)
    return rows


def judged_in_source(source: str, run: Run, path) -> dict:
    """The judge's verdict on a reach plan of a family made from ``source`` (a scan of it), in ``source``'s own
    scene of the run's seed: ``{scene, success, reason}`` (no path: not a success, no reason)."""
    from snakeplan.evaluation import evaluate
    from snakeplan.scenes import make_scene

    if path is None or run.task != "reach":
        return {"scene": source, "success": False, "reason": None}
    report = evaluate(make_scene(source, run.seed), run.arm(), np.asarray(path, dtype=float))
    return {"scene": source, "success": bool(report.success), "reason": report.reason}


def _row(run: Run, status: str, why: str, success: bool, reason: str | None, compute_time_s: float,
         metrics: dict | None, details: dict, path: np.ndarray | None, provenance: dict) -> dict:
    """A ``snakeplan.run/1`` row: the run, the outcome (the planner's status and why, the judge's verdict), the
    path (mm) with its hash, provenance."""
    row = {"schema": SCHEMA, "key": run.key, "config": run.config, "task": run.task, "scene": run.scene,
           "sensor": run.sensor,
           "seed": run.seed,
           "robot": run.robot, "planner": run.planner, "options": dict(run.options),
           "time_limit_s": run.time_limit_s, "knowledge": run.knowledge,
           "status": status, "why": why, "success": success, "reason": reason, "compute_time_s": compute_time_s,
           "metrics": metrics, "details": details,
           "path": None if path is None else path.tolist(),
           "path_points": 0 if path is None else len(path),
           "path_sha256": None if path is None else hashlib.sha256(path.tobytes()).hexdigest(),
           "provenance": provenance}
    if run.scene_json:
        row["scene_sha256"] = run.identity()["scene_sha256"]
    if run.files_sha256:
        row["files_sha256"] = dict(run.files_sha256)
    if run.policy_sha256:
        row["policy_sha256"] = run.policy_sha256
    return jsonable(row)


def make_row(run: Run, episode, provenance: dict) -> dict:
    """The ``snakeplan.run/1`` row of a judged episode."""
    plan, report = episode.plan, episode.report
    return _row(run, str(plan.status), plan.why, episode.success, episode.reason, plan.compute_time_s,
                report.metrics() if report is not None else None, jsonable(plan.details),
                None if plan.path is None else np.asarray(plan.path, dtype=float), provenance)


def comparable(row: dict) -> dict:
    """A row without what measures time or place (:data:`TIMING_FIELDS`, details in seconds, ``*_s`` at any depth,
    and the details of a run its time budget stopped, ``timeout``: its search statistics, and the why of any run its
    clock stopped, which says how far it got): what must agree between backends and between an interrupted run and
    an uninterrupted one."""
    out = {k: v for k, v in row.items() if k not in TIMING_FIELDS}
    details = out.get("details") if isinstance(out.get("details"), dict) else {}
    if "timeout" in (out.get("status"), details.get("stopped")):
        out.pop("why", None)
    if out.get("status") == "timeout":
        out.pop("details", None)  # how far the search got before its clock stopped it: a measure of speed
    elif isinstance(out.get("details"), dict):
        out["details"] = untimed(out["details"])
    return out


def untimed(details: dict) -> dict:
    """``details`` without its seconds (``*_s`` keys), nested objects included (the optimiser's ``time_s``)."""
    return {k: untimed(v) if isinstance(v, dict) else v for k, v in details.items() if not k.endswith("_s")}


# --- the results folder ----------------------------------------------------------------------------------------
def provenance(settings: dict) -> dict:
    """Where and how results come from: snakeplan version, git commit (None outside a checkout), Python,
    platform, start time (UTC) and the run's settings; the worker adds its host."""
    from snakeplan import __version__

    return {"snakeplan": __version__, "commit": git_commit(), "python": platform.python_version(),
            "platform": platform.platform(), "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
            "settings": settings}


def git_commit() -> str | None:
    """The commit of the checkout snakeplan runs from (``+dirty`` with uncommitted changes), or None."""
    root = Path(__file__).resolve().parents[3]
    if not (root / ".git").exists():
        return None
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True,
                              timeout=10, check=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=10, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return head + ("+dirty" if dirty else "")


def read_rows(folder: str | Path) -> list[dict]:
    """The complete rows of ``folder/runs.jsonl`` (a torn or unreadable last line is left out)."""
    rows, _ = _scan(Path(folder) / RUNS_FILE)
    return rows


#: A row's fields that name its run apart from the content of the files it names (scene, mesh, robot and policy
#: files).
SLOT_FIELDS = ("config", "task", "scene", "sensor", "seed", "robot", "planner", "options", "time_limit_s",
               "knowledge")


def current_rows(rows: list[dict]) -> tuple[list[dict], int]:
    """``rows`` without those a later row supersedes: the same run (:data:`SLOT_FIELDS`) planned again because a
    file it names changed (a policy retrained in place, a scene, mesh or robot file edited), which keys it anew;
    and how many were left out. A folder's report counts each run once, as it is now (two files of one scene or
    arm name in one folder count as one, as the report's entries already merge them)."""
    def slot(row: dict) -> str:
        return json.dumps({k: row.get(k) for k in SLOT_FIELDS}, sort_keys=True)

    last = {slot(r): i for i, r in enumerate(rows)}
    kept = [r for i, r in enumerate(rows) if last[slot(r)] == i]
    return kept, len(rows) - len(kept)


def _scan(path: Path) -> tuple[list[dict], int]:
    """(rows, byte length of the complete lines) of a runs file; only the last line may be torn."""
    if not path.exists():
        return [], 0
    data = path.read_bytes()
    rows, good = [], 0
    for line in data.splitlines(keepends=True):
        if not line.endswith(b"\n"):
            break
        try:
            row = json.loads(line)
        except ValueError:
            if good + len(line) == len(data):
                break
            raise ValueError(f"out: {path} line {len(rows) + 1} is not a JSON row (not a results folder?)") from None
        rows.append(row)
        good += len(line)
    return rows, good


class ResultsLog:
    """The rows file of a results folder, held by one writer (:meth:`open`)."""

    def __init__(self, folder: str | Path):
        self.folder = Path(folder)
        self.path = self.folder / RUNS_FILE
        self.rows: list[dict] = []
        self._fd: int | None = None

    @contextmanager
    def open(self, fresh: bool = False) -> Iterator[ResultsLog]:
        """Lock the folder (ValueError naming ``--out`` when another runner has it), cut a torn last line, load
        the rows; ``fresh`` forgets them first."""
        self.folder.mkdir(parents=True, exist_ok=True)
        with lock_folder(self.folder, "--out"):
            if fresh:
                self.path.unlink(missing_ok=True)
            self.rows, good = _scan(self.path)
            self._fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_APPEND, 0o644)
            try:
                if os.fstat(self._fd).st_size != good:
                    os.ftruncate(self._fd, good)
                    os.fsync(self._fd)
                yield self
            finally:
                os.close(self._fd)
                self._fd = None

    def done(self) -> set[str]:
        return {r["key"] for r in self.rows}

    def append(self, row: dict) -> None:
        """Append one row as one line in one write, fsync'ed; a long path goes to its sidecar file first."""
        if row.get("path") is not None and row["path_points"] > PATH_INLINE_POINTS:
            folder = self.folder / PATHS_FOLDER
            folder.mkdir(exist_ok=True)
            atomic_write(folder / f"{row['path_sha256']}.json", json.dumps({"path": row["path"]}))
            fsync_dir(folder)
            row = {**row, "path": None, "path_file": f"{PATHS_FOLDER}/{row['path_sha256']}.json"}
        line = (json.dumps(row, allow_nan=False) + "\n").encode()
        os.write(self._fd, line)
        os.fsync(self._fd)
        self.rows.append(row)


def row_path(folder: str | Path, row: dict) -> np.ndarray | None:
    """The tip path (m, 3) of a logged row, inline or from its sidecar file; None without one."""
    if row.get("path") is not None:
        return np.asarray(row["path"], dtype=float)
    if row.get("path_file"):
        return np.asarray(json.loads((Path(folder) / row["path_file"]).read_text())["path"], dtype=float)
    return None


@dataclass
class Outcome:
    """What :func:`run_sweep` did: the sweep's rows (logged before or now), how many it ran, wall time (s)."""

    rows: list[dict]
    ran: int
    skipped: int
    wall_s: float
    backend: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        return {**{k: v for k, v in asdict(self).items() if k != "rows"}, "runs": len(self.rows)}


def run_sweep(sweep: Sweep, out: str | Path, backend: Backend = Backend(), fresh: bool = False,
              progress: bool = True, runs: Iterable[Run] | None = None,
              on_row: Callable[[Run, dict], None] | None = None) -> Outcome:
    """Run every run of ``sweep`` (or ``runs``) that ``out`` does not hold yet on ``backend``, appending rows as
    tasks finish; returns the sweep's rows in the sweep's order. ``on_row(run, row)`` sees each new row once it is
    logged (a live view). SIGINT/SIGTERM stop at once (every row appended
    so far is whole and kept; the workers are stopped; :class:`~snakeplan.interrupt.Interrupted`, exit 130);
    rerunning resumes."""
    all_runs = list(sweep.runs() if runs is None else runs)
    log = ResultsLog(out)
    start, load = time.perf_counter(), loadavg()
    with log.open(fresh) as log:
        done = log.done()
        todo = [r for r in all_runs if r.key not in done]
        pending = {r.key: r for r in todo}
        stamp = provenance({"config": sweep.name, **backend.settings(), "argv": sys.argv[1:]})
        tasks = chunks(todo, backend.slots)

        def stopped() -> str:
            return f"interrupted: {len(log.rows)} runs in {log.path}; rerun the same command to resume"

        with streamed(run_chunk, tasks, backend, stamp, name=sweep.name, progress=progress, stopped=stopped,
                      total=len(todo)) as (stream, tick):
            for rows in stream:
                for row in rows:
                    log.append(row)
                    tick(f"{row['scene']} seed {row['seed']} {row['planner']}")
                    if on_row is not None:
                        on_row(pending[row["key"]], row)
        by_key = {r["key"]: r for r in log.rows}
        outcome = Outcome([by_key[r.key] for r in all_runs if r.key in by_key], len(todo),
                          len(all_runs) - len(todo), time.perf_counter() - start, backend.settings())
        _log_invocation(log.folder, stamp, outcome, load)
    return outcome


def _log_invocation(folder: Path, stamp: dict, outcome: Outcome, load: tuple[float, ...]) -> None:
    """Append what this invocation did (backend, runs, wall time, the machine's load averages before and after)
    to ``folder/invocations.jsonl``: the runner's own timing of a sweep."""
    entry = {"started": stamp["started"], "commit": stamp["commit"], **outcome.to_dict(), "host": socket.gethostname(),
             "cores": usable_cores(), "loadavg_before": list(load), "loadavg_after": list(loadavg())}
    with open(folder / INVOCATIONS_FILE, "a") as fh:
        fh.write(json.dumps(jsonable(entry)) + "\n")
        fh.flush()
        os.fsync(fh.fileno())


def loadavg() -> tuple[float, ...]:
    try:
        return os.getloadavg()
    except OSError:
        return ()
