"""In a real headless Chromium, on Roban S14: *Solve* in the "Gait (DIRCON)" folder with the
robot's default settings. Its robot-derived 16.9 cm steps leave no start ramp the legs can
follow, so the panel tries shorter steps in the worker and the page says, in one line, that
the default steps were shortened so the walk can start; *Walk this gait* then walks a gait
whose start reaches the gait's speed (no "jump in speed" note).

The studio opens Roban S14 without its <visual> meshes (its collision meshes drawn instead):
the same model, feet and gait, but 1.8 k triangles in the page instead of 308 k, which a
software-WebGL tab took minutes to keep drawing; S14's full meshes are drawn by
test_load_browser's upload test."""

from __future__ import annotations

import re

import pytest

from app.core.collocation.defaults import robot_gait_defaults
from app.studio import Studio
from tests.browser.page_helpers import UI_TIMEOUT_S, click_button, expand_folder, folder, wait_for
from tests.conftest import ROBAN_URDF

GAIT = "Gait (DIRCON)"
SEARCH_TIMEOUT_S = 900.0
"""Spawn the worker, build S14's NLP, solve the default and up to six more (a busy machine)."""


@pytest.fixture(scope="module")
def studio_robot(tmp_path_factory: pytest.TempPathFactory) -> str:
    """Roban S14 without its <visual> elements, its collision meshes named by absolute path."""
    text = re.sub(r"\s*<visual>.*?</visual>", "", ROBAN_URDF.read_text(), flags=re.S)
    meshes = ROBAN_URDF.parents[1] / "meshes"
    text = text.replace('filename="../meshes/', f'filename="{meshes}/')
    path = tmp_path_factory.mktemp("s14") / "robanS14_collision_only.urdf"
    path.write_text(text)
    return str(path)


def test_the_page_says_the_default_steps_were_shortened(page, studio: Studio) -> None:
    default = robot_gait_defaults(studio.state.robot).settings.step_length_m
    expand_folder(page, GAIT, "Solve")
    click_button(page, "Solve")
    gait = folder(page, GAIT)
    gait.get_by_text(f"default steps shortened from {50 * default:.1f} to", exact=False).wait_for(
        state="visible", timeout=SEARCH_TIMEOUT_S * 1000
    )
    step = studio.gait.panel.sliders["step_length_m"].value
    gait.get_by_text(f"to {50 * step:.1f} cm", exact=False).wait_for(state="visible")
    assert step < 0.6 * default
    click_button(page, "Walk this gait")
    walk = wait_for("the walk of the gait", lambda: studio.gait.walk, UI_TIMEOUT_S)
    assert not any("jump in speed" in note for note in walk.notes)
