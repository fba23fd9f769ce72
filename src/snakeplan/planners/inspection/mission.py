"""The mission loop of paper 002: ask the planner for a camera path from where the camera is, fly it with the arm,
measure at a constant frequency, fuse every measurement into the surface map, ask again until the budget is spent
(mm, s, K).

The camera flies at the settings' constant speed (acceleration phases are ignored), measuring every
1 / measurement_hz s on the mission clock. The arm follows each path: a configuration every FOLLOW_STEP_MM of
camera travel and at every measurement, warm-started from the one before and checked step by step by the one
validity checker (:meth:`StationArm.follow`); where it cannot follow, the path is flown only as far as it did and
the planner is asked again from there (the mission ends after MAX_STUCK paths in a row the arm cannot start on). The planner sees the map, never the true field: the loop simulates the
measurements (noise from the mission's own stream, :func:`snakeplan.world.mission.mission_rngs`).

What the loop returns is the planner's own account (:class:`FlownMission`: its map and curves) and the
:class:`~snakeplan.world.mission.Mission` the judge replays: the arm's motion and the views.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from snakeplan.mapping import GaussianMap
from snakeplan.planners.inspection.camera_path import CHECK_STEP_MM, CameraPath
from snakeplan.planners.inspection.survey import Survey
from snakeplan.world.mission import InspectionSettings, JointMotion, Mission, Views, mission_rngs

#: Camera travel (mm) between two configurations of the arm along a path.
FOLLOW_STEP_MM = 250.0
#: Paths in a row the arm cannot start on before the mission ends (the planner is asked again after each).
MAX_STUCK = 3

Proposer = Callable[["MissionState"], CameraPath | None]


class MissionEnd(StrEnum):
    """Why a mission ended: its budget was flown; the planner had nothing more to fly; the arm could not follow
    MAX_STUCK paths in a row; the planner's calls used up the time limit. A ``str``: JSON holds the plain value."""

    BUDGET = "budget"
    PLANNER = "planner"
    ARM = "arm"
    TIMEOUT = "timeout"


@dataclass
class MissionState:
    """What a planner sees when asked for the next camera path: the map (read only), where the camera is, the
    mission time spent (s), the survey, the settings."""

    settings: InspectionSettings
    world: Survey
    map: GaussianMap
    position: np.ndarray
    time_s: float

    @property
    def prior_mean(self) -> float:
        """The map's prior mean (K)."""
        return float(self.world.prior.mean[0]) if len(self.world.prior.mean) else 0.0

    @property
    def time_left_s(self) -> float:
        return self.settings.budget_s - self.time_s

    def future_ticks(self, duration: float) -> np.ndarray:
        """Measurement times (s, relative to now) within the next ``duration`` seconds (now excluded)."""
        t = self.settings.ticks() - self.time_s
        return t[(t > 1e-9) & (t <= min(duration, self.time_left_s) + 1e-9)]


@dataclass
class FlownMission:
    """A flown mission as the planner saw it: the camera path (mm) and its times (s), the measurement poses and
    times, the map's RMSE (K) and covariance trace (K^2) after each, planning compute time (wall and process CPU,
    s, summed over the planner's calls), the number of planner calls, the final map, why it ended, and the mission."""

    planner: str
    path: np.ndarray
    path_times: np.ndarray
    poses: np.ndarray
    times: np.ndarray
    rmse: np.ndarray
    trace: np.ndarray
    compute_time_s: float
    compute_cpu_s: float
    plans: int
    final_map: GaussianMap
    stopped: MissionEnd
    mission: Mission

    @property
    def final_mean_k(self) -> np.ndarray:
        return self.final_map.mean

    @property
    def final_variance_k2(self) -> np.ndarray:
        return np.diag(self.final_map.cov)

    def to_dict(self) -> dict:
        """JSON-ready summary: planner, path (mm), measurement times (s) and poses (mm), RMSE (K) and
        covariance trace (K^2) curves, planning compute time (s), planner calls."""
        return {"planner": self.planner, "path": self.path.tolist(), "path_times_s": self.path_times.tolist(),
                "measurement_times_s": self.times.tolist(), "measurement_poses": self.poses.tolist(),
                "rmse_k": self.rmse.tolist(), "trace_k2": self.trace.tolist(),
                "final_rmse_k": float(self.rmse[-1]) if self.rmse.size else None,
                "final_trace_k2": float(self.trace[-1]) if self.trace.size else None,
                "compute_time_s": self.compute_time_s, "compute_cpu_s": self.compute_cpu_s, "plans": self.plans}


def _follow_times(duration: float, speed: float, ticks: np.ndarray) -> np.ndarray:
    """Times (s, from a path's start) of the arm's configurations along it: every FOLLOW_STEP_MM of camera travel
    and every measurement, up to ``duration``."""
    n = max(1, math.ceil(duration * speed / FOLLOW_STEP_MM))
    grid = np.linspace(0.0, duration, n + 1)[1:]
    return np.unique(np.concatenate([grid, ticks[(ticks > 1e-9) & (ticks <= duration + 1e-9)]]))


def fly(name: str, propose: Proposer, settings: InspectionSettings, world: Survey, truth: np.ndarray, seed: int,
        time_limit_s: float = math.inf, on_measure: Callable[[float, np.ndarray, GaussianMap], None] | None = None
        ) -> FlownMission:
    """Fly a mission of planner ``name`` whose ``propose(state)`` gives the next camera path (None: done); see the
    module. The planner's calls may take ``time_limit_s`` in all (wall time; the mission stops, ``"timeout"``,
    before a call once they have). ``on_measure(t, pose, map)`` is called after each measurement is fused; it must
    not change the map."""
    noise_rng = mission_rngs(seed)[1]
    gmap = GaussianMap(world.prior.mean, world.prior.covariance)
    pos = world.home()
    held, base, q = world.reach.solve(pos)
    ticks = settings.ticks()
    times, rmse, trace, poses, dirs = [], [], [], [], []
    path, path_t = [pos], [0.0]
    m_times, m_bases, m_q = [0.0], [base], [q]

    def measure(p: np.ndarray, t: float) -> None:
        d = world.look(p)
        nodes, y, r = world.camera.measure(p, d, truth, noise_rng)
        gmap.update(nodes, y, r)
        poses.append(p)
        dirs.append(d)
        times.append(t)
        rmse.append(gmap.rmse(truth))
        trace.append(gmap.trace)
        if on_measure is not None:
            on_measure(t, p, gmap)

    now, compute, cpu, plans, stuck = 0.0, 0.0, 0.0, 0, 0
    stopped = MissionEnd.BUDGET
    if not held:
        stopped = MissionEnd.ARM
    else:
        measure(pos, 0.0)
    while stopped is MissionEnd.BUDGET and settings.budget_s - now > 1e-9:
        if compute >= time_limit_s:
            stopped = MissionEnd.TIMEOUT
            break
        state = MissionState(settings, world, gmap, pos.copy(), now)
        t0, c0 = time.perf_counter(), time.process_time()
        traj = propose(state)
        compute += time.perf_counter() - t0
        cpu += time.process_time() - c0
        plans += 1
        if traj is None or traj.length < 1e-6:
            stopped = MissionEnd.PLANNER
            break
        fly_s = min(traj.duration, settings.budget_s - now)
        at = _follow_times(fly_s, settings.speed_mm_s, ticks - now)
        arm = world.reach.follow(traj.at_time(at), m_bases[-1], m_q[-1], now + at)
        if arm.held < len(at):
            fly_s = float(at[arm.held - 1]) if arm.held else 0.0
            at = at[:arm.held]
            stopped = MissionEnd.ARM
        for t in ticks[(ticks > now + 1e-9) & (ticks <= now + fly_s + 1e-9)]:
            measure(traj.at_time(t - now), float(t))
        m_times.extend(now + at)
        m_bases.extend(arm.bases[:len(at)])
        m_q.extend(arm.q[:len(at)])
        if fly_s > 0.0:
            dense = np.linspace(0.0, fly_s, max(2, math.ceil(fly_s * settings.speed_mm_s / CHECK_STEP_MM) + 1))
            path.extend(traj.at_time(dense[1:]))
            path_t.extend(now + dense[1:])
            pos = traj.at_time(fly_s)
            now += fly_s
        stuck = stuck + 1 if fly_s == 0.0 else 0
        if stopped is MissionEnd.ARM and stuck < MAX_STUCK:
            stopped = MissionEnd.BUDGET  # flown as far as the arm followed: ask again from there
    if stopped is MissionEnd.BUDGET and settings.budget_s - now > 1e-9:
        stopped = MissionEnd.PLANNER
    if len(path) == 1:
        path.append(pos)
        path_t.append(now)
    views = Views(np.array(times), np.array(poses).reshape(-1, 3), np.array(dirs).reshape(-1, 3))
    motion = JointMotion(np.array(m_times), np.array(m_bases), np.array(m_q))
    mission = Mission((motion,), views, settings, int(seed))
    return FlownMission(name, np.array(path), np.array(path_t), views.positions, views.times_s, np.array(rmse),
                        np.array(trace), compute, cpu, plans, gmap, stopped, mission)
