"""`rrt-star`: judged success on fixed seeds, determinism, the time budget, and problems it cannot solve."""

import dataclasses
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from snakeplan.evaluation import evaluate
from snakeplan.geometry.polyline import densify
from snakeplan.geometry.primitives import Box
from snakeplan.planners import Problem
from snakeplan.planners.registry import get_planner
from snakeplan.planners.rrt_star import RRTStar
from snakeplan.robots import get_robot
from snakeplan.scenes import make_scene

ROBOT = get_robot("sjtu-snake-iii")
#: Allowance (s) past the budget for the last smoothing and crawl check, which are not interrupted.
OVERRUN_S = 0.5


def _enclosed(scene, target, inner_half_mm: float, wall_mm: float = 10.0):
    """The scene with a closed box of walls around ``target`` (``inner_half_mm`` from it to each wall)."""
    walls = []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            centre = np.array(target, dtype=float)
            centre[axis] += sign * (inner_half_mm + wall_mm / 2)
            size = np.full(3, 2 * (inner_half_mm + wall_mm))
            size[axis] = wall_mm
            walls.append(Box(centre, size))
    return dataclasses.replace(scene, obstacles=[*scene.obstacles, *walls])


@pytest.mark.parametrize(("name", "seed"), [("fuel-tank", 0), ("oil-tank", 1)])
def test_plan_passes_the_judge(name, seed):
    scene = make_scene(name, seed)
    plan = get_planner("rrt-star", optimize="none").plan(Problem(scene, ROBOT, time_limit_s=10.0), seed=seed)
    assert plan.status == "found" and plan.planner == "rrt-star"
    report = evaluate(scene, ROBOT, plan.path)
    assert report.success, report.reason
    assert plan.details["legs"] == len(scene.targets)
    assert len(plan.details["tree_sizes"]) >= len(scene.targets)
    assert plan.details["smoothed_length_mm"] == pytest.approx(report.path_length_mm)
    dense = densify(plan.path, 1.0)
    for target in scene.targets:  # smoothing keeps the tip on every target, not just within the tolerance
        assert np.min(np.linalg.norm(dense - target, axis=1)) < 5.0


def test_same_seed_same_plan():
    problem = Problem(make_scene("oil-tank", 3), ROBOT, time_limit_s=10.0)
    first = RRTStar().plan(problem, seed=7)
    second = RRTStar().plan(problem, seed=7)
    assert first.status == second.status == "found"
    np.testing.assert_array_equal(first.path, second.path)
    timed = ("optimize",)  # the optimiser's own time is the one figure that is the clock's
    assert {k: v for k, v in first.details.items() if k not in timed} == \
        {k: v for k, v in second.details.items() if k not in timed}
    assert {**first.details["optimize"], "time_s": 0} == {**second.details["optimize"], "time_s": 0}


def test_stops_within_a_short_budget():
    problem = Problem(make_scene("oil-tank", 0), ROBOT, time_limit_s=0.05)
    t0 = time.perf_counter()
    plan = RRTStar().plan(problem, seed=0)
    assert time.perf_counter() - t0 < problem.time_limit_s + OVERRUN_S
    assert plan.status in ("found", "timeout")
    assert (plan.path is None) == (plan.status != "found")


def test_enclosed_target_times_out_within_budget():
    scene = make_scene("fuel-tank", 0)
    boxed = _enclosed(scene, scene.targets[0], inner_half_mm=80.0)
    plan = RRTStar().plan(Problem(boxed, ROBOT, time_limit_s=1.5), seed=0)
    assert plan.status == "timeout" and plan.path is None
    assert plan.compute_time_s < 1.5 + OVERRUN_S


def test_blocked_target_is_refused_at_once():
    scene = make_scene("fuel-tank", 0)
    k = len(scene.obstacles)
    solid = dataclasses.replace(scene, obstacles=[*scene.obstacles, Box(scene.targets[0], np.full(3, 40.0))])
    plan = RRTStar().plan(Problem(solid, ROBOT, time_limit_s=5.0), seed=0)
    assert plan.status == "invalid_target" and plan.path is None
    assert f"lies -20 mm from obstacles[{k}]" in plan.why
    assert plan.compute_time_s < 1.0


def test_compiled_tree_is_a_shortest_path_tree_of_free_motions():
    """Invariants of the compiled RRT*'s tree, checked with the validity checker's own segment test: every edge
    is a free motion no longer than the range, every cost-to-come is its parent's plus the edge's length, the
    child lists match the parents, and the best goal vertex is the cheapest vertex at the goal."""
    from snakeplan.planners import rrt_star, tip_rrt_star
    from snakeplan.world import PLANNING, ValidityChecker

    scene = make_scene("fuel-tank", 2)
    arm = ValidityChecker(Problem(scene, ROBOT).world, ROBOT, PLANNING)
    start = scene.entrance.position + rrt_star.LEAD_MM * arm.direction
    goal = scene.targets[0]
    tip_rrt_star.seed_stream(5)
    tree = tip_rrt_star._Tree(start, scene.bounds_min.astype(float), scene.bounds_max.astype(float),
                              rrt_star.RANGE_MM, capacity=64)  # small: the arrays must grow
    k_rrt = tip_rrt_star.REWIRE_FACTOR * np.e * 4.0 / 3.0
    for _ in range(12):
        tree.grow(goal, rrt_star.RANGE_MM, rrt_star.GOAL_BIAS, k_rrt, 10**6, tip_rrt_star.CHUNK,
                  arm.obstacles.packed, arm.tip_radius, arm.obstacles.evaluations)
    n = int(tree.state[0])
    assert n > 500 and tree.state[3] >= 0
    v = np.arange(1, n)
    par = tree.parent[v]
    edge = np.linalg.norm(tree.pos[v] - tree.pos[par], axis=1)
    assert np.all(arm.segment_free(tree.pos[par], tree.pos[v]))
    assert np.all(edge <= rrt_star.RANGE_MM + 1e-9)
    np.testing.assert_allclose(tree.cost[v], tree.cost[par] + edge, rtol=1e-12, atol=1e-9)
    children = {}
    for u in range(n):
        c = tree.child[u]
        while c >= 0:
            children.setdefault(u, []).append(int(c))
            c = tree.sibling[c]
    assert sorted(x for cs in children.values() for x in cs) == list(range(1, n))
    assert all(tree.parent[c] == u for u, cs in children.items() for c in cs)
    at_goal = np.flatnonzero(np.all(tree.pos[:n] == goal, axis=1))
    best = int(tree.state[3])
    assert best in at_goal and tree.cost[best] == tree.cost[at_goal].min()
    path = tree.path()
    assert np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)) == pytest.approx(tree.cost[best])


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 400), k=st.integers(1, 40),
       radius=st.floats(1.0, 400.0), clustered=st.booleans())
def test_grid_neighbours_are_the_brute_force_ones(seed, n, k, radius, clustered):
    """The grid's nearest vertex and its k nearest within a radius are those of a brute-force search over every
    vertex, ties to the older vertex (points on a coarse lattice make ties), inside and outside the bounds."""
    from snakeplan.planners import tip_rrt_star

    rng = np.random.default_rng(seed)
    lo, hi = np.array([0.0, -300.0, 100.0]), np.array([1000.0, 300.0, 400.0])
    span = hi - lo
    pts = lo + (np.round(rng.random((n, 3)) * 4) / 4 if clustered else rng.random((n, 3))) * span
    tree = tip_rrt_star._Tree(pts[0], lo, hi, radius, capacity=n)
    tree.pos[:n] = pts
    for v in range(1, n):
        tip_rrt_star.grid_add(tree.head, tree.nxt, tree.dims, tree.cell, tree.lo, tree.pos, v)
    kd, ki = np.empty(k), np.empty(k, dtype=np.int64)
    for x in lo - 0.2 * span + rng.random((20, 3)) * 1.4 * span:
        d = np.linalg.norm(pts - x, axis=1)
        order = np.lexsort((np.arange(n), d))
        near, dn = tip_rrt_star.nearest(tree.pos, tree.head, tree.nxt, tree.dims, tree.cell, tree.lo, x)
        assert near == order[0] and np.sqrt(dn) == pytest.approx(d[order[0]])
        within = [int(j) for j in order if d[j] <= radius][:k]
        m = tip_rrt_star.near_k(tree.pos, tree.head, tree.nxt, tree.dims, tree.cell, tree.lo, x, k, radius, kd, ki)
        assert list(ki[:m]) == within


@pytest.mark.parametrize(("name", "seed"), [("fuel-tank", 4), ("oil-tank", 5)])
def test_compiled_rrt_star_matches_ompl(name, seed):
    """The compiled RRT* and OMPL's, on the same problem: both judged successful, smoothed paths of about the
    same length (different random streams, so not the same tree)."""
    pytest.importorskip("ompl")
    scene = make_scene(name, seed)
    plans = {b: RRTStar(backend=b).plan(Problem(scene, ROBOT, time_limit_s=10.0), seed=seed)
             for b in ("compiled", "ompl")}
    for plan in plans.values():
        assert plan.status == "found" and evaluate(scene, ROBOT, plan.path).success
    lengths = [p.details["smoothed_length_mm"] for p in plans.values()]
    assert lengths[0] == pytest.approx(lengths[1], rel=0.1)


def test_unknown_backend_is_refused():
    with pytest.raises(ValueError, match="^backend: "):
        RRTStar(backend="fast")
