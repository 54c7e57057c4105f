"""Translate a :class:`reference_tracer.Scene` to Mitsuba 3: a dict and an XML file.

The mapping follows the conventions of docs/conventions.md exactly; anything without an exact
Mitsuba equivalent raises ``ValueError`` naming the object, never an approximation:

=====================================  ==================================================
ours                                   Mitsuba 3
=====================================  ==================================================
``Camera(vfov, lookfrom, ...)``        ``perspective``, ``fov=vfov``, ``fov_axis='y'``,
                                       ``to_world = look_at(lookfrom, lookat, vup)``;
                                       ``hdrfilm`` with the camera's rfilter; ``independent``
``aperture_radius > 0``                ``thinlens``, ``aperture_radius``, ``focus_distance``
``projection='orthographic'``          ``orthographic``, ``to_world = look_at . scale(w/2,
                                       h/2 * aspect, 1)`` for a view of w x h
``near_clip``, ``far_clip``            the same (where 0 / inf: a near plane below any
                                       feature, a far one beyond all)
``Quad(Q, u, v)``                      ``rectangle``, to_world columns (u/2, v/2, n, centre)
``Box(pmin, pmax)``                    ``cube``, to_world = M . T(centre) . S(half size)
``Sphere(c, r)``                       ``sphere`` with world centre and radius (textured:
                                       ``to_world`` with the transform's rotation, which
                                       sets Mitsuba's texture coordinates)
``Triangle``, ``Mesh``                 a mesh (``mi.Mesh`` in the dict, PLY in the XML),
                                       world-space vertices; a Mesh's vertex normals (world
                                       space) where it has them (smooth), else none (flat)
``flip_normals``                       ``flip_normals`` (baked into the winding of meshes
                                       and the axes of quads, but for textured ones, whose
                                       coordinates follow the unflipped order)
``Checkerboard``, ``Bitmap``           ``checkerboard``, ``bitmap`` (the file, or an array
                                       as an ``mi.Bitmap`` / an EXR beside the XML), with
                                       ``to_uv``; a mesh's ``uv`` as its texture coordinates
``MeshAttribute``                      ``mesh_attribute`` (``name``, ``scale``); the mesh's
                                       attributes its textures read go along
                                       (``Mesh.add_attribute`` in the dict, float PLY
                                       properties Mitsuba's ``ply`` groups back in the XML)
``Lambertian``                         ``diffuse``
``Metal(fuzz=0)``                      ``conductor``: ``material='none'``, or RGB ``eta`` and ``k``
``RoughConductor``                     ``roughconductor``: its ``distribution``, ``material='none'``
                                       or RGB ``eta`` and ``k``
``Dielectric(ior)``                    ``dielectric``, ``int_ior=ior``, ``ext_ior=1.0``
``ThinDielectric(ior)``                ``thindielectric``, ``int_ior=ior``, ``ext_ior=1.0``
``RoughDielectric(ior, alpha)``        ``roughdielectric``, ``int_ior=ior``, ``ext_ior=1.0``, its
                                       ``distribution`` and ``alpha``
``Plastic``                            ``plastic``: its reflectances (RGB), ``int_ior``,
                                       ``ext_ior`` and ``nonlinear``
``RoughPlastic``                       ``roughplastic``: as ``plastic``, with its
                                       ``distribution`` and ``alpha``
``two_sided=True``                     ``twosided`` wrapper
``DiffuseLight(L, albedo=a)``          ``area`` emitter + ``diffuse`` BSDF of albedo a (black if None)
``background``                         ``constant`` emitter (none when black)
``EnvMap(image, scale, to_world)``     ``envmap`` with its texels (a ``bitmap`` in the dict, an
                                       OpenEXR file beside the XML), ``scale``, ``to_world``
``PointLight(position, intensity)``    ``point``, ``position``, ``intensity``
``SpotLight(position, direction, ...)`` ``spot``, ``to_world = look_at(position, position +
                                       direction, up)``, ``intensity``, ``cutoff_angle``, ``beam_width``,
                                       a ``texture`` (checkerboard or bitmap) where it has one
``ProjectorLight(position, direction,`` ``projector``, ``to_world = look_at(position, position +
``irradiance, ...)``                   direction, up)``, ``irradiance`` (RGB or a texture),
                                       ``scale``, ``fov`` = x_fov with ``fov_axis`` x
``DirectionalLight(direction, E)``     ``directional``, ``direction``, ``irradiance``
``max_depth``, ``rr_depth``            ``path`` integrator; ``rr_depth=None`` -> larger than max_depth
``direct=Direct(ne, nb)``              ``direct`` integrator, ``emitter_samples=ne``, ``bsdf_samples=nb``
=====================================  ==================================================
"""
from __future__ import annotations

from .dictionary import to_mitsuba
from .ply import write_ply
from .records import NO_RR_DEPTH, look_at_matrix, mitsuba_rr_depth, scene_extent
from .xml_file import to_xml

__all__ = ["to_mitsuba", "to_xml", "write_ply", "look_at_matrix", "mitsuba_rr_depth", "scene_extent", "NO_RR_DEPTH"]
