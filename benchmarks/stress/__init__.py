"""Numerical stability on hard cases, behind ``rtbench stress``: one module per case, whose function
returns a :class:`StressRecord`; :data:`CASES` holds their quick and full settings, :func:`run_cases`
runs them."""
from __future__ import annotations

from .degenerate import degenerate_input, same_box_triangles
from .exact import classify_rays, exact_intersection, quad_error_bound, triangle_error_bound
from .fireflies import fireflies, firefly_counts
from .furnace import white_furnace
from .glass import glass
from .grazing import grazing_rays
from .lights import light_sampling, quad_solid_angle, triangle_solid_angle
from .probes import count_escapes, creased_furnace_scene, edge_and_vertex_rays, icosphere, probe_scene, transform_scene
from .record import StressRecord
from .registry import CASES, run_cases, suite_nonfinite
from .scale import scale_invariance
from .watertight import watertight_mesh
from .ztests import constant_ztest, image_ztest

__all__ = ["StressRecord", "CASES", "run_cases", "watertight_mesh", "grazing_rays", "degenerate_input",
           "scale_invariance", "light_sampling", "glass", "white_furnace", "fireflies", "suite_nonfinite",
           "icosphere", "edge_and_vertex_rays", "count_escapes", "probe_scene", "exact_intersection",
           "triangle_error_bound", "quad_error_bound", "classify_rays", "image_ztest", "constant_ztest",
           "transform_scene", "creased_furnace_scene", "triangle_solid_angle", "quad_solid_angle",
           "firefly_counts", "same_box_triangles"]
