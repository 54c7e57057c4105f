"""small_light: where uniform sampling fails - the Cornell box lit by a light 1/25 the area.

The Cornell box with the ceiling light shrunk to 1/5 of its width and depth (26 x 21,
same centre) and its radiance raised 25 times (375), so the emitted power is that of
``cornell_box``. Directions that hit the light become rare: uniform and cosine
sampling get noisy, light sampling stays good.

Examples
--------
>>> from mitsuba_scenes import get_scene
>>> get_scene("small_light", width=16, height=16).shapes[5].material.radiance
(375.0, 375.0, 375.0)
"""
from __future__ import annotations

import reference_tracer as rt

from .cornell_box import LIGHT_RADIANCE, camera, ceiling_light, room, short_box, tall_box

SHRINK = 5   # per side: 1/25 of the area, 25x the radiance


def build(*, width: int = 64, height: int = 64, max_depth: int = 50, rr_depth=5) -> rt.Scene:
    cx, cz, w, d = 278.0, 279.5, 130.0 / SHRINK, 105.0 / SHRINK
    light = ceiling_light(x=(cx - w / 2, cx + w / 2), z=(cz - d / 2, cz + d / 2),
                          radiance=LIGHT_RADIANCE * SHRINK**2)
    return rt.Scene(camera=camera(width, height), shapes=[*room(), light, tall_box(), short_box()],
                    max_depth=max_depth, rr_depth=rr_depth)
