"""The self-test's own scenes, each built to expose a bug that no suite scene shows.

``cornell_box_rr3``: ``cornell_box`` with Russian roulette from depth 3
(``roulette_no_reweight``). ``hanging_lamp``: the ceiling light lowered to ``y = 450`` with a
diffuser plate 2 units under it (``two_sided_light``, ``shadow_epsilon_leak``).
``glass_lamp``: the ceiling light embedded in a glass slab, so every path that reaches it ends
inside glass (``glass_no_eta_scale``). A Mitsuba reference is cached for each like any scene's.

Examples
--------
>>> from benchmarks.selftest.scenes import selftest_scene
>>> selftest_scene("glass_lamp", width=8).camera.width
8
>>> selftest_scene("cornell_box_rr3", width=8).rr_depth
3
"""
from __future__ import annotations

import reference_tracer as rt
from mitsuba_scenes import get_scene, list_scenes
from mitsuba_scenes.scenes.cornell_box import WHITE, camera, ceiling_light, room, short_box, tall_box

from ..gate.suite import gate_scene

__all__ = ["SELFTEST_SCENES", "selftest_scene", "is_suite_scene"]

#: height of the lowered light of ``hanging_lamp``; the diffuser plate hangs 2 units under it.
HANGING_LIGHT_Y = 450.0
PLATE_GAP = 2.0
#: the glass slab of ``glass_lamp`` and the height of the light inside it.
GLASS_SLAB = ((203.0, 535.0, 217.0), (353.0, 552.0, 342.0))
GLASS_LIGHT_Y = 545.0
GLASS_IOR = 1.5


def _cornell_box_rr3(width: int, height: int) -> rt.Scene:
    return get_scene("cornell_box", width=width, height=height, rr_depth=3)


def _hanging_lamp(width: int, height: int) -> rt.Scene:
    x, z = (213.0, 343.0), (227.0, 332.0)  # the cornell_box light's extent
    w, d = x[1] - x[0], z[1] - z[0]
    plate = rt.Quad((x[0] + w / 4, HANGING_LIGHT_Y - PLATE_GAP, z[0] + d / 4), (w / 2, 0, 0), (0, 0, d / 2),
                    rt.Lambertian(WHITE))  # normal u x v = -y: faces the room, like the light
    return rt.Scene(camera=camera(width, height),
                    shapes=[*room(), ceiling_light(x=x, z=z, y=HANGING_LIGHT_Y), plate, tall_box(), short_box()],
                    max_depth=50)


def _glass_lamp(width: int, height: int) -> rt.Scene:
    slab = rt.Box(GLASS_SLAB[0], GLASS_SLAB[1], rt.Dielectric(GLASS_IOR))
    return rt.Scene(camera=camera(width, height),
                    shapes=[*room(), ceiling_light(y=GLASS_LIGHT_Y), slab, tall_box(), short_box()],
                    max_depth=50)


#: self-test scene name -> builder(width, height).
SELFTEST_SCENES = {
    "cornell_box_rr3": _cornell_box_rr3,
    "hanging_lamp": _hanging_lamp,
    "glass_lamp": _glass_lamp,
}


def is_suite_scene(name: str) -> bool:
    return name in list_scenes()


def selftest_scene(name: str, *, width: int, height: int | None = None) -> rt.Scene:
    """Scene ``name`` at ``width`` x ``height`` (default square): a suite scene as the gate
    builds it (:func:`benchmarks.gate.gate_scene`) or one of :data:`SELFTEST_SCENES`."""
    height = width if height is None else height
    if name in SELFTEST_SCENES:
        return SELFTEST_SCENES[name](width, height)
    if is_suite_scene(name):
        return gate_scene(name, width=width, height=height)
    raise ValueError(f"unknown self-test scene {name!r}")
