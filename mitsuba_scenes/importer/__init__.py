"""``from_mitsuba``: import the subset of Mitsuba 3 scenes that our tracer models.

The dict or XML file is parsed with Mitsuba's own parser (``mi.parser``: defaults,
includes, references and transform chains resolved exactly as Mitsuba does), then
walked node by node. Supported: ``perspective`` and ``thinlens`` sensors (``fov`` with any
``fov_axis``, ``to_world`` a rigid matrix or ``look_at``, clip planes (a pinhole's dropped where
they clip nothing of the scene); the lens's ``aperture_radius`` and ``focus_distance``),
``orthographic`` (``to_world`` a rotation and scale, clip planes), ``hdrfilm`` with a ``box``,
``tent`` or ``gaussian`` filter (film fields that change no pixel are ignored),
``independent`` sampler, ``path`` integrator (``max_depth``, ``rr_depth``) and ``direct``
(``emitter_samples``, ``bsdf_samples``, ``shading_samples``), shapes ``sphere``,
``rectangle``, ``cube``, ``obj``, ``ply`` (with ``to_world``, ``flip_normals`` and
``face_normals``: the vertex normals Mitsuba's loader gives, read from the file or
computed where it has none, shade the mesh smooth as in Mitsuba), BSDFs ``diffuse``,
``conductor`` and ``roughconductor`` (``ggx`` or ``beckmann``, isotropic, ``material``
names or RGB ``eta``/``k``), ``dielectric``, ``thindielectric``, ``roughdielectric`` (``ggx`` or
``beckmann``, isotropic), ``plastic`` and ``roughplastic`` (constant
reflectances, named or numeric ``int_ior``/``ext_ior``, ``nonlinear``; rough: ``ggx`` or
``beckmann``, isotropic), ``twosided`` around one of those that only reflects (Mitsuba's
nests no BSDF that transmits), references by id, ``area``
emitters (on their shape or declared at the top level and referenced), ``constant``,
``envmap`` (an OpenEXR or RGBE ``filename`` read by our own checked readers, or a
``bitmap``; ``scale``, a rotation ``to_world``), ``point`` (``position`` or ``to_world``,
``intensity``), ``spot`` (``to_world`` a similarity, ``intensity``, ``cutoff_angle``,
``beam_width``, a ``checkerboard`` or ``bitmap`` ``texture``), ``directional`` (``direction``
or ``to_world``, ``irradiance``) and ``projector`` (``to_world`` a similarity, ``irradiance``
a constant or a ``checkerboard`` or ``bitmap``, ``scale``, ``fov`` with ``fov_axis`` or
``focal_length``), RGB or scalar values, and ``checkerboard`` and ``bitmap`` textures (with
``to_uv``; bitmap ``filter_type``, ``wrap_mode``, ``raw``; declared inline or at the top
level and referenced) for ``diffuse.reflectance``, a plastic's ``diffuse_reflectance`` and a
conductor's ``specular_reflectance``, with the texture coordinates of each shape (a mesh
file's own), and ``mesh_attribute`` textures (``name``, ``scale``) on meshes, the attribute
as Mitsuba's loader made it (a PLY's vertex or face properties).
Anything else is refused with one ``ValueError`` listing every unsupported item and
where it is; no partial scene is ever returned.
"""
from __future__ import annotations

from .load import MAX_XML_DEPTH, check_xml_depth, from_mitsuba
from .sensor import checked_film_size
from .values import IOR_TABLE, UnsupportedSceneError

__all__ = ["from_mitsuba", "UnsupportedSceneError", "IOR_TABLE", "check_xml_depth", "MAX_XML_DEPTH",
           "checked_film_size"]
