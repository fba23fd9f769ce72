"""Scene families registered by name with their specs: ``make_scene("fuel-tank", seed=3)``, ``scene_spec("pipe")``.

A generator is a function ``(seed: int, **params) -> Scene`` that is deterministic in its seed on any machine
(it draws only from ``numpy.random.default_rng(seed)``). Its module registers it with ``@register_scene(name,
robot=..., planner=..., task=..., policies=...)``: the :class:`SceneSpec` is the one place that says which robot
the family is sized for, which planner plans in it by default, what the task is and which trained policies ship
for it. The command line, the benchmarks and training read these from the spec only.

A new scene family is its generator module: a plugin package names it by an entry point
(``scene.my-scene = my_pkg.scenes:my_scene``, see :mod:`snakeplan.registry`); a built-in one is listed in
``BUILTIN_SCENES`` so that it is imported only when asked for.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from importlib.resources import files
from pathlib import Path
from types import MappingProxyType

from snakeplan.registry import Registry, describe
from snakeplan.scenes.scene import Scene
from snakeplan.scenes.task import Task, as_task

SceneGenerator = Callable[..., Scene]



#: A spec's defaults where its family names none: the robot and, per task, the planner.
DEFAULT_ROBOT = "sjtu-snake-iii"
DEFAULT_PLANNER = {Task.REACH: "as-rrt", Task.INSPECT: "coverage", Task.SEARCH: "explore-reach"}

#: The families with a scanned family ``<family>-scan`` (:mod:`snakeplan.scenes.scan`).
SCANNED = ("confined", "fuel-tank", "oil-tank", "pipe", "concentric-pipe", "pipework", "vessel", "engine")

BUILTIN_SCENES = {
    "fuel-tank": "snakeplan.scenes.fuel_tank:fuel_tank",
    "thermal-tank": "snakeplan.scenes.fuel_tank:thermal_tank",
    "oil-tank": "snakeplan.scenes.oil_tank:oil_tank",
    "confined": "snakeplan.scenes.confined:confined",
    "pipe": "snakeplan.scenes.pipe:pipe",
    "concentric-pipe": "snakeplan.scenes.pipe:concentric_pipe",
    "station": "snakeplan.scenes.station:station",
    "pipework": "snakeplan.scenes.mesh_families:pipework",
    "vessel": "snakeplan.scenes.mesh_families:vessel",
    "engine": "snakeplan.scenes.mesh_families:engine",
    **{f"{of}-scan": f"snakeplan.scenes.scan:{of.replace('-', '_')}_scan" for of in SCANNED},
}


@dataclass(frozen=True)
class SceneSpec:
    """What goes with a scene family.

    ``robot``: the robot preset it is sized for (used when none is named). ``planner``: the planner used when
    none is named (an inspection planner for ``task="inspect"``). ``task``: one of :data:`snakeplan.scenes.task.TASKS`.
    ``policies``: planner name -> the trained policy file that ships for this family, as ``"package:path"``
    (a path inside an installed package, e.g. ``"snakeplan:rl/data/fuel-tank-sac-her.npz"``).
    ``made_from``: the family this one is made from, seed for seed (a scan of it), where a plan is also judged
    (:mod:`snakeplan.scenes.scan`); empty for a family of its own.
    ``generator`` is None for a scene read from a file whose family is not registered.
    """

    name: str
    generator: SceneGenerator | None = None
    robot: str = DEFAULT_ROBOT
    planner: str = ""
    task: Task = Task.REACH
    policies: Mapping[str, str] = field(default_factory=dict)
    made_from: str = ""

    def __post_init__(self) -> None:
        object.__setattr__(self, "task", as_task(self.task))
        for planner, ref in self.policies.items():
            if ":" not in ref:
                raise ValueError(f"policies[{planner!r}]: expected 'package:path', got {ref!r}")
        object.__setattr__(self, "planner", self.planner or DEFAULT_PLANNER[self.task])
        object.__setattr__(self, "policies", MappingProxyType(dict(self.policies)))

    def planner_for(self, task: Task | str) -> str:
        """The planner used when none is named for ``task``: this family's for its own task, else the default."""
        task = as_task(task)
        return self.planner if task is self.task else DEFAULT_PLANNER[task]

    def policy_path(self, planner: str) -> Path | None:
        """The file of the policy that ships for ``planner`` in this family, or None when none ships."""
        ref = self.policies.get(planner)
        if ref is None:
            return None
        package, _, path = ref.partition(":")
        return Path(str(files(package).joinpath(*path.split("/"))))


def _as_spec(name: str, obj) -> SceneSpec:
    """An entry-point object its module did not register: a spec, or a bare generator with the default spec."""
    if isinstance(obj, SceneSpec):
        return obj
    if not callable(obj):
        raise ValueError(f"{describe(obj)} is neither a generator nor a SceneSpec")
    return SceneSpec(name, obj)


SCENES: Registry[SceneSpec] = Registry("scene", BUILTIN_SCENES, load=_as_spec)


def register_scene(name: str, *, robot: str = DEFAULT_ROBOT, planner: str = "", task: Task | str = Task.REACH,
                   policies: Mapping[str, str] | None = None, made_from: str = ""
                   ) -> Callable[[SceneGenerator], SceneGenerator]:
    """Decorator that registers a generator under ``name`` with its spec (see :class:`SceneSpec`; names are
    unique)."""

    def wrap(fn: SceneGenerator) -> SceneGenerator:
        SCENES.register(name, SceneSpec(name, fn, robot, planner, task, policies or {}, made_from), describe(fn))
        return fn

    return wrap


def scene_names() -> list[str]:
    """Names of all registered scenes."""
    return SCENES.names()


def scene_spec(name: str) -> SceneSpec:
    """The spec of scene family ``name``; KeyError lists the known names for an unknown one."""
    return SCENES.get(name)


def spec_for(scene: Scene) -> SceneSpec:
    """The spec of ``scene``'s family; the default spec when the family is not registered (a scene file), whose
    task is inspect when the file has an ``inspect`` block and no targets. A scene that names its ``task`` (a file's
    ``"task"``) has it, with that task's default planner where it differs from its family's."""
    if scene.name in SCENES:
        spec = scene_spec(scene.name)
    else:
        inspects = scene.inspect is not None and len(scene.targets) == 0
        spec = SceneSpec(scene.name, task=Task.INSPECT if inspects else Task.REACH)
    if scene.task is None or scene.task is spec.task:
        return spec
    return replace(spec, task=scene.task, planner=DEFAULT_PLANNER[scene.task])


def make_scene(name: str, seed: int = 0, **params) -> Scene:
    """Generate scene ``name`` from ``seed``, its spec's robot in ``metadata["robot"]``; KeyError lists the
    known names for an unknown one."""
    spec = scene_spec(name)
    if not isinstance(seed, int) or isinstance(seed, bool) or seed < 0:
        raise ValueError(f"seed: expected a non-negative integer, got {seed!r}")
    scene = spec.generator(seed, **params)
    return replace(scene, metadata={**scene.metadata, "robot": spec.robot})
