"""What an export carries: a judged plan or mission as the arm's motion over time beside the scene and the verdict.

A :class:`Recording` is made once (:func:`of_trajectory` for a reach plan the robot can execute, :func:`of_plan`
for any reach plan, feasible or not, :func:`of_mission` for an inspect or search mission) and written by every
exporter (:mod:`.bag`, :mod:`.foxglove`), so a ROS bag and a Foxglove file of one plan show the same motion.
Lengths in mm and times in s here; the exporters convert to SI.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from snakeplan import ftl
from snakeplan.geometry.polyline import point_at
from snakeplan.geometry.surface_points import surface_triangles
from snakeplan.robots import Chain
from snakeplan.scenes import Scene
from snakeplan.trajectory import Trajectory
from snakeplan.world import JUDGE
from snakeplan.world.joint_motion import arm_bodies
from snakeplan.world.mission import Crawl, Views, tips_at


@dataclass(frozen=True)
class Failure:
    """The judge's first failure: its kind, the time (s) the arm reaches it and where the tip is then (mm)."""

    reason: str
    time_s: float
    position: np.ndarray


@dataclass(frozen=True)
class Recording:
    """The arm at samples in time: ``t (T,)`` s, nondecreasing; the base poses ``bases (T, 4, 4)`` (mm, scene
    frame); ``q (T, dof)`` (feed mm, angles rad); ``robot`` with an identity base (its URDF is the one in the
    bag). ``velocities`` and ``accelerations`` (T, dof) come with a timed trajectory (None for a mission, whose
    samples are where its motions are piecewise linear). ``paths``: the tip paths flown (mm), with the time each
    starts; ``views`` a mission's, or None; ``points`` (P, 3) mm the points the judge counts (a fed arm's points of
    interest, the station's mesh nodes) and ``first_seen`` (P,) s when a view first saw each (inf: never; the
    station's: the mission's end, as the judge's map says which, not when); ``found_s`` (k,) s when a search's
    targets were found (inf: never; None unless a search). ``success`` and ``verdict`` (one line) are the judge's,
    ``failure`` its first failure."""

    scene: Scene
    robot: Chain
    t: np.ndarray
    bases: np.ndarray
    q: np.ndarray
    paths: list[np.ndarray]
    path_starts_s: np.ndarray
    success: bool
    verdict: str
    failure: Failure | None = None
    velocities: np.ndarray | None = None
    accelerations: np.ndarray | None = None
    views: Views | None = None
    points: np.ndarray | None = None
    first_seen: np.ndarray | None = None
    found_s: np.ndarray | None = None

    @property
    def duration_s(self) -> float:
        return float(self.t[-1]) if len(self.t) else 0.0

    def joint_positions(self) -> np.ndarray:
        """The body's joints (T, n+1, 3) mm in the scene frame at every sample."""
        return arm_bodies(self.robot, self.bases, self.q)

    @cached_property
    def triangles(self) -> list[np.ndarray]:
        """Each obstacle's surface as triangles (k, 3, 3) mm, tessellated once for every writer."""
        return scene_triangles(self.scene)

    def coverage_updates(self) -> Iterator[tuple[float, np.ndarray]]:
        """(time s, which points are seen by then) at the start and whenever a view sees a point first."""
        if self.points is None:
            return
        first = self.first_seen
        yield 0.0, first <= 0.0
        for t in np.unique(first[np.isfinite(first) & (first > 0.0)]).tolist():
            yield t, first <= t


def scene_triangles(scene: Scene) -> list[np.ndarray]:
    """Each obstacle's surface as triangles (k, 3, 3) mm
    (:func:`snakeplan.geometry.surface_points.surface_triangles`: a mesh's own, a primitive's tessellation)."""
    return [surface_triangles(o) for o in scene.obstacles]


def of_trajectory(scene: Scene, traj: Trajectory) -> Recording:
    """A judged, executable reach plan in ``scene``: every crawl state at its TOPP-RA time."""
    report = traj.report
    bases = np.broadcast_to(traj.base_pose, (len(traj.t), 4, 4))
    return Recording(scene, traj.robot.with_base(np.eye(4)), traj.t, bases, traj.positions, [traj.path],
                     np.zeros(1), report.success, report.lines()[0], None, traj.velocities, traj.accelerations)


def of_plan(scene: Scene, robot: Chain, path: np.ndarray, report) -> Recording:
    """Any judged reach plan, feasible or not: the crawl states at the judge's steps, timed at the robot's feed
    speed (no time scaling: a plan the judge refuses is shown, not executed), and the judge's first failure, where
    the tip is on the path at its depth."""
    p = np.asarray(path, dtype=np.float64)
    entrance, u = scene.entrance.position, scene.entrance.direction
    states = ftl.crawl(p, robot.lengths, u, JUDGE.step_mm, entrance=entrance)
    base, q = ftl.fed_joints(robot, entrance, u, states)
    speed = robot.limits.feed_speed_mm_s
    failure = None
    if report.first_failure_depth_mm is not None:
        depth = float(report.first_failure_depth_mm)
        failure = Failure(report.reason, depth / speed, point_at(p, np.array([depth]))[0])
    return Recording(scene, robot.with_base(np.eye(4)), states.s / speed, np.broadcast_to(base, (len(q), 4, 4)), q,
                     [p], np.zeros(1), report.success, report.lines()[0], failure)


def _crawl_samples(scene: Scene, robot: Chain, crawl: Crawl) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(times, base poses, joint vectors) of a fed arm's crawl: its samples, and between two of them a sample every
    judge's step (5 mm) of depth, where the body follows the leader."""
    times, depths = [crawl.times_s[:1]], [crawl.depths_mm[:1]]
    for k in range(1, len(crawl.times_s)):
        steps = max(1, int(np.ceil(abs(crawl.depths_mm[k] - crawl.depths_mm[k - 1]) / JUDGE.step_mm)))
        f = np.arange(1, steps + 1) / steps
        times.append(crawl.times_s[k - 1] + f * (crawl.times_s[k] - crawl.times_s[k - 1]))
        depths.append(crawl.depths_mm[k - 1] + f * (crawl.depths_mm[k] - crawl.depths_mm[k - 1]))
    t, d = np.concatenate(times), np.concatenate(depths)
    entrance, u = scene.entrance.position, scene.entrance.direction
    states = ftl.fit_states(crawl.path, robot.lengths, d, u, entrance=entrance)
    base, q = ftl.fed_joints(robot, entrance, u, states)
    return t, np.broadcast_to(base, (len(t), 4, 4)), q


def _failure_tip(scene: Scene, robot: Chain, mission, failure) -> np.ndarray:
    """Where the tip is when the judge's first failure happens: in the motion it names, or, for a failure of the
    mission as a whole (motion -1), in the motion under way then; at the entrance when there is none."""
    motions = mission.motions
    if not motions:
        return scene.entrance.position
    k = failure.motion if failure.motion >= 0 else next(
        (i for i, m in enumerate(motions) if m.end_s >= failure.time_s), len(motions) - 1)
    return tips_at(robot, motions[k], failure.time_s)[0]


def of_mission(scene: Scene, robot: Chain, mission, report) -> Recording:
    """An inspect or search mission as the judge replayed it: every motion's samples in time order (a crawl's every
    5 mm of depth, a joint motion's as given: its joints move linearly between them), the views, which points of
    interest the views saw first when (the judge's camera), a search's targets and when each was found, and the
    judge's first failure."""
    from snakeplan.evaluation import SearchReport
    from snakeplan.world.mission import inspected_surface
    from snakeplan.world.sight import PoiCamera

    ts, bases, qs, paths, starts = [np.zeros(0)], [np.zeros((0, 4, 4))], [np.zeros((0, robot.dof))], [], []
    for motion in mission.motions:
        if isinstance(motion, Crawl):
            t, b, q = _crawl_samples(scene, robot, motion)
            paths.append(motion.path)
            starts.append(motion.start_s)
        else:
            t, b, q = motion.times_s, motion.bases, motion.q
        if len(ts[-1]) and t[0] == ts[-1][-1] and np.array_equal(q[0], qs[-1][-1]) and np.array_equal(
                b[0], bases[-1][-1]):  # a motion starts where the one before ended: one sample of the two
            t, b, q = t[1:], b[1:], q[1:]
        ts.append(t)
        bases.append(b)
        qs.append(q)
    views = mission.views
    f = report.failure
    failure = None if f is None else Failure(report.reason, f.time_s, _failure_tip(scene, robot, mission, f))
    search = isinstance(report, SearchReport)
    points = first = None
    if not search and report.tip_camera:  # a fed arm's points of interest, each when a view first saw it
        pois = scene.points_of_interest
        points = pois.points
        first = PoiCamera(scene.obstacle_set, pois, mission.settings.camera).first_seen(
            views.times_s, views.positions, views.directions)
    elif not search and report.seen is not None:  # the station's mesh nodes: the judge's map says which, not when
        points = inspected_surface(scene)[0].vertices
        first = np.where(report.seen, float(views.times_s[-1]) if len(views) else 0.0, np.inf)
    return Recording(scene, robot.with_base(np.eye(4)), np.concatenate(ts), np.concatenate(bases),
                     np.concatenate(qs), paths, np.array(starts), report.success, report.lines()[0], failure,
                     views=views, points=points, first_seen=first,
                     found_s=np.asarray(report.found_s, dtype=float) if search else None)
