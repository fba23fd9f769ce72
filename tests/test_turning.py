"""Turning routes (scenes.routes.turning): a route a tip turning no tighter than a radius can follow, checked
against plane geometry, an independent interpolator and the obstacles' exact distances; and the learned planners'
roll-outs along one where the taut guide's fail."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator

from snakeplan.episode import run_episode
from snakeplan.geometry.distance import ObstacleSet
from snakeplan.geometry.primitives import Box, Plate
from snakeplan.planners import Problem, Status
from snakeplan.planners.sac.guide import turning_guide
from snakeplan.planners.sac.planner import SacPlanner
from snakeplan.robots import load_robot
from snakeplan.scenes import Entrance, arm_sizing, sized_scene
from snakeplan.scenes.routes.grid import Grid
from snakeplan.scenes.routes.guide import GUIDE_CELL_MM, FreeSpace, route_through
from snakeplan.scenes.routes.turning import _clearance, _tour, turning_route

RADIUS_MM, CLEAR_MM, STEP_MM = 250.0, 40.0, 35.0
CAPTURE_MM = 4 * STEP_MM  # the generalists' goal capture
ENTRANCE = Entrance([0.0, 150.0, 300.0], [1.0, 0.0, 0.0])
BESIDE = np.array([[100.0, 750.0, 300.0]])  # 600 mm beside the entrance, 100 mm in


def _room(depth_mm: float) -> tuple[FreeSpace, ObstacleSet]:
    """A 1200 x 900 x 600 mm box of bounds fed along +x at x = 0, with a wall across it at x = ``depth_mm``."""
    wall = ObstacleSet([Box([depth_mm + 5.0, 450.0, 300.0], [10.0, 900.0, 600.0])])
    grid = Grid.covering([0.0, 0.0, 0.0], [1200.0, 900.0, 600.0], GUIDE_CELL_MM)
    return FreeSpace.of(wall, grid, 100.0), wall


def _vertices(points: np.ndarray) -> np.ndarray:
    """The polyline's corners: its points less those inside a straight run."""
    d = np.diff(points, axis=0)
    d = d[np.linalg.norm(d, axis=1) > 1e-9]
    u = d / np.linalg.norm(d, axis=1)[:, None]
    keep = np.concatenate([[True], np.einsum("ij,ij->i", u[1:], u[:-1]) < 1 - 1e-12, [True]])
    corners = np.concatenate([points[:1], points[:1] + np.cumsum(d, axis=0)])
    return corners[keep]


def _capture_arc(points: np.ndarray) -> np.ndarray:
    """The arc the crawl captures the route's last target on: tangent to the last step's heading at the point the
    route leaves for the target in a straight chord, through the target; it turns no tighter than the route."""
    prev, p, q = _vertices(points)[-3:]
    h = (p - prev) / np.linalg.norm(p - prev)
    c = q - p
    side = c - (c @ h) * h
    r = (c @ c) / (2 * np.linalg.norm(side))
    assert r >= RADIUS_MM
    centre = p + r * side / np.linalg.norm(side)
    theta = np.linspace(0.0, 2 * np.arcsin(np.linalg.norm(c) / (2 * r)), 50)
    arc = centre + r * (-np.cos(theta)[:, None] * side / np.linalg.norm(side) + np.sin(theta)[:, None] * h)
    np.testing.assert_allclose(arc[-1], q, atol=1e-6)
    return arc


def test_the_clearance_is_the_trilinear_interpolation_of_the_field():
    rng = np.random.default_rng(0)
    sdf = rng.normal(size=(5, 4, 3))
    origin, spacing = np.array([10.0, -5.0, 2.0]), np.array([40.0, 30.0, 20.0])
    axes = [origin[a] + (np.arange(sdf.shape[a]) + 0.5) * spacing[a] for a in range(3)]
    reference = RegularGridInterpolator(axes, sdf)
    shape = np.array(sdf.shape, dtype=np.int64)
    lo, hi = np.array([a[0] for a in axes]), np.array([a[-1] for a in axes])
    for p in rng.uniform(lo - 50.0, hi + 50.0, (400, 3)):  # beyond the outer centres: the outer value
        assert _clearance(sdf, shape, origin, spacing, p) == pytest.approx(reference(np.clip(p, lo, hi))[0], abs=1e-9)


def test_a_target_beside_the_entrance_needs_a_room_as_deep_as_the_turning_radius():
    """From heading +x to a point 600 mm aside and 100 mm in, the heading must turn through 90 deg (else x only
    grows and, turning by at most 1/R, the heading never steepens enough to gain 600 mm aside in 100 mm along),
    which on a radius of R carries the tip R along x; in crawl steps s that turn before they advance (as the crawl
    does), sum(s cos(k s / R)) up to 90 deg, which is R - s / 2 to within a millimetre. A wall 250 mm in leaves
    210 mm clear of it: no turning route, though the taut guide passes; 450 mm in leaves room, and the route (with
    the arc that captures its target) swings out that far."""
    shallow, _ = _room(250.0)
    assert route_through(shallow, ENTRANCE, BESIDE, CLEAR_MM).complete
    assert turning_route(shallow, ENTRANCE, BESIDE, RADIUS_MM, CLEAR_MM, STEP_MM, 3000.0, CAPTURE_MM) is None
    deep, wall = _room(450.0)
    route = turning_route(deep, ENTRANCE, BESIDE, RADIUS_MM, CLEAR_MM, STEP_MM, 3000.0, CAPTURE_MM)
    assert route is not None and route.complete
    arc = _capture_arc(route.points)
    swing = max(route.points[:-1, 0].max(), arc[:, 0].max())
    assert swing >= RADIUS_MM - STEP_MM / 2 - 1.0 and route.points[:, 0].max() <= 450.0 - CLEAR_MM + 1e-6
    assert np.min(wall.signed_distance(route.points)) >= CLEAR_MM - 1e-6
    np.testing.assert_allclose(route.points[-1], BESIDE[0])


def test_a_route_through_two_targets_turns_no_tighter_than_its_radius():
    """Every corner of the route between crawl steps turns by at most its shorter side over R (an arc of radius R
    turns a step s by s / R), but at the targets and where a chord to one starts: there the crawl's capture takes
    over, on the arc tangent to the heading through the target, which is no tighter than R; the targets come in
    order, at the route's target arcs; the route keeps the clearance from a wall (exact: the field is linear
    there); a tour longer than allowed is none."""
    space, wall = _room(1000.0)
    targets = np.array([[600.0, 600.0, 200.0], [250.0, 200.0, 450.0]])
    route = turning_route(space, ENTRANCE, targets, RADIUS_MM, CLEAR_MM, STEP_MM, 3000.0, CAPTURE_MM)
    assert route is not None
    np.testing.assert_allclose(route.at(route.target_arc), targets, atol=1e-9)
    assert np.all(np.diff(route.target_arc) > 0)
    corners = _vertices(route.points)
    is_target = np.min(np.linalg.norm(corners[:, None] - targets[None], axis=2), axis=1) < 1e-6
    at_target, chord = is_target[1:-1], is_target[2:]
    before = np.linalg.norm(corners[1:-1] - corners[:-2], axis=1)
    after = np.linalg.norm(corners[2:] - corners[1:-1], axis=1)
    u, v = (corners[1:-1] - corners[:-2]) / before[:, None], (corners[2:] - corners[1:-1]) / after[:, None]
    turn = np.arccos(np.clip(np.einsum("ij,ij->i", u, v), -1.0, 1.0))
    assert len(turn) > 10 and np.all((turn <= np.minimum(before, after) / RADIUS_MM + 1e-9) | at_target | chord)
    for h, c in zip(u[chord], (corners[2:] - corners[1:-1])[chord]):  # the capturing arc's radius |c|^2 / 2 |side|
        assert c @ c / (2 * np.linalg.norm(c - (c @ h) * h)) >= RADIUS_MM
    assert np.min(wall.signed_distance(route.points)) >= CLEAR_MM - 1e-6
    short = route.arc[-1] * 0.8
    assert turning_route(space, ENTRANCE, targets, RADIUS_MM, CLEAR_MM, STEP_MM, short, CAPTURE_MM) is None


def test_a_route_through_a_hole_keeps_the_clearance_from_its_rim_as_the_field_holds_it():
    """A wall across x = 500 with a round hole of radius 90 mm centred at y = 450, fed at y = 250 towards a target
    at y = 650 behind it: the route threads the hole off its axis, within 90 mm of the rim, and keeps the
    clearance from the rim to within half a cell diagonal (the field is trilinear between cell centres, and the
    distance to a rim is not linear)."""
    wall = ObstacleSet([Plate([500.0, 450.0, 300.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], (900.0, 600.0), 10.0,
                              {"offset": [0.0, 0.0], "semi_axes": [90.0, 90.0]})])
    grid = Grid.covering([0.0, 0.0, 0.0], [1200.0, 900.0, 600.0], GUIDE_CELL_MM)
    route = turning_route(FreeSpace.of(wall, grid, 100.0), Entrance([0.0, 250.0, 300.0], [1.0, 0.0, 0.0]),
                          np.array([[900.0, 650.0, 300.0]]), RADIUS_MM, CLEAR_MM, STEP_MM, 3000.0, CAPTURE_MM)
    assert route is not None
    assert CLEAR_MM - 0.5 * np.linalg.norm(grid.spacing) <= np.min(wall.signed_distance(route.points)) <= 90.0


def test_without_goal_capture_a_route_ends_where_the_crawl_snaps():
    """With no goal capture the crawl takes a target only within two steps, inside one step's turn: the route's
    last chord is so."""
    space, _ = _room(450.0)
    route = turning_route(space, ENTRANCE, BESIDE, RADIUS_MM, CLEAR_MM, STEP_MM, 3000.0, 0.0)
    prev, p, q = _vertices(route.points)[-3:]
    u, v = (p - prev) / np.linalg.norm(p - prev), (q - p) / np.linalg.norm(q - p)
    assert np.linalg.norm(q - p) <= 2 * STEP_MM + 1e-9 and np.arccos(min(u @ v, 1.0)) <= STEP_MM / RADIUS_MM + 1e-9


def test_a_turning_guide_given_no_time_is_none():
    space, _ = _room(1000.0)
    scene_like = type("S", (), {"entrance": ENTRANCE, "targets": BESIDE})()
    arm = load_robot("src/snakeplan/robots/data/arms/arm-10x220.json")
    assert turning_guide(space, scene_like, arm, 25.0, STEP_MM, CAPTURE_MM, seconds=0.0) is None
    assert turning_guide(space, scene_like, arm, 25.0, STEP_MM, CAPTURE_MM) is not None


def test_the_stiff_arm_reaches_a_confined_target_along_a_turning_route_it_missed_on_the_taut_guide():
    """The 10 x 220 mm arm (55 deg) in confined seed 6, sized to it, sensed: fed in through a side wall of a room
    567 mm high towards a target 564 mm in and 1071 mm aside, 15 of the 16 roll-outs on the taut guide swing past
    the turn and leave the bounds (the other reaches the target on a path no smoothing crawls); the first roll-out
    along the turning route reaches it, and the judge passes the plan."""
    arm = load_robot("src/snakeplan/robots/data/arms/arm-10x220.json")
    scene = sized_scene("confined", 6, arm_sizing("confined", arm))
    planner = SacPlanner(policy="generalist-arms")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        taut = run_episode(Problem(scene, arm, time_limit_s=10.0, knowledge="sensed"),
                           SacPlanner(policy="generalist-arms", turning=False))
        planner.warm_up(Problem(scene, arm, time_limit_s=10.0, knowledge="sensed"))
        compiled = len(getattr(_tour, "signatures", ()))
        turned = run_episode(Problem(scene, arm, time_limit_s=10.0, knowledge="sensed"), planner)
    assert not taut.success and taut.plan.why.count("left the bounds") == 1 and "15 left the bounds" in taut.plan.why
    assert turned.success and turned.plan.status is Status.FOUND and turned.plan.details["route"] == "turning"
    assert turned.plan.details["attempts"] == 2
    assert len(getattr(_tour, "signatures", ())) == compiled  # the plan called the search as the warm-up did


def test_a_residual_policy_pursuing_a_turning_route_alone_keeps_to_it():
    """The arm generalist's pursuit-only copy acts 0 on any observation (tanh of a zeroed head), so its crawl is
    the pursuit of the guide: on the turning route of confined seed 149 for the 10 x 220 mm arm (sensed) it
    reaches the target within 20 mm of the route throughout, where the residual crawl (trained on taut guides)
    strays farther; a policy without a pursuit has no such copy."""
    from snakeplan.planners.sac.guide import guide_space, turning_crawl_radius
    from snakeplan.planners.sac.observation import observation_dim
    from snakeplan.planners.sac.planner import _generalist, rollout
    from snakeplan.planners.sac.policy import NumpyPolicy
    from snakeplan.world import SensedView

    policy = _generalist("generalist-arms")
    alone = policy.pursuit_only()
    rng = np.random.default_rng(0)
    obs = {"observation": rng.normal(size=(5, observation_dim("guide", True, True))),
           "achieved_goal": rng.normal(size=(5, 3)), "desired_goal": rng.normal(size=(5, 3))}
    assert np.all(alone.act(obs) == 0.0) and np.all(np.abs(policy.act(obs)) > 0.0)
    arm = load_robot("src/snakeplan/robots/data/arms/arm-10x220.json")
    scene = sized_scene("confined", 149, arm_sizing("confined", arm))
    space = guide_space(scene, SensedView.of(scene), float(np.max(arm.radii)))
    crawl = policy.crawler(arm)
    route = turning_guide(space, scene, arm, 25.0, crawl.step_mm, crawl.capture_mm)
    assert route is not None
    radius = min(turning_crawl_radius(arm), crawl.step_mm / crawl.max_turn)  # as a plan crawls a turning route
    strays = []
    for driver in (alone, policy):
        path, outcome = rollout(driver, scene, arm, world=SensedView.of(scene), guide=route, turn_radius_mm=radius)
        assert outcome == "reached"
        strays.append(np.max(np.min(np.linalg.norm(path[:, None] - route.points[None], axis=2), axis=1)))
    assert strays[0] <= 20.0 < strays[1]
    with pytest.raises(ValueError, match="residual guide policy"):
        NumpyPolicy(policy.layers, policy.mu, {**policy.meta, "residual": False}).pursuit_only()


def test_a_plan_crawls_its_turning_route_with_the_pursuit_only_copy_made_once(monkeypatch):
    """In the stiff arm's plan of confined seed 6 (its second roll-out follows the turning route, above), the
    taut-guide roll-out is driven by the generalist itself and the turning one by its pursuit-only copy, made once
    in the plan; a policy whose crawl has no pursuit is never asked for one."""
    from snakeplan.planners.sac import planner as module
    from snakeplan.planners.sac.policy import NumpyPolicy

    calls, made = [], []
    real_rollout, real_copy = module.rollout, NumpyPolicy.pursuit_only

    def recording_rollout(policy, *args, **kwargs):
        calls.append((policy, kwargs["turn_radius_mm"] is not None))
        return real_rollout(policy, *args, **kwargs)

    def recording_copy(policy):
        made.append(policy)
        return real_copy(policy)

    monkeypatch.setattr(module, "rollout", recording_rollout)
    monkeypatch.setattr(NumpyPolicy, "pursuit_only", recording_copy)
    arm = load_robot("src/snakeplan/robots/data/arms/arm-10x220.json")
    scene = sized_scene("confined", 6, arm_sizing("confined", arm))
    generalist = module._generalist("generalist-arms")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        plan = SacPlanner(policy=generalist).plan(Problem(scene, arm, time_limit_s=10.0, knowledge="sensed"))
    assert plan.details["route"] == "turning" and [turning for _, turning in calls] == [False, True]
    assert calls[0][0] is generalist and made == [generalist]
    assert np.all(calls[1][0].mu[0] == 0.0) and np.all(calls[1][0].mu[1] == 0.0)
    assert all(np.array_equal(a[0], b[0]) for a, b in zip(calls[1][0].layers, generalist.layers))
    calls.clear()
    plain = NumpyPolicy(generalist.layers, generalist.mu, {**generalist.meta, "residual": False})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        SacPlanner(policy=plain, attempts=2).plan(Problem(scene, arm, time_limit_s=10.0, knowledge="sensed"))
    assert made == [generalist] and all(policy is plain for policy, _ in calls)
