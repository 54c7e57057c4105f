"""Degenerate input (issue 8): zero-area, collinear and all-equal triangles, duplicate
vertices, 100,000 triangles with one bounding box - a balanced tree, never hit, no NaN."""
import numpy as np
import pytest

import reference_tracer as rt
from benchmarks import stress


@pytest.fixture(scope="module")
def record():
    return stress.degenerate_input(coincident=100_000, seed=0, repeats=3)


@pytest.mark.parametrize("test", rt.TRIANGLE_TESTS)
def test_degenerate_triangles_never_hit(record, test):
    r = record.details["ray_hits"][test]
    assert r["degenerate_hits"] == 0
    assert r["brute_force_mismatch"] == 0
    assert r["differs_from_without"] == 0     # same closest hit and distance as without them
    assert r["nan"] == 0


def test_degenerate_triangles_change_no_pixel(record):
    """Renders with and without the degenerate faces (every strategy) are bit-identical."""
    assert record.details["image_differences"] == 0
    assert record.details["nonfinite_samples"] == 0
    assert record.details["emitters_with_degenerate"] == 1   # zero-area emitters are not lights


def test_duplicate_vertices_stay_watertight(record):
    assert record.details["split_vertex_escapes"] == 0


def test_coincident_centroids_build_a_balanced_tree(record):
    """1e5 triangles with one bounding box (no SAH split possible) still build a balanced
    tree, which the O(n log n) build needs: at most log2(1e5) = 17 levels (a builder that
    peeled one leaf off a level would need thousands) and leaves of a few triangles (no leaf
    of them all). Counted, not timed: the build time is reported in the record only."""
    d = record.details
    print(record.figure)
    assert d["bvh_depth_bound"] == 17 and 1 <= d["bvh_depth"] <= 17, d["bvh_depth"]
    assert 4 * d["bvh_blocks"] >= 100_000 and d["bvh_nodes"] < 100_000
    assert d["coincident_brute_force_mismatch"] == 0
    assert record.passed


def test_same_box_triangles_have_one_box():
    tris = stress.same_box_triangles(1000, np.random.default_rng(0))
    assert np.all(tris.min(axis=1) == -1.0) and np.all(tris.max(axis=1) == 1.0)
    assert np.all(np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1) > 0)


def test_all_equal_vertex_mesh_is_refused():
    """A mesh whose vertices are all one point has no area: refused with the reason (a light
    of it would render black), as a zero-area Quad or Triangle is."""
    with pytest.raises(ValueError, match="zero area"):
        rt.Mesh(np.full((9, 3), 0.5), np.arange(9).reshape(3, 3), rt.DiffuseLight(3.0))


