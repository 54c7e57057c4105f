"""mitsuba_scenes: the scene suite and its translation to and from Mitsuba 3.

Examples
--------
>>> from mitsuba_scenes import list_scenes, get_scene, to_mitsuba, render_mitsuba
>>> "cornell_box" in list_scenes()
True
>>> scene = get_scene("cornell_box", width=32, height=32)
>>> scene.camera.width
32
>>> mean, variance, seconds = render_mitsuba(scene, spp=4, seed=0)  # doctest: +SKIP
"""
from .importer import from_mitsuba
from .render import MitsubaRender, render_mitsuba
from .scene_files import register_scene_file
from .suite import SUITE, describe_scene, get_scene, known_scenes, list_scenes
from .translate import to_mitsuba, to_xml
from .variants import select_variant, versions

__all__ = ["list_scenes", "known_scenes", "register_scene_file", "get_scene", "describe_scene", "SUITE", "to_mitsuba", "to_xml",
           "from_mitsuba", "render_mitsuba", "MitsubaRender", "select_variant", "versions"]
