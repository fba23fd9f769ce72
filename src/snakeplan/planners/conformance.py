"""The planner conformance suite: :func:`check_planner` runs a planner on a few problems and checks the contract of
:class:`~snakeplan.planners.base.Planner`, in the spirit of Gymnasium's ``check_env``. It is public so that the
author of an outside planner can run it: ``check_planner(MyPlanner())``.

Rules (a :class:`ConformanceError` names the first one broken):

* ``runs``: ``plan`` returns a :class:`Plan`, named after the planner, for a well-formed problem in a scene the
  planner supports (``scenes``).
* ``entrance``: a path starts at the scene's entrance, within the judge's ``ENTRANCE_TOLERANCE_MM``.
* ``status-path``: the status is a :class:`Status` and agrees with the path as :class:`Plan` says, checked here
  afresh (a planner may override ``plan``): ``found`` and ``approximate`` carry a finite ``(m, 3)`` path, m >= 2,
  ``approximate`` with ``details["stopped"]`` ``"timeout"`` or ``"no_progress"``; the other statuses carry none.
  A ``found`` path passes every target in order within the judge's ``REACH_TOLERANCE_MM`` (what the checker can
  see of "the planner's own checks accept it").
* ``why``: every plan but a found one says why it ended so, in one line of text (``Plan.why``).
* ``deadline``: ``plan`` returns, on the checker's wall clock, within ``time_limit_s`` plus
  ``max(DEADLINE_SLACK_S, DEADLINE_SLACK_FRACTION * time_limit_s)``: for each problem after a first, warm-up plan
  (loading and compiling are not planning), and on a hard version of it (its last target walled in, so no plan
  exists) with ``TINY_TIME_LIMIT_S``.
* ``determinism``: the same problem and seed, planned twice by the same planner, give the same status and a path
  equal to the bit. Skipped (and said so in the report) when a run stopped on the clock, since where a search is
  cut off depends on the machine.
* ``honesty``: a planner that plans with sensed knowledge (``needs_full_scene`` False) plans each problem again with
  ``knowledge="sensed"`` and a scene whose obstacles raise when read (:func:`snakeplan.world.guarded`), so all it
  knows comes from the sensed view in ``problem.world``.
* ``malformed``: a malformed problem raises ValueError whose message starts with the field's name: a non-positive,
  NaN, infinite or non-numeric ``time_limit_s``, an unknown ``knowledge``, a non-positive ``sensor_range_mm``, a
  ``scene`` with no targets or that is not a Scene, a ``robot`` that is not a Chain, and, for a planner that
  ``needs_full_scene``, a ``knowledge="sensed"`` problem.

A planner that does not reach (an inspection planner) is checked on inspect problems instead (the station, a
short mission): ``runs``, ``status-path`` (a plan with a path carries its mission, with at least one view),
``determinism`` (the same path and views), ``malformed`` (the fields above, a ``scene`` with nothing to inspect),
and ``deadline`` on the planner's own calls (``details["planning_time_s"]``), which ``time_limit_s`` bounds for
an inspect task. The walled-in target is reaching's and is listed as skipped; ``entrance`` is not checked.

A search planner is checked on search problems (:data:`SEARCH_SCENES`, sensed knowledge): ``runs``, ``entrance``,
``status-path`` (its mission, with at least one view), ``deadline``, ``determinism``, ``malformed`` (the fields
above, ``knowledge="full"`` too) and ``honesty``: a search planner is handed the scene with its targets hidden and
its obstacles guarded (:meth:`Problem.hidden`), so a planner that reads a target before one of its views has seen
it, or an obstacle it has not sensed, raises, and the rule names it; and every pose it looked through for targets
(``problem.sight.looks``) must be a view of its mission.
"""

from __future__ import annotations

import dataclasses
import math
import re
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from snakeplan.geometry.primitives import Box
from snakeplan.planners.base import STOPPED, WITH_PATH, Plan, Planner, Problem, Status
from snakeplan.planners.registry import get_planner
from snakeplan.robots import get_robot
from snakeplan.scenes import Scene, Task, make_scene
from snakeplan.world import (
    ENTRANCE_TOLERANCE_MM,
    REACH_TOLERANCE_MM,
    SensedView,
    UnsensedObstacleError,
    guarded,
    targets_reached,
)
from snakeplan.world.mission import InspectionSettings, default_settings
from snakeplan.world.search import UnseenTargetError, looked_off_mission

#: The problems used when none are given: these scene families (seed ``scene_seed``) with this robot.
DEFAULT_SCENES = ("fuel-tank", "oil-tank")
DEFAULT_ROBOT = "sjtu-snake-iii"
#: Time limit (s) of the default problems.
DEFAULT_TIME_LIMIT_S = 5.0
#: The inspect problem of a planner that does not reach: this family (seed ``scene_seed``), robot and mission
#: budget (s).
INSPECT_SCENE = "station"
INSPECT_ROBOT = "hsr-10"
INSPECT_BUDGET_S = 10.0
#: A fed arm's inspect problem (the tip camera, a field to map), and its mission budget (s).
FED_SCENE = "thermal-tank"
FED_ROBOT = "sjtu-snake-iii"
FED_BUDGET_S = 120.0
#: A search planner's problems: these families (seed ``scene_seed``), sensed knowledge.
SEARCH_SCENES = ("oil-tank", "fuel-tank")
#: Time limit (s) of the hard problems of the deadline rule.
TINY_TIME_LIMIT_S = 0.05
#: Allowed overrun of the time limit: the larger of this (s) and this fraction of the limit.
DEADLINE_SLACK_S = 0.5
DEADLINE_SLACK_FRACTION = 0.2
#: Hard problem: free space (mm) from the last target to each wall of the closed box around it, and wall thickness.
ENCLOSURE_HALF_MM = 80.0
ENCLOSURE_WALL_MM = 10.0

RULES = ("runs", "entrance", "status-path", "deadline", "determinism", "honesty", "malformed")


class ConformanceError(AssertionError):
    """A planner broke a rule of the contract; ``rule`` is one of :data:`RULES`."""

    def __init__(self, rule: str, message: str):
        super().__init__(f"[{rule}] {message}")
        self.rule = rule


@dataclass(frozen=True)
class ConformanceReport:
    """What :func:`check_planner` ran: one line per plan it checked, and the checks it skipped with the reason."""

    planner: str
    plans: tuple[str, ...]
    skipped: tuple[str, ...]


def deadline_slack_s(time_limit_s: float) -> float:
    """Allowed overrun (s) of ``time_limit_s``."""
    return max(DEADLINE_SLACK_S, DEADLINE_SLACK_FRACTION * time_limit_s)


def default_problems(scenes: Sequence[str] = DEFAULT_SCENES, robot: str = DEFAULT_ROBOT, scene_seed: int = 1,
                     time_limit_s: float = DEFAULT_TIME_LIMIT_S) -> list[Problem]:
    """One full-knowledge problem per scene family: ``make_scene(name, scene_seed)`` with ``get_robot(robot)``."""
    chain = get_robot(robot)
    return [Problem(make_scene(name, scene_seed), chain, time_limit_s) for name in scenes]


def inspect_problems(planner: Planner, scene_seed: int, time_limit_s: float) -> list[Problem]:
    """An inspection planner's problems: the station's field from a camera path where it maps one, a fed arm's tip
    camera in the thermal tank where it does that (short budgets, so the check is quick)."""
    out = []
    if getattr(planner, "maps_fields", True):
        out.append(Problem(make_scene(INSPECT_SCENE, scene_seed), get_robot(INSPECT_ROBOT), time_limit_s,
                           task=Task.INSPECT, inspection=InspectionSettings(budget_s=INSPECT_BUDGET_S)))
    if getattr(planner, "fed", False):
        scene, robot = make_scene(FED_SCENE, scene_seed), get_robot(FED_ROBOT)
        settings = dataclasses.replace(default_settings(scene, robot), budget_s=FED_BUDGET_S)
        out.append(Problem(scene, robot, time_limit_s, task=Task.INSPECT, inspection=settings))
    return out


def search_problems(scene_seed: int, time_limit_s: float, robot: str = DEFAULT_ROBOT) -> list[Problem]:
    """A search planner's problems: :data:`SEARCH_SCENES` with sensed knowledge."""
    chain = get_robot(robot)
    return [Problem(make_scene(name, scene_seed), chain, time_limit_s, knowledge="sensed", task=Task.SEARCH)
            for name in SEARCH_SCENES]


def check_planner(planner: Planner | str, problems: Sequence[Problem] | None = None, *,
                  scenes: Sequence[str] = DEFAULT_SCENES, robot: str = DEFAULT_ROBOT, scene_seed: int = 1,
                  time_limit_s: float = DEFAULT_TIME_LIMIT_S, seed: int = 0) -> ConformanceReport:
    """Check ``planner`` (an instance, or a registered name) against the contract (module docstring) on
    ``problems``, by default :func:`default_problems` of ``scenes`` (the families the planner supports), ``robot``,
    ``scene_seed`` and ``time_limit_s``; plans with planner seed ``seed``. Raises :class:`ConformanceError` naming
    the first rule broken; returns what it ran."""
    if isinstance(planner, str):
        planner = get_planner(planner)
    if problems is None and Task.SEARCH in planner.tasks:
        problems = search_problems(scene_seed, time_limit_s, robot)
    elif problems is None and Task.REACH not in planner.tasks:
        problems = inspect_problems(planner, scene_seed, time_limit_s)
    elif problems is None:
        problems = default_problems(scenes, robot, scene_seed, time_limit_s)
    if not problems:
        raise ValueError("problems: at least one problem is needed")
    plans, skipped = [], []
    for problem in problems:
        where = _describe(problem)
        first = _plan(planner, problem, seed, where, timed=False)
        again = _plan(planner, problem, seed, where, timed=True)
        if _stopped_on_clock(first) or _stopped_on_clock(again):
            skipped.append(f"determinism on {where}: a run stopped on the clock ({first.status}, {again.status})")
        else:
            _check_same(first, again, where)
        if problem.task is not Task.REACH:
            plans.append(f"{where}: {first.status}")
            skipped.append(f"the walled-in target on {where}: a rule of the reach task")
            continue
        hard = dataclasses.replace(problem, scene=_enclose_last_target(problem.scene), time_limit_s=TINY_TIME_LIMIT_S,
                                   world=None)  # a view of the walled scene, not the old one
        tiny = _plan(planner, hard, seed, f"{where} with its last target walled in", timed=True)
        plans += [f"{where}: {first.status}", f"{where}, last target walled in, {TINY_TIME_LIMIT_S} s: {tiny.status}"]
        if not planner.needs_full_scene:
            plans.append(f"{where}, sensed through a guarded scene: {_check_honest(planner, problem, seed).status}")
    _check_malformed(planner, problems[0], seed)
    return ConformanceReport(planner.name, tuple(plans), tuple(skipped))


def _check_honest(planner: Planner, problem: Problem, seed: int) -> Plan:
    """Plan ``problem`` with sensed knowledge through a scene whose obstacles raise when read."""
    sensed = dataclasses.replace(problem, scene=guarded(problem.scene), knowledge="sensed",
                                 world=SensedView.of(problem.scene, problem.sensor_range_mm))
    try:
        return planner.plan(sensed, seed=seed)
    except UnsensedObstacleError as exc:
        raise ConformanceError("honesty", f"{planner.name} on {_describe(problem)}: {exc}") from exc


def _describe(problem: Problem) -> str:
    return (f"{problem.scene.name} seed {problem.scene.seed} ({problem.robot.name}, {problem.knowledge}, "
            f"{problem.time_limit_s:g} s)")


def _plan(planner: Planner, problem: Problem, seed: int, where: str, timed: bool) -> Plan:
    """Plan once and check the rules every plan must meet (runs, entrance, status-path; deadline when ``timed``)."""
    if problem.sight is not None:
        problem.sight.looks.clear()
    t0 = time.perf_counter()
    try:
        plan = planner.plan(problem, seed=seed)
    except (UnseenTargetError, UnsensedObstacleError) as exc:
        raise ConformanceError("honesty", f"{planner.name} on {where}: {exc}") from exc
    except Exception as exc:
        raise ConformanceError("runs", f"{planner.name} on {where} raised {type(exc).__name__}: {exc}") from exc
    wall = time.perf_counter() - t0
    if not isinstance(plan, Plan):
        raise ConformanceError("runs", f"{planner.name} on {where} returned {type(plan).__name__}, not a Plan")
    if plan.planner != planner.name:
        raise ConformanceError("runs", f"{planner.name} on {where} returned a plan named {plan.planner!r}")
    limit = problem.time_limit_s
    if problem.task is Task.INSPECT:
        wall = float(plan.details.get("planning_time_s", wall))
    if timed and wall > limit + deadline_slack_s(limit):
        raise ConformanceError("deadline", f"{planner.name} on {where} took {wall:.3f} s, more than the time limit "
                                           f"{limit:g} s + {deadline_slack_s(limit):g} s slack")
    _check_status_path(plan, problem, f"{planner.name} on {where}")
    if problem.sight is not None:
        off = looked_off_mission(problem.sight.looks, plan.mission.views) if plan.mission is not None else sum(
            len(p) for p, _ in problem.sight.looks)
        if off:
            raise ConformanceError("honesty", f"{planner.name} on {where} looked for targets from {off} poses its "
                                              f"mission never flies")
    return plan


def _check_status_path(plan: Plan, problem: Problem, where: str) -> None:
    if not isinstance(plan.status, Status):
        raise ConformanceError("status-path", f"{where}: status {plan.status!r} is not a Status")
    if plan.status is not Status.FOUND and not (isinstance(plan.why, str) and plan.why.strip()
                                                  and "\n" not in plan.why):
        raise ConformanceError("why", f"{where}: a {plan.status} plan gives no one-line why ({plan.why!r})")
    path = plan.path
    if plan.status not in WITH_PATH:
        if path is not None:
            raise ConformanceError("status-path", f"{where}: a {plan.status} plan carries a path")
        return
    if path is None:
        raise ConformanceError("status-path", f"{where}: a {plan.status} plan has no path")
    if not (isinstance(path, np.ndarray) and path.ndim == 2 and path.shape[1] == 3 and len(path) >= 2
            and np.all(np.isfinite(path))):
        raise ConformanceError("status-path", f"{where}: the path is not a finite (m, 3) array with m >= 2")
    if problem.task is not Task.REACH:
        if plan.mission is None or len(plan.mission.views) == 0:
            raise ConformanceError("status-path", f"{where}: an {problem.task} plan with a path carries no mission "
                                                  f"with a view")
        if problem.task is Task.INSPECT:
            return
    gap = float(np.linalg.norm(path[0] - problem.start))
    if gap > ENTRANCE_TOLERANCE_MM:
        raise ConformanceError("entrance", f"{where}: the path starts {gap:.3g} mm from the entrance")
    if problem.task is Task.SEARCH:
        return
    if plan.status is Status.APPROXIMATE and plan.details.get("stopped") not in STOPPED:
        raise ConformanceError("status-path", f"{where}: an approximate plan has details['stopped'] = "
                                              f"{plan.details.get('stopped')!r}, not 'timeout' or 'no_progress'")
    if plan.status is Status.FOUND:
        reached = targets_reached(path, problem.goals)
        if reached < len(problem.goals):
            raise ConformanceError("status-path", f"{where}: a found path passes only {reached} of the "
                                                  f"{len(problem.goals)} targets in order within "
                                                  f"{REACH_TOLERANCE_MM} mm")


def _stopped_on_clock(plan: Plan) -> bool:
    return plan.status is Status.TIMEOUT or plan.details.get("stopped") == Status.TIMEOUT


def _check_same(first: Plan, again: Plan, where: str) -> None:
    name = first.planner
    if first.status != again.status:
        raise ConformanceError("determinism", f"{name} on {where}: the same seed ended {first.status}, then "
                                              f"{again.status}")
    if (first.path is None) != (again.path is None) or (
            first.path is not None and (first.path.shape != again.path.shape
                                        or first.path.tobytes() != again.path.tobytes())):
        raise ConformanceError("determinism", f"{name} on {where}: the same seed gave two different paths")
    if first.mission is not None and (again.mission is None or first.mission.views.positions.tobytes()
                                      != again.mission.views.positions.tobytes()):
        raise ConformanceError("determinism", f"{name} on {where}: the same seed gave two different missions")


def _enclose_last_target(scene: Scene) -> Scene:
    """``scene`` with a closed box of walls around its last target: no plan exists, the planner stops on the clock."""
    target, inner = scene.targets[-1], ENCLOSURE_HALF_MM
    outer = inner + ENCLOSURE_WALL_MM
    walls = []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            centre = target.copy()
            centre[axis] += sign * (inner + ENCLOSURE_WALL_MM / 2)
            size = np.full(3, 2 * outer)
            size[axis] = ENCLOSURE_WALL_MM
            walls.append(Box(centre, size))
    return dataclasses.replace(scene, obstacles=[*scene.obstacles, *walls])


def _malformed(problem: Problem, needs_full_scene: bool) -> list[tuple[str, object, Callable[[], Problem]]]:
    """(field, value, builder) for each malformed problem derived from ``problem``."""
    scene = problem.scene
    fields = {"scene": scene, "robot": problem.robot, "time_limit_s": problem.time_limit_s,
              "knowledge": problem.knowledge, "sensor_range_mm": problem.sensor_range_mm, "task": problem.task,
              "inspection": problem.inspection}
    if problem.task is not Task.INSPECT:
        empty = dataclasses.replace(scene, targets=np.zeros((0, 3)))
    elif problem.inspection.tip_camera:
        empty = dataclasses.replace(scene, obstacles=(), discovered=(), inspect=None)
    else:
        empty = dataclasses.replace(scene, metadata={})
    cases: list[tuple[str, object]] = [
        ("time_limit_s", 0.0), ("time_limit_s", -1.0), ("time_limit_s", math.nan), ("time_limit_s", math.inf),
        ("time_limit_s", "1"), ("knowledge", "psychic"), ("sensor_range_mm", 0.0), ("sensor_range_mm", math.nan),
        ("scene", empty), ("scene", scene.name),
        ("robot", problem.robot.name)]
    if needs_full_scene:
        cases.append(("knowledge", "sensed"))
    if problem.task is Task.SEARCH:
        cases.append(("knowledge", "full"))
    return [(name, value, lambda name=name, value=value: Problem(**{**fields, name: value}))
            for name, value in cases]


def _check_malformed(planner: Planner, problem: Problem, seed: int) -> None:
    for name, value, build in _malformed(problem, planner.needs_full_scene):
        shown = f"{value.name} with nothing to {problem.task}" if isinstance(value, Scene) else repr(value)
        what = f"{planner.name} given {name} = {shown}"
        try:
            planner.plan(build(), seed=seed)
        except ValueError as exc:
            if not re.match(rf"{re.escape(name)}\b", str(exc)):
                raise ConformanceError("malformed", f"{what}: the ValueError does not start with the field name: "
                                                    f"{exc}") from exc
            continue
        except Exception as exc:
            raise ConformanceError("malformed", f"{what} raised {type(exc).__name__}, not ValueError: {exc}") from exc
        raise ConformanceError("malformed", f"{what} planned without a ValueError")
