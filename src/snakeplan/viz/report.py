"""A markdown report (headings, paragraphs, pipe tables, PNG figures) as one self-contained HTML page.

The page needs no network and no other file: figures are embedded as ``data:image/png;base64`` URIs and the
style sheet is inline. ``snakeplan bench report`` writes its HTML page through :func:`report_html`.
"""

from __future__ import annotations

import base64
import html

#: PNG files start with these 8 bytes.
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"

_STYLE = """
body { font-family: system-ui, sans-serif; max-width: 72rem; margin: 2rem auto; padding: 0 1rem; color: #222; }
h1, h2, h3 { border-bottom: 1px solid #ddd; padding-bottom: .2rem; }
table { border-collapse: collapse; margin: 1rem 0; font-size: .92rem; }
th, td { border: 1px solid #ccc; padding: .25rem .6rem; }
th { background: #f0f2f5; }
tr:nth-child(even) td { background: #fafbfc; }
img { max-width: 100%; display: block; margin: 1rem 0; }
code { background: #f3f3f3; padding: 0 .2rem; }
"""


def report_html(markdown: str, images: dict[str, bytes], title: str) -> str:
    """One HTML page of ``markdown`` (CommonMark with pipe tables); every image it references as
    ``![caption](name.png)`` must be a key of ``images`` (PNG bytes) and is embedded as a data URI.

    Raw HTML in the markdown is shown as text, not interpreted. ValueError (naming ``images[...]``) for a figure the
    markdown references but ``images`` lacks, or one that is not PNG.
    """
    from markdown_it import MarkdownIt

    md = MarkdownIt("commonmark", {"html": False}).enable("table")
    tokens = md.parse(markdown)
    for token in tokens:
        for child in token.children or ():
            if child.type != "image":
                continue
            name = child.attrGet("src") or ""
            if name not in images:
                raise ValueError(f"images[{name!r}]: the markdown shows this figure but no image of that name was "
                                 f"given (given: {', '.join(sorted(images)) or 'none'})")
            data = images[name]
            if not data.startswith(PNG_SIGNATURE):
                raise ValueError(f"images[{name!r}]: not a PNG file")
            child.attrSet("src", "data:image/png;base64," + base64.b64encode(data).decode("ascii"))
    body = md.renderer.render(tokens, md.options, {})
    return (f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n<title>{html.escape(title)}</title>\n'
            f"<style>{_STYLE}</style>\n</head>\n<body>\n{body}</body>\n</html>\n")
