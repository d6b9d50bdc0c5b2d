"""Videos of the playback: which instants to film, checked settings, and the encoder (MP4 through
imageio-ffmpeg's ffmpeg, GIF through Pillow). The frames come from elsewhere (a browser tab's
renders in the studio); this module only checks and encodes them.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
from pathlib import Path
from typing import Literal

import numpy as np

from app.core.errors import StudioError

VideoFormat = Literal["mp4", "gif"]
FORMATS: tuple[VideoFormat, ...] = ("mp4", "gif")
MAX_FRAMES = 600
MIN_FPS, MAX_FPS = 1, 60
MIN_SIDE, MAX_SIDE = 16, 1920
DEFAULT_FPS = 15
DEFAULT_WIDTH = 640


class VideoError(StudioError):
    """A video request or a frame was refused (too long, too large, wrong shape)."""


@dataclasses.dataclass(frozen=True)
class VideoPlan:
    """A checked request: the instants to film (seconds of the motion), at `fps`, in a
    `width`×`height` picture (even sides: what H.264 needs)."""

    times: tuple[float, ...]
    fps: int
    width: int
    height: int
    format: VideoFormat

    @property
    def n_frames(self) -> int:
        return len(self.times)


def _even(value: float) -> int:
    return max(MIN_SIDE, round(value / 2.0) * 2)


def plan_video(
    duration_s: float,
    fps: float,
    width: float,
    aspect: float,
    video_format: str,
    max_frames: int = MAX_FRAMES,
) -> VideoPlan:
    """The frames of a video of a `duration_s` motion at `fps` (first and last instants both
    shown), `width` px wide with the tab's `aspect` (width / height). Anything out of bounds
    is refused with the bound, not clamped silently."""
    if video_format not in FORMATS:
        raise VideoError(f"video format {video_format!r}: choose one of {', '.join(FORMATS)}")
    for name, value in (
        ("duration", duration_s),
        ("fps", fps),
        ("width", width),
        ("aspect", aspect),
    ):
        if not isinstance(value, (int, float)) or not math.isfinite(value):
            raise VideoError(f"the video's {name} is {value!r}; give a finite number")
    if duration_s < 0.0:
        raise VideoError(f"the motion lasts {duration_s} s; nothing to film")
    if not MIN_FPS <= fps <= MAX_FPS or fps != int(fps):
        raise VideoError(f"fps {fps:g}: give a whole number from {MIN_FPS} to {MAX_FPS}")
    if not MIN_SIDE <= width <= MAX_SIDE:
        raise VideoError(f"width {width:g} px: give {MIN_SIDE} to {MAX_SIDE} px")
    if not 0.1 <= aspect <= 10.0:
        raise VideoError(f"the view's aspect ratio {aspect:.3g} is not a picture's")
    n_frames = math.floor(duration_s * fps + 1e-9) + 1
    if n_frames > max_frames:
        raise VideoError(
            f"{duration_s:.2f} s at {int(fps)} fps is {n_frames} frames; the limit is "
            f"{max_frames}: lower the fps (at most {int(max(1, (max_frames - 1) / max(duration_s, 1e-9)))})"
        )
    height = _even(width / aspect)
    if height > MAX_SIDE:
        raise VideoError(f"height {height} px: the limit is {MAX_SIDE} px; narrow the video")
    times = tuple(min(k / fps, duration_s) for k in range(n_frames))
    return VideoPlan(times, int(fps), _even(width), height, video_format)


class VideoWriter:
    """Frames in, one video file out. `add` takes an RGB (or RGBA, flattened on white) uint8
    image of any size and fits it to the plan's size; `close` finishes the file and returns
    it; `abort` removes what was written."""

    def __init__(self, path: Path, plan: VideoPlan) -> None:
        self.path, self.plan = Path(path), plan
        self.n_written = 0
        self._gif: list[object] = []
        self._ffmpeg: object | None = None
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if plan.format == "mp4":
            import imageio_ffmpeg

            gen = imageio_ffmpeg.write_frames(
                str(self.path),
                (plan.width, plan.height),
                fps=plan.fps,
                codec="libx264",
                pix_fmt_in="rgb24",
                pix_fmt_out="yuv420p",
                macro_block_size=2,
                ffmpeg_log_level="error",
            )
            gen.send(None)  # start ffmpeg
            self._ffmpeg = gen

    def add(self, image: np.ndarray) -> None:
        from PIL import Image

        if self.n_written >= self.plan.n_frames:
            raise VideoError(f"the video has its {self.plan.n_frames} frames already")
        array = np.asarray(image)
        if array.dtype != np.uint8 or array.ndim != 3 or array.shape[2] not in (3, 4):
            raise VideoError(
                f"a frame must be an H×W×3 (or ×4) uint8 image, not {array.dtype} {array.shape}"
            )
        if array.shape[0] < 1 or array.shape[1] < 1:
            raise VideoError("an empty frame")
        if array.shape[2] == 4:
            alpha = array[..., 3:4].astype(np.float32) / 255.0
            array = np.round(array[..., :3] * alpha + 255.0 * (1.0 - alpha)).astype(np.uint8)
        picture = Image.fromarray(np.ascontiguousarray(array), "RGB")
        if picture.size != (self.plan.width, self.plan.height):
            picture = picture.resize((self.plan.width, self.plan.height), Image.Resampling.LANCZOS)
        if self._ffmpeg is not None:
            self._ffmpeg.send(np.ascontiguousarray(np.asarray(picture)))  # type: ignore[attr-defined]
        else:
            self._gif.append(picture)
        self.n_written += 1

    def close(self) -> Path:
        """Finish the file (every planned frame must have been added)."""
        if self.n_written != self.plan.n_frames:
            self.abort()
            raise VideoError(f"{self.n_written} of {self.plan.n_frames} frames were filmed")
        if self._ffmpeg is not None:
            self._ffmpeg.close()  # type: ignore[attr-defined]
            self._ffmpeg = None
        else:
            first, *rest = self._gif
            first.save(  # type: ignore[attr-defined]
                self.path,
                save_all=True,
                append_images=rest,
                duration=round(1000 / self.plan.fps),
                loop=0,
                optimize=False,
            )
            self._gif = []
        return self.path

    def abort(self) -> None:
        if self._ffmpeg is not None:
            # ffmpeg may refuse a file with no frames; the file is removed anyway
            with contextlib.suppress(Exception):
                self._ffmpeg.close()  # type: ignore[attr-defined]
            self._ffmpeg = None
        self._gif = []
        self.path.unlink(missing_ok=True)
