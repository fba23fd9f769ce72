"""Static figures: the fine curvature profile agrees with the judge's and with a circle's 1/R; --plot writes."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image
from viz_scenes import corridor, straight

from snakeplan.cli import main
from snakeplan.evaluation import curvature_profile
from snakeplan.viz.figures import fine_curvature


def test_fine_curvature_of_a_circle_and_at_the_judges_points():
    R, h = 400.0, 177.5
    t = np.linspace(0.0, 1.5 * np.pi, 2000)
    arc = np.column_stack([R * np.cos(t), R * np.sin(t), np.zeros_like(t)])
    s, k = fine_curvature(arc, h)
    assert np.diff(s) == pytest.approx(5.0)
    assert k == pytest.approx(1.0 / R, rel=1e-3)  # chord-sampled circle: exact up to the polyline's own chords
    wiggle = np.column_stack([np.linspace(0, 1500, 400), 80 * np.sin(np.linspace(0, 9, 400)), np.zeros(400)])
    s_judge, k_judge = curvature_profile(wiggle, h)
    s_fine, k_fine = fine_curvature(wiggle, h, resolution=h / 5)
    for sj, kj in zip(s_judge[:-1], k_judge[:-1], strict=True):  # the judge's last point takes a remainder step
        i = int(np.argmin(np.abs(s_fine - sj)))
        assert s_fine[i] == pytest.approx(sj) and k_fine[i] == pytest.approx(kj, rel=1e-6)


def test_check_plot_writes_a_picture_of_a_collision(tmp_path, capsys):
    scene_file, path_file, png = tmp_path / "s.json", tmp_path / "p.json", tmp_path / "hit.png"
    scene_file.write_text(json.dumps(corridor().to_dict()))
    path_file.write_text(json.dumps({"path": straight(900.0).tolist()}))
    assert main(["check", "--scene-file", str(scene_file), "--robot", "sjtu-snake-iii", "--plot", str(png),
                 str(path_file)]) == 1
    with Image.open(png) as im:
        rgb = np.asarray(im.convert("RGB")).astype(int)
    assert im.size[0] > 1500
    red = (rgb[..., 0] > 230) & (rgb[..., 1] < 30) & (rgb[..., 2] < 30)
    assert red.sum() > 50  # the first collision's cross


@pytest.mark.parametrize("family", ["fuel-tank", "oil-tank", "concentric-pipe", "station"])
def test_obstacle_meshes_lie_on_the_exact_surfaces(family):
    from snakeplan.scenes import make_scene
    from snakeplan.geometry.tessellation import obstacle_mesh

    for o in make_scene(family, 2).obstacles:
        m = obstacle_mesh(o)
        assert m.is_watertight
        assert np.abs(o.signed_distance(m.vertices)).max() < 1e-6  # every vertex on the obstacle's surface


def test_the_collision_mark_is_where_the_link_meets_the_wall_and_a_side_view_shows_depth(tmp_path):
    """viz_scenes' corridor: the tip link's capsule first meets the wall's face (x = 700) on the axis, at 675 mm of
    insertion; the mark was the link's middle, 114 mm back. A path under an obstacle shows its depth in the side
    view, which looks along the scene's shorter horizontal extent."""
    import matplotlib

    from snakeplan.geometry.distance import ObstacleSet
    from snakeplan.viz.figures import plan_figure
    from snakeplan.scenes import make_scene
    from snakeplan.viz.scene_plot import contact_point, flat_view, side_view

    scene = corridor()
    tip, back = np.array([675.0, 0.0, 0.0]), np.array([675.0 - 177.5, 0.0, 0.0])
    assert np.allclose(contact_point(ObstacleSet(scene.obstacles), back, tip), [700.0, 0.0, 0.0], atol=0.3)
    # 1050 x 600 x 600 mm: the flat view looks along y (the first shortest), the side view across it along z
    assert (flat_view(scene)[2], side_view(scene)[2]) == ("view along y", "view along z")
    assert side_view(make_scene("fuel-tank", 0))[2] == "side view along y"  # under the top view: x against z
    fig = plan_figure(scene, straight(600.0), title="t")
    try:
        names = [ax.get_title() for ax in fig.axes]
    finally:
        matplotlib.pyplot.close(fig)
    assert names == ["3-D view", "view along y", "view along z"]


def test_a_scene_of_ten_thousand_obstacles_is_drawn_as_a_few_collections(tmp_path, capsys):
    """show on a scene file at the obstacle limit took 28.7 s, one matplotlib artist per obstacle per view: the
    obstacles are now one collection of faces (and one of outlines) per view, every face still drawn."""
    import matplotlib
    from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection

    from snakeplan.scenes.scene import MAX_OBSTACLES
    from snakeplan.viz.figures import plan_figure

    k = np.arange(MAX_OBSTACLES - 2)
    boxes = [{"type": "box", "center": [float(100 + 8 * (i % 100)), float(-400 + 8 * (i // 100)), 300.0],
              "size": [4, 4, 4]} for i in k]
    plates = [{"type": "plate", "center": [500.0, 0.0, -300.0 + 100 * j], "normal": [0, 0, 1], "up": [0, 1, 0],
               "size": [400, 400], "thickness": 5, "hole": {"offset": [0, 0], "semi_axes": [50, 50]}} for j in (0, 1)]
    scene = {"schema": "snakeplan.scene/1", "name": "many", "bounds": {"min": [0, -500, -500], "max": [1000, 500, 500]},
             "entrance": {"position": [10, 0, 0], "direction": [1, 0, 0]}, "targets": [[900, 0, 0]],
             "obstacles": boxes + plates}
    f = tmp_path / "many.json"
    f.write_text(json.dumps(scene))
    assert main(["show", "--scene-file", str(f), "--out", str(tmp_path / "many.png")]) == 0
    assert capsys.readouterr().out == f"wrote {tmp_path / 'many.png'}\n"
    from snakeplan.scenes import Scene

    fig = plan_figure(Scene.from_json(f.read_text()), title="t")
    try:
        fig.canvas.draw()  # a 3-D collection projects its faces when drawn
        for ax in fig.axes:
            ours = [c for c in ax.collections if c.get_gid() == "obstacles"]
            polys = [c for c in ours if isinstance(c, Poly3DCollection)]
            lines = [c for c in ours if isinstance(c, Line3DCollection)]
            assert len(ours) == 2
            assert len(polys) == 1 and len(polys[0].get_paths()) == 6 * len(boxes) + len(plates)
            assert len(lines) == 1 and len(lines[0].get_segments()) == 2 * len(plates)  # edge and hole
    finally:
        matplotlib.pyplot.close(fig)


def test_obstacles_of_three_and_four_corners_scale_the_axes_to_themselves_alone(monkeypatch):
    """The demo failed one CI run in two ("Axis limits cannot be NaN or Inf"): matplotlib pads a ragged list of
    polygons (a sphere's triangles beside a box's quads) with uninitialised memory and scales the axes to it.
    Memory poisoned with 1e300 makes that certain; the obstacles' own corners must set the limits."""
    import matplotlib.pyplot as plt

    from snakeplan.geometry.primitives import Box, Sphere
    from snakeplan.viz.scene_plot import draw_obstacles

    empty = np.empty

    def poisoned(*args, **kwargs):
        out = empty(*args, **kwargs)
        if out.dtype.kind == "f":
            out.fill(1e300)
        return out

    monkeypatch.setattr(np, "empty", poisoned)
    fig = plt.figure()
    try:
        ax = fig.add_subplot(projection="3d")
        draw_obstacles(ax, [Box(np.array([0.0, 0.0, 0.0]), np.array([100.0, 100.0, 100.0])),
                            Sphere(np.array([0.0, 0.0, 300.0]), 50.0)])
        lo, hi = ax.get_zlim()
        assert -200.0 < lo < -50.0 and 350.0 < hi < 500.0
    finally:
        plt.close(fig)
