"""Point clouds as obstacles: exact clearance against brute force and SciPy's k-d tree, the file readers against
the libraries that write the files, scans of known scenes planned and judged in the exact scene, and bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from snakeplan.cli import main
from snakeplan.geometry.cloud_files import downsample, read_cloud_file
from snakeplan.geometry.distance import ObstacleSet
from snakeplan.geometry.primitives import Box, Points, obstacle_from_dict


def brute_segment_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from each segment a[i] -> b[i] to its nearest point of ``points``, every pair in NumPy."""
    out = np.empty(len(a))
    for i in range(len(a)):
        d = b[i] - a[i]
        t = np.clip((points - a[i]) @ d / max(d @ d, 1e-300), 0.0, 1.0)
        out[i] = np.sqrt(np.min(np.sum((a[i] + t[:, None] * d - points) ** 2, axis=1)))
    return out


def test_capsule_clearance_is_the_brute_force_distance_on_10000_random_capsules():
    """A cloud of 3,000 points (balls of 4 mm) and a box: every one of 10,000 random capsules' clearance is the
    brute-force least distance from its segment to the points, less both radii (or the box's, where nearer), to
    1e-9 mm, and collides exactly where that is below the contact resolution."""
    rng = np.random.default_rng(7)
    pts = rng.uniform(-200.0, 200.0, (3000, 3)) * [1.0, 1.0, 0.2]
    cloud = Points(pts, radius_mm=4.0)
    box = Box([400.0, 0.0, 0.0], [50.0, 50.0, 50.0])
    both = ObstacleSet([cloud, box])
    a = rng.uniform(-300.0, 450.0, (10_000, 3))
    b = a + rng.normal(0.0, 60.0, (10_000, 3))
    radii = rng.uniform(0.0, 20.0, 10_000)
    expected = np.minimum(brute_segment_distance(pts, a, b) - 4.0,
                          ObstacleSet([box]).chain_clearance(np.stack([a, b], axis=1)[:, None], [0.0])[:, 0]) - radii
    got = np.array([both.chain_clearance(np.stack([a[i], b[i]])[None], radii[i:i + 1])[0] for i in range(len(a))])
    near = expected < 100.0  # far from the box, its clearance is settled to the tolerance only
    assert np.abs(got - expected)[near].max() <= 1e-9
    collides = np.array([both.chain_collides(np.stack([a[i], b[i]])[None], radii[i:i + 1])[0] for i in range(len(a))])
    assert np.array_equal(collides, expected < -0.01)
    assert 500 < collides.sum() < 9500


def test_signed_distance_agrees_with_scipy_ckdtree_on_random_clouds():
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(3)
    for n, radius in ((1, 2.0), (17, 0.5), (50_000, 3.0)):
        pts = rng.normal(0.0, 300.0, (n, 3))
        q = rng.normal(0.0, 400.0, (5000, 3))
        d, _ = cKDTree(pts).query(q)
        assert np.abs(ObstacleSet([Points(pts, radius_mm=radius)]).signed_distance(q) - (d - radius)).max() <= 1e-9


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 300), st.integers(0, 2**31 - 1), st.floats(0.1, 30.0))
def test_segment_distance_is_exact_for_any_cloud(n, seed, radius):
    """Clouds of every size (one point included, duplicates included): segment clearance = brute force."""
    rng = np.random.default_rng(seed)
    pts = rng.normal(0.0, 100.0, (n, 3))
    pts[rng.random(n) < 0.2] = pts[0]
    obstacles = ObstacleSet([Points(pts, radius_mm=radius)])
    a = rng.normal(0.0, 150.0, (20, 3))
    b = a + rng.normal(0.0, 80.0, (20, 3))
    got = obstacles.chain_clearance(np.stack([a, b], axis=1), [0.0])
    assert np.abs(got - (brute_segment_distance(pts, a, b) - radius)).max() <= 1e-9


def test_the_default_radius_is_one_and_a_half_spacings():
    """A regular 5 mm grid: every point's nearest other is 5 mm away, so the balls are 7.5 mm."""
    g = np.arange(0.0, 200.0, 5.0)
    x, y = np.meshgrid(g, g)
    cloud = Points(np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)]))
    assert cloud.radius == pytest.approx(7.5, abs=1e-12)
    with pytest.raises(ValueError, match="radius_mm"):
        Points([[1.0, 2.0, 3.0]])


def test_voxel_downsampling_keeps_the_mean_of_each_cube():
    """Two clusters of points in two 10 mm cubes, and one alone: three points, each its cube's mean."""
    rng = np.random.default_rng(0)
    a = rng.uniform(0.5, 9.5, (40, 3))
    b = rng.uniform(20.5, 29.5, (25, 3))
    out = downsample(np.vstack([a, b, [[55.0, 55.0, 55.0]]]), 10.0)
    assert out.shape == (3, 3)
    assert np.allclose(out, [a.mean(axis=0), b.mean(axis=0), [55.0, 55.0, 55.0]])


def _cloud(n: int = 4000, seed: int = 1) -> np.ndarray:
    """Points (m) on a 2 m x 1 m wall, 1 cm noise."""
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(0, 2, n), rng.uniform(0, 1, n), rng.normal(0.0, 0.01, n)])


def test_every_format_reads_the_points_its_library_wrote(tmp_path):
    """PLY written by trimesh, PCD by pypcd4, LAS by laspy, XYZ with colour columns, NPY: the same points (m to
    mm) back; a PLY with faces is a mesh, not a cloud."""
    import laspy
    import trimesh
    from pypcd4 import PointCloud

    from snakeplan.geometry.cloud_files import is_cloud_file

    pts = _cloud()
    trimesh.PointCloud(pts).export(tmp_path / "a.ply")
    PointCloud.from_xyz_points(pts.astype(np.float32)).save(tmp_path / "a.pcd")
    np.savetxt(tmp_path / "a.xyz", np.column_stack([pts, np.full((len(pts), 3), 200)]), fmt="%.9f")
    np.save(tmp_path / "a.npy", pts)
    las = laspy.create(point_format=3, file_version="1.2")
    las.header.scales = [1e-5, 1e-5, 1e-5]
    las.header.offsets = [0.0, 0.0, 0.0]
    las.x, las.y, las.z = pts[:, 0], pts[:, 1], pts[:, 2]
    las.write(tmp_path / "a.las")
    for name, tol in (("a.ply", 1e-4), ("a.pcd", 1e-4), ("a.xyz", 1e-6), ("a.npy", 0.0), ("a.las", 1e-2)):
        assert is_cloud_file(tmp_path / name)
        got = read_cloud_file(tmp_path / name, "FILE", "m")
        assert got.shape == pts.shape and np.abs(got - 1000.0 * pts).max() <= tol, name
    trimesh.creation.box([1.0, 1.0, 1.0]).export(tmp_path / "box.ply")
    assert not is_cloud_file(tmp_path / "box.ply")


def _import(tmp_path, cloud: str, *extra: str) -> tuple[int, dict | None]:
    out = tmp_path / "scene.json"
    code = main(["scene", "import", cloud, "--units", "m", "--entrance", "1000,500,-300", "--direction", "0,0,1",
                 "--bounds", "-100,-100,-400,2100,1100,400", "-o", str(out), *extra])
    return code, json.loads(out.read_text()) if out.exists() else None


def test_scene_import_crops_and_thins_a_cloud_and_the_scene_plans(tmp_path, capsys):
    """``scene import wall.npy --crop --downsample``: the scene names the file, the crop box and the voxel; loaded
    again it holds one point per occupied 20 mm cube of the cropped points, and ``snakeplan plan`` reaches a target
    beyond the wall with as-rrt, judged valid, drawn as a picture and a page."""
    from snakeplan.scenes import Scene

    wall = _cloud(60_000)
    np.save(tmp_path / "wall.npy", wall)
    code, doc = _import(tmp_path, str(tmp_path / "wall.npy"), "--crop", "0,0,-100,1500,1000,100", "--downsample",
                        "20", "--target", "1800,500,300")
    assert code == 0, capsys.readouterr().err
    cloud = doc["obstacles"][0]
    assert cloud["type"] == "points" and cloud["file"] == "wall.npy" and cloud["downsample_mm"] == 20.0
    assert cloud["crop"] == [0.0, 0.0, -100.0, 1500.0, 1000.0, 100.0]
    scene = Scene.from_json((tmp_path / "scene.json").read_text(), base_dir=tmp_path)
    kept = 1000.0 * wall[np.all((1000.0 * wall >= [0, 0, -100]) & (1000.0 * wall <= [1500, 1000, 100]), axis=1)]
    assert len(scene.obstacles[0].points) == len(np.unique(np.floor(kept / 20.0), axis=0))
    capsys.readouterr()
    code = main(["plan", "--scene-file", str(tmp_path / "scene.json"), "--planner", "as-rrt", "--json",
                 "--plot", str(tmp_path / "plan.png"), "--html", str(tmp_path / "plan.html")])
    plan = json.loads(capsys.readouterr().out)
    assert code == 0 and plan["success"], plan.get("why")
    assert (tmp_path / "plan.png").stat().st_size > 10_000 and (tmp_path / "plan.html").stat().st_size > 100_000


@pytest.mark.parametrize("make, message", [
    (lambda p: np.save(p / "c.npy", np.zeros((0, 3))), "holds no points"),
    (lambda p: np.save(p / "c.npy", np.array([[0.0, 0.0, 0.0], [np.nan, 1.0, 1.0], [1.0, 1.0, 1.0]])),
     "not finite numbers"),
    (lambda p: np.save(p / "c.npy", np.ones((10, 2))), "expected an array of n rows x, y, z"),
    (lambda p: (p / "c.xyz").write_text("1 2\n3 4\n"), "expected at least 3 columns"),
    (lambda p: (p / "c.xyz").write_text("1 2 3\n3 4\n"), "not rows of numbers"),
    (lambda p: np.save(p / "c.npy", np.random.default_rng(0).uniform(0, 2e-3, (50, 3))), "are its units 'm'"),
    (lambda p: np.save(p / "c.npy", np.random.default_rng(0).uniform(0, 2e3, (50, 3))), "are its units 'mm'"),
])
def test_bad_clouds_get_one_line_naming_the_field_and_write_nothing(tmp_path, capsys, make, message):
    make(tmp_path)
    cloud = next(tmp_path.glob("c.*"))
    code, doc = _import(tmp_path, str(cloud), "--target", "1000,500,300")
    err = capsys.readouterr().err.strip()
    assert code == 2 and doc is None
    assert len(err.splitlines()) == 1 and message in err and ("FILE" in err or "--units" in err), err


def test_a_cloud_over_the_limits_is_refused_in_one_line(tmp_path, capsys, monkeypatch):
    """Over the file-size limit, and over the points limit unless thinned (the line says how)."""
    from snakeplan.geometry import cloud_files

    np.save(tmp_path / "c.npy", _cloud(20_000))
    monkeypatch.setattr(cloud_files, "MAX_CLOUD_POINTS", 10_000)
    code, doc = _import(tmp_path, str(tmp_path / "c.npy"), "--target", "1000,500,300")
    err = capsys.readouterr().err.strip()
    assert code == 2 and doc is None and "more than the 10000 limit" in err and "--downsample" in err
    assert _import(tmp_path, str(tmp_path / "c.npy"), "--target", "1000,500,300", "--downsample", "30")[0] == 0
    monkeypatch.setattr(cloud_files, "MAX_CLOUD_FILE_BYTES", 1000)
    (tmp_path / "scene.json").unlink()
    code, doc = _import(tmp_path, str(tmp_path / "c.npy"), "--target", "1000,500,300")
    err = capsys.readouterr().err.strip()
    assert code == 2 and doc is None and "larger than the" in err


def test_scene_file_errors_name_the_obstacle_field(tmp_path):
    np.save(tmp_path / "c.npy", _cloud(100))
    base = {"type": "points", "file": "c.npy", "units": "m"}
    cases = [({"units": "furlong"}, "obstacles[0].units"), ({"radius_mm": -1}, "obstacles[0].radius_mm"),
             ({"crop": [0, 0, 0, -1, 1, 1]}, "obstacles[0].crop"), ({"downsample_mm": 0}, "obstacles[0].downsample_mm"),
             ({"file": "nope.npy"}, "obstacles[0].file: file not found")]
    for change, message in cases:
        with pytest.raises(ValueError, match=message.replace("[", r"\[").replace("]", r"\]")):
            obstacle_from_dict({**base, **change}, "obstacles[0]", str(tmp_path))
    with pytest.raises(ValueError, match=r"obstacles\[0\]\.points"):
        obstacle_from_dict({"type": "points", "points": [[0, 0]]}, "obstacles[0]")
    inline = obstacle_from_dict({"type": "points", "points": [[0, 0, 0], [3, 4, 0]]}, "obstacles[0]")
    assert inline.radius == pytest.approx(7.5)


def test_a_scan_of_a_real_cad_mesh_is_planned_and_the_plan_holds_in_the_mesh():
    """gymnasium-robotics' kitchen base cabinets (an open STL in metres no one here wrote) on a floor, scanned at
    8 mm with 2 mm noise and holes (about 0.4 million points): as-rrt plans in the cloud to a target inside the
    cabinets, and the plan is judged valid against the exact mesh."""
    from test_inspect_any_space import gymnasium_robotics_mesh

    from snakeplan.episode import run_episode
    from snakeplan.evaluation import evaluate
    from snakeplan.planners import Problem
    from snakeplan.robots import get_robot
    from snakeplan.scenes.importing import import_scene
    from snakeplan.scenes.scan import ScanSettings, scan_scene

    exact = import_scene([str(gymnasium_robotics_mesh("cabinetbase.stl"))], "m", np.array([0.0, -1900.0, 700.0]),
                         np.array([0.0, 1.0, 0.0]), [np.array([-150.0, -300.0, 80.0])], "kitchen.json",
                         bounds=(np.array([-1500.0, -1900.0, 0.0]), np.array([1400.0, 800.0, 1800.0])),
                         primitives=[{"type": "box", "center": [0, -500, -10], "size": [3000, 3000, 20]}])
    scan = scan_scene(exact, ScanSettings(spacing_mm=8.0), seed=3)
    assert len(scan.obstacles) == 1 and len(scan.obstacles[0].points) > 300_000
    robot = get_robot("sjtu-snake-iii")
    episode = run_episode(Problem(scan, robot, time_limit_s=20.0), "as-rrt", seed=3)
    assert episode.success, episode.plan.why
    assert evaluate(exact, robot, episode.plan.path).success


def _depth_folder(folder, scene, poses, w=64, h=48, f=40.0, scale=0.0002):
    """Depth PNGs (16-bit, ``scale`` m a count) of ``scene`` from camera ``poses`` (mm, camera to scene, OpenCV
    axes), cast with the scene's own ray queries, and their camera.json (metres)."""
    from PIL import Image

    folder.mkdir()
    u, v = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
    local = np.stack([(u - w / 2) / f, (v - h / 2) / f, np.ones_like(u)], axis=-1).reshape(-1, 3)
    frames = []
    for i, T in enumerate(poses):
        dirs = local @ T[:3, :3].T
        t = scene.obstacle_set.raycast(np.broadcast_to(T[:3, 3], dirs.shape), dirs, 3000.0, 1e-6)
        z = t / np.linalg.norm(local, axis=1) / 1000.0  # along the ray (mm) -> along the camera's z (m)
        counts = np.where(np.isfinite(z), np.round(z / scale), 0).astype(np.uint16).reshape(h, w)
        Image.fromarray(counts).save(folder / f"{i}.png")
        pose = T.copy()
        pose[:3, 3] /= 1000.0
        frames.append({"depth": f"{i}.png", "pose": pose.tolist()})
    (folder / "camera.json").write_text(json.dumps({"width": w, "height": h, "fx": f, "fy": f, "cx": w / 2,
                                                    "cy": h / 2, "depth_scale": scale, "frames": frames}))


def test_depth_images_with_poses_fuse_into_a_cloud_on_the_surfaces_they_saw(tmp_path, capsys):
    """Three 16-bit depth PNGs of a plate, cast from known poses: ``scene import`` of their folder gives a cloud
    whose every point lies on the plate's surface to the PNGs' quantisation (0.2 mm counts), and the plan through
    the cloud is valid in the exact scene."""
    from snakeplan.evaluation import evaluate
    from snakeplan.geometry.primitives import Plate
    from snakeplan.robots import get_robot
    from snakeplan.scenes import Scene
    from snakeplan.scenes.scene import Entrance

    plate = Plate([0.0, 0.0, 600.0], [0.0, 0.0, 1.0], [0.0, 1.0, 0.0], (1200.0, 1200.0), 20.0)
    exact = Scene("plate", None, [-1000.0, -1000.0, -100.0], [1000.0, 1000.0, 1200.0],
                  Entrance([-400.0, 0.0, 0.0], [0.0, 0.0, 1.0]), [[900.0, 0.0, 900.0]], (plate,))
    poses = []
    for x in (-400.0, 0.0, 400.0):  # looking up (+z) from below the plate
        T = np.eye(4)
        T[:3, 3] = [x, 0.0, 0.0]
        poses.append(T)
    _depth_folder(tmp_path / "views", exact, poses)
    out = tmp_path / "scene.json"
    assert main(["scene", "import", str(tmp_path / "views"), "--units", "m", "--entrance", "-400,0,0", "--direction",
                 "0,0,1", "--bounds", "-1000,-1000,-100,1000,1000,1200", "--target", "900,0,900", "--radius", "15",
                 "-o", str(out)]) == 0, capsys.readouterr().err
    scene = Scene.from_json(out.read_text(), base_dir=tmp_path)
    pts = scene.obstacles[0].points
    assert len(pts) > 7000  # the rays that meet the plate of 3 x 64 x 48
    assert np.abs(plate.signed_distance(pts)).max() <= 0.2
    capsys.readouterr()
    assert main(["plan", "--scene-file", str(out), "--planner", "as-rrt", "--json"]) == 0
    plan = json.loads(capsys.readouterr().out)
    assert plan["success"] and evaluate(exact, get_robot("sjtu-snake-iii"), np.asarray(plan["path"])).success
    (tmp_path / "views" / "camera.json").write_text(json.dumps({"width": 64, "height": 48, "fx": 40, "fy": 40,
                                                                "cx": 32, "cy": 24, "frames": [{"depth": "0.png"}]}))
    assert main(["scene", "import", str(tmp_path / "views"), "--units", "m", "--entrance", "-400,0,0", "--direction",
                 "0,0,1", "--target", "900,0,900", "-o", str(tmp_path / "bad.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "frames[0]" in err and "pose" in err and not (tmp_path / "bad.json").exists()
