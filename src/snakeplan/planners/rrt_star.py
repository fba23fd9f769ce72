"""`rrt-star`: RRT* in tip space (compiled; OMPL's as the reference), then shortcut and filleted within the arm's
turning radius.

RRT* here is the generic sampling baseline of paper 000 (§1, Table 2): it searches for the tip's path alone and
ignores the body while it searches. The state is the tip position (mm) in the scene's bounds. A state is valid
when a ball of the body radius plus the planning margin (:attr:`ValidityChecker.tip_radius`) around the tip
clears every obstacle. A motion is valid when the capsule that ball sweeps along the straight segment clears
every obstacle: an exact sweep (:func:`snakeplan.world.validity.motion_free`), so no wall is thin enough to
tunnel through, and one check per motion instead of one per interpolated state (3.7x faster than OMPL's discrete
check at a 10 mm step, with the same success, on fuel-tank seeds 0-9). The objective is path length, the
planner RRT* with OMPL ``og.RRTstar``'s defaults (extension ``RANGE_MM``, goal bias ``GOAL_BIAS``).

Two implementations (``backend``): ``"compiled"`` (default), :mod:`snakeplan.planners.tip_rrt_star`, the same
algorithm in numba with the motion check in the same compiled loop; ``"ompl"``, OMPL's ``og.RRTstar`` with a
motion validator that calls the jitted check with the six coordinates. Through OMPL every motion check is a
Python callback and OMPL's own iteration costs ~0.1 ms besides, so the compiled one is several times faster
(``snakeplan bench speed`` measures both on the same problems; the success and path lengths agree). The body,
its bend limits and the follow-the-leader crawl play no part in the search; they are checked afterwards
(:meth:`ValidityChecker.first_failure`).

Choices, each a named default below:

* Start: the path leaves the entrance straight along the feed axis (the arm cannot turn inside the entrance
  port); RRT* starts ``LEAD_MM`` in. Smoothing may lengthen that lead (up to ``MAX_LEAD_MM``) so that the
  first turn fits the turning radius.
* Targets (the multi-target rule of :mod:`snakeplan.planners.base`): one RRT* per leg, from the previous
  target (or the lead's end) to the next, each from a fresh tree; the legs join into one path.
* Budget: the legs share ``problem.time_limit_s`` less ``POST_RESERVE_FRACTION`` of it, kept for
  post-processing; a leg gets an equal share of what is left when it starts. A leg stops at its share, or
  ``IMPROVE_ITERATIONS`` iterations after its first solution, whichever comes first. RRT* would keep
  shortening a found path for ever, but on these scenes the raw leg is then within about 3 % of its length
  after 5000 iterations, and the shortcut path does not change at all, so burning the whole budget buys
  nothing. The improvement budget is counted in iterations, not seconds, so a seed gives the same plan on
  any machine whenever the time limit does not bind.
* Seeding: the compiled search draws from numba's random stream, seeded from the planner's seed before each
  plan; OMPL draws every generator's seed from one process-wide seed generator, which is reset
  (``ompl.util.RNG.setSeed``) from the planner's seed before each plan makes its first OMPL object. Either way
  the same seed gives the same trees, and it is process-wide state: plan from one thread at a time.
* Shortcut: greedy; from each kept point, jump to the furthest later point of the raw leg (densified every
  ``SHORTCUT_STEP_MM``) that a ball of the tip radius plus a shortcut margin reaches in a straight line. The
  margin keeps the straight stretches off the obstacles the fillets later cut towards.
* Smoothing: a target that is an interior corner becomes two corners on a straight stretch through the
  target (the tip passes within ``TARGET_TOL_MM`` of it); neighbouring corners too close for their fillets
  are merged into one where their outer segments' lines meet; then every corner is rounded by
  :func:`fillet` with radius ``RADIUS_FACTOR`` x :attr:`ValidityChecker.turn_radius`, arcs sampled every
  ``ARC_STEP_MM``.
* Repair (bounded, a good-faith baseline): when the smoothed path fails the crawl check, smoothing is redone
  with each larger shortcut margin of ``SHORTCUT_MARGINS_MM``; when all fail, the legs are planned again with
  the tip clearance raised by each of ``REPAIR_PLAN_MARGINS_MM`` (a target or lead end too close to an obstacle
  for a raised clearance skips it), while time is left.

Status: "found" when a smoothed path passed the crawl check; "timeout" when the time ran out first (a leg
without a solution in its share of the time included); "no_progress" when the lead or a target is blocked under
the planning margin, a re-planned leg found no solution, or every repair was tried without a path, its why naming
each repair and the crawl check's first failure. Details: ``legs``,
``tree_sizes`` (vertices of every RRT* tree grown, in order), ``raw_length_mm`` (lead plus raw legs),
``smoothed_length_mm``, ``repairs`` (smoothing attempts that failed the crawl check), ``plan_margin_mm`` and
``shortcut_margin_mm`` (those of the returned path).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from snakeplan.geometry.polyline import densify, drop_duplicates, fillet, path_length
from snakeplan.planners import tip_rrt_star
from snakeplan.planners.base import Planner, Problem, Solution, Status
from snakeplan.planners.registry import register_planner
from snakeplan.world import PLANNING, ValidityChecker

#: Shortest straight lead (mm) along the feed axis from the entrance; RRT* starts at its end.
LEAD_MM = 60.0
#: Longest lead (mm) smoothing may use so that the first fillet fits, and the step (mm) it grows by.
MAX_LEAD_MM = 500.0
LEAD_STEP_MM = 20.0
#: RRT* extension length (mm), a third of a fuel-tank chamber. OMPL's default (a fifth of the bounds'
#: diagonal, about 460 mm here) gives raw legs 1-3 % shorter in up to twice the time, and the same smoothed paths.
RANGE_MM = 200.0
#: Probability that RRT* samples the leg's goal.
GOAL_BIAS = 0.05
#: RRT* iterations run after a leg's first solution before the leg stops improving.
IMPROVE_ITERATIONS = 1500
#: Share of the time budget kept for shortcutting, smoothing and crawl checks.
POST_RESERVE_FRACTION = 0.15
#: Spacing (mm) of the points along a raw leg that a shortcut may jump to.
SHORTCUT_STEP_MM = 20.0
#: Shortcut margins (mm) beyond the tip radius, tried in turn while the crawl check fails.
SHORTCUT_MARGINS_MM = (10.0, 25.0, 45.0)
#: Extra tip clearance (mm) of re-planned legs when no shortcut margin gives a path that crawls.
REPAIR_PLAN_MARGINS_MM = (15.0, 30.0)
#: Fillet radius as a multiple of :attr:`ValidityChecker.turn_radius`; the slack absorbs the chords of the sampled
#: arcs, which bend slightly more than the circle they approximate.
RADIUS_FACTOR = 1.05
#: Arc-length step (mm) at which fillet arcs are sampled.
ARC_STEP_MM = 5.0
#: Pass-through corners sit this multiple of their fillet's tangent length from the target.
PASS_SLACK = 1.05
#: Halvings of that distance tried while the pass-through segments are blocked.
PASS_TRIES = 3
#: Largest gap (mm) between the lines of two segments for the corners between them to be merged.
MERGE_GAP_MM = 30.0
#: Largest distance (mm) a merge may leave a target from the waypoint polyline.
TARGET_TOL_MM = 1.0


def _seed_ompl(rng: np.random.Generator) -> None:
    """Reset OMPL's process-wide seed generator from the planner's generator (OMPL logs an error whenever the
    seed is reset after first use, which is exactly what is meant here, so the log is muted meanwhile)."""
    from ompl import util as ou

    level = ou.getLogLevel()
    ou.setLogLevel(ou.LOG_NONE)
    ou.RNG.setSeed(int(rng.integers(1, 2**31 - 1)))
    ou.setLogLevel(level)


def _plan_leg_ompl(arm: ValidityChecker, start: np.ndarray, goal: np.ndarray, radius: float, deadline: float
                   ) -> tuple[np.ndarray | None, int]:
    """OMPL's RRT* from ``start`` to ``goal`` (mm) with tip clearance ``radius`` (mm) until ``deadline`` (a
    perf_counter value) or ``IMPROVE_ITERATIONS`` after the first solution; (waypoints or None, tree size)."""
    from ompl import base as ob
    from ompl import geometric as og

    class SweptTip(ob.MotionValidator):
        """OMPL motion check: the tip ball swept along the segment clears every obstacle (one jitted call)."""

        def __init__(self, si: ob.SpaceInformation):
            super().__init__(si)
            self._check = arm.motion_check(radius)

        def checkMotion(self, s1: ob.State, s2: ob.State) -> bool:
            return self._check(s1[0], s1[1], s1[2], s2[0], s2[1], s2[2])

    space = ob.RealVectorStateSpace(3)
    bounds = ob.RealVectorBounds(3)
    for k in range(3):
        bounds.setLow(k, float(arm.world.scene.bounds_min[k]))
        bounds.setHigh(k, float(arm.world.scene.bounds_max[k]))
    space.setBounds(bounds)
    setup = og.SimpleSetup(space)
    setup.setStateValidityChecker(lambda s: bool(arm.tip_free(np.array([s[0], s[1], s[2]]), radius)))
    si = setup.getSpaceInformation()
    validator = SweptTip(si)  # kept referenced while OMPL uses it
    si.setMotionValidator(validator)
    s, g = space.allocState(), space.allocState()
    for k in range(3):
        s[k], g[k] = float(start[k]), float(goal[k])
    setup.setStartAndGoalStates(s, g)
    setup.setOptimizationObjective(ob.PathLengthOptimizationObjective(si))
    planner = og.RRTstar(si)
    planner.setRange(RANGE_MM)
    planner.setGoalBias(GOAL_BIAS)
    setup.setPlanner(planner)
    setup.setup()
    found_at: list[int] = []

    def stop() -> bool:
        if time.perf_counter() >= deadline:
            return True
        if not found_at:
            if math.isfinite(planner.bestCost().value()):
                found_at.append(planner.numIterations())
            return False
        return planner.numIterations() >= found_at[0] + IMPROVE_ITERATIONS

    setup.solve(ob.PlannerTerminationCondition(stop))
    data = ob.PlannerData(si)
    planner.getPlannerData(data)
    tree = int(data.numVertices())
    if not setup.getProblemDefinition().hasExactSolution():
        return None, tree
    path = setup.getSolutionPath()
    pts = np.array([[path.getState(i)[k] for k in range(3)] for i in range(path.getStateCount())])
    pts[0], pts[-1] = start, goal
    return pts, tree


def _furthest_visible(arm: ValidityChecker, point: np.ndarray, later: np.ndarray, radius: float) -> int:
    """Index of the furthest of ``later`` points a ball of ``radius`` (mm) reaches from ``point`` in a straight
    line; 0 when none is (callers pass a raw path whose first step is valid)."""
    hits = np.flatnonzero(arm.segment_free(np.broadcast_to(point, later.shape), later, radius))
    return int(hits[-1]) if hits.size else 0


def shortcut(arm: ValidityChecker, dense: np.ndarray, radius: float) -> list[np.ndarray]:
    """Greedy shortcut of a densified leg (mm): from each kept point, jump to the furthest later point that a
    ball of ``radius`` reaches in a straight line; both ends are kept."""
    keep = [dense[0]]
    i, n = 0, len(dense)
    while i < n - 1:
        i = i + 1 + _furthest_visible(arm, dense[i], dense[i + 1:], radius)
        keep.append(dense[i])
    return keep


def _turn(u: np.ndarray, v: np.ndarray) -> float:
    """Angle (rad) between directions u and v."""
    return float(np.arctan2(np.linalg.norm(np.cross(u, v)), np.dot(u, v)))


def _entry(arm: ValidityChecker, start: np.ndarray, dense: np.ndarray, radius: float, turn_radius: float,
           ends_path: bool) -> tuple[np.ndarray, int]:
    """End of the straight lead along the feed axis (mm), and the index of the point of the first densified
    raw leg ``dense`` (which starts ``LEAD_MM`` in) that the path turns towards from there.

    The lead grows from ``LEAD_MM`` by ``LEAD_STEP_MM`` (while the tip clears the port and beyond) until the
    fillet of ``turn_radius`` at its end fits: tangent length R tan(turn / 2) within the lead and within half
    of the next straight (all of it when that straight ends the path, ``ends_path``). When no length fits,
    the one with the smallest ratio of tangent length to room is kept."""
    feed = arm.direction
    best = (math.inf, dense[0], 0)
    length = LEAD_MM
    while length <= MAX_LEAD_MM:
        corner = start + length * feed
        if not bool(arm.segment_free(start[None], corner[None])[0]):
            break
        j = _furthest_visible(arm, corner, dense, radius)
        out = dense[j] - corner
        share = 1.0 if ends_path and j == len(dense) - 1 else 0.5
        room = min(length, share * float(np.linalg.norm(out)))
        ratio = turn_radius * math.tan(_turn(feed, out) / 2.0) / max(room, 1e-9)
        if ratio < best[0]:
            best = (ratio, corner, j)
        if ratio <= 1.0:
            break
        length += LEAD_STEP_MM
    return best[1], best[2]


def _pass_through(arm: ValidityChecker, prev: np.ndarray, target: np.ndarray, nxt: np.ndarray, radius: float,
                  turn_radius: float) -> list[np.ndarray]:
    """Corners (mm) that replace a target corner: two on the line through the target along the bisector of
    the turn, far enough apart that their fillets leave the stretch through the target straight. Their
    distance from the target is halved (up to ``PASS_TRIES`` times) while the new segments are not free for a
    ball of ``radius``; the target itself stays the corner when none is."""
    u, v = target - prev, nxt - target
    lu, lv = float(np.linalg.norm(u)), float(np.linalg.norm(v))
    u, v = u / lu, v / lv
    turn = _turn(u, v)
    if turn < 1e-6:
        return [target]
    t = u + v
    t = t / np.linalg.norm(t) if np.linalg.norm(t) > 1e-9 else u
    d = min(turn_radius * math.tan(min(turn, 0.99 * math.pi) / 4.0) * PASS_SLACK, 0.45 * lu, 0.45 * lv)
    for _ in range(PASS_TRIES):
        corners = [target - d * t, target + d * t]
        chain = np.array([prev, *corners, nxt])
        if bool(np.all(arm.segment_free(chain[:-1], chain[1:], radius))):
            return corners
        d /= 2.0
    return [target]


def _tightness(pts: np.ndarray, turn_radius: float) -> np.ndarray:
    """Per interior corner, the fillet tangent length R tan(turn / 2) over the room :func:`fillet` gives it
    (half of each adjacent segment; all of the first or last): above 1 the fillet shrinks below R."""
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    share = seg / 2.0
    share[0], share[-1] = seg[0], seg[-1]
    if len(seg) == 2:
        share[:] = seg
    u = np.diff(pts, axis=0) / seg[:, None]
    cos = np.clip(np.einsum("ij,ij->i", u[:-1], u[1:]), -1.0, 1.0)
    need = turn_radius * np.tan(np.minimum(np.arccos(cos), 0.999 * math.pi) / 2.0)
    return need / np.maximum(np.minimum(share[:-1], share[1:]), 1e-9)


def _line_meet(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> np.ndarray | None:
    """Where the ray a -> b (beyond a) and the ray d -> c (beyond d) pass closest, when that is ahead of both
    a and d and within ``MERGE_GAP_MM``: the midpoint of the two closest points; else None."""
    u, w, r = b - a, c - d, a - d
    uu, uw, ww, ur, wr = u @ u, u @ w, w @ w, u @ r, w @ r
    den = uu * ww - uw * uw
    if den < 1e-9 * uu * ww:
        return None
    s = (uw * wr - ww * ur) / den
    t = (uu * wr - uw * ur) / den
    if s <= 0.0 or t <= 0.0:
        return None
    p, q = a + s * u, d + t * w
    return (p + q) / 2.0 if np.linalg.norm(p - q) <= MERGE_GAP_MM else None


def _on_path(pts: np.ndarray, targets: np.ndarray) -> bool:
    """Whether every target lies within ``TARGET_TOL_MM`` of the polyline ``pts``."""
    a, ab = pts[:-1], np.diff(pts, axis=0)
    den = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-12)
    for q in targets:
        t = np.clip(np.einsum("ij,ij->i", q - a, ab) / den, 0.0, 1.0)
        if np.min(np.linalg.norm(a + t[:, None] * ab - q, axis=1)) > TARGET_TOL_MM:
            return False
    return True


def _merge_tight(arm: ValidityChecker, pts: np.ndarray, targets: np.ndarray, radius: float, turn_radius: float
                 ) -> np.ndarray:
    """Merge neighbouring corners whose fillets do not fit (:func:`_tightness` > 1) into one corner where the
    lines of their outer segments meet, when the two new segments are free for a ball of ``radius`` (mm), the
    targets stay on the path and the merged corner is less tight than the worse of the two. The tightest
    corner goes first; it stops when none is tight or no merge helps."""
    for _ in range(len(pts)):
        if len(pts) < 4:
            break
        tight = _tightness(pts, turn_radius)
        merged = None
        for corner in np.argsort(-tight):
            if tight[corner] <= 1.0:
                break
            for lo in (corner, corner + 1):  # vertex pairs (lo, lo + 1) that include this corner
                if lo < 1 or lo + 1 > len(pts) - 2:
                    continue
                x = _line_meet(pts[lo - 1], pts[lo], pts[lo + 1], pts[lo + 2])
                if x is None:
                    continue
                cand = np.vstack([pts[:lo], x[None], pts[lo + 2:]])
                new = cand[lo - 1:lo + 2]
                if (np.all(arm.segment_free(new[:-1], new[1:], radius)) and _on_path(cand, targets)
                        and _tightness(cand, turn_radius)[lo - 1] < max(tight[lo - 1], tight[lo])):
                    merged = cand
                    break
            if merged is not None:
                break
        if merged is None:
            break
        pts = merged
    return pts


def _smooth(arm: ValidityChecker, start: np.ndarray, legs: list[np.ndarray], targets: np.ndarray, margin: float
            ) -> np.ndarray:
    """Shortcut every raw leg with a ball of tip radius + ``margin`` (mm) after a straight lead from ``start``
    (:func:`_entry`), join the legs through the targets (:func:`_pass_through`), merge corners too tight for
    their fillets (:func:`_merge_tight`), and fillet every corner."""
    radius = arm.tip_radius + margin
    turn_radius = arm.turn_radius * RADIUS_FACTOR
    dense = [densify(leg, SHORTCUT_STEP_MM) for leg in legs]
    corner, j = _entry(arm, start, dense[0], radius, turn_radius, len(dense) == 1)
    pieces = [[start, corner, *shortcut(arm, dense[0][j:], radius)]]
    pieces += [shortcut(arm, d, radius) for d in dense[1:]]
    points = pieces[0][:-1]
    for k in range(1, len(pieces)):
        points.extend(_pass_through(arm, points[-1], pieces[k][0], pieces[k][1], radius, turn_radius))
        points.extend(pieces[k][1:-1])
    points.append(pieces[-1][-1])
    waypoints = _merge_tight(arm, drop_duplicates(np.array(points)), targets, radius, turn_radius)
    return fillet(waypoints, turn_radius, ARC_STEP_MM)


def _crawls(arm: ValidityChecker, path: np.ndarray) -> bool:
    """Whether the tip capsule clears the obstacles along ``path`` and the body crawls along it."""
    return bool(np.all(arm.segment_free(path[:-1], path[1:]))) and arm.first_failure(path) is None


def _crawl_failure(arm: ValidityChecker, path: np.ndarray) -> str:
    """What :func:`_crawls` refuses in ``path``, in words."""
    failure = arm.first_failure(path)
    if failure is None:
        return "the tip's capsule meets an obstacle"
    return f"{failure.kind} at depth {failure.depth_mm:.0f} mm"


def _plan_leg(arm: ValidityChecker, start: np.ndarray, goal: np.ndarray, radius: float, deadline: float
              ) -> tuple[np.ndarray | None, int]:
    """The compiled RRT* (:mod:`snakeplan.planners.tip_rrt_star`) with this module's settings."""
    return tip_rrt_star.plan_leg(arm, start, goal, radius, deadline, RANGE_MM, GOAL_BIAS, IMPROVE_ITERATIONS)


#: The RRT* implementations: the compiled one (default) and OMPL's, kept as the reference it is checked against.
BACKENDS = ("compiled", "ompl")


@register_planner
class RRTStar(Planner):
    """RRT* in tip space (compiled, or OMPL's), shortcut, filleted and crawl-checked, with a bounded repair."""

    name = "rrt-star"
    default_optimize = "fast"
    needs_full_scene = True

    def __init__(self, backend: str = "compiled") -> None:
        if backend not in BACKENDS:
            raise ValueError(f"backend: must be one of {', '.join(BACKENDS)}, got {backend!r}")
        self.backend = backend

    def warm_up(self, problem: Problem) -> None:
        """The validity checker's and the compiled search's kernels (a few iterations of a throw-away leg),
        outside the timed plan."""
        super().warm_up(problem)
        if self.backend == "compiled":
            arm = ValidityChecker(problem.world, problem.robot, PLANNING)
            tip_rrt_star.warm_up(arm, problem.start + LEAD_MM * arm.direction, problem.goals[0])
            _crawls(arm, np.array([problem.start, problem.start + LEAD_MM * arm.direction]))

    def _solve(self, problem: Problem, rng: np.random.Generator, deadline: float
               ) -> tuple[Status, np.ndarray | None, dict]:
        if self.backend == "compiled":
            tip_rrt_star.seed_stream(int(rng.integers(1, 2**31 - 1)))
            return self._search(problem, deadline, _plan_leg)
        from ompl import util as ou

        level = ou.getLogLevel()
        ou.setLogLevel(ou.LOG_WARN)
        try:
            _seed_ompl(rng)
            return self._search(problem, deadline, _plan_leg_ompl)
        finally:
            ou.setLogLevel(level)

    def _search(self, problem: Problem, deadline: float, plan_leg: Callable[..., tuple[np.ndarray | None, int]]
                ) -> tuple[Status, np.ndarray | None, dict]:
        arm = ValidityChecker(problem.world, problem.robot, PLANNING)
        start, goals = problem.start, problem.goals
        lead = start + LEAD_MM * arm.direction
        details: dict = {"legs": len(goals), "tree_sizes": [], "raw_length_mm": None, "smoothed_length_mm": None,
                         "repairs": 0, "plan_margin_mm": None, "shortcut_margin_mm": None}
        if not arm.segment_free(start[None], lead[None])[0]:
            return Solution(Status.NO_PROGRESS, None, details,
                            f"the {LEAD_MM:g} mm lead along the entrance's direction is not clear by the planning "
                            f"margin {PLANNING.margin_mm:g} mm")
        if not np.all(arm.tip_free(goals, arm.tip_radius)):
            return Solution(Status.NO_PROGRESS, None, details,
                            f"a target is not clear of the obstacles by the tip's radius and the planning margin "
                            f"({arm.tip_radius:g} mm)")
        tried: list[str] = []
        search_deadline = deadline - POST_RESERVE_FRACTION * problem.time_limit_s
        for plan_margin in (0.0, *REPAIR_PLAN_MARGINS_MM):
            radius = arm.tip_radius + plan_margin
            if not np.all(arm.tip_free(np.vstack([lead, goals]), radius)):
                tried.append(f"no room for a {plan_margin:g} mm clearance at the lead or a target")
                continue
            legs: list[np.ndarray] = []
            for k, goal in enumerate(goals):
                now = time.perf_counter()
                pts, tree = plan_leg(arm, goals[k - 1] if k else lead, goal, radius,
                                      now + (search_deadline - now) / (len(goals) - k))
                details["tree_sizes"].append(tree)
                if pts is None:  # the leg's time share ran out; a raised clearance only makes it harder
                    if plan_margin == 0.0:
                        return Solution(Status.TIMEOUT, None, details,
                                        f"no tip path to targets[{k}] within its share of the time limit")
                    return Solution(Status.NO_PROGRESS, None, details,
                                    f"{'; '.join(tried)}; then no tip path to targets[{k}] with the clearance "
                                    f"raised to {plan_margin:g} mm within its share of the time limit")
                legs.append(pts)
            details["raw_length_mm"] = LEAD_MM + sum(path_length(leg) for leg in legs)
            for margin in SHORTCUT_MARGINS_MM:
                if time.perf_counter() >= deadline:
                    return Solution(Status.TIMEOUT, None, details, "the time limit ran out while smoothing")
                margin = max(margin, plan_margin)
                path = _smooth(arm, start, legs, goals, margin)
                if _crawls(arm, path):
                    details.update(smoothed_length_mm=path_length(path), plan_margin_mm=plan_margin,
                                   shortcut_margin_mm=margin)
                    return Solution(Status.FOUND, path, details)
                details["repairs"] += 1
            tried.append(f"the tree's path with {plan_margin:g} mm clearance, shortcut at "
                         f"{max(SHORTCUT_MARGINS_MM[0], plan_margin):g}-{max(SHORTCUT_MARGINS_MM[-1], plan_margin):g} "
                         f"mm, failed the crawl check ({_crawl_failure(arm, path)})")
            if time.perf_counter() >= search_deadline:
                return Solution(Status.TIMEOUT, None, details, f"the time limit ran out after {'; '.join(tried)}")
        return Solution(Status.NO_PROGRESS, None, details,
                        f"every repair was tried: {'; '.join(tried)}")
