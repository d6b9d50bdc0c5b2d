"""The replay page's title card and ghost legend, drawn by the page itself (HTML), not in 3D.

A label in the 3D scene hangs above the robot and grows upwards with every line: with the
legend under the title it ran off the top of the page, and a 3D label has one colour, so the
legend could only name colours. The card is a box fixed in the page's top-left corner (held
inside the viewport; it scrolls when the window is very small), each ghost with a swatch of its
own colour. It is added to the replay's copy of viser's page (`with_overlay`).
"""

from __future__ import annotations

import html
from collections.abc import Sequence

ELEMENT_ID = "replay-legend"
STYLE = (
    "position: fixed; top: 12px; left: 12px; z-index: 1000; box-sizing: border-box; "
    "max-width: min(420px, calc(100vw - 24px)); max-height: calc(100vh - 110px); overflow: auto; "
    "padding: 8px 12px; border-radius: 6px; background: rgba(255, 255, 255, 0.92); "
    "color: #222; font: 13px/1.45 system-ui, sans-serif; box-shadow: 0 1px 4px rgba(0,0,0,0.25);"
)
SWATCH = (
    "display: inline-block; width: 0.9em; height: 0.9em; margin-right: 0.45em; "
    "border-radius: 2px; vertical-align: -0.1em; background-color: rgb({r}, {g}, {b});"
)


def legend_html(title: str, entries: Sequence[tuple[tuple[int, int, int], str]]) -> str:
    """The card: the title's lines (the first in bold), then one line per ghost (colour RGB
    0–255, text) with its swatch."""
    lines = [line for line in title.splitlines() if line.strip()]
    parts = [f'<div id="{ELEMENT_ID}" style="{STYLE}">']
    for i, line in enumerate(lines):
        text = html.escape(line)
        parts.append(f"<div><b>{text}</b></div>" if i == 0 else f"<div>{text}</div>")
    if entries:
        parts.append('<div style="margin-top: 4px">')
        for (r, g, b), text in entries:
            swatch = SWATCH.format(r=int(r), g=int(g), b=int(b))
            parts.append(
                f'<div class="replay-ghost"><span class="replay-swatch" style="{swatch}"></span>'
                f"{html.escape(text)}</div>"
            )
        parts.append("</div>")
    parts.append("</div>")
    return "".join(parts)


def with_overlay(page: str, overlay: str) -> str:
    """viser's page with `overlay` as the first thing in its body (viser draws into #root)."""
    marker = "<body>"
    at = page.find(marker)
    if at < 0 or not overlay:
        return page
    at += len(marker)
    return page[:at] + "\n" + overlay + page[at:]
