"""The inputs a command reads from its options: scene, robot, tip path and planner; a mistake is a
:class:`~snakeplan.commands.common.UsageError` naming the option."""

from __future__ import annotations

import argparse
import inspect
import sys
from pathlib import Path
from typing import NamedTuple

import numpy as np

from snakeplan.commands.common import UsageError


def load_scene(args: argparse.Namespace, robot=None):
    """The scene of --scene-file, else of --scene and --seed sized to ``robot`` (:func:`generated`)."""
    from snakeplan.scenes import Scene

    if getattr(args, "scene_file", None):
        return Scene.from_json(read_text(args.scene_file, "--scene-file"), "--scene-file", scene_dir(args.scene_file))
    return generated(args.scene, args.seed, robot)


def plan_scene(args: argparse.Namespace, named: tuple[str, int] | None,
               fallback: tuple[str, int] | None = None, robot=None):
    """A plan file's scene: --scene-file's, else --scene and --seed, each defaulting to the scene the plan names
    (``named``: name, seed, or None), then to ``fallback``; a generated one sized to ``robot``."""
    from snakeplan.scenes import Scene

    if args.scene_file:
        return Scene.from_json(read_text(args.scene_file, "--scene-file"), "--scene-file", scene_dir(args.scene_file))
    name, scene_seed = args.scene, args.seed
    for default in (named, fallback):
        if default is not None:
            name = default[0] if name is None else name
            scene_seed = default[1] if scene_seed is None else scene_seed
    if name is None or scene_seed is None:
        raise UsageError("--scene: the plan names no generated scene; give --scene and --seed, or --scene-file")
    return generated(name, scene_seed, robot)


def generated(name: str, seed: int, robot=None):
    """Family ``name``'s scene of ``seed``, sized to ``robot`` where that is another arm than the family's
    (:mod:`snakeplan.scenes.sizing`; None: the family's own arm)."""
    from snakeplan.scenes import arm_sizing, sized_scene

    try:
        return sized_scene(name, seed, arm_sizing(name, robot))
    except KeyError as exc:
        raise UsageError(f"--scene: {exc.args[0]}") from None


def given_robot(args: argparse.Namespace, field: str = "--robot"):
    """The robot --robot names (a preset or a robot file), or None when it names none."""
    return load_robot(args.robot, field) if args.robot else None


def scene_dir(filename: str) -> Path:
    """The folder a scene file's mesh files are read relative to (the working directory for standard input)."""
    return Path(".") if filename == "-" else Path(filename).parent


def scene_robot(scene):
    """The robot the scene's spec says it is sized for."""
    from snakeplan.scenes import spec_for

    return load_robot(spec_for(scene).robot)


def scene_and_robot(args: argparse.Namespace):
    """(scene, robot): --scene-file's scene, else --scene and --seed sized to --robot; the arm --robot names, else
    the scene's own (:func:`scene_robot`)."""
    given = given_robot(args)
    scene = load_scene(args, given)
    return scene, given if given is not None else scene_robot(scene)


def load_robot(spec: str | dict, field: str = "--robot"):
    """A robot preset, robot file or robot/1 body."""
    from snakeplan.robots import load_robot as load

    try:
        return load(spec)
    except (KeyError, ValueError) as exc:
        raise UsageError(f"{field}: {exc.args[0]}") from None


def read_text(filename: str, field: str) -> str:
    """The UTF-8 text of ``filename`` ('-': standard input), at most :data:`snakeplan.inputs.MAX_INPUT_BYTES`."""
    from snakeplan.inputs import MAX_INPUT_BYTES

    where = "standard input" if filename == "-" else filename if filename.isprintable() else repr(filename)
    try:
        if filename == "-":
            data = sys.stdin.buffer.read(MAX_INPUT_BYTES + 1)
        else:
            with open(filename, "rb") as f:
                data = f.read(MAX_INPUT_BYTES + 1)
    except FileNotFoundError:
        raise UsageError(f"{field}: file not found: {where}") from None
    except OSError as exc:
        raise UsageError(f"{field}: cannot read {where}: {exc.__class__.__name__}") from None
    if len(data) > MAX_INPUT_BYTES:
        raise UsageError(f"{field}: {where} is larger than the {MAX_INPUT_BYTES // 2**20} MiB limit")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise UsageError(f"{field}: {where} is not UTF-8 text (byte {exc.start})") from None


def load_path_file(filename: str) -> np.ndarray:
    """Read ``{"path": [[x, y, z], ...]}`` (any plan file will do: other fields are ignored); at least 2 points of
    real numbers. ValueError names the field (``path[3][1]``), or ``PATH`` for the file as a whole."""
    return load_plan_file(filename)[0]


class PlanFile(NamedTuple):
    """A path or plan file: its path (m, 3) mm; the arm a plan document carries (its ``arm``, a robot) or None; an
    inspect or search plan's ``mission`` or None; its ``task`` or None; the generated scene it names, (name, seed),
    or None."""

    path: np.ndarray
    arm: object | None
    mission: object | None
    task: str | None
    scene: tuple[str, int] | None = None


def _named_scene(data: dict) -> tuple[str, int] | None:
    scene = data.get("scene")
    if not isinstance(scene, dict):
        return None
    name, seed = scene.get("name"), scene.get("seed")
    if isinstance(name, str) and isinstance(seed, int) and not isinstance(seed, bool) and seed >= 0:
        return name, seed
    return None


def load_plan_file(filename: str) -> PlanFile:
    """A path or plan file (the path as :func:`load_path_file` reads it). A bad ``arm``, ``mission`` or ``task`` is
    one line naming the field."""
    from snakeplan.inputs import load_json, points, show

    data = load_json(read_text(filename, "PATH"), "PATH")
    if not isinstance(data, dict):
        raise ValueError(f'PATH: expected an object with a "path" list of [x, y, z], got {show(data)}')
    if "path" not in data:
        raise ValueError('path: missing; PATH must hold an object with a "path" list of [x, y, z]')
    if data.get("path") == [] and isinstance(data.get("status"), str):
        why = data.get("why")
        raise ValueError(f"path: the plan holds none to judge: its planner ended {data['status']}"
                         + (f" ({why})" if isinstance(why, str) and why else ""))
    path = points(data["path"], "path", min_count=2)
    mission = None
    if data.get("mission") is not None:
        from snakeplan.world.mission import Mission

        try:
            mission = Mission.from_dict(data["mission"])
        except ValueError as exc:
            raise UsageError(str(exc)) from None
    task = data.get("task")
    if task is not None:
        from snakeplan.scenes import as_task

        task = str(as_task(task))
    arm = data.get("arm")
    if arm is not None and not isinstance(arm, dict):
        raise UsageError(f"arm: expected a snakeplan.robot/1 object, got {show(arm)}")
    return PlanFile(path, None if arm is None else load_robot(arm, "arm"), mission, task, _named_scene(data))


def load_planner(name: str, **options):
    """The registered planner ``name`` made with ``options`` (``optimize`` among them: every planner takes it)."""
    from snakeplan.planners.registry import PLANNERS, get_planner

    try:
        cls = PLANNERS.get(name)
    except KeyError as exc:
        raise UsageError(f"--planner: {exc.args[0]}") from None
    if "policy" in options and not cls.takes_policy:
        raise UsageError(f"--policy: planner {name} rolls out no trained policy")
    if "reach" in options and "reach" not in inspect.signature(cls).parameters:
        raise UsageError(f"--reach: planner {name} has no reaching planner to choose (the search planners do)")
    try:
        return get_planner(name, **options)
    except KeyError as exc:
        if "reach" in options:
            raise UsageError(f"--reach: {exc.args[0]}") from None
        raise
