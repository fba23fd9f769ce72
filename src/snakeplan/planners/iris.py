"""`iris`: an IRIS-style inspection planner for a fed arm, the anchor baseline of inspection planning.

After IRIS (Fu, Kuntz, Salzman, Alterovitz: "Toward asymptotically-optimal inspection planning via efficient
near-optimal graph search", RSS 2019; "Computationally-efficient roadmap-based inspection planning via incremental
lazy search", IJRR 2023): a roadmap of configurations, each with the points of interest it sees, and a near-optimal
graph search over (vertex, points seen so far) nodes whose approximate dominance keeps the search small.

For a fed arm the roadmap's configurations are branches, insertions from the entrance
(:mod:`snakeplan.planners.inspection.branches`), some grafted onto another branch's trunk, and an edge between two
is a retraction to where they part and an insertion along the next. The roadmap grows for ``ROADMAP_SHARE`` of the time limit: branches to goals drawn
anywhere free and facing points of interest not yet seen by any branch (the same reaching planner as every fed
inspection planner). The search then takes the rest: best first by points seen, a node (last branch, points seen,
mission time) expands by every branch not yet in it that fits the mission's budget, and a new node is dropped
when a kept node ending at the same branch has seen all but ``p`` of its points (a share ``P_SLACK`` of the points
of interest) in at most ``1 + EPSILON`` times its mission time: IRIS's (epsilon, p) approximate dominance. The best
node found (most points seen, then least time) is flown in its order.

Differences from IRIS, each because the arm is fed: the roadmap is a tree of insertions (every configuration is
reached from the entrance along its own branch, as follow-the-leader demands), so an edge's cost is the feed's
travel back to where two branches part and in again, not a straight-line motion; and the search ends at the time
limit, not at a proven bound. The roadmap grows until the clock stops it, so what iris flies depends on how far the
machine got: its plan always says it stopped on the clock (``approximate``, ``stopped: timeout``), and the same seed
gives the same plan only on the same machine under the same load.
"""

from __future__ import annotations

import heapq
import time

import numpy as np

from snakeplan.planners.inspection import InspectionPlanner
from snakeplan.planners.inspection.branches import Branch, BranchSource, mission_time, shared_length
from snakeplan.planners.registry import register_planner

#: Share of the time limit spent growing the roadmap; the search has the rest.
ROADMAP_SHARE = 0.6
#: IRIS's approximate dominance: time slack (relative) and points slack (share of the points of interest).
EPSILON = 0.1
P_SLACK = 0.01
#: Every how many roadmap branches one goes anywhere free (the others aim at a point not yet seen).
RANDOM_EVERY = 3


@register_planner
class IrisPlanner(InspectionPlanner):
    """Roadmap of branches + near-optimal inspection graph search (IRIS-style)."""

    name = "iris"
    fed = True
    maps_fields = False

    def roadmap(self, source: BranchSource, rng: np.random.Generator, until: float) -> list[Branch]:
        """Branches grown until ``until`` (a time.perf_counter() value)."""
        n = len(source.pois)
        seen = np.zeros(n, dtype=bool)
        tries = np.zeros(n, dtype=np.int64)
        out: list[Branch] = []
        k = 0
        while time.perf_counter() < until:
            k += 1
            aim = np.flatnonzero(~seen)
            if k % RANDOM_EVERY == 0 or aim.size == 0:
                goal = source.random_goal(rng)
            else:
                p = int(rng.choice(aim))
                goal = source.goal_facing(p, int(tries[p]))
                tries[p] += 1
            branch = source.grow(goal, out, rng, until)
            if branch is not None:
                out.append(branch)
                seen[branch.seen] = True
        return out

    def choose_branches(self, source: BranchSource, rng: np.random.Generator, deadline: float
                        ) -> tuple[list[Branch], bool]:
        start = time.perf_counter()
        roads = self.roadmap(source, rng, start + ROADMAP_SHARE * (deadline - start))
        if not roads:
            return [], False
        direction = source.scene.entrance.direction
        robot, budget = source.robot, source.problem.inspection.budget_s
        v = robot.limits.feed_speed_mm_s
        alone = np.array([mission_time([b], robot, direction) for b in roads])
        m = len(roads)
        saving = np.zeros((m + 1, m))  # row m: from the entrance
        for i in range(m):
            for j in range(m):
                if i != j:
                    saving[i, j] = 2.0 * shared_length(roads[i].path, roads[j].path) / v
        masks = [sum(1 << int(k) for k in b.seen) for b in roads]
        slack = int(P_SLACK * len(source.pois))
        kept: dict[int, list[tuple[int, float]]] = {}
        best: tuple[int, float, tuple[int, ...]] = (0, 0.0, ())
        heap = [(0, 0.0, 0, (), m)]  # (-points seen, time, seen mask, branches, last)
        while heap:
            if time.perf_counter() >= deadline:
                break
            neg, cost, mask, chosen, last = heapq.heappop(heap)
            if -neg > best[0] or (-neg == best[0] and cost < best[1]):
                best = (-neg, cost, chosen)
            for j in range(m):
                if j in chosen:
                    continue
                c = cost + alone[j] - saving[last, j]
                if c > budget:
                    continue
                new = mask | masks[j]
                count = new.bit_count()
                if count == -neg:
                    continue  # sees nothing new
                if any((new & ~s).bit_count() <= slack and t <= (1.0 + EPSILON) * c for s, t in kept.get(j, ())):
                    continue
                kept.setdefault(j, []).append((new, c))
                heapq.heappush(heap, (-count, c, new, chosen + (j,), j))
        tree = [roads[j] for j in best[2]]
        while tree and mission_time(tree, robot, direction) > budget:
            tree.pop()
        return tree, False
