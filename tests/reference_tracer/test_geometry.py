"""Shapes against analytic answers (hypothesis property tests) and the BVH against brute force."""
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

import reference_tracer as rt
from reference_tracer import probe
from reference_tracer.probe import core_scene

MAT = rt.Lambertian(0.5)
CAM = rt.Camera(lookfrom=(0, 0, -10), lookat=(0, 0, 0), width=4, height=4)

coord = st.floats(-100, 100, allow_nan=False, allow_infinity=False)
vec = st.tuples(coord, coord, coord)
unit_interval = st.floats(0.0, 1.0)


def core(shapes):
    return core_scene(rt.Scene(camera=CAM, shapes=shapes))


def cast(c, origins, dirs, **kw):
    return c.intersect(np.ascontiguousarray(origins, dtype=np.float64),
                       np.ascontiguousarray(dirs, dtype=np.float64), **kw)


def random_unit(rng, n):
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@settings(max_examples=60, deadline=None)
@given(center=vec, radius=st.floats(1e-3, 50), seed=st.integers(0, 2**32 - 1))
def test_sphere_hits_lie_on_surface(center, radius, seed):
    rng = np.random.default_rng(seed)
    c = np.array(center)
    n = 64
    # Origins outside the sphere, aimed at random points of its surface: every ray hits.
    origins = c + random_unit(rng, n) * radius * rng.uniform(1.5, 20, size=(n, 1))
    targets = c + random_unit(rng, n) * radius
    dirs = targets - origins
    out = cast(core([rt.Sphere(center, radius, MAT)]), origins, dirs)
    assert np.all(out["prim"] == 0)
    dist = np.linalg.norm(out["point"] - c, axis=1)
    scale = 1.0 + np.abs(c).max() + radius
    np.testing.assert_allclose(dist, radius, atol=1e-12 * scale)
    # The hit is the near side: the front (outward) normal faces the ray.
    assert np.all(np.einsum("ij,ij->i", out["normal"], dirs) < 0)
    np.testing.assert_allclose(np.linalg.norm(out["normal"], axis=1), 1.0, atol=1e-12)


@settings(max_examples=30, deadline=None)
@given(center=vec, radius=st.floats(1e-2, 50), seed=st.integers(0, 2**32 - 1))
def test_sphere_misses_rays_that_pass_outside(center, radius, seed):
    rng = np.random.default_rng(seed)
    c = np.array(center)
    n = 64
    origins = c + random_unit(rng, n) * radius * rng.uniform(2, 20, size=(n, 1))
    to_c = c - origins
    # Lines parallel to (centre - origin), shifted sideways by 1.01 radius: they pass the
    # centre at exactly that distance and miss the sphere.
    perp = np.cross(to_c, random_unit(rng, n))
    perp /= np.linalg.norm(perp, axis=1, keepdims=True)
    out = cast(core([rt.Sphere(center, radius, MAT)]), origins + perp * radius * 1.01, to_c)
    assert np.all(out["prim"] == -1)


def test_sphere_flip_normals_points_inward_and_inside_ray_hits_far_side():
    c = core([rt.Sphere((0, 0, 0), 2.0, MAT, flip_normals=True)])
    out = cast(c, [[0, 0, 0], [0, 0, -5]], [[1, 0, 0], [0, 0, 1]])
    np.testing.assert_allclose(out["t"], [2.0, 3.0])
    np.testing.assert_allclose(out["normal"], [[-1, 0, 0], [0, 0, 1]], atol=1e-15)


@settings(max_examples=60, deadline=None)
@given(a=vec, b=vec, c=vec, seed=st.integers(0, 2**32 - 1))
def test_triangle_hits_have_barycentrics_in_range(a, b, c, seed):
    a, b, c = map(np.array, (a, b, c))
    normal = np.cross(b - a, c - a)
    area2 = np.linalg.norm(normal)
    scale = max(np.abs([a, b, c]).max(), 1.0)
    # Skip slivers: the property is about well-posed triangles (degenerate ones: issue 8).
    if area2 < 1e-3 * scale ** 2 or area2 / max(np.linalg.norm(b - a), np.linalg.norm(c - a), np.linalg.norm(c - b)) ** 2 < 1e-3:
        return
    normal /= area2
    rng = np.random.default_rng(seed)
    n = 64
    # Targets strictly inside (barycentrics >= 0.01), origins on either side of the plane.
    w = rng.dirichlet((1, 1, 1), size=n) * 0.97 + 0.01
    targets = w[:, :1] * a + w[:, 1:2] * b + w[:, 2:] * c
    side = rng.choice([-1.0, 1.0], size=(n, 1))
    origins = targets + side * normal * rng.uniform(0.5, 10, size=(n, 1)) * scale + rng.normal(size=(n, 3)) * 0.1 * scale
    dirs = targets - origins
    for test in rt.TRIANGLE_TESTS[:2]:
        sc = core_scene(rt.Scene(camera=CAM, shapes=[rt.Triangle(tuple(a), tuple(b), tuple(c), MAT)]), triangle_test=test)
        out = cast(sc, origins, dirs)
        assert np.all(out["prim"] == 0), test
        p = out["point"]
        # On the plane, and barycentrics (by areas) in [0, 1] up to rounding.
        assert np.all(np.abs((p - a) @ normal) <= 1e-9 * scale)
        tot = np.cross(b - a, c - a) @ normal
        l1 = np.cross(c - b, p - b) @ normal / tot
        l2 = np.cross(a - c, p - c) @ normal / tot
        l3 = 1 - l1 - l2
        for lam in (l1, l2, l3):
            assert np.all(lam >= -1e-9) and np.all(lam <= 1 + 1e-9)
        np.testing.assert_allclose(np.column_stack([l1, l2, l3]), w, atol=1e-6)
        # The front normal follows the counter-clockwise winding.
        np.testing.assert_allclose(out["normal"], np.broadcast_to(normal, (n, 3)), atol=1e-9)


@settings(max_examples=40, deadline=None)
@given(Q=vec, u=vec, v=vec, s=unit_interval, t=unit_interval)
def test_quad_hit_and_outside_miss(Q, u, v, s, t):
    Q, u, v = map(np.array, (Q, u, v))
    n = np.cross(u, v)
    if np.linalg.norm(n) < 1e-2 * max(np.linalg.norm(u) * np.linalg.norm(v), 1e-9) or np.linalg.norm(n) < 1e-3:
        return
    n /= np.linalg.norm(n)
    c = core([rt.Quad(tuple(Q), tuple(u), tuple(v), MAT)])
    s, t = 0.02 + 0.96 * s, 0.02 + 0.96 * t
    inside = Q + s * u + t * v
    outside = Q + (1.2 + s) * u + t * v
    origin = inside + 5 * n * max(1.0, np.abs(Q).max())
    out = cast(c, [origin, origin], [inside - origin, outside - origin])
    assert out["prim"].tolist() == [0, -1]
    np.testing.assert_allclose(out["normal"][0], n, atol=1e-12)


def test_box_faces_point_outward_under_transforms():
    box = rt.Box((0, 0, 0), (1, 2, 3), MAT).rotate((1, 1, 0), 33).scale(2.5).translate((4, -1, 7))
    c = core([box])
    centre = box._point((0.5, 1.0, 1.5))
    rng = np.random.default_rng(1)
    dirs = random_unit(rng, 500)
    origins = centre - 50 * dirs
    out = cast(c, origins, dirs)
    assert np.all(out["prim"] >= 0)
    # Seen from outside, every hit is on a front face (normal against the ray).
    assert np.all(np.einsum("ij,ij->i", out["normal"], dirs) < 0)
    # From the inside, every hit is on the back of a face.
    out_in = cast(c, np.broadcast_to(centre, (500, 3)), dirs)
    assert np.all(np.einsum("ij,ij->i", out_in["normal"], dirs) > 0)


def test_flip_normals_reverses_quad_triangle_and_mesh():
    for shape in (rt.Quad((-1, -1, 0), (2, 0, 0), (0, 2, 0), MAT),
                  rt.Triangle((-1, -1, 0), (1, -1, 0), (0, 1, 0), MAT),
                  rt.Mesh([[-1, -1, 0], [1, -1, 0], [0, 1, 0]], [[0, 1, 2]], MAT)):
        for flip, expected_z in ((False, 1.0), (True, -1.0)):
            s = replace(shape, flip_normals=flip)
            out = cast(core([s]), [[0, 0, 5]], [[0, 0, -1]])
            assert out["normal"][0][2] == expected_z, (type(shape).__name__, flip)


def random_primitives(n, rng):
    shapes = []
    kinds = rng.integers(0, 3, size=n) if n > 1 else [2]
    for k in kinds:
        p = rng.uniform(-50, 50, size=3)
        if k == 0:
            shapes.append(rt.Sphere(tuple(p), float(rng.uniform(0.1, 3)), MAT))
        elif k == 1:
            shapes.append(rt.Quad(tuple(p), tuple(rng.normal(size=3) * 3), tuple(rng.normal(size=3) * 3), MAT))
        else:
            shapes.append(rt.Triangle(tuple(p), tuple(p + rng.normal(size=3) * 3), tuple(p + rng.normal(size=3) * 3), MAT))
    return shapes


def random_mesh(n, rng):
    base = rng.uniform(-50, 50, size=(n, 1, 3))
    verts = (base + rng.normal(size=(n, 3, 3)) * 2).reshape(-1, 3)
    return rt.Mesh(verts, np.arange(3 * n).reshape(n, 3), MAT)


@pytest.mark.parametrize("n", [1, 2, 10, 100, 1000, 10000])
def test_bvh_equals_brute_force(n):
    rng = np.random.default_rng(n)
    shapes = random_primitives(min(n, 1000), rng) if n <= 1000 else [random_mesh(n, rng)]
    c = core(shapes)
    m = 3000 if n < 10000 else 800
    origins = rng.uniform(-70, 70, size=(m, 3))
    dirs = random_unit(rng, m)
    # Half the rays aimed at primitives so that hits are common.
    anchors = np.array([s.world_center() if isinstance(s, rt.Sphere) else
                        (s.world_corners()[0] + 0.5 * s.world_corners()[1] + 0.5 * s.world_corners()[2]) if isinstance(s, rt.Quad) else
                        s.world_vertices().mean(axis=0) if isinstance(s, rt.Triangle) else np.zeros(3)
                        for s in shapes]) if n <= 1000 else shapes[0].world_triangles().mean(axis=1)
    targets = anchors[rng.integers(0, len(anchors), size=m // 2)]
    dirs[: m // 2] = targets - origins[: m // 2]
    fast = cast(c, origins, dirs)
    slow = cast(c, origins, dirs, brute_force=True)
    assert np.array_equal(fast["prim"], slow["prim"])
    assert np.array_equal(fast["t"], slow["t"])
    assert (fast["prim"] >= 0).mean() > 0.3


def test_bvh_handles_flat_boxes_and_coincident_centroids():
    # Axis-aligned quads (zero-thickness boxes) and many triangles sharing one centroid.
    quads = [rt.Quad((-5, y, -5), (10, 0, 0), (0, 0, 10), MAT) for y in np.linspace(-3, 3, 7)]
    rng = np.random.default_rng(3)
    d = rng.normal(size=(2000, 3))
    verts = np.stack([d, -d / 2 + 0.1 * rng.normal(size=(2000, 3)), -d / 2], axis=1)
    verts[:, 2] = -verts[:, 0] - verts[:, 1]  # all centroids exactly at the origin
    mesh = rt.Mesh(verts.reshape(-1, 3) + (0, 10, 0), np.arange(6000).reshape(-1, 3), MAT)
    c = core(quads + [mesh])
    origins = rng.uniform(-8, 8, size=(2000, 3)) + (0, 5, 0)
    dirs = random_unit(rng, 2000)
    fast, slow = cast(c, origins, dirs), cast(c, origins, dirs, brute_force=True)
    assert np.array_equal(fast["prim"], slow["prim"])
    assert c.bvh_depth < 64


def test_mesh_load_obj_and_ply_keep_winding(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    tm = trimesh.creation.icosphere(subdivisions=1)
    for ext in ("obj", "ply"):
        path = tmp_path / f"ico.{ext}"
        tm.export(path)
        mesh = rt.Mesh.load(path, MAT)
        assert mesh.faces.shape == tm.faces.shape
        np.testing.assert_allclose(mesh.world_triangles(), np.asarray(tm.vertices)[tm.faces], atol=1e-6)
    with pytest.raises(ValueError, match="could not read"):
        rt.Mesh.load(tmp_path / "missing.obj", MAT)


@pytest.mark.parametrize("offset", [0.0, 1234.5678, 3.1e6 + 0.3])
@pytest.mark.parametrize("dir_y", [0.0, -0.0, 1e-40, -1e-300, 1e-9])
@pytest.mark.parametrize("packets", [False, True])
def test_float_box_test_never_misses_thin_boxes(offset, dir_y, packets):
    # The BVH tests child boxes in single precision (wide_bvh.h). Tiny triangles whose
    # boxes are 2e-6 thick in y sit far from the float grid (the float spacing at 3.1e6
    # is 0.25); rays run (almost) parallel to y = const through the slab, half of them
    # through a triangle. A box test that merely rounded the origin to float would put
    # most origins outside these slabs and miss every such hit; the conservative test
    # must find exactly what brute force finds.
    rng = np.random.default_rng(17)
    # One packet's rays a triangle (with packets).
    h, w, n_tri, per_tri = 1e-6, 1e-6, 400, probe.PACKET_RAYS
    corner = offset + rng.uniform(-3, 3, size=(n_tri, 3))
    a = corner + (0.0, -h, 0.0)
    b = corner + (w, h, 0.0)
    c = corner + (0.0, h, w)
    mesh = rt.Mesh(np.stack([a, b, c], axis=1).reshape(-1, 3), np.arange(3 * n_tri).reshape(-1, 3), MAT)
    core_ = core([mesh])
    # Points on (s in [0, 1]) or beside (s outside) each triangle's slice y = const:
    # y(u, v) = corner_y - h + 2 h (u + v), taken at u = v = s / 2.
    s = rng.uniform(-0.5, 1.5, size=(n_tri, per_tri, 1))
    q = (a[:, None] + 0.5 * s * (b - a)[:, None] + 0.5 * s * (c - a)[:, None]).reshape(-1, 3)
    if packets:
        # One direction for the rays of a triangle (consecutive, origins within 2e-6):
        # the batch traces them as a packet (wide_bvh.h, traverse_packet).
        theta = np.repeat(rng.uniform(0, 2 * np.pi, size=n_tri), per_tri)
    else:
        theta = rng.uniform(0, 2 * np.pi, size=len(q))
    dirs = np.stack([np.cos(theta), np.full(len(q), dir_y), np.sin(theta)], axis=1)
    if packets:
        dirs[: per_tri * (n_tri // 4)] = (1.0, dir_y, 0.0)  # a quarter of the packets along x
    else:
        dirs[::4] = (1.0, dir_y, 0.0)  # some rays along x: two components (almost) zero
        dirs[1::4, 0] = -dirs[1::4, 0]
    origins = q - 5.0 * dirs
    origins[:, 1] = q[:, 1]  # on the slice exactly, whatever dir_y is
    fast = cast(core_, origins, dirs)
    slow = cast(core_, origins, dirs, brute_force=True)
    assert (fast["packet_rays"] > 0.9 * len(q)) if packets else (fast["packet_rays"] < 0.01 * len(q))
    assert np.array_equal(fast["prim"], slow["prim"])
    assert np.array_equal(fast["t"], slow["t"])
    assert 0.3 < (slow["prim"] >= 0).mean() < 0.7


@pytest.mark.parametrize("n_rays", [0, 1, 3, 8, 1001])
@pytest.mark.parametrize("threads", [1, 2])
def test_interleaved_traversal_equals_single_ray(n_rays, threads):
    # Scene.intersect traces its rays eight at a time, interleaved (wide_bvh.h); every
    # field of every result must equal the one-ray-at-a-time traversal's and brute force.
    rng = np.random.default_rng(n_rays + 7 * threads)
    shapes = random_primitives(60, rng) + [random_mesh(3000, rng)]
    c = core(shapes)
    origins = rng.uniform(-70, 70, size=(n_rays, 3))
    dirs = random_unit(rng, n_rays)
    dirs[: n_rays // 2] = rng.uniform(-50, 50, size=(n_rays // 2, 3)) - origins[: n_rays // 2]
    interleaved = cast(c, origins, dirs, threads=threads)
    single = cast(c, origins, dirs, threads=threads, batch=False)
    brute = cast(c, origins, dirs, brute_force=True)
    for key in ("t", "prim", "point", "normal"):
        assert np.array_equal(interleaved[key], single[key]), key
        assert np.array_equal(interleaved[key], brute[key]), key
    if n_rays > 100:
        assert 0.2 < (brute["prim"] >= 0).mean() < 0.9


def _child_order_key(t, slot):
    # wide_bvh.h's child_order_key: the float's bits with the lowest three replaced by the slot.
    bits = int(np.array(t, dtype=np.float32).view(np.int32))
    return (bits & ~7) | slot


near_distance = st.one_of(st.floats(0.0, 1e6, width=32), st.sampled_from([0.0, 1.0, 1.0000001, np.inf]))


@settings(max_examples=300, deadline=None)
@given(t_near=st.lists(near_distance, min_size=8, max_size=8), met=st.lists(st.booleans(), min_size=8, max_size=8),
       close=st.integers(0, 7))
def test_children_are_visited_nearest_first_in_both_traversals(t_near, met, close):
    # The interleaved traversal orders a node's children with a sorting network, the
    # single-ray one with an insertion sort (wide_bvh.h); both must give the slots met in
    # the order of the same key, or their results could differ on ties. `close` puts two
    # distances a few ulps apart, where the key's slot bits decide.
    t_near[close] = float(np.nextafter(np.float32(t_near[(close + 1) % 8]), np.float32(np.inf)))
    network, insertion = probe.child_visit_order(t_near, met)
    expected = sorted((c for c in range(8) if met[c]), key=lambda c: _child_order_key(t_near[c], c))
    assert list(network) == expected
    assert list(insertion) == expected


def test_child_visit_order_rejects_bad_input():
    with pytest.raises(ValueError, match="one entry per child"):
        probe.child_visit_order([1.0] * 7, [True] * 7)
    with pytest.raises(ValueError, match="not NaN"):
        probe.child_visit_order([1.0] * 7 + [float("nan")], [True] * 8)


@pytest.mark.parametrize("threads", [1, 2])
def test_interleaved_traversal_of_a_tree_beyond_the_cache_threshold(threads):
    # Trees over 8 MiB (Scene::kCachedTreeBytes) take another instance of the interleaved
    # traversal, one that does not prefetch pushed children (wide_bvh.h, kPrefetchPushed): its
    # results must equal the one-ray-at-a-time traversal's, field by field.
    from benchmarks.speed.rays import mesh_scene, random_rays

    c = core_scene(mesh_scene(200_000))
    assert c.bvh_float_blocks and c.bvh_bytes > probe.CACHED_TREE_BYTES
    origins, dirs = random_rays(3000, seed=11)
    interleaved = cast(c, origins, dirs, threads=threads)
    single = cast(c, origins, dirs, threads=threads, batch=False)
    assert interleaved["packet_rays"] == 0
    for key in ("t", "prim", "point", "normal"):
        assert np.array_equal(interleaved[key], single[key]), key
    assert 0.2 < (single["prim"] >= 0).mean() < 0.7


@pytest.mark.parametrize("n_prims, mesh_triangles", [(1, 3000), (8, 3000), (20, 1), (20, 0), (0, 500), (40, 3000)])
@pytest.mark.parametrize("triangle_test", ["watertight", "cramer"])
def test_batched_queries_equal_brute_force(n_prims, mesh_triangles, triangle_test):
    # Scene.intersect_batch / occluded_batch (the wavefront integrator's queries): spheres
    # and quads four rays at a time, then the triangles through a tree of their own behind
    # a four-ray box test (scene.cpp). Every field must equal brute force's; shadow rays
    # must equal the one-ray-at-a-time query's.
    rng = np.random.default_rng(n_prims + mesh_triangles)
    shapes = random_primitives(n_prims, rng) if n_prims else []
    if mesh_triangles:
        shapes.append(random_mesh(mesh_triangles, rng))
    c = core_scene(rt.Scene(camera=CAM, shapes=shapes), triangle_test=triangle_test)
    n = 1003
    origins = rng.uniform(-70, 70, size=(n, 3))
    dirs = random_unit(rng, n)
    dirs[: n // 2] = rng.uniform(-50, 50, size=(n // 2, 3)) - origins[: n // 2]
    dirs[::9] = (0.0, 1.0, 0.0)  # parallel to two slab planes of every box
    batch = cast(c, origins, dirs, wavefront=True)
    brute = cast(c, origins, dirs, brute_force=True)
    for key in ("t", "prim", "point", "normal"):
        assert np.array_equal(batch[key], brute[key]), key
    hit = brute["prim"] >= 0
    assert hit.mean() > (0.05 if mesh_triangles >= 500 else 0.0)  # something to compare
    t = np.where(hit, brute["t"], 1e3)
    for t_max in (t * (1 - 1e-9), t * (1 + 1e-9), np.full(n, np.inf)):
        t_max = np.ascontiguousarray(t_max)
        assert np.array_equal(c.occluded(origins, dirs, t_max, wavefront=True),
                              c.occluded(origins, dirs, t_max, wavefront=False))
    assert np.array_equal(c.occluded(origins, dirs, np.ascontiguousarray(t * (1 + 1e-9)), wavefront=True), hit)


@pytest.mark.parametrize("path", [{}, {"batch": False}, {"wavefront": True}, {"brute_force": True}])
@pytest.mark.parametrize("threads", [1, 2])
def test_preliminary_query_gives_the_full_querys_distance_and_primitive(path, threads):
    # intersect(preliminary=True) answers as Mitsuba's ray_intersect_preliminary does
    # (distance and primitive; the batch traversal then skips the hit point and normal):
    # its t and prim must be the full query's, for camera rays (packets) and scattered
    # rays (interleaved), on spheres, quads and a mesh, whichever traversal answers.
    rng = np.random.default_rng(41 + threads)
    shapes = random_primitives(30, rng) + [random_mesh(3000, rng)]
    c = core(shapes)
    side = 40
    gx, gy = np.meshgrid(np.linspace(-0.5, 0.5, side), np.linspace(-0.4, 0.4, side))
    cam = np.stack([gx.ravel() + 0.013, gy.ravel() + 0.017, -np.ones(gx.size)], axis=1)
    n = 1500
    origins = np.concatenate([np.tile([0.0, 0.0, 120.0], (len(cam), 1)), rng.uniform(-70, 70, size=(n, 3))])
    dirs = np.concatenate([cam / np.linalg.norm(cam, axis=1, keepdims=True), random_unit(rng, n)])
    full = cast(c, origins, dirs, threads=threads, **path)
    pre = cast(c, origins, dirs, threads=threads, preliminary=True, **path)
    assert "point" not in pre and "normal" not in pre
    assert np.array_equal(pre["t"], full["t"]) and np.array_equal(pre["prim"], full["prim"])
    assert pre["packet_rays"] == full["packet_rays"]
    assert 0.2 < (full["prim"] >= 0).mean() < 0.95
    # The outputs are not zero-filled before the query (bindings.cpp): every miss must have
    # been written as a miss by whichever path answered it.
    miss = full["prim"] < 0
    assert np.all(np.isinf(full["t"][miss])) and np.all(full["point"][miss] == 0.0)
    assert np.all(full["normal"][miss] == 0.0)


def test_interleaved_traversal_of_an_empty_scene():
    c = core([])
    out = cast(c, np.zeros((5, 3)), np.tile([0.0, 0.0, 1.0], (5, 1)))
    assert np.all(np.isinf(out["t"])) and np.all(out["prim"] == -1)


def test_bvh_fills_triangle_blocks():
    # The SAH costs a leaf of triangles per 4-lane block, not per triangle (bvh.cpp): on a
    # smooth mesh leaves come out nearly full. Costed per triangle, the same build split
    # them down to 1-2 triangles per block (1.76 on this torus), which
    # tripled the memory a ray touches. Leaves of the Cramer tests are not packed.
    from benchmarks.speed import mesh_scene

    scene = mesh_scene(20_000)
    n_tri = len(scene.shapes[0].faces)
    c = core_scene(scene)
    assert n_tri / c.bvh_blocks > 3.3
    assert core_scene(scene, triangle_test="cramer").bvh_blocks == 0


@pytest.mark.parametrize("n_quads", [20, 40])
def test_exact_ties_go_to_the_lower_id_in_every_path(n_quads):
    # Pairs of identical quads (a face drawn twice, a box on a floor) give two hits at
    # exactly one distance. Every path reports the lower id: brute force and the packs
    # (20 quads: intersect_batch tests them in id order) by their order, the tree
    # (40 quads, and single rays always) by Scene::closest_primitive's rule, whatever
    # order it visits them in. Each duplicate comes late in the id order, after unrelated
    # quads, so that the tree's order and the ids disagree.
    rng = np.random.default_rng(2)
    n_pairs = n_quads // 4
    base = [rt.Quad((x, y, -1.0), (1.0, 0.0, 0.0), (0.0, 0.0, 2.0), MAT)
            for x, y in zip(rng.uniform(-20, 20, n_quads - n_pairs), rng.uniform(-5, 5, n_quads - n_pairs))]
    shapes = base + [base[i] for i in range(n_pairs)]
    c = core(shapes)
    m = 400
    pick = rng.integers(0, n_pairs, size=m)
    q = np.array([shapes[i].Q for i in pick])
    origins = q + np.stack([rng.uniform(0.05, 0.95, m), np.full(m, 30.0), rng.uniform(0.1, 1.9, m)], axis=1)
    dirs = np.tile([0.0, -1.0, 0.0], (m, 1)) + rng.normal(scale=1e-3, size=(m, 3))
    brute = cast(c, origins, dirs, brute_force=True)
    duplicated = brute["prim"] < n_pairs
    assert duplicated.mean() > 0.5  # most rays end on the first quad of a pair
    for path in ({}, {"batch": False}, {"wavefront": True}):
        out = cast(c, origins, dirs, **path)
        for key in ("t", "prim"):
            assert np.array_equal(out[key], brute[key]), (path, key)


@pytest.mark.parametrize("triangles", [2_000, 20_000])
def test_wide_tree_fills_its_nodes(triangles):
    # The binary tree's nodes that become 8-wide nodes are chosen by dynamic programming
    # for the least summed area of wide nodes, i.e. the fewest node visits a ray expects
    # (wide_bvh.cpp). Slots in use = children that are nodes (all but the root) plus
    # leaves (one block each on this mesh). The greedy collapse it replaced (open the
    # largest child until eight) filled 5.09 and 4.07 slots of 8 on these tori; this one
    # 6.10 and 6.05.
    from benchmarks.speed import mesh_scene

    c = core_scene(mesh_scene(triangles))
    assert c.bvh_float_blocks and c.bvh_blocks > 0
    assert (c.bvh_nodes - 1 + c.bvh_blocks) / c.bvh_nodes > 5.8


@pytest.mark.parametrize("width, height", [(64, 48), (37, 29)])
@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("view", ["-z", "+x", "-y"])
def test_packet_traversal_of_camera_rays_equals_single_ray(width, height, threads, view):
    # Camera rays through neighbouring pixels go through the BVH as packets of sixteen
    # (wide_bvh.h, kPacketRays): every field of every result must equal the one-ray-at-a-time
    # traversal's and brute force. The camera looks straight along an axis, so the centre
    # column and row have exactly zero components and the packets there straddle a change
    # of octant (traced one ray at a time); odd sizes leave a partial packet. Packets
    # compute their rays' constants four at a time (PacketSlabs, WatertightRays4): the
    # three views give each axis as the dominant one, in both directions.
    rng = np.random.default_rng(width + threads)
    shapes = random_primitives(40, rng) + [random_mesh(3000, rng)]
    c = core(shapes)
    xs = np.linspace(-0.6, 0.6, width)
    ys = np.linspace(-0.45, 0.45, height)
    gx, gy = np.meshgrid(xs, ys)
    dirs = np.stack([gx.ravel(), gy.ravel(), -np.ones(gx.size)], axis=1)
    axis = "xyz".index(view[1])
    sign = 1.0 if view[0] == "+" else -1.0
    # The dominant component (-1 above) moved to `axis`, pointing along `sign`.
    order = {0: [2, 0, 1], 1: [0, 2, 1], 2: [0, 1, 2]}[axis]
    dirs = dirs[:, order]
    dirs[:, axis] = sign
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    origins = np.zeros((len(dirs), 3))
    origins[:, axis] = -120.0 * sign
    batch = cast(c, origins, dirs, threads=threads)
    single = cast(c, origins, dirs, threads=threads, batch=False)
    brute = cast(c, origins, dirs, brute_force=True)
    # The rows are gathered into tiles of 4 x 4 rays (4 x 2 with packets of eight;
    # packet_order.h). Tiles that straddle the centre are not coherent; sixteen are then
    # traced as two packets of eight where they can be. 88% of the rays go in packets at
    # 37 x 29 (89% with packets of eight), all at 64 x 48; in rows of sixteen, as the rays
    # come, 60% did at 37 x 29 (19% without the halves).
    assert batch["packet_rays"] > 0.8 * len(dirs)
    for key in ("t", "prim", "point", "normal"):
        assert np.array_equal(batch[key], single[key]), key
        assert np.array_equal(batch[key], brute[key]), key
    assert 0.1 < (brute["prim"] >= 0).mean()


def scanline_camera(width, height, *, jitter=0.0, rng=None):
    """Pinhole rays from (0, 0, 120) down -z, pixel after pixel along rows, row after row,
    and each ray's pixel (x, y); ``jitter`` moves each ray up to that share of a pixel."""
    y, x = np.divmod(np.arange(width * height), width)
    pitch = 0.5 / max(width, height)  # square pixels
    u = (x + 0.5 + (rng.uniform(-jitter, jitter, x.size) if jitter else 0.0)) * pitch
    v = (y + 0.5 + (rng.uniform(-jitter, jitter, y.size) if jitter else 0.0)) * pitch
    # Off the axes, so that no tile straddles a change of octant.
    dirs = np.stack([0.05 + u, 0.05 + v, -np.ones(u.size)], axis=1)
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    return np.tile([0.0, 0.0, 120.0], (len(dirs), 1)), dirs, x, y


@pytest.mark.parametrize("width, height, skip", [(64, 48, 0), (64, 48, 10), (37, 29, 0), (37, 29, 30), (1024, 8, 0),
                                                 (200, 41, 150)])
@pytest.mark.parametrize("jitter", [0.0, 0.5])
def test_packet_order_gathers_scanline_rays_into_tiles(width, height, skip, jitter):
    # Camera rays that come row after row are gathered into tiles of four rays across and
    # PACKET_RAYS / 4 rows (packet_order.h): the order must find the rows' width and the
    # first whole row (the batch may begin inside a row), visit every ray once, and give
    # packets that are tiles: within the bands of rows, four columns and PACKET_RAYS / 4
    # rows at most, and the first band's first packet exactly the tile at its corner.
    rng = np.random.default_rng(width + skip)
    c = core(random_primitives(10, rng) + [random_mesh(500, rng)])
    o, d, x, y = scanline_camera(width, height, jitter=jitter, rng=rng)
    o, d, x, y = o[skip:], d[skip:], x[skip:], y[skip:]
    po = c.packet_order(np.ascontiguousarray(o), np.ascontiguousarray(d))
    order, sizes = np.asarray(po["order"]), np.asarray(po["sizes"])
    assert np.array_equal(np.sort(order), np.arange(len(o)))
    assert sizes.sum() == len(o) and sizes.max() <= probe.PACKET_RAYS
    assert po["row_width"] == width and po["first_row"] == (width - skip % width) % width
    rows = probe.PACKET_RAYS // 4
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    band_end = po["first_row"] + (len(o) - po["first_row"]) // (rows * width) * rows * width
    first_tile = True
    for start, m in zip(starts, sizes):
        if start < po["first_row"] or start >= band_end:
            continue
        k = order[start:start + m]
        assert np.ptp(x[k]) < 4 and np.ptp(y[k]) < rows
        if first_tile:
            assert sorted(zip(y[k], x[k])) == [(y[k].min() + r, i) for r in range(rows) for i in range(4)]
            first_tile = False
    assert not first_tile


@pytest.mark.parametrize("width, skip", [(64, 0), (37, 5), (1500, 700), (3000, 0)])
def test_intersect_chunks_hold_whole_bands_of_rows(width, skip):
    # intersect() hands its threads chunks of rays, each ordered on its own. Where the rays
    # come in rows, a chunk holds whole bands of tiles (at least two), and the chunks begin
    # at the first whole row: with chunks of RAY_CHUNK, rows wider than about 1600 rays
    # would never be tiled, and bands would be cut wherever the width does not divide
    # RAY_CHUNK. Each chunk's own order must find the rows, and every hit stay the
    # single-ray traversal's.
    rng = np.random.default_rng(width)
    c = core(random_primitives(10, rng) + [random_mesh(2000, rng)])
    o, d, _, _ = scanline_camera(width, max(12, 2 * probe.RAY_CHUNK // width + 3), jitter=0.5, rng=rng)
    o, d = o[skip:], d[skip:]
    batch = cast(c, o, d, threads=2, preliminary=True)
    band = probe.PACKET_RAYS // 4 * width
    chunk, offset = batch["chunk"], batch["chunk_offset"]
    assert chunk % band == 0 and chunk >= max(2 * band, probe.RAY_CHUNK) and chunk - band < max(probe.RAY_CHUNK, 2 * band)
    assert offset == (width - skip) % width
    bounds = [0] + list(range(offset + chunk, len(o), chunk)) + [len(o)]
    for begin, end in zip(bounds[:-1], bounds[1:]):
        if end - begin >= band + width:
            po = c.packet_order(o[begin:end], d[begin:end])
            assert po["row_width"] == width
            assert po["first_row"] == (offset if begin == 0 else 0)
    assert batch["packet_rays"] > 0.95 * len(o)
    single = cast(c, o, d, batch=False, preliminary=True)
    assert np.array_equal(batch["t"], single["t"]) and np.array_equal(batch["prim"], single["prim"])
    assert (single["prim"] >= 0).mean() > 0.05


def test_packet_order_keeps_the_order_of_rays_without_rows():
    # Rays that come in no rows keep their own order: random rays, rays already in tiles
    # of 4 x 4 pixels, one ray repeated, rows of fewer than eight rays, zero directions and
    # NaN (no crash: the median step must still have an order to find).
    rng = np.random.default_rng(3)
    c = core(random_primitives(10, rng) + [random_mesh(500, rng)])
    n = 4096
    o, d, x, y = scanline_camera(64, 64)
    tiled = np.lexsort((x % 4, y % 4, x // 4, y // 4))
    narrow_o, narrow_d, _, _ = scanline_camera(6, 600)
    cases = {"random": (rng.uniform(-50, 50, (n, 3)), random_unit(rng, n)),
             "tiles": (o[tiled], d[tiled]),
             "one ray": (np.tile(o[:1], (n, 1)), np.tile(d[:1], (n, 1))),
             "narrow rows": (narrow_o, narrow_d),
             "zero directions": (o, np.zeros_like(d)),
             "NaN": (np.where(rng.random((len(o), 1)) < 0.3, np.nan, o), d)}
    for name, (oo, dd) in cases.items():
        po = c.packet_order(np.ascontiguousarray(oo), np.ascontiguousarray(dd))
        assert po["row_width"] == 0, name
        assert np.array_equal(po["order"], np.arange(len(oo))), name


@pytest.mark.parametrize("scale, offset", [(1e-30, 0.0), (1e-3, 1e5), (1.0, 0.0), (1e-6, 3.1e6), (1e25, 0.0)])
@pytest.mark.parametrize("flat", [False, True])
def test_bvh_equals_brute_force_at_any_scale(scale, offset, flat):
    # The tree tests its child boxes in single precision, rounded outward from the double
    # boxes (wide_bvh.h; boxes quantised to bytes are in PERFORMANCE.md, Ideas tried).
    # Meshes of every size the API accepts (coordinates up to 1e30), far from the origin,
    # and flat ones (every vertex at one z: boxes without extent in z; the triangles laid
    # out on a grid so that none overlaps another and no hit is a tie) must give exactly
    # brute force's hits, for packets, interleaved and single rays.
    rng = np.random.default_rng(5)
    n = 3000
    if flat:
        cells = np.stack(np.meshgrid(np.arange(55), np.arange(55), indexing="ij"), -1).reshape(-1, 2)[:n]
        base = np.concatenate([2.0 * cells - 55.0, np.full((n, 1), 7.0)], axis=1)[:, None, :]
        verts = base + np.concatenate([rng.uniform(-0.6, 0.6, size=(n, 3, 2)), np.zeros((n, 3, 1))], axis=2)
    else:
        verts = rng.uniform(-50, 50, size=(n, 1, 3)) + rng.normal(size=(n, 3, 3)) * 2
    verts = (verts * scale + offset).reshape(-1, 3)
    c = core([rt.Mesh(verts, np.arange(3 * n).reshape(n, 3), MAT)])
    m = 2048
    centre = np.array([0.0, 0.0, 7.0 if flat else 0.0]) * scale + offset
    origins = centre + rng.uniform(-70, 70, size=(m, 3)) * scale
    targets = verts.reshape(n, 3, 3).mean(axis=1)[rng.integers(0, n, size=m)]
    dirs = (targets - origins) / scale
    # The first half from one point towards neighbouring targets: packets.
    origins[: m // 2] = centre + np.array([0.0, -120.0, 30.0]) * scale
    half = (targets[: m // 2] - origins[: m // 2]) / scale
    dirs[: m // 2] = half[np.lexsort((half[:, 0], np.round(half[:, 1], 0)))]
    brute = cast(c, origins, dirs, brute_force=True)
    assert (brute["prim"] >= 0).mean() > 0.3
    single = cast(c, origins, dirs, batch=False)
    batch = cast(c, origins, dirs)
    assert batch["packet_rays"] > 0
    for out in (single, batch):
        for key in ("t", "prim"):
            assert np.array_equal(out[key], brute[key]), key


@pytest.mark.parametrize("float_exact", [True, False])
def test_float_stored_triangle_blocks_equal_brute_force(float_exact):
    # Where every vertex is exactly a float (meshes from PLY/OBJ files), the BVH's
    # triangle blocks are stored in float and widened to double for the same double
    # test (shapes/triangle.h): every field of every hit must still equal brute force,
    # for packets, interleaved and single-ray traversal. One vertex that is not a float
    # keeps the whole scene on double blocks; both storages are checked.
    rng = np.random.default_rng(29)
    mesh = random_mesh(4000, rng)
    verts = mesh.vertices.astype(np.float32).astype(np.float64)
    if not float_exact:
        verts[0, 0] += 1e-12
    c = core([rt.Mesh(verts, mesh.faces, MAT)])
    assert c.bvh_float_blocks == float_exact and c.bvh_blocks > 0
    n = 4096
    origins = rng.uniform(-70, 70, size=(n, 3))
    dirs = random_unit(rng, n)
    dirs[: n // 2] = rng.uniform(-50, 50, size=(n // 2, 3)) - origins[: n // 2]
    # Camera rays from one point (packets), then the scattered rays (interleaved).
    side = 48
    gx, gy = np.meshgrid(np.linspace(-0.5, 0.5, side), np.linspace(-0.4, 0.4, side))
    cam_dirs = np.stack([gx.ravel() + 0.013, gy.ravel() + 0.017, -np.ones(gx.size)], axis=1)
    origins = np.concatenate([np.tile([0.0, 0.0, 120.0], (len(cam_dirs), 1)), origins])
    dirs = np.concatenate([cam_dirs / np.linalg.norm(cam_dirs, axis=1, keepdims=True), dirs])
    batch = cast(c, origins, dirs)
    single = cast(c, origins, dirs, batch=False)
    brute = cast(c, origins, dirs, brute_force=True)
    assert batch["packet_rays"] > 0.75 * len(cam_dirs)  # those straddling x = 0 or y = 0 are not
    for key in ("t", "prim", "point", "normal"):
        assert np.array_equal(batch[key], single[key]), key
        assert np.array_equal(batch[key], brute[key]), key
    assert 0.2 < (brute["prim"] >= 0).mean() < 0.9


def _within(shapes, point, distance):
    """surface_within just beyond and just short of ``distance``: (True, False) where it is the nearest."""
    from reference_tracer.distances import surface_within

    return surface_within(shapes, point, distance * (1 + 1e-9)), surface_within(shapes, point, distance * (1 - 1e-9))


def test_surface_within_and_farthest_distance_by_hand():
    from reference_tracer.distances import farthest_distance

    quad = rt.Quad((0, 0, 0), (2, 0, 0), (0, 1, 0), MAT)
    assert _within([quad], (1.0, 0.5, 0.3), 0.3) == (True, False)            # over its inside: the plane
    assert _within([quad], (2.3, 0.5, 0.4), 0.5) == (True, False)            # beyond an edge: the edge
    assert _within([quad], (-3.0, -4.0, 0.0), 5.0) == (True, False)          # beyond a corner: the corner
    box = rt.Box((-1, -1, -1), (1, 1, 1), MAT).scale(2.0).translate((5, 0, 0))
    assert _within([box], (5.5, 0.0, 0.0), 1.5) == (True, False)             # inside: the nearest face
    sphere = rt.Sphere((0, 0, 0), 1.0, MAT).scale(3.0)
    assert _within([sphere], (0.5, 0.0, 0.0), 2.5) == (True, False)          # inside: the shell
    assert _within([sphere], (0.0, 5.0, 0.0), 2.0) == (True, False)
    # a mesh's zero-area face is never hit: it is not a surface here either
    mesh = rt.Mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 5], [0, 0, 5.0], [1, 0, 5]],
                   [[0, 1, 2], [3, 4, 5]], MAT).translate((0, 0, 1))
    assert _within([mesh], (0.2, 0.2, 6.1), 5.1) == (True, False)
    tri = rt.Triangle((0, 0, 0), (1, 0, 0), (0, 1, 0), MAT)
    assert _within([tri, quad, sphere, box], (0.0, 0.0, -7.0), 4.0) == (True, False)
    assert farthest_distance([], (0, 0, 0)) == 0.0
    assert farthest_distance([sphere], (1, 0, 0)) == pytest.approx(4.0)
    assert farthest_distance([quad, tri], (0, 0, 0)) == pytest.approx(np.sqrt(5.0))
    assert farthest_distance([box], (5, 0, 0)) == pytest.approx(2 * np.sqrt(3.0))
    assert farthest_distance([mesh], (0, 0, 1)) == pytest.approx(np.hypot(1.0, 5.0))
