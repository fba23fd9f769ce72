"""Crawl videos: frames and sizes as asked, the arm moving, the first collision marked from its frame on."""

from __future__ import annotations

import numpy as np
import pytest
from viz_scenes import COLLISION_DEPTH_MM, HOLE_CLEARANCE_MM, TIP_LINK, corridor, straight

from snakeplan.cli import main
from snakeplan.robots import load_robot
from snakeplan.viz.animation import save_crawl_video
from snakeplan.viz.crawl import crawl_frames

imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg", reason="the video extra (imageio-ffmpeg) is not installed")
ROBOT = load_robot("sjtu-snake-iii")
SIZE = (640, 360)


def _decode(filename) -> tuple[dict, list[np.ndarray]]:
    reader = imageio_ffmpeg.read_frames(str(filename))
    meta = reader.__next__()
    w, h = meta["size"]
    frames = [np.frombuffer(f, dtype=np.uint8).reshape(h, w, 3) for f in reader]
    return meta, frames


def _red(frame: np.ndarray) -> int:
    """Pixels of the collision red (pure red, allowing for the codec's rounding)."""
    r, g, b = (frame[..., i].astype(int) for i in range(3))
    return int(np.sum((r > 200) & (g < 60) & (b < 60)))


def test_frames_follow_the_judge_and_hand_geometry():
    scene = corridor()
    frames = crawl_frames(scene, ROBOT, straight(900.0), 181)
    assert frames.failure is not None and frames.failure.kind == "collision"
    assert frames.failure.depth_mm == COLLISION_DEPTH_MM and frames.failure.link == TIP_LINK
    k = frames.failure_frame
    assert frames.depths[k] >= COLLISION_DEPTH_MM > frames.depths[k - 1]
    # with the tip at 400 mm the body is on the axis and passes the hole: its nearest wall is the hole's edge
    i = int(np.argmin(np.abs(frames.depths - 400.0)))
    assert abs(frames.depths[i] - 400.0) < 3.0
    assert np.min(frames.link_clearance[i]) == pytest.approx(HOLE_CLEARANCE_MM, abs=0.06)
    # with the tip at 690 mm, short of the wall's face, the tip link's capsule end at 690 + 27.5 mm penetrates it
    j = int(np.argmin(np.abs(frames.depths - 690.0)))
    assert frames.depths[j] == pytest.approx(690.0)
    assert frames.link_clearance[j, TIP_LINK] == pytest.approx(-(690.0 + 27.5 - 700.0), abs=0.06)
    assert frames.times is None  # an infeasible plan is not timed


def test_feasible_video_is_timed_decodes_and_shows_the_arm_moving(tmp_path):
    scene = corridor(600.0)
    frames = crawl_frames(scene, ROBOT, straight(600.0), 24)
    assert frames.report.success and frames.failure is None
    assert frames.times is not None and np.all(np.diff(frames.times) > 0)
    assert frames.depths[0] == 0.0 and frames.depths[-1] == pytest.approx(600.0)
    out = save_crawl_video(tmp_path / "crawl.mp4", frames, fps=12, size=SIZE, progress=False)
    meta, video = _decode(out)
    assert len(video) == 24 and tuple(meta["size"]) == SIZE and meta["fps"] == pytest.approx(12)
    first, last = (f.astype(int) for f in (video[0], video[-1]))
    changed = np.abs(first - last).sum(axis=2) > 60

    def body(f):  # the links, clear of everything, are green
        return (f[..., 1] > f[..., 0] + 40) & (f[..., 1] > f[..., 2] + 20)

    arrived = body(last) & ~body(first)  # where the arm is at the end and was not at the start
    assert arrived.sum() > 150
    assert changed[arrived].mean() > 0.9
    assert all(_red(f) < 20 for f in video)  # nothing collides, nothing red


def test_a_timed_video_says_the_speed_up_it_plays_its_trajectory_at():
    """The newcomer's 35.8 s crawl played in 4 s was described as "at the speed of its trajectory": the title now
    says the motion's seconds, the video's, and their ratio (frames / fps)."""
    from snakeplan.viz.animation import crawl_title

    frames = crawl_frames(corridor(600.0), ROBOT, straight(600.0), 24)
    motion = float(frames.times[-1])
    title = crawl_title(frames, "as-rrt", fps=12)
    assert f"{motion:.1f} s of motion played in 2.0 s ({motion / 2.0:.3g}x)" in title
    assert crawl_title(crawl_frames(corridor(600.0), ROBOT, straight(900.0), 8), fps=12).endswith("evenly in depth")


def test_colliding_video_marks_the_collision_frame(tmp_path):
    frames = crawl_frames(corridor(), ROBOT, straight(900.0), 40)
    out = save_crawl_video(tmp_path / "hit.mp4", frames, fps=10, size=SIZE, progress=False)
    _, video = _decode(out)
    assert len(video) == 40
    k = frames.failure_frame
    reds = [_red(f) for f in video]
    assert max(reds[:k]) < 20
    assert min(reds[k:]) > 300


def test_gif_through_the_command_line(tmp_path, capsys):
    from PIL import Image

    scene_file = tmp_path / "corridor.json"
    scene_file.write_text(__import__("json").dumps(corridor(600.0).to_dict()))
    path_file = tmp_path / "path.json"
    path_file.write_text(__import__("json").dumps({"path": straight(600.0).tolist()}))
    gif = tmp_path / "crawl.gif"
    code = main(["check", "--scene-file", str(scene_file), "--robot", "sjtu-snake-iii", "--animate", str(gif),
                 "--frames", "9", "--fps", "5", "--frame-size", "320x240", str(path_file)])
    assert code == 0
    with Image.open(gif) as im:
        assert im.n_frames == 9 and im.size == (320, 240)
        assert im.info["duration"] == 200


@pytest.mark.parametrize("args, message", [
    (["--animate", "x.avi"], "--animate: expected a .mp4 or .gif file"),
    (["--animate", "x.mp4", "--frames", "1"], "--frames: expected 2 to 5000"),
    (["--animate", "x.mp4", "--fps", "0"], "--fps: expected 0.5 to 120"),
    (["--animate", "x.mp4", "--frame-size", "641x480"], "--frame-size: expected WIDTHxHEIGHT, both even"),
    (["--animate", "x.mp4", "--frame-size", "big"], "argument --frame-size: expected WIDTHxHEIGHT"),
    (["--html", "x.txt"], "--html: expected a .html or .htm file"),
])
def test_bad_video_options_are_one_line_and_write_nothing(tmp_path, monkeypatch, capsys, args, message):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "p.json").write_text('{"path": [[0, 0, 0], [1, 0, 0]]}')
    assert main(["check", *args, "p.json"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"snakeplan: error: {message}") and err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.json"]


def test_show_animate_needs_a_path(tmp_path, capsys):
    assert main(["show", "--out", str(tmp_path / "s.png"), "--animate", str(tmp_path / "a.mp4")]) == 2
    assert "--animate: needs --path" in capsys.readouterr().err


def test_show_path_writes_the_page(tmp_path, capsys):
    scene_file, path_file = tmp_path / "corridor.json", tmp_path / "path.json"
    scene_file.write_text(__import__("json").dumps(corridor().to_dict()))
    path_file.write_text(__import__("json").dumps({"path": straight(900.0).tolist()}))
    page = tmp_path / "crawl.html"
    assert main(["show", "--scene-file", str(scene_file), "--robot", "sjtu-snake-iii", "--path", str(path_file),
                 "--out", str(tmp_path / "s.png"), "--html", str(page)]) == 0
    data = page.read_text().split('id="snakeplan-data">', 1)[1].split("</script>", 1)[0]
    doc = __import__("json").loads(data.replace("<\\/", "</"))
    assert doc["failure"]["kind"] == "collision" and doc["failure"]["depth"] == COLLISION_DEPTH_MM
    assert len(doc["joints"]) == len(doc["depths"]) and len(doc["joints"][0]) == 13
    # the deepest a link gets: its axis through the middle of the 20 mm wall, 10 mm + the radius 27.5 mm deep
    assert doc["closest"]["clearance"] == pytest.approx(-37.5, abs=0.06)
    assert doc["closest"]["clearance"] == pytest.approx(float(np.min(doc["clearance"])), abs=0.01)


def test_a_scene_without_obstacles_has_no_closest_approach():
    import json

    from snakeplan.scenes import Scene
    from snakeplan.viz.page import crawl_page

    c = corridor()
    empty = Scene("empty", 0, c.bounds_min, c.bounds_max, c.entrance, c.targets, ())
    page = crawl_page(crawl_frames(empty, ROBOT, straight(600.0), 5))
    doc = json.loads(page.split('id="snakeplan-data">', 1)[1].split("</script>", 1)[0].replace("<\\/", "</"))
    assert doc["closest"] is None and doc["failure"] is None and doc["glb"] == ""
    assert doc["clearance"][0] == [None] * 12  # nothing to be near: no number, not infinity
