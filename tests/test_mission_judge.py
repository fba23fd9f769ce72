"""The judge of missions: joint motions through the validity checker (collisions certified between samples, against
dense sampling and hand-made cases), views on the arm, and the map measured again from the views; one task
protocol (a problem's task, planners that refuse tasks they do not do)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from snakeplan.evaluation import evaluate_mission
from snakeplan.geometry.distance import ObstacleSet
from snakeplan.geometry.primitives import Box, Sphere
from snakeplan.planners import Problem, get_planner, planner_names
from snakeplan.robots import Chain, Section, get_robot
from snakeplan.scenes import Entrance, Scene, make_scene
from snakeplan.world import JUDGE, FullView, ValidityChecker
from snakeplan.world.joint_motion import interpolate
from snakeplan.world.mission import InspectionSettings, JointMotion, Mission, Views

ARM = Chain([Section(100.0, 10.0, math.radians(45.0))] * 3, name="three", feed_range=(0.0, 200.0))


def _scene(obstacles) -> Scene:
    return Scene("joint-motions", None, [-1000.0, -1000.0, -1000.0], [1000.0, 1000.0, 1000.0],
                 Entrance([0.0, 0.0, -5.0], [0.0, 0.0, 1.0]), [[0.0, 0.0, 250.0]], obstacles)


def _turn(angle: float) -> np.ndarray:
    """A base pose turned by ``angle`` rad about x."""
    T = np.eye(4)
    c, s = math.cos(angle), math.sin(angle)
    T[1:3, 1:3] = [[c, -s], [s, c]]
    return T


def _motion(bases, q=None):
    bases = np.asarray(bases, dtype=float)
    q = np.zeros((len(bases), ARM.dof)) if q is None else np.asarray(q, dtype=float)
    return np.linspace(0.0, 1.0, len(bases)), bases, q


def test_a_swing_through_a_box_collides_between_two_clear_samples():
    """The straight arm turned 90 deg about x sweeps a quarter disc; a box at 45 deg in it, clear of both ends."""
    box = Box([0.0, -150.0 * math.sqrt(0.5), 150.0 * math.sqrt(0.5)], [30.0, 30.0, 30.0])
    check = ValidityChecker(FullView(_scene([box])), ARM, JUDGE)
    t, bases, q = _motion([_turn(0.0), _turn(math.pi / 2)])
    jm = check.joint_motions()
    assert np.all(jm._clear(bases, q) > 50.0)  # both ends clear by far
    f = check.joint_motion_failure(t, bases, q)
    assert f is not None and f.kind == "collision"
    # by hand: the arm's axis first comes within its radius (10 mm) of the box's nearest edge, at y = -(c - 15),
    # z = c + 15 (c = 150 sin 45 deg): at the edge's angle less asin(10 / its distance), of the 90 deg turn
    c = 150.0 * math.sqrt(0.5)
    edge = math.hypot(c - 15.0, c + 15.0)
    touch = (math.atan2(c - 15.0, c + 15.0) - math.asin(10.0 / edge)) / (math.pi / 2)
    assert touch <= f.time_s <= touch + 1e-3
    # without the box the swing is clear; moved out of the swept disc it is too
    assert ValidityChecker(FullView(_scene([])), ARM, JUDGE).joint_motion_failure(t, bases, q) is None
    away = Box([200.0, -106.0, 106.0], [30.0, 30.0, 30.0])
    assert ValidityChecker(FullView(_scene([away])), ARM, JUDGE).joint_motion_failure(t, bases, q) is None


def test_bends_joint_limits_and_bounds_are_checked_along_the_motion():
    check = ValidityChecker(FullView(_scene([])), ARM, JUDGE)
    q = np.zeros((2, ARM.dof))
    q[1, 1] = math.radians(60.0)  # the first joint past its 45 deg bend limit at the end, not at the start
    f = check.joint_motion_failure([0.0, 1.0], [np.eye(4)] * 2, q)
    assert f is not None and f.kind in ("bend_limit", "joint_limit") and 0.5 < f.time_s <= 1.0
    q = np.zeros((2, ARM.dof))
    q[1, 0] = 250.0  # the feed past its 200 mm stroke
    assert check.joint_motion_failure([0.0, 1.0], [np.eye(4)] * 2, q).kind == "joint_limit"
    T = np.eye(4)
    T[:3, 3] = [0.0, 0.0, 800.0]  # the tip leaves the 1000 mm box
    f = check.joint_motion_failure([0.0, 1.0], [np.eye(4), T], np.zeros((2, ARM.dof)))
    assert f is not None and f.kind == "out_of_bounds"


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_certified_steps_agree_with_dense_sampling(seed):
    """Random motions among random spheres: a collision the checker misses is never found by 2,000 samples of the
    step, and one it reports is real (the state it names penetrates)."""
    rng = np.random.default_rng(seed)
    spheres = [Sphere(rng.uniform(-300.0, 300.0, 3), rng.uniform(20.0, 60.0)) for _ in range(6)]
    obstacles = ObstacleSet(spheres)
    check = ValidityChecker(FullView(_scene(spheres)), ARM, JUDGE)
    jm = check.joint_motions()
    a, b = (_turn(rng.uniform(-math.pi, math.pi)) for _ in range(2))
    q = np.zeros((2, ARM.dof))
    q[:, 0] = rng.uniform(0.0, 200.0, 2)
    bases = np.stack([a, b])
    f = check.joint_motion_failure([0.0, 1.0], bases, q)
    s = np.linspace(0.0, 1.0, 2001)
    T, Q = interpolate(bases, q, 0, s)
    dense = obstacles.chain_clearance(jm.bodies(T, Q), ARM.radii)
    if f is None or f.kind != "collision":
        assert dense.min() >= -0.011
    else:
        Tf, Qf = interpolate(bases, q, 0, np.array([f.time_s]))
        assert obstacles.chain_clearance(jm.bodies(Tf, Qf), ARM.radii)[0] < -0.01
        hits = np.flatnonzero(dense < -0.05)
        assert hits.size == 0 or f.time_s <= s[hits[0]] + 1e-3


@pytest.fixture(scope="module")
def station_plan():
    """A short coverage mission round station seed 0, planned (not judged)."""
    problem = Problem(make_scene("station", 0), get_robot("hsr-10"), inspection=InspectionSettings(budget_s=20.0))
    return problem, get_planner("coverage").plan(problem, seed=3)


def test_the_judge_measures_again_what_the_planner_measured(station_plan):
    problem, plan = station_plan
    report = evaluate_mission(problem.scene, problem.robot, plan.mission)
    assert report.success and report.reason == "inspected" and report.views == len(plan.mission.views)
    np.testing.assert_allclose(report.rmse_k, plan.details["rmse_k"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(report.final_mean_k, plan.details["final_mean_k"], rtol=0, atol=1e-9)
    other = dataclasses.replace(plan.mission, measurement_seed=plan.mission.measurement_seed + 1)
    assert evaluate_mission(problem.scene, problem.robot, other).rmse_k[-1] != report.rmse_k[-1]


def test_the_judge_refuses_a_view_off_the_arm_and_a_carriage_that_jumps_through_the_station(station_plan):
    problem, plan = station_plan
    views = plan.mission.views
    moved = views.positions.copy()
    moved[3] += [0.0, 0.0, 50.0]  # the camera claimed 50 mm from where the tip was
    off = dataclasses.replace(plan.mission, views=Views(views.times_s, moved, views.directions))
    report = evaluate_mission(problem.scene, problem.robot, off)
    assert not report.success and report.reason == "view_off_arm" and report.views_on_arm == len(views) - 1
    m = plan.mission.motions[0]
    bases = m.bases.copy()
    k = len(bases) // 2
    bases[k:, :3, 3] *= [-1.0, -1.0, 1.0]  # the carriage on the far side of the station from one sample to the next
    bases[k:, :2, :] *= -1.0
    jump = dataclasses.replace(plan.mission, motions=(JointMotion(m.times_s, bases, m.q),))
    report = evaluate_mission(problem.scene, problem.robot, jump)
    assert not report.success and report.reason in ("collision", "view_off_arm")
    assert report.failure.time_s <= m.times_s[k] + 1e-9


def test_a_problem_says_its_task_and_planners_refuse_tasks_they_do_not_do():
    station, tank = make_scene("station", 0), make_scene("fuel-tank", 0)
    assert Problem(station, get_robot("hsr-10")).task == "inspect" and Problem(tank, get_robot("sjtu-snake-iii")).task == "reach"
    fed = Problem(tank, get_robot("sjtu-snake-iii"), task="inspect")
    assert fed.inspection.tip_camera and fed.inspection.camera == get_robot("sjtu-snake-iii").camera
    with pytest.raises(ValueError, match="^task: planner informative maps a field, and fuel-tank has none"):
        get_planner("informative").plan(fed)
    with pytest.raises(ValueError, match="^task: must be one of reach, inspect"):
        Problem(tank, get_robot("sjtu-snake-iii"), task="explore")
    with pytest.raises(ValueError, match=r"^task: planner sp-rrt does not inspect \(it does: reach\)"):
        get_planner("sp-rrt").plan(Problem(station, get_robot("hsr-10")))
    assert set(planner_names("inspect")) == {"informative", "coverage", "random", "iris"}
    assert "as-rrt" in planner_names("reach") and "informative" not in planner_names("reach")
    with pytest.raises(KeyError, match="known: coverage, informative, iris, random"):
        get_planner("nope", task="inspect")


def test_the_judge_refuses_other_settings_views_off_the_clock_a_mission_past_its_budget_and_a_scaled_base(
        station_plan):
    """A mission is judged under the task's settings and clock: a document claiming a noiseless camera, a view
    between two measurement times, a motion past the budget, and a base pose that shrinks the arm are refused."""
    problem, plan = station_plan
    mission = plan.mission
    quiet = dataclasses.replace(mission.settings, camera=dataclasses.replace(mission.settings.camera, noise_a=0.0))
    assert evaluate_mission(problem.scene, problem.robot, dataclasses.replace(mission, settings=quiet),
                            problem.inspection).reason == "settings"
    v = mission.views
    t = v.times_s.copy()
    t[1] += 0.5
    off = dataclasses.replace(mission, views=Views(t, v.positions, v.directions))
    assert evaluate_mission(problem.scene, problem.robot, off).reason == "view_times"
    m = mission.motions[0]
    late = dataclasses.replace(mission, motions=(JointMotion(m.times_s * 2.0, m.bases, m.q),))
    assert evaluate_mission(problem.scene, problem.robot, late).reason == "over_budget"
    shrunk = m.bases.copy()
    shrunk[:, :3, :3] *= 0.001
    with pytest.raises(ValueError, match="^bases"):
        JointMotion(m.times_s, shrunk, m.q)
    assert len(Views([], [], [])) == 0
