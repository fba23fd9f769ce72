"""The planning problem, the plan, and the interface every planner implements.

A planner turns a :class:`Problem` into a :class:`Plan`: a tip path from the entrance (reach), or the camera
path flown and its mission (inspect). It never judges itself; :func:`snakeplan.evaluation.judge` does, with the
same rules for every planner.
:func:`snakeplan.planners.check_planner` checks a planner against the contract stated in :class:`Planner`.

One problem shape whatever the task (after OMPL's ``ProblemDefinition`` and its goals): a :class:`Problem` says
its :class:`~snakeplan.scenes.Task`, reach the scene's targets or inspect its surface, and every planner declares
the tasks it does (``Planner.tasks``). A reach plan is a tip path; an inspect plan is the tip path flown and its
:class:`~snakeplan.world.mission.Mission`, the arm's motions and the views, which the judge replays.

Multi-target rule (decided once here, applied to every planner): targets are visited in the scene's order
(generators order them by geodesic distance from the entrance) along ONE continuous follow-the-leader path;
the arm does not retract between targets. A plan reaches target k when its tip path passes within the
judge's tolerance of it after reaching targets 0..k-1.
"""

from __future__ import annotations

import math
import time
from abc import ABC, abstractmethod
from collections.abc import Hashable
from dataclasses import dataclass, field, replace
from enum import StrEnum
from pathlib import Path
from typing import ClassVar, NamedTuple

import numpy as np

from snakeplan.geometry.polyline import validate_path
from snakeplan.optimize import optimize_path
from snakeplan.optimize import warm_up as warm_optimizer
from snakeplan.planners.input_states import invalid_start, invalid_target
from snakeplan.robots import Chain
from snakeplan.scenes import Scene, SceneSpec, Task, as_task, spec_for
from snakeplan.threads import single_threaded
from snakeplan.world import (
    DEFAULT_SENSOR_RANGE_MM,
    JUDGE,
    PLANNING,
    Knowledge,
    KnowledgeView,
    ValidityChecker,
    as_knowledge,
    view_for,
)
from snakeplan.world import mission as missions
from snakeplan.world.depth import DepthCamera, DepthView
from snakeplan.world.mission import InspectionSettings, Mission, inspected_surface
from snakeplan.world.search import TargetSight, hide_targets

#: The tip sensors of a sensed plan: exact whole-obstacle reveals, or a depth camera.
SENSORS = ("exact", "depth")
#: Default planning budget (s), the same for every planner in a comparison.
DEFAULT_TIME_LIMIT_S = 30.0



class Status(StrEnum):
    """How a plan ended, after OMPL's ``PlannerStatus`` (EXACT_SOLUTION, APPROXIMATE_SOLUTION, TIMEOUT,
    INVALID_START, INVALID_GOAL; its UNRECOGNIZED_GOAL_TYPE is a refused task here, a ValueError naming it).

    * ``found``: a path the planner's own checks accept;
    * ``approximate``: a best-effort path (``details["stopped"]`` says which of the two below stopped it);
    * ``timeout``: the time limit ran out;
    * ``no_progress``: the planner gave up before its time limit (its tree cannot grow, its policy is stuck...);
    * ``invalid_start``: no tip path can leave the entrance (:mod:`snakeplan.planners.input_states`);
    * ``invalid_target``: some target cannot be reached by the tip.

    A ``str`` so that JSON and CSV hold the plain value. ``"failed"``, written before the causes were told
    apart, reads as ``no_progress``; ``Status.FAILED`` is the same member.
    """

    FOUND = "found"
    APPROXIMATE = "approximate"
    TIMEOUT = "timeout"
    NO_PROGRESS = "no_progress"
    INVALID_START = "invalid_start"
    INVALID_TARGET = "invalid_target"
    FAILED = "no_progress"

    @classmethod
    def _missing_(cls, value):
        return cls.NO_PROGRESS if value == "failed" else None


#: Why an approximate plan stopped (its ``details["stopped"]``).
STOPPED = (Status.TIMEOUT, Status.NO_PROGRESS)
#: The statuses that carry a path.
WITH_PATH = (Status.FOUND, Status.APPROXIMATE)


class Solution(NamedTuple):
    """What :meth:`Planner._solve` returns: how it ended, the tip path or None, the planner's details, why it
    ended so (one line; required unless found), and for an inspect task the mission flown."""

    status: Status | str
    path: np.ndarray | None
    details: dict
    why: str = ""
    mission: Mission | None = None


@dataclass(frozen=True)
class Problem:
    """What to plan: a robot in a scene, its task, within a time budget.

    ``task``: reach the scene's targets from the entrance, inspect its surfaces (its field, or its points of
    interest; ``inspection`` says how the mission is flown and measured; None: the scene's and robot's defaults), or
    search for its targets (sensed knowledge only; the planner finds them through ``sight``, a
    :class:`~snakeplan.world.search.TargetSight` built from the scene, with the tip camera of ``inspection``); None
    takes the task of the scene's family (:func:`spec_for`).
    ``knowledge`` says what the planner may use: ``"full"`` the whole scene, ``"sensed"`` only what the tip sensor
    has sensed within ``sensor_range_mm`` of where the tip has been; ``sensor`` (:data:`SENSORS`) is that sensor:
    ``"exact"`` reveals whole obstacles exactly (:class:`~snakeplan.world.SensedView`), ``"depth"`` is a depth
    camera whose noisy returns are what is known (:class:`~snakeplan.world.depth.DepthView`, its default camera at
    that range). ``world`` is the knowledge view that says it
    (:mod:`snakeplan.world.knowledge`; built from ``knowledge`` when not given): the only way a planner reaches
    obstacles. ``scene`` supplies the structure (bounds, entrance, targets).
    """

    scene: Scene
    robot: Chain
    time_limit_s: float = DEFAULT_TIME_LIMIT_S
    knowledge: Knowledge | str = Knowledge.FULL
    sensor_range_mm: float = DEFAULT_SENSOR_RANGE_MM
    world: KnowledgeView | None = None
    task: Task | None = None
    inspection: InspectionSettings | None = None
    sight: TargetSight | None = None
    sensor: str = "exact"

    def __post_init__(self) -> None:
        if not _positive(self.time_limit_s):
            raise ValueError(f"time_limit_s: must be a positive number of seconds, got {self.time_limit_s!r}")
        object.__setattr__(self, "knowledge", as_knowledge(self.knowledge))
        if not isinstance(self.scene, Scene):
            raise ValueError(f"scene: must be a Scene, got {type(self.scene).__name__}")
        object.__setattr__(self, "task", spec_for(self.scene).task if self.task is None else as_task(self.task))
        if self.task is Task.REACH and len(self.scene.targets) == 0:
            raise ValueError(f"scene: {self.scene.name} has no targets to plan to")
        if self.task is Task.SEARCH and self.knowledge is not Knowledge.SENSED:
            raise ValueError("knowledge: a search task knows the scene only through its sensor and camera ('sensed')")
        if not isinstance(self.robot, Chain):
            raise ValueError(f"robot: must be a Chain, got {type(self.robot).__name__}")
        if self.inspection is None:
            object.__setattr__(self, "inspection", missions.default_settings(self.scene, self.robot))
        if not isinstance(self.inspection, InspectionSettings):
            raise ValueError(f"inspection: must be InspectionSettings, got {type(self.inspection).__name__}")
        if self.task is Task.SEARCH and not self.inspection.tip_camera:
            raise ValueError(f"task: a search looks with a fed arm's tip camera; scene {self.scene.name} maps a surface "
                             f"field from a camera path")
        if self.task is Task.INSPECT:
            if self.inspection.tip_camera:
                if not self.scene.obstacles:
                    raise ValueError(f"scene: {self.scene.name} has no surface to inspect (no obstacles)")
                _ = self.scene.points_of_interest  # sampled now: a bad inspect block is refused here
            else:
                inspected_surface(self.scene)  # a measurement clock maps a surface field (the station)
        if self.task is Task.SEARCH and self.sight is None:
            if len(self.scene.targets) == 0:
                raise ValueError(f"scene: {self.scene.name} has no targets to search for")
            object.__setattr__(self, "sight", TargetSight(self.scene.targets, self.scene.obstacle_set,
                                                          self.inspection.camera))
        if not _positive(self.sensor_range_mm):
            raise ValueError(f"sensor_range_mm: must be a positive number of mm, got {self.sensor_range_mm!r}")
        if self.sensor not in SENSORS:
            raise ValueError(f"sensor: must be one of {', '.join(SENSORS)}, got {self.sensor!r}")
        if self.sensor == "depth" and self.knowledge is not Knowledge.SENSED:
            raise ValueError("sensor: a depth camera senses; plan with knowledge 'sensed'")
        if self.world is None and self.sensor == "depth":
            object.__setattr__(self, "world", DepthView.of(self.scene, DepthCamera(range_mm=self.sensor_range_mm)))
        elif self.world is None:
            object.__setattr__(self, "world", view_for(self.scene, self.knowledge, self.sensor_range_mm))
        elif self.world.kind != self.knowledge:
            raise ValueError(f"world: a {self.world.kind} view does not match knowledge={self.knowledge!r}")

    @property
    def start(self) -> np.ndarray:
        return self.scene.entrance.position

    @property
    def goals(self) -> np.ndarray:
        """Targets in visiting order, ``(k, 3)`` mm (a search planner's raise: it finds them through ``sight``)."""
        return self.scene.targets

    def hidden(self) -> Problem:
        """The problem as a planner is handed it, before anything is sensed or seen: a search problem's scene with
        its targets hidden (:func:`snakeplan.world.search.hide_targets`) and a fresh sight of them."""
        if self.task is not Task.SEARCH:
            return replace(self, world=self.world.fresh())
        scene = hide_targets(self.scene)
        return replace(self, scene=scene, world=self.world.over(scene), sight=self.sight.fresh())


def _positive(value) -> bool:
    """Whether ``value`` is a finite positive number (not a bool)."""
    return (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
            and value > 0)


@dataclass(frozen=True)
class Plan:
    """A planner's answer: how it ended, the tip path (mm, ``(m, 3)``, m >= 2) or None, how long it took (s), and
    for an inspect task the mission flown (the arm's motions and the views; None for a reach plan).

    Status and path agree (checked here, ValueError naming the field):

    * ``FOUND``: a path that the planner's own checks accept;
    * ``APPROXIMATE``: a best-effort path that failed the planner's own checks (the judge may still accept
      it), with ``details["stopped"]`` saying why the planner stopped, ``"timeout"`` or ``"no_progress"``;
    * the others (:class:`Status`): no path.

    ``why``: one line saying why the plan ended so, given by every plan but a found one.
    """

    planner: str
    status: Status
    path: np.ndarray | None
    compute_time_s: float
    details: dict = field(default_factory=dict)
    mission: Mission | None = None
    why: str = ""

    def __post_init__(self) -> None:
        try:
            object.__setattr__(self, "status", Status(self.status))
        except ValueError:
            raise ValueError(f"status: must be one of {', '.join(s.value for s in Status)}, "
                             f"got {self.status!r}") from None
        if self.path is not None:
            object.__setattr__(self, "path", validate_path(self.path))
        if self.status in WITH_PATH and self.path is None:
            raise ValueError(f"path: a {self.status} plan needs a path")
        if self.status not in WITH_PATH and self.path is not None:
            raise ValueError(f"path: a {self.status} plan has no path (a best-effort path is 'approximate')")
        if self.status is Status.APPROXIMATE:
            stopped = self.details.get("stopped")
            if _status_or_none(stopped) not in STOPPED:
                raise ValueError(f"details: an approximate plan says why it stopped in details['stopped'] "
                                 f"({' or '.join(STOPPED)}), got {stopped!r}")
            self.details["stopped"] = Status(stopped)
        if not isinstance(self.why, str) or "\n" in self.why:
            raise ValueError(f"why: one line of text, got {self.why!r}")
        if self.status is not Status.FOUND and not self.why.strip():
            raise ValueError(f"why: a {self.status} plan says why it ended so")


def _status_or_none(value) -> Status | None:
    """``value`` as a :class:`Status` (an older file's "failed" included), or None."""
    try:
        return Status(value)
    except ValueError:
        return None


def input_refusal(problem: Problem) -> Solution | None:
    """An ``invalid_start`` or ``invalid_target`` solution, saying why, for a reach problem that no plan can
    solve in what the planner may know (:mod:`snakeplan.planners.input_states`); None otherwise (and for an
    inspect problem)."""
    if problem.task is not Task.REACH:
        return None
    arm = ValidityChecker(problem.world, problem.robot, JUDGE)
    for status, check in ((Status.INVALID_START, invalid_start), (Status.INVALID_TARGET, invalid_target)):
        why = check(problem.world, arm)
        if why is not None:
            return Solution(status, None, {}, why)
    return None


#: The :meth:`Planner.warm_key` of every planner whose :meth:`Planner.warm_up` has run in this process.
_WARM: set[Hashable] = set()


class Planner(ABC):
    """A motion planner for follow-the-leader tip paths. Subclasses set ``name`` and implement ``_solve``.

    The contract (:func:`snakeplan.planners.check_planner` checks it): a path starts at the entrance; status and
    path agree as :class:`Plan` says, and a found path passes the targets in order; ``plan`` returns within the
    time limit plus a small slack; the same problem and seed give the same plan, path equal to the bit; a problem
    the planner cannot take raises ValueError naming the field (``knowledge`` for a sensed problem given to a
    planner that ``needs_full_scene``).
    """

    name: ClassVar[str] = ""
    #: The tasks the planner does (a problem of another task is refused, naming both).
    tasks: ClassVar[frozenset[Task]] = frozenset({Task.REACH})
    #: Whether the planner needs the whole scene (it then refuses ``knowledge="sensed"`` problems).
    needs_full_scene: ClassVar[bool] = True
    #: Whether the planner rolls out a trained policy, given as ``policy=`` (a file; ``snakeplan plan --policy``).
    takes_policy: ClassVar[bool] = False
    #: How hard the path optimiser works on a found reach path (:data:`snakeplan.optimize.LEVELS`) unless the
    #: planner is made with ``optimize=`` (every planner takes it: :func:`snakeplan.planners.get_planner`):
    #: ``fast`` for the sampling planners, whose paths are rough; ``none`` for the others (the learned planners
    #: rank their own smoothings), so that each paper's method is what runs unless asked.
    default_optimize: ClassVar[str] = "none"
    #: This instance's level; None: ``default_optimize``.
    optimize: str | None = None

    @property
    def optimize_level(self) -> str:
        """The optimiser level this planner plans at: its own, else its class's default."""
        return self.optimize or self.default_optimize

    def plan(self, problem: Problem, seed: int = 0) -> Plan:
        """Plan within ``problem.time_limit_s``; the wall time is measured here, the same way for all planners,
        with BLAS/OpenMP on one thread (:mod:`snakeplan.threads`)."""
        self.check_task(problem.task)
        if self.needs_full_scene and problem.knowledge is not Knowledge.FULL:
            raise ValueError(f"knowledge: planner {self.name} needs the whole scene ('full')")
        fresh = problem.hidden  # every plan starts knowing only the prior, and nothing a warm-up saw
        problem = fresh()
        with single_threaded():
            key = self.warm_key()
            if key not in _WARM:
                self.warm_up(fresh())
                _WARM.add(key)
            t0 = time.perf_counter()
            refusal = input_refusal(problem)
            if refusal is not None:
                return Plan(self.name, refusal.status, None, time.perf_counter() - t0, refusal.details,
                            why=refusal.why)
            out = self._solve(problem, np.random.default_rng(seed), t0 + problem.time_limit_s)
            if not isinstance(out, Solution):  # a plain (status, path, details[, mission]) tuple: no why
                out = Solution(*out[:3], mission=out[3] if len(out) > 3 else None)
            out = self._optimized(problem, out, t0 + problem.time_limit_s)
            elapsed = time.perf_counter() - t0
        why = out.why
        if not why and Status(out.status) is Status.TIMEOUT:
            why = f"the time limit of {problem.time_limit_s:g} s ran out"
        return Plan(self.name, out.status, out.path, elapsed, out.details, out.mission, why)

    def _optimized(self, problem: Problem, out: Solution, deadline: float) -> Solution:
        """``out`` with its path optimised (:func:`snakeplan.optimize.optimize_path`) when it is a found reach path
        and this planner's level is not none; what the optimiser did goes in ``details["optimize"]``."""
        level = self.optimize_level
        if level == "none" or problem.task is not Task.REACH or Status(out.status) is not Status.FOUND:
            return out
        done = optimize_path(out.path, problem.world, problem.robot, problem.goals, level, deadline)
        return out._replace(path=done.path, details={**out.details, "optimize": done.to_dict()})

    def check_task(self, task: Task | str) -> None:
        """ValueError naming ``task`` (and the tasks this planner does) unless it does ``task``."""
        if as_task(task) not in self.tasks:
            raise ValueError(f"task: planner {self.name} does not {as_task(task)} (it does: "
                             f"{', '.join(sorted(t.value for t in self.tasks))})")

    def warm_key(self) -> Hashable:
        """What a warm-up loads is the same for every planner with this key: by default the class (a planner whose
        warm-up depends on an option, a search planner's reaching planner, adds it), with its optimiser level."""
        return type(self), self.optimize_level

    def warm_up(self, problem: Problem) -> None:
        """Load, before a process's first plan of this class is timed, what that plan would otherwise load
        inside ``compute_time_s`` (numba kernels from the cache, trained weights): a call of each kernel on a
        tiny input. The default warms the validity checker's kernels (:meth:`ValidityChecker.warm_up`); a planner
        with kernels of its own extends it. The problem given is a fresh copy, free to sense. A planner whose found
        reach paths are optimised warms the optimiser too (:func:`snakeplan.optimize.warm_up`)."""
        ValidityChecker(problem.world, problem.robot, PLANNING).warm_up()
        if self.optimize_level != "none" and problem.task is Task.REACH:
            warm_optimizer(problem.world, problem.robot)

    def policy_file(self, spec: SceneSpec, robot: Chain) -> Path | None:
        """The file of the trained policy this planner reads to plan ``robot`` in ``spec``'s family, or None (the
        default: none, or none it can name before planning). The benchmark runner keys each run by its content,
        so a policy retrained in place, or another shipped with a new snakeplan, is planned again on a rerun."""
        return None

    @abstractmethod
    def _solve(self, problem: Problem, rng: np.random.Generator, deadline: float) -> Solution | tuple:
        """Return a :class:`Solution` as :class:`Plan` says (a plain ``(status, path, details)`` tuple, with the
        mission fourth for an inspect task, is a solution that says no why: enough for found and timeout plans);
        stop by ``deadline`` (a time.perf_counter() value). A problem :func:`input_refusal` refuses never
        reaches it."""
