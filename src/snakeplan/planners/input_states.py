"""Whether a reach problem can be solved at all, decided before a planner searches (after OMPL's
``PlannerInputStates``, which refuses an invalid start or goal with ``INVALID_START`` or ``INVALID_GOAL``).

Each refusal is a fact no plan can get past under the judge's rules, checked in what the planner may know (the
obstacles of its knowledge view), so a problem that can be solved is never refused:

* the entrance: the tip's ball (the judge's radius, no margin) at the entrance and one judge's step along its
  direction is in bounds and clear of the known obstacles, since the judge checks the crawl from depth 0, and
  so is the arm not yet inserted, each section's capsule straight back from the entrance (the judge checks it too);
  and when the bounds lie ahead closer than half the arm's turning radius, no target lies behind the entrance by
  more than the reach tolerance (a path that starts along the direction cannot turn a right angle in less forward
  room than its turning radius, half of it covering the chords of the fitted chain, so it only moves forward);
* each target: its ball of the tip's radius, less the reach tolerance, is in bounds and clear of the known
  obstacles; and the straight legs from the entrance through the targets to it, less the tolerance at each,
  fit within the arm's length (the tip path never runs longer than the arm: its base stays outside).
"""

from __future__ import annotations

import numpy as np

from snakeplan.inputs import point_text
from snakeplan.scenes import Scene
from snakeplan.world import Knowledge, KnowledgeView, ValidityChecker
from snakeplan.world.tolerances import JUDGE, REACH_TOLERANCE_MM


def _clearance(world: KnowledgeView, p: np.ndarray) -> float:
    """The clearance of ``p`` from the known obstacles (mm)."""
    return float(world.obstacle_set.signed_distance(p[None])[0]) if len(world.obstacle_set) else np.inf


def _nearest(world: KnowledgeView, p: np.ndarray) -> str:
    """The known obstacle nearest ``p``: its index in the scene when the planner knows the whole scene, else
    its kind (a sensed view's obstacles are a subset)."""
    known = world.obstacle_set.obstacles
    k = int(np.argmin([float(o.signed_distance(p[None])[0]) for o in known]))
    return f"obstacles[{k}]" if world.kind == Knowledge.FULL else f"a known {type(known[k]).__name__.lower()}"


def _room_ahead(scene: Scene, start: np.ndarray, direction: np.ndarray) -> float:
    """How far the bounds lie ahead of ``start`` along the unit ``direction`` (mm)."""
    lo, hi = np.asarray(scene.bounds_min, dtype=float), np.asarray(scene.bounds_max, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(direction > 0, (hi - start) / direction, np.where(direction < 0, (lo - start) / direction,
                                                                         np.inf))
    return max(float(t.min()), 0.0)


def invalid_start(world: KnowledgeView, arm: ValidityChecker) -> str | None:
    """Why no tip path can leave the entrance, or None."""
    scene = world.scene
    start, d = arm.entrance, arm.direction
    r = arm.tip_radius
    for depth in (0.0, JUDGE.step_mm):
        p = start + depth * d
        where = f"{depth:g} mm along entrance.direction {point_text(d)}" if depth else "at the entrance"
        if not world.in_bounds(p[None])[0]:
            return f"the entrance points out of the scene: {where} the tip leaves the bounds"
        clearance = _clearance(world, p)
        if clearance < r:
            return (f"{_nearest(world, p)} blocks the entrance: {where} the tip's ball of radius {r:g} mm is "
                    f"{clearance:.3g} mm from it")
    if len(world.obstacle_set):  # the judge checks the arm not yet inserted, straight back from the entrance
        cum = np.concatenate([[0.0], np.cumsum(arm.lengths[::-1])])
        a, b, radii = start - cum[:-1, None] * d, start - cum[1:, None] * d, arm.radii[::-1]
        clear = np.ones(len(radii), dtype=bool)
        for radius in np.unique(radii):  # one call per radius (an arm of one radius: one call)
            of = radii == radius
            clear[of] = world.obstacle_set.segments_clear(a[of], b[of], float(radius))
        if not clear.all():
            k = int(np.argmin(clear))
            return (f"the arm waiting behind the entrance (straight back from it along entrance.direction "
                    f"{point_text(d)}, {arm.total_length:.4g} mm) meets {_nearest(world, (a[k] + b[k]) / 2)} "
                    f"{cum[k]:.4g}-{cum[k + 1]:.4g} mm back: does the entrance face into the scene?")
    room = _room_ahead(scene, start, d)
    behind = np.flatnonzero((scene.targets - start) @ d < -REACH_TOLERANCE_MM)
    if room < arm.turn_radius / 2 and behind.size:
        return (f"the entrance points out of the scene: the bounds lie {room:.3g} mm ahead along entrance.direction "
                f"{point_text(d)}, too little to turn the arm (turning radius {arm.turn_radius:.3g} mm) back to "
                f"targets[{int(behind[0])}] behind it")
    return None


def invalid_target(world: KnowledgeView, arm: ValidityChecker) -> str | None:
    """Why some target cannot be reached by the tip, or None."""
    scene = world.scene
    tol, r = REACH_TOLERANCE_MM, arm.tip_radius
    legs = np.linalg.norm(np.diff(np.vstack([arm.entrance, scene.targets]), axis=0), axis=1)
    needs = np.cumsum(legs) - tol * (2 * np.arange(len(legs)) + 1)
    clearances = (world.obstacle_set.signed_distance(scene.targets) if len(world.obstacle_set)
                  else np.full(len(legs), np.inf))
    for k, (t, needed, clearance) in enumerate(zip(scene.targets, needs, clearances)):
        if clearance < r - tol:
            return (f"targets[{k}] {point_text(t)} lies {clearance:.3g} mm from {_nearest(world, t)}: the tip (radius "
                    f"{r:g} mm) cannot come within the reach tolerance {tol:g} mm of it")
        if needed > arm.total_length:
            return (f"targets[{k}] {point_text(t)} needs at least {needed:.4g} mm of tip path from the entrance (through the "
                    f"targets before it), beyond the arm's length {arm.total_length:.4g} mm")
    return None
