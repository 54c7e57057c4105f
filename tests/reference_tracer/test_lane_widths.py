"""The core's routines written once over a lane type, at every compiled width.

The C++ core writes each routine that runs on one sample and on a pack of samples once,
over its lane type (simd.h: double, or a pack of 4 or 8 doubles), and instantiates it per
width: the scalar integrator runs width 1, the wavefront one the build's ``PACK_WIDTH``.
Every lane does width 1's operations in its order, so each width must give width 1's
results bit for bit. The probes run each width on the same inputs (``probe.LANE_WIDTHS``,
``reference_tracer/cpp/bindings.cpp``: a testing seam) and compare every lane with width 1.
"""
import numpy as np
import pytest

import reference_tracer as rt
from mitsuba_scenes import SUITE, get_scene
from reference_tracer import probe
from reference_tracer.probe import core_scene

PACK_WIDTHS = (4, 8)  # LANE_WIDTHS above 1 (test_the_compiled_widths_are_one_and_the_packs)


def test_the_compiled_widths_are_one_and_the_packs():
    assert probe.LANE_WIDTHS == (1, 4, 8)
    assert probe.PACK_WIDTH in probe.LANE_WIDTHS


def _light_sampling_inputs(scene):
    """Reference points and uniforms for light sampling: points all over and beyond the
    scene, on a quad light's plane, at its corners (where the sampled point can be the
    reference point itself: distance 0) and behind it; on, inside and just outside a
    sphere light (area sampling there, cone sampling outside)."""
    rng = np.random.default_rng(7)
    n = 4001  # not a multiple of any pack width: the last pack is partial
    refs = rng.uniform(-700.0, 1300.0, (n, 3))
    u = rng.random((n, 3))
    lights = [s for s in scene.shapes if isinstance(s, rt.Quad) and isinstance(s.material, rt.DiffuseLight)]
    special = []
    for q in lights:
        Q, a, b = (np.asarray(x, dtype=float) for x in (q.Q, q.u, q.v))
        normal = np.cross(a, b) / np.linalg.norm(np.cross(a, b))
        for p in (Q, Q + a, Q + b, Q + a + b, Q + 0.5 * a + 0.5 * b):
            special += [p, p + normal, p - normal, p + 1e-9 * normal]
    spheres = [s for s in scene.shapes if isinstance(s, rt.Sphere) and isinstance(s.material, rt.DiffuseLight)]
    for sph in spheres:
        c, r = np.asarray(sph.center, dtype=float), float(sph.radius)
        dirs = rng.normal(size=(600, 3))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        scale = rng.choice([0.0, 0.3, 0.999, 1.0, 1.0, 1.0, 1.0 + 1e-12, 1.5], size=(600, 1))
        special += list(c + r * scale * dirs)
    if special:
        refs[: len(special)] = special
        u[: len(special), 1:] = 0.0  # the sampled point is Q: at the corner Q, distance 0
        if spheres:  # random uniforms for the sphere points (u = 0 is the pole)
            u[len(special) - 600 * len(spheres): len(special)] = rng.random((600 * len(spheres), 3))
    return np.ascontiguousarray(refs), np.ascontiguousarray(u), bool(lights)


@pytest.mark.parametrize("width", PACK_WIDTHS)
@pytest.mark.parametrize("name", SUITE)
def test_light_samples_at_every_width_equal_width_one(name, width):
    # LightSampler::sample_pack: the quad light of every Cornell box, the sphere lights of
    # `furnace` (inside: by area) and `glossy_plates` (outside: the cone), sample()'s
    # bodies on the pack (Quad::point, sphere_point, area_sample); the other scenes' lights
    # sample() lane by lane. Each sample must be sample()'s, the failed ones included.
    scene = get_scene(name)
    core = core_scene(scene)
    refs, u, has_quad_light = _light_sampling_inputs(scene)
    one, wide = core.sample_lights(refs, u, width=1), core.sample_lights(refs, u, width=width)
    assert one["valid"].any() or not has_quad_light
    for key in ("valid", "delta", "wi", "pdf", "dist", "pdf_all", "radiance"):
        assert np.array_equal(one[key], wide[key]), key


def test_an_uncompiled_width_is_refused():
    core = core_scene(get_scene("cornell_box"))
    with pytest.raises(ValueError, match="LANE_WIDTHS"):
        core.sample_lights(np.zeros((1, 3)), np.zeros((1, 3)), width=2)


def _shapes_scene():
    """Spheres (one with inward normals, one tiny and far) and quads (a wall, a tilted one,
    a thin sliver), each tested alone by ``shape_hits``."""
    cam = rt.Camera(lookfrom=(0, 0, -5), lookat=(0, 0, 0), width=4, height=4)
    white = rt.Lambertian(0.5)
    shapes = [rt.Sphere((0, 0, 0), 1.0, white), rt.Sphere((0.5, -0.2, 1.0), 0.7, white, flip_normals=True),
              rt.Sphere((40.0, 3.0, -7.0), 1e-3, white),
              rt.Quad((-1, -1, 2), (2, 0, 0), (0, 2, 0), white), rt.Quad((0, -2, -1), (1, 1, 0.5), (-0.3, 0.2, 1.5), white),
              rt.Quad((-3, 0, 0), (6, 0, 0), (0, 1e-9, 0), white)]
    return rt.Scene(camera=cam, shapes=shapes)


def _shape_rays():
    """Rays from all around and from inside the spheres, toward the shapes and anywhere,
    parallel to a quad's plane, along its edges and through a sphere's centre, with finite
    and infinite reach."""
    rng = np.random.default_rng(11)
    n = 3001  # not a multiple of any pack width
    o = rng.uniform(-4.0, 4.0, (n, 3))
    targets = rng.uniform(-1.5, 1.5, (n, 3))
    d = targets - o
    d[::3] = rng.normal(size=(len(d[::3]), 3))
    o[:200] *= 0.2  # inside the unit sphere
    d[200:300, 2] = 0.0  # parallel to the first quad's plane
    o[300:400] = [-1.0, -1.0, 2.0] + rng.uniform(0, 1, (100, 1)) * [2.0, 0.0, 0.0] - d[300:400]  # its edge
    o[400:450] = [0.0, 0.0, 0.0] - d[400:450]  # through the sphere's centre at t = 1
    d[450:500] = [40.0, 3.0, -7.0] + rng.uniform(-2e-3, 2e-3, (50, 3)) - o[450:500]  # at the tiny far sphere
    t_max = np.where(rng.random(n) < 0.5, np.inf, rng.uniform(0.0, 3.0, n))
    return (np.ascontiguousarray(o), np.ascontiguousarray(d), np.ascontiguousarray(t_max))


@pytest.mark.parametrize("width", PACK_WIDTHS)
def test_sphere_and_quad_hits_at_every_width_equal_width_one(width):
    # Sphere::hit and Quad::hit, the closest-hit batches' tests of the wavefront integrator
    # (intersect_pack) and the scalar ones (intersect), and a sphere's hit point
    # (Sphere::surface_lanes): every lane's hit, t, point and normal must be width 1's.
    core = core_scene(_shapes_scene())
    o, d, t_max = _shape_rays()
    one, wide = core.shape_hits(o, d, t_max, width=1), core.shape_hits(o, d, t_max, width=width)
    assert one["hit"].shape == (len(o), 6)
    assert one["hit"].any(axis=0).all() and not one["hit"].all(axis=0).any()  # each shape hit, and missed
    assert np.array_equal(one["hit"], wide["hit"])
    assert np.isfinite(one["t"][one["hit"] == 1]).all()
    assert np.array_equal(one["t"], wide["t"])
    # Sphere::surface_lanes: the hit point re-projected onto the sphere and its normal.
    assert np.array_equal(one["point"], wide["point"], equal_nan=True)
    assert np.array_equal(one["normal"], wide["normal"], equal_nan=True)


def _grid_mesh_scene():
    """A bumpy 8x8 grid of 128 triangles (shared edges and vertices) and a degenerate one."""
    rng = np.random.default_rng(5)
    xs, ys = np.meshgrid(np.linspace(-1, 1, 9), np.linspace(-1, 1, 9))
    v = np.stack([xs.ravel(), ys.ravel(), 0.1 * rng.standard_normal(81)], axis=1)
    f = []
    for j in range(8):
        for i in range(8):
            a, b, c, d = j * 9 + i, j * 9 + i + 1, (j + 1) * 9 + i, (j + 1) * 9 + i + 1
            f += [(a, b, d), (a, d, c)]
    f.append((0, 1, 2))  # collinear: degenerate, never hit
    cam = rt.Camera(lookfrom=(0, 0, -5), lookat=(0, 0, 0), width=4, height=4)
    return rt.Scene(camera=cam, shapes=[rt.Mesh(v, np.array(f), rt.Lambertian(0.5))]), v


def test_triangle_hits_of_a_block_equal_one_triangle_at_a_time():
    # intersect_watertight_lanes: one triangle (intersect_watertight: single rays, the brute
    # force) and a block of four (intersect_watertight4: every traversal's leaves) must
    # find the same nearest hit, ties at shared edges and vertices included.
    scene, v = _grid_mesh_scene()
    core = core_scene(scene)
    rng = np.random.default_rng(2)
    n = 3000
    o = rng.uniform(-1.5, 1.5, (n, 3)) + [0.0, 0.0, -3.0]
    targets = np.concatenate([v[rng.integers(0, len(v), n // 3)],  # through vertices
                              0.5 * (v[rng.integers(0, len(v), n // 3)] + v[rng.integers(0, len(v), n // 3)]),
                              rng.uniform(-1.2, 1.2, (n - 2 * (n // 3), 3))])
    d = np.ascontiguousarray(targets - o)
    o = np.ascontiguousarray(o)
    one, four = core.triangle_hits(o, d, width=1), core.triangle_hits(o, d, width=4)
    assert (one["index"] >= 0).mean() > 0.5
    assert np.array_equal(one["index"], four["index"])
    assert np.array_equal(one["t"], four["t"])


@pytest.mark.parametrize("width", PACK_WIDTHS)
@pytest.mark.parametrize("alpha", [0.001, 0.05, 0.3, 1.0])
def test_rough_conductor_samples_at_every_width_equal_width_one(alpha, width):
    # rough_conductor.h's plain GGX (sample_visible_normal, ggx_d, smith_g1) on packs, as
    # the wavefront integrator samples rough metal (rough_conductor_pack.h): each valid
    # sample must be width 1's, from views at normal, oblique and grazing incidence and
    # from below the surface (never valid), and on the uniforms' edges.
    rng = np.random.default_rng(4)
    edges = np.array([0.0, 0.25, 0.5, np.nextafter(1.0, 0.0)])
    u = np.concatenate([np.stack(np.meshgrid(edges, edges, edges), axis=-1).reshape(-1, 3), rng.random((3001, 3))])
    u = np.ascontiguousarray(u)
    albedo = np.array([0.9, 0.6, 0.3])
    for wo in ([0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.3, -0.95, 0.05], [0.0, 0.6, -0.8]):
        wo = np.array(wo) / np.linalg.norm(wo)
        one = probe.bsdf_sample("rough_conductor", wo, u, albedo, alpha)
        wide = probe.bsdf_sample("rough_conductor", wo, u, albedo, alpha, width=width)
        assert np.array_equal(one["valid"], wide["valid"])
        ok = one["valid"] == 1
        assert ok.any() == (wo[2] > 0)
        for key in ("wi", "weight", "pdf"):
            assert np.array_equal(one[key][ok], wide[key][ok]), key


@pytest.mark.parametrize("width", PACK_WIDTHS)
@pytest.mark.parametrize("count", [3, 5, 20])
def test_several_sphere_lights_choose_as_width_one(count, width):
    """Packs of light samples among several sphere lights choose each lane's light by counting
    the cumulative powers below its uniform (DiscreteDistribution::sample_lanes), up to 16
    lights, and by sample()'s search beyond: the same light as width 1 in every lane, the
    uniforms that land exactly on a boundary between two lights' shares, a light of zero
    radiance and u0 just below 1 included."""
    shapes = [rt.Sphere((2.0 * i, 0.0, 0.0), 0.5, rt.DiffuseLight(0.0 if i == 1 else 1.0)) for i in range(count)]
    shapes.append(rt.Quad((-5, -1, -5), (40, 0, 0), (0, 0, 10), rt.Lambertian(0.5)))
    camera = rt.Camera(lookfrom=(0, 5, 12), lookat=(0, 0, 0), vup=(0, 1, 0), vfov=60.0, width=8, height=8)
    core = core_scene(rt.Scene(camera=camera, shapes=shapes))
    rng = np.random.default_rng(11)
    n = 3001
    refs = np.column_stack([rng.uniform(-2, 2 * count, n), rng.uniform(0.6, 4, n), rng.uniform(-3, 3, n)])
    u = rng.random((n, 3))
    u[:257, 0] = np.concatenate([np.arange(256) / 256.0, [np.nextafter(1.0, 0.0)]])  # boundaries of equal shares
    one, wide = core.sample_lights(refs, u, width=1), core.sample_lights(refs, u, width=width)
    valid = one["valid"].astype(bool)
    points = refs[valid] + one["wi"][valid] * one["dist"][valid][:, None]
    chosen = set(np.round(points[:, 0] / 2.0).astype(int))  # the sampled point's sphere
    assert len(chosen) == count - 1 and 1 not in chosen  # every light but the dark one
    for key in ("valid", "wi", "pdf", "dist", "pdf_all", "radiance"):
        assert np.array_equal(one[key], wide[key]), key
