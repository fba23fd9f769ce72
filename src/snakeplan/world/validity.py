"""THE validity checker: is a follow-the-leader crawl along a tip path feasible for a robot in a known world?

The judge and every planner check crawls here and nowhere else; they differ only in the
:class:`~snakeplan.world.tolerances.Tolerances` profile and in the knowledge view that supplies the obstacles.
A crawl is feasible at insertion depth s when (mm, rad):

- ``collision``: no link, a capsule of its section's radius plus the profile's margin, penetrates an obstacle by
  more than the contact resolution (``CONTACT_RESOLUTION_MM``; exact branch-and-bound, never sampled);
- ``bend_limit``: every bend (feed axis vs link 0, then link vs link) is within the profile's fraction of its
  section's limit;
- ``insertion``: the arm is long enough (its base never passes the entrance);
- ``out_of_bounds``: the tip path so far stays inside the scene's bounds (checked exactly: the bounds are a box,
  so a straight segment is inside when its ends are).

Depths are checked on the grid ``0, h, 2h, ..., L`` (h the profile's step, L the path's length; the last step
takes the remainder), the same grid for every profile, so a profile whose step divides the judge's checks every
depth the judge checks.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum
from typing import NamedTuple

import numpy as np

from snakeplan import ftl
from snakeplan.geometry.distance import ObstacleSet, chain_hit, workspace
from snakeplan.geometry.polyline import (
    cumulative_length,
    cumulative_unchecked,
    grid_unchecked,
    validate_path,
)
from snakeplan.jit import compiled_on_disk, kernel, leaf
from snakeplan.robots import Chain
from snakeplan.world.joint_motion import JointMotionCheck, MotionFailure
from snakeplan.world.knowledge import KnowledgeView
from snakeplan.world.tolerances import (
    BEND_TOLERANCE_RAD,
    PLANNING,
    REACH_TOLERANCE_MM,
    Tolerances,
)


class FailureKind(StrEnum):
    """What makes a crawl infeasible (see the module). A ``str`` so that JSON and printed output hold the plain
    value (``"collision"``), and it compares equal to it."""

    COLLISION = "collision"
    BEND_LIMIT = "bend_limit"
    INSERTION = "insertion"
    OUT_OF_BOUNDS = "out_of_bounds"


#: Failure kinds in the order that breaks a tie at one depth.
FAILURE_KINDS: tuple[FailureKind, ...] = tuple(FailureKind)


@dataclass(frozen=True)
class Failure:
    """Why a crawl is infeasible: the first failing depth (mm), the kind, and the tip-most link (collision) or joint
    (bend: joint 0 is the feed axis against link 0) that fails there, or the path vertex that leaves the bounds
    (out_of_bounds); None for insertion."""

    depth_mm: float
    kind: FailureKind
    link: int | None = None


@dataclass(frozen=True)
class CrawlCheck:
    """A whole crawl, every state judged: the configurations, per state what failed, the least clearance (mm,
    exact to the clearance tolerance; inf with no obstacles) over the crawl and the first state that has it (-1
    with none), and the first failure (None when feasible)."""

    states: ftl.FTLBatch
    min_clearance: float
    closest_state: int
    collides: np.ndarray
    bend_bad: np.ndarray
    insertion_bad: np.ndarray
    in_bounds: bool
    failure: Failure | None


#: Failure kind codes of :func:`_scan` (indices into FAILURE_KINDS).
_COLLISION, _BEND, _INSERTION = 0, 1, 2


@kernel
def _scan(p, cum, lengths, u, depths, max_bends, radii, W, stats):
    """The first failing depth of a crawl, scanned in order: (depth index, kind code, link) or (-1, -1, -1).

    Each depth is fitted, then its bends, insertion and links are checked; nothing past the first failure is
    fitted or checked. A collision wins a tie at one depth, then a bend (the tip-most joint), then insertion.
    """
    n = lengths.shape[0]
    joints = np.empty((n + 1, 3))
    arc = np.empty(n + 1)
    bends = np.empty(n)
    work = workspace(W)
    for i in range(depths.shape[0]):
        ftl.fit_into(p, cum, lengths, u, depths[i], joints, arc)
        link = chain_hit(W, joints, radii, work, stats)
        if link >= 0:
            return i, _COLLISION, link
        ftl.bends_into(u, joints, bends)
        for k in range(n - 1, -1, -1):
            if bends[k] > max_bends[k] + BEND_TOLERANCE_RAD:
                return i, _BEND, k
        if arc[0] > ftl.INSERTION_TOL:
            return i, _INSERTION, -1
    return -1, -1, -1


class CrawlSpec(NamedTuple):
    """What a compiled crawl check needs of a :class:`ValidityChecker` (mm, rad): the scene's bounds, the profile's
    depth step, and the arm's section lengths, feed direction, bend limits and link radii under the profile, and
    its length."""

    lo: np.ndarray
    hi: np.ndarray
    step_mm: float
    lengths: np.ndarray
    direction: np.ndarray
    max_bends: np.ndarray
    radii: np.ndarray
    total_length: float


@kernel
def crawl_depths(start, stop, step, total_length):
    """The profile's depths (mm) in (start, stop], and 0 when start is 0: the grid 0, h, 2h, ... of the crawl to
    ``stop``, never past where insertion must fail (one step beyond the arm's length)."""
    full = grid_unchecked(min(stop, total_length + step), step)
    return full[full > start] if start > 0.0 else full


@leaf
def in_box(lo, hi, x, y, z):
    """Whether the point (x, y, z) lies in the box [lo, hi] (mm; boundary included; NaN is outside)."""
    return lo[0] <= x <= hi[0] and lo[1] <= y <= hi[1] and lo[2] <= z <= hi[2]


@kernel
def first_out_vertex(p, cum, start, stop, lo, hi):
    """The first vertex of the tip path ``p`` outside the bounds [lo, hi], among those from the one at or before
    depth ``start`` to the one at or after ``stop`` (mm; ``cum`` its cumulative length), or -1."""
    first = max(np.searchsorted(cum, start, side="right") - 1, 0)
    last = max(min(np.searchsorted(cum, stop, side="left"), p.shape[0] - 1), first)
    for i in range(first, last + 1):
        if not in_box(lo, hi, p[i, 0], p[i, 1], p[i, 2]):
            return i
    return -1


@kernel
def crawl_free(p, start, spec, W, stats):
    """Whether the crawl along the tip path ``p (m, 3)`` is feasible at every depth in (start, end] (mm; depth 0
    included when start is 0) against the packed obstacles ``W``: :meth:`ValidityChecker.first_failure` is None,
    compiled so that planners call it from their own compiled loops. Unchecked, unlike ``first_failure``: ``p``
    is a C-contiguous float64 array of at least two finite points starting at the entrance."""
    cum = cumulative_unchecked(p)
    stop = cum[-1]
    start = min(max(start, 0.0), stop)
    if first_out_vertex(p, cum, start, stop, spec.lo, spec.hi) >= 0:
        return False
    depths = crawl_depths(start, stop, spec.step_mm, spec.total_length)
    if depths.shape[0] == 0:
        return True
    return _scan(p, cum, spec.lengths, spec.direction, depths, spec.max_bends, spec.radii, W, stats)[0] < 0


@leaf
def motion_free(W, lo, hi, ax, ay, az, bx, by, bz, radius, joints, radii, work, stats):
    """Whether the capsule of ``radius`` along (ax, ay, az) -> (bx, by, bz) is clear and both ends are in the
    bounds [lo, hi] (one segment, scalars in: the per-motion check of a sampling planner; jitted, so compiled
    planners call it too)."""
    if not (in_box(lo, hi, ax, ay, az) and in_box(lo, hi, bx, by, bz)):
        return False
    joints[0, 0], joints[0, 1], joints[0, 2] = ax, ay, az
    joints[1, 0], joints[1, 1], joints[1, 2] = bx, by, bz
    radii[0] = radius
    return chain_hit(W, joints, radii, work, stats) < 0


@functools.lru_cache(maxsize=64)
def coarse_to_fine(n: int) -> np.ndarray:
    """The indices 0..n-1 ordered coarse to fine: 0, then the multiples of the largest power of two below n,
    then the odd multiples of each smaller power in turn (every index once)."""
    i = np.arange(n)
    low = np.where(i == 0, n + 1, i & -i)
    order = np.lexsort((i, -low))
    order.flags.writeable = False
    return order


def _last(flags: np.ndarray) -> int:
    """Index of the last True flag."""
    return int(flags.shape[0] - 1 - np.argmax(flags[::-1]))


def min_turn_radius(lengths: np.ndarray, max_bends: np.ndarray) -> float:
    """Smallest circle radius (mm) whose chords of every section length bend within the limits.

    Consecutive chords of length l on a circle of radius R meet at 2 asin(l / 2R), so R >= l / (2 sin(theta/2)).
    """
    return float(np.max(lengths / (2.0 * np.sin(max_bends / 2.0))))


def targets_reached(path, targets, tolerance: float = REACH_TOLERANCE_MM) -> int:
    """How many ``targets (k, 3)``, in order, the tip path passes within ``tolerance`` (mm) of (exact: distances
    to the path's segments, each target found after the point where the previous one was reached)."""
    p = np.asarray(path, dtype=float)
    count, seg, t0 = 0, 0, 0.0
    for target in np.asarray(targets, dtype=float).reshape(-1, 3):
        a, b = p[seg:-1].copy(), p[seg + 1:]
        a[0] = p[seg] + t0 * (p[seg + 1] - p[seg])
        d = b - a
        dd = np.einsum("ij,ij->i", d, d)
        t = np.clip(np.einsum("ij,ij->i", target - a, d) / np.where(dd > 0.0, dd, 1.0), 0.0, 1.0)
        near = np.linalg.norm(a + t[:, None] * d - target, axis=1) <= tolerance
        hits = np.flatnonzero(near)
        if hits.size == 0:
            break
        j = int(hits[0])
        # the first point of that segment within tolerance: the smaller root of |a + t d - target| = tolerance
        w = a[j] - target
        qa, qb, qc = dd[j], 2.0 * float(w @ d[j]), float(w @ w) - tolerance ** 2
        root = math.sqrt(max(qb * qb - 4.0 * qa * qc, 0.0))
        first = 0.0 if qc <= 0.0 or qa == 0.0 else max((-qb - root) / (2.0 * qa), 0.0)
        base = t0 if j == 0 else 0.0
        seg, t0 = seg + j, base + first * (1.0 - base)
        count += 1
    return count


def kernels_ready() -> bool:
    """Whether the crawl check's kernel, which every plan runs, is kept compiled (else the first plan compiles it and
    the kernels it calls: about a minute on a fresh install)."""
    return compiled_on_disk(_scan)


class ValidityChecker:
    """Crawl checks for ``robot`` in the obstacles ``world`` knows, under ``tolerances`` (see the module)."""

    def __init__(self, world: KnowledgeView, robot: Chain, tolerances: Tolerances = PLANNING):
        self.world = world
        self.robot = robot
        self.tolerances = tolerances
        scene = world.scene
        self.entrance = scene.entrance.position
        self.spec = CrawlSpec(np.array(scene.bounds_min, dtype=float), np.array(scene.bounds_max, dtype=float),
                              float(tolerances.step_mm), np.array(robot.lengths, dtype=float),
                              np.array(scene.entrance.direction, dtype=float),
                              robot.max_bends * tolerances.bend_fraction, robot.radii + tolerances.margin_mm,
                              float(robot.total_length))
        self.direction, self.lengths, self.total_length = self.spec.direction, self.spec.lengths, self.spec.total_length
        self.radii, self.max_bends = self.spec.radii, self.spec.max_bends
        self.tip_radius = float(self.radii[-1])
        self.turn_radius = min_turn_radius(self.lengths, self.max_bends)

    @property
    def obstacles(self) -> ObstacleSet:
        """The obstacles known now (a sensed view's grow as it senses)."""
        return self.world.obstacle_set

    # --- the tip alone ------------------------------------------------------------------------------------------
    def warm_up(self) -> None:
        """Compile (or load from numba's cache) every kernel of the checks below on a tiny input, so that a
        planner can do it before its timed region: a cold first call costs seconds to tens of seconds."""
        a = self.entrance[None, :]
        b = a + self.direction[None, :]
        self.tip_free(a)
        self.segment_free(a, b)
        self.first_failure(np.vstack([a, b]))

    def tip_free(self, points, radius: float | None = None) -> np.ndarray:
        """True where a ball of ``radius`` (default: the tip's, with margin) at ``points`` is clear and in bounds."""
        p = np.asarray(points, dtype=float)
        r = self.tip_radius if radius is None else radius
        return (self.obstacles.signed_distance(p) >= r) & self.world.in_bounds(p)

    def segment_free(self, a, b, radius: float | None = None) -> np.ndarray:
        """True where the capsule of ``radius`` (default: the tip's, with margin) along a -> b is clear and its ends
        are in bounds (so the whole segment is)."""
        r = self.tip_radius if radius is None else radius
        return self.obstacles.segments_clear(a, b, r) & self.world.in_bounds(a) & self.world.in_bounds(b)

    def motion_check(self, radius: float | None = None) -> Callable[[float, float, float, float, float, float], bool]:
        """A fast form of :meth:`segment_free` for one segment given as six coordinates (mm): ``check(ax, ay, az,
        bx, by, bz)``, for a sampling planner's per-motion callback (one jitted call, no arrays built per call).
        It checks the obstacles known when it is made (a sensed view's later growth is not seen)."""
        r = self.tip_radius if radius is None else float(radius)
        obstacles = self.obstacles
        W, stats = obstacles.packed, obstacles.evaluations
        lo, hi = self.spec.lo, self.spec.hi
        joints, radii, work = np.empty((2, 3)), np.empty(1), workspace(W)

        def check(ax: float, ay: float, az: float, bx: float, by: float, bz: float) -> bool:
            return motion_free(W, lo, hi, ax, ay, az, bx, by, bz, r, joints, radii, work, stats)

        return check

    # --- crawls -------------------------------------------------------------------------------------------------
    def _depths(self, start: float, stop: float) -> np.ndarray:
        """:func:`crawl_depths` under this profile."""
        return crawl_depths(float(start), float(stop), self.spec.step_mm, self.spec.total_length)

    def _bounds_failure(self, p: np.ndarray, cum: np.ndarray, start: float, stop: float) -> Failure | None:
        """The depth at which the tip path first leaves the bounds within [start, stop], exactly."""
        i = int(first_out_vertex(p, cum, float(start), float(stop), self.spec.lo, self.spec.hi))
        if i < 0:
            return None
        if i == 0:
            return Failure(0.0, FailureKind.OUT_OF_BOUNDS, 0)
        a, d = p[i - 1], p[i] - p[i - 1]
        lo, hi = self.spec.lo, self.spec.hi
        with np.errstate(divide="ignore", invalid="ignore"):
            t = np.where(d > 0, (hi - a) / d, np.where(d < 0, (lo - a) / d, np.inf))
        depth = float(cum[i - 1] + min(float(t.min()), 1.0) * (cum[i] - cum[i - 1]))
        return Failure(max(depth, start), FailureKind.OUT_OF_BOUNDS, i)

    def first_failure(self, path, from_depth: float = 0.0, to_depth: float | None = None) -> Failure | None:
        """The first failure of the crawl at depths in (``from_depth``, ``to_depth``] (mm; depth 0 included when
        ``from_depth`` is 0; default: to the path's end), or None. Stops at the first failing depth."""
        p = np.ascontiguousarray(path, dtype=float)
        cum = cumulative_length(p)
        stop = float(cum[-1]) if to_depth is None else min(max(float(to_depth), 0.0), float(cum[-1]))
        start = min(max(float(from_depth), 0.0), stop)
        out = self._bounds_failure(p, cum, start, stop)
        depths = self._depths(start, stop if out is None else out.depth_mm)
        if depths.size == 0:
            return out
        i, code, link = self._scan(p, cum, depths)
        if i < 0 or (out is not None and out.depth_mm < depths[i]):
            return out
        return Failure(float(depths[i]), FAILURE_KINDS[code], None if link < 0 else int(link))

    def feasible(self, path) -> bool:
        """Whether the whole crawl is feasible (:meth:`first_failure` is None), answered sooner when it is not:
        the same depths are checked coarse to fine (:func:`coarse_to_fine`), since a failure holds over a run of
        consecutive depths (a corner cut, a bend held), wherever along the path it is."""
        p = np.ascontiguousarray(path, dtype=float)
        cum = cumulative_length(p)
        stop = float(cum[-1])
        if self._bounds_failure(p, cum, 0.0, stop) is not None:
            return False
        depths = self._depths(0.0, stop)
        return self._scan(p, cum, depths[coarse_to_fine(depths.size)])[0] < 0

    def _scan(self, p: np.ndarray, cum: np.ndarray, depths: np.ndarray) -> tuple[int, int, int]:
        """:func:`_scan` of the crawl along ``p`` at ``depths``, in their order, against the obstacles known now."""
        obstacles = self.obstacles
        return _scan(p, cum, self.lengths, self.direction, depths, self.max_bends, self.radii, obstacles.packed,
                     obstacles.evaluations)

    def crawl(self, path) -> CrawlCheck:
        """Every state of the crawl from depth 0 to the path's end (or to where insertion must have failed), with
        exact clearances: what the judge reports."""
        p = validate_path(path)
        cum = cumulative_length(p)
        depths = self._depths(0.0, float(cum[-1]))
        states = ftl.fit_states(p, self.lengths, depths, self.direction)
        # the least clearance alone (each state's search cut off at the least so far: 3-4x cheaper than every
        # state's own), and collisions by the collision test, which agrees with clearance < -CONTACT_RESOLUTION_MM
        least, closest = self.obstacles.least_clearance(states.joints, self.radii)
        collides = self.obstacles.chain_collides(states.joints, self.radii)
        bends = states.bend_angles > self.max_bends + BEND_TOLERANCE_RAD
        bend_bad = bends.any(axis=1)
        insertion_bad = ~states.insertion_ok
        found = [self._bounds_failure(p, cum, 0.0, float(cum[-1]))]
        for kind, bad in ((FailureKind.COLLISION, collides), (FailureKind.BEND_LIMIT, bend_bad),
                          (FailureKind.INSERTION, insertion_bad)):
            rows = np.flatnonzero(bad)
            if rows.size:
                i = int(rows[0])
                link = _last(bends[i]) if kind is FailureKind.BEND_LIMIT else None
                if kind is FailureKind.COLLISION:
                    hit = self.obstacles.first_hit(states.joints[i:i + 1], self.radii)
                    link = None if hit is None else hit[1]
                found.append(Failure(float(depths[i]), kind, link))
        found = [f for f in found if f is not None]
        failure = min(found, key=lambda f: (f.depth_mm, FAILURE_KINDS.index(f.kind))) if found else None
        return CrawlCheck(states, least, closest, collides, bend_bad, insertion_bad,
                          not any(f.kind is FailureKind.OUT_OF_BOUNDS for f in found), failure)

    # --- joint motions ------------------------------------------------------------------------------------------
    def joint_motions(self) -> JointMotionCheck:
        """The check of whole-arm joint motions (base pose and joints at sample times, linear in between) under
        this profile, against the obstacles known now (:mod:`snakeplan.world.joint_motion`)."""
        return JointMotionCheck(self.robot, self.obstacles, self.tolerances, self.spec.lo, self.spec.hi)

    def joint_motion_failure(self, times, bases, q) -> MotionFailure | None:
        """The first failure in time of a joint motion (times (k,) s, base poses (k, 4, 4), joints (k, dof)), or
        None: collisions certified between samples, bends, joint limits and the tip's bounds every step."""
        return self.joint_motions().first_failure(np.asarray(times, dtype=float), np.asarray(bases, dtype=float),
                                                  np.asarray(q, dtype=float))
