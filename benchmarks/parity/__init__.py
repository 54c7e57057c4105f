"""AOV parity: do both renderers see the same first hit at every pixel centre?

:func:`run_parity` casts one ray through each pixel centre in our tracer
(:func:`reference_tracer.probe.first_hit_aovs`) and in Mitsuba (:mod:`.mitsuba`) and compares
hit distance, shading normal, diffuse albedo, emitted radiance and the shape hit
(:mod:`.compare`, which also draws the mismatch maps): deterministic, it names a translation
error (camera, winding, material, emitter) that a statistical gate would only see as a biased image.

>>> from mitsuba_scenes import get_scene
>>> run_parity(get_scene("cornell_box", width=8, height=8)).passed
True
"""
from __future__ import annotations

from reference_tracer.probe import first_hit_aovs

from .compare import ParityReport, compare_aovs, write_mismatch_maps
from .mitsuba import mitsuba_aovs, mitsuba_scene_for

__all__ = ["ParityReport", "run_parity", "write_mismatch_maps"]


def run_parity(scene, *, mitsuba=None, name: str = "scene", params=None, film_size=None) -> ParityReport:
    """Compare the first-hit AOVs of ``scene`` in our tracer and in Mitsuba.

    Parameters
    ----------
    scene : reference_tracer.Scene
    mitsuba : dict or str or os.PathLike or None
        What Mitsuba loads: a scene dict, the XML file the scene was imported from, or
        None for ``to_mitsuba(scene)``.
    name : str
        The scene's name in messages and file names.
    params : dict or None
        ``$name`` values of an XML file.
    film_size : (int, int) or None
        ``(width, height)`` replacing the films of an XML file (``scene`` must have been
        imported at that size: ``from_mitsuba(path, film_size=...)``).

    Returns
    -------
    ParityReport
    """
    mscene = mitsuba_scene_for(scene, mitsuba, params=params, film_size=film_size)
    return compare_aovs(scene, first_hit_aovs(scene), mitsuba_aovs(mscene, scene), name=name,
                        theirs_at=lambda off: mitsuba_aovs(mscene, scene, offset=off))
