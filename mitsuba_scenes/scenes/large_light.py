"""large_light: where light sampling gains least - a light covering most of the ceiling.

The Cornell box with the ceiling light enlarged to x, z in [30, 525] (495 x 495, 18x the
area of ``cornell_box``'s light) and its radiance lowered to keep the emitted power
(15 * 130 * 105 / 495^2 = 0.8356). With a near-ceiling-sized light, cosine sampling
already finds it often and light sampling helps least; grazing light directions and
large solid angles stress the light pdf.

Examples
--------
>>> from mitsuba_scenes import get_scene
>>> round(get_scene("large_light", width=16, height=16).shapes[5].material.radiance[0], 4)
0.8356
"""
from __future__ import annotations

import reference_tracer as rt

from .cornell_box import LIGHT_RADIANCE, camera, ceiling_light, room, short_box, tall_box

EXTENT = (30.0, 525.0)
RADIANCE = LIGHT_RADIANCE * 130.0 * 105.0 / (EXTENT[1] - EXTENT[0]) ** 2


def build(*, width: int = 64, height: int = 64, max_depth: int = 50, rr_depth=5) -> rt.Scene:
    light = ceiling_light(x=EXTENT, z=EXTENT, radiance=RADIANCE)
    return rt.Scene(camera=camera(width, height), shapes=[*room(), light, tall_box(), short_box()],
                    max_depth=max_depth, rr_depth=rr_depth)
