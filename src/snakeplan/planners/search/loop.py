"""The loop every search planner flies (mm, s): explore, look, reach what was seen, explore on.

The planner is handed the scene's structure alone: obstacles through its sensed view, targets through
``problem.sight`` (:class:`snakeplan.world.search.TargetSight`), which answers the views of each branch flown with
the targets they see. The mission is a tree of follow-the-leader insertions from the entrance
(:mod:`snakeplan.planners.inspection.branches`), flown in the order the loop chooses them:

1. while a target seen is not yet reached (in the order they were seen), the reaching planner (``reach``: any
   registered reaching planner; one that needs the whole scene plans in what is known, then senses and checks)
   grows a branch from the entrance to it, up to :data:`REACH_TRIES` tries of :data:`REACH_TIME_S` each;
2. else the explorer (a subclass's :meth:`SearchPlanner.explorer`) proposes the next branch;
3. the branch is flown: its tip senses along it (later branches know what it met), its views are looked through.

It stops when every target is reached, the explorer has nothing left, the next branch would not fit the mission's
budget, or the time limit runs out. The plan's path is the branch that reached the last target (else the last one
flown); the judge (:mod:`snakeplan.evaluation.search`) finds again from the mission's views when each target was
seen and reached.
"""

from __future__ import annotations

import time
from abc import abstractmethod
from collections import Counter
from typing import ClassVar, Protocol

import numpy as np

from snakeplan.planners.base import Planner, Problem, Solution, Status
from snakeplan.planners.inspection.branches import (
    SENSED_REACH_PLANNER,
    Branch,
    BranchSource,
    mission_of,
    mission_time,
    reach_problem,
)
from snakeplan.planners.inspection.planner import ASSEMBLY_RESERVE_S, ASSEMBLY_RESERVE_SHARE
from snakeplan.scenes import Task

#: Time (s) the reaching planner may take for one try at a target seen, and tries per target.
REACH_TIME_S = 2.0
REACH_TRIES = 3
#: Time (s) of the reaching planner's warm-up plan.
WARM_UP_TIME_S = 0.2


class Explorer(Protocol):
    """Proposes the branches that explore: :meth:`next` the next one to fly (None: nothing left), :meth:`saw` each
    branch flown (the explorer's own or a reach)."""

    def next(self, deadline: float) -> Branch | None: ...

    def saw(self, branch: Branch) -> None: ...


class SearchPlanner(Planner):
    """The search loop (see the module) over a subclass's explorer; ``reach`` names the reaching planner that grows
    every branch (the explorer's towards its views, and each to a target seen)."""

    tasks: ClassVar[frozenset[Task]] = frozenset({Task.SEARCH})
    needs_full_scene: ClassVar[bool] = False

    def __init__(self, reach: str = SENSED_REACH_PLANNER) -> None:
        from snakeplan.planners.registry import PLANNERS, planner_names

        if reach not in PLANNERS or Task.REACH not in PLANNERS.get(reach).tasks:
            raise KeyError(f"reach: {reach!r} is not a reaching planner (known: {', '.join(planner_names('reach'))})")
        self.reach = reach

    @abstractmethod
    def explorer(self, source: BranchSource, flown: list[Branch], rng: np.random.Generator, deadline: float
                 ) -> Explorer:
        """The explorer of one plan: ``source`` grows branches, ``flown`` is the mission's branches so far (the
        loop's list, growing as it flies)."""

    def points(self, problem: Problem):
        """The points of interest the source's branches are scored on (None: what the problem knows of)."""
        return None

    def warm_key(self):
        return *super().warm_key(), self.reach

    def warm_up(self, problem: Problem) -> None:
        """The reaching planner's kernels and weights, through a short plan of its own (which warms it up first)
        towards a point ahead of the entrance."""
        super().warm_up(problem)
        from snakeplan.planners.registry import get_planner

        reach = get_planner(self.reach, optimize="none")  # as the legs' (inspection.branches.BranchSource)
        e = problem.scene.entrance
        view = problem.world.for_targets((e.position + 300.0 * e.direction)[None])
        reach.plan(reach_problem(problem, view, WARM_UP_TIME_S, reach.needs_full_scene))

    def _solve(self, problem: Problem, rng: np.random.Generator, deadline: float) -> Solution:
        seed = int(rng.integers(2**31))
        source = BranchSource(problem, seed, self.reach, self.points(problem))
        sight = problem.sight
        flown: list[Branch] = []
        reserve = min(ASSEMBLY_RESERVE_S, ASSEMBLY_RESERVE_SHARE * problem.time_limit_s)
        until = deadline - reserve
        explorer = self.explorer(source, flown, rng, until)
        budget, direction = problem.inspection.budget_s, problem.scene.entrance.direction
        seen: list[int] = []
        reached: dict[int, int] = {}
        tries: Counter[int] = Counter()
        ended = ""

        def fly(branch: Branch) -> bool:
            if mission_time(flown + [branch], problem.robot, direction) > budget:
                return False
            flown.append(branch)
            source.fly(branch)
            seen.extend(sight.look(branch.positions, branch.directions))
            explorer.saw(branch)
            return True

        while len(reached) < sight.count:
            if time.perf_counter() >= until:
                ended = "timeout"
                break
            pending = [k for k in seen if k not in reached and tries[k] < REACH_TRIES]
            if pending:
                k = pending[0]
                tries[k] += 1
                branch = source.branch_to(sight.position(k), until, REACH_TIME_S)
                if branch is None:
                    continue
                if not fly(branch):
                    ended = "budget"
                    break
                reached[k] = len(flown) - 1
                continue
            branch = explorer.next(until)
            if branch is None:
                ended = "timeout" if time.perf_counter() >= until else "explored"
                break
            if not fly(branch):
                ended = "budget"
                break
        mission = mission_of(flown, problem.robot, problem.inspection, direction, seed)
        details = {"reach_planner": self.reach, "branches": len(flown), "reach_calls": source.calls,
                   "seen_order": seen, "reached": sorted(reached), "reach_tries": dict(tries),
                   "mission_time_s": max((m.end_s for m in mission.motions), default=0.0)}
        why = {"timeout": f"the time limit of {problem.time_limit_s:g} s ran out",
               "budget": f"the next branch would not fit the mission's {budget:g} s",
               "explored": "the explorer had nothing left to look at"}.get(ended, "")
        if not flown:
            return Solution(Status.TIMEOUT if ended == "timeout" else Status.NO_PROGRESS, None, details,
                            f"{why} before any branch was flown ({source.calls} calls of the reaching planner)")
        last = flown[max(reached.values())] if reached else flown[-1]
        if len(reached) == sight.count:
            return Solution(Status.FOUND, last.path, details, mission=mission)
        details["stopped"] = str(Status.TIMEOUT if ended == "timeout" else Status.NO_PROGRESS)
        return Solution(Status.APPROXIMATE, last.path, details,
                        f"{why} with {len(seen)} of {sight.count} targets seen and {len(reached)} reached; the mission "
                        "so far is given", mission)
