"""Numerical stability on hard cases: the measurements behind ``rtbench stress`` (issue 8).

Every case is a function that measures a figure on the tracer and returns a
:class:`StressRecord` (case, figure, verdict, details). ``tests/benchmarks/stress/test_stress_*.py``
assert on the same functions; ``rtbench stress`` (:mod:`benchmarks.commands.stress`)
prints them as a table. This package measures and decides; it prints nothing.

Cases (one module each)
-----------------------
``watertight_mesh`` (:mod:`.watertight`)
    Rays aimed exactly at shared edges and vertices of closed icospheres, cast from
    inside: escapes per triangle test (the shipped default must leak none).
``grazing_rays`` (:mod:`.grazing`)
    Rays within 1e-7 rad of a triangle's or quad's plane, and exactly parallel rays:
    hit/miss compared with exact rational arithmetic on the same float64 ray.
``degenerate_input`` (:mod:`.degenerate`)
    Zero-area, collinear and all-equal-vertex triangles, duplicate vertices, 100,000
    triangles with one bounding box: a balanced tree, never hit, no NaN.
``scale_invariance`` (:mod:`.scale`)
    The Cornell box at scale 1e-4, 1, 1e4 and translated 1e5 away: the same image
    within noise; a white furnace with creases at every scale: exactly 1 per sample.
``light_sampling`` (:mod:`.lights`)
    Points on a quad light, on its plane, behind it, grazing it, inside / on / just
    outside a sphere light: finite pdfs, estimates equal to closed-form solid angles,
    and renders of a floor cutting a sphere light agree across strategies.
``glass`` (:mod:`.glass`)
    A camera inside a glass sphere (rays start inside; total internal reflection traps
    the tangential ones) against closed forms, and ior 1.0 against no glass.
``white_furnace`` (:mod:`.furnace`)
    An albedo-1 sphere in a constant background 1: exactly 1 per sample for ``cosine``,
    1 in expectation for every other strategy.
``fireflies`` (:mod:`.fireflies`)
    ``small_light``: samples above 100x the image mean, per strategy.
``suite_nonfinite`` (:mod:`.suite`)
    Every suite scene under every strategy: NaN/Inf samples discarded.

Shared helpers: :mod:`.probes` (probe scenes and aimed rays), :mod:`.exact` (exact
rational intersection and float64 error bounds), :mod:`.ztests` (the statistical
decisions), :mod:`.record` (:class:`StressRecord`); :mod:`.registry` holds
:data:`CASES` (quick and full settings) and :func:`run_cases`.

Statistical decisions use :func:`image_ztest` (nominal false-positive rate 1e-4 per
comparison) or a z-score against a closed form with |z| <= 5 (5.7e-7 per check).
"""
from __future__ import annotations

from .degenerate import degenerate_input, same_box_triangles
from .exact import UNIT_ROUNDOFF, classify_rays, exact_intersection, quad_error_bound, triangle_error_bound
from .fireflies import fireflies, firefly_counts, small_light_scene
from .furnace import white_furnace
from .glass import fresnel_dielectric, glass
from .grazing import grazing_rays
from .lights import light_sampling, quad_solid_angle, triangle_solid_angle
from .probes import (camera_rays, count_escapes, creased_furnace_scene, edge_and_vertex_rays, icosphere,
                     probe_scene, transform_scene, white_furnace_scene)
from .record import StressRecord
from .registry import CASES, run_cases
from .scale import SCALES, scale_invariance
from .suite import suite_nonfinite
from .watertight import watertight_mesh
from .ztests import constant_ztest, image_ztest

__all__ = [
    "StressRecord", "CASES", "run_cases", "UNIT_ROUNDOFF",
    "watertight_mesh", "grazing_rays", "degenerate_input", "scale_invariance", "light_sampling",
    "glass", "white_furnace", "fireflies", "suite_nonfinite",
    "icosphere", "edge_and_vertex_rays", "count_escapes", "probe_scene",
    "exact_intersection", "triangle_error_bound", "quad_error_bound", "classify_rays",
    "image_ztest", "constant_ztest", "transform_scene", "white_furnace_scene", "creased_furnace_scene",
    "triangle_solid_angle", "quad_solid_angle", "fresnel_dielectric", "camera_rays",
    "small_light_scene", "firefly_counts", "same_box_triangles", "SCALES",
]
