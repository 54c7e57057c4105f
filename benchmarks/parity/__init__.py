"""AOV parity: do both renderers see the same first hit at every pixel centre?

Before any statistics, :func:`run_parity` casts one ray through the centre of each pixel
in our tracer and in Mitsuba (``sensor.sample_ray`` and ``scene.ray_intersect``) and
compares five first-hit AOVs with float tolerances: hit distance, shading normal,
diffuse albedo, emitted radiance (the background on a miss) and which shape was hit.
Deterministic and fast, it catches translation errors - a camera (fov, fov axis, look-at,
film size), a winding or ``flip_normals``, one-sidedness, a material or an emitter - that a
statistical gate would only see as a biased image, and it says where.

Our AOVs come from the tracer's probe (:func:`reference_tracer.probe.first_hit_aovs`);
:mod:`~benchmarks.parity.mitsuba` computes Mitsuba's, :mod:`~benchmarks.parity.ours` the
bounding boxes that match the two renderers' shapes; :mod:`~benchmarks.parity.compare`
compares the AOVs and names the culprits, :mod:`~benchmarks.parity.maps` writes the
mismatch maps (PNG and EXR).

Examples
--------
>>> from mitsuba_scenes import get_scene
>>> from benchmarks.parity import run_parity
>>> run_parity(get_scene("cornell_box", width=8, height=8)).passed
True
"""
from __future__ import annotations

from reference_tracer.probe import first_hit_aovs

from .compare import AOVS, ParityReport, compare_aovs
from .maps import write_mismatch_maps
from .mitsuba import mitsuba_aovs, mitsuba_scene_for
from .ours import shape_bounds

__all__ = ["AOVS", "ParityReport", "compare_aovs", "run_parity", "write_mismatch_maps", "mitsuba_aovs",
           "mitsuba_scene_for", "shape_bounds"]


def run_parity(scene, *, mitsuba=None, name: str = "scene", params=None) -> ParityReport:
    """Compare the first-hit AOVs of ``scene`` in our tracer and in Mitsuba.

    Parameters
    ----------
    scene : reference_tracer.Scene
        Our scene.
    mitsuba : dict or str or os.PathLike or None
        What Mitsuba loads: a scene dict, an XML file (``mi.load_file``, the file the
        scene was imported from) or None for ``to_mitsuba(scene)``.
    name : str
        The scene's name in messages and file names.
    params : dict or None
        ``$name`` values of an XML file.

    Returns
    -------
    ParityReport
    """
    mscene = mitsuba_scene_for(scene, mitsuba, params=params)
    return compare_aovs(scene, first_hit_aovs(scene), mitsuba_aovs(mscene, scene), name=name,
                        theirs_at=lambda off: mitsuba_aovs(mscene, scene, offset=off))
