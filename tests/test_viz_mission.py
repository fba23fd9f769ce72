"""Inspection-mission pictures: the record sees the map the mission ends with; the video decodes as asked."""

from __future__ import annotations

import numpy as np
import pytest
from _browser import near

from snakeplan.planners import Problem, get_planner
from snakeplan.robots import load_robot
from snakeplan.scenes import make_scene
from snakeplan.viz.mission import MissionRecord, save_mission_page, save_mission_video
from snakeplan.world.mission import InspectionSettings

imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg", reason="the video extra (imageio-ffmpeg) is not installed")


@pytest.fixture(scope="module")
def mission():
    """A short random mission round station seed 0 and the map after each of its measurements."""
    scene = make_scene("station", 0)
    record = MissionRecord()
    result = get_planner("random").fly(Problem(scene, load_robot("hsr-10"), inspection=InspectionSettings(budget_s=10.0)),
                                       0, on_measure=record)
    return scene, result, record


def test_record_is_the_missions_map(mission):
    scene, result, record = mission
    assert record.times == pytest.approx(result.times.tolist())
    np.testing.assert_array_equal(record.means[-1], result.final_map.mean)
    np.testing.assert_array_equal(record.variances[-1], np.diag(result.final_map.cov))
    assert np.sum(record.variances[-1]) == pytest.approx(result.trace[-1])  # the trace is the variances' sum
    assert np.all(np.diff([np.sum(v) for v in record.variances]) <= 1e-6)  # measuring never adds uncertainty


def test_mission_video_shows_the_map_filling_in(tmp_path, mission):
    scene, result, record = mission
    out = save_mission_video(tmp_path / "m.mp4", scene, result, record, 8, 4.0, (480, 272), "t", progress=False)
    reader = imageio_ffmpeg.read_frames(str(out))
    meta = reader.__next__()
    frames = [np.frombuffer(f, dtype=np.uint8).reshape(272, 480, 3) for f in reader]
    assert len(frames) == 8 and tuple(meta["size"]) == (480, 272)
    assert np.abs(frames[0].astype(int) - frames[-1].astype(int)).max(axis=2).astype(bool).sum() > 500


def test_mission_page_colours_the_station_by_the_map(tmp_path, mission, browser):
    scene, result, record = mission
    page = save_mission_page(tmp_path / "mission.html", scene, result, record, "station")
    browser.events.clear()
    browser.open(page, "window.snakeplan && window.snakeplan.ready")
    browser.evaluate("document.getElementById('panel').style.visibility = 'hidden'")
    end = browser.screenshot()
    assert end.std() > 10 and near(end, "#d62728", 6) > 30  # the station drawn, the flight over it
    browser.evaluate("window.snakeplan.setFrame(0)")
    start = browser.screenshot()
    assert (np.abs(end.astype(int) - start.astype(int)).max(axis=2) > 30).sum() > 500  # the map changed
    browser.evaluate("document.querySelector('input[value=variance]').click()")
    assert (np.abs(browser.screenshot().astype(int) - start.astype(int)).max(axis=2) > 30).sum() > 500
    assert browser.errors() == []


def test_plan_station_writes_plot_video_and_page(tmp_path, monkeypatch, capsys):
    from PIL import Image

    import snakeplan.world.mission as missions
    from snakeplan.cli import main

    monkeypatch.setattr(missions, "default_settings", lambda scene, robot=None: InspectionSettings(budget_s=10.0))
    png, mp4, page = tmp_path / "maps.png", tmp_path / "flight.mp4", tmp_path / "flight.html"
    assert main(["plan", "--scene", "station", "--planner", "random", "--plot", str(png), "--animate", str(mp4),
                 "--frames", "6", "--frame-size", "480x272", "--html", str(page)]) == 0
    err = capsys.readouterr().err
    assert all(f"wrote {f}" in err for f in (png, mp4, page))
    with Image.open(png) as im:
        assert im.size[0] > 1000
    assert sum(1 for _ in imageio_ffmpeg.read_frames(str(mp4))) - 1 == 6  # the first item is the metadata
    assert 'id="snakeplan-data"' in page.read_text()
