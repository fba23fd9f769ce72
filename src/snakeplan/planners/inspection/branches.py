"""A fed arm's inspection mission as a tree of follow-the-leader insertions (mm, rad, s).

The arm enters through the port and looks with its tip camera. It can only move along its own body's path: insert
along a branch, looking as it goes, retract along the same path to where the next branch leaves it, insert along
that one; at the end it comes back out. A :class:`Branch` is one insertion from the entrance: a tip path a reaching
planner found (reused from the planner registry, so every reaching planner can grow the tree), the views along it
(every :data:`VIEW_STEP_MM` of insertion, the camera on the tip looking along the last section's axis) and the
points of interest they see. :func:`mission_of` turns an ordered list of branches into the
:class:`~snakeplan.world.mission.Mission` the judge replays: one :class:`~snakeplan.world.mission.Crawl` per
branch, inserting from where it leaves the previous one's path and retracting to where the next one leaves it.

Mission time comes from the robot's limits: between two depth samples the feed moves no faster than its speed
limit, and no bend changes faster than the joint rate limit (a bend's change bounds its joints' from below).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from snakeplan import ftl
from snakeplan.geometry.polyline import cumulative_length
from snakeplan.geometry.surface_points import SurfacePoints
from snakeplan.mapping.camera import Sightings
from snakeplan.planners.base import Problem
from snakeplan.robots import Chain
from snakeplan.world import PLANNING, Knowledge, KnowledgeView, ValidityChecker
from snakeplan.world.mission import Crawl, InspectionSettings, Mission, Views, tip_poses
from snakeplan.world.sight import PoiCamera

#: Insertion (mm) between two views along a branch.
VIEW_STEP_MM = 50.0
#: How long (s) the reaching planner may take for one branch (a reachable goal takes 10-50 ms in the tanks, a few
#: hundred in the mesh families; most of a failed one's time is wasted).
BRANCH_TIME_S = 1.0
#: The reaching planner that grows branches, with the whole scene known and with sensed knowledge.
REACH_PLANNER = "rrt-star"
SENSED_REACH_PLANNER = "as-rrt"
#: Goal stand-offs off a point of interest, as shares of the camera's range, tried in turn (a far goal sees more
#: round it, a near one fits where a far one is blocked).
STANDOFF_SHARES = (0.5, 0.3, 0.15, 0.08)
#: Clearance (mm) a goal keeps beyond the tip's radius.
GOAL_CLEARANCE_MM = 15.0
#: A graft leaves its trunk this far (mm) back from the trunk's view nearest its goal, and runs straight along the
#: trunk's heading this far (mm) before it may turn (the fillet's room).
GRAFT_BACKOFF_MM = 150.0
GRAFT_LEAD_MM = 120.0
#: Share of the goals first tried as a graft onto the grown branch that passes nearest them.
GRAFT_SHARE = 0.5
#: Spacing (mm) of the points along a flown path at which the tip senses (well within the sensor's 400 mm range).
SENSE_STEP_MM = 20.0
#: Plans a reaching planner that needs the whole scene makes for one goal in a sensed problem (plan, sense, replan).
KNOWN_REPLANS = 3


@dataclass(frozen=True)
class Branch:
    """One insertion from the entrance: the tip path (m, 3) mm, the depths (k,) mm of its views, their positions
    (k, 3) mm and directions (k, 3), the indices of the points of interest they see, and each sighting (view,
    point, distance mm)."""

    path: np.ndarray
    depths: np.ndarray
    positions: np.ndarray
    directions: np.ndarray
    seen: np.ndarray
    sightings: Sightings

    @property
    def length(self) -> float:
        return float(self.depths[-1])


def shared_length(a: np.ndarray, b: np.ndarray) -> float:
    """How far (mm) from the entrance tip paths ``a`` and ``b`` run together: the arc length of their common
    leading vertices (identical points), so the arm inserted along one is inserted along the other that far."""
    n = min(len(a), len(b))
    same = np.all(a[:n] == b[:n], axis=1)
    k = n if same.all() else int(np.argmin(same))
    return float(cumulative_length(a[:k])[-1]) if k >= 2 else 0.0


class BranchSource:
    """Grows branches for one problem: goals near points of interest or anywhere free, reached by the reaching
    planner :data:`REACH_PLANNER` from the entrance (:data:`SENSED_REACH_PLANNER` with sensed knowledge: it plans
    in what the tip has sensed, and each branch starts knowing the prior structure), and what each branch's views
    see of the points the planner knows of (with sensed knowledge: points on the known surfaces alone, drawn
    again, since those on clutter nobody has seen would give the clutter away; the judge counts the task's own)."""

    def __init__(self, problem: Problem, seed: int, reach: str | None = None, pois: SurfacePoints | None = None
                 ) -> None:
        from snakeplan.planners.registry import get_planner

        self.problem = problem
        self.scene = problem.scene
        self.robot: Chain = problem.robot
        self.sensed = problem.knowledge is not Knowledge.FULL
        if pois is None:
            pois = known_points(problem) if self.sensed else problem.scene.points_of_interest
        self.pois = pois
        self.camera = PoiCamera(problem.world.obstacle_set, self.pois, problem.inspection.camera)
        # a mission's legs are its reaching planner's own paths: the optimiser would spend the mission's time
        self.reach = get_planner(reach or (SENSED_REACH_PLANNER if self.sensed else REACH_PLANNER), optimize="none")
        self.seed = seed
        self.calls = 0
        self.clearance = self.robot.radii[-1] + GOAL_CLEARANCE_MM
        self._arm: ValidityChecker | None = None

    def free(self, points: np.ndarray) -> np.ndarray:
        """Where a goal may lie: inside the bounds and clear of every known obstacle by the goal clearance."""
        p = np.atleast_2d(points)
        return self.scene.in_bounds(p, self.clearance) & (
            self.problem.world.obstacle_set.signed_distance(p) >= self.clearance)

    def goal_facing(self, k: int, attempt: int = 0) -> np.ndarray | None:
        """A goal from which the camera could see point of interest ``k``: off it along its normal line (on the free
        side), at the stand-offs of :data:`STANDOFF_SHARES` from the ``attempt``-th on (round), the first that is
        free; None if none is."""
        p, n = self.pois.points[k], self.pois.normals[k]
        d_max = self.problem.inspection.camera.d_max
        shares = np.roll(STANDOFF_SHARES, -attempt)
        cands = np.array([p + sign * n * share * d_max for share in shares for sign in (1.0, -1.0)])
        ok = np.flatnonzero(self.free(cands))
        return cands[ok[0]] if ok.size else None

    def random_goal(self, rng: np.random.Generator, tries: int = 64) -> np.ndarray | None:
        """A goal drawn uniformly from the free part of the bounds (None after ``tries`` misses)."""
        pts = rng.uniform(self.scene.bounds_min, self.scene.bounds_max, size=(tries, 3))
        ok = np.flatnonzero(self.free(pts))
        return pts[ok[0]] if ok.size else None

    def branch_to(self, goal: np.ndarray, deadline: float, time_s: float = BRANCH_TIME_S) -> Branch | None:
        """The branch the reaching planner finds from the entrance to ``goal`` within ``time_s`` (and ``deadline``,
        a time.perf_counter() value), or None. With sensed knowledge it starts from what the problem's view knows
        (:meth:`snakeplan.world.KnowledgeView.for_targets`); a reaching planner that needs the whole scene plans in
        the obstacles known (:meth:`_in_known`)."""
        import time

        until = min(time.perf_counter() + time_s, deadline)
        if until - time.perf_counter() <= 0.05:
            return None
        if self.sensed and self.reach.needs_full_scene:
            path = self._in_known(goal, until)
            return None if path is None else self.branch(path)
        view = self.problem.world.for_targets(goal[None])
        plan = self.reach.plan(reach_problem(self.problem, view, until - time.perf_counter(), False),
                               seed=self.seed + self.calls)
        self.calls += 1
        if plan.status != "found":
            return None
        return self.branch(plan.path)

    def _in_known(self, goal: np.ndarray, until: float) -> np.ndarray | None:
        """A path to ``goal`` by a reaching planner that needs the whole scene, in a sensed problem: planned in a
        scene of the obstacles known, then checked against what the tip senses along it (every
        :data:`SENSE_STEP_MM`) under ``PLANNING``, and planned again in what is known then, at most
        :data:`KNOWN_REPLANS` times (the classic plan, sense, replan); None when none holds by ``until``. It senses
        in a view of its own that starts from what the problem's knows (as a sensing reaching planner's plan does):
        only a branch flown tells the mission (:meth:`fly`)."""
        import time

        from snakeplan.geometry.polyline import densify

        view = self.problem.world.for_targets(goal[None])
        arm = ValidityChecker(view, self.robot, PLANNING)
        for _ in range(KNOWN_REPLANS):
            left = until - time.perf_counter()
            if left <= 0.05:
                return None
            plan = self.reach.plan(reach_problem(self.problem, view, left, True), seed=self.seed + self.calls)
            self.calls += 1
            if plan.status != "found":
                return None
            view.sense(densify(plan.path, SENSE_STEP_MM))
            if arm.first_failure(plan.path) is None:
                return plan.path
        return None

    def fly(self, branch: Branch) -> None:
        """What the tip senses along ``branch`` as the arm is inserted along it, into the problem's view (a sensed
        mission's later branches start knowing it)."""
        from snakeplan.geometry.polyline import densify

        self.problem.world.sense(densify(branch.path, SENSE_STEP_MM))

    def grow(self, goal: np.ndarray | None, grown: list[Branch], rng: np.random.Generator, deadline: float
             ) -> Branch | None:
        """A branch to ``goal`` (None: none): with chance :data:`GRAFT_SHARE`, first a graft onto the branch of
        ``grown`` that passes nearest it, else (or when the graft fails) one from the entrance."""
        if goal is None:
            return None
        branch = None
        if grown and rng.random() < GRAFT_SHARE:
            trunk = min(grown, key=lambda b: float(np.min(np.linalg.norm(b.positions - goal, axis=1))))
            branch = self.graft(trunk, goal, deadline)
        return branch if branch is not None else self.branch_to(goal, deadline)

    def graft(self, trunk: Branch, goal: np.ndarray, deadline: float) -> Branch | None:
        """A branch that leaves ``trunk`` (a branch of the tree) and goes on to ``goal``: the trunk's path up to
        :data:`GRAFT_BACKOFF_MM` before its view nearest the goal, straight on along its heading for
        :data:`GRAFT_LEAD_MM`, then the leg the compiled RRT* finds (shortcut and filleted within the arm's turning
        radius, as ``rrt-star`` smooths its own); None when no leg is found in :data:`BRANCH_TIME_S` or the whole
        path fails the crawl check. Its retraction back to the trunk is all a mission pays for it beyond the trunk.
        The whole scene only (RRT* plans in it)."""
        import time

        from snakeplan.geometry.polyline import densify, drop_duplicates, fillet, point_at
        from snakeplan.planners import rrt_star, tip_rrt_star

        left = min(BRANCH_TIME_S, deadline - time.perf_counter())
        if self.sensed or left <= 0.05:
            return None
        arm = self._checker()
        cum = cumulative_length(trunk.path)
        near = int(np.argmin(np.linalg.norm(trunk.positions - goal, axis=1)))
        depth = max(float(trunk.depths[near]) - GRAFT_BACKOFF_MM, float(cum[1]) if len(cum) > 1 else 0.0)
        i = min(int(np.searchsorted(cum, depth, side="right")) - 1, len(cum) - 2)
        heading = trunk.path[i + 1] - trunk.path[i]
        start = point_at(trunk.path, depth)
        lead = start + GRAFT_LEAD_MM * heading / np.linalg.norm(heading)
        if not bool(arm.segment_free(start[None], lead[None])[0]):
            return None
        tip_rrt_star.seed_stream(self.seed + self.calls)
        self.calls += 1
        leg, _ = tip_rrt_star.plan_leg(arm, lead, goal, arm.tip_radius, time.perf_counter() + left, rrt_star.RANGE_MM,
                                       rrt_star.GOAL_BIAS, rrt_star.IMPROVE_ITERATIONS)
        if leg is None:
            return None
        radius = arm.tip_radius + rrt_star.SHORTCUT_MARGINS_MM[0]
        corners = [start, *rrt_star.shortcut(arm, densify(leg, rrt_star.SHORTCUT_STEP_MM), radius)]
        tail = fillet(np.array(corners), arm.turn_radius * rrt_star.RADIUS_FACTOR, rrt_star.ARC_STEP_MM)
        path = drop_duplicates(np.vstack([trunk.path[cum < depth], tail]))
        if not (np.all(arm.segment_free(path[:-1], path[1:])) and arm.first_failure(path) is None):
            return None
        return self.branch(path)

    def _checker(self) -> ValidityChecker:
        """The planning profile's validity checker of this problem's robot in what the planner knows."""
        if self._arm is None:
            self._arm = ValidityChecker(self.problem.world, self.robot, PLANNING)
        return self._arm

    def branch(self, path: np.ndarray) -> Branch:
        """The branch along ``path``: views every :data:`VIEW_STEP_MM` of insertion once the tip is past the
        entrance, and what they see."""
        length = float(cumulative_length(path)[-1])
        depths = np.unique(np.r_[np.arange(VIEW_STEP_MM, length, VIEW_STEP_MM), length])
        pos, axes = tip_poses(path, depths, self.robot.lengths, self.scene.entrance.direction)
        sight = self.camera.visible(pos, axes)
        return Branch(np.asarray(path, dtype=float), depths, pos, axes, np.unique(sight.node), sight)


def reach_problem(problem: Problem, view: KnowledgeView, time_s: float, whole_scene: bool) -> Problem:
    """The reach problem, within ``time_s``, of a branch of ``problem`` to the target of ``view`` (the problem's view
    retargeted, :meth:`snakeplan.world.KnowledgeView.for_targets`); ``whole_scene``: a scene of the obstacles
    ``view`` knows, with full knowledge of it, for a reaching planner that needs the whole scene."""
    if not whole_scene:
        return Problem(view.scene, problem.robot, time_limit_s=time_s, knowledge=problem.knowledge,
                       sensor_range_mm=problem.sensor_range_mm, world=view.fresh(), task="reach")
    from snakeplan.scenes import Scene

    s = view.scene
    known = Scene(s.name, s.seed, s.bounds_min, s.bounds_max, s.entrance, s.targets, view.obstacle_set.obstacles,
                  s.metadata)
    return Problem(known, problem.robot, time_limit_s=time_s, task="reach")


def known_points(problem: Problem):
    """Points of interest on the surfaces a sensed planner knows before the job (the prior structure): those of the
    task's ``inspect`` block (its indices are the scene's; the known obstacles are its prior ones, in order), in its
    region, at its spacing (or about as many per area as the task's default)."""
    from snakeplan.geometry.surface_points import sample_surfaces
    from snakeplan.scenes.inspect import InspectSpec

    scene = problem.scene
    known = list(problem.world.obstacle_set.obstacles)
    spec = scene.inspect or InspectSpec()
    discovered = set(scene.discovered)
    prior = [k for k in range(len(known) + len(discovered)) if k not in discovered]
    named = set(spec.obstacles(len(prior) + len(discovered)))
    which = [i for i, k in enumerate(prior) if k in named]
    return sample_surfaces(known, which, spec.spacing(known, which),
                           spec.region or (scene.bounds_min, scene.bounds_max))


def _timed(path: np.ndarray, depths: np.ndarray, robot: Chain, entrance_direction: np.ndarray) -> np.ndarray:
    """Times (s, from 0) at which the feed passes ``depths`` along ``path``: each step as slow as the feed speed
    limit and the joint rate limit (on the bends' change) ask."""
    bends = ftl.fit_states(path, robot.lengths, depths, entrance_direction).bend_angles
    limits = robot.limits
    step = np.maximum(np.abs(np.diff(depths)) / limits.feed_speed_mm_s,
                      np.abs(np.diff(bends, axis=0)).max(axis=1, initial=0.0) / limits.joint_rate_rad_s)
    return np.r_[0.0, np.cumsum(step)]


def mission_of(branches: list[Branch], robot: Chain, settings: InspectionSettings, entrance_direction: np.ndarray,
               seed: int) -> Mission:
    """The mission that flies ``branches`` in order (see the module): one crawl per branch, inserting from where it
    leaves the previous branch's path, looking at each view depth, retracting (through the same depths) to where
    the next branch leaves it, the last one all the way out."""
    motions, times, positions, directions = [], [], [], []
    now = 0.0
    for i, b in enumerate(branches):
        start = shared_length(branches[i - 1].path, b.path) if i else 0.0
        end = shared_length(b.path, branches[i + 1].path) if i + 1 < len(branches) else 0.0
        inward = b.depths[b.depths > start]
        outward = b.depths[(b.depths > end) & (b.depths < b.length)][::-1]
        depths = np.r_[start, inward, outward, end]
        t = now + _timed(b.path, depths, robot, entrance_direction)
        motions.append(Crawl(b.path, depths, t))
        looked = np.searchsorted(b.depths, inward)
        times.append(t[1:1 + len(inward)])
        positions.append(b.positions[looked])
        directions.append(b.directions[looked])
        now = float(t[-1])
    views = Views(np.concatenate(times) if times else np.zeros(0),
                  np.concatenate(positions) if positions else np.zeros((0, 3)),
                  np.concatenate(directions) if directions else np.zeros((0, 3)))
    return Mission(tuple(motions), views, settings, int(seed))


def mission_time(branches: list[Branch], robot: Chain, entrance_direction: np.ndarray) -> float:
    """How long (s) the mission of ``branches`` in order takes (:func:`mission_of`'s clock)."""
    if not branches:
        return 0.0
    settings = InspectionSettings(measurement_hz=None)
    return max(m.end_s for m in mission_of(branches, robot, settings, entrance_direction, 0).motions)


def tree_order(branches: list[Branch]) -> list[Branch]:
    """The branches in an order that cuts retractions: from the first, each next one the branch that runs longest
    together with the one just flown (a depth-first walk of their tree)."""
    left = list(branches)
    out = [left.pop(0)] if left else []
    while left:
        k = int(np.argmax([shared_length(out[-1].path, b.path) for b in left]))
        out.append(left.pop(k))
    return out


def coverage_of(branches: list[Branch], n: int) -> float:
    """The share of ``n`` points of interest the branches' views see."""
    if n == 0:
        return 1.0
    seen = np.zeros(n, dtype=bool)
    for b in branches:
        seen[b.seen] = True
    return float(seen.mean())
