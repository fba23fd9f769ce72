"""The interactive page and the report page in a real headless Chromium: no JavaScript errors, a drawn scene
with its colours, and a depth slider that moves the body. CI installs Debian's chromium (.ci/run); elsewhere
the test skips when no Chromium is installed, and fails instead under CI."""

from __future__ import annotations

import io
import json
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from _browser import Browser, chromium_path  # noqa: E402
from viz_scenes import corridor, straight  # noqa: E402

from snakeplan.robots import load_robot  # noqa: E402
from snakeplan.viz.crawl import crawl_frames  # noqa: E402
from snakeplan.viz.page import OBSTACLE_EDGE_HEX, PATH_HEX, TARGET_HEX, save_crawl_page  # noqa: E402
from snakeplan.viz.report import report_html  # noqa: E402

READY = "window.snakeplan && window.snakeplan.ready"


@pytest.fixture(scope="module")
def browser():
    if chromium_path() is None:
        why = "Chromium is not installed (apt-get install -y chromium; CI's .ci/run installs it)"
        if os.environ.get("CI") == "true":
            pytest.fail(why)
        pytest.skip(why)
    b = Browser(1000, 700)
    yield b
    b.close()


def _rgb(hex_color: str) -> np.ndarray:
    return np.array([int(hex_color[i:i + 2], 16) for i in (1, 3, 5)])


def _near(img: np.ndarray, hex_color: str, tol: int) -> int:
    return int(np.sum(np.abs(img.astype(int) - _rgb(hex_color)).max(axis=2) <= tol))


def test_crawl_page_draws_the_scene_and_the_slider_moves_the_body(tmp_path, browser):
    frames = crawl_frames(corridor(), load_robot("sjtu-snake-iii"), straight(900.0), 61)
    page = save_crawl_page(tmp_path / "crawl.html", frames, "hand-made")
    browser.events.clear()
    browser.open(page, READY)
    assert browser.evaluate("window.snakeplan.frame") == 60  # the page opens at the end of the crawl
    browser.evaluate("document.getElementById('panel').style.visibility = 'hidden'")  # the 3-D view alone
    before = browser.screenshot()
    assert before.std() > 10 and len(np.unique(before.reshape(-1, 3), axis=0)) > 50  # not blank
    assert _near(before, PATH_HEX, 6) > 50  # the tip path (unlit, drawn on top)
    assert _near(before, TARGET_HEX, 6) > 20  # the target
    assert _near(before, OBSTACLE_EDGE_HEX, 24) > 200  # the obstacles' outlines
    assert _near(before, "#ff0000", 6) > 20  # the first collision's marker: the path collides
    browser.evaluate("document.getElementById('panel').style.visibility = 'visible'")
    box = json.loads(browser.evaluate("JSON.stringify(document.getElementById('depth').getBoundingClientRect())"))
    browser.click(box["x"] + 3, box["y"] + box["height"] / 2)  # the slider's left end: insertion 0
    assert browser.evaluate("window.snakeplan.frame") <= 1
    assert "collision" not in browser.evaluate("document.getElementById('readout').textContent")
    browser.evaluate("document.getElementById('panel').style.visibility = 'hidden'")
    after = browser.screenshot()
    changed = np.abs(before.astype(int) - after.astype(int)).max(axis=2) > 40
    assert changed.sum() > 2000  # the body moved out of the corridor
    assert _near(after, "#ff0000", 6) < 5  # before the collision, no collision marker
    assert browser.errors() == []
    assert all(url.split(":", 1)[0] in ("file", "data", "blob") for url in browser.requests())  # offline


def test_report_page_shows_its_table_and_figure(tmp_path, browser):
    fig, ax = plt.subplots(figsize=(4, 3))
    ax.plot([0, 1], [0, 1], color="#ff00ff", lw=6)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    page = tmp_path / "report.html"
    page.write_text(report_html("# Bench\n\n| planner | success |\n|---|---|\n| as-rrt | 1.0 |\n\n![Fig](fig.png)\n",
                                {"fig.png": buf.getvalue()}, "bench report"))
    browser.events.clear()
    browser.open(page, "document.readyState === 'complete' && document.images[0].complete")
    assert browser.evaluate("document.images[0].naturalWidth") == 400
    assert browser.evaluate("document.querySelectorAll('td').length") == 2
    shot = browser.screenshot()
    assert _near(shot, "#ff00ff", 10) > 100  # the figure is drawn
    assert browser.errors() == []
    assert [url.split(":", 1)[0] for url in browser.requests()] == ["file", "data"]  # the figure is inside the page


def test_mission_page_colours_the_station_by_the_map(tmp_path, browser):
    from snakeplan.episode import run_mission
    from snakeplan.planners.inspection import InspectionProblem
    from snakeplan.scenes import make_scene
    from snakeplan.viz.mission import MissionRecord, save_mission_page

    scene = make_scene("station", 0)
    record = MissionRecord()
    result = run_mission(InspectionProblem(scene, load_robot("hsr-10"), budget_s=12.0), "random", 0,
                         on_measure=record).result
    page = save_mission_page(tmp_path / "mission.html", scene, result, record, "station")
    browser.events.clear()
    browser.open(page, READY)
    browser.evaluate("document.getElementById('panel').style.visibility = 'hidden'")
    end = browser.screenshot()
    assert end.std() > 10 and _near(end, "#d62728", 6) > 30  # the station drawn, the flight over it
    browser.evaluate("window.snakeplan.setFrame(0)")
    start = browser.screenshot()
    assert (np.abs(end.astype(int) - start.astype(int)).max(axis=2) > 30).sum() > 500  # the map changed
    browser.evaluate("document.querySelector('input[value=variance]').click()")
    assert (np.abs(browser.screenshot().astype(int) - start.astype(int)).max(axis=2) > 30).sum() > 500
    assert browser.errors() == []
