"""Mesh obstacles: the tree-walk distance against brute force, collisions against coal, open meshes, mesh files,
scene import and the mesh scene families."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from snakeplan.geometry import mesh_distance
from snakeplan.geometry.distance import ObstacleSet
from snakeplan.geometry.primitives import Box, Mesh
from snakeplan.scenes.scene import MeshWarning, Scene

trimesh = pytest.importorskip("trimesh")


@pytest.fixture(scope="module")
def part() -> Mesh:
    """A closed, non-convex part: a block with a spherical pocket cut into one face and a boss on another."""
    from manifold3d import Manifold

    from snakeplan.scenes.meshing import to_mesh

    block = Manifold.cube([200.0, 120.0, 80.0], center=True)
    pocket = Manifold.sphere(50.0, 48).translate([60.0, 0.0, 40.0])
    boss = Manifold.cylinder(60.0, 25.0, 25.0, 40).translate([-60.0, 0.0, 40.0])
    return to_mesh([(block - pocket) + boss], triangles=5000)


def _points(mesh: Mesh, n: int, rng: np.random.Generator) -> np.ndarray:
    """Half uniform in a box around the mesh, half near the surface (within 5 mm on either side)."""
    lo, hi = mesh.aabb()
    far = rng.uniform(lo - 40.0, hi + 40.0, (n // 2, 3))
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    surf, face = trimesh.sample.sample_surface(tm, n - n // 2, seed=int(rng.integers(2**31)))
    near = surf + rng.uniform(-5.0, 5.0, (len(surf), 1)) * tm.face_normals[face]
    return np.vstack([far, near])


def test_closed_mesh_distance_matches_brute_force(part):
    """10,000 points near and far: the tree walk with pseudonormal signs equals every-triangle distance with a winding-number
    sign to 1e-6 mm."""
    assert part.closed
    pts = _points(part, 10_000, np.random.default_rng(1))
    fast = ObstacleSet([part]).signed_distance(pts)
    ref = mesh_distance.reference_sdf(part.vertices, part.faces, pts)
    assert np.abs(fast - ref).max() <= 1e-6
    assert (ref < 0).sum() > 1000 and (ref > 0).sum() > 1000  # both sides exercised


def test_closed_mesh_is_solid_like_the_box_it_tessellates():
    """A box exported as 12 triangles has the box's exact signed distance, inside and out."""
    box = Box([10.0, -5.0, 3.0], [80.0, 40.0, 20.0])
    tm = trimesh.creation.box(extents=box.size, transform=trimesh.transformations.translation_matrix(box.center))
    mesh = Mesh(tm.vertices, tm.faces)
    pts = np.random.default_rng(2).uniform(-80.0, 80.0, (5000, 3))
    assert np.abs(mesh.signed_distance(pts) - box.signed_distance(pts)).max() <= 1e-9


def test_inward_faces_are_turned_outward():
    tm = trimesh.creation.icosphere(2, 50.0)
    inverted = Mesh(tm.vertices, tm.faces[:, ::-1])
    assert inverted.signed_distance(np.zeros(3)) == pytest.approx(-Mesh(tm.vertices, tm.faces).signed_distance(
        np.array([0.0, 0.0, 100.0])) + 50.0 - 100.0 + 50.0, abs=2.0)
    assert inverted.signed_distance(np.zeros(3)) < -45.0


@pytest.mark.parametrize("n", [500, pytest.param(10_000, marks=pytest.mark.slow)])
def test_capsule_distance_matches_brute_force(part, n):
    """Random capsules (10,000 in the slow run): a one-link chain's clearance is the exact segment-to-surface
    distance minus the radius (to 1e-6 mm) for links outside the part, and negative for links that enter it."""
    rng = np.random.default_rng(3)
    a = _points(part, n, rng)
    d = rng.normal(size=(n, 3))
    b = a + d / np.linalg.norm(d, axis=1, keepdims=True) * rng.uniform(1.0, 120.0, (n, 1))
    radius = 4.0
    clearance = ObstacleSet([part]).chain_clearance(np.stack([a, b], axis=1), np.array([radius]))
    surface = mesh_distance.reference_segment_distance(part.vertices, part.faces, a, b)
    ends = mesh_distance.reference_sdf(part.vertices, part.faces, np.vstack([a, b]))
    outside = (surface > 1e-9) & (ends[:n] > 0)
    assert outside.sum() > 0.3 * n and (~outside).sum() > 0.1 * n
    assert np.abs(clearance[outside] - (surface[outside] - radius)).max() <= 1e-6
    assert np.all(clearance[~outside] < 0.0)


def _coal_model(coal, mesh: Mesh):
    """The mesh as coal's bounding volume hierarchy (the independent library the collision tests compare with)."""
    model = coal.BVHModelOBBRSS()
    model.beginModel(len(mesh.faces), len(mesh.vertices))
    model.addVertices(np.asarray(mesh.vertices, dtype=float))
    model.addTriangles(np.asarray(mesh.faces, dtype=np.int64))
    model.endModel()
    return model


def _coal_pose(coal, a: np.ndarray, b: np.ndarray):
    """coal's pose of a capsule along segment a -> b (its axis is the local z, centred at the origin)."""
    z = (b - a) / np.linalg.norm(b - a)
    x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    T = coal.Transform3s()
    T.setRotation(np.stack([x, np.cross(z, x), z], axis=1))
    T.setTranslation(0.5 * (a + b))
    return T


def test_collisions_agree_with_coal(part):
    """Capsule against mesh, yes or no, agrees with coal (a surface test: capsules wholly inside the part, which
    coal does not see, and contacts within the contact resolution are left out)."""
    coal = pytest.importorskip("coal")
    model = _coal_model(coal, part)
    rng = np.random.default_rng(4)
    n = 300
    a = _points(part, n, rng)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    length = rng.uniform(5.0, 150.0, n)
    radius = rng.uniform(1.0, 20.0, n)
    b = a + d * length[:, None]
    obstacles = ObstacleSet([part])
    ours = np.array([obstacles.chain_collides(np.stack([a[i], b[i]])[None], radius[i:i + 1])[0] for i in range(n)])
    surface = mesh_distance.reference_segment_distance(part.vertices, part.faces, a, b)
    inside = (mesh_distance.reference_sdf(part.vertices, part.faces, a) < 0) & (surface > radius)
    clear_cut = np.abs(surface - radius) > 0.02
    theirs = np.empty(n, dtype=bool)
    for i in range(n):
        T = _coal_pose(coal, a[i], b[i])
        result = coal.CollisionResult()
        theirs[i] = coal.collide(model, coal.Transform3s(), coal.Capsule(radius[i], length[i]), T,
                                 coal.CollisionRequest(), result) > 0
    keep = ~inside & clear_cut
    assert keep.sum() > 0.7 * n and theirs[keep].sum() > 0.1 * n
    assert np.array_equal(ours[keep], theirs[keep])
    assert np.all(ours[inside])


def test_segment_distance_agrees_with_coal(part):
    """The segment-to-surface distance (every triangle, the reference the tree walk is held to) agrees with coal's
    capsule-to-mesh distance plus the capsule's radius, for capsules clear of the part."""
    coal = pytest.importorskip("coal")
    model = _coal_model(coal, part)
    rng = np.random.default_rng(7)
    n, radius = 300, 1.0
    a = _points(part, n, rng)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    length = rng.uniform(5.0, 150.0, n)
    b = a + d * length[:, None]
    ours = mesh_distance.reference_segment_distance(part.vertices, part.faces, a, b)
    keep = (ours > 2.0 * radius) & (mesh_distance.reference_sdf(part.vertices, part.faces, a) > 0)
    assert keep.sum() > 0.4 * n
    for i in np.flatnonzero(keep):
        T = _coal_pose(coal, a[i], b[i])
        result = coal.DistanceResult()
        coal.distance(model, coal.Transform3s(), coal.Capsule(radius, length[i]), T, coal.DistanceRequest(), result)
        assert ours[i] == pytest.approx(result.min_distance + radius, abs=1e-4)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.floats(-50.0, 50.0, allow_nan=False), min_size=15, max_size=15),
       st.sampled_from(["free", "parallel", "in-plane", "through"]))
def test_segment_triangle_is_the_least_of_its_candidate_pairs(coords, kind):
    """Segment against triangle equals the textbook composition: 0 where the segment crosses, else the least of
    both ends against the whole triangle and the segment against each edge; with segments parallel to the
    triangle, lying in its plane and passing through it."""
    c = np.array(coords).reshape(5, 3)
    tri = c[:3]
    a, b = c[3], c[4]
    n = np.cross(tri[1] - tri[0], tri[2] - tri[0])
    if np.linalg.norm(n) < 1e-3:
        return
    n /= np.linalg.norm(n)
    if kind == "parallel":
        b = b - ((b - a) @ n) * n
    elif kind == "in-plane":
        a, b = a - ((a - tri[0]) @ n) * n, b - ((b - tri[0]) @ n) * n
    elif kind == "through":
        centre = tri.mean(axis=0)
        a, b = centre + 0.3 * (a - centre), 2.0 * centre - (centre + 0.3 * (a - centre)) + 5.0 * n
    d2, feature, s, x, y, z = mesh_distance.segment_triangle(a, b, tri[None], 0)
    # a crossing passes from one side of the plane to the other (within the plane, ends or edges meet instead)
    sides = (a - tri[0]) @ n, (b - tri[0]) @ n
    crossing = (sides[0] * sides[1] < 0.0 and min(map(abs, sides)) > 1e-9
                and mesh_distance.ray_triangle(a, b - a, tri[0], tri[1], tri[2])[0] <= 1.0)
    ends = min(mesh_distance.closest_on_triangle(p, tri[0], tri[1], tri[2])[0] for p in (a, b))
    edges = min(mesh_distance._segments_closest(*a, *b, *tri[j], *tri[(j + 1) % 3])[0] for j in range(3))
    expected = 0.0 if crossing else min(ends, edges)
    assert d2 == pytest.approx(expected, abs=1e-7, rel=1e-9)
    # the pair it reports is attained: the closest points are that far apart
    assert np.sum((a + s * (b - a) - np.array([x, y, z])) ** 2) == pytest.approx(d2, abs=1e-7, rel=1e-9)


def test_crawl_clearance_is_each_chains_own(part):
    """Along a crawl of four-link chains past and into the part, each chain's clearance (links taken in the
    previous chain's order, searches started from its values moved by the links' displacement) equals the chain
    taken alone, and for chains clear of the part the exact least segment distance less the radius (1e-6 mm)."""
    rng = np.random.default_rng(8)
    lo, hi = (np.asarray(v) for v in part.aabb())
    start = np.array([lo[0] - 60.0, 0.5 * (lo[1] + hi[1]), hi[2] + 25.0])
    links, length, radius = 4, 40.0, 6.0
    steps = 120
    chains = np.empty((steps, links + 1, 3))
    for i in range(steps):
        tip = start + np.array([3.0 * i, 0.0, -0.35 * i]) + rng.normal(scale=0.3, size=3)
        chains[i] = tip - np.arange(links + 1)[:, None] * np.array([length, 0.0, 0.0])
    radii = np.full(links, radius)
    obstacles = ObstacleSet([part])
    crawl = obstacles.chain_clearance(chains, radii)
    alone = np.array([obstacles.chain_clearance(ch[None], radii)[0] for ch in chains])
    assert np.abs(crawl - alone).max() <= 1e-9
    a, b = chains[:, :-1].reshape(-1, 3), chains[:, 1:].reshape(-1, 3)
    surface = mesh_distance.reference_segment_distance(part.vertices, part.faces, a, b).reshape(steps, links)
    ends = mesh_distance.reference_sdf(part.vertices, part.faces, chains.reshape(-1, 3)).reshape(steps, links + 1)
    clear = np.all(surface > 1e-9, axis=1) & np.all(ends > 0.0, axis=1)
    assert 10 < clear.sum() < steps - 10  # the crawl runs both clear of the part and into it
    assert np.abs(crawl[clear] - (surface[clear].min(axis=1) - radius)).max() <= 1e-6
    assert np.all(crawl[~clear] < 0.0)


def test_inside_test_agrees_with_winding_numbers(part):
    """The one-ray inside test (first surface met faces away) says inside exactly where the winding number does,
    for points near and far."""
    from snakeplan.geometry import bvh

    pts = _points(part, 4000, np.random.default_rng(9))
    tris, normals, nodes, links = mesh_distance.prepare(part.vertices, part.faces)
    stack = np.empty(bvh.STACK_SIZE, dtype=np.int64)
    ours = np.array([mesh_distance.mesh_inside(tris, normals, nodes, links, 0, p, stack) for p in pts])
    ref = mesh_distance.reference_sdf(part.vertices, part.faces, pts) < 0.0
    assert ref.sum() > 1000 and (~ref).sum() > 1000
    assert np.array_equal(ours, ref)


def test_a_link_through_a_mesh_is_found_at_a_zero_cutoff():
    """A link that passes through a closed mesh collides whatever its radius, also when the radius equals the
    contact resolution (the search's cutoff is then exactly 0), and a chain's clearance with such a link is that
    link's own; an empty batch of chains has no clearances."""
    from snakeplan.geometry.distance import CONTACT_RESOLUTION_MM

    tm = trimesh.creation.box(extents=[20.0, 20.0, 20.0])
    obstacles = ObstacleSet([Mesh(tm.vertices, tm.faces)])
    a, b = np.array([-30.0, 0.3, 0.2]), np.array([30.0, 0.3, 0.2])
    for radius in (0.0, CONTACT_RESOLUTION_MM, 0.02):
        assert not obstacles.segments_clear(a, b, radius)
        assert obstacles.chain_collides(np.stack([a, b])[None], np.array([radius]))[0]
    with_face = ObstacleSet([Mesh(tm.vertices, tm.faces), Box([0.0, 40.0, 0.0], [20.0, 20.0, 20.0])])
    chain = np.array([[-5.0, 30.0, 0.0], [5.0, 30.0, 0.0], [-30.0, 0.0, 0.0], [-5.0, 0.0, 0.0]])
    together = with_face.chain_clearance(chain, np.ones(3))
    assert together == pytest.approx(with_face.chain_clearance(chain[2:], np.ones(1)), abs=0.05)
    assert together == pytest.approx(-6.0, abs=0.05)
    assert obstacles.chain_clearance(np.zeros((0, 3, 3)), np.ones(2)).shape == (0,)


def test_inside_test_is_not_fooled_by_a_ray_through_an_edge():
    """Points placed so that the inside test's first ray runs exactly through a concave edge of a notched cube
    (it grazes the surface there without crossing it) are still judged as the winding number judges them."""
    from manifold3d import Manifold

    from snakeplan.geometry import bvh
    from snakeplan.scenes.meshing import to_mesh

    cube = Manifold.cube([20.0, 20.0, 20.0], center=True) - Manifold.cube([20.0, 40.0, 20.0]).translate(
        [0.0, -20.0, -20.0])
    mesh = to_mesh([cube])
    ray = mesh_distance._INSIDE_RAYS[0]
    y, t = np.meshgrid(np.linspace(-8.0, 8.0, 15), np.linspace(0.5, 8.0, 15))
    pts = np.stack([np.zeros(y.size), y.ravel(), np.zeros(y.size)], axis=1) - t.reshape(-1, 1) * ray
    tris, normals, nodes, links = mesh_distance.prepare(mesh.vertices, mesh.faces)
    stack = np.empty(bvh.STACK_SIZE, dtype=np.int64)
    ours = np.array([mesh_distance.mesh_inside(tris, normals, nodes, links, 0, p, stack) for p in pts])
    ref = mesh_distance.reference_sdf(mesh.vertices, mesh.faces, pts) < 0.0
    assert ref.sum() > 100 and (~ref).sum() > 10  # mostly inside: grazing the concave edge from the material
    assert np.array_equal(ours, ref)


def test_rays_on_a_closed_mesh_agree_with_embree(part):
    """Range-sensor rays (``ObstacleSet.raycast``) in a scene of the part and a sphere primitive: on the part the
    first hit agrees with embree (trimesh's ray intersector) to 0.01 mm, rays starting inside the part stop at 0,
    and where the sphere is nearer its sphere-traced hit (within ``eps``) is taken."""
    from snakeplan.geometry.primitives import Sphere

    if not trimesh.ray.has_embree:
        pytest.skip("embreex is not installed")
    from trimesh.ray.ray_pyembree import RayMeshIntersector

    rng = np.random.default_rng(10)
    n = 2000
    origins = _points(part, n, rng)
    dirs = rng.normal(size=(n, 3))
    dirs[: n // 2] = np.mean(part.aabb(), axis=0) - origins[: n // 2] + rng.normal(scale=30.0, size=(n // 2, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    reach = 400.0
    ours = ObstacleSet([part]).raycast(origins, dirs, reach)
    inside = mesh_distance.reference_sdf(part.vertices, part.faces, origins) < 0.0
    assert np.all(ours[inside] == 0.0)
    tm = trimesh.Trimesh(part.vertices, part.faces, process=False)
    locations, ray_index, _ = RayMeshIntersector(tm).intersects_location(origins, dirs, multiple_hits=False)
    theirs = np.full(n, np.inf)
    theirs[ray_index] = np.linalg.norm(locations - origins[ray_index], axis=1)
    theirs[theirs > reach] = np.inf
    out = ~inside
    assert np.isfinite(theirs[out]).sum() > 0.3 * n and np.isinf(theirs[out]).sum() > 0.1 * n
    assert np.array_equal(np.isinf(ours[out]), np.isinf(theirs[out]))
    both = out & np.isfinite(theirs)
    assert np.abs(ours[both] - theirs[both]).max() < 0.01

    ball = Sphere(np.asarray(part.aabb()[1]) + 20.0, 60.0)
    with_ball = ObstacleSet([part, ball]).raycast(origins, dirs, reach)
    alone = ObstacleSet([ball]).raycast(origins, dirs, reach)
    assert np.array_equal(with_ball, np.minimum(ours, alone))
    assert np.sum(alone < ours) > 10 and np.sum(np.isfinite(alone) & (alone > ours)) > 10


def test_parts_touching_at_a_vertex_keep_exact_signs():
    """A cone whose apex touches the inner corner of a block's notch (one closed mesh, two parts meeting at a
    vertex): the vertex is found as the only one with two fans of faces, and points around it (inside the block,
    inside the cone, in the notch) and links through it get the winding number's side."""
    from manifold3d import Manifold

    block = Manifold.cube([100.0, 100.0, 100.0]) - Manifold.cube([50.0, 50.0, 50.0]).translate([50.0, 50.0, 50.0])
    out = block.to_mesh()
    corner = np.array([50.0, 50.0, 50.0])
    cone = trimesh.creation.cone(radius=40.0 * np.tan(np.radians(20.0)), height=40.0, sections=16)
    cone.apply_transform(trimesh.transformations.rotation_matrix(np.pi, [1.0, 0.0, 0.0]))
    cone.apply_translation([0.0, 0.0, 40.0])  # apex at the origin, body along +z
    cone.apply_transform(trimesh.geometry.align_vectors([0.0, 0.0, 1.0], np.ones(3) / np.sqrt(3.0)))
    vertices = cone.vertices.copy()
    vertices[np.argmin(np.linalg.norm(vertices, axis=1))] = 0.0
    joined = trimesh.util.concatenate([trimesh.Trimesh(np.asarray(out.vert_properties)[:, :3],
                                                       np.asarray(out.tri_verts), process=False),
                                       trimesh.Trimesh(vertices + corner, cone.faces, process=False)])
    joined.merge_vertices()
    mesh = Mesh(joined.vertices, joined.faces)
    assert mesh.closed
    closed, faces = mesh_distance.topology(mesh.vertices, mesh.faces)
    normals = mesh_distance.pseudonormals(mesh.vertices, faces)
    pinched = np.unique(faces[np.all(normals[:, 4:7] == 0.0, axis=2)])
    assert len(pinched) == 1 and np.array_equal(mesh.vertices[pinched[0]], corner)

    rng = np.random.default_rng(11)
    pts = corner + rng.normal(size=(20_000, 3)) * 3.0
    ours = ObstacleSet([mesh]).signed_distance(pts)
    ref = mesh_distance.reference_sdf(mesh.vertices, mesh.faces, pts)
    assert (ref < 0).sum() > 1000 and (ref > 0).sum() > 1000
    assert np.abs(ours - ref).max() <= 1e-9
    a = corner + rng.normal(size=(500, 3)) * 4.0
    a[:300] = corner + np.abs(a[:300] - corner)  # in the notch, around the cone
    b = a + rng.normal(size=(500, 3)) * 2.0
    clearance = ObstacleSet([mesh]).chain_clearance(np.stack([a, b], axis=1), np.array([0.5]))
    surface = mesh_distance.reference_segment_distance(mesh.vertices, mesh.faces, a, b)
    ends = mesh_distance.reference_sdf(mesh.vertices, mesh.faces, np.vstack([a, b]))
    outside = (surface > 1e-9) & (ends[:500] > 0)
    assert outside.sum() > 50 and (~outside).sum() > 50
    assert np.abs(clearance[outside] - (surface[outside] - 0.5)).max() <= 1e-6
    assert np.all(clearance[~outside] < 0.0)


def test_open_mesh_is_a_shell(part):
    """An open mesh (a hemisphere) stands for a shell: unsigned distance minus half its thickness, against the
    brute-force reference; the default thickness is stated and the scene loader warns."""
    sphere = trimesh.creation.icosphere(3, 80.0)
    keep = sphere.triangles_center[:, 2] > 0.0
    V, F = sphere.vertices, sphere.faces[keep]
    shell = Mesh(V, F, thickness=6.0)
    assert not shell.closed
    pts = np.random.default_rng(5).uniform(-120.0, 120.0, (3000, 3))
    ref = mesh_distance.reference_sdf(V, F, pts, thickness=6.0)
    assert np.abs(shell.signed_distance(pts) - ref).max() <= 1e-6
    assert Mesh(V, F).shell_thickness == mesh_distance.DEFAULT_SHELL_MM
    scene = _scene_dict([{"type": "mesh", "vertices": V.tolist(), "faces": F.tolist()}])
    with pytest.warns(MeshWarning, match=r"obstacles\[0\]: the mesh is open"):
        Scene.from_dict(scene)


def test_non_manifold_mesh_is_an_error():
    V = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, -1]]
    F = [[0, 1, 2], [1, 0, 3], [0, 1, 4], [2, 1, 3]]
    with pytest.raises(ValueError, match=r"^mesh.faces: non-manifold: the edge 0-1 is shared by 3 faces"):
        Mesh(V, F)


def _scene_dict(obstacles: list, targets=([400.0, 0.0, 0.0],)) -> dict:
    return {"schema": "snakeplan.scene/1", "name": "part", "bounds": {"min": [-500, -500, -500],
                                                                      "max": [500, 500, 500]},
            "entrance": {"position": [-450.0, 0.0, 0.0], "direction": [1, 0, 0]}, "targets": list(targets),
            "obstacles": obstacles}


@pytest.mark.parametrize("suffix", [".stl", ".obj", ".ply", ".glb"])
def test_mesh_file_in_metres_with_a_transform(tmp_path, part, suffix):
    """A part exported in metres, placed by a transform, is the inline mesh in mm moved by it (to the float32
    rounding of STL, GLB and PLY coordinates: 1e-4 mm on a 0.2 m part)."""
    tm = trimesh.Trimesh(part.vertices / 1000.0, part.faces)
    (tmp_path / "parts").mkdir()
    tm.export(tmp_path / "parts" / f"part{suffix}")
    T = np.eye(4)
    T[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]
    T[:3, 3] = [10.0, 20.0, -30.0]
    d = _scene_dict([{"type": "mesh", "file": f"parts/part{suffix}", "units": "m", "transform": T.tolist()},
                     {"type": "sphere", "center": [300, 300, 300], "radius": 20}])
    (tmp_path / "scene.json").write_text(json.dumps(d))
    scene = Scene.from_json((tmp_path / "scene.json").read_text(), "scene", tmp_path)
    moved = Mesh(part.vertices @ T[:3, :3].T + T[:3, 3], part.faces)
    pts = np.random.default_rng(6).uniform(-200.0, 200.0, (500, 3))
    assert np.abs(scene.obstacles[0].signed_distance(pts) - moved.signed_distance(pts)).max() <= 1e-4
    again = Scene.from_dict(json.loads(scene.to_json()))
    assert again.obstacles[0].to_dict()["units"] == "m"
    assert np.abs(again.signed_distance(pts) - scene.signed_distance(pts)).max() == 0.0


@pytest.mark.parametrize("change, field", [
    ({"file": "missing.stl"}, r"obstacles\[0\]\.file: file not found"),
    ({"file": "empty.stl"}, r"obstacles\[0\]\.file: .*(no triangles|cannot read)"),
    ({"file": "part.txt"}, r"obstacles\[0\]\.file: .*not a mesh file"),
    ({"units": "mm"}, r"obstacles\[0\]\.units: in 'mm' the mesh spans .*are its units 'm'\?"),
    ({"units": "furlong"}, r"obstacles\[0\]\.units: expected one of"),
    ({"transform": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0]]}, r"obstacles\[0\]\.transform: "),
    ({"transform": (2 * np.eye(4)).tolist()}, r"obstacles\[0\]\.transform\[3\]"),
])
def test_bad_mesh_files_name_the_field(tmp_path, part, change, field):
    trimesh.Trimesh(part.vertices / 1000.0, part.faces).export(tmp_path / "part.stl")
    (tmp_path / "empty.stl").write_bytes(b"")
    (tmp_path / "part.txt").write_text("not a mesh")
    spec = {"type": "mesh", "file": "part.stl", "units": "m", **change}
    with pytest.raises(ValueError, match=field):
        Scene.from_dict(_scene_dict([spec]), tmp_path)


def test_target_inside_a_mesh_is_an_error(tmp_path, part):
    trimesh.Trimesh(part.vertices, part.faces).export(tmp_path / "part.stl")
    spec = {"type": "mesh", "file": "part.stl", "units": "mm"}
    with pytest.raises(ValueError, match=r"^targets\[0\]: .* deep inside obstacles\[0\]"):
        Scene.from_dict(_scene_dict([spec], targets=([0.0, 0.0, 0.0],)), tmp_path)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        Scene.from_dict(_scene_dict([spec]), tmp_path)


@pytest.mark.parametrize("family", ["pipework", "vessel", "engine"])
def test_mesh_families_are_closed_with_free_targets_and_a_clear_entrance(family):
    from snakeplan.scenes import make_scene
    from snakeplan.scenes.mesh_families import TARGET_CLEARANCE_MM

    for seed in (0, 7):
        s = make_scene(family, seed)
        (mesh,) = s.obstacles
        assert mesh.closed
        assert make_scene(family, seed).targets.tolist() == s.targets.tolist()
        assert np.all(s.in_bounds(s.targets))
        # independent of the tree walk: the brute-force distance of the target
        assert mesh_distance.reference_sdf(mesh.vertices, mesh.faces, s.targets)[0] >= TARGET_CLEARANCE_MM - 1e-9
        e = s.entrance
        assert s.obstacle_set.segments_clear(e.position - 300.0 * e.direction, e.position + 100.0 * e.direction,
                                             27.5)


@pytest.mark.parametrize("family", ["pipework", "vessel", "engine"])
def test_as_rrt_plans_a_judged_path_in_each_mesh_family(family):
    from snakeplan.episode import run_episode
    from snakeplan.planners import Problem
    from snakeplan.robots import get_robot
    from snakeplan.scenes import make_scene

    s = make_scene(family, 0)
    episode = run_episode(Problem(s, get_robot("sjtu-snake-iii"), time_limit_s=20.0), "as-rrt", seed=0)
    assert episode.success, episode.report and episode.report.reason


def test_scene_import_then_plan_from_the_command_line(tmp_path, capsys):
    """An elbow exported in metres: import it with an entrance and a target, plan in it, judge it; bad options are
    one line naming the option, and nothing is written."""
    from snakeplan.cli import main
    from snakeplan.scenes.meshing import pipe_run, to_mesh

    elbow = to_mesh([pipe_run([[0, 0, 0], [500, 0, 0], [500, 500, 0]], 100.0, 15.0, 250.0, 48)])
    (tmp_path / "parts").mkdir()
    trimesh.Trimesh(elbow.vertices / 1000.0, elbow.faces).export(tmp_path / "parts" / "elbow.stl")
    out = tmp_path / "elbow.json"
    base = ["scene", "import", str(tmp_path / "parts" / "elbow.stl"), "--units", "m", "--entrance", "0,0,0",
            "--direction", "1,0,0", "-o", str(out)]
    for extra, field in ((["--target", "250,0,108"], "--target[0]: "), (["--target", "500,900,0", "--bounds=-100,-200,-200,700,700,200"], "--target[0]: "),
                         (["--target", "1,2"], "--target[0]: "), (["--target", "500,450,0", "--units", "mm"],
                                                                   "--units: ")):
        code = main(base + extra)
        err = capsys.readouterr().err
        assert code == 2 and not out.exists()
        assert err.count("\n") == 1 and err.startswith("snakeplan: error: ")
        assert err.startswith(f"snakeplan: error: {field}")
    assert main(base + ["--target", "500,450,0"]) == 0
    doc = json.loads(out.read_text())
    assert doc["obstacles"] == [{"type": "mesh", "file": "parts/elbow.stl", "units": "m"}]
    capsys.readouterr()
    assert main(["plan", "--scene-file", str(out), "--planner", "as-rrt", "--time-limit", "20"]) == 0
    assert "verdict: feasible" in capsys.readouterr().out


def test_scene_import_takes_negative_coordinates_as_values(tmp_path, capsys):
    """A mesh centred on the origin: entrance, target and bounds with negative numbers, written after the option
    as a user writes them (no '=' needed)."""
    from snakeplan.cli import main
    from snakeplan.scenes.meshing import pipe_run, to_mesh

    elbow = to_mesh([pipe_run([[0, 0, 0], [500, 0, 0], [500, 500, 0]], 100.0, 15.0, 250.0, 48)])
    trimesh.Trimesh((elbow.vertices - [250.0, 250.0, 0.0]) / 1000.0, elbow.faces).export(tmp_path / "elbow.stl")
    out = tmp_path / "centred.json"
    assert main(["scene", "import", str(tmp_path / "elbow.stl"), "--units", "m", "--entrance", "-250,-250,0",
                 "--direction", "1,0,0", "--target", "250,200,0", "--bounds", "-400,-450,-200,450,450,200",
                 "-o", str(out)]) == 0, capsys.readouterr().err
    doc = json.loads(out.read_text())
    assert doc["entrance"]["position"] == [-250.0, -250.0, 0.0] and doc["bounds"]["min"] == [-400.0, -450.0, -200.0]


def test_scene_import_help_is_its_own(capsys):
    from snakeplan.cli import main

    with pytest.raises(SystemExit) as stop:
        main(["scene", "import", "--help"])
    out = capsys.readouterr().out
    assert stop.value.code == 0 and out.startswith("usage: snakeplan scene import [-h] --units")
    assert "--entrance X,Y,Z" in out and "--target X,Y,Z" in out


@pytest.mark.parametrize("planner", ["rrt-star", "sp-rrt", "as-rrt"])
def test_sampling_planners_keep_their_time_budget_on_a_134k_triangle_mesh(planner):
    """The contract's deadline rule (conformance suite) on a mesh scene: a solvable problem within 1 s and a walled
    one (no plan exists; a new obstacle set around the same mesh) within 0.05 s, each plus the contract's slack.
    The walled problem ends in a timeout, or for sp-rrt, whose field of the mesh is kept from the first problem,
    may be found walled in (failed) before its budget ends."""
    from snakeplan.planners import Problem
    from snakeplan.planners.conformance import check_planner
    from snakeplan.robots import get_robot
    from snakeplan.scenes import make_scene, scene_spec

    scene = make_scene("pipework", 0)
    assert len(scene.obstacles[0].faces) > 100_000
    report = check_planner(planner, [Problem(scene, get_robot(scene_spec("pipework").robot), time_limit_s=1.0)])
    assert report.plans[0].endswith(": found")
    assert report.plans[1].endswith("0.05 s: timeout" if planner != "sp-rrt" else ("0.05 s: timeout", "0.05 s: no_progress"))


def test_a_mesh_read_in_the_wrong_unit_is_named_against_the_arm_and_a_point_in_metres_gets_a_hint(tmp_path, capsys):
    """The newcomer's mistakes: a part exported in metres read with --units cm is planned in as if a 5 m part were
    50 mm (a warning names both sizes and the unit), and an entrance typed in metres lands inside the part (the
    error says what it would be in mm)."""
    from snakeplan.cli import main
    from snakeplan.robots import get_robot
    from snakeplan.scenes import scale_warnings
    from snakeplan.scenes.importing import import_scene
    from snakeplan.scenes.meshing import pipe_run, to_mesh

    elbow = to_mesh([pipe_run([[0, 0, 0], [500, 0, 0], [500, 500, 0]], 100.0, 15.0, 250.0, 48)])
    trimesh.Trimesh(elbow.vertices / 100.0, elbow.faces).export(tmp_path / "elbow.stl")  # 5 m, in metres
    scene = import_scene([str(tmp_path / "elbow.stl")], "cm", np.zeros(3), np.array([1.0, 0.0, 0.0]), [],
                         tmp_path / "s.json")
    whole, line, way_in = scale_warnings(scene, get_robot("sjtu-snake-iii"))  # the auto bounds are that small too
    assert way_in.startswith("entrance: the free space there is") and "0 of its 12 sections fit through" in way_in
    assert whole.startswith("scene: elbow spans 162 mm, less than one section of sjtu-snake-iii")
    assert line.startswith("obstacles[0]: the mesh spans 61.5 mm (read in 'cm')")
    assert "less than one section of sjtu-snake-iii (178 mm); are its units right?" in line
    assert scale_warnings(import_scene([str(tmp_path / "elbow.stl")], "m", np.zeros(3), np.array([1.0, 0.0, 0.0]),
                                       [], tmp_path / "s.json"), get_robot("sjtu-snake-iii")) == []
    trimesh.creation.box(extents=(2.0, 2.0, 2.0)).export(tmp_path / "block.stl")  # a 2 m block about the origin
    code = main(["scene", "import", str(tmp_path / "block.stl"), "--units", "m", "--entrance", "-1.2,0,0",
                 "--direction", "1,0,0", "--bounds", "-1500,-1500,-1500,1500,1500,1500", "-o",
                 str(tmp_path / "x.json")])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "deep inside obstacles[0]" in err
    assert "were its coordinates metres? snakeplan's are mm: [-1200, 0, 0]" in err


def test_scene_import_adds_primitives_beside_the_meshes(tmp_path, capsys):
    """A floor the CAD file lacks, as a scene/1 box; a malformed one is one line naming it and writes nothing."""
    from snakeplan.cli import main

    trimesh.creation.box(extents=(2.0, 2.0, 2.0)).export(tmp_path / "block.stl")
    out = tmp_path / "s.json"
    floor = '{"type": "box", "center": [0, 0, -1110], "size": [3000, 3000, 20]}'
    base = ["scene", "import", str(tmp_path / "block.stl"), "--units", "m", "--entrance", "-1200,0,0",
            "--direction", "1,0,0", "-o", str(out)]
    assert main(base + ["--obstacle", floor]) == 0, capsys.readouterr().err
    doc = json.loads(out.read_text())
    assert [o["type"] for o in doc["obstacles"]] == ["mesh", "box"] and doc["obstacles"][1]["center"][2] == -1110
    assert doc["bounds"]["min"][2] == pytest.approx(-1120.0 - 50.0)  # the auto bounds hold the floor too
    out.unlink()
    assert main(base + ["--obstacle", '{"type": "box", "center": [0, 0]}']) == 2
    err = capsys.readouterr().err
    assert err.startswith("snakeplan: error: --obstacle[0].") and err.count("\n") == 1 and not out.exists()
