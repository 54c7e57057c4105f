"""mitsuba_scenes: the scene suite and its translation to and from Mitsuba 3.

Examples
--------
>>> from mitsuba_scenes import list_scenes, get_scene
>>> "cornell_box" in list_scenes()
True
>>> get_scene("cornell_box", width=32, height=32).camera.width
32
"""
from .suite import get_scene, list_scenes

__all__ = ["list_scenes", "get_scene"]
