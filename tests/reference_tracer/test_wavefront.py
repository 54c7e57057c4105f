"""The wavefront integrator against the scalar one (the reference implementation).

Both draw each pixel's random numbers in the same order and do the same arithmetic, so
their images must agree bit for bit, not only statistically: every suite scene and
strategy, both Russian-roulette configurations, the tail moments, the ray counts. The
batched intersection queries it relies on must equal the one-ray-at-a-time ones exactly.
"""
import dataclasses

import numpy as np
import pytest

import reference_tracer as rt
from mitsuba_scenes import SUITE, get_scene
from reference_tracer.probe import core_scene


def _assert_same_render(a, b):
    assert np.array_equal(a.mean, b.mean)
    assert np.array_equal(a.variance, b.variance)
    assert a.rays == b.rays
    assert a.nonfinite_samples == b.nonfinite_samples
    if a.moments is not None:
        for field in ("m2", "m3", "m4", "max"):
            assert np.array_equal(getattr(a.moments, field), getattr(b.moments, field)), field


@pytest.mark.parametrize("strategy", rt.STRATEGIES)
@pytest.mark.parametrize("name", SUITE)
def test_wavefront_image_equals_scalar_bit_for_bit(name, strategy):
    # 20x18: tiles and lanes do not divide the image; 6 spp: pixels end at different
    # bounces, so lanes refill while others are mid-path.
    scene = get_scene(name, width=20, height=18)
    a, b = (rt.render(scene, spp=6, strategy=strategy, seed=11, threads=2, moments=True, integrator=i)
            for i in ("scalar", "wavefront"))
    _assert_same_render(a, b)


@pytest.mark.parametrize("rr_depth", [None, 1, 5])
@pytest.mark.parametrize("name", ["cornell_box", "glossy_plates", "cornell_mesh"])
def test_wavefront_equals_scalar_with_and_without_roulette(name, rr_depth):
    scene = dataclasses.replace(get_scene(name, width=16, height=16), rr_depth=rr_depth)
    a, b = (rt.render(scene, spp=8, strategy="mis", seed=5, threads=1, integrator=i)
            for i in ("scalar", "wavefront"))
    _assert_same_render(a, b)


@pytest.mark.parametrize("size", [(1, 1), (3, 2), (40, 1)])
@pytest.mark.parametrize("spp", [1, 3])
def test_wavefront_on_images_smaller_than_its_batch(size, spp):
    # Fewer pixels than lanes: most lanes never get one.
    scene = get_scene("cornell_box", width=size[0], height=size[1])
    a, b = (rt.render(scene, spp=spp, strategy="mis", seed=2, threads=3, integrator=i)
            for i in ("scalar", "wavefront"))
    _assert_same_render(a, b)



@pytest.mark.parametrize("triangles", [3000, 300_000])
@pytest.mark.parametrize("size", [(3, 2), (24, 16)])
def test_wavefront_equals_scalar_on_mesh_renders(triangles, size):
    # A torus lit by the background: 3000 triangles go through the mesh's own tree behind
    # the packs' box test, 300,000 (over 2^18) through the scene's tree; either way the
    # batch's rays that may meet the mesh are traced together, interleaved, closest hits
    # and shadow rays. 3x2 pixels leave most packs partly empty.
    from benchmarks.speed.rays import torus_mesh

    v, f = torus_mesh(triangles)
    camera = rt.Camera(lookfrom=(0.0, -3.0, 2.0), lookat=(0.0, 0.0, 0.0), vup=(0.0, 0.0, 1.0), vfov=40.0,
                       width=size[0], height=size[1])
    scene = rt.Scene(camera=camera, shapes=[rt.Mesh(v, f, rt.Lambertian(0.5))], max_depth=8,
                     background=(1.0, 1.0, 1.0))
    for strategy in ("cosine", "mis"):
        a, b = (rt.render(scene, spp=3, strategy=strategy, seed=4, threads=2, integrator=i)
                for i in ("scalar", "wavefront"))
        _assert_same_render(a, b)
        assert 0.0 < a.mean.min() < a.mean.max()  # the torus in front of a lit background


def _coplanar_grids(spheres):
    """Two coplanar square meshes triangulated differently (3x3 and 16x16 cells, their
    triangles' edges crossing), so that many rays meet two triangles at exactly one
    distance, and `spheres` far-away spheres (over 32 primitives: beyond the packs' limit)."""
    def grid(n, flip):
        xs = np.linspace(-1.0, 1.0, n + 1)
        v = np.array([(x, y, 0.0) for y in xs for x in xs])
        faces = []
        for j in range(n):
            for i in range(n):
                a = j * (n + 1) + i
                b, c, d = a + 1, a + n + 1, a + n + 2
                faces += [(a, b, c), (b, d, c)] if flip else [(a, b, d), (a, d, c)]
        return v, np.array(faces)
    camera = rt.Camera(lookfrom=(0.02, 0.03, 1.0), lookat=(0.0, 0.0, 0.0), vup=(0, 1, 0), vfov=60.0, width=32,
                       height=32)
    shapes = [rt.Mesh(*grid(3, False), rt.Lambertian(0.2)), rt.Mesh(*grid(16, True), rt.Lambertian(0.8))]
    shapes += [rt.Sphere((100.0 + 3 * i, 100.0, 100.0), 0.5, rt.Lambertian(0.5)) for i in range(spheres)]
    return rt.Scene(camera=camera, shapes=shapes, max_depth=2, background=(1.0, 1.0, 1.0))


@pytest.mark.parametrize("spheres", [10, 40])
def test_exact_ties_between_triangles_go_as_in_the_scalar_integrator(spheres):
    # Of two triangles hit at one distance, the batches report the one Scene::intersect
    # does, through the mesh's own tree (10 spheres) and beyond the packs' limit (40),
    # where packets of coherent rays would order a node's children otherwise.
    scene = _coplanar_grids(spheres)
    side = np.linspace(-0.9, 0.9, 128)
    ys, xs = np.meshgrid(side, side, indexing="ij")
    origins = np.ascontiguousarray(np.stack([xs.ravel(), ys.ravel(), np.ones(xs.size)], axis=1))
    dirs = np.ascontiguousarray(np.tile([0.01, 0.02, -1.0], (xs.size, 1)))
    c = core_scene(scene)
    one, batch = (c.intersect(origins, dirs, wavefront=w, batch=False) for w in (False, True))
    assert (one["prim"] >= 0).all()
    for key in ("t", "prim", "point", "normal"):
        assert np.array_equal(one[key], batch[key]), key
    a, b = (rt.render(scene, spp=1, strategy="cosine", seed=4, threads=1, integrator=i)
            for i in ("scalar", "wavefront"))
    _assert_same_render(a, b)

def test_wavefront_beyond_the_batched_primitive_limit():
    # 80 quads and 10 spheres: more than the scene tests four rays at a time against
    # (kBatchTestLimit 32), so the batches go through the scene's tree, interleaved.
    rng = np.random.default_rng(3)
    shapes = [rt.Quad(Q=tuple(rng.uniform(-2, 2, 3)), u=tuple(rng.uniform(-1, 1, 3)), v=tuple(rng.uniform(-1, 1, 3)),
                      material=rt.Lambertian(albedo=(0.6, 0.5, 0.4))) for _ in range(80)]
    shapes += [rt.Sphere(center=tuple(rng.uniform(-2, 2, 3)), radius=0.3, material=rt.Lambertian(albedo=(0.5, 0.5, 0.5)))
               for _ in range(10)]
    shapes.append(rt.Sphere(center=(0.0, 4.0, 0.0), radius=0.5, material=rt.DiffuseLight(radiance=(20.0, 20.0, 20.0))))
    scene = rt.Scene(shapes=shapes, background=(0.5, 0.6, 0.7),  # lit from everywhere
                     camera=rt.Camera(lookfrom=(0, 0, 8), lookat=(0, 0, 0), vup=(0, 1, 0), vfov=40, width=16, height=12))
    for strategy in ("cosine", "mis"):
        a, b = (rt.render(scene, spp=4, strategy=strategy, seed=9, threads=2, integrator=i)
                for i in ("scalar", "wavefront"))
        _assert_same_render(a, b)
        assert a.mean.max() > 0


def _mixed_vertices_scene():
    # What the wavefront's vertex queue separates (wavefront.h, VertexQueue): diffuse vertices
    # that take a light sample and scatter in packs, two-sided ones seen from the back,
    # one-sided ones seen from the back (no scatter), a light that also reflects, rough
    # metal beside them (a light sample in the queue, its estimate and scatter lane by
    # lane), a mirror (neither); and light sampling that does not run in packs: two quad
    # lights, a triangle light and the background.
    white = rt.Lambertian(albedo=(0.7, 0.7, 0.7))
    shapes = [
        rt.Quad(Q=(-3, 0, -3), u=(0, 0, 6), v=(6, 0, 0), material=white),  # floor, facing up
        # Back wall and right wall, both facing away from the camera and the room.
        rt.Quad(Q=(-3, 0, -3), u=(0, 4, 0), v=(6, 0, 0), material=rt.Lambertian(albedo=(0.6, 0.3, 0.2), two_sided=True)),
        rt.Quad(Q=(3, 0, -3), u=(0, 4, 0), v=(0, 0, 6), material=rt.Lambertian(albedo=(0.2, 0.5, 0.3))),
        rt.Quad(Q=(-1, 3.9, -1), u=(2, 0, 0), v=(0, 0, 0.5), material=rt.DiffuseLight((8, 8, 8), albedo=(0.5, 0.5, 0.5))),
        rt.Quad(Q=(-1, 3.9, 1), u=(2, 0, 0), v=(0, 0, 0.5), material=rt.DiffuseLight((4, 6, 8))),
        rt.Triangle(a=(-2.9, 0.5, 2), b=(-2.9, 0.5, 0), c=(-2.9, 2.5, 1), material=rt.DiffuseLight((6, 3, 2))),
        rt.Sphere(center=(-1, 1, 0), radius=0.8, material=rt.RoughConductor(albedo=(0.9, 0.8, 0.6), alpha=0.3)),
        rt.Sphere(center=(1.2, 0.7, 0.5), radius=0.6, material=rt.Metal(albedo=(0.9, 0.9, 0.9))),
        rt.Sphere(center=(0.5, 0.4, -1.5), radius=0.4, material=white),
    ]
    return rt.Scene(shapes=shapes, background=(0.2, 0.25, 0.3),
                    camera=rt.Camera(lookfrom=(0.5, 2, 7), lookat=(0, 1, 0), vup=(0, 1, 0), vfov=60, width=24, height=18))


def _plastics_scene():
    # Plastics run the scalar steps lane by lane in the wavefront integrator (its packs are
    # for Lambertian vertices): smooth plastic, whose samples are a Dirac lobe's or not, one
    # sample at a time (the MIS weight of the emitter hit next and the ray's offset follow
    # the sample), one-sided and two-sided, beside rough plastics of both distributions and
    # Lambertian walls that do run in packs.
    shapes = list(_mixed_vertices_scene().shapes[:6])
    shapes += [
        rt.Sphere(center=(-1, 1, 0), radius=0.8, material=rt.Plastic((0.2, 0.4, 0.7), specular_reflectance=0.9)),
        rt.Sphere(center=(1.2, 0.7, 0.5), radius=0.6, material=rt.RoughPlastic(0.6, alpha=0.05, nonlinear=True)),
        rt.Sphere(center=(0.5, 0.4, -1.5), radius=0.4, material=rt.RoughPlastic((0.7, 0.2, 0.1), alpha=0.4,
                                                                                distribution="ggx", int_ior=1.9)),
        rt.Quad(Q=(-2.5, 0.3, 1.5), u=(0, 1.5, 0), v=(1.5, 0, -0.5), material=rt.Plastic(0.3, two_sided=True)),
    ]
    scene = _mixed_vertices_scene()
    return rt.Scene(shapes=shapes, background=scene.background, camera=scene.camera)


def _smooth_scene():
    # Smooth-shaded meshes (vertex normals) of every material kind, where shading and
    # geometric normals disagree: the offsets along the geometric normal, the reference
    # points and shadow-ray origins of the queue's packs, an emitting mesh sampled by its
    # shading normal (with a quad light: light sampling lane by lane), and flat shapes
    # between them (a lane's interaction switching between smooth and flat hits).
    rng = np.random.default_rng(5)
    t = (1 + 5 ** 0.5) / 2
    v = np.array([(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
                  (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)], dtype=float)
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6),
         (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10),
         (8, 6, 7), (9, 8, 1)]
    bent = v + rng.normal(scale=0.5, size=v.shape)       # far from the faces' normals
    floor_v = [(-3, 0, -3), (-3, 0, 3), (3, 0, 3), (3, 0, -3)]
    lean = [(0.5, 1, 0.2), (-0.4, 1, 0), (0, 1, -0.6), (0.3, 1, 0.3)]
    shapes = [
        rt.Mesh(floor_v, [(0, 1, 2), (0, 2, 3)], rt.Lambertian((0.7, 0.7, 0.7)), normals=lean),
        rt.Mesh(v, f, rt.Lambertian((0.8, 0.5, 0.3)), normals=bent).translate((-1.5, 1, 0)),
        rt.Mesh(v, f, rt.Lambertian((0.3, 0.5, 0.8), two_sided=True), normals=bent).scale(0.6).translate((0, 0.7, -1)),
        rt.Mesh(v, f, rt.RoughConductor((0.9, 0.8, 0.6), alpha=0.3), normals=v).scale(0.7).translate((1.4, 0.8, 0)),
        rt.Mesh(v, f, rt.Dielectric(1.5), normals=bent).scale(0.5).translate((0.2, 0.6, 1.2)),
        rt.Mesh(v, f, rt.Metal((0.9, 0.9, 0.9)), normals=v).scale(0.4).translate((-0.4, 0.5, 1.6)),
        rt.Mesh(v, f, rt.DiffuseLight((6, 5, 4), albedo=(0.5, 0.5, 0.5)), normals=bent).scale(0.4).translate((0, 3, 0)),
        rt.Quad((-2.5, 3.5, -2), (1, 0, 0), (0, 0, 1), rt.DiffuseLight((3, 3, 3))),
        rt.Sphere((2, 0.4, 1.5), 0.4, rt.Lambertian((0.5, 0.5, 0.5))),
    ]
    return rt.Scene(shapes=shapes, background=(0.1, 0.12, 0.15),
                    camera=rt.Camera(lookfrom=(0.5, 2.5, 6), lookat=(0, 0.8, 0), vup=(0, 1, 0), vfov=55, width=24,
                                     height=18))


#: Hand-made scenes whose vertices take the integrators' less common paths, and the seed each renders at.
_CASES = {"mixed vertices": (_mixed_vertices_scene, 13), "plastics": (_plastics_scene, 17),
          "shading normals": (_smooth_scene, 17)}


@pytest.mark.parametrize("rr_depth", [None, 2])
@pytest.mark.parametrize("strategy", rt.STRATEGIES)
@pytest.mark.parametrize("case", _CASES)
def test_wavefront_equals_scalar_on_hand_made_scenes(case, strategy, rr_depth):
    build, seed = _CASES[case]
    scene = dataclasses.replace(build(), rr_depth=rr_depth)
    a, b = (rt.render(scene, spp=8, strategy=strategy, seed=seed, threads=2, moments=True, integrator=i)
            for i in ("scalar", "wavefront"))
    _assert_same_render(a, b)
    assert a.mean.max() > 0 and a.nonfinite_samples == 0


@pytest.mark.parametrize("integrator", rt.INTEGRATORS)
def test_each_integrator_is_deterministic_whatever_the_thread_count(integrator):
    scene = get_scene("glossy_plates", width=24, height=20)
    images = [rt.render(scene, spp=4, strategy="mis", seed=7, threads=t, integrator=integrator) for t in (1, 2, 5)]
    for r in images[1:]:
        _assert_same_render(r, images[0])


def test_the_pack_width_is_the_machines():
    from reference_tracer import probe

    assert probe.PACK_WIDTH in (4, 8)


@pytest.mark.parametrize("bad", ["Scalar", "simd", "", None, 0])
def test_unknown_integrator_is_refused(bad):
    scene = get_scene("cornell_box", width=4, height=4)
    with pytest.raises(ValueError, match="integrator must be one of"):
        rt.render(scene, spp=1, integrator=bad)


def _random_rays(rng, n, scale):
    origins = rng.uniform(-scale, scale, size=(n, 3))
    dirs = rng.normal(size=(n, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    # Edge cases of the 4-lane tests: axis-parallel directions (zero components, rays
    # parallel to the walls), and a direction that is not unit length.
    dirs[::7] = (0.0, 0.0, 1.0)
    dirs[1::7] = (1.0, 0.0, 0.0)
    dirs[2::7] *= 3.0
    return origins, dirs


@pytest.mark.parametrize("name", ["cornell_box", "glossy_plates", "furnace", "cornell_glass", "cornell_mesh"])
@pytest.mark.parametrize("n", [1, 3, 4, 5, 999])
def test_batched_queries_equal_single_ray_queries(name, n):
    scene = get_scene(name, width=8, height=8)
    c = core_scene(scene)
    rng = np.random.default_rng(n)
    # Origins around the point the camera looks at, within the scene's scale.
    centre = np.asarray(scene.camera.lookat, dtype=float)
    scale = 0.3 * float(np.linalg.norm(np.subtract(scene.camera.lookfrom, centre)))
    origins, dirs = _random_rays(rng, n, scale)
    origins += centre
    one, batch = (c.intersect(origins, dirs, wavefront=w, batch=False) for w in (False, True))
    # Bit for bit, ties included: rays from inside a box of cornell_box (random origins)
    # meet its bottom face and the floor at exactly one distance, and both paths report the
    # lower id (Scene::closest_primitive).
    for key in ("t", "prim", "point", "normal"):
        assert np.array_equal(one[key], batch[key]), key
    hit = one["prim"] >= 0
    if n > 100:
        assert 0.2 < hit.mean()  # enough hits to test (glossy_plates is open: 30%)
    # Shadow rays: to just before, at and beyond each closest hit, and unbounded.
    t = np.where(hit, one["t"], 10.0 * scale)
    for t_max in (t * (1 - 1e-9), t, t * (1 + 1e-9), np.full(n, np.inf)):
        expected = c.occluded(origins, dirs, np.ascontiguousarray(t_max), wavefront=False)
        got = c.occluded(origins, dirs, np.ascontiguousarray(t_max), wavefront=True)
        assert np.array_equal(expected, got)
    blocked = c.occluded(origins, dirs, np.ascontiguousarray(t * (1 + 1e-9)), wavefront=True)
    assert np.array_equal(blocked.astype(bool), hit)


def _boxes_scene():
    """Five small boxes (30 quads, within the packs' direct limit) on a floor, one rotated."""
    grey, light = rt.Lambertian(0.5), rt.DiffuseLight((4.0, 4.0, 4.0))
    boxes = [rt.Box((x, 0.0, z), (x + 1.0, 1.0 + 0.5 * k, z + 1.0), grey)
             for k, (x, z) in enumerate([(-3.0, -3.0), (2.0, -3.0), (-3.0, 2.0), (2.0, 2.0)])]
    boxes.append(rt.Box((-0.5, 0.0, -0.5), (0.5, 2.0, 0.5), grey).rotate_y(30.0))
    floor = rt.Quad((-10.0, 0.0, 10.0), (20.0, 0.0, 0.0), (0.0, 0.0, -20.0), light)
    camera = rt.Camera(lookfrom=(0.0, 8.0, 12.0), lookat=(0.0, 0.0, 0.0), vfov=40.0, width=8, height=8)
    return rt.Scene(camera, [floor, *boxes])


def test_boxed_quad_runs_skip_no_hit():
    # The batched queries test a box's six quads only where a lane of the pack may meet
    # the box (Scene::choose_quad_runs): rays aimed at the boxes' corners, edges and faces,
    # from origins on the faces and just off them, along the faces and parallel to them,
    # must get the single-ray queries' answers bit for bit (those go through the tree).
    scene = _boxes_scene()
    c = core_scene(scene)
    rng = np.random.default_rng(7)
    corners = np.array([[x, y, z] for x in (-3.0, -2.0, 2.0, 3.0) for y in (0.0, 1.0, 1.5, 2.5)
                        for z in (-3.0, -2.0, 2.0, 3.0)])
    targets = np.concatenate([corners, corners + rng.uniform(-0.5, 0.5, corners.shape)])
    origins = np.concatenate([rng.uniform(-6.0, 6.0, (len(targets), 3)) + (0.0, 3.0, 0.0),
                              corners[rng.integers(0, len(corners), len(targets))]])
    targets = np.concatenate([targets, targets[rng.permutation(len(targets))]])
    dirs = targets - origins
    dirs[::5] = (1.0, 0.0, 0.0)  # along and parallel to the faces
    dirs[1::5] = (0.0, 0.0, -1.0)
    dirs[2::5] = (0.0, -1.0, 0.0)
    keep = np.linalg.norm(dirs, axis=1) > 0
    origins, dirs = np.ascontiguousarray(origins[keep]), np.ascontiguousarray(dirs[keep])
    one, batch = (c.intersect(origins, dirs, wavefront=w, batch=False) for w in (False, True))
    # A ray aimed at an edge meets two faces at exactly the same distance, and the tree and
    # the packs may then name different ones (either is right): the distances must agree
    # everywhere (a skipped closest hit would change one), the primitives nearly everywhere.
    assert np.array_equal(one["t"], batch["t"])
    hit = one["prim"] >= 0
    assert np.array_equal(hit, batch["prim"] >= 0)
    assert (one["prim"] == batch["prim"]).mean() > 0.9
    assert 0.3 < hit.mean() and (one["prim"][hit] >= 1).mean() > 0.3  # the boxes, not only the floor
    t = np.where(hit, one["t"], 100.0)
    for t_max in (t * (1 - 1e-9), t, t * (1 + 1e-9), np.full(len(t), np.inf)):
        expected = c.occluded(origins, dirs, np.ascontiguousarray(t_max), wavefront=False)
        got = c.occluded(origins, dirs, np.ascontiguousarray(t_max), wavefront=True)
        assert np.array_equal(expected, got)


@pytest.mark.parametrize("strategy", ["mis", "cosine"])
def test_boxed_quad_runs_render_the_scalar_image(strategy):
    scene = _boxes_scene().with_camera_size(24, 20)
    a, b = (rt.render(scene, spp=8, strategy=strategy, seed=5, threads=2, integrator=i)
            for i in ("scalar", "wavefront"))
    assert np.array_equal(a.mean, b.mean) and a.rays == b.rays


@pytest.mark.slow
def test_eight_ray_packs_give_the_same_images(tmp_path):
    # AVX-512 machines build packs of eight rays (simd.h); this machine may not have
    # AVX-512, so build the core with RT_PACK_WIDTH=8 (each 512-bit operation done as two
    # halves) and check the wavefront images against the scalar integrator there. About a
    # minute: the build.
    from build_util import build_core, run_with_core

    module = build_core(tmp_path, "-DRT_PACK_WIDTH=8")
    script = """
import numpy as np
assert core.PACK_WIDTH == 8
import reference_tracer as rt
from mitsuba_scenes import SUITE, get_scene
for name in SUITE:
    for strategy in rt.STRATEGIES:
        scene = get_scene(name, width=20, height=18)
        a, b = (rt.render(scene, spp=6, strategy=strategy, seed=11, threads=2, integrator=i)
                for i in ("scalar", "wavefront"))
        assert np.array_equal(a.mean, b.mean) and a.rays == b.rays, (name, strategy)
print("ok")
"""
    assert run_with_core(module, script).strip() == "ok"


def test_seeded_bugs_run_in_the_scalar_integrator_only():
    # The self-test's mutants (reference_tracer.testing) exist in Integrator<M> alone: a
    # mutant render asked of the wavefront integrator is refused, not silently rerouted.
    from reference_tracer.testing import mutant_core_scene, mutant_id

    core = mutant_core_scene(get_scene("cornell_box", width=4, height=4))
    k = mutant_id("two_sided_light")
    with pytest.raises(ValueError, match="scalar integrator only"):
        core.render(1, 4, 0, 1, None, False, integrator=0, mutant=k)
    core.render(1, 4, 0, 1, None, False, integrator=1, mutant=k)
    core.render(1, 4, 0, 1, None, False, integrator=0, mutant=0)  # the tracer itself: either


@pytest.mark.parametrize("warp", ["cosine_hemisphere", "concentric_disk"])
def test_packed_cosine_warp_equals_scalar_one(warp):
    # The wavefront draws the directions of a pack of diffuse vertices at once with the same
    # template as the scalar warp (warp.h: square_to_cosine_hemisphere); bit for bit on
    # random numbers and on the concentric map's special points (centre, diagonals, edges).
    from reference_tracer import probe

    rng = np.random.default_rng(3)
    edges = np.array([0.0, 0.25, 0.5, 0.75, np.nextafter(1.0, 0.0), np.nextafter(0.5, 0.0), np.nextafter(0.5, 1.0)])
    grid = np.stack(np.meshgrid(edges, edges), axis=-1).reshape(-1, 2)
    u = np.ascontiguousarray(np.concatenate([grid, rng.random((9999, 2))]))
    assert np.array_equal(probe.warp_sample(warp, u, packed=True), probe.warp_sample(warp, u))


def test_only_the_cosine_warp_has_a_packed_version():
    from reference_tracer import probe

    with pytest.raises(ValueError, match="packed"):
        probe.warp_sample("uniform_sphere", np.zeros((3, 2)), packed=True)
