"""The judge of inspection missions: every motion of the arm through the one validity checker under ``JUDGE``,
every view on the arm's tip, and what the views saw recomputed from the camera model (mm, rad, s, K).

The planner's own account of its mission (its map, its curves) is not read. The judge replays the motions
(whole body, collisions certified between samples, bends and joint limits every step: the checker's joint
motions; a fed arm's crawls as reaching's crawls), checks that the tip is where each view says the camera was, and
measures again: the views' sightings by ray casts against the inspected surface, the simulated measurements drawn
from the mission's measurement seed, fused into the surface map from its prior. The map's error and uncertainty,
and the share of the surface seen, come from that recomputation.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from snakeplan.geometry.polyline import cumulative_length, point_at, prefix
from snakeplan.mapping.models import CameraModel
from snakeplan.robots import Chain
from snakeplan.scenes import Scene
from snakeplan.threads import single_threaded
from snakeplan.world import ENTRANCE_TOLERANCE_MM, JUDGE, REACH_TOLERANCE_MM, FullView, ValidityChecker
from snakeplan.world.joint_motion import JointMotionCheck, MotionFailure
from snakeplan.world.mission import (
    Crawl,
    InspectionSettings,
    JointMotion,
    Mission,
    inspected_surface,
    mission_rngs,
    points_field,
    points_prior,
    tip_poses,
    tips_at,
)

#: The reasons a mission is refused, and its verdict when none holds.
MISSION_FAILURES = ("settings", "no_motion", "collision", "bend_limit", "joint_limit", "insertion", "out_of_bounds",
                    "not_at_entrance", "discontinuity", "too_fast", "over_budget", "view_times", "view_off_arm")
INSPECTED = "inspected"
#: How far (mm) one motion may end from where the next starts (the tip), and how far apart in time (s).
CONTINUITY_MM = 1e-6
CONTINUITY_S = 1e-9
#: How far (rad) a tip camera's view direction may be from the tip's axis.
VIEW_ANGLE_TOL_RAD = 1e-3
#: Relative round-off allowed on the feed speed limit.
SPEED_TOL = 1e-6


@dataclass(frozen=True)
class MissionFailure:
    """The first thing wrong with a mission: the motion (index), the mission time (s), the kind (one of
    :data:`MISSION_FAILURES`) and the link or joint involved, if any."""

    motion: int
    time_s: float
    kind: str
    link: int | None = None


@dataclass(frozen=True, kw_only=True)
class Replayed:
    """What the judge's replay of a mission decides whatever the task (:func:`replay`): the verdict and the first
    failure, the motions, the mission's length (s), the least clearance (mm), the views and those on the arm, the
    feed's travel (mm), the retractions, whether the arm came back out, and whether views are a tip camera's."""

    success: bool
    reason: str
    failure: MissionFailure | None
    motions: int
    mission_time_s: float
    min_clearance_mm: float
    views: int
    views_on_arm: int
    motion_mm: float = 0.0
    retractions: int = 0
    returned: bool = False
    tip_camera: bool = False


@dataclass(frozen=True, kw_only=True)
class MissionReport(Replayed):
    """The judge's verdict on an inspect mission and the map its views make (see the module)."""

    coverage: float
    times_s: np.ndarray
    rmse_k: np.ndarray
    trace_k2: np.ndarray
    final_mean_k: np.ndarray
    final_variance_k2: np.ndarray
    seen: np.ndarray | None = None

    def metrics(self) -> dict:
        """The metrics block of an inspect plan's ``snakeplan.plan/1`` document and runner rows."""
        f = self.failure
        return {"inspected": self.success, "motions": self.motions, "mission_time_s": self.mission_time_s,
                "min_clearance_mm": self.min_clearance_mm if math.isfinite(self.min_clearance_mm) else None,
                "views": self.views,
                "reach_share": self.views_on_arm / self.views if self.views else 1.0,
                "coverage": self.coverage,
                "points": None if self.seen is None else int(self.seen.size),
                "points_seen": None if self.seen is None else int(self.seen.sum()),
                "seen_points": np.flatnonzero(self.seen).tolist() if self.tip_camera else None,
                "motion_mm": self.motion_mm, "retractions": self.retractions, "returned": self.returned,
                "final_rmse_k": float(self.rmse_k[-1]) if self.rmse_k.size else None,
                "final_trace_k2": float(self.trace_k2[-1]) if self.trace_k2.size else None,
                "first_failure_time_s": None if f is None else f.time_s,
                "first_failure_motion": None if f is None else f.motion,
                "measurement_times_s": self.times_s.tolist(), "rmse_k": self.rmse_k.tolist(),
                "trace_k2": self.trace_k2.tolist()}

    def lines(self) -> list[str]:
        """The verdict as console lines."""
        head = "inspected: every motion valid, every view on the arm" if self.success else (
            f"refused ({self.reason}) at {self.failure.time_s:.2f} s, motion {self.failure.motion}")
        if self.tip_camera:
            mapped = f", final RMSE {self.rmse_k[-1]:.3f} K" if self.rmse_k.size else ""
            return [head, f"views {self.views} ({self.views_on_arm} on the arm), points of interest seen "
                          f"{int(self.seen.sum())} of {self.seen.size} ({self.coverage:.1%}){mapped}, mission "
                          f"{self.mission_time_s:.0f} s, feed travel {self.motion_mm / 1000:.1f} m, "
                          f"{self.retractions} retractions, {'back out' if self.returned else 'left inserted'}, "
                          f"min clearance {self.min_clearance_mm:.1f} mm"]
        rmse = f"{self.rmse_k[-1]:.3f} K" if self.rmse_k.size else "none (no view)"
        return [head, f"views {self.views} ({self.views_on_arm} on the arm), coverage {self.coverage:.1%}, "
                      f"final RMSE {rmse}, min clearance {self.min_clearance_mm:.1f} mm"]


_CAMERAS: dict[tuple, object] = {}


def _camera(mesh, model: CameraModel):
    """The camera bound to the inspected surface (a ``SurfaceCamera``), kept per mesh content and camera model."""
    from snakeplan.mapping import SurfaceCamera

    key = (mesh.fingerprint, model)
    if key not in _CAMERAS:
        _CAMERAS[key] = SurfaceCamera(mesh.vertices, mesh.faces, model)
    return _CAMERAS[key]


_FIELDS: dict[str, object] = {}


def _field(mesh):
    """The distance field round the inspected surface (``mapping.field.DistanceField``), kept per mesh content."""
    from snakeplan.mapping.field import DistanceField

    if mesh.fingerprint not in _FIELDS:
        _FIELDS[mesh.fingerprint] = DistanceField(mesh.vertices, mesh.faces)
    return _FIELDS[mesh.fingerprint]


def _motion_failure(checker: ValidityChecker, jm: JointMotionCheck, motion, index: int, feed_speed: float
                    ) -> MissionFailure | None:
    """The first failure of one motion, in mission time (``jm``: the checker's joint motions): a crawl's states
    from depth 0 to its deepest (the checker's crawl rules), its feed no faster than ``feed_speed`` (mm/s)."""
    if isinstance(motion, JointMotion):
        f: MotionFailure | None = jm.first_failure(motion.times_s, motion.bases, motion.q)
        return None if f is None else MissionFailure(index, f.time_s, f.kind, f.link)
    if np.linalg.norm(motion.path[0] - checker.entrance) > ENTRANCE_TOLERANCE_MM:
        return MissionFailure(index, motion.start_s, "not_at_entrance")
    d, t = motion.depths_mm, motion.times_s
    dt = np.diff(t)
    fast = np.abs(np.diff(d)) > feed_speed * (1.0 + SPEED_TOL) * dt + CONTINUITY_MM
    if fast.any():
        return MissionFailure(index, float(t[int(np.argmax(fast))]), "too_fast")
    f = checker.first_failure(motion.path, 0.0, float(d.max()))
    if f is None:
        return None
    k = int(np.argmax(d >= f.depth_mm - CONTINUITY_MM))
    at = float(t[k]) if k == 0 else float(np.interp(f.depth_mm, d[k - 1:k + 1], t[k - 1:k + 1])
                                          if d[k] > d[k - 1] else t[k])
    return MissionFailure(index, at, str(f.kind), f.link)


def _ends(jm: JointMotionCheck, motion) -> tuple[np.ndarray, np.ndarray]:
    """The body (joint positions, mm) where a motion starts and where it ends: a crawl's at its entrance and at its
    last state (the tip alone: its body follows the path), a joint motion's whole at its first and last sample."""
    if isinstance(motion, JointMotion):
        bodies = jm.bodies(motion.bases[[0, -1]], motion.q[[0, -1]])
        return bodies[0], bodies[1]
    tips = tips_at(jm.robot, motion, [motion.start_s, motion.end_s])
    return tips[0][None], tips[1][None]


def _same_prefix(a: np.ndarray, b: np.ndarray, depth: float) -> bool:
    """Whether tip paths ``a`` and ``b`` agree (to CONTINUITY_MM) over their first ``depth`` mm: where one crawl
    hands the arm to the next, the body lies on that stretch of both. Both are polylines, so comparing them at
    every vertex of either up to ``depth`` is exact."""
    ca, cb = cumulative_length(a), cumulative_length(b)
    s = np.unique(np.concatenate([ca[ca < depth], cb[cb < depth], [depth]]))
    return bool(np.max(np.linalg.norm(point_at(a, s) - point_at(b, s), axis=1)) <= CONTINUITY_MM)


def _joins(previous, motion, jm: JointMotionCheck) -> bool:
    """Whether ``motion`` starts where ``previous`` ended: in time, and the arm's body (two crawls: the same depth
    along paths that agree up to it; else the bodies :func:`_ends` gives)."""
    if abs(motion.start_s - previous.end_s) > CONTINUITY_S:
        return False
    if isinstance(previous, Crawl) and isinstance(motion, Crawl):
        d = float(previous.depths_mm[-1])
        return abs(float(motion.depths_mm[0]) - d) <= CONTINUITY_MM and _same_prefix(previous.path, motion.path, d)
    end, start = _ends(jm, previous)[1], _ends(jm, motion)[0]
    return bool(np.max(np.linalg.norm(start - end, axis=-1)) <= CONTINUITY_MM)


def _task_failure(mission: Mission, settings: InspectionSettings) -> MissionFailure | None:
    """What is wrong with a mission as a whole before any motion is replayed: flown under other settings than the
    task's, no motion, views not one at each measurement time of the settings' clock (a tip camera's: not in
    time order), or past the budget."""
    if mission.settings != settings:
        return MissionFailure(-1, 0.0, "settings")
    if not mission.motions:
        return MissionFailure(-1, 0.0, "no_motion")
    end = max(m.end_s for m in mission.motions)
    if end > settings.budget_s + CONTINUITY_S:
        return MissionFailure(len(mission.motions) - 1, settings.budget_s, "over_budget")
    t, ticks = mission.views.times_s, settings.ticks()
    if settings.tip_camera:
        early = np.flatnonzero(np.diff(t) < 0.0)
        return None if early.size == 0 else MissionFailure(-1, float(t[early[0] + 1]), "view_times")
    on_tick = np.abs(t[:, None] - ticks[None]).min(axis=1, initial=np.inf) <= CONTINUITY_S if t.size else t.astype(bool)
    if not on_tick.all() or np.any(np.diff(t) <= 0.0):
        k = int(np.argmin(on_tick)) if not on_tick.all() else int(np.argmax(np.diff(t) <= 0.0)) + 1
        return MissionFailure(-1, float(t[k]), "view_times")
    return None


def measure_views(scene: Scene, mission: Mission, on_measure: Callable[[float, np.ndarray, object], None] | None = None
                  ) -> tuple[object, np.ndarray, list[float], list[float]]:
    """Measure again from every view of ``mission``: sightings by ray casts against the inspected surface, the
    simulated measurements drawn from the mission's measurement seed, fused into the map from its prior. Returns
    (the final map, a ``GaussianMap``; which surface nodes were seen; the RMSE (K) and covariance trace (K^2) after
    each view); ``on_measure(t, position, map)`` sees the map after each. The camera is aimed as its pan-tilt aims
    it, at the closest point of the surface (the judge's own distance field), whatever the views' directions say. The
    mapping machinery loads here, for a mission only."""
    from snakeplan.mapping import GaussianMap, surface_prior

    surface, truth = inspected_surface(scene)
    s, views = mission.settings, mission.views
    prior = surface_prior(surface.vertices, surface.faces, s.prior_mean(scene.metadata), s.sigma_f, s.length_scale)
    aims = _field(surface).look_direction(views.positions) if len(views) else views.directions
    return _fuse(GaussianMap(prior.mean, prior.covariance), _camera(surface, s.camera), truth, mission, aims,
                 on_measure)


def _fuse(gmap, camera, truth: np.ndarray, mission: Mission, aims: np.ndarray,
          on_measure: Callable[[float, np.ndarray, object], None] | None):
    """Each view's simulated measurement by ``camera`` (its ``measure(position, direction, truth, rng)``) from the
    view's position along its aim, noise from the mission's measurement seed, fused into ``gmap`` in view order:
    (the map, which nodes were seen, the RMSE (K) and covariance trace (K^2) after each view)."""
    noise = mission_rngs(mission.measurement_seed)[1]
    seen = np.zeros(len(truth), dtype=bool)
    rmse, trace = [], []
    v = mission.views
    for t, p, d in zip(v.times_s, v.positions, aims):
        nodes, y, r = camera.measure(p, d, truth, noise)
        gmap.update(nodes, y, r)
        seen[nodes] = True
        rmse.append(gmap.rmse(truth))
        trace.append(gmap.trace)
        if on_measure is not None:
            on_measure(float(t), p, gmap)
    return gmap, seen, rmse, trace


def evaluate_mission(scene: Scene, robot: Chain, mission: Mission, settings: InspectionSettings | None = None
                     ) -> MissionReport:
    """Judge ``mission`` of ``robot`` in ``scene`` under the task's ``settings`` (default: the mission's own; a
    mission flown under others is refused); ValueError for a scene with no surface to inspect, or motions of
    another arm (their joint count). BLAS runs on one thread (:mod:`snakeplan.threads`), as the mission did: the
    map's small updates are faster so, and the same bits in any process."""
    with single_threaded():
        return _evaluate_mission(scene, robot, mission, mission.settings if settings is None else settings)


def _evaluate_mission(scene: Scene, robot: Chain, mission: Mission, settings: InspectionSettings) -> MissionReport:
    if not settings.tip_camera:
        inspected_surface(scene)
    common = replay(scene, robot, mission, settings)
    views = mission.views
    if settings.tip_camera and points_field(scene) is None:  # points to see, no field to map
        seen = points_seen(scene, settings.camera, views.positions, views.directions)
        return MissionReport(**common, coverage=float(seen.mean()), times_s=views.times_s.copy(), rmse_k=np.zeros(0),
                             trace_k2=np.zeros(0), final_mean_k=np.zeros(0), final_variance_k2=np.zeros(0), seen=seen)
    measure = measure_points if settings.tip_camera else measure_views
    gmap, seen, rmse, trace = measure(scene, replace(mission, settings=settings))  # the task's camera
    return MissionReport(**common, coverage=float(seen.mean()), times_s=views.times_s.copy(), rmse_k=np.array(rmse),
                         trace_k2=np.array(trace), final_mean_k=gmap.mean.copy(),
                         final_variance_k2=np.diag(gmap.cov).copy(), seen=seen)


def replay(scene: Scene, robot: Chain, mission: Mission, settings: InspectionSettings) -> dict:
    """The judge's replay of a mission's motions and views, whatever the task: the mission as a whole, every motion
    through the checker under ``JUDGE`` in order and joined to the one before, every view on the tip. Returns the
    fields of :class:`Replayed` it decides, as keywords."""
    for i, m in enumerate(mission.motions):
        if isinstance(m, JointMotion) and m.q.shape[1] != robot.dof:
            raise ValueError(f"mission.motions[{i}].q: {m.q.shape[1]} joints per sample; {robot.name} has "
                             f"{robot.dof}")
    checker = ValidityChecker(FullView(scene), robot, JUDGE)
    jm = checker.joint_motions()
    failure: MissionFailure | None = _task_failure(mission, settings)
    clearance = math.inf
    for i, motion in enumerate(mission.motions if failure is None else ()):
        if i == 0 and isinstance(motion, Crawl) and motion.depths_mm[0] > CONTINUITY_MM:
            failure = MissionFailure(i, motion.start_s, "not_at_entrance")
            break
        if i > 0 and not _joins(mission.motions[i - 1], motion, jm):
            failure = MissionFailure(i, motion.start_s, "discontinuity")
            break
        found = _motion_failure(checker, jm, motion, i, robot.limits.feed_speed_mm_s)
        if isinstance(motion, JointMotion):
            clearance = min(clearance, jm.least_clearance(motion.bases, motion.q))
        else:
            reached = prefix(motion.path, float(motion.depths_mm.max()))
            clearance = min(clearance, checker.crawl(reached).min_clearance)
        if found is not None:
            failure = found
            break
    views = mission.views
    held = np.zeros(len(views), dtype=bool)
    for i, motion in enumerate(mission.motions):
        inside = (views.times_s >= motion.start_s - CONTINUITY_S) & (views.times_s <= motion.end_s + CONTINUITY_S)
        if not inside.any():
            continue
        if settings.tip_camera and isinstance(motion, Crawl):
            tips, axes = tip_poses(motion.path, motion.depth_at(views.times_s[inside]), robot.lengths,
                                   scene.entrance.direction)
            aligned = np.einsum("ij,ij->i", axes, views.directions[inside]) >= math.cos(VIEW_ANGLE_TOL_RAD)
        else:
            tips, aligned = tips_at(jm.robot, motion, views.times_s[inside]), True
        held[inside] |= (np.linalg.norm(tips - views.positions[inside], axis=1) <= REACH_TOLERANCE_MM) & aligned
    if failure is None and not held.all():
        k = int(np.argmin(held))
        owner = next((i for i, m in enumerate(mission.motions) if m.start_s <= views.times_s[k] <= m.end_s), -1)
        failure = MissionFailure(owner, float(views.times_s[k]), "view_off_arm")
    end_s = max((m.end_s for m in mission.motions), default=0.0)
    crawls = [m for m in mission.motions if isinstance(m, Crawl)]
    common = dict(success=failure is None, reason=INSPECTED if failure is None else failure.kind, failure=failure,
                  motions=len(mission.motions), mission_time_s=float(end_s), min_clearance_mm=float(clearance),
                  views=len(views), views_on_arm=int(held.sum()),
                  motion_mm=float(sum(m.travel_mm for m in crawls)),
                  retractions=int(sum(_reversals(m.depths_mm) for m in crawls)),
                  returned=bool(crawls) and float(crawls[-1].depths_mm[-1]) <= CONTINUITY_MM,
                  tip_camera=settings.tip_camera)
    return common


def _reversals(depths: np.ndarray) -> int:
    """How many times a depth profile turns from inserting to retracting (the retractions of a crawl)."""
    step = np.sign(np.diff(depths))
    step = step[step != 0]
    return int(np.sum((step[:-1] > 0) & (step[1:] < 0)) + (1 if step.size and step[0] < 0 else 0))


def measure_points(scene: Scene, mission: Mission, on_measure: Callable[[float, np.ndarray, object], None] | None = None
                   ) -> tuple[object, np.ndarray, list[float], list[float]]:
    """A fed arm's views measured again on the scene's field at its points of interest: each view's simulated
    measurement (the tip camera, :meth:`snakeplan.world.sight.PoiCamera.measure`, noise from the mission's
    measurement seed) fused into the map from its prior in view order. Returns (the final map, which points were
    seen, the RMSE (K) and covariance trace (K^2) after each view), as :func:`measure_views` does for the station;
    ``on_measure(t, position, map)`` sees the map after each."""
    from snakeplan.mapping import GaussianMap
    from snakeplan.world.sight import PoiCamera

    truth = points_field(scene)
    prior = points_prior(scene, mission.settings)
    camera = PoiCamera(scene.obstacle_set, scene.points_of_interest, mission.settings.camera)
    return _fuse(GaussianMap(prior.mean, prior.covariance), camera, truth, mission, mission.views.directions,
                 on_measure)


def points_seen(scene: Scene, camera: CameraModel, positions: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Which of the scene's points of interest (n,) bool the tip camera sees from the views (positions (k, 3) mm,
    directions (k, 3)): :class:`snakeplan.world.sight.PoiCamera` against every obstacle."""
    from snakeplan.world.sight import PoiCamera

    return PoiCamera(scene.obstacle_set, scene.points_of_interest, camera).seen(positions, directions)
