"""`as-rrt`: arc-segment RRT for follow-the-leader tip paths (mm, rad, s).

After Deng, Li, Zheng and Gu, "An RRT-based motion planning method for hyper-redundant manipulators in confined
spaces" (ROBIO 2022), as paper 000 describes it: a tree rooted at the entrance whose every edge is a
constant-curvature arc tangent to its parent's end heading, so every root-to-node branch is a G1 chain of arcs
the arm can follow, and which needs only the obstacles near the tree. No public code exists; every choice below
is ours and is written down here, with its number as a module-level default.

Tree. A node is a tip pose: position, unit heading, depth (length of its branch from the entrance) and parent.
The root is the entrance, heading along the feed direction, so the path leaves the port in line with the part of
the arm still behind it. Node fields live in NumPy arrays that double in size when full.

Curvature. Every arc has curvature at most ``1 / ValidityChecker.turn_radius``: the circle whose section-length chords
bend within the bend limits times the planning safety factor (217.5 mm for SJTU-Snake III).

Extension (one iteration). Draw a sample: the stage's target with probability ``GOAL_BIAS``, otherwise uniform
in the scene's bounds (the coarse prior an operator has). Pick the nearest eligible node under an arc-length
metric: a point q at chord c from a node, seen at angle a off its heading, lies on the node's tangent circle of
curvature 2 sin(a) / c; within the limit the distance is that circle's arc a c / sin(a), beyond it (and for a
point dead behind) the chord plus the turn radius times a (the detour of a sharper turn). Eligible: nodes of the
stage being grown (see multi-target) with at least ``MIN_ARC_MM`` of arm left; for a target sample, only nodes
not yet extended toward it (a repeat would rebuild the same arc). Steer: the arc from the node in the plane of
its heading and q, the tangent circle through q with its curvature clamped to the limit, ``ARC_SECTIONS`` mean
section lengths long (shorter when it reaches q first), sampled at ``ARC_POINTS`` points. A node that would
repeat the pose of a node of its stage (``TWIN_MM``, ``TWIN_COS``) is not added.

Validity, for every extension and landing, cheap check first. (1) Sweep: the tip capsule (body radius plus the
planning margin) clears every known obstacle along each chord of the arcs, inside the bounds
(:func:`snakeplan.world.validity.motion_free`). (2) Body: the follow-the-leader crawl of the new branch from the
parent's depth to the new node's (:func:`snakeplan.world.validity.crawl_free`, the compiled form of
``ValidityChecker.first_failure``: every link clear, bends within the limits, insertion within the arm's length,
at the planning profile's depths). The crawl runs on every extension that passes the sweep: checking less often
would grow branches whose body already collides, which the judge would reject. A failed extension is dropped
whole (no partial arcs).

Compiled. An extension (nearest node, steer, arc, twin test, sweep, crawl, new node) is one numba call on the
tree's arrays; the random draws, landings and sensing stay in Python.

Landing. A new node within ``LANDING_RADIUS_MM`` of its stage's target tries to end exactly on it, at most
``LANDING_SECTIONS`` section lengths further and turning at most ``MAX_LANDING_TURN_RAD`` in all:
- free landings: planar pairs of arcs, the first on a grid (``LANDING_CURVATURES`` curvatures in [-limit,
  limit], ``LANDING_LENGTHS`` lengths, none included), the second the tangent circle through the target; the
  ``LANDING_CANDIDATES`` gentlest (lowest peak curvature, then shortest) are checked in turn, the first valid kept;
- for a target that is not the last, also biarcs (two arcs, equal tangent lengths) that arrive with a chosen
  heading: toward the next target, and ``LANDING_HEADINGS - 1`` headings drawn around it (a Gaussian of
  ``HEADING_SPREAD`` added to the unit vector). The heading at an intermediate target decides whether the next
  one can be reached with bounded curvature, and a free landing leaves it to chance; every valid one is kept.
A landing node at once tries to land on the next target the same way (a chain of landings).

Multi-target (the rule of :mod:`snakeplan.planners.base`: in order, one continuous path, no retraction). A node's
stage is the number of targets its branch has landed on; a landing on target k starts stage k + 1, whose nodes
grow toward target k + 1, so every path is a branch through one landing per target. Each iteration grows the
latest stage reached, or with probability ``REVISIT_PROB`` a uniformly drawn earlier one (other landings on an
earlier target may open the way when the first ones lead nowhere).

Restarts. A tree either finds the targets within a few hundred iterations or has committed to landings that
lead nowhere; so after ``RESTART_ITERATIONS`` iterations the tree is dropped and a fresh one grown, each with
``RESTART_GROWTH`` times the previous patience (the random generator carries on, so trees differ).

Knowledge. The planner sees obstacles only through ``problem.world`` (:mod:`snakeplan.world.knowledge`). With a
sensed view, each node of a tree (any tree grown so far, the root included) is reported to the sensor, which reveals
every obstacle within ``problem.sensor_range_mm`` of it; the checks use only known obstacles. Every arc and landing
is capped at the sensor range minus the tip radius, so the tip never sweeps beyond what its start node sensed, and
the body's capsules lie within about 50 mm (radius plus chord deviation) of the tree's own arcs, near its nodes: for
any sensor range above about 100 mm, every obstacle that could touch an extension is known when it is checked. The
sensed planner then accepts what the full one would (the same seed gives the same path), while seeing only the
obstacles near its tree. A target closer to a known obstacle than the tip radius, or out of bounds, can never be
landed on: the planner then stops at once with ``"no_progress"``.

Ends. ``"found"`` when the last target is landed on, ``"no_progress"`` for a blocked target (above),
``"timeout"`` at the budget (path None), each non-found plan saying why (the targets landed on, the restarts). The same seed gives the same trees and path: the only randomness is the seeded
generator, and the clock only decides when to stop.
"""

from __future__ import annotations

import math
import time

import numpy as np

from snakeplan.geometry.distance import workspace
from snakeplan.jit import kernel
from snakeplan.planners.base import Planner, Problem, Solution, Status
from snakeplan.planners.registry import register_planner
from snakeplan.world import PLANNING, ValidityChecker
from snakeplan.world.validity import crawl_free, motion_free

#: Probability (per iteration) of sampling the stage's target instead of a uniform point in the bounds.
GOAL_BIAS = 0.3
#: With targets already reached, probability (per iteration) of growing an earlier stage instead of the latest.
REVISIT_PROB = 0.25
#: Length of one extension arc, in mean section lengths ("about one section long").
ARC_SECTIONS = 1.0
#: Points sampled along each arc after its start (chords of about 11 mm on a 177.5 mm arc).
ARC_POINTS = 16
#: Shortest arc (mm) worth adding; nodes with less arm left than this are not extended.
MIN_ARC_MM = 20.0
#: A new node this close (mm) to its stage's target tries to land on it.
LANDING_RADIUS_MM = 400.0
#: Longest landing (all its arcs), in mean section lengths.
LANDING_SECTIONS = 2.0
#: Largest total turn (rad) of a landing.
MAX_LANDING_TURN_RAD = math.pi / 2
#: Grid of a free landing's first arc: curvatures in [-limit, limit], lengths in [0, longest landing].
LANDING_CURVATURES = 9
LANDING_LENGTHS = 9
#: Free landings validity-checked per try, gentlest first.
LANDING_CANDIDATES = 2
#: Biarc landings per try on a target that is not the last: arrival headings toward the next target and around it.
LANDING_HEADINGS = 8
#: Spread of the drawn arrival headings (standard deviation added to the unit vector toward the next target).
HEADING_SPREAD = 0.5
#: A node within this distance (mm) of a node of its stage, heading within ``TWIN_COS`` of it, is a twin.
TWIN_MM = 2.0
TWIN_COS = 0.999
#: Iterations before the first restart, and the growth of that patience per restart.
RESTART_ITERATIONS = 300
RESTART_GROWTH = 1.5
#: Initial capacity (nodes) of the tree's arrays; they double when full.
INITIAL_CAPACITY = 1024
#: Iterations between clock reads.
CLOCK_EVERY = 8

_EPS = 1e-12
#: The counters of :func:`_extend`'s codes -2, -3, -4 (and of :func:`_check`'s 1 and 2).
_REJECTS = ("twins", "sweep_rejects", "body_rejects")


@kernel
def _any_normal(t):
    """A unit vector perpendicular to the unit vector t."""
    e = np.zeros(3)
    e[np.argmin(np.abs(t))] = 1.0
    v = e - (e @ t) * t
    return v / np.linalg.norm(v)


@kernel
def tangent_circle(p, t, q):
    """The circle tangent to unit heading t at p through q: ``(curvature 1/mm, unit normal toward its centre,
    arc length p -> q (mm), turn (rad))``; a straight line (curvature 0) when q is dead ahead, and an infinite
    length when q is dead behind."""
    d = q - p
    c = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    along = d[0] * t[0] + d[1] * t[1] + d[2] * t[2]
    perp = d - along * t
    s = math.sqrt(perp[0] * perp[0] + perp[1] * perp[1] + perp[2] * perp[2])
    if s <= 1e-9 * max(c, _EPS):
        if along > 0.0 or c < _EPS:
            return 0.0, _any_normal(t), c, 0.0
        return 0.0, _any_normal(t), math.inf, math.pi
    a = math.atan2(s, along)
    return 2.0 * s / (c * c), perp / s, a * c / math.sin(a), 2.0 * a


@kernel
def arc(p, t, n, kappa, length, count):
    """``count`` points (after p, the last at arc length ``length``) of the arc of curvature ``kappa`` leaving p
    along t and bending toward n, and the unit heading at its end."""
    pts = np.empty((count, 3))
    if kappa < _EPS:
        for j in range(count):
            pts[j] = p + (length * (j + 1) / count) * t
        return pts, t.copy()
    ks = 0.0
    for j in range(count):
        ks = kappa * (length * (j + 1) / count)
        pts[j] = p + (math.sin(ks) / kappa) * t + ((1.0 - math.cos(ks)) / kappa) * n
    end = math.cos(ks) * t + math.sin(ks) * n
    return pts, end / np.linalg.norm(end)


@kernel
def steer(p, t, q, kappa_max, length):
    """The extension from pose (p, t) toward q: ``(curvature, unit normal, arc length)``: the tangent circle
    through q with its curvature clamped to ``kappa_max``, ``length`` long or shorter if it reaches q first."""
    kappa, n, reach, _ = tangent_circle(p, t, q)
    if kappa <= kappa_max:
        return kappa, n, min(length, reach)
    return kappa_max, n, length


@kernel
def arc_distance(p, t, q, kappa_max, turn_radius):
    """Arc-length metric (mm) from the pose (p, t) to q: the tangent circle's arc within the curvature limit, else
    the chord plus the turn radius times the angle off the heading (a half turn for a point dead behind)."""
    d0, d1, d2 = q[0] - p[0], q[1] - p[1], q[2] - p[2]
    c = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    along = d0 * t[0] + d1 * t[1] + d2 * t[2]
    s = math.sqrt(max(c * c - along * along, 0.0))
    a = math.atan2(s, along)
    sin_a = s / max(c, _EPS)
    if sin_a <= 1e-9 and along < 0.0:
        return c + turn_radius * math.pi  # dead behind: no tangent circle reaches it
    if 2.0 * s / max(c * c, _EPS) <= kappa_max:
        return (a / max(sin_a, 1e-9) if sin_a > 1e-9 else 1.0) * c
    return c + turn_radius * a


@kernel
def _landing_firsts(p, t, n, q, kappa_max, max_length, max_turn, keep):
    """The first arcs (curvatures, signed toward n, and lengths) of :func:`landings`' ways, gentlest first: the
    candidates of its grid that pass, ordered by peak curvature, then total length, then grid order."""
    m = 1 + LANDING_CURVATURES * (LANDING_LENGTHS - 1)
    k1, l1 = np.zeros(m), np.zeros(m)
    for a in range(LANDING_CURVATURES):
        for b in range(1, LANDING_LENGTHS):
            r = 1 + a * (LANDING_LENGTHS - 1) + b - 1
            k1[r] = -kappa_max + 2.0 * kappa_max * a / (LANDING_CURVATURES - 1)
            l1[r] = max_length * b / (LANDING_LENGTHS - 1)
    peak, total = np.full(m, np.inf), np.full(m, np.inf)
    for r in range(m):
        th = k1[r] * l1[r]
        if abs(k1[r]) > _EPS:
            fwd, side = math.sin(th) / k1[r], (1.0 - math.cos(th)) / k1[r]
        else:
            fwd, side = l1[r], 0.0
        c2 = math.cos(th)
        s2 = math.sin(th)
        d = q - (p + fwd * t + side * n)
        h = c2 * t + s2 * n
        c = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        along = d[0] * h[0] + d[1] * h[1] + d[2] * h[2]
        off = math.sqrt(max(c * c - along * along, 0.0))
        a2 = math.atan2(off, along)
        k2 = 2.0 * off / max(c * c, _EPS)
        sin_a2 = off / max(c, _EPS)
        length = l1[r] + (a2 / max(sin_a2, 1e-9) if sin_a2 > 1e-9 else 1.0) * c
        if k2 <= kappa_max and length <= max_length and abs(th) + 2.0 * a2 <= max_turn and c > _EPS:
            peak[r], total[r] = max(abs(k1[r]), k2), length
    chosen = np.empty(min(keep, m), dtype=np.int64)
    count = 0
    for _ in range(chosen.shape[0]):
        best = -1
        for r in range(m):
            if peak[r] < np.inf and (best < 0 or peak[r] < peak[best]
                                     or (peak[r] == peak[best] and total[r] < total[best])):
                best = r
        if best < 0:
            break
        chosen[count] = best
        count += 1
        peak[best] = np.inf
    return k1[chosen[:count]], l1[chosen[:count]]


def landings(p: np.ndarray, t: np.ndarray, q: np.ndarray, kappa_max: float, max_length: float, max_turn: float,
             count: int, keep: int) -> list[list[tuple[np.ndarray, np.ndarray]]]:
    """Up to ``keep`` ways from pose (p, t) to end exactly on q, each a list of arcs (points, end heading).

    Each way is a planar pair of arcs in the plane of t and q - p: a first arc of curvature on a grid of
    ``LANDING_CURVATURES`` values in [-kappa_max, kappa_max] (negative: bending away from q) and a length on a
    grid of ``LANDING_LENGTHS`` values in [0, max_length] (0: none), then the tangent circle through q. Kept when
    the second curvature is within the limit, the total at most ``max_length`` long and turning at most
    ``max_turn``; ordered by peak curvature, then length (the gentlest first).
    """
    _, n, _, _ = tangent_circle(p, t, q)
    k1, l1 = _landing_firsts(p, t, n, q, kappa_max, max_length, max_turn, keep)
    ways = []
    for i in range(k1.shape[0]):
        pieces, start, heading = [], p, t
        if l1[i] > 0.0:
            pts, heading = arc(p, t, n * np.sign(k1[i]) if k1[i] else n, abs(float(k1[i])), float(l1[i]), count)
            pieces.append((pts, heading))
            start = pts[-1]
        kappa, n2, reach, _ = tangent_circle(start, heading, q)
        pts, end = arc(start, heading, n2, kappa, reach, count)
        pts[-1] = q
        pieces.append((pts, end))
        ways.append(pieces)
    return ways


def biarc(p: np.ndarray, t: np.ndarray, q: np.ndarray, h: np.ndarray, kappa_max: float, max_length: float,
          max_turn: float, count: int) -> list[tuple[np.ndarray, np.ndarray]] | None:
    """Two arcs (points, end heading) from pose (p, t) to pose (q, h) with equal tangent lengths, or None when an
    arc exceeds ``kappa_max`` or they are longer than ``max_length`` or turn more than ``max_turn`` together."""
    v = q - p
    w = t + h
    a = float(w @ w) - 4.0
    vw, vv = float(v @ w), float(v @ v)
    if abs(a) < 1e-12:
        if vw <= 0.0:
            return None
        d = vv / (2.0 * vw)
    else:
        d = (vw - math.sqrt(max(vw * vw - a * vv, 0.0))) / a
    if not d > 0.0:
        return None
    joint = 0.5 * (p + d * t + q - d * h)
    pieces, start, heading, total, turned = [], p, t, 0.0, 0.0
    for end in (joint, q):
        kappa, n, reach, turn = tangent_circle(start, heading, end)
        total += reach
        turned += turn
        if kappa > kappa_max or total > max_length or turned > max_turn:
            return None
        pts, heading = arc(start, heading, n, kappa, reach, count)
        pts[-1] = end
        pieces.append((pts, heading))
        start = end
    return pieces


@kernel
def _add_node(P, T, depth, parent, stage, arcs, n, i, pts, heading, k):
    """Write node ``n``: the end of arc ``pts`` from node i, arriving with ``heading``, of stage k."""
    P[n], T[n], arcs[n] = pts[-1], heading, pts
    length, prev = 0.0, P[i]
    for j in range(pts.shape[0]):
        length += math.sqrt((pts[j, 0] - prev[0]) ** 2 + (pts[j, 1] - prev[1]) ** 2 + (pts[j, 2] - prev[2]) ** 2)
        prev = pts[j]
    depth[n] = depth[i] + length
    parent[n], stage[n] = i, k


@kernel
def _has_twin(P, T, stage, n, p, t, k):
    """Whether one of the first n nodes of stage k already has (nearly) the pose (p, t)."""
    for i in range(n):
        if stage[i] == k and ((P[i, 0] - p[0]) ** 2 + (P[i, 1] - p[1]) ** 2 + (P[i, 2] - p[2]) ** 2 <= TWIN_MM ** 2
                              and T[i, 0] * t[0] + T[i, 1] * t[1] + T[i, 2] * t[2] >= TWIN_COS):
            return True
    return False


@kernel
def _branch(P, parent, arcs, i, tail):
    """The tip path (mm) from the root to node i, then the points ``tail``."""
    count, k = 0, i
    while k > 0:
        count += 1
        k = parent[k]
    a = arcs.shape[1]
    out = np.empty((1 + count * a + tail.shape[0], 3))
    out[0] = P[0]
    k = i
    for r in range(count - 1, -1, -1):
        out[1 + r * a:1 + (r + 1) * a] = arcs[k]
        k = parent[k]
    out[1 + count * a:] = tail
    return out


@kernel
def _check(P, depth, parent, arcs, i, pts, spec, W, stats):
    """Whether the tip can sweep ``pts`` from node i (0), else 1, and then whether the body can crawl there (0),
    else 2: the sweep of each chord (:func:`motion_free`, the tip's radius under the profile), then the crawl of
    the new depths (:func:`crawl_free`)."""
    joints, radii, work = np.empty((2, 3)), np.empty(1), workspace(W)
    tip_radius = spec.radii[-1]
    a = P[i]
    for j in range(pts.shape[0]):
        b = pts[j]
        if not motion_free(W, spec.lo, spec.hi, a[0], a[1], a[2], b[0], b[1], b[2], tip_radius, joints, radii, work,
                           stats):
            return 1
        a = b
    if not crawl_free(_branch(P, parent, arcs, i, pts), depth[i], spec, W, stats):
        return 2
    return 0


@kernel
def _extend(P, T, depth, parent, stage, arcs, tried, n, eligible, to_goal, q, k, kappa_max, turn_radius, step, spec,
            W, stats):
    """One extension of stage k toward q from the nearest eligible node (of the first n): the new node's index
    n, or -1 (no eligible node, or too short), -2 (a twin), -3 (the sweep fails), -4 (the crawl fails). Marks the
    node tried when ``to_goal``. The arc has as many points as the tree keeps per node."""
    i, best = -1, math.inf
    for j in range(n):
        if eligible[j]:
            d = arc_distance(P[j], T[j], q, kappa_max, turn_radius)
            if d < best:
                i, best = j, d
    if i < 0:
        return -1
    tried[i] |= to_goal
    kappa, normal, length = steer(P[i], T[i], q, kappa_max, step)
    length = min(length, spec.total_length - depth[i])
    if length < MIN_ARC_MM:
        return -1
    pts, heading = arc(P[i], T[i], normal, kappa, length, arcs.shape[1])
    if _has_twin(P, T, stage, n, pts[-1], heading, k):
        return -2
    code = _check(P, depth, parent, arcs, i, pts, spec, W, stats)
    if code:
        return -2 - code
    _add_node(P, T, depth, parent, stage, arcs, n, i, pts, heading, k)
    return n


class _Tree:
    """Node poses (mm), depths (mm), parents, stages, goal-tried flags and the arc points leading to each node."""

    _FIELDS = ("P", "T", "depth", "parent", "stage", "tried", "arcs")

    def __init__(self, root: np.ndarray, heading: np.ndarray, arc_points: int):
        cap = INITIAL_CAPACITY
        self.n = 1
        self.P = np.zeros((cap, 3))
        self.T = np.zeros((cap, 3))
        self.depth = np.zeros(cap)
        self.parent = np.full(cap, -1, dtype=np.int64)
        self.stage = np.zeros(cap, dtype=np.int64)
        self.tried = np.zeros(cap, dtype=bool)
        self.arcs = np.zeros((cap, arc_points, 3))
        self.P[0], self.T[0] = root, heading

    def reserve(self, extra: int) -> None:
        """Room for ``extra`` more nodes (the arrays double when full)."""
        while self.n + extra > self.P.shape[0]:
            for name in self._FIELDS:
                a = getattr(self, name)
                setattr(self, name, np.concatenate([a, np.zeros_like(a)]))

    def add(self, parent: int, pts: np.ndarray, heading: np.ndarray, stage: int) -> int:
        """Append the node at the end of arc ``pts`` from ``parent``; its index."""
        self.reserve(1)
        _add_node(self.P, self.T, self.depth, self.parent, self.stage, self.arcs, self.n, parent, pts, heading,
                  stage)
        self.n += 1
        return self.n - 1

    def has_twin(self, p: np.ndarray, t: np.ndarray, stage: int) -> bool:
        """Whether a node of ``stage`` already has (nearly) this pose."""
        return bool(_has_twin(self.P, self.T, self.stage, self.n, p, t, stage))

    def branch(self, i: int) -> np.ndarray:
        """The tip path (mm) from the root to node i."""
        return _branch(self.P, self.parent, self.arcs, i, np.empty((0, 3)))


class _Search:
    """One planning run: the tree, what is known, the arm model against it, and counters."""

    def __init__(self, planner: AsRRT, problem: Problem, rng: np.random.Generator):
        self.planner = planner
        self.problem = problem
        self.rng = rng
        self.goals = np.array(problem.goals, dtype=float)  # writable: the kernels take one array type
        self.world = problem.world
        self.world.sense(problem.start)
        self.model = ValidityChecker(self.world, problem.robot, PLANNING)
        self.blocked = not bool(self.model.tip_free(self.goals).all())
        self.kappa_max = 1.0 / self.model.turn_radius
        section = float(np.mean(self.model.lengths))
        cap = math.inf if self.world.kind == "full" else problem.sensor_range_mm - self.model.tip_radius
        self.step = min(planner.arc_sections * section, cap)
        self.landing_max = min(LANDING_SECTIONS * section, cap)
        self.counts = {"iterations": 0, "restarts": 0, "sweep_rejects": 0, "body_rejects": 0, "twins": 0,
                       "landing_tries": 0}
        self._new_tree()

    def _new_tree(self) -> None:
        """Start a fresh tree at the entrance (what was sensed stays known)."""
        u = self.problem.scene.entrance.direction
        self.tree = _Tree(self.problem.start, u / np.linalg.norm(u), ARC_POINTS)
        self.reached = 0
        self.landings = 0

    def details(self, reason: str) -> dict:
        """Planner-specific facts of the run (counts over all trees; nodes, landings and targets of the last)."""
        return {"reason": reason, "nodes": self.tree.n, "targets_reached": self.reached,
                "landings": self.landings, "known_obstacles": len(self.world.obstacle_set),
                "knowledge": self.problem.knowledge,
                "arc_length_mm": self.step, "turn_radius_mm": self.model.turn_radius, **self.counts}

    def _blocked(self) -> Solution:
        return Solution(Status.NO_PROGRESS, None, self.details("target_blocked"),
                        f"a target lies closer to a known obstacle than the tip's radius with the planning margin "
                        f"({self.model.tip_radius:g} mm)")

    def run(self, deadline: float) -> Solution:
        """Grow trees until the last target is landed on, a target is found blocked, or the deadline."""
        if self.blocked:
            return self._blocked()
        usable = self.model.total_length - MIN_ARC_MM
        patience, grown = float(RESTART_ITERATIONS), 0
        while True:
            if self.counts["iterations"] % CLOCK_EVERY == 0 and time.perf_counter() >= deadline:
                return Solution(Status.TIMEOUT, None, self.details("timeout"),
                                f"the time limit ran out with {self.reached} of {len(self.goals)} targets landed on "
                                f"({self.counts['restarts']} restarts)")
            self.counts["iterations"] += 1
            grown += 1
            if grown > patience:
                self._new_tree()
                self.counts["restarts"] += 1
                patience, grown = patience * RESTART_GROWTH, 0
            tree, stage = self.tree, self.reached
            if stage > 0 and self.rng.random() < REVISIT_PROB:
                stage = int(self.rng.integers(stage))
            live = (tree.stage[:tree.n] == stage) & (tree.depth[:tree.n] <= usable)
            if not live.any():
                continue
            j = self._extend(stage, live)
            k = None if j is None or self.blocked else self._land(j, stage)
            while k is not None and tree.stage[k] < len(self.goals) and not self.blocked:
                k = self._land(k, int(tree.stage[k]))
            if self.blocked:
                return self._blocked()
            if k is not None:
                return Solution(Status.FOUND, tree.branch(k), self.details("reached"))

    def _extend(self, stage: int, live: np.ndarray) -> int | None:
        """One extension of ``stage`` toward a sample; the new node, or None."""
        tree, rng = self.tree, self.rng
        to_goal = rng.random() < self.planner.goal_bias
        if to_goal:
            untried = live & ~tree.tried[:tree.n]
            to_goal = bool(untried.any())
        if to_goal:
            q, live = self.goals[stage], untried
        else:
            lo, hi = self.problem.scene.bounds_min, self.problem.scene.bounds_max
            q = lo + rng.random(3) * (hi - lo)
        tree.reserve(1)
        obstacles = self.model.obstacles
        k = _extend(tree.P, tree.T, tree.depth, tree.parent, tree.stage, tree.arcs, tree.tried, tree.n, live, to_goal,
                    q, stage, self.kappa_max, self.model.turn_radius, self.step, self.model.spec, obstacles.packed,
                    obstacles.evaluations)
        if k < 0:
            if k < -1:
                self.counts[_REJECTS[-k - 2]] += 1
            return None
        tree.n += 1
        self._sensed(k)
        return k

    def _land(self, j: int, stage: int) -> int | None:
        """Try to land node j on the stage's target; the landing node, or None."""
        tree, goal = self.tree, self.goals[stage]
        if np.linalg.norm(goal - tree.P[j]) > LANDING_RADIUS_MM:
            return None
        self.counts["landing_tries"] += 1
        room = min(self.landing_max, self.model.total_length - float(tree.depth[j]))
        groups = [landings(tree.P[j], tree.T[j], goal, self.kappa_max, room, MAX_LANDING_TURN_RAD, ARC_POINTS,
                           LANDING_CANDIDATES)]
        ahead = self.goals[stage + 1] - goal if stage + 1 < len(self.goals) else np.zeros(3)
        if np.linalg.norm(ahead) > _EPS:
            ahead /= np.linalg.norm(ahead)
            for m in range(LANDING_HEADINGS):
                h = ahead + (HEADING_SPREAD * self.rng.normal(size=3) if m else 0.0)
                way = biarc(tree.P[j], tree.T[j], goal, h / np.linalg.norm(h), self.kappa_max, room,
                            MAX_LANDING_TURN_RAD, ARC_POINTS)
                groups.append([] if way is None else [way])
        found = None
        for ways in groups:
            for pieces in ways:
                pts, heading = pieces[-1]
                if tree.has_twin(pts[-1], heading, stage + 1):
                    self.counts["twins"] += 1
                    break
                if not self._valid(j, np.vstack([p for p, _ in pieces])):
                    continue
                k = j
                for m, (pts, heading) in enumerate(pieces):
                    k = self._add(k, pts, heading, stage + (m == len(pieces) - 1))
                self.landings += 1
                self.reached = max(self.reached, stage + 1)
                found = k
                break
        return found

    def _valid(self, i: int, pts: np.ndarray) -> bool:
        """Whether the tip can sweep ``pts`` from node i and the body can crawl there (known obstacles)."""
        tree, obstacles = self.tree, self.model.obstacles
        code = _check(tree.P, tree.depth, tree.parent, tree.arcs, i, np.ascontiguousarray(pts), self.model.spec,
                      obstacles.packed, obstacles.evaluations)
        if code:
            self.counts[_REJECTS[code]] += 1
        return not code

    def _add(self, parent: int, pts: np.ndarray, heading: np.ndarray, stage: int) -> int:
        """Add a node and sense from it."""
        k = self.tree.add(parent, pts, heading, stage)
        self._sensed(k)
        return k

    def _sensed(self, k: int) -> None:
        """Sense from node k; a target closer to a newly seen obstacle than the tip radius (or out of bounds) can
        never be landed on, which ``blocked`` records."""
        if self.world.sense(self.tree.P[k]):
            self.blocked = not bool(self.model.tip_free(self.goals).all())


@register_planner
class AsRRT(Planner):
    """Arc-segment RRT (Deng et al. 2022): a tree of tangent constant-curvature arcs from the entrance; plans with
    the whole scene or with only the obstacles sensed near its tree."""

    name = "as-rrt"
    default_optimize = "fast"
    needs_full_scene = False

    def __init__(self, goal_bias: float = GOAL_BIAS, arc_sections: float = ARC_SECTIONS):
        self.goal_bias = goal_bias
        self.arc_sections = arc_sections

    def warm_up(self, problem: Problem) -> None:
        """The default, then each kernel of the search on a one-node tree: an extension (the sweep and crawl
        inside it), a landing's arcs, a check and a node added from Python; cold, they compiled inside the first
        plan's budget."""
        super().warm_up(problem)
        search = _Search(self, problem, np.random.default_rng(0))
        tree = search.tree
        search._extend(0, np.ones(1, dtype=bool))
        p, t = tree.P[0], tree.T[0]
        goal = p + 2.0 * MIN_ARC_MM * t
        biarc(p, t, goal, t, search.kappa_max, search.landing_max, MAX_LANDING_TURN_RAD, ARC_POINTS)
        landings(p, t, goal, search.kappa_max, search.landing_max, MAX_LANDING_TURN_RAD, ARC_POINTS, 1)
        pts, heading = arc(p, t, _any_normal(t), 0.0, MIN_ARC_MM, ARC_POINTS)
        search._valid(0, pts)
        tree.has_twin(pts[-1], heading, 0)
        tree.branch(tree.add(0, pts, heading, 0))

    def _solve(self, problem: Problem, rng: np.random.Generator, deadline: float) -> Solution:
        return _Search(self, problem, rng).run(deadline)
