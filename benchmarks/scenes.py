"""The harness's scenes by name (suite scenes and ``--scene PATH`` files): a scene at a size,
and what a record says of it."""
from __future__ import annotations

from mitsuba_scenes import get_scene
from mitsuba_scenes.scene_files import scene_file


def scene_at(name: str, width: int, height: int):
    """Scene ``name`` (suite or registered file) at ``width`` x ``height``: a suite scene's camera
    resized, a scene file built at that size (an XML file's field of view follows its ``fov_axis``).

    >>> scene_at("cornell_box", 16, 12).camera.height
    12
    """
    if scene_file(name) is not None:
        return get_scene(name, width=int(width), height=int(height))
    return get_scene(name).with_camera_size(int(width), int(height))


def scene_info(name: str, scene) -> dict:
    """What a record says of its scene: content hash and, for a scene file, its path and parameters.

    >>> info = scene_info("furnace", get_scene("furnace", width=4, height=4))
    >>> len(info["scene_hash"]), info["scene_source"]
    (16, None)
    """
    entry = scene_file(name)
    return {"scene_hash": scene.content_hash()[:16],
            "scene_source": None if entry is None else entry.path,
            "scene_params": None if entry is None or not entry.params else dict(entry.params)}
