"""cornell_box: the Cornell box of "Ray Tracing: The Rest of Your Life".

Tests diffuse interreflection with a single quad light: the seed's reference scene.
555-unit room without a front wall, walls are one-sided Lambertian quads facing inward;
green wall at x=555, red at x=0; a downward-facing light (radiance 15) under the
ceiling; a tall box rotated 15 degrees and a short box rotated -18 degrees.
"""
from __future__ import annotations

import reference_tracer as rt

RED = (0.65, 0.05, 0.05)
WHITE = (0.73, 0.73, 0.73)
GREEN = (0.12, 0.45, 0.15)
LIGHT_RADIANCE = 15.0


def camera(width: int, height: int) -> rt.Camera:
    return rt.Camera(lookfrom=(278, 278, -800), lookat=(278, 278, 0), vup=(0, 1, 0),
                     vfov=40.0, width=width, height=height)


def room(*, white=rt.Lambertian(WHITE), red=rt.Lambertian(RED), green=rt.Lambertian(GREEN)):
    """The five walls, every normal pointing into the room."""
    return [
        rt.Quad((555, 0, 0), (0, 0, 555), (0, 555, 0), green),    # x=555, normal -x
        rt.Quad((0, 0, 0), (0, 555, 0), (0, 0, 555), red),        # x=0, normal +x
        rt.Quad((0, 0, 0), (0, 0, 555), (555, 0, 0), white),      # floor, normal +y
        rt.Quad((0, 555, 0), (555, 0, 0), (0, 0, 555), white),    # ceiling, normal -y
        rt.Quad((0, 0, 555), (0, 555, 0), (555, 0, 0), white),    # back wall, normal -z
    ]


def ceiling_light(*, x=(213, 343), z=(227, 332), y=554, radiance=LIGHT_RADIANCE) -> rt.Quad:
    """A quad light facing down (normal -y) at height ``y``."""
    return rt.Quad((x[0], y, z[0]), (x[1] - x[0], 0, 0), (0, 0, z[1] - z[0]), rt.DiffuseLight(radiance))


def tall_box(material=rt.Lambertian(WHITE)) -> rt.Box:
    return rt.Box((0, 0, 0), (165, 330, 165), material).rotate_y(15).translate((265, 0, 295))


def short_box(material=rt.Lambertian(WHITE)) -> rt.Box:
    return rt.Box((0, 0, 0), (165, 165, 165), material).rotate_y(-18).translate((130, 0, 65))


def build(*, width: int = 64, height: int = 64, max_depth: int = 50, rr_depth=5) -> rt.Scene:
    return rt.Scene(camera=camera(width, height),
                    shapes=[*room(), ceiling_light(), tall_box(), short_box()],
                    max_depth=max_depth, rr_depth=rr_depth)
