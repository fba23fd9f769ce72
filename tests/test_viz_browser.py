"""The interactive page and the report page in a real headless Chromium: no JavaScript errors, a drawn scene
with its colours, and a depth slider that moves the body. CI installs Debian's chromium (.ci/run); elsewhere
the test skips when no Chromium is installed, and fails instead under CI."""

from __future__ import annotations

import io
import json

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from _browser import near  # noqa: E402
from viz_scenes import corridor, straight  # noqa: E402

from snakeplan.robots import load_robot  # noqa: E402
from snakeplan.viz.crawl import crawl_frames  # noqa: E402
from snakeplan.viz.page import OBSTACLE_EDGE_HEX, PATH_HEX, TARGET_HEX, save_crawl_page  # noqa: E402
from snakeplan.viz.report import report_html  # noqa: E402

READY = "window.snakeplan && window.snakeplan.ready"


def test_crawl_page_draws_the_scene_and_the_slider_moves_the_body(tmp_path, browser):
    frames = crawl_frames(corridor(), load_robot("sjtu-snake-iii"), straight(900.0), 61)
    page = save_crawl_page(tmp_path / "crawl.html", frames, "hand-made")
    browser.events.clear()
    browser.open(page, READY)
    assert browser.evaluate("window.snakeplan.frame") == 60  # the page opens at the end of the crawl
    browser.evaluate("document.getElementById('panel').style.visibility = 'hidden'")  # the 3-D view alone
    before = browser.screenshot()
    assert before.std() > 10 and len(np.unique(before.reshape(-1, 3), axis=0)) > 50  # not blank
    assert near(before, PATH_HEX, 6) > 50  # the tip path (unlit, drawn on top)
    assert near(before, TARGET_HEX, 6) > 20  # the target
    assert near(before, OBSTACLE_EDGE_HEX, 24) > 200  # the obstacles' outlines
    assert near(before, "#ff0000", 6) > 20  # the first collision's marker: the path collides
    browser.evaluate("document.getElementById('panel').style.visibility = 'visible'")
    box = json.loads(browser.evaluate("JSON.stringify(document.getElementById('depth').getBoundingClientRect())"))
    browser.click(box["x"] + 3, box["y"] + box["height"] / 2)  # the slider's left end: insertion 0
    assert browser.evaluate("window.snakeplan.frame") <= 1
    assert "collision" not in browser.evaluate("document.getElementById('readout').textContent")
    browser.evaluate("document.getElementById('panel').style.visibility = 'hidden'")
    after = browser.screenshot()
    changed = np.abs(before.astype(int) - after.astype(int)).max(axis=2) > 40
    assert changed.sum() > 2000  # the body moved out of the corridor
    assert near(after, "#ff0000", 6) < 5  # before the collision, no collision marker
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
    assert near(shot, "#ff00ff", 10) > 100  # the figure is drawn
    assert browser.errors() == []
    assert [url.split(":", 1)[0] for url in browser.requests()] == ["file", "data"]  # the figure is inside the page

