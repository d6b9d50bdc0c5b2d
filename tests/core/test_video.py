"""The video encoder wrapper: the planned instants, the bounds, and files that decode back to
the frames given (imageio reads them independently of the writer)."""

from __future__ import annotations

import imageio.v3 as iio
import numpy as np
import pytest
from PIL import Image

from app.core.replay.video import MAX_FRAMES, VideoError, VideoWriter, plan_video


def _frames(n: int, width: int, height: int) -> list[np.ndarray]:
    """Frames that each hold one big, differently placed and coloured square."""
    frames = []
    for k in range(n):
        image = np.full((height, width, 3), 255, np.uint8)
        x = (k * 7) % (width - 16)
        image[4:20, x : x + 16] = (k * 40 % 256, 80, 200 - k * 20 % 200)
        frames.append(image)
    return frames


def test_plan_films_first_and_last_instants_at_the_frame_rate():
    plan = plan_video(2.0, 10, 320, 16 / 9, "mp4")
    assert plan.n_frames == 21
    assert plan.times[0] == 0.0 and plan.times[-1] == pytest.approx(2.0)
    assert np.allclose(np.diff(plan.times), 0.1)
    assert plan.width == 320 and plan.height % 2 == 0
    assert abs(plan.width / plan.height - 16 / 9) < 0.02


@pytest.mark.parametrize(
    ("duration", "fps", "width", "aspect", "fmt", "says"),
    [
        (60.0, 30, 640, 1.5, "mp4", "limit is 600"),
        (1.0, 0, 640, 1.5, "mp4", "fps"),
        (1.0, 61, 640, 1.5, "mp4", "fps"),
        (1.0, 12.5, 640, 1.5, "mp4", "fps"),
        (1.0, 10, 4, 1.5, "mp4", "width"),
        (1.0, 10, 5000, 1.5, "mp4", "width"),
        (1.0, 10, 640, float("nan"), "mp4", "finite"),
        (float("inf"), 10, 640, 1.5, "mp4", "finite"),
        (-1.0, 10, 640, 1.5, "mp4", "nothing to film"),
        (1.0, 10, 640, 1.5, "avi", "choose one of"),
        (1.0, 10, 1900, 0.5, "mp4", "height"),
    ],
)
def test_plan_refuses_what_is_out_of_bounds(duration, fps, width, aspect, fmt, says):
    with pytest.raises(VideoError, match=says):
        plan_video(duration, fps, width, aspect, fmt)


def test_the_frame_limit_is_the_last_accepted_length():
    assert plan_video((MAX_FRAMES - 1) / 10, 10, 64, 1.0, "gif").n_frames == MAX_FRAMES
    with pytest.raises(VideoError):
        plan_video(MAX_FRAMES / 10, 10, 64, 1.0, "gif")


def test_mp4_decodes_to_the_frames_given(tmp_path):
    plan = plan_video(1.0, 12, 96, 96 / 64, "mp4")
    frames = _frames(plan.n_frames, plan.width, plan.height)
    writer = VideoWriter(tmp_path / "clip.mp4", plan)
    for frame in frames:
        writer.add(frame)
    path = writer.close()
    decoded = iio.imread(path, plugin="pyav") if _has_pyav() else _read_ffmpeg(path)
    assert len(decoded) == plan.n_frames
    assert decoded[0].shape == (plan.height, plan.width, 3)
    # Lossy, but each decoded frame is nearest to the frame it came from.
    for k, image in enumerate(decoded):
        errors = [np.abs(image.astype(int) - f.astype(int)).mean() for f in frames]
        assert int(np.argmin(errors)) == k


def test_gif_keeps_frames_and_timing(tmp_path):
    plan = plan_video(0.5, 10, 64, 2.0, "gif")
    frames = _frames(plan.n_frames, plan.width, plan.height)
    writer = VideoWriter(tmp_path / "clip.gif", plan)
    for frame in frames:
        writer.add(frame)
    path = writer.close()
    with Image.open(path) as gif:
        assert getattr(gif, "n_frames", 1) == plan.n_frames
        assert gif.size == (plan.width, plan.height)
        assert gif.info["duration"] == 100
    decoded = iio.imread(path, index=None)
    assert np.abs(decoded[-1][..., :3].astype(int) - frames[-1]).mean() < 8


def test_frames_of_another_size_are_fitted_and_rgba_flattened(tmp_path):
    plan = plan_video(0.1, 10, 64, 2.0, "gif")
    writer = VideoWriter(tmp_path / "fit.gif", plan)
    transparent = np.zeros((100, 200, 4), np.uint8)  # nothing drawn: the page's white
    writer.add(transparent)
    writer.add(np.zeros((10, 10, 3), np.uint8))
    with Image.open(writer.close()) as gif:
        assert gif.size == (64, 32)
        assert np.asarray(gif.convert("RGB"))[5, 5].tolist() == [255, 255, 255]


@pytest.mark.parametrize(
    "bad",
    [
        np.zeros((8, 8), np.uint8),
        np.zeros((8, 8, 2), np.uint8),
        np.zeros((8, 8, 3), np.float32),
        np.zeros((0, 8, 3), np.uint8),
    ],
)
def test_bad_frames_are_refused_and_a_short_video_is_removed(tmp_path, bad):
    plan = plan_video(0.1, 10, 64, 1.0, "mp4")
    writer = VideoWriter(tmp_path / "bad.mp4", plan)
    with pytest.raises(VideoError):
        writer.add(bad)
    writer.add(np.zeros((64, 64, 3), np.uint8))
    with pytest.raises(VideoError, match="1 of 2 frames"):
        writer.close()
    assert not (tmp_path / "bad.mp4").exists()


def test_too_many_frames_are_refused(tmp_path):
    plan = plan_video(0.0, 10, 64, 1.0, "gif")
    writer = VideoWriter(tmp_path / "one.gif", plan)
    writer.add(np.zeros((64, 64, 3), np.uint8))
    with pytest.raises(VideoError, match="already"):
        writer.add(np.zeros((64, 64, 3), np.uint8))
    writer.abort()
    assert not (tmp_path / "one.gif").exists()


def _has_pyav() -> bool:
    try:
        import av  # noqa: F401
    except ImportError:
        return False
    return True


def _read_ffmpeg(path) -> list[np.ndarray]:
    """Decode with imageio-ffmpeg's reader (a separate ffmpeg process from the writer's)."""
    import imageio_ffmpeg

    reader = imageio_ffmpeg.read_frames(str(path))
    meta = reader.__next__()
    width, height = meta["size"]
    return [np.frombuffer(raw, np.uint8).reshape(height, width, 3).copy() for raw in reader]
