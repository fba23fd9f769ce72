"""Obstacle signed distances against hand-computed values, and the batched queries against brute force."""

import math
import pickle

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from snakeplan.geometry.distance import ObstacleSet, sampled_chain_clearance
from snakeplan.geometry.primitives import Box, Cylinder, Mesh, Pipe, Plate, Sphere, obstacle_from_dict
from snakeplan.geometry.transforms import frame_from_z, rot_z

coord = st.floats(-400, 400, allow_nan=False)
point = st.tuples(coord, coord, coord)


def test_box_distances_hand_computed():
    box = Box([0, 0, 0], [100, 200, 300])
    d = box.signed_distance([[0, 0, 0], [200, 0, 0], [50, 100, 150], [80, 130, 0], [10, 0, 0]])
    assert d == pytest.approx([-50, 150, 0, math.hypot(30, 30), -40])


def test_rotated_box_uses_columns_as_local_axes():
    box = Box([10, 0, 0], [100, 20, 20], rotation=rot_z(math.pi / 2))
    # The long local x axis now lies along world y.
    assert box.signed_distance([10, 49, 0]) == pytest.approx(-1)
    assert box.signed_distance([49 + 10, 0, 0]) == pytest.approx(39)


def test_sphere_cylinder_pipe_hand_computed():
    assert Sphere([1, 2, 3], 5).signed_distance([1, 2, 13]) == pytest.approx(5)
    cyl = Cylinder([0, 0, 0], [0, 0, 1], 50, 200)
    assert cyl.signed_distance([[0, 0, 0], [80, 0, 0], [0, 0, 130], [80, 0, 140], [45, 0, 95]]) == pytest.approx(
        [-50, 30, 30, 50, -5]
    )
    pipe = Pipe([0, 0, 0], [1, 0, 0], 100, 110, 400)
    assert pipe.signed_distance([[0, 0, 0], [0, 105, 0], [0, 0, 150], [250, 105, 0], [250, 0, 0]]) == pytest.approx(
        [100, -5, 40, 50, math.hypot(50, 100)]
    )


def test_plate_with_elliptical_hole():
    plate = Plate([0, 0, 0], normal=[1, 0, 0], up=[0, 0, 1], size=[800, 400], thickness=40,
                  hole={"offset": [100, 0], "semi_axes": [250, 150]})
    # side = up x normal = +y; the hole centre is at y = 100, its rim at y = 350 and z = +-150.
    assert np.allclose(plate.side, [0, 1, 0])
    d = plate.signed_distance([[0, 100, 0], [0, 100, 160], [0, 360, 0], [0, 395, 0], [30, 100, 0], [0, 400, 0]])
    assert d == pytest.approx([150, -10, -10, -5, math.hypot(10, 150), 0])


def test_ellipse_distance_matches_brute_force():
    plate = Plate([0, 0, 0], [1, 0, 0], [0, 0, 1], [1000, 600], 2, {"offset": [0, 0], "semi_axes": [250, 100]})
    t = np.linspace(0, 2 * np.pi, 200001)
    rim = np.stack([250 * np.cos(t), 100 * np.sin(t)], -1)
    rng = np.random.default_rng(1)
    for y, z in rng.uniform([-240, -90], [240, 90], size=(40, 2)):
        if (y / 250) ** 2 + (z / 100) ** 2 >= 1:
            continue
        brute = np.min(np.hypot(rim[:, 0] - y, rim[:, 1] - z))
        # In the plane of a hole point the distance to material is the distance to the rim.
        assert plate.signed_distance([0, y, z]) == pytest.approx(brute, abs=1e-3)


def cube_mesh(half: float) -> Mesh:
    v = np.array([[x, y, z] for x in (-half, half) for y in (-half, half) for z in (-half, half)])
    import trimesh

    hull = trimesh.convex.convex_hull(v)
    return Mesh(hull.vertices, hull.faces)


@settings(max_examples=60, deadline=None)
@given(point)
def test_mesh_cube_equals_box(p):
    mesh = cube_mesh(100)
    box = Box([0, 0, 0], [200, 200, 200])
    assert mesh.signed_distance(p) == pytest.approx(box.signed_distance(p), abs=1e-6)


@settings(max_examples=40, deadline=None)
@given(st.lists(point, min_size=2, max_size=6), st.floats(1, 40))
def test_chain_clearance_matches_dense_sampling(pts, radius):
    obstacles = ObstacleSet([
        Box([0, 0, 0], [100, 200, 150]),
        Sphere([250, 50, 0], 60),
        Plate([-250, 0, 0], [1, 0, 0], [0, 0, 1], [600, 500], 10, {"offset": [0, 50], "semi_axes": [120, 80]}),
        Pipe([0, 250, 0], [0, 0, 1], 60, 80, 300),
    ])
    joints = np.array(pts, dtype=float)
    radii = np.full(len(joints) - 1, radius)
    exact = obstacles.chain_clearance(joints, radii)
    step = 0.05
    sampled = sampled_chain_clearance(obstacles, joints, radii, step=step)
    # The exact value is within its tolerance of the true minimum; the sampled one over-estimates by <= step/2.
    assert exact <= sampled + 0.05 + 1e-9
    assert exact >= sampled - step / 2 - 1e-9
    assert obstacles.chain_collides(joints, radii) == (exact < 0) or abs(exact) < 0.06


@settings(max_examples=30, deadline=None)
@given(st.lists(st.lists(point, min_size=4, max_size=4), min_size=1, max_size=6), st.floats(1, 30))
def test_least_clearance_is_the_least_of_every_chains_clearance(chains, radius):
    obstacles = ObstacleSet([Box([0, 0, 0], [100, 200, 150]), Sphere([250, 50, 0], 60), cube_mesh(40.0),
                             Pipe([0, 250, 0], [0, 0, 1], 60, 80, 300)])
    joints = np.array(chains, dtype=float)
    radii = np.full(3, radius)
    each = obstacles.chain_clearance(joints, radii)
    least, i = obstacles.least_clearance(joints, radii)
    # both exceed the true values by at most the tolerance, so they agree to it; the chain named has the least
    assert least == pytest.approx(each.min(), abs=0.05 + 1e-9)
    assert each[i] <= each.min() + 0.05 + 1e-9
    assert ObstacleSet([]).least_clearance(joints, radii) == (math.inf, -1)


@settings(max_examples=30, deadline=None)
@given(st.lists(point, min_size=1, max_size=40), st.floats(0.0, 300.0))
def test_capped_signed_distance_is_the_least_of_each_obstacles_and_the_cap(points, cap):
    """A capped query equals min(the distance to each obstacle alone, cap) and evaluates no more obstacles than
    the uncapped one; free_space on a grid is the distance at the cell centres clamped to [-cap, cap]."""
    from snakeplan.scenes.routes.grid import Grid, free_space

    shapes = [Box([0, 0, 0], [100, 200, 150]), Sphere([250, 50, 0], 60), cube_mesh(40.0),
              Pipe([0, 250, 0], [0, 0, 1], 60, 80, 300),
              Plate([-250, 0, 0], [1, 0, 0], [0, 0, 1], [600, 500], 10, {"offset": [0, 50], "semi_axes": [120, 80]})]
    obstacles = ObstacleSet(shapes)
    p = np.array(points, dtype=float)
    each = np.min([ObstacleSet([o]).signed_distance(p) for o in shapes], axis=0)
    before = int(obstacles.evaluations[0])
    np.testing.assert_allclose(obstacles.signed_distance(p, cap), np.minimum(each, cap), rtol=0, atol=1e-9)
    capped = int(obstacles.evaluations[0]) - before
    obstacles.signed_distance(p)
    assert capped <= int(obstacles.evaluations[0]) - before - capped
    grid = Grid.covering(np.array([-400.0, -300, -300]), np.array([400.0, 400, 300]), 50.0)
    if cap <= 0.0:  # a field clamped to [0, 0] would lose the side of every cell
        with pytest.raises(ValueError, match="cap: a grid query needs a finite positive cap"):
            free_space(obstacles, grid, cap)
        return
    centres = grid.centres().reshape(-1, 3)
    expect = np.clip(obstacles.signed_distance(centres), -cap, cap).reshape(grid.shape)
    np.testing.assert_allclose(free_space(obstacles, grid, cap), expect, rtol=0, atol=1e-9)
    np.testing.assert_allclose(obstacles.grid_distance(grid.origin, grid.spacing, grid.shape, cap, (3, 7)),
                               expect[:, :, 3:7], rtol=0, atol=1e-9)


@pytest.mark.parametrize("cell, cap", [(50.0, 120.0), (80.0, 60.0)])
def test_a_mesh_grid_field_is_the_clamped_distance_far_inside_and_outside_and_is_kept_per_content(cell, cap):
    """A mesh is searched only near each cell (within the cap, and beyond the z spacing), and a cell with no surface
    that near takes its side from the cell before it, or from a ray at the first cell of a column (a chunk of
    layers starts inside the cube): a 600 mm cube mesh's field equals the box's analytic distance clamped to
    [-cap, cap], deep inside included, with the cell smaller and larger than the cap; a non-convex closed mesh
    (an annulus) and an open shell equal their exact point queries, clamped. An equal mesh built again reuses the
    field without evaluating."""
    from snakeplan.geometry import distance
    from snakeplan.scenes.routes.grid import Grid, free_space

    distance._MESH_GRIDS.clear()
    grid = Grid.covering(np.array([-500.0, -450, -420]), np.array([480.0, 500, 430]), cell)
    centres = grid.centres().reshape(-1, 3)
    cube = ObstacleSet([cube_mesh(300.0)])
    box = ObstacleSet([Box([0, 0, 0], [600, 600, 600])]).signed_distance(centres)
    assert (box < -cap).any() and (box > cap).any()
    field = free_space(cube, grid, cap)
    np.testing.assert_allclose(field.reshape(-1), np.clip(box, -cap, cap), rtol=0, atol=1e-9)
    assert cube.evaluations[0] > 0
    again = ObstacleSet([Sphere([0, 0, 900], 20), cube_mesh(300.0)])
    both = free_space(again, grid, cap)
    assert again.evaluations[0] <= np.prod(grid.shape) // 4  # the sphere's cells only
    sphere = np.linalg.norm(centres - [0, 0, 900], axis=1) - 20
    np.testing.assert_allclose(both.reshape(-1), np.clip(np.minimum(box, sphere), -cap, cap), rtol=0, atol=1e-9)
    ring = trimesh.creation.annulus(r_min=150, r_max=400, height=500, sections=48)
    cup = trimesh.creation.box(extents=[700, 700, 500])
    cup = trimesh.Trimesh(cup.vertices, cup.faces[np.abs(cup.face_normals[:, 2] - 1) > 1e-9])  # no top: a shell
    for mesh in (Mesh(ring.vertices, ring.faces), Mesh(cup.vertices, cup.faces, thickness=20.0)):
        one = ObstacleSet([mesh])
        exact = np.clip(one.signed_distance(centres), -cap, cap)
        np.testing.assert_allclose(free_space(one, grid, cap).reshape(-1), exact, rtol=0, atol=1e-9)


def test_the_kept_mesh_fields_stay_within_their_bound_dropping_the_least_recently_used(monkeypatch):
    from snakeplan.geometry import distance
    from snakeplan.scenes.routes.grid import Grid, free_space

    distance._MESH_GRIDS.clear()
    grid = Grid.covering(np.array([-200.0, -200, -200]), np.array([200.0, 200, 200]), 40.0)
    monkeypatch.setattr(distance, "MESH_GRID_CELLS", 2 * int(np.prod(grid.shape)))
    small, large, third = (ObstacleSet([cube_mesh(h)]) for h in (50.0, 70.0, 90.0))
    for obstacles in (small, large, small, third):  # small used again: large is the least recently used
        free_space(obstacles, grid, 60.0)
    kept = {key[0] for key in distance._MESH_GRIDS}
    assert kept == {(small.obstacles[0].fingerprint(),), (third.obstacles[0].fingerprint(),)}
    before = int(large.evaluations[0])
    free_space(large, grid, 60.0)
    assert large.evaluations[0] > before  # dropped, so evaluated again


def test_an_obstacle_set_pickles_as_its_obstacles_and_loads_an_older_versions_state():
    # A training checkpoint pickles the environment, obstacle sets included; the packed arrays are derived, so a
    # state written before they changed (here: a dict without them) must load into today's form.
    obstacles = ObstacleSet([Sphere([0, 0, 0], 10), Box([100, 0, 0], [20, 20, 20]), cube_mesh(5.0)])
    points = np.array([[0, 0, 30.0], [100, 0, 25], [0, 0, 0]])
    blob = pickle.dumps(obstacles)
    assert len(blob) < len(pickle.dumps(obstacles.packed))
    again = pickle.loads(blob)
    assert np.array_equal(again.signed_distance(points), obstacles.signed_distance(points))
    old_mesh = Mesh.__new__(Mesh)  # a mesh pickled before the fields derived from it changed
    old_mesh.__setstate__({"vertices": obstacles.obstacles[2].vertices, "faces": obstacles.obstacles[2].faces,
                           "thickness": None})
    older = ObstacleSet.__new__(ObstacleSet)
    older.__setstate__({"obstacles": (*obstacles.obstacles[:2], old_mesh), "_rows": np.zeros((3, 1)),
                        "evaluations": np.zeros(1)})
    assert np.allclose(older.signed_distance(points)[:2], [20.0, 15.0]) and old_mesh.closed
    mesh = obstacles.obstacles[2]
    again_mesh = pickle.loads(pickle.dumps(mesh))
    assert np.array_equal(again_mesh.vertices, mesh.vertices) and np.array_equal(again_mesh.faces, mesh.faces)
    assert again_mesh.closed == mesh.closed and "_distance_data" not in again_mesh.__dict__
    assert all(np.array_equal(a, b) for a, b in zip(older.packed, obstacles.packed))


def test_chain_clearance_batched_shapes_and_empty_scene():
    obstacles = ObstacleSet([Sphere([0, 0, 0], 10)])
    joints = np.zeros((4, 5, 3, 3))
    joints[..., 0] = np.arange(3) * 10 + 100
    out = obstacles.chain_clearance(joints, np.ones(2))
    assert out.shape == (4, 5)
    assert np.allclose(out, 100 - 10 - 1, atol=0.06)
    assert np.isinf(ObstacleSet([]).chain_clearance(joints, np.ones(2))).all()


def test_line_of_sight_and_raycast():
    obstacles = ObstacleSet([Box([0, 0, 0], [100, 100, 100])])
    assert not obstacles.line_of_sight([-200, 0, 0], [200, 0, 0])
    assert obstacles.line_of_sight([-200, 0, 100], [200, 0, 100])
    hit = obstacles.raycast([[-200, 0, 0], [-200, 0, 100]], [[1, 0, 0], [1, 0, 0]])
    assert hit[0] == pytest.approx(150, abs=1e-2)
    assert np.isinf(hit[1])


def test_round_trip_and_validation():
    obstacles = [
        Box([1, 2, 3], [4, 5, 6], frame_from_z([1, 1, 0])),
        Sphere([0, 0, 0], 3),
        Cylinder([0, 0, 0], [0, 1, 0], 2, 5),
        Pipe([0, 0, 0], [0, 0, 2], 1, 2, 3),
        Plate([0, 0, 0], [0, 0, 1], [0, 1, 0], [10, 20], 1, {"offset": [1, 2], "semi_axes": [2, 3]}),
        cube_mesh(5),
    ]
    for o in obstacles:
        again = obstacle_from_dict(o.to_dict())
        assert again.to_dict() == o.to_dict()
    with pytest.raises(ValueError, match=r"obstacles\[2\].radius"):
        obstacle_from_dict({"type": "sphere", "center": [0, 0, 0], "radius": -1}, "obstacles[2]")
    with pytest.raises(ValueError, match="unknown obstacle type"):
        obstacle_from_dict({"type": "torus"})
    with pytest.raises(ValueError, match="center"):
        obstacle_from_dict({"type": "sphere", "center": [0, float("nan"), 0], "radius": 1})
    with pytest.raises(ValueError, match="hole"):
        Plate([0, 0, 0], [0, 0, 1], [0, 1, 0], [10, 10], 1, {"offset": [0, 0], "semi_axes": [5, 1]})


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000), many=st.booleans())
def test_raycast_culling_keeps_the_first_hit_among_many_obstacles(seed, many):
    """Tracing only the obstacles whose bounding boxes a ray meets (found through the obstacle tree, several levels
    deep with ``many``) finds the same first surface as sphere tracing the whole scene's signed distance (NumPy,
    step by step)."""
    rng = np.random.default_rng(seed)
    obstacles = [Sphere(rng.uniform(-300, 300, 3), rng.uniform(10, 60)) for _ in range(6)]
    obstacles += [Box(c, rng.uniform(20, 120, 3)) for c in rng.uniform(-300, 300, (6, 3))]
    if many:
        obstacles += [Box(c, rng.uniform(5, 30, 3)) for c in rng.uniform(-600, 600, (150, 3))]
    scene = ObstacleSet(obstacles)
    origin = rng.uniform(-400, 400, 3)
    dirs = rng.normal(size=(8, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    eps, reach = 1e-3, 500.0
    hit = scene.raycast(origin, dirs, reach, eps=eps)
    for d, h in zip(dirs, hit):
        t, ref = 0.0, np.inf
        while t <= reach:
            step = float(scene.signed_distance(origin + t * d))
            if step < eps:
                ref = t
                break
            t += step
        assert (np.isinf(h) and np.isinf(ref)) or abs(h - ref) < 0.01
        if np.isfinite(h):
            assert scene.signed_distance(origin + h * d) < eps


@given(flags=st.lists(st.booleans(), min_size=7, max_size=7), seed=st.integers(0, 2**31 - 1))
@settings(max_examples=30, deadline=None)
def test_a_subset_answers_as_the_set_of_its_obstacles_packed_alone(flags, seed):
    ball = trimesh.creation.icosphere(subdivisions=2, radius=60.0)
    ring = trimesh.creation.annulus(r_min=40.0, r_max=70.0, height=30.0)
    ring.apply_translation([-250.0, 0.0, 0.0])
    obstacles = [Box([200.0, 0.0, 0.0], [50.0, 400.0, 400.0]), Mesh(ball.vertices, ball.faces),
                 Sphere([0.0, 250.0, 0.0], 40.0), Mesh(ring.vertices, ring.faces),
                 Plate([0.0, 0.0, 300.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [500.0, 500.0], 10.0,
                       {"offset": [0.0, 0.0], "semi_axes": [80.0, 50.0]}),
                 Cylinder([0.0, -250.0, 0.0], [1.0, 0.0, 0.0], 30.0, 200.0),
                 Pipe([0.0, 0.0, -300.0], [0.0, 0.0, 1.0], 60.0, 80.0, 100.0)]
    whole = ObstacleSet(obstacles)
    part = whole.subset(flags)
    alone = ObstacleSet([o for o, f in zip(obstacles, flags) if f])
    rng = np.random.default_rng(seed)
    pts = rng.uniform(-400.0, 400.0, (50, 3))
    dirs = rng.standard_normal((50, 3))
    assert part.obstacles == alone.obstacles
    np.testing.assert_array_equal(part.signed_distance(pts), alone.signed_distance(pts))
    np.testing.assert_array_equal(part.raycast(pts, dirs, 600.0), alone.raycast(pts, dirs, 600.0))
    joints = rng.uniform(-400.0, 400.0, (20, 4, 3))
    np.testing.assert_array_equal(part.chain_collides(joints, np.full(3, 10.0)),
                                  alone.chain_collides(joints, np.full(3, 10.0)))


@given(a=st.floats(5.0, 400.0), b=st.floats(5.0, 400.0), u=st.floats(-3.0, 3.0), v=st.floats(-3.0, 3.0))
@settings(max_examples=200, deadline=None)
def test_ellipse_distance_is_the_nearest_rim_point_to_a_micrometre_fraction(a, b, u, v):
    """The distance to an ellipse's rim (negative inside) against the rim's nearest point found by sampling the
    rim's angle densely three times, each time around the last nearest sample."""
    from snakeplan.geometry.distance import _ellipse_distance

    px, py = u * a, v * b
    centre, half = 0.0, np.pi
    for _ in range(3):
        t = np.linspace(centre - half, centre + half, 20001)
        d = np.hypot(a * np.cos(t) - px, b * np.sin(t) - py)
        centre, half = t[np.argmin(d)], 4.0 * (t[1] - t[0])
    nearest = float(d.min())
    expect = nearest if (px / a) ** 2 + (py / b) ** 2 >= 1.0 else -nearest
    assert _ellipse_distance(px, py, a, b) == pytest.approx(expect, abs=1e-7)
