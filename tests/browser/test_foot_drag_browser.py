"""A foot's gizmo arrow dragged 60 px up in a real Chromium tab (issue 23, defect 1): the robot
lifts the foot with its knees, torso upright, and the Pose panel's status says what pinocchio
finds (reached only when the foot is on the target the gizmo sent); *Swap stance foot* is
enabled only when one foot is held.

The arrow is found on the screen by projecting the foot's world position (and a point up its
z arrow) through the tab's own camera (position, look-at, fov as the client reports them) onto
the canvas; the mouse presses there, moves up 60 px and releases, as a hand would.
"""

from __future__ import annotations

import contextlib

import numpy as np
import pinocchio as pin
import pytest
from playwright.sync_api import expect

from app.studio import Studio
from tests.browser.page_helpers import (
    RENDER_TIMEOUT_S,
    UI_TIMEOUT_S,
    click_button,
    dismiss_software_webgl_warning,
    gui_row_input,
    not_blank,
    select_option,
    wait_for,
    wait_stable,
)

DRAG_PX = 60
MOVES = 12
ON_ARROW = 0.7
"""Where along the z arrow (a fraction of the gizmo's scale) the mouse takes it: past the
rotation arcs and plane handles near the gizmo's centre, short of its tip."""


@pytest.fixture(scope="module")
def page(browser_page, studio: Studio, studio_url: str):
    browser_page.set_default_timeout(120_000)  # screenshots of a software-rendered page, busy CI
    browser_page.goto(studio_url)
    with contextlib.suppress(Exception):  # cosmetic: never fails the test
        dismiss_software_webgl_warning(browser_page)
    wait_stable(browser_page, "the studio's first render", not_blank)
    return browser_page


def pixel_of(camera, box: dict, point: np.ndarray) -> np.ndarray:
    """Page coordinates [px] of a world point through the tab's pinhole camera (vertical fov)
    onto the canvas's box."""
    eye, look = np.asarray(camera.position), np.asarray(camera.look_at)
    forward = (look - eye) / np.linalg.norm(look - eye)
    up_hint = np.asarray(camera.up_direction, dtype=float)
    right = np.cross(forward, up_hint)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    focal = 0.5 * box["height"] / np.tan(0.5 * float(camera.fov))
    d = point - eye
    x, y = focal * (d @ right) / (d @ forward), focal * (d @ up) / (d @ forward)
    return np.array([box["x"] + 0.5 * box["width"] + x, box["y"] + 0.5 * box["height"] - y])


def test_dragging_a_foot_arrow_up_lifts_it_with_the_knees(page, studio: Studio) -> None:
    robot = studio.state.robot
    assert robot is not None and studio.pose.handles is not None
    wait_for("the tab to register", lambda: studio.web.server.get_clients() or None, UI_TIMEOUT_S)
    (client,) = studio.web.server.get_clients().values()
    camera = client.camera
    q_before = studio.state.q.copy()
    data = robot.model.createData()
    foot_link = studio.pose.handles.frames["left"]
    foot_before = robot.link_placements(q_before, data)[foot_link][:3, 3]
    control = studio.pose.handles.handle("left")
    scale = float(control.scale)

    box = page.locator("canvas").first.bounding_box()
    assert box is not None
    grab = pixel_of(camera, box, foot_before + np.array([0.0, 0.0, ON_ARROW * scale]))
    page.mouse.move(*grab)
    page.mouse.down()
    for k in range(1, MOVES + 1):
        page.mouse.move(grab[0], grab[1] - DRAG_PX * k / MOVES)
    page.mouse.up()

    def lifted():
        pose = studio.state.pose
        return pose is not None and pose.origin == "drag:left" and pose.stance == "right"

    wait_for("the drag to reach the studio", lifted, UI_TIMEOUT_S)
    status = page.locator("text=Stance: right").first
    status.wait_for(state="visible", timeout=RENDER_TIMEOUT_S * 1000)
    wait_for(
        "the Pose panel's verdict",
        lambda: (
            page.get_by_text("Target reached ✓").count()
            or page.get_by_text("Closest reachable pose").count()
        ),
        UI_TIMEOUT_S,
    )
    q = studio.state.q
    placements = robot.link_placements(q, data)
    rise = placements[foot_link][2, 3] - foot_before[2]
    assert rise > 0.03, f"the foot rose {rise * 1000:.0f} mm"
    R = placements[robot.tree.root][:3, :3]
    assert np.degrees(np.arccos(np.clip(R[2, 2], -1, 1))) < 2.0, "the torso folded"
    angles = np.degrees(robot.joint_angles(q))
    for side in ("left", "right"):
        assert angles[robot.joint_names.index(f"{side}_knee")] > 10.0, f"{side} knee straight"
    # The verdict matches pinocchio: the target is where the gizmo ended.
    T_gizmo = np.eye(4)
    T_gizmo[:3, :3] = pin.Quaternion(*np.roll(np.asarray(control.wxyz), -1)).toRotationMatrix()
    T_gizmo[:3, 3] = control.position
    miss = np.linalg.norm(placements[foot_link][:3, 3] - T_gizmo[:3, 3])
    reached = page.get_by_text("Target reached ✓").count() > 0
    print(  # what the drag did, for the log (not asserted)
        f"60 px drag: foot up {rise * 1000:.0f} mm, {miss * 1000:.2f} mm from the gizmo, "
        f"knees {angles[robot.joint_names.index('left_knee')]:.0f}°/"
        f"{angles[robot.joint_names.index('right_knee')]:.0f}°, reached={reached}"
    )
    assert reached == (miss < 1e-3), f"status says reached={reached}, foot {miss * 1000:.1f} mm off"


def test_a_foot_dragged_out_of_reach_and_released_says_what_holds_it_back(
    page, studio: Studio
) -> None:
    """The same arrow taken again and pulled far up, out of the leg's reach, then released:
    the release (viser's "end" event) is the event that works out what holds the pose back
    (app.core.posing.drag), and the tab shows it: a "held back by" line naming a joint that
    pinocchio finds at its URDF bound in the studio's pose; let go, the gizmo is back on the
    foot (taken there again, the foot follows it down)."""
    robot = studio.state.robot
    assert robot is not None and studio.pose.handles is not None
    wait_for("the tab to register", lambda: studio.web.server.get_clients() or None, UI_TIMEOUT_S)
    (client,) = studio.web.server.get_clients().values()
    control = studio.pose.handles.handle("left")
    box = page.locator("canvas").first.bounding_box()
    assert box is not None
    handle_at = np.asarray(control.position, dtype=float)
    grab = pixel_of(client.camera, box, handle_at + np.array([0.0, 0.0, ON_ARROW * control.scale]))
    rise_px = min(250.0, grab[1] - box["y"] - 10.0)
    page.mouse.move(*grab)
    page.mouse.down()
    for k in range(1, MOVES + 1):
        page.mouse.move(grab[0], grab[1] - rise_px * k / MOVES)
    page.mouse.up()
    handles = studio.pose.handles

    def released():  # the "end" event arrived and its solve is done
        result = studio.pose.last_result
        idle = not handles.held and studio.pose.drags_idle
        return idle and result is not None and not result.reached and result.explained

    wait_for("the release's verdict", released, UI_TIMEOUT_S)
    said = [
        line.removeprefix("- ")
        for line in studio.pose.panel.status.content.split("  \n")
        if line.startswith("- held back by")
    ]
    assert said, studio.pose.panel.status.content
    wait_for(
        "the tab to show them",
        lambda: all(page.get_by_text(line).count() for line in said),
        UI_TIMEOUT_S,
    )
    lines = page.get_by_text("held back by").all_inner_texts()
    angles = robot.joint_angles(studio.state.q)
    at_bound = {
        joint.name
        for joint, angle in zip(robot.joints, angles, strict=True)
        if joint.kind != "continuous"
        and min(abs(angle - joint.lower), abs(angle - joint.upper)) < np.deg2rad(0.5)
    }
    named = {name for line in lines for name in at_bound if f"held back by {name} at its" in line}
    print(f"released out of reach: {lines}; at a bound: {sorted(at_bound)}")
    assert named, f"no joint at its bound named: {lines}, at a bound {sorted(at_bound)}"
    # The lines after the reasons are the pose's, not reasons: not drawn inside the list
    # (markdown took them as its last item's continuation, "CoM margin" under a bullet).
    pose_folder = page.locator(".mantine-Paper-root", has=page.get_by_text("held back by"))
    items = pose_folder.last.locator("li").all_inner_texts()
    assert items and not [item for item in items if "CoM margin" in item], items

    # let go, the gizmo is back on the foot where pinocchio places it: the tab's arrow is
    # taken there again and pulled down, and the foot comes down with it
    data = robot.model.createData()
    foot = robot.link_placements(studio.state.q, data)[handles.frames["left"]][:3, 3]
    wait_for(
        "the gizmo back on the foot",
        lambda: np.linalg.norm(np.asarray(control.position) - foot) < 1e-4 or None,
        UI_TIMEOUT_S,
    )
    q_released = studio.state.q.copy()
    grab = pixel_of(client.camera, box, foot + np.array([0.0, 0.0, ON_ARROW * control.scale]))
    page.mouse.move(*grab)
    page.mouse.down()
    for k in range(1, MOVES + 1):
        page.mouse.move(grab[0], grab[1] + 0.5 * rise_px * k / MOVES)
    page.mouse.up()
    wait_for(
        "the foot to come down",
        lambda: not np.array_equal(studio.state.q, q_released) and studio.pose.drags_idle,
        UI_TIMEOUT_S,
    )
    fall = foot[2] - robot.link_placements(studio.state.q, data)[handles.frames["left"]][2, 3]
    assert fall > 0.03, f"the foot came down {fall * 1000:.0f} mm"


def test_swap_stance_is_enabled_only_when_one_foot_is_held(page, studio: Studio) -> None:
    """With Stance both (after *Reset pose*) *Swap stance foot* had nothing to swap and a click
    did nothing, silently: it is disabled then, and enabled once a stance foot is picked, when
    a click swaps it (the Stance dropdown shows the other foot)."""
    swap = page.get_by_role("button", name="Swap stance foot", exact=True)
    stance = gui_row_input(page, "Stance", "input.mantine-Select-input")
    click_button(page, "Reset pose")
    expect(stance).to_have_value("both", timeout=UI_TIMEOUT_S * 1000)
    expect(swap).to_be_disabled(timeout=UI_TIMEOUT_S * 1000)
    select_option(page, "Stance", "left")
    expect(swap).to_be_enabled(timeout=UI_TIMEOUT_S * 1000)
    swap.click()
    expect(stance).to_have_value("right", timeout=UI_TIMEOUT_S * 1000)
    assert studio.state.pose is not None and studio.state.pose.stance == "right"
