"""cornell_mirror: specular reflection - the tall box is an aluminium mirror (Metal, fuzz 0).

The book's aluminium variant of the Cornell box: the tall box is a perfect mirror of
albedo (0.8, 0.85, 0.88) (Mitsuba ``conductor``, ``material='none'``). Tests delta
reflection, light reaching diffuse surfaces only through the mirror, and that the
mirror reflects the room without a left/right flip.

Examples
--------
>>> from mitsuba_scenes import get_scene
>>> get_scene("cornell_mirror", width=16, height=16).shapes[6].material.fuzz
0.0
"""
from __future__ import annotations

import reference_tracer as rt

from .cornell_box import camera, ceiling_light, room, short_box, tall_box

ALUMINIUM = (0.8, 0.85, 0.88)


def build(*, width: int = 64, height: int = 64, max_depth: int = 50, rr_depth=5) -> rt.Scene:
    return rt.Scene(camera=camera(width, height),
                    shapes=[*room(), ceiling_light(), tall_box(rt.Metal(ALUMINIUM, fuzz=0.0)), short_box()],
                    max_depth=max_depth, rr_depth=rr_depth)
