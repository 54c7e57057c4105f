"""Watertight meshes (issue 8): rays aimed exactly at shared edges and vertices of closed
icospheres, cast from inside, must never escape with the default triangle test.

The figure is the escape count per triangle test; Cramer's rule (float32 and float64)
must leak, which shows that the rays really probe the edges.
"""
import inspect

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import reference_tracer as rt
from benchmarks import stress


@pytest.fixture(scope="module")
def record():
    return stress.watertight_mesh(rays=100_000, subdivisions=(1, 2, 3, 4), seed=0)


def test_default_triangle_test_is_watertight():
    assert inspect.signature(rt.render).parameters["triangle_test"].default == "watertight"
    assert rt.TRIANGLE_TESTS[0] == "watertight"


def test_watertight_leaks_zero_of_1e5_edge_and_vertex_rays(record):
    d = record.details
    print(record.figure)
    assert d["rays_per_test"] == 100_000
    assert d["escapes"]["watertight"] == 0
    assert d["nan"] == 0
    assert record.passed


@pytest.mark.parametrize("test", ["cramer", "cramer32"])
def test_cramer_rule_leaks(record, test):
    """Sensitivity: the same rays do escape through Cramer's-rule triangles, at every level."""
    d = record.details
    assert d["escapes"][test] > 1000
    for level, counts in d["by_level"].items():
        assert counts[test]["edge"] > 0 and counts[test]["vertex"] > 0, (level, counts)


def test_camera_inside_sees_no_background(record):
    """A black icosphere around the camera in a white background: every pixel exactly 0."""
    assert record.details["leak_pixels"] == 0
    assert record.details["nonfinite_samples"] == 0


@settings(max_examples=25, deadline=None, derandomize=True)
@given(level=st.integers(1, 4), axis=st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(0.1, 1)),
       angle=st.floats(0, 360), radius=st.floats(1e-3, 1e3), seed=st.integers(0, 2**32 - 1))
def test_rotated_scaled_icosphere_is_watertight(level, axis, angle, radius, seed):
    """Property: any rotation and scale of a closed icosphere (vertex coordinates no longer
    symmetric or round), 2,000 edge/vertex rays from random interior points: no escape."""
    rng = np.random.default_rng(seed)
    V, F, E = stress.icosphere(level)
    R = rt.shapes.rotation_matrix(axis, angle)[:3, :3]
    V = (V @ R.T) * radius
    origins = np.ascontiguousarray(rng.uniform(-0.5, 0.5, (2000, 3)) * radius)
    dirs, _ = stress.edge_and_vertex_rays(V, E, origins, rng)
    scene = stress.probe_scene([rt.Mesh(V, F, rt.Lambertian(0.5))])
    out = stress.count_escapes(scene, origins, dirs, triangle_test="watertight")
    assert out["escapes"] == 0 and out["nan"] == 0 and out["nonfinite_hits"] == 0


@pytest.mark.slow
def test_watertight_leaks_zero_of_millions_of_rays():
    rec = stress.watertight_mesh(rays=4_000_000, subdivisions=(1, 2, 3, 4, 5, 6), seed=1)
    print(rec.figure)
    assert rec.details["escapes"]["watertight"] == 0
    assert rec.details["escapes"]["cramer"] > 0 and rec.details["escapes"]["cramer32"] > 0
    assert rec.passed
