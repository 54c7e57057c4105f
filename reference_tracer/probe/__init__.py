"""Probes of the C++ core: ray queries, first-hit AOVs and the sampling routines, one batch at a time.

This package is the public door to what the tracer computes *inside* a render, for the
code that checks it (the harness's chi-square tests, AOV parity, stress cases and speed
benchmarks, and the tests). Nothing here renders an image: :func:`reference_tracer.render`
does. The compiled extension loads on first use, as for ``render``. The package exports the
public names of its modules: :mod:`~reference_tracer.probe.camera` (the camera's rays),
:mod:`~reference_tracer.probe.first_hit` (first-hit AOVs), :mod:`~reference_tracer.probe.sampling`
(the sampling routines) and :mod:`~reference_tracer.probe.layout` (the core's layout), and
:func:`core_scene` (:mod:`reference_tracer.render`'s).

Ray queries
    :func:`core_scene` compiles a :class:`~reference_tracer.Scene` (BVH built) and returns
    the core's scene object, whose batch queries take C-contiguous float64 arrays of
    origins and directions, shape (N, 3):

    - ``intersect(origins, directions, brute_force=False, threads=1, batch=True,
      wavefront=False, preliminary=False)``: dict of ``t`` (inf on a miss), ``prim``
      (primitive id, -1 on a miss; :func:`primitive_shapes` maps it to a shape), ``point``
      and front ``normal`` (not with ``preliminary``; ``shading_normal`` too where a mesh
      has vertex normals; ``uv``, Mitsuba's texture coordinates, and ``reflectance``, the
      material's reflectance there, where a material has a texture), ``seconds``, ``packet_rays``, ``chunk``, ``chunk_offset``;
    - ``occluded(origins, directions, t_max, wavefront=False)``: (N,) uint8;
    - ``sample_lights(refs, u, width=1)``: light sampling from points ``refs`` with
      uniforms ``u`` (N, 3): dict ``wi``, ``pdf``, ``pdf_all``, ``dist``, ``valid`` and the
      radiance fields; ``width`` points at a time, one of ``LANE_WIDTHS`` (1: the scalar
      integrator's sampler, more: the packs of the wavefront one; every width must give
      width 1's samples bit for bit);
    - ``light_pdf(refs, dirs)``: density of light sampling (every emitter and the background);
    - ``shape_hits(origins, directions, t_max, width=1)``: each sphere's and quad's own test
      on every ray (dict ``hit``, ``t``, the spheres' re-projected ``point`` and ``normal``)
      and ``triangle_hits(origins, directions, width=1)``: the nearest watertight hit among
      the triangles, one at a time or (``width=4``) in blocks of four (dict ``t``,
      ``index``): testing seams, run at each width of ``LANE_WIDTHS`` (every width must
      give width 1's results bit for bit, ``docs/core.md``);
    - ``packet_order(origins, directions)``: how ``intersect`` gathers rays into packets;
    - properties ``primitive_count``, ``emitter_count``, ``bvh_nodes``, ``bvh_depth``,
      ``bvh_blocks``, ``bvh_float_blocks``, ``bvh_bytes``, ``build_seconds``.

    :func:`camera_rays` gives the camera's rays through film points, :func:`first_hit_aovs`
    the first-hit AOVs of every pixel (what AOV parity compares with Mitsuba's).

Sampling routines
    :func:`warp_sample`, :func:`warp_pdf`, :func:`bsdf_sample`, :func:`bsdf_eval_pdf` and
    :func:`rough_plastic_table` run the core's own inline routines (``sampling/warp.h``,
    the material dispatch of ``materials/material.h``) once per row of an array
    (``reference_tracer/cpp/sampling_probe.cpp``).

Layout of the core
    :func:`child_visit_order` and the constants ``PACK_WIDTH`` (rays per pack of the
    batched queries: 8 in AVX-512 builds, else 4), ``PACKET_RAYS`` (rays per packet of
    coherent rays), ``RAY_CHUNK`` (rays a thread of ``intersect`` orders into packets at a
    time), ``CACHED_TREE_BYTES`` (trees above it are traversed without prefetching) and
    ``LANE_WIDTHS`` (the widths, in lanes of doubles, that the core's routines over a lane
    type are compiled for, 1 being the scalar one: ``(1, 4, 8)``), read from the compiled
    core on first access.

Examples
--------
>>> import numpy as np
>>> import reference_tracer as rt
>>> from reference_tracer import probe
>>> cam = rt.Camera(lookfrom=(0, 0, -3), lookat=(0, 0, 0), width=4, height=4)
>>> scene = rt.Scene(camera=cam, shapes=[rt.Sphere((0, 0, 0), 1, rt.Lambertian(0.5))])
>>> hit = probe.core_scene(scene).intersect(np.array([[0.0, 0, -3]]), np.array([[0.0, 0, 1]]))
>>> float(hit["t"][0]), int(hit["prim"][0])
(2.0, 0)
>>> probe.first_hit_aovs(scene)["shape"].tolist()
[[-1, 0, 0, -1], [0, 0, 0, 0], [0, 0, 0, 0], [-1, 0, 0, -1]]
"""
from __future__ import annotations

from ..render import core_scene
from .camera import camera_rays, camera_rays_with_reach
from .first_hit import diffuse_albedo, first_hit_aovs, primitive_shapes
from .layout import CORE_CONSTANTS, child_visit_order, core_constant
from .sampling import bsdf_eval_pdf, bsdf_sample, rough_plastic_table, warp_pdf, warp_sample

__all__ = ["core_scene", "camera_rays", "camera_rays_with_reach", "primitive_shapes", "diffuse_albedo", "first_hit_aovs",
           "warp_sample", "warp_pdf", "bsdf_sample", "bsdf_eval_pdf", "rough_plastic_table",
           "child_visit_order"]


def __getattr__(name: str):
    # The layout constants live in the compiled core; reading one loads it.
    if name in CORE_CONSTANTS:
        return core_constant(name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
