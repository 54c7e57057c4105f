"""cornell_glass: refraction and caustics - a glass sphere (ior 1.5) replaces the short box.

The Cornell box of "Ray Tracing: The Rest of Your Life" with the short box replaced by
a dielectric sphere of radius 90 at (190, 90, 190), as in the book's final scene (the
book also samples the sphere as a light; our ``mixture``/``mis`` strategies sample
emitters only, which is unbiased either way). Tests exact Fresnel, the 1/eta^2
radiance scaling and caustics seen through specular chains.

Examples
--------
>>> from mitsuba_scenes import get_scene
>>> get_scene("cornell_glass", width=16, height=16).shapes[-1].material.ior
1.5
"""
from __future__ import annotations

import reference_tracer as rt

from .cornell_box import camera, ceiling_light, room, tall_box

IOR = 1.5


def build(*, width: int = 64, height: int = 64, max_depth: int = 50, rr_depth=5,
          ior: float = IOR) -> rt.Scene:
    glass = rt.Sphere((190, 90, 190), 90, rt.Dielectric(ior))
    return rt.Scene(camera=camera(width, height), shapes=[*room(), ceiling_light(), tall_box(), glass],
                    max_depth=max_depth, rr_depth=rr_depth)
