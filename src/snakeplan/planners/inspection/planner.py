"""The base of the inspection planners: a :class:`~snakeplan.planners.base.Planner` for the inspect task whose
subclasses propose camera paths from the map as it stands; the mission loop flies them with the arm.

A subclass sets ``name`` and implements :meth:`InspectionPlanner.next_path`; ``reset`` is called once before a
mission with the survey and the planner's seeded generator. :meth:`Planner.plan` times the whole mission (the
planner's calls, the arm following, the simulated measurements); the planner's own calls are in the plan's
``details`` (``planning_time_s``, ``compute_cpu_s``, ``plans``), and ``time_limit_s`` bounds them (flying the
mission is the simulated world's time, not the planner's).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import ClassVar

import numpy as np

from snakeplan.geometry.polyline import point_at
from snakeplan.mapping import GaussianMap, kalman
from snakeplan.planners.base import Planner, Problem, Solution, Status
from snakeplan.planners.inspection.branches import (
    BRANCH_TIME_S,
    VIEW_STEP_MM,
    Branch,
    BranchSource,
    coverage_of,
    mission_of,
    mission_time,
)
from snakeplan.planners.inspection.camera_path import CameraPath
from snakeplan.planners.inspection.library import VIEW_STANDOFF_MM
from snakeplan.planners.inspection.mission import MAX_STUCK, FlownMission, MissionEnd, MissionState, fly
from snakeplan.planners.inspection.survey import Survey, survey_for
from snakeplan.scenes import Task
from snakeplan.world.mission import inspected_surface, mission_rngs

#: Time kept back from a fed arm's planner for building its mission from the branches: at most this (s), or this
#: share of the time limit.
ASSEMBLY_RESERVE_S = 1.0
ASSEMBLY_RESERVE_SHARE = 0.05
#: Control points per planned camera path (paper 002 §4), the current position included.
N_CONTROL_POINTS = 5
#: Why a mission ended short of its budget -> the plan's ``details["stopped"]``.
_STOPPED = {MissionEnd.PLANNER: Status.NO_PROGRESS, MissionEnd.ARM: Status.NO_PROGRESS,
            MissionEnd.TIMEOUT: Status.TIMEOUT}
#: What a mission's end means, for a plan's why.
_WHY = {MissionEnd.PLANNER: "the planner had no camera path left to fly",
        MissionEnd.ARM: f"the arm could not follow {MAX_STUCK} camera paths in a row",
        MissionEnd.TIMEOUT: "the planner's calls used up the time limit"}


def mission_details(flown: FlownMission, survey: Survey) -> dict:
    """The plan's details of a flown mission: the planner's own curves and final map, its calls and their time,
    the mission's settings and the survey's prior and library."""
    s = flown.mission.settings
    prior = survey.prior
    details = {
        "mission": {"budget_s": s.budget_s, "camera_speed_mm_s": s.speed_mm_s, "measurement_hz": s.measurement_hz},
        "measurement_times": flown.times, "rmse_k": flown.rmse, "trace_k2": flown.trace,
        "final_mean_k": flown.final_map.mean, "final_variance_k2": np.diag(flown.final_map.cov),
        "path_times_s": flown.path_times, "planning_time_s": flown.compute_time_s,
        "compute_cpu_s": flown.compute_cpu_s, "plans": flown.plans, "ended": flown.stopped,
        "world": {"prior_mean_k": float(prior.mean[0]), "sigma_f_k": prior.sigma_f,
                  "length_scale_mm": prior.length_scale,
                  "pd_fix": {"smallest_eigenvalues_before": list(prior.pd_fix.smallest_before),
                             "smallest_eigenvalues_after": list(prior.pd_fix.smallest_after),
                             "clipped": prior.pd_fix.n_clipped, "max_entry_change": prior.pd_fix.max_change},
                  "viewpoints": len(survey.library), "reachable_share": float(survey.library.reachable.mean()),
                  "standoff_mm": VIEW_STANDOFF_MM}}
    if flown.stopped in _STOPPED:
        details["stopped"] = str(_STOPPED[flown.stopped])
    return details


class InspectionPlanner(Planner):
    """An inspection planner: proposes camera paths from the current map (see the module); one that also inspects
    with a fed arm's tip camera (``fed``) chooses the branches of its tree of insertions
    (:meth:`choose_branches`)."""

    name: ClassVar[str] = ""
    tasks: ClassVar[frozenset[Task]] = frozenset({Task.INSPECT})
    #: Whether the planner inspects points of interest with a fed arm's tip camera, and whether it maps a surface
    #: field from a camera path (paper 002's station).
    fed: ClassVar[bool] = False
    maps_fields: ClassVar[bool] = True
    #: A fed arm's inspection may plan with sensed knowledge (its branches grown by a sensing reaching planner);
    #: the station's needs the whole scene (refused in :meth:`plan`).
    needs_full_scene: ClassVar[bool] = False

    def choose_branches(self, source: BranchSource, rng: np.random.Generator, deadline: float
                        ) -> tuple[list[Branch], bool]:
        """(the branches to fly, in order; whether the planner finished rather than ran out of time), within the
        mission's budget and by ``deadline`` (a time.perf_counter() value)."""
        raise NotImplementedError

    def reset(self, problem: Problem, world: Survey, rng: np.random.Generator) -> None:
        """Called once before a mission (subclasses keep their seeded generator here)."""
        self.rng = rng

    def next_path(self, state: MissionState) -> CameraPath | None:
        """The camera path to fly next from ``state.position`` (None: nothing more to do); a planner that maps
        fields implements it."""
        raise NotImplementedError

    def survey(self, problem: Problem) -> Survey:
        """The (cached) survey of the problem's station, arm and settings."""
        return survey_for(problem.scene, problem.robot, problem.inspection)

    def warm_up(self, problem: Problem) -> None:
        """Build the survey and load the map's kernels before the first mission's clock starts (a fed arm's: the
        reaching planner's, the camera's and the follow-the-leader fit's)."""
        super().warm_up(problem)
        if problem.task is not Task.INSPECT:
            return
        if problem.inspection.tip_camera:
            source = BranchSource(problem, 0)
            goal = source.random_goal(np.random.default_rng(0))
            if goal is not None:
                source.branch_to(goal, time.perf_counter() + BRANCH_TIME_S)
            e = problem.scene.entrance
            branch = source.branch(np.array([e.position, e.position + e.direction * 2 * VIEW_STEP_MM]))
            mission_time([branch], problem.robot, e.direction)
            return
        self.survey(problem)
        kalman.warm_up()

    def fly(self, problem: Problem, seed: int = 0,
            on_measure: Callable[[float, np.ndarray, GaussianMap], None] | None = None) -> FlownMission:
        """Fly the mission of ``problem`` from ``seed`` (same seed, same mission): the planner's generator and the
        measurements' noise are independent streams of it; the planner's own calls may take
        ``problem.time_limit_s`` in all. ``on_measure(t, pose, map)`` sees the map after each measurement."""
        world = self.survey(problem)
        _, truth = inspected_surface(problem.scene)
        self.reset(problem, world, mission_rngs(seed)[0])
        return fly(self.name, self.next_path, problem.inspection, world, truth, seed, problem.time_limit_s,
                   on_measure)

    def plan(self, problem: Problem, seed: int = 0):
        """Plan (fly) the mission from ``seed``: the mission's own seed, as :meth:`fly` takes it (the planner's
        generator and the measurements' noise are its two streams, as before missions were plans)."""
        if problem.task is Task.INSPECT and problem.inspection.tip_camera and not self.fed:
            raise ValueError(f"task: planner {self.name} maps a surface field from a camera path; "
                             f"{problem.scene.name} is inspected by a fed arm's tip camera (coverage, iris, random)")
        if problem.task is Task.INSPECT and not problem.inspection.tip_camera and not self.maps_fields:
            raise ValueError(f"task: planner {self.name} inspects points of interest with a fed arm's tip camera; "
                             f"{problem.scene.name} maps a surface field (informative, coverage, random)")
        if problem.task is Task.INSPECT and not problem.inspection.tip_camera and problem.knowledge != "full":
            raise ValueError(f"knowledge: planner {self.name} needs the whole scene ('full') to map a surface field "
                             f"from a camera path")
        self._seed = int(seed)
        return super().plan(problem, seed)

    def _solve(self, problem: Problem, rng: np.random.Generator, deadline: float):
        if problem.inspection.tip_camera:
            return self._solve_branches(problem, deadline)
        flown = self.fly(problem, self._seed)
        details = mission_details(flown, self.survey(problem))
        if flown.stopped not in _STOPPED:
            return Solution(Status.FOUND, flown.path, details, mission=flown.mission)
        why = (f"{_WHY[flown.stopped]} after {float(flown.path_times[-1]):.0f} s of the "
               f"{problem.inspection.budget_s:g} s budget; the mission flown so far is given")
        return Solution(Status.APPROXIMATE, flown.path, details, why, flown.mission)

    def _solve_branches(self, problem: Problem, deadline: float) -> Solution:
        """A fed arm's mission: the branches :meth:`choose_branches` picks, flown in their order."""
        source = BranchSource(problem, self._seed)
        reserve = min(ASSEMBLY_RESERVE_S, ASSEMBLY_RESERVE_SHARE * problem.time_limit_s)  # to build the mission
        branches, finished = self.choose_branches(source, mission_rngs(self._seed)[0], deadline - reserve)
        e = problem.scene.entrance
        mission = mission_of(branches, problem.robot, problem.inspection, e.direction, self._seed)
        coverage = coverage_of(branches, len(source.pois))
        details = {"branches": len(branches), "reach_calls": source.calls, "reach_planner": source.reach.name,
                   "points": len(source.pois), "coverage": coverage,
                   "mission_time_s": max((m.end_s for m in mission.motions), default=0.0)}
        if not branches:
            return Solution(Status.NO_PROGRESS, None, details,
                            f"no branch reached a view: the reaching planner found none in {source.calls} tries")
        path = np.concatenate([point_at(m.path, m.depths_mm) for m in mission.motions])
        if finished:
            return Solution(Status.FOUND, path, details, mission=mission)
        details["stopped"] = str(Status.TIMEOUT)
        return Solution(Status.APPROXIMATE, path, details,
                        f"the time limit of {problem.time_limit_s:g} s ran out with {coverage:.0%} of the points of "
                        f"interest seen from {len(branches)} branches; the mission so far is given", mission)
