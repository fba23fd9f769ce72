"""Scene generators (fuel-tank, oil-tank, pipe, concentric-pipe, station) and the reachability field (mm)."""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import pytest
import trimesh

from snakeplan.geometry.distance import ObstacleSet
from snakeplan.geometry.primitives import Box, Plate
from snakeplan.planners import planner_names
from snakeplan.robots import get_robot, robot_names
from snakeplan.scenes import Entrance, Scene, SceneSpec, make_scene, scene_spec, spec_for
from snakeplan.scenes.routes.geodesic import geodesic_field
from snakeplan.scenes.routes.grid import Grid
from snakeplan.scenes.station import STATION_HEIGHT_MM, STATION_RADIUS_MM

ALL = ["fuel-tank", "oil-tank", "pipe", "concentric-pipe", "station"]
WITH_TARGETS = ALL[:4]
SEEDS = [0, 5, 11]
BODY_RADIUS_MM = 27.5


@lru_cache(maxsize=None)
def scene(name: str, seed: int) -> Scene:
    return make_scene(name, seed)


@pytest.mark.parametrize("name", ALL)
def test_deterministic(name):
    assert make_scene(name, 3).to_json() == scene(name, 3).to_json()


@pytest.mark.parametrize("name", ALL)
def test_seeds_differ(name):
    assert scene(name, 0).to_json() != scene(name, 5).to_json()


@pytest.mark.parametrize("name", ALL)
def test_json_round_trip(name):
    s = scene(name, 0)
    text = s.to_json()
    assert Scene.from_json(text).to_json() == text


@pytest.mark.parametrize("name", WITH_TARGETS)
@pytest.mark.parametrize("seed", SEEDS)
def test_targets_clear_in_bounds_and_reachable(name, seed):
    s = scene(name, seed)
    params = s.metadata["parameters"]
    assert len(s.targets) >= 1
    assert np.all(s.in_bounds(s.targets))
    assert np.all(s.signed_distance(s.targets) >= params["target_clearance_mm"])
    field = geodesic_field(s, inflate_mm=params["inflate_mm"], cell_mm=params["cell_mm"])
    geo = field.distance_at(s.targets)
    limit = params["reach_fraction"] * s.metadata["arm_length_mm"]
    assert np.all(geo <= limit)
    assert np.all(geo >= np.linalg.norm(s.targets - s.entrance.position, axis=1) - 1e-6)


@pytest.mark.parametrize("name", ALL)
@pytest.mark.parametrize("seed", SEEDS)
def test_straight_body_through_the_entrance_is_clear(name, seed):
    s = scene(name, seed)
    e = s.entrance
    ahead = 10000.0 if name == "station" else 200.0
    behind = 400.0 if name == "station" else 300.0
    a = e.position - behind * e.direction
    b = e.position + ahead * e.direction
    assert s.obstacle_set.segments_clear(a, b, BODY_RADIUS_MM)


def test_fuel_tank_facts():
    s = scene("fuel-tank", 0)
    assert np.allclose(s.bounds_min, 0.0) and np.allclose(s.bounds_max, [1800.0, 1400.0, 400.0])
    ovals = [o for o in s.obstacles if isinstance(o, Plate) and o.hole and o.hole["semi_axes"] == [250.0, 150.0]]
    assert len(ovals) == 7
    assert len(s.metadata["chambers"]) == 6 and len(s.metadata["holes"]) == 7
    assert s.metadata["target_holes"] in (1, 2)
    assert s.metadata["target_geodesic_mm"] >= 1000.0
    ports = [o for o in s.obstacles if isinstance(o, Plate) and o.hole and o.hole["semi_axes"] == [60.0, 60.0]]
    assert len(ports) == 1
    port = ports[0]
    u, v = port.hole["offset"]
    mouth = port.center + u * port.side + v * port.up + port.thickness / 2 * np.sign(
        np.dot(s.entrance.direction, port.normal)) * port.normal
    assert np.allclose(mouth, s.entrance.position)


@pytest.mark.parametrize("seed", SEEDS)
def test_fuel_tank_holes_open_and_clutter_placed_well(seed):
    s = scene("fuel-tank", seed)
    n = s.metadata["clutter"]
    assert 3 <= n <= 6
    clutter = s.obstacles[-n:]
    structure = ObstacleSet(s.obstacles[:-n])
    for item in clutter:
        assert item.signed_distance(s.entrance.position) >= 250.0
        r = item.bounding_radius()
        axis = np.linspace(-r, r, 15)
        pts = item.center + np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), -1).reshape(-1, 3)
        inside = pts[(item.signed_distance(pts) < 0) & (pts[:, 2] > 1.0)]
        assert np.all(structure.signed_distance(inside) > 0.0)
    t = np.linspace(0.0, 2 * math.pi, 64, endpoint=False)
    disc = np.concatenate([np.stack([f * np.cos(t), f * np.sin(t)], 1) for f in (0.0, 0.5, 0.98)])
    for hole in s.metadata["holes"]:
        normal = np.array(hole["normal"])
        side = np.cross([0.0, 0.0, 1.0], normal)
        a, b = hole["semi_axes"]
        pts = np.array(hole["center"]) + a * disc[:, :1] * side + b * disc[:, 1:] * np.array([0.0, 0.0, 1.0])
        assert np.all(s.signed_distance(pts) > 0.0)


def test_oil_tank_facts():
    s = scene("oil-tank", 0)
    assert np.allclose(s.bounds_max - s.bounds_min, [1200.0, 600.0, 600.0])
    assert len(s.metadata["cells"]) == 16
    holes = [o for o in s.obstacles if isinstance(o, Plate) and o.hole and o.hole["semi_axes"] == [140.0, 140.0]]
    assert len(holes) == 28 and all(o.size == (300.0, 300.0) for o in holes)
    cells = s.metadata["target_cells"]
    assert len(s.targets) == 3 and len(set(cells)) == 3 and s.metadata["entrance_cell"] not in cells
    assert s.metadata["target_geodesic_mm"] == sorted(s.metadata["target_geodesic_mm"])
    face = (s.entrance.position % 300.0)[np.abs(s.entrance.direction) < 0.5]
    assert np.allclose(face, 150.0)


def test_pipe_targets_in_their_regions():
    for seed in SEEDS:
        p = scene("pipe", seed).targets[0]
        assert 250.0 <= p[0] <= 750.0 and math.hypot(p[1], p[2]) <= 60.0
        c = scene("concentric-pipe", seed).targets[0]
        assert 300.0 <= c[0] <= 800.0 and 100.0 <= math.hypot(c[1], c[2]) <= 110.0


def test_station_mesh_and_field():
    s = scene("station", 0)
    mesh = s.obstacles[0]
    assert len(mesh.vertices) == 1097 and len(mesh.faces) == 2190
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    assert tm.is_watertight and tm.is_winding_consistent and tm.volume > 0
    assert tm.volume == pytest.approx(math.pi * STATION_RADIUS_MM**2 * STATION_HEIGHT_MM, rel=0.01)
    axis = np.array([[0.0, 0.0, z] for z in (1000.0, 10000.0, 19000.0)])
    d = s.signed_distance(axis)
    assert np.all(d < 0) and d[1] == pytest.approx(-6000.0, abs=50.0)
    outside = np.array([[6100.0, 0.0, 10000.0], [0.0, -6500.0, 3000.0], [0.0, 0.0, 20100.0], [0.0, 0.0, -100.0]])
    assert np.all(s.signed_distance(outside) > 0)
    values = np.array(s.metadata["field"]["values"])
    assert s.metadata["field"]["units"] == "K" and values.shape == (1097,)
    assert np.all(np.isfinite(values)) and values.min() >= s.metadata["parameters"]["base_temperature_k"]
    assert s.signed_distance(s.entrance.position) == pytest.approx(500.0, abs=30.0)
    assert len(s.targets) == 0


def test_bad_parameters_are_named():
    with pytest.raises(ValueError, match="reach_fraction"):
        make_scene("fuel-tank", 0, reach_fraction=2.0)
    with pytest.raises(ValueError, match="n_targets"):
        make_scene("oil-tank", 0, n_targets=0)
    with pytest.raises(ValueError, match="n_sources"):
        make_scene("station", 0, n_sources=1.5)


# --- reach.py on a tiny scene ---------------------------------------------------------------------------------

SOURCE = np.array([250.0, 300.0, 50.0])
GOAL = np.array([750.0, 300.0, 50.0])


def _tiny(obstacles) -> Scene:
    return Scene("tiny", 0, [0.0, 0.0, 0.0], [1000.0, 1000.0, 100.0], Entrance(SOURCE, [1.0, 0.0, 0.0]), [],
                 obstacles)


def test_grid_tiles_the_bounds():
    g = Grid.covering([0.0, 0.0, 0.0], [1000.0, 990.0, 15.0], 20.0)
    assert g.shape == (50, 50, 1)
    assert np.allclose(g.origin + g.spacing * g.shape, [1000.0, 990.0, 15.0]) and np.all(g.spacing <= 20.0)


def test_open_space_distance_is_euclidean():
    field = geodesic_field(_tiny([]), inflate_mm=0.0, cell_mm=10.0)
    pts = np.random.default_rng(0).uniform([0.0, 0.0, 0.0], [1000.0, 1000.0, 100.0], (200, 3))
    assert np.allclose(field.distance_at(pts), np.linalg.norm(pts - SOURCE, axis=1), atol=1e-9)
    assert np.all(np.isinf(field.distance_at([[-5.0, 0.0, 0.0], [500.0, 500.0, 101.0]])))


def test_distance_around_a_wall():
    # A wall x in [490, 510], y in [0, 700], through the whole height: the shortest way from SOURCE to GOAL
    # runs over the wall's end, touching the corners (490, 700) and (510, 700).
    cell = 10.0
    field = geodesic_field(_tiny([Box([500.0, 350.0, 50.0], [20.0, 700.0, 400.0])]), inflate_mm=0.0, cell_mm=cell)
    expected = 2 * math.hypot(240.0, 400.0) + 20.0
    got = float(field.distance_at(GOAL))
    assert expected - 1e-6 <= got <= expected + 2 * cell
    assert got - 500.0 == pytest.approx(expected - 500.0, abs=2 * cell)
    path = field.path_to(GOAL)
    assert np.allclose(path[0], SOURCE) and np.allclose(path[-1], GOAL)
    assert np.linalg.norm(np.diff(path, axis=0), axis=1).sum() == pytest.approx(got)
    assert path[:, 1].max() >= 700.0


def test_inflation_and_enclosure():
    wall = Box([500.0, 350.0, 50.0], [20.0, 700.0, 400.0])
    thin = float(geodesic_field(_tiny([wall]), inflate_mm=0.0, cell_mm=10.0).distance_at(GOAL))
    fat = float(geodesic_field(_tiny([wall]), inflate_mm=40.0, cell_mm=10.0).distance_at(GOAL))
    assert fat > thin + 20.0
    cage = [Box(GOAL + off, size) for off, size in (([0.0, 100.0, 0.0], [220.0, 20.0, 400.0]),
                                                    ([0.0, -100.0, 0.0], [220.0, 20.0, 400.0]),
                                                    ([100.0, 0.0, 0.0], [20.0, 220.0, 400.0]),
                                                    ([-100.0, 0.0, 0.0], [20.0, 220.0, 400.0]))]
    field = geodesic_field(_tiny(cage), inflate_mm=0.0, cell_mm=10.0)
    assert math.isinf(float(field.distance_at(GOAL))) and len(field.path_to(GOAL)) == 0


@pytest.mark.parametrize("seed", range(6))
def test_oil_tank_targets_lie_in_order_along_the_entrance_row(seed):
    from snakeplan.scenes.oil_tank import ROW_OFFSET_MM

    s = make_scene("oil-tank", seed)
    e, d = s.entrance.position, s.entrance.direction
    assert abs(d[0]) == 1.0
    rel = s.targets - e
    axial = rel @ d
    lateral = np.linalg.norm(rel - np.outer(axial, d), axis=1)
    assert np.all(lateral <= ROW_OFFSET_MM + 1e-6)
    assert np.all(np.diff(axial) > 0)  # listed in visiting order, farther and farther down the row
    assert np.all((axial // 300).astype(int) == [1, 2, 3])


@pytest.mark.parametrize("seed", range(8))
def test_fuel_tank_target_is_outside_the_turning_region(seed):
    from snakeplan.scenes.fuel_tank import TURN_RADIUS_MM, chamber_steps, outside_turning_region

    s = make_scene("fuel-tank", seed)
    assert outside_turning_region(s.entrance, s.targets).all()
    # Hand check of the region: a point beside the entrance at 100 mm off-axis is inside the turning circle,
    # a point straight ahead is not.
    e, d = s.entrance.position, s.entrance.direction
    side = np.cross(d, [0.0, 0.0, 1.0])
    assert not outside_turning_region(s.entrance, (e + 50 * d + 100 * side)[None])[0]
    assert outside_turning_region(s.entrance, (e + 3 * TURN_RADIUS_MM * d)[None])[0]
    steps = chamber_steps(s.metadata["holes"], s.metadata["entrance_chamber"])
    assert steps[s.metadata["target_chamber"]] == s.metadata["target_holes"]


# ---------------------------------------------------------------- specs
@pytest.mark.parametrize("name", ALL)
def test_spec_fits_its_scenes(name):
    spec, s = scene_spec(name), scene(name, 0)
    assert s.metadata["robot"] == spec.robot and spec.robot in robot_names()
    # The robot is the arm the generator sized the scene for.
    robot = get_robot(spec.robot)
    assert robot.total_length == pytest.approx(s.metadata["arm_length_mm"])
    assert float(robot.radii.max()) == pytest.approx(s.metadata["arm_radius_mm"])
    # The task follows from what the scene holds: targets to reach, or a surface field and no targets.
    assert spec.task == ("inspect" if len(s.targets) == 0 and "field" in s.metadata else "reach")
    known = planner_names(spec.task)
    assert spec.planner in known and set(spec.policies) <= set(known)


def test_shipped_policies_are_the_files_the_planners_load():
    from snakeplan.planners.sac import policy_path
    from snakeplan.planners.sscc.agent import shipped_agent_path

    shipped = {(n, p) for n in ALL for p in scene_spec(n).policies}
    assert {p for _, p in shipped} == {"sac-her", "sac-per", "sscc"}
    for name, planner in shipped:
        spec = scene_spec(name)
        loaded = shipped_agent_path(spec.robot) if planner == "sscc" else policy_path(name, planner)
        assert spec.policy_path(planner) == loaded and loaded.is_file()
    assert scene_spec("station").policy_path("informative") is None


def test_a_scene_file_of_an_unregistered_family_gets_the_default_spec():
    from dataclasses import replace

    assert spec_for(scene("pipe", 0)) is scene_spec("pipe")
    spec = spec_for(replace(scene("pipe", 0), name="my-pipe"))
    assert spec == SceneSpec("my-pipe") and spec.generator is None and spec.task == "reach"


def test_spec_validation_names_the_field():
    with pytest.raises(ValueError, match="task"):
        SceneSpec("x", task="fly")
    with pytest.raises(ValueError, match=r"policies\['sac'\]"):
        SceneSpec("x", policies={"sac": "policy.npz"})



def test_titles_name_the_seed_only_where_there_is_one():
    """A generated scene's label carries its seed; a scene from a file (no seed) is its name alone, not 'seed None'."""
    from dataclasses import replace

    from snakeplan.scenes import make_scene

    scene = make_scene("fuel-tank", 3)
    assert scene.label == "fuel-tank seed 3"
    assert replace(scene, name="my tank", seed=None).label == "my tank"
