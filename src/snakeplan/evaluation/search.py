"""The judge of search missions: the mission replayed as an inspection's (every motion through the one checker
under ``JUDGE``, every view on the tip), then, from the views and the motions alone, when each target was first seen
and when the tip first came within the reach tolerance of it after that (mm, s); from the replay's first failure on,
nothing is counted.

A planner's own account (which targets it says it found, when) is not read: the first sightings come from the
mission's views through the camera rules of :mod:`snakeplan.world.search`, against the whole scene; a target counts
as reached only at a time after it was seen, so a plan that drives to a target it has not seen yet does not score.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from snakeplan.evaluation.mission import Replayed, replay
from snakeplan.geometry.polyline import cumulative_length, point_at
from snakeplan.robots import Chain
from snakeplan.scenes import Scene
from snakeplan.threads import single_threaded
from snakeplan.world import REACH_TOLERANCE_MM
from snakeplan.world.mission import Crawl, InspectionSettings, Mission
from snakeplan.world.search import first_sightings

#: Arc-length step (mm) at which a crawl's path is compared with a target.
REACH_STEP_MM = 1.0


@dataclass(frozen=True, kw_only=True)
class SearchReport(Replayed):
    """The judge's verdict on a search mission: the replay's (:func:`snakeplan.evaluation.mission.replay`), and per
    target the mission time it was first seen and first reached after that (s; inf: never)."""

    found_s: np.ndarray
    reached_s: np.ndarray

    @property
    def found(self) -> float:
        """The share of the targets seen."""
        return float(np.isfinite(self.found_s).mean()) if self.found_s.size else 1.0

    @property
    def reached(self) -> float:
        """The share of the targets reached after being seen."""
        return float(np.isfinite(self.reached_s).mean()) if self.reached_s.size else 1.0

    def metrics(self) -> dict:
        """The metrics block of a search plan's ``snakeplan.plan/1`` document and runner rows."""
        f = self.failure

        def times(a):
            return [float(x) if math.isfinite(x) else None for x in a]

        every_found = bool(np.isfinite(self.found_s).all())
        every_reached = bool(np.isfinite(self.reached_s).all())
        return {"searched": self.failure is None, "targets": int(self.found_s.size), "found": self.found,
                "reached": self.reached, "found_s": times(self.found_s), "reached_s": times(self.reached_s),
                "time_to_find_s": float(self.found_s.max()) if every_found and self.found_s.size else None,
                "time_to_reach_s": float(self.reached_s.max()) if every_reached and self.reached_s.size else None,
                "motions": self.motions, "mission_time_s": self.mission_time_s,
                "min_clearance_mm": self.min_clearance_mm if math.isfinite(self.min_clearance_mm) else None,
                "views": self.views, "reach_share": self.views_on_arm / self.views if self.views else 1.0,
                "motion_mm": self.motion_mm, "retractions": self.retractions, "returned": self.returned,
                "first_failure_time_s": None if f is None else f.time_s,
                "first_failure_motion": None if f is None else f.motion}

    def lines(self) -> list[str]:
        """The verdict as console lines."""
        if self.failure is not None:
            head = f"refused ({self.reason}) at {self.failure.time_s:.2f} s, motion {self.failure.motion}"
        else:
            head = {"reached": "searched: every target seen, then reached; every motion valid",
                    "not_found": "searched, valid, but not every target was seen",
                    "not_reached": "searched, valid, but not every target seen was reached"}[self.reason]
        per = ", ".join(f"#{k} seen {_at(f)} reached {_at(r)}" for k, (f, r) in enumerate(zip(self.found_s,
                                                                                                self.reached_s)))
        n = self.found_s.size
        return [head, f"targets found {int(np.isfinite(self.found_s).sum())} of {n}, reached "
                      f"{int(np.isfinite(self.reached_s).sum())} of {n} ({per}); mission {self.mission_time_s:.0f} s, "
                      f"{self.views} views, feed travel {self.motion_mm / 1000:.1f} m, {self.retractions} retractions, "
                      f"min clearance {self.min_clearance_mm:.1f} mm"]


def _at(t: float) -> str:
    return f"at {t:.0f} s" if math.isfinite(t) else "never"


def evaluate_search(scene: Scene, robot: Chain, mission: Mission, settings: InspectionSettings | None = None
                    ) -> SearchReport:
    """Judge search ``mission`` of ``robot`` in ``scene`` (its targets, the debris) under the task's ``settings``
    (default: the mission's own); see the module."""
    settings = mission.settings if settings is None else settings
    with single_threaded():
        common = replay(scene, robot, mission, settings)
        v = mission.views
        first = first_sightings(scene.obstacle_set, scene.targets, settings.camera, v.positions, v.directions)
        found = np.where(first >= 0, v.times_s[np.maximum(first, 0)] if len(v) else np.inf, np.inf)
        crawls = [m for m in mission.motions if isinstance(m, Crawl)]
        reached = np.array([_first_reach(crawls, t, f) for t, f in zip(scene.targets, found)])
    failure = common["failure"]
    if failure is not None:  # nothing counts from the first failure on
        found = np.where(found <= failure.time_s, found, np.inf)
        reached = np.where(reached <= failure.time_s, reached, np.inf)
    if failure is not None:
        reason = failure.kind
    elif not np.isfinite(found).all():
        reason = "not_found"
    else:
        reason = "reached" if np.isfinite(reached).all() else "not_reached"
    return SearchReport(**{**common, "success": reason == "reached", "reason": reason}, found_s=found,
                        reached_s=reached)


def _first_reach(crawls: list[Crawl], target: np.ndarray, after: float) -> float:
    """The first mission time at or after ``after`` (s) at which a crawl's tip is within the reach tolerance of
    ``target``. Each crawl's depth moves linearly between its samples; over each stretch from ``after`` on, the
    depths swept are tested at the stretch's ends and every :data:`REACH_STEP_MM` of the path between them, the tip
    at each the path's point (a hold is its one depth, from ``after`` or its start)."""
    if not math.isfinite(after):
        return math.inf
    for m in crawls:
        if m.end_s < after:
            continue
        t, d = m.times_s, m.depths_mm
        if len(t) == 1:
            if _near(m.path, np.array([d[0]]), target).any():
                return float(max(t[0], after))
            continue
        length = float(cumulative_length(m.path)[-1])
        for k in range(len(t) - 1):
            if t[k + 1] < after:
                continue
            t0 = max(float(t[k]), after)
            d0 = float(np.interp(t0, t[k:k + 2], d[k:k + 2])) if t[k + 1] > t[k] else float(d[k])
            d1 = float(d[k + 1])
            lo, hi = min(d0, d1), max(d0, d1)
            grid = np.arange(0.0, length + REACH_STEP_MM, REACH_STEP_MM)
            depths = np.unique(np.r_[d0, grid[(grid > lo) & (grid < hi)], d1])
            near = depths[_near(m.path, depths, target)]
            if near.size == 0:
                continue
            if d1 == d0:
                return t0
            times = t0 + (near - d0) / (d1 - d0) * (float(t[k + 1]) - t0)
            return float(times.min())
    return math.inf


def _near(path: np.ndarray, depths: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Whether the tip at each of ``depths`` along ``path`` is within the reach tolerance of ``target``."""
    return np.linalg.norm(point_at(path, depths) - target, axis=1) <= REACH_TOLERANCE_MM
