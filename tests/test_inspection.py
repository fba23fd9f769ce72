"""Inspection planning (paper 002): camera paths, the arm's reach, the viewpoint library, the mission loop and
the three planners (deterministic for a seed, coverage helix fitted to the budget)."""

import dataclasses
import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from snakeplan.planners import Problem, get_planner, planner_names
from snakeplan.planners.coverage import helix_points
from snakeplan.planners.inspection import (
    KEEP_OUT_MM,
    SPLINE_SAMPLES,
    natural_spline_samples,
    survey_for,
)
from snakeplan.planners.inspection import CameraPath as Trajectory
from snakeplan.robots import get_robot
from snakeplan.scenes import make_scene
from snakeplan.world.mission import InspectionSettings


def InspectionProblem(scene, robot, **settings):
    """The inspect problem of ``scene`` with mission ``settings`` (budget_s, ...)."""
    return Problem(scene, robot, task="inspect", inspection=InspectionSettings(**settings))


def get_inspection_planner(name, **options):
    """An inspection planner by name, whose ``plan`` flies its mission and returns the planner's own account."""
    planner = get_planner(name, task="inspect", **options)
    planner.plan = planner.fly
    return planner


def inspection_planner_names():
    return planner_names("inspect")

#: A short mission keeps the planner tests fast.
SHORT_BUDGET_S = 16.0


@pytest.fixture(scope="module")
def problem():
    return InspectionProblem(make_scene("station", 3), get_robot("hsr-10"))


@pytest.fixture(scope="module")
def world(problem):
    return survey_for(problem.scene, problem.robot, problem.inspection)


def test_registry_names():
    assert inspection_planner_names() == ["coverage", "informative", "iris", "random"]
    with pytest.raises(KeyError, match="known: coverage, informative, iris, random"):
        get_inspection_planner("nope")


def test_problem_validation(problem):
    with pytest.raises(ValueError, match="budget_s"):
        dataclasses.replace(problem.inspection, budget_s=0.0)
    with pytest.raises(ValueError, match="no surface field"):
        InspectionProblem(make_scene("fuel-tank", 0), get_robot("hsr-10"))


def test_trajectory_spline_through_points_at_constant_speed():
    pts = np.array([[0.0, 0, 0], [1000, 500, 0], [2000, 0, 300], [3000, 200, 0]])
    t = Trajectory(pts, 500.0)
    s = t.samples(10.0)
    for p in pts:
        assert np.min(np.linalg.norm(s - p, axis=1)) < 10.0
    assert t.duration == pytest.approx(t.length / 500.0)
    assert np.allclose(t.at_time(0.0), pts[0]) and np.allclose(t.at_time(t.duration), pts[-1])
    steps = np.linalg.norm(np.diff(t.at_time(np.linspace(0, t.duration, 200)), axis=0), axis=1)
    assert steps.max() / steps.mean() < 1.05
    line = Trajectory(pts, 500.0, "polyline")
    assert line.length == pytest.approx(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))


@settings(max_examples=40, deadline=None)
@given(st.integers(3, 9), st.integers(0, 2**31 - 1))
def test_spline_samples_are_scipys_natural_cubic_spline(n, seed):
    """The trajectory's spline is SciPy's natural CubicSpline on the chord-length parameter, sampled the same."""
    from scipy.interpolate import CubicSpline

    pts = np.random.default_rng(seed).normal(size=(n, 3)) * 2000.0
    u = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
    t = np.concatenate([np.linspace(u[i], u[i + 1], SPLINE_SAMPLES, endpoint=False) for i in range(n - 1)] + [u[-1:]])
    np.testing.assert_allclose(natural_spline_samples(pts, SPLINE_SAMPLES), CubicSpline(u, pts, bc_type="natural")(t),
                               rtol=0, atol=1e-8)


def test_distance_field_interpolates_as_scipy_does(world):
    """The field's trilinear lookup of the distance and its gradient equals SciPy's RegularGridInterpolator on
    the same grid, and outside the grid the distance grows by the distance to it."""
    from scipy.interpolate import RegularGridInterpolator

    f = world.field
    axes = tuple(f.lo[d] + f.spacing * np.arange(f._values.shape[d]) for d in range(3))
    pts = f.lo + np.random.default_rng(0).random((500, 3)) * (f.hi - f.lo)
    _, values = f._at(pts)
    for c in range(4):
        ref = RegularGridInterpolator(axes, f._values[..., c])(pts)
        np.testing.assert_allclose(values[:, c], ref, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(f.distance(pts), values[:, 0], rtol=0, atol=0)
    np.testing.assert_allclose(f.look_direction(pts), -values[:, 1:] / np.linalg.norm(values[:, 1:], axis=1,
                                                                                       keepdims=True), atol=1e-12)
    out = f.hi + np.array([300.0, 0.0, 400.0])
    assert f.distance(out) == pytest.approx(f.distance(f.hi) + 500.0)


def test_helix_fits_requested_length():
    pts, turns = helix_points(10000.0, 0.0, 20000.0, 120000.0, step=50.0)
    assert np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)) == pytest.approx(120000.0, rel=1e-4)
    assert turns == pytest.approx(np.sqrt(120000.0**2 - 20000.0**2) / (2 * np.pi * 10000.0))
    assert pts[0, 2] == 0.0 and pts[-1, 2] == 20000.0


def test_library_reach_and_keep_out(world):
    lib = world.library
    assert lib.reachable.mean() > 0.9
    assert np.all(world.field.distance(lib.positions) > KEEP_OUT_MM)
    assert all(len(s) > 0 for s in lib.seen)
    home = world.home()
    report = world.reach.check([home, [0.0, 0.0, 10000.0]])
    assert report.ok.tolist() == [True, False]
    joints = world.reach.robot.with_base(report.base[0]).joint_positions(report.q[0])
    assert np.allclose(joints[-1], home, atol=2.0)


def test_look_direction_points_at_the_skin(world):
    f = world.frame
    side = f.point(f.radius + 4000.0, 1.0, 8000.0)
    assert np.allclose(world.look(side), -np.array([np.cos(1.0), np.sin(1.0), 0.0]), atol=0.02)
    above = f.point(2000.0, 0.3, f.height + 4000.0)
    assert np.allclose(world.look(above), [0.0, 0.0, -1.0], atol=0.02)


def test_coverage_fills_the_budget(problem):
    res = get_inspection_planner("coverage").plan(problem, seed=0)
    assert res.times[-1] == pytest.approx(problem.inspection.budget_s)
    assert len(res.times) == len(problem.inspection.ticks())
    length = np.sum(np.linalg.norm(np.diff(res.path, axis=0), axis=1))
    assert length == pytest.approx(problem.inspection.speed_mm_s * problem.inspection.budget_s, rel=0.01)
    assert np.all(np.diff(res.trace) <= 1e-6)
    out = json.loads(json.dumps(res.to_dict(), allow_nan=False))
    assert out["final_rmse_k"] == pytest.approx(res.rmse[-1]) and len(out["rmse_k"]) == len(res.times)


@pytest.fixture(scope="module")
def short_runs(problem):
    """Two missions per planner with the same seed on a short budget."""
    short = dataclasses.replace(problem, inspection=dataclasses.replace(problem.inspection, budget_s=SHORT_BUDGET_S))
    options = {"informative": {"generations": 2, "popsize": 4}}
    return {name: [get_inspection_planner(name, **options.get(name, {})).plan(short, seed=7) for _ in range(2)]
            for name in ("coverage", "random", "informative")}


@pytest.mark.parametrize("name", ["coverage", "random", "informative"])
def test_planners_deterministic_for_a_seed(short_runs, name):
    a, b = short_runs[name]
    assert np.array_equal(a.path, b.path) and np.array_equal(a.rmse, b.rmse)
    assert np.array_equal(a.final_map.mean, b.final_map.mean)
    assert a.times[-1] == pytest.approx(SHORT_BUDGET_S)
    assert a.trace[-1] < a.trace[0] and a.rmse[-1] < a.rmse[0]
    assert np.all(np.diff(a.trace) <= 1e-6)


@pytest.mark.parametrize("name", ["random", "informative"])
def test_library_paths_are_feasible(short_runs, world, name):
    res = short_runs[name][0]
    assert np.all(world.field.distance(res.path) >= KEEP_OUT_MM - 1.0)
    assert np.all(world.within_reach(res.path))
    assert world.reach.check(res.poses).share > 0.8
