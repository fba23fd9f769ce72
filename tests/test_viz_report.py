"""The bench report's HTML page: markdown tables and headings as HTML, figures embedded, nothing fetched."""

from __future__ import annotations

import base64
import io
from html.parser import HTMLParser

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pytest  # noqa: E402
from PIL import Image  # noqa: E402

from snakeplan.viz.report import report_html  # noqa: E402


class _Collect(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.tags: list[tuple[str, dict]] = []
        self.cells: list[str] = []
        self._in_cell = False

    def handle_starttag(self, tag, attrs):
        self.tags.append((tag, dict(attrs)))
        self._in_cell = tag in ("td", "th")

    def handle_endtag(self, tag):
        self._in_cell = False

    def handle_data(self, data):
        if self._in_cell:
            self.cells.append(data.strip())


def _png(color: str) -> bytes:
    fig, ax = plt.subplots(figsize=(2, 1.5))
    ax.plot([0, 1], [0, 1], color=color)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return buf.getvalue()


def test_tables_headings_and_embedded_figures():
    images = {"fig7.png": _png("red"), "curve.png": _png("blue")}
    md = ("# Table 2\n\nSome text with <script>alert(1)</script>.\n\n| planner | success |\n|---|---:|\n"
          "| rrt-star | 0.9 |\n| sac-her | 1.0 |\n\n![Fig. 7](fig7.png)\n\n## Curves\n\n![curve](curve.png)\n")
    page = report_html(md, images, "bench <report>")
    p = _Collect()
    p.feed(page)
    tags = [t for t, _ in p.tags]
    assert tags.count("h1") == 1 and tags.count("h2") == 1 and tags.count("table") == 1
    assert tags.count("script") == 0  # raw HTML is text
    assert p.cells == ["planner", "success", "rrt-star", "0.9", "sac-her", "1.0"]
    srcs = [a["src"] for t, a in p.tags if t == "img"]
    assert len(srcs) == 2 and all(s.startswith("data:image/png;base64,") for s in srcs)
    decoded = [base64.b64decode(s.split(",", 1)[1]) for s in srcs]
    assert decoded == [images["fig7.png"], images["curve.png"]]
    assert Image.open(io.BytesIO(decoded[0])).size == Image.open(io.BytesIO(images["fig7.png"])).size
    assert "http" not in page.replace("http-equiv", "")  # nothing fetched from a network
    assert "<title>bench &lt;report&gt;</title>" in page


def test_missing_or_bad_figure_names_images():
    with pytest.raises(ValueError, match=r"^images\['nope.png'\]"):
        report_html("![x](nope.png)", {}, "t")
    with pytest.raises(ValueError, match=r"^images\['a.png'\]: not a PNG"):
        report_html("![x](a.png)", {"a.png": b"GIF89a"}, "t")
