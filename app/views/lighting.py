"""The scene's lighting: fast by default, detailed on request.

viser's default lighting is an HDR environment map plus lights that cast shadows. On a
computer without a graphics card (the browser renders WebGL in software), that costs about a
second per frame, and playback with ghosts then leaves the page unable to take a click for a
minute: measured in headless Chromium with SwiftShader, servo_biped standing, 1280×800,
~1 s per frame with the environment map, ~0.1 s without it and without shadows. The fast
lighting is a hemisphere light (sky above, grey ground) and viser's default lights without
shadows: every part keeps its colour and shading, and the page keeps answering. *Detailed
lighting* (Display folder) puts the environment map and the shadows back for a graphics card.
"""

from __future__ import annotations

from typing import Final

import viser

HDRI: Final = "city"
"""viser's default environment map."""
SKY_RGB = (255, 255, 255)
GROUND_RGB = (120, 120, 120)
HEMISPHERE_INTENSITY = 1.5


class Lighting:
    """Owns the scene's lights; `set_detailed(False)` is the fast lighting."""

    def __init__(self, scene: viser.SceneApi, detailed: bool = False) -> None:
        self._scene = scene
        self._hemisphere: viser.HemisphereLightHandle | None = None
        self.detailed = not detailed  # so that the first call applies
        self.set_detailed(detailed)

    def set_detailed(self, detailed: bool) -> None:
        if detailed == self.detailed:
            return
        self.detailed = detailed
        scene = self._scene
        scene.configure_environment_map(hdri=HDRI if detailed else None)
        scene.configure_default_lights(enabled=True, cast_shadow=detailed)
        if detailed and self._hemisphere is not None:
            self._hemisphere.remove()
            self._hemisphere = None
        elif not detailed and self._hemisphere is None:
            self._hemisphere = scene.add_light_hemisphere(
                "/lighting/hemisphere",
                sky_color=SKY_RGB,
                ground_color=GROUND_RGB,
                intensity=HEMISPHERE_INTENSITY,
            )
