"""`as-rrt`: judged success on fixed seeds, curvature within the limit, determinism, sensing, impossible problems."""

from __future__ import annotations

import dataclasses
import math
from functools import cache

import numpy as np
import pytest

from snakeplan.evaluation import evaluate
from snakeplan.evaluation.metrics import curvature_profile
from snakeplan.geometry.primitives import Box
from snakeplan.planners.as_rrt import (
    LANDING_CURVATURES,
    LANDING_LENGTHS,
    AsRRT,
    _landing_firsts,
    arc,
    arc_distance,
    biarc,
    landings,
    tangent_circle,
)
from snakeplan.planners.base import Plan, Problem
from snakeplan.planners.registry import get_planner
from snakeplan.robots import get_robot
from snakeplan.scenes import Entrance, Scene, make_scene
from snakeplan.world import PLANNING, ValidityChecker

ROBOT = get_robot("sjtu-snake-iii")
BUDGET_S = 10.0
#: Seeds the planner solves in well under a second (measured), so the suite stays fast.
CASES = [("fuel-tank", 0), ("fuel-tank", 2), ("oil-tank", 0), ("oil-tank", 3)]


@cache
def solved(name: str, seed: int, knowledge: str = "full") -> tuple[Scene, Plan]:
    scene = make_scene(name, seed)
    return scene, get_planner("as-rrt", optimize="none").plan(Problem(scene, ROBOT, BUDGET_S, knowledge=knowledge), seed)


def kappa_limit(scene: Scene) -> float:
    return 1.0 / ValidityChecker(Problem(scene, ROBOT).world, ROBOT, PLANNING).turn_radius


def corridor(targets, obstacles=()) -> Scene:
    """A 3000 x 1000 x 1000 mm box world entered at the origin along +x."""
    return Scene("corridor", None, [0, -500, -500], [3000, 500, 500], Entrance([0, 0, 0], [1, 0, 0]),
                 np.array(targets, dtype=float).reshape(-1, 3), list(obstacles))


@pytest.mark.parametrize("name,seed", CASES)
def test_judge_says_success(name, seed):
    scene, plan = solved(name, seed)
    assert plan.planner == "as-rrt" and plan.status == "found"
    report = evaluate(scene, ROBOT, plan.path)
    assert report.success, report.reason
    assert report.targets_reached == len(scene.targets)
    assert np.allclose(plan.path[0], scene.entrance.position)
    assert plan.details["targets_reached"] == len(scene.targets)


@pytest.mark.parametrize("name,seed", CASES)
@pytest.mark.parametrize("step_mm", [60.0, 177.5])
def test_path_curvature_within_the_limit(name, seed, step_mm):
    # Resampled at 60 mm and at the judge's scale (section length). Resampled points fall on the ~11 mm chords of
    # the arcs, up to 0.07 mm inside the circle, which can raise a 60 mm turning angle by about 1 %.
    scene, plan = solved(name, seed)
    _, kappa = curvature_profile(plan.path, step_mm)
    assert kappa.max() <= kappa_limit(scene) * 1.015


@pytest.mark.parametrize("name,seed", CASES)
def test_every_vertex_turns_within_the_limit(name, seed):
    # At the emitted points themselves: turning angle over the mean adjacent chord, exact for points on a circle
    # up to 2 asin(c / 2R) / c versus 1 / R (1e-4 relative at c = 11 mm).
    scene, plan = solved(name, seed)
    d = np.diff(plan.path, axis=0)
    length = np.linalg.norm(d, axis=1)
    u = d / length[:, None]
    turn = np.arccos(np.clip(np.sum(u[:-1] * u[1:], axis=1), -1.0, 1.0))
    assert np.max(turn / (0.5 * (length[:-1] + length[1:]))) <= kappa_limit(scene) * (1 + 1e-3)


def test_path_leaves_the_entrance_along_the_feed_direction():
    scene, plan = solved("fuel-tank", 0)
    first = plan.path[1] - plan.path[0]
    assert np.dot(first / np.linalg.norm(first), scene.entrance.direction) > 0.999


def test_same_seed_same_path_other_seed_other_path():
    scene = make_scene("oil-tank", 3)
    problem = Problem(scene, ROBOT, BUDGET_S)
    a, b, c = (AsRRT().plan(problem, s) for s in (7, 7, 8))
    assert a.status == b.status == "found"
    assert np.array_equal(a.path, b.path)
    assert c.path is None or c.path.shape != a.path.shape or not np.array_equal(a.path, c.path)


def test_sensed_plans_without_seeing_far_obstacles():
    scene, sensed = solved("fuel-tank", 2, "sensed")
    assert sensed.status == "found" and evaluate(scene, ROBOT, sensed.path).success
    assert sensed.details["known_obstacles"] < len(scene.obstacles)
    # Every arc stays within the sensor range of its start node, so nothing unseen could have changed a check:
    # the sensed plan is the full-knowledge plan.
    _, full = solved("fuel-tank", 2, "full")
    assert np.array_equal(sensed.path, full.path)
    assert full.details["known_obstacles"] == len(scene.obstacles)


def test_sensed_obstacles_are_those_near_the_tree():
    # A box 2 m down the corridor is never within 400 mm of a tree that reaches a target 600 mm in.
    far = Box([2500, 0, 0], [100, 100, 100])
    scene = dataclasses.replace(corridor([[600, 100, 0]], [far]), discovered=(0,))  # debris, unknown before the job
    plan = AsRRT().plan(Problem(scene, ROBOT, BUDGET_S, knowledge="sensed"), 0)
    assert plan.status == "found" and evaluate(scene, ROBOT, plan.path).success
    assert plan.details["known_obstacles"] == 0


def test_target_inside_an_obstacle_is_refused_at_once():
    scene = corridor([[1000, 0, 0]], [Box([1000, 0, 0], [200, 200, 200])])
    plan = AsRRT().plan(Problem(scene, ROBOT, BUDGET_S), 0)
    assert plan.status == "invalid_target" and plan.path is None
    assert plan.why.startswith("targets[0] [1000, 0, 0] lies -100 mm from obstacles[0]")
    assert plan.compute_time_s < 1.0


def test_target_too_close_for_the_planning_margin_stops_with_its_why():
    """A target the judge could reach (the tip's ball clears it) but not with the planner's 3 mm margin: the
    planner gives up at once and says so."""
    r = float(ROBOT.radii[-1])
    scene = corridor([[1000, 0, 0]], [Box([1000, r + 101.0, 0], [200, 200, 200])])  # 1 mm over the tip radius
    plan = AsRRT().plan(Problem(scene, ROBOT, BUDGET_S), 0)
    assert plan.status == "no_progress" and plan.details["reason"] == "target_blocked"
    assert "planning margin" in plan.why and plan.compute_time_s < 1.0


def test_unreachable_target_times_out_within_the_budget():
    # A solid wall closes the corridor: the free target behind it can never be reached.
    wall = Box([1000, 0, 0], [20, 1200, 1200])
    scene = corridor([[1500, 0, 0]], [wall])
    plan = AsRRT().plan(Problem(scene, ROBOT, 1.0), 0)
    assert plan.status == "timeout" and plan.path is None
    assert plan.compute_time_s < 1.5


def test_arc_distance_is_the_tangent_arc_within_the_limit_and_a_detour_beyond():
    # From the origin heading +x: a point on the tangent circle of radius 200 mm, 0.8 rad round it, is 160 mm of
    # arc away; a point 50 mm to the side needs curvature 1/25 mm, beyond a limit of 1/100 mm, so its distance is
    # the chord plus the turn radius times the 90 degrees off the heading.
    p, t = np.zeros(3), np.array([1.0, 0, 0])
    on_circle = np.array([200.0 * math.sin(0.8), 200.0 * (1 - math.cos(0.8)), 0.0])
    assert np.isclose(arc_distance(p, t, on_circle, 1 / 100.0, 100.0), 160.0)
    assert np.isclose(arc_distance(p, t, np.array([0.0, 50.0, 0.0]), 1 / 100.0, 100.0), 50.0 + 100.0 * math.pi / 2)
    assert np.isclose(arc_distance(p, t, np.array([70.0, 0.0, 0.0]), 1 / 100.0, 100.0), 70.0)
    # dead behind no tangent circle reaches: a half turn's detour
    assert np.isclose(arc_distance(p, t, np.array([-5.0, 0.0, 0.0]), 1 / 100.0, 100.0), 5.0 + 100.0 * math.pi)


def test_arc_points_lie_on_the_circle_and_end_tangent():
    p, t, n = np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 1.0, 0])
    pts, end = arc(p, t, n, 1 / 200.0, 150.0, 16)
    centre = p + 200.0 * n
    assert np.allclose(np.linalg.norm(pts - centre, axis=1), 200.0)
    assert np.isclose(np.dot(end, t), math.cos(150.0 / 200.0))
    assert np.isclose(np.dot(end, pts[-1] - centre), 0.0, atol=1e-9)


@pytest.mark.parametrize("q", [[300, 100, 0], [300, -150, 80], [150, 20, -10]])
def test_landings_end_on_the_target_within_the_limit(q):
    p, t, q = np.zeros(3), np.array([1.0, 0, 0]), np.array(q, dtype=float)
    kmax = 1 / 217.5
    ways = landings(p, t, q, kmax, 400.0, math.pi / 2, 16, 3)
    assert ways
    for pieces in ways:
        path = np.vstack([p] + [pts for pts, _ in pieces])
        assert np.allclose(path[-1], q)
        _, kappa = curvature_profile(path, 30.0)
        assert kappa.size == 0 or kappa.max() <= kmax * 1.02


@pytest.mark.parametrize("q", [[300, 100, 0], [300, -150, 80], [150, 20, -10], [40, 200, 0]])
def test_free_landings_are_ranked_gentlest_first(q):
    # Brute force over the same grid with NumPy: every candidate first arc, the tangent circle after it, the
    # three limits; ranked by peak curvature, then total length, then grid order.
    p, t, q = np.zeros(3), np.array([1.0, 0, 0]), np.array(q, dtype=float)
    kmax, length, turn = 1 / 217.5, 355.0, math.pi / 2
    n = tangent_circle(p, t, q)[1]
    k1 = np.r_[0.0, np.repeat(np.linspace(-kmax, kmax, LANDING_CURVATURES), LANDING_LENGTHS - 1)]
    l1 = np.r_[0.0, np.tile(np.linspace(0.0, length, LANDING_LENGTHS)[1:], LANDING_CURVATURES)]
    th = k1 * l1
    bent = np.abs(k1) > 1e-12
    fwd = np.where(bent, np.sin(th) / np.where(bent, k1, 1.0), l1)
    side = np.where(bent, (1.0 - np.cos(th)) / np.where(bent, k1, 1.0), 0.0)
    start = p + fwd[:, None] * t + side[:, None] * n
    heading = np.cos(th)[:, None] * t + np.sin(th)[:, None] * n
    circles = [tangent_circle(a, h, q) for a, h in zip(start, heading)]
    k2 = np.array([c[0] for c in circles])
    total = l1 + np.array([c[2] for c in circles])
    ok = (k2 <= kmax) & (total <= length) & (np.abs(th) + np.array([c[3] for c in circles]) <= turn)
    idx = np.flatnonzero(ok)
    order = idx[np.lexsort((total[idx], np.maximum(np.abs(k1[idx]), k2[idx])))][:3]
    got_k, got_l = _landing_firsts(p, t, n, q, kmax, length, turn, 3)
    assert np.allclose(got_k, k1[order], atol=1e-12) and np.allclose(got_l, l1[order])


def test_biarc_joins_two_poses_g1():
    p, t = np.zeros(3), np.array([1.0, 0, 0])
    q, h = np.array([350.0, 60.0, 40.0]), np.array([0.9, 0.1, 0.3])
    h /= np.linalg.norm(h)
    pieces = biarc(p, t, q, h, 1 / 217.5, 500.0, math.pi, 16)
    assert pieces is not None and len(pieces) == 2
    assert np.allclose(pieces[-1][0][-1], q)
    assert np.allclose(pieces[-1][1], h, atol=1e-9)
    first, joint_heading = pieces[0]
    second = pieces[1][0]
    assert np.allclose(joint_heading, (second[0] - first[-1]) / np.linalg.norm(second[0] - first[-1]), atol=2e-2)


def test_registered_and_works_with_sensed_knowledge():
    planner = get_planner("as-rrt")
    assert isinstance(planner, AsRRT) and not planner.needs_full_scene
