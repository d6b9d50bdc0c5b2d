"""*Export replay* in a real studio: the replay holds what the studio shows (the ghosts and
traces that are on, a title card), and nothing of it reaches the live tabs."""

from __future__ import annotations

import pytest

from app.core.replay.folder import RECORDING
from app.core.replay.viser_file import read_viser_file
from tests.studio.conftest import compute_torques, wait_for_signal


def _export(studio):
    return wait_for_signal(
        studio.presenting.share.exported,
        lambda: setattr(studio.presenting.share.panel.export, "value", True),
    )


def test_export_records_what_is_shown_and_nothing_reaches_the_live_tabs(studio, tmp_path):
    studio.motions.panel.motion.value = "com_shift"
    studio.motions.panel.generate.value = True
    compute_torques(studio)
    ghosts = studio.servo_rooms.ghosts.panel.ghosts
    ghosts["planned"].value = True
    ghosts["with"].value = True  # by default the plan and the command only
    ghosts["without"].value = False
    studio.playback.panel.traces.value = False
    studio.presenting.share.panel.zip.value = True
    live = studio.web.server.get_scene_serializer()  # everything the live tabs are sent from now

    result = _export(studio)

    assert result is not None
    folder = result.folder.path
    assert folder.parent == tmp_path / "data" / "replays"
    assert folder.with_name(folder.name + ".zip").is_file()
    assert str(folder) in studio.presenting.share.panel.status.content
    recording = read_viser_file((folder / RECORDING).read_bytes())
    names = recording.node_names()
    for shown in ("planned", "command", "with"):
        assert any(n.startswith(f"/ghosts/{shown}/") for n in names), shown
    assert not any(n.startswith("/ghosts/without") for n in names)
    assert not any(n.startswith("/traces") for n in names)
    title = next(m["props"]["text"] for _, m in recording.messages if m.get("name") == "/title")
    assert "com_shift" in title
    # the full card and the legend are drawn by the page (app.core.replay.legend)
    viewer = (folder / "viewer.html").read_text(encoding="utf-8")
    assert 'id="replay-legend"' in viewer and "quick estimate, compensated" in viewer
    trajectory = studio.state.trajectory
    assert recording.duration_s == pytest.approx(trajectory.duration, abs=0.04)

    sent_live = read_viser_file(live.serialize())
    assert "/title" not in sent_live.node_names()
    assert not any(n.startswith("/ghosts/planned/") for n in sent_live.node_names())


def test_export_without_a_motion_says_so_and_changes_nothing(studio):
    assert studio.state.trajectory is None
    assert _export(studio) is None
    assert "generate or build a motion first" in studio.presenting.share.panel.status.content
    assert not (studio.config.data_dir / "replays").exists()
    assert studio.state.robot is not None
