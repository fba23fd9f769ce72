"""Knowledge views: what a sensed planner may know, and the honesty test for every planner that plans sensed."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from snakeplan.evaluation import evaluate
from snakeplan.geometry.distance import ObstacleSet, workspace
from snakeplan.geometry.primitives import Plate, Sphere
from snakeplan.planners import Planner, Problem, get_planner, planner_names
from snakeplan.robots import get_robot
from snakeplan.scenes import Entrance, Scene, make_scene
from snakeplan.world import FullView, SensedView, UnsensedObstacleError, guarded
from snakeplan.world.knowledge import sensor_rays

ROBOT = get_robot("sjtu-snake-iii")
#: Boxes, plates with holes, cylinders and a sphere (fuel-tank seed 2).
CLUTTERED = make_scene("fuel-tank", 2)


def spheres_scene():
    """Spheres of radius 10, all discovered (unknown before the job), whose surfaces lie 100, 300 and 500 mm from
    the origin along x, y and -z."""
    obstacles = [Sphere([110.0, 0.0, 0.0], 10.0), Sphere([0.0, 310.0, 0.0], 10.0), Sphere([0.0, 0.0, -510.0], 10.0)]
    return Scene("spheres", 0, [-1000.0] * 3, [1000.0] * 3, Entrance([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]),
                 np.array([[500.0, 0.0, 0.0]]), obstacles, discovered=(0, 1, 2))


def test_sensing_reveals_exactly_the_obstacles_within_range():
    scene = spheres_scene()
    view = SensedView.of(scene, sensor_range_mm=300.0)
    assert len(view.obstacle_set) == 0
    assert view.sense([0.0, 0.0, 0.0])  # 100 and 300 mm away: both within range (exact distance, not box)
    assert list(view.known) == [True, True, False]
    assert not view.sense([0.0, 0.0, 0.0])  # nothing new
    assert view.sense([0.0, 0.0, -210.0]) and view.known.all()
    assert len(view.obstacle_set) == 3
    fresh = view.fresh()
    assert not fresh.known.any() and view.known.all()


def test_range_sensor_sees_no_further_than_its_range():
    scene = spheres_scene()
    view = SensedView.of(scene, sensor_range_mm=200.0)
    d = view.raycast(np.zeros((2, 3)), np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]), max_distance=1000.0)
    assert d[0] == pytest.approx(100.0, abs=1e-2) and np.isinf(d[1])  # the sphere at 300 mm is out of range
    assert np.allclose(FullView(scene).raycast(np.zeros((1, 3)), np.array([[0.0, 1.0, 0.0]]), 1000.0), 300.0,
                       atol=1e-2)


def test_a_prior_obstacle_is_known_from_the_start():
    scene = spheres_scene()
    view = SensedView(scene, scene.obstacles, 100.0, prior=[False, False, True])
    assert list(view.known) == [False, False, True] and list(view.fresh().known) == [False, False, True]


def test_guarded_scene_keeps_its_structure_and_hides_its_obstacles():
    scene = make_scene("fuel-tank", 1)
    g = guarded(scene)
    assert np.array_equal(g.targets, scene.targets) and g.name == scene.name
    assert bool(g.in_bounds(scene.entrance.position))
    for read in (lambda: g.obstacles, lambda: g.obstacle_set, lambda: g.signed_distance(np.zeros(3))):
        with pytest.raises(UnsensedObstacleError):
            read()


def test_a_problems_view_must_match_its_knowledge():
    scene = make_scene("fuel-tank", 1)
    with pytest.raises(ValueError, match="world"):
        Problem(scene, ROBOT, knowledge="full", world=SensedView.of(scene))


class _Peeking(Planner):
    """Plans straight ahead after a look at the whole scene: dishonest under sensed knowledge."""

    name = "peeking"
    needs_full_scene = False

    def _solve(self, problem, rng, deadline):
        len(problem.scene.obstacles)
        return "found", np.array([problem.start, problem.goals[0]]), {}


def test_a_planner_that_reads_unsensed_obstacles_fails_the_honesty_test():
    scene = make_scene("fuel-tank", 1)
    with pytest.raises(UnsensedObstacleError):
        _Peeking().plan(Problem(guarded(scene), ROBOT, knowledge="sensed", world=SensedView.of(scene)))


SENSED = [name for name in planner_names("reach") if not get_planner(name).needs_full_scene and name != "sac"]


@pytest.mark.parametrize("name", SENSED)
def test_sensed_planners_plan_honestly(name):
    """Every planner that declares sensed support plans with a scene whose obstacles raise when read, so all it
    knows comes from the sensed view; its plans are still judged against the whole scene."""
    family = "oil-tank" if name == "sac-per" else "fuel-tank"
    successes = 0
    for seed in range(3):
        scene = make_scene(family, seed)
        view = SensedView.of(scene)
        plan = get_planner(name).plan(Problem(guarded(scene), ROBOT, time_limit_s=10.0, knowledge="sensed",
                                              world=view), seed=0)
        successes += plan.path is not None and evaluate(scene, ROBOT, plan.path).success
    assert successes >= 2


def test_a_sensed_views_scene_is_structure_only():
    """The view's own scene is guarded too: no way round the sensor through ``problem.world.scene``."""
    scene = make_scene("fuel-tank", 1)
    view = SensedView.of(scene)
    assert np.array_equal(view.scene.targets, scene.targets)
    with pytest.raises(UnsensedObstacleError):
        view.scene.obstacles
    assert len(view.fresh().obstacle_set) == len(scene.obstacles) - len(scene.discovered)


def test_fuel_tank_clutter_is_discovered_and_the_structure_prior():
    """Paper 000's setting (§4.1): the operator knows the coarse structure alone. The generator lists the six outer
    walls and seven partitions first (plates, the holes cut in them) and marks everything after them, the support
    frame and the clutter, as discovered; a sensed view starts knowing the walls and partitions only."""
    for seed in range(3):
        scene = make_scene("fuel-tank", seed)
        n, clutter = len(scene.obstacles), scene.metadata["clutter"]
        coarse = 6 + 7
        assert all(isinstance(o, Plate) for o in scene.obstacles[:coarse])
        assert not any(isinstance(o, Plate) for o in scene.obstacles[coarse:])
        assert clutter >= 3 and scene.discovered == tuple(range(coarse, n)) and n - coarse > clutter
        view = SensedView.of(scene)
        assert list(view.known) == [True] * coarse + [False] * (n - coarse)
        assert not SensedView.of(scene, prior=False).known.any()
    assert make_scene("oil-tank", 0).prior.all()


def test_prior_flags_round_trip_through_scene_json():
    scene = make_scene("fuel-tank", 2)
    d = scene.to_dict()
    flagged = [i for i, o in enumerate(d["obstacles"]) if "prior" in o]
    assert flagged == list(scene.discovered) and all(d["obstacles"][i]["prior"] is False for i in flagged)
    back = Scene.from_dict(d)
    assert back.discovered == scene.discovered and np.array_equal(back.prior, scene.prior)
    d["obstacles"][0]["prior"] = True  # explicit true is the default
    d["obstacles"][1]["prior"] = False
    assert Scene.from_dict(d).discovered == (1, *scene.discovered)


@pytest.mark.parametrize("value", [0, "no", None, 1.0])
def test_a_prior_flag_that_is_not_a_boolean_is_refused(value):
    d = make_scene("oil-tank", 0).to_dict()
    d["obstacles"][3]["prior"] = value
    with pytest.raises(ValueError, match=r"^obstacles\[3\]\.prior: expected true or false"):
        Scene.from_dict(d)


def test_discovered_indices_are_checked():
    scene = spheres_scene()
    with pytest.raises(ValueError, match="discovered"):
        Scene("spheres", 0, scene.bounds_min, scene.bounds_max, scene.entrance, scene.targets, scene.obstacles,
              discovered=(3,))


class _PeeksThroughTheView(_Peeking):
    def _solve(self, problem, rng, deadline):
        len(problem.world.scene.obstacle_set)
        return super()._solve(problem, rng, deadline)


def test_reading_the_views_scene_is_caught_as_well():
    scene = make_scene("fuel-tank", 1)
    with pytest.raises(UnsensedObstacleError):
        _PeeksThroughTheView().plan(Problem(scene, ROBOT, knowledge="sensed"))


# --- the compiled sensor ----------------------------------------------------------------------------------------
@given(seed=st.integers(0, 2**31 - 1), reach=st.floats(50.0, 600.0))
@settings(max_examples=30, deadline=None)
def test_the_compiled_sensing_rule_is_each_obstacles_exact_distance(seed, reach):
    scene = CLUTTERED
    rng = np.random.default_rng(seed)
    points = rng.uniform(scene.bounds_min, scene.bounds_max, (3, 3))
    view = SensedView.of(scene, sensor_range_mm=reach, prior=False)
    view.sense(points)
    alone = [min(float(ObstacleSet([o]).signed_distance(p)) for p in points) for o in scene.obstacles]
    assert list(view.known) == [d <= reach for d in alone]


@given(seed=st.integers(0, 2**31 - 1))
@settings(max_examples=20, deadline=None)
def test_sensor_rays_see_what_the_known_obstacles_alone_show(seed):
    """The sensor's rays cast on the whole packed scene, masked by what is known, read what the known obstacles
    packed alone read after the same sensing."""
    scene = CLUTTERED
    rng = np.random.default_rng(seed)
    origin = rng.uniform(scene.bounds_min, scene.bounds_max)
    dirs = rng.standard_normal((13, 3))
    unit = dirs / np.linalg.norm(dirs, axis=-1, keepdims=True)  # as ObstacleSet.raycast makes them
    view = SensedView.of(scene, sensor_range_mm=300.0, prior=False)
    sensor = view.sensor()
    out = np.empty(13)
    sensor_rays(sensor.packed, sensor.known, sensor.range_mm, origin, unit, 400.0, 0.5, out,
                workspace(sensor.packed), sensor.stats, sensor.frame_rays, sensor.params, sensor.hits, sensor.state)
    assert sensor.known is view.known and len(view.obstacle_set) == int(view.known.sum())
    expect = ObstacleSet([o for o, k in zip(scene.obstacles, view.known) if k]).raycast(np.tile(origin, (13, 1)),
                                                                                       dirs, 300.0, 0.5)
    np.testing.assert_array_equal(out, expect)
