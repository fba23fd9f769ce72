"""The planning problem, the plan, and the interface every planner implements.

A planner turns a :class:`Problem` into a :class:`Plan`: a tip path from the entrance. It never judges
itself; :func:`snakeplan.evaluation.evaluate` does, with the same rules for every planner.

Multi-target rule (decided once here, applied to every planner): targets are visited in the scene's order
(generators order them by geodesic distance from the entrance) along ONE continuous follow-the-leader path;
the arm does not retract between targets. A plan reaches target k when its tip path passes within the
judge's tolerance of it after reaching targets 0..k-1.
"""

from __future__ import annotations

import math
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field, replace
from typing import ClassVar, Literal

import numpy as np

from snakeplan.robots import Chain
from snakeplan.scenes import Scene
from snakeplan.world import DEFAULT_SENSOR_RANGE_MM, KnowledgeView, view_for

#: Default planning budget (s), the same for every planner in a comparison.
DEFAULT_TIME_LIMIT_S = 30.0

Knowledge = Literal["full", "sensed"]
STATUSES = ("found", "timeout", "failed")


@dataclass(frozen=True)
class Problem:
    """What to plan: a robot in a scene, from the entrance through the targets, within a time budget.

    ``knowledge`` says what the planner may use: ``"full"`` the whole scene, ``"sensed"`` only obstacles within
    ``sensor_range_mm`` of where the tip has been. ``world`` is the knowledge view that says it
    (:mod:`snakeplan.world.knowledge`; built from ``knowledge`` when not given): the only way a planner reaches
    obstacles. ``scene`` supplies the structure (bounds, entrance, targets).
    """

    scene: Scene
    robot: Chain
    time_limit_s: float = DEFAULT_TIME_LIMIT_S
    knowledge: Knowledge = "full"
    sensor_range_mm: float = DEFAULT_SENSOR_RANGE_MM
    world: KnowledgeView | None = None

    def __post_init__(self) -> None:
        if not (isinstance(self.time_limit_s, (int, float)) and math.isfinite(self.time_limit_s)
                and self.time_limit_s > 0):
            raise ValueError(f"time_limit: must be a positive number of seconds, got {self.time_limit_s!r}")
        if self.knowledge not in ("full", "sensed"):
            raise ValueError(f"knowledge: must be 'full' or 'sensed', got {self.knowledge!r}")
        if len(self.scene.targets) == 0:
            raise ValueError(f"scene: {self.scene.name} has no targets to plan to")
        if self.world is None:
            object.__setattr__(self, "world", view_for(self.scene, self.knowledge, self.sensor_range_mm))
        elif self.world.kind != self.knowledge:
            raise ValueError(f"world: a {self.world.kind} view does not match knowledge={self.knowledge!r}")

    @property
    def start(self) -> np.ndarray:
        return self.scene.entrance.position

    @property
    def goals(self) -> np.ndarray:
        """Targets in visiting order, ``(k, 3)`` mm."""
        return self.scene.targets


@dataclass
class Plan:
    """A planner's answer: the tip path (mm) or None, how it ended, and how long it took (s)."""

    planner: str
    status: str
    path: np.ndarray | None
    compute_time_s: float
    details: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.status not in STATUSES:
            raise ValueError(f"status: must be one of {STATUSES}, got {self.status!r}")


class Planner(ABC):
    """A motion planner for follow-the-leader tip paths. Subclasses set ``name`` and implement ``_solve``."""

    name: ClassVar[str] = ""
    #: Whether the planner needs the whole scene (it then refuses ``knowledge="sensed"`` problems).
    needs_full_scene: ClassVar[bool] = True

    def plan(self, problem: Problem, seed: int = 0) -> Plan:
        """Plan within ``problem.time_limit_s``; the wall time is measured here, the same way for all planners."""
        if self.needs_full_scene and problem.knowledge != "full":
            raise ValueError(f"knowledge: planner {self.name} needs the whole scene ('full')")
        problem = replace(problem, world=problem.world.fresh())  # every plan starts knowing only the prior
        t0 = time.perf_counter()
        status, path, details = self._solve(problem, np.random.default_rng(seed), t0 + problem.time_limit_s)
        return Plan(self.name, status, path, time.perf_counter() - t0, details)

    @abstractmethod
    def _solve(self, problem: Problem, rng: np.random.Generator, deadline: float
               ) -> tuple[str, np.ndarray | None, dict]:
        """Return (status, tip path or None, details); stop by ``deadline`` (a time.perf_counter() value)."""
