"""`sp-rrt`: a tree of follow-the-leader bodies grown from the target back to the entrance (mm, rad, s).

After Wei, Zheng and Gu (IROS 2021), "RRT-based path planning for follow-the-leader motion of hyper-redundant
manipulators" (no public code exists; built from that description and paper 000 §1, §4). The tree is rooted at
the target, where the tip must end, and every node is a joint position: a node at depth k (k links from the root)
is joint n-k of the n-section arm, exactly one section length (``lengths[n-k]``) from its parent. The chain from
any node to the root is therefore itself a follow-the-leader body with its tip on the target. An extension is
refused if its bend with the parent link exceeds the limit or its link collides. A solution is a chain joined to
the entrance; the tip path is that chain read from the entrance to the target, so every point after the entrance
is a joint of the final configuration and consecutive points are exactly one section apart (the first segment,
from the entrance, may be shorter).

Choices (every number is a module-level default below):

* **Bend limits.** The tree allows ``TREE_BEND_FRACTION`` of each section's limit; the crawl check (the
  ``PLANNING`` profile of :class:`~snakeplan.world.ValidityChecker`) and the judge (the full limit) keep the rest.
  Between node depths the follow-the-leader links are chords across the node polyline's corners; their bends were
  measured to exceed the node bends by well under a degree, which this margin absorbs.
* **Collision.** A link is a capsule of the largest body radius plus the ``PLANNING`` margin, and a node must lie in
  the bounds. Chords cut corners (by up to l sin(theta/2) / 2, about 34 mm at 45 degrees), so the chord from the
  middle of a new link to the middle of its parent link is checked as well. The candidates of an iteration go to
  the obstacle kernel in one batch.
* **Arm length.** A node is at most joint 1 (joint 0 must stay on the feed ray), and a node is pruned when its chain
  length to the root plus a lower bound on the rest of the path exceeds the arm by more than ``BUDGET_SLACK_MM``
  (the grid error of the bound). The bound is a geodesic distance (below), or before an intermediate target the
  straight distance to it plus its geodesic distance. A target beyond that reach fails at once.
* **Geodesic field.** :func:`snakeplan.scenes.routes.geodesic.geodesic_from_sdf` on cells of ``FIELD_CELL_MM``
  (coarse: it is only a guide and a bound, and it costs a few ms), inflated by the planning body radius, with its
  source on the feed axis ``FIELD_SOURCE_SECTIONS`` first-section lengths inside the entrance (less if the axis
  is not clear that far); distances minus that depth bound the path length from the entrance (triangle inequality).
  Pulled towards that source, the tree meets the entrance from the inside, where it can join the axis, instead
  of crowding beside the port along the wall (which made some fuel-tank seeds fail).
* **Nearest neighbour.** A numba kernel over the node arrays: for each sample, the nearest node of the sample's
  stage that may still grow and whose bend cone admits the direction to the sample (a node whose cone excludes it
  would only be refused; skipping it saves the iteration). The extension is one section towards the sample. A
  candidate within ``DUPLICATE_MM`` of a node of its stage with nearly the same outgoing direction
  (``DUPLICATE_COS``) is a repeat and is dropped.
* **Sampling (goal bias, in good faith).** Each iteration draws ``BATCH`` samples. With ``GOAL_BIAS`` a sample is
  its stage's goal: for the entrance a point on the feed axis up to one section inside (where the last node
  lies), for an intermediate target a through connection (below) from a random node within two sections of it.
  With ``FRONTIER_BIAS`` it is a free cell whose geodesic distance lies up to ``FRONTIER_BAND_MM`` below the
  closest node of its stage (for an intermediate target, a band of that width centred on the target's own
  distance): this pulls the tree along free space towards the entrance, around walls, instead of straight at
  it. Otherwise it is a free cell of the informed set (geodesic distance plus straight distance to the last
  target within the arm length). Cell samples are jittered within their cell.
* **Line connection** (the analytic goal connection). Node N reaches a line (point T, direction v away from the
  tip) through a new node X = T - a v one section from N, 0 <= a <= the next section, so that the link from X
  along v passes through T; the bends at N and at X must be within the limits and the links and chords clear.
  Entrance: T = E, v = -u (the feed axis): X is the last node, on the axis, and the link behind it lies on the
  feed ray (bend 0). Every new node near the entrance tries both roots.
* **Entrance, direct.** A node N with ``|N - E| <= l`` may also be the last node itself (the first segment is then
  shorter than a section): its link starts on the feed ray at B one section from N; the bends at B (against the
  feed direction) and at N must be within the limits, and the links B-N, E-N and the link at half that depth
  must be clear (the port is narrow).
* **Multi-target** (targets in order along one path, no retraction; see :mod:`snakeplan.planners.base`). One tree,
  rooted at the last target. Every node carries a stage: the index of the next target its chain must pass, read
  towards the entrance (-1: the entrance). A link that passes within ``TARGET_PASS_MM`` of its stage's target
  gives its new node the next stage, so a target need not be a node. Through connections make such links: a
  stage-s node within one section of target s extends straight through it; otherwise (or if that is refused) a
  line connection through target s with v aimed at the next goal (target s-1, or a random point of the feed
  axis) tilted by a random ``THROUGH_TILT``, so repeated tries differ. Every new node near its target tries one.
  The legs join inside one chain, so the bend limit holds at every junction; many chains pass a target in
  different directions and all keep growing, which is the backtracking between legs. A sample's stage is the
  most advanced one present with ``ADVANCE_BIAS``, else one drawn uniformly among those present.

* **Check and repair.** Each solution is crawled with :meth:`ValidityChecker.first_failure` (every intermediate
  depth, the planning bend safety and margin). A failing bend at joint j or colliding link j depends only on the path from
  joint j-1 (or j) to the tip, so the last node behind that joint and its whole subtree are closed; the tree
  then grows on to the next solution, until the budget runs out.

Status: ``found`` with the path; ``timeout`` when the budget ran out; ``failed`` when the target is beyond the
arm's geodesic reach, the tree cannot grow (no open node), or it reached ``MAX_NODES``. Details: iterations, tree
size, nodes per stage, solutions tried, rejected by the crawl check, nodes closed by those rejections, and the
time spent on setup (arm model and field), crawl checks and the search.
"""

from __future__ import annotations

import math
import time

import numpy as np

from snakeplan import ftl
from snakeplan.geometry.polyline import cumulative_length
from snakeplan.jit import kernel
from snakeplan.planners.base import Planner, Problem, Solution, Status
from snakeplan.planners.registry import register_planner
from snakeplan.world import PLANNING, Failure, ValidityChecker
from snakeplan.scenes.routes.geodesic import DEFAULT_FEED_MM, geodesic_from_sdf
from snakeplan.scenes.routes.grid import FieldDeadline, Grid, free_space
from snakeplan.scenes.scene import Entrance

#: Fraction of each section's bend limit the tree allows; the rest absorbs mid-depth chord effects.
TREE_BEND_FRACTION = 0.94
#: Probability that a sample is its stage's goal.
GOAL_BIAS = 0.2
#: Probability that a sample is drawn from the geodesic frontier ahead of its stage's closest node.
FRONTIER_BIAS = 0.5
#: Width (mm) of the frontier band of geodesic distance.
FRONTIER_BAND_MM = 200.0
#: Probability that a sample belongs to the most advanced stage present (multi-target).
ADVANCE_BIAS = 0.7
#: Samples drawn, extended and collision-checked together per iteration.
BATCH = 16
#: Grid cell (mm) of the geodesic field: a fuel-tank hole (110 mm free radius once inflated) spans four cells. The
#: field's lazy Theta* is half of a fuel-tank plan at 40 mm; at 50 mm the plan takes about half the time, with the same
#: judged success over 100 seeds of fuel-tank and oil-tank and 30 of pipework, vessel and engine (confined: 58 of 60
#: against 59; the difference is a seed that needs 8-29 s with either size and, over four planner seeds, timed out
#: at the 30 s budget once with 40 mm cells and twice with 50 mm).
FIELD_CELL_MM = 50.0
#: Depth of the field's source on the feed axis inside the entrance, in first-section lengths.
FIELD_SOURCE_SECTIONS = 1.0
#: Slack (mm) on the arm-length bound for the geodesic field's grid error.
BUDGET_SLACK_MM = 50.0
#: A link passes an intermediate target when it comes this close (mm; half the judge's reach tolerance).
TARGET_PASS_MM = 5.0
#: Spread of the random tilt of a through-target line direction (a unit-normal perturbation of this size).
THROUGH_TILT = 0.3
#: A candidate node this close (mm) to a node of its stage with a similar outgoing direction is a repeat ...
DUPLICATE_MM = 15.0
#: ... where similar means a cosine at least this.
DUPLICATE_COS = 0.99
#: Largest tree (nodes) before the planner gives up.
MAX_NODES = 200_000

_NONE = np.zeros(0, dtype=np.int64)


def _unit(v: np.ndarray) -> np.ndarray:
    """Rows of ``v`` scaled to unit length (zero rows stay zero)."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(n > 0.0, n, 1.0)


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    """Angle (rad) between vectors ``a`` and ``b``."""
    return float(np.arctan2(np.linalg.norm(np.cross(a, b)), np.dot(a, b)))


@kernel
def _nearest_kernel(pts, stages, pos, out, has_out, stage, open_, cos_lim, n):
    """For each sample, the nearest open node of its stage whose bend cone (cosine ``cos_lim``) admits the
    direction to the sample; -1 where there is none."""
    res = np.full(pts.shape[0], -1, dtype=np.int64)
    for b in range(pts.shape[0]):
        best = np.inf
        for i in range(n):
            if stage[i] != stages[b] or not open_[i]:
                continue
            dx, dy, dz = pts[b, 0] - pos[i, 0], pts[b, 1] - pos[i, 1], pts[b, 2] - pos[i, 2]
            d2 = dx * dx + dy * dy + dz * dz
            if d2 >= best or d2 < 1e-18:
                continue
            if has_out[i] and dx * out[i, 0] + dy * out[i, 1] + dz * out[i, 2] < cos_lim[i] * np.sqrt(d2):
                continue
            best = d2
            res[b] = i
    return res


@kernel
def _repeats_kernel(new, dirs, stages, pos, out, stage, n, gap, cos_min):
    """True for candidates within ``gap`` of a node (or an earlier candidate) of the same stage whose outgoing
    direction has a cosine of at least ``cos_min`` with theirs."""
    k = new.shape[0]
    res = np.zeros(k, dtype=np.bool_)
    g2 = gap * gap
    for c in range(k):
        x, y, z = new[c, 0], new[c, 1], new[c, 2]
        for i in range(n):
            if stage[i] == stages[c]:
                dx, dy, dz = x - pos[i, 0], y - pos[i, 1], z - pos[i, 2]
                if (dx * dx + dy * dy + dz * dz <= g2
                        and dirs[c, 0] * out[i, 0] + dirs[c, 1] * out[i, 1] + dirs[c, 2] * out[i, 2] >= cos_min):
                    res[c] = True
                    break
        for j in range(c):
            if stages[j] == stages[c]:
                dx, dy, dz = x - new[j, 0], y - new[j, 1], z - new[j, 2]
                if (dx * dx + dy * dy + dz * dz <= g2
                        and dirs[c, 0] * dirs[j, 0] + dirs[c, 1] * dirs[j, 1] + dirs[c, 2] * dirs[j, 2] >= cos_min):
                    res[c] = True
    return res


@kernel
def _informed_cells(geo, centres, target, limit):
    """The cells whose geodesic distance ``geo`` (mm, inf: unreached) plus straight distance to ``target`` is at
    most ``limit``: their centres and distances, by distance (ties in cell order)."""
    keep = np.empty(geo.shape[0], dtype=np.int64)
    m = 0
    for i in range(geo.shape[0]):
        if np.isfinite(geo[i]) and geo[i] + math.sqrt((centres[i, 0] - target[0]) ** 2 + (centres[i, 1] - target[1])
                                                      ** 2 + (centres[i, 2] - target[2]) ** 2) <= limit:
            keep[m] = i
            m += 1
    kept = keep[:m]
    order = kept[np.argsort(geo[kept], kind="mergesort")]
    return centres[order], geo[order]


@kernel
def _subtree_kernel(parent, root, n):
    """Mask of ``root`` and all its descendants among the first ``n`` nodes (children follow their parents)."""
    mask = np.zeros(n, dtype=np.bool_)
    mask[root] = True
    for i in range(root + 1, n):
        if parent[i] >= 0 and mask[parent[i]]:
            mask[i] = True
    return mask


class _Tree:
    """Node arrays: position (mm), outgoing unit direction (away from the tip), parent, depth, stage, whether the
    node has an outgoing link (all but the root), and whether it may still grow."""

    _FIELDS = ("pos", "out", "parent", "depth", "stage", "has_out", "open")

    def __init__(self, capacity: int = 1024):
        self.n = 0
        self.pos = np.zeros((capacity, 3))
        self.out = np.zeros((capacity, 3))
        self.parent = np.full(capacity, -1, dtype=np.int64)
        self.depth = np.zeros(capacity, dtype=np.int64)
        self.stage = np.zeros(capacity, dtype=np.int64)
        self.has_out = np.zeros(capacity, dtype=bool)
        self.open = np.zeros(capacity, dtype=bool)

    def add(self, pos: np.ndarray, parent: np.ndarray, depth: np.ndarray, stage: np.ndarray,
            open_: np.ndarray) -> np.ndarray:
        """Append nodes (arrays of equal length); returns their indices."""
        k = pos.shape[0]
        if self.n + k > self.pos.shape[0]:
            capacity = max(2 * self.pos.shape[0], self.n + k)
            for name in self._FIELDS:
                old = getattr(self, name)
                new = np.zeros((capacity,) + old.shape[1:], dtype=old.dtype)
                new[: self.n] = old[: self.n]
                setattr(self, name, new)
        idx = np.arange(self.n, self.n + k)
        self.pos[idx] = pos
        self.parent[idx] = parent
        has = parent >= 0
        self.has_out[idx] = has
        self.out[idx] = np.where(has[:, None], _unit(pos - self.pos[np.maximum(parent, 0)]), 0.0)
        self.depth[idx] = depth
        self.stage[idx] = stage
        self.open[idx] = open_
        self.n += k
        return idx

    def chain(self, i: int) -> list[int]:
        """Node indices from ``i`` to the root."""
        out = [i]
        while self.parent[out[-1]] >= 0:
            out.append(int(self.parent[out[-1]]))
        return out


@register_planner
class SpRRT(Planner):
    """Sp-RRT: an RRT of joint positions one section apart, rooted at the target, grown back to the entrance."""

    name = "sp-rrt"
    default_optimize = "fast"
    needs_full_scene = True

    def __init__(self, tree_bend_fraction: float = TREE_BEND_FRACTION, goal_bias: float = GOAL_BIAS,
                 frontier_bias: float = FRONTIER_BIAS, frontier_band_mm: float = FRONTIER_BAND_MM,
                 batch: int = BATCH, field_cell_mm: float = FIELD_CELL_MM):
        """Tuning knobs; the module defaults are the tuned values (see the module docstring)."""
        self.tree_bend_fraction = tree_bend_fraction
        self.goal_bias = goal_bias
        self.frontier_bias = frontier_bias
        self.frontier_band_mm = frontier_band_mm
        self.batch = batch
        self.field_cell_mm = field_cell_mm

    def warm_up(self, problem: Problem) -> None:
        """The default, the geodesic field's kernels (a field over a few free cells at the entrance, and a distance
        looked up in it), the tree's (a one-node tree) and the repair's (a fit at one depth, a subtree): cold, they
        compiled inside the first plan's budget."""
        super().warm_up(problem)
        e = problem.scene.entrance
        position = np.array(e.position, dtype=float)
        _informed_cells(np.zeros(1), position[None, :], np.asarray(problem.goals, dtype=float)[-1], 1.0)
        ftl.fit_states(np.vstack([position, position + e.direction]), problem.robot.lengths, [0.5], e.direction)
        grid = Grid.covering(position - self.field_cell_mm, position + self.field_cell_mm, self.field_cell_mm)
        field = geodesic_from_sdf(grid, np.full(grid.shape, np.inf), Entrance(position, np.array(e.direction)),
                                  0.0, DEFAULT_FEED_MM)
        field.distance_at(position[None, :] + 1.0)
        tree = _Tree(2)
        tree.add(position[None, :], np.array([-1]), np.array([0]), np.array([0]), np.array([True]))
        pts, stages = position[None, :] + 1.0, np.zeros(1, dtype=np.int64)
        _nearest_kernel(pts, stages, tree.pos, tree.out, tree.has_out, tree.stage, tree.open, np.ones(2), tree.n)
        _repeats_kernel(pts, _unit(pts - position), stages, tree.pos, tree.out, tree.stage, tree.n, DUPLICATE_MM,
                        DUPLICATE_COS)
        _subtree_kernel(tree.parent, 0, tree.n)

    def _solve(self, problem: Problem, rng: np.random.Generator, deadline: float) -> Solution:
        t0 = time.perf_counter()
        try:
            search = _Search(self, problem, rng, deadline)
        except FieldDeadline:
            return Solution(Status.TIMEOUT, None, {"setup_s": round(time.perf_counter() - t0, 4)},
                            "the time limit ran out while building the geodesic field")
        return search.run()


class _Search:
    """One Sp-RRT search: the tree, the sampler and the connections for one problem."""

    def __init__(self, cfg: SpRRT, problem: Problem, rng: np.random.Generator, deadline: float):
        t0 = time.perf_counter()
        self.cfg = cfg
        self.rng = rng
        self.deadline = deadline
        self.model = ValidityChecker(problem.world, problem.robot, PLANNING)
        robot = problem.robot
        self.n = robot.n_sections
        self.lengths = np.asarray(robot.lengths, dtype=float)
        #: bend limit (rad) the tree allows at the joint of a depth-k node (joint n-k); none at the tip (k = 0)
        self.lim = np.concatenate([[math.pi], (np.asarray(robot.max_bends, dtype=float)
                                               * cfg.tree_bend_fraction)[::-1]])
        self.cos_lim = np.cos(self.lim)
        #: chain length (mm) from a depth-k node to the root: sections n-k .. n-1
        self.tip_len = np.concatenate([[0.0], np.cumsum(self.lengths[::-1])])
        #: length (mm) of the link from a depth-k node to its child: section n-k-1 (clipped at the base)
        self.steps = self.lengths[np.clip(self.n - np.arange(self.n + 2) - 1, 0, self.n - 1)]
        self.arm = float(robot.total_length)
        self.radius = float(np.max(self.model.radii))
        self.entrance = self.model.entrance
        self.u = self.model.direction
        self.targets = np.asarray(problem.goals, dtype=float)
        self._build_field(problem, cfg.field_cell_mm)
        self.target_geo = self._geo(self.targets)
        self._prepare_cells()
        self.tree = _Tree()
        self.front: dict[int, float] = {}
        #: open nodes per stage (index stage + 1)
        self.open_count = np.zeros(len(self.targets) + 1, dtype=np.int64)
        self.iterations = 0
        self.solutions = 0
        self.rejected = 0
        self.pruned = 0
        self.timing = {"setup_s": time.perf_counter() - t0, "crawl_s": 0.0}

    # --- helpers ----------------------------------------------------------------------------------------------
    def _step(self, depth):
        """Length (mm) of the link from a node at ``depth`` to its child (section n-depth-1)."""
        return self.steps[depth]

    def _build_field(self, problem: Problem, cell_mm: float) -> None:
        """Geodesic field sourced on the feed axis, ``FIELD_SOURCE_SECTIONS`` first sections inside the entrance
        (or less, as far as the axis is clear): a tree pulled towards that source meets the entrance from the
        inside, where it can join the axis, rather than sideways along the wall."""
        scene = problem.scene
        reach = FIELD_SOURCE_SECTIONS * float(self.lengths[0])
        self.source_depth = 0.0
        for a in reach * np.linspace(1.0, 0.0, 5)[:-1]:
            if bool(self.model.segment_free(self.entrance, self.entrance + a * self.u)):
                self.source_depth = float(a)
                break
        grid = Grid.covering(scene.bounds_min, scene.bounds_max, cell_mm)
        sdf = free_space(self.model.obstacles, grid, self.radius, self.deadline)  # only thresholded at the radius
        source = Entrance(self.entrance + self.source_depth * self.u, self.u)
        self.field = geodesic_from_sdf(grid, sdf, source, self.radius, DEFAULT_FEED_MM)

    def _geo(self, points: np.ndarray) -> np.ndarray:
        """Lower bound (mm) on the path length from the entrance to ``points``: the field's distance less the
        source's depth on the axis (triangle inequality)."""
        return self.field.distance_at(points) - self.source_depth

    def _prepare_cells(self) -> None:
        """Free cells of the informed set, sorted by geodesic distance from the entrance."""
        f = self.field
        self.cells, self.cell_geo = _informed_cells(f.distance.reshape(-1) - self.source_depth,
                                                    f.grid.centres().reshape(-1, 3), self.targets[-1],
                                                    self.arm + BUDGET_SLACK_MM)
        self.half_cell = f.grid.spacing / 2

    def _admissible(self, pts: np.ndarray, depth: np.ndarray, stage: np.ndarray, geo: np.ndarray) -> np.ndarray:
        """Within the joint count and the arm length (chain so far plus a lower bound on the rest)."""
        s = np.maximum(stage, 0)
        via = np.linalg.norm(pts - self.targets[s], axis=-1) + self.target_geo[s]
        rest = np.where(stage < 0, geo, np.maximum(geo, via))
        return (depth <= self.n - 1) & (self.tip_len[np.minimum(depth, self.n)] + rest <= self.arm + BUDGET_SLACK_MM)

    def _add(self, pos: np.ndarray, parent: np.ndarray, depth: np.ndarray, stage: np.ndarray) -> np.ndarray:
        """Add checked nodes and update the stage frontiers; returns their indices."""
        geo = self._geo(pos)
        open_ = depth <= self.n - 2
        idx = self.tree.add(pos, parent, depth, stage, open_)
        np.add.at(self.open_count, stage[open_] + 1, 1)
        for s in np.unique(stage):
            self.front[int(s)] = min(self.front.get(int(s), math.inf), float(np.min(geo[stage == s])))
        return idx

    def _clear(self, a: np.ndarray, b: np.ndarray, nodes: np.ndarray) -> np.ndarray:
        """For each segment a -> b: the capsule is clear and the end ``nodes`` lie inside the bounds."""
        return self.model.obstacles.segments_clear(a, b, self.radius) & self.model.world.in_bounds(nodes)

    # --- sampling and extension -------------------------------------------------------------------------------
    def _samples(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``BATCH`` samples, their stages, and which are intermediate-target goals (line connections)."""
        rng, k = self.rng, self.cfg.batch
        present = np.flatnonzero(self.open_count) - 1
        if present.size == 0:
            return np.zeros((0, 3)), _NONE, np.zeros(0, dtype=bool)
        stages = np.where(rng.random(k) < ADVANCE_BIAS, present[0], present[rng.integers(present.size, size=k)])
        kind = rng.random(k)
        goal = kind < self.cfg.goal_bias
        frontier = ~goal & (kind < self.cfg.goal_bias + self.cfg.frontier_bias)
        pick = rng.integers(len(self.cells), size=k)
        if frontier.any():
            fs = stages[frontier]
            hi = np.array([self.front[int(s)] for s in fs])
            hi = np.where(fs >= 0, self.target_geo[np.maximum(fs, 0)] + self.cfg.frontier_band_mm / 2, hi)
            a = np.searchsorted(self.cell_geo, hi - self.cfg.frontier_band_mm)
            b = np.searchsorted(self.cell_geo, hi)
            empty = b <= a
            a, b = np.where(empty, 0, a), np.where(empty, len(self.cells), b)
            pick[frontier] = a + (rng.random(a.size) * (b - a)).astype(np.int64)
        pts = self.cells[pick] + rng.uniform(-1.0, 1.0, (k, 3)) * self.half_cell
        axis = self.entrance + rng.uniform(0.0, self.lengths[0], k)[:, None] * self.u
        pts[goal] = np.where((stages < 0)[:, None], axis, self.targets[np.maximum(stages, 0)])[goal]
        return pts, stages, goal & (stages >= 0)

    def _nearest(self, pts: np.ndarray, stages: np.ndarray) -> np.ndarray:
        """For each sample, the nearest open node of its stage whose bend cone admits the direction (-1: none)."""
        t = self.tree
        return _nearest_kernel(pts, stages, t.pos, t.out, t.has_out, t.stage, t.open, self.cos_lim[t.depth], t.n)

    def _passed(self, near: np.ndarray, new: np.ndarray, stage: np.ndarray) -> np.ndarray:
        """Stages of new nodes after their links (near -> new, away from the tip) pass targets in order."""
        stage = stage.copy()
        t_prev = np.zeros(len(stage))
        a = self.tree.pos[near]
        d = new - a
        dd = np.maximum(np.sum(d * d, axis=1), 1e-12)
        for _ in range(len(self.targets)):
            live = stage >= 0
            if not live.any():
                break
            goal = self.targets[np.maximum(stage, 0)]
            t = np.clip(np.sum((goal - a) * d, axis=1) / dd, 0.0, 1.0)
            hit = live & (np.linalg.norm(a + t[:, None] * d - goal, axis=1) <= TARGET_PASS_MM) & (t >= t_prev)
            if not hit.any():
                break
            stage = np.where(hit, stage - 1, stage)
            t_prev = np.where(hit, t, t_prev)
        return stage

    def _novel(self, near: np.ndarray, new: np.ndarray, stage: np.ndarray) -> np.ndarray:
        """False for candidates repeating a node of their stage or an earlier candidate (see ``DUPLICATE_MM``)."""
        t = self.tree
        dirs = _unit(new - t.pos[near])
        return ~_repeats_kernel(new, dirs, stage, t.pos, t.out, t.stage, t.n, DUPLICATE_MM, DUPLICATE_COS)

    def _grow(self, near: np.ndarray, new: np.ndarray) -> np.ndarray:
        """Add the candidates ``new`` (children of ``near``) within the bend cone, novel, admissible and clear;
        returns their indices."""
        t = self.tree
        depth = t.depth[near] + 1
        stage = self._passed(near, new, t.stage[near])
        cone = np.sum(_unit(new - t.pos[near]) * t.out[near], axis=1) >= self.cos_lim[t.depth[near]]
        ok = (cone | ~t.has_out[near]) & self._novel(near, new, stage)
        ok &= self._admissible(new, depth, stage, self._geo(new))
        near, new, depth, stage = near[ok], new[ok], depth[ok], stage[ok]
        if near.size == 0:
            return _NONE
        mid = 0.5 * (new + t.pos[near])
        back = np.where(t.has_out[near][:, None], 0.5 * (t.pos[near] + t.pos[t.parent[near]]), mid)
        ok = self._clear(np.concatenate([new, mid]), np.concatenate([t.pos[near], back]), np.concatenate([new, new]))
        ok = ok[: len(new)] & ok[len(new):]
        return self._add(new[ok], near[ok], depth[ok], stage[ok]) if ok.any() else _NONE

    def _extend(self) -> np.ndarray:
        """One iteration: a batch of extensions and through-target connections; returns the new nodes."""
        pts, stages, through = self._samples()
        added = []
        for s in stages[through]:
            added.append(self._through_from_random(int(s)))
        pts, stages = pts[~through], stages[~through]
        if len(pts):
            near = self._nearest(pts, stages)
            near, pts = near[near >= 0], pts[near >= 0]
            if near.size:
                t = self.tree
                added.append(self._grow(near, t.pos[near] + self._step(t.depth[near])[:, None]
                                        * _unit(pts - t.pos[near])))
        return np.concatenate(added) if added else _NONE

    # --- connections ------------------------------------------------------------------------------------------
    def _line(self, i: int, point: np.ndarray, v: np.ndarray, inside: bool = True
              ) -> list[tuple[np.ndarray, np.ndarray]]:
        """Line connections of node ``i``: new nodes X = point - a v one section from it (0 <= a <= the next
        section) with the bends at i and X within the limits and links X -> i, X -> X + l v clear.

        Returns (X, Y = X + l v) pairs, smallest a first. Y must lie inside the bounds when ``inside`` (not for
        the entrance, where Y is on the feed ray behind it)."""
        t = self.tree
        p, k = t.pos[i], int(t.depth[i])
        if k + 2 > self.n:
            return []
        la, lb = float(self._step(k)), float(self._step(k + 1))
        w = point - p
        vw = float(v @ w)
        disc = vw * vw - float(w @ w) + la * la
        if disc < 0.0:
            return []
        out = []
        for a in sorted({vw - math.sqrt(disc), vw + math.sqrt(disc)}):
            if not 0.0 <= a <= lb:
                continue
            x = point - a * v
            into = (x - p) / la
            if (t.has_out[i] and _angle(into, t.out[i]) > self.lim[k]) or _angle(v, into) > self.lim[k + 1]:
                continue
            y = x + lb * v
            back = 0.5 * (p + t.pos[t.parent[i]]) if t.has_out[i] else 0.5 * (x + p)
            a_ = np.array([x, y, 0.5 * (x + p), 0.5 * (x + y)])
            b_ = np.array([p, x, back, 0.5 * (x + p)])
            if np.all(self._clear(a_, b_, a_ if inside else np.array([x, x, x, x]))):
                out.append((x, y))
        return out

    def _through(self, i: int) -> np.ndarray:
        """Through-target connections of stage-s node ``i``: straight through target s when it lies within one
        section, else a line connection through it aimed at the next goal with a random tilt. Returns the added
        node of the next stage (none if refused)."""
        t = self.tree
        s, k = int(t.stage[i]), int(t.depth[i])
        if s < 0 or not t.open[i]:
            return _NONE
        p, goal = t.pos[i], self.targets[s]
        d = float(np.linalg.norm(goal - p))
        if d > self._step(k) + self._step(k + 1):
            return _NONE
        if 1e-9 < d <= self._step(k):
            added = self._grow(np.array([i]), p[None] + self._step(k) * (goal - p)[None] / d)
            if added.size:
                return added
        ahead = self.targets[s - 1] if s > 0 else self.entrance + self.rng.uniform(0.0, self.lengths[0]) * self.u
        v = _unit(_unit(ahead - goal) + THROUGH_TILT * self.rng.normal(size=3))
        depth = np.array([k + 1, k + 2])
        stage = np.array([s, s - 1])
        for x, y in self._line(i, goal, v):
            pos = np.array([x, y])
            if self._admissible(pos, depth, stage, self._geo(pos)).all():
                xi = self._add(x[None], np.array([i]), depth[:1], stage[:1])
                return self._add(y[None], xi, depth[1:], stage[1:])
        return _NONE

    def _through_from_random(self, s: int) -> np.ndarray:
        """Goal sample of intermediate target s: a through connection from a random open stage-s node within two
        sections of it, or an extension towards it from the nearest admissible node when there is none."""
        t = self.tree
        n = t.n
        d = np.linalg.norm(t.pos[:n] - self.targets[s], axis=1)
        cand = np.flatnonzero((t.stage[:n] == s) & t.open[:n] & (d <= self._step(t.depth[:n]) * 2))
        if cand.size:
            return self._through(int(cand[self.rng.integers(cand.size)]))
        near = self._nearest(self.targets[s][None], np.array([s]))
        if near[0] < 0:
            return _NONE
        p = t.pos[near]
        return self._grow(near, p + self._step(t.depth[near])[:, None] * _unit(self.targets[s] - p))

    def _queued(self, idx: np.ndarray) -> list[int]:
        """The new nodes ``idx`` that have something to try: a through connection (stage >= 0), or an entrance
        connection (stage -1, a joint left behind it, ahead of the entrance and within two sections of it)."""
        t = self.tree
        k = t.depth[idx]
        w = t.pos[idx] - self.entrance
        near = ((k + 1 <= self.n) & (np.sum(w * self.u, axis=1) > 0.0)
                & (np.sqrt(np.sum(w * w, axis=1)) <= self.steps[k] + self.steps[k + 1]))
        return idx[(t.stage[idx] >= 0) | near].tolist()

    def _entrance_paths(self, i: int) -> list[np.ndarray]:
        """Entrance connections of stage -1 node ``i``, one :meth:`_queued` lets through: the points (entrance
        first) to put before its chain."""
        t = self.tree
        p, k = t.pos[i], int(t.depth[i])
        e, u = self.entrance, self.u
        w = p - e
        d0 = float(np.linalg.norm(w))
        la = float(self._step(k))
        out = []
        if 1e-6 < d0 <= la:
            # direct: i is the last node; its link starts on the feed ray at B, one section from it
            tau = float(-(w @ u) + math.sqrt(max(float(w @ u) ** 2 - d0 * d0 + la * la, 0.0)))
            b = e - tau * u
            into = (p - b) / la
            back = 0.5 * (p + t.pos[t.parent[i]]) if t.has_out[i] else 0.5 * (b + p)
            # the link at half that depth: tip halfway from E to p, its other end on the ray one section behind
            half = e + 0.5 * w
            hu = float((half - e) @ u)
            r = e - (-hu + math.sqrt(max(hu * hu - float((half - e) @ (half - e)) + la * la, 0.0))) * u
            if (_angle(u, into) <= self.lim[k + 1] and not (t.has_out[i] and _angle(-into, t.out[i]) > self.lim[k])
                    and np.all(self.model.obstacles.segments_clear(np.array([b, e, 0.5 * (b + p), r]),
                                                                   np.array([p, p, back, half]), self.radius))):
                out.append(e[None])
        for x, _ in self._line(i, e, -u, inside=False):
            out.append(e[None] if float(np.linalg.norm(x - e)) <= 1e-6 else np.array([e, x]))
        return out

    # --- main loop --------------------------------------------------------------------------------------------
    def _try_solution(self, i: int) -> np.ndarray | None:
        """The first entrance connection of node ``i`` whose path passes the crawl check, if any."""
        prefixes = self._entrance_paths(i)
        chain = self.tree.chain(i) if prefixes else []
        for prefix in prefixes:
            path = np.vstack([prefix, self.tree.pos[chain]])
            self.solutions += 1
            t0 = time.perf_counter()
            fail = self.model.first_failure(path)
            if fail is None:
                self.timing["crawl_s"] += time.perf_counter() - t0
                return path
            self.rejected += 1
            self._prune(path, len(prefix), chain, fail)
            self.timing["crawl_s"] += time.perf_counter() - t0
        return None

    def _prune(self, path: np.ndarray, offset: int, chain: list[int], failure: Failure) -> None:
        """Close the subtree that a crawl ``failure`` dooms.

        The failing bend (at joint j, between links j-1 and j) or colliding link j (the tip-most one: the checker
        reports it) depends only on the path from joint j-1 (or j) to the tip, so every chain through the last node
        behind that joint fails the same way: that node and its descendants stop growing. Failures in the entrance
        connection, and insertion or bounds failures, close nothing.
        """
        if failure.kind not in ("collision", "bend_limit"):
            return
        st = ftl.fit_states(path, self.model.lengths, [failure.depth_mm], self.model.direction)
        j = failure.link if failure.kind == "collision" else max(failure.link - 1, 0)
        k = int(np.searchsorted(cumulative_length(path), st.joint_arclength[0, j], side="right")) - 1
        if k < offset:
            return
        t = self.tree
        sub = np.flatnonzero(_subtree_kernel(t.parent, chain[k - offset], t.n))
        sub = sub[t.open[sub]]
        np.add.at(self.open_count, t.stage[sub] + 1, -1)
        t.open[sub] = False
        self.pruned += len(sub)

    def _details(self, t_start: float) -> dict:
        t = self.tree
        stages, counts = np.unique(t.stage[: t.n], return_counts=True)
        return {
            "iterations": self.iterations,
            "tree_size": int(t.n),
            "nodes_per_stage": {int(s): int(c) for s, c in zip(stages, counts)},
            "solutions_tried": self.solutions,
            "solutions_rejected_by_crawl": self.rejected,
            "nodes_closed_by_crawl": self.pruned,
            "setup_s": round(self.timing["setup_s"], 4),
            "crawl_s": round(self.timing["crawl_s"], 4),
            "search_s": round(time.perf_counter() - t_start, 4),
        }

    def run(self) -> Solution:
        """Grow until a solution passes the crawl check, the budget runs out or the tree cannot grow."""
        t_start = time.perf_counter()
        root = self.targets[-1][None]
        stage = np.array([len(self.targets) - 2])
        if not self._admissible(root, np.array([0]), stage, self._geo(root))[0]:
            return Solution(Status.NO_PROGRESS, None, self._details(t_start),
                            f"the geodesic field (around the known obstacles grown by the arm's largest radius, "
                            f"{self.radius:g} mm) puts the last target beyond the arm's length {self.arm:g} mm")
        queue = self._queued(self._add(root, np.array([-1]), np.array([0]), stage))
        while True:
            while queue and time.perf_counter() < self.deadline:
                i = queue.pop()
                if self.tree.stage[i] < 0:
                    path = self._try_solution(i)
                    if path is not None:
                        return Solution(Status.FOUND, path, self._details(t_start))
                else:
                    queue.extend(self._queued(self._through(i)))
            if time.perf_counter() >= self.deadline:
                return Solution(Status.TIMEOUT, None, self._details(t_start),
                                f"the time limit ran out with {self.tree.n} nodes grown")
            if self.tree.n >= MAX_NODES:
                return Solution(Status.NO_PROGRESS, None, self._details(t_start),
                                f"the tree is full ({MAX_NODES} nodes) and no branch crawls to the entrance")
            if not self.open_count.any():
                return Solution(Status.NO_PROGRESS, None, self._details(t_start),
                                f"no node of the {self.tree.n} grown can be extended and no branch crawls to the "
                                f"entrance")
            queue = self._queued(self._extend())
            self.iterations += 1
