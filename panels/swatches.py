"""Colour swatches in checkbox labels: a small coloured square before the label's text, and the
ticked box filled in the same colour, so that a toggle shows the colour of what it draws.

viser's checkbox has no colour of its own. Its page gives each checkbox input the handle's id
and its label `for=` that id; one stylesheet (a GUI HTML element) draws the swatches on them.
viser exposes that id only privately: read by app.web.viser_internals.gui_input_id, and checked
by a browser test (tests/browser/test_compare_browser.py) that sees the swatches in the page.
"""

from __future__ import annotations

import viser

from app.web.viser_internals import gui_input_id


def input_id(handle: viser.GuiCheckboxHandle) -> str:
    """The id of the checkbox's input element in the page."""
    return gui_input_id(handle)


def swatch_css(colours: dict[str, tuple[int, int, int]]) -> str:
    """A stylesheet: input id -> its colour (RGB 0–255)."""
    rules = []
    for uid, (r, g, b) in colours.items():
        rgb = f"rgb({int(r)}, {int(g)}, {int(b)})"
        rules.append(
            f'label[for="{uid}"]::before {{ content: ""; display: inline-block; width: 0.85em; '
            f"height: 0.85em; margin-right: 0.35em; border-radius: 2px; vertical-align: -0.1em; "
            f"background-color: {rgb}; }}"
        )
        rules.append(f'[id="{uid}"]:checked {{ background-color: {rgb}; border-color: {rgb}; }}')
    return "<style>" + "\n".join(rules) + "</style>"


def add_swatches(
    gui: viser.GuiApi, boxes: dict[str, viser.GuiCheckboxHandle], colours: dict[str, tuple]
) -> viser.GuiHtmlHandle:
    """Draw each box's colour (name -> RGB) in its label; the stylesheet's own row is empty."""
    return gui.add_html(
        swatch_css({input_id(box): colours[name] for name, box in boxes.items() if name in colours})
    )
