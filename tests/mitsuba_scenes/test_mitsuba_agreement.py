"""Ours vs Mitsuba on tiny images: every suite scene and one tiny scene per convention.

Each test renders the same scene with our tracer (``mis``) and with Mitsuba's ``path``
integrator (per-sample RGB variance from 1-spp batches) at fixed seeds and applies
``mitsuba_stats.compare``: a Sidak-corrected per-pixel z-test plus a per-channel
whole-image z-test, each at family-wise false-positive rate 1e-3 under the normal
approximation (so at most about 2e-3 per test; the seeds are fixed, so a pass or a
failure is reproducible).
"""
from __future__ import annotations

import numpy as np
import pytest

import reference_tracer as rt
from mitsuba_scenes import get_scene, list_scenes, render_mitsuba
from mitsuba_scenes.scenes.furnace import expected_radiance
from mitsuba_stats import compare

THREADS = 2


def agree(scene, *, spp=64, seed=1):
    ours = rt.render(scene, spp=spp, strategy="mis", seed=seed, threads=THREADS)
    assert ours.nonfinite_samples == 0
    mit = render_mitsuba(scene, spp=spp, seed=seed, batches=spp, threads=THREADS)
    res = compare(ours.mean, ours.variance, spp, mit.mean, mit.variance, spp)
    return res, ours, mit


# Mitsuba 3.9.1 is biased high in the furnace (camera inside an emitting sphere):
# +0.06% .. +1.1% at max_depth=2 depending on radius and variant (many standard errors),
# while our tracer matches the closed form to 1e-7. The reference for that scene is the
# closed form (test_furnace_ours_closed_form); see test_mitsuba_furnace_closed_form.
MITSUBA_FURNACE_BIAS = "Mitsuba's sphere-emitter sampling from a point on the sphere itself is biased"


@pytest.mark.parametrize("name", [n if n != "furnace" else pytest.param(
    n, marks=pytest.mark.xfail(strict=True, reason=MITSUBA_FURNACE_BIAS)) for n in list_scenes()])
def test_suite_scene_agrees(name):
    size = dict(width=24, height=16) if name == "glossy_plates" else dict(width=20, height=20)
    res, _, _ = agree(get_scene(name, **size), spp=64, seed=7)
    assert res.ok, f"{name}: {res.message}"


# ----------------------------------------------------------------------- conventions
BLACK = rt.Lambertian(0.0)


def _cam(width=24, height=16, **kw):
    args = dict(lookfrom=(0, 0, -5), lookat=(0, 0, 0), vup=(0, 1, 0), vfov=40.0)
    args.update(kw)
    return rt.Camera(width=width, height=height, **args)


def test_camera_orientation_small_light_lands_on_same_pixel():
    # World +x is image left for this camera (right = forward x up = -x); +y is up.
    light = rt.Quad((0.9, 0.6, 0), (0.3, 0, 0), (0, 0.3, 0), rt.DiffuseLight((4, 2, 1)), flip_normals=True)
    scene = rt.Scene(camera=_cam(), shapes=[light], max_depth=1)
    res, ours, mit = agree(scene, spp=32)
    assert res.ok, res.message
    lum_o, lum_m = ours.mean.sum(-1), mit.mean.sum(-1)
    po, pm = np.unravel_index(lum_o.argmax(), lum_o.shape), np.unravel_index(lum_m.argmax(), lum_m.shape)
    assert po == pm
    assert po[0] < 8 and po[1] < 12, f"light at world (+x, +y) must be top left, got pixel {po}"


@pytest.mark.parametrize("size", [(40, 16), (16, 40)])
def test_fov_is_vertical(size):
    # Emitting strips near the top and bottom edges and left/right edges of the view.
    L = rt.DiffuseLight((1, 2, 3))
    shapes = [rt.Quad((-3, y, 0), (0, 0.1, 0), (6, 0, 0), L) for y in (-1.7, -1.0, 0.9, 1.6)]
    shapes += [rt.Quad((x, -3, 0), (0.1, 0, 0), (0, 6, 0), L) for x in (-3.0, -1.5, 1.4, 2.9)]
    scene = rt.Scene(camera=_cam(*size, vfov=42.0), shapes=shapes, max_depth=1)
    res, _, _ = agree(scene, spp=32)
    assert res.ok, res.message


def _facing_scene(flip):
    """Front and back faces of every shape kind, lit by a constant background."""
    D = rt.Lambertian((0.7, 0.5, 0.3))
    E = rt.DiffuseLight((2, 1, 0.5))
    shapes = [
        rt.Quad((-2.5, 0.3, 0), (1, 0, 0), (0, 1, 0), D, flip_normals=flip),        # faces +z: back to camera
        rt.Quad((-1.2, 0.3, 0), (0, 1, 0), (1, 0, 0), D, flip_normals=flip),        # faces -z: front
        rt.Triangle((0.2, 0.3, 0), (1.2, 0.3, 0), (0.7, 1.3, 0), E, flip_normals=flip),   # +z: back
        rt.Triangle((1.5, 0.3, 0), (2.0, 1.3, 0), (2.5, 0.3, 0), E, flip_normals=flip),   # -z: front
        rt.Mesh([[-2.5, -1.5, 0], [-1.5, -1.5, 0], [-2, -0.5, 0]], [[0, 2, 1]], D, flip_normals=flip),
        rt.Sphere((0.2, -1.0, 0), 0.5, D, flip_normals=flip),
        rt.Sphere((1.8, -1.0, 0), 0.5, E, flip_normals=flip),
        rt.Box((-1.2, -1.4, -0.3), (-0.5, -0.7, 0.3), D, flip_normals=flip).rotate_y(20),
    ]
    return rt.Scene(camera=_cam(32, 20, vfov=50.0), shapes=shapes, max_depth=3, background=(0.4, 0.5, 0.6))


def test_winding_and_one_sided_back_faces():
    res, ours, _ = agree(_facing_scene(False), spp=64)
    assert res.ok, res.message


def test_flip_normals():
    res, _, _ = agree(_facing_scene(True), spp=64)
    assert res.ok, res.message


def _object_in_room(material, *, two_sided=False, max_depth=6, background=(0.2, 0.3, 0.4)):
    lights = [rt.Quad((-1, 2.5, -1), (2, 0, 0), (0, 0, 2), rt.DiffuseLight((6, 5, 4))),
              rt.Quad((2.5, -1, -1), (0, 0, 2), (0, 2, 0), rt.DiffuseLight((0.5, 2, 1)))]
    floor = rt.Quad((-4, -1, -4), (0, 0, 8), (8, 0, 0), rt.Lambertian((0.6, 0.6, 0.6)))
    obj = rt.Sphere((0, 0, 0), 0.9, material)
    return rt.Scene(camera=_cam(24, 16, lookfrom=(0.5, 1.0, -4)), shapes=[*lights, floor, obj],
                    max_depth=max_depth, background=background)


@pytest.mark.parametrize("material", [
    rt.Metal((0.9, 0.8, 0.7)),
    rt.Dielectric(1.5),
    rt.RoughConductor((0.9, 0.8, 0.7), alpha=0.25),
    rt.RoughConductor((0.9, 0.8, 0.7), alpha=0.05, two_sided=True),
    rt.Lambertian((0.5, 0.6, 0.7), two_sided=True),
    rt.Metal((1.0, 1.0, 1.0), material="Au"),
    rt.Metal((0.9, 0.9, 0.9), eta=(0.2, 0.9, 1.1), k=(3.9, 2.4, 2.1)),
    rt.RoughConductor((1.0, 1.0, 1.0), alpha=0.25, distribution="beckmann"),
    rt.RoughConductor((1.0, 1.0, 1.0), alpha=0.1, distribution="beckmann", material="Cu"),
    rt.RoughConductor((0.9, 0.8, 0.7), alpha=0.3, material="Al"),
    rt.Plastic((0.2, 0.4, 0.7)),
    rt.Plastic((0.8, 0.3, 0.1), specular_reflectance=(0.9, 0.8, 0.5), int_ior=1.9, nonlinear=True),
    rt.Plastic((0.5, 0.6, 0.7), two_sided=True),
    rt.RoughPlastic((0.2, 0.4, 0.7)),
    rt.RoughPlastic((0.8, 0.3, 0.1), alpha=0.3, distribution="ggx", specular_reflectance=0.7, nonlinear=True),
    rt.RoughPlastic((0.5, 0.6, 0.7), alpha=0.2, int_ior=1.0, ext_ior=1.33, two_sided=True),
], ids=["mirror", "glass", "rough_conductor", "rough_conductor_sharp_twosided", "lambertian_twosided",
        "mirror_gold", "mirror_eta_k", "beckmann", "beckmann_copper", "ggx_aluminium",
        "plastic", "plastic_coloured_nonlinear", "plastic_twosided", "roughplastic",
        "roughplastic_ggx_nonlinear", "roughplastic_thin_coating_twosided"])
def test_material(material):
    res, _, _ = agree(_object_in_room(material), spp=64)
    assert res.ok, res.message


@pytest.mark.parametrize("material", [rt.Plastic((0.3, 0.5, 0.2), specular_reflectance=0.9),
                                      rt.RoughPlastic((0.3, 0.5, 0.2), alpha=0.03)], ids=["smooth", "rough"])
def test_plastic_floor_reflects_a_light(material):
    """A plastic floor seen at a grazing angle, with an area light in its mirror direction: the
    reflection of the light fills a band of pixels, reached by the (smooth: Dirac) specular
    lobe, beside the diffuse lobe lit by light sampling. Smooth: the emitter met after a
    specular sample counts with weight 1, as after a mirror."""
    floor = rt.Quad((-4, -1, -6), (0, 0, 12), (8, 0, 0), material)                      # faces up
    light = rt.Quad((-1.5, 0.8, 3.5), (0, 1.6, 0), (3, 0, 0), rt.DiffuseLight((3, 3, 2.5)))  # faces us
    scene = rt.Scene(camera=_cam(32, 20, lookfrom=(0, 0.2, -5), lookat=(0, -1, 0)), shapes=[floor, light],
                     max_depth=4, background=(0.05, 0.05, 0.08))
    res, ours, _ = agree(scene, spp=128)
    assert res.ok, res.message
    assert np.count_nonzero(ours.mean[10:].sum(axis=-1) > 0.5) >= 10   # the light's reflection, below the horizon


def test_veach_plates_of_rough_plastic():
    """The glossy_plates scene (Veach's MIS test) with Mitsuba's documentation plates:
    roughplastic, Beckmann, int_ior 2, dark blue base, alpha 0.005 to 0.2."""
    import dataclasses

    scene = get_scene("glossy_plates", width=24, height=16)
    shapes = [dataclasses.replace(s, material=rt.RoughPlastic((0.07, 0.09, 0.13), alpha=s.material.alpha,
                                                              int_ior=2.0))
              if isinstance(s.material, rt.RoughConductor) else s for s in scene.shapes]
    res, _, _ = agree(dataclasses.replace(scene, shapes=shapes), spp=64, seed=7)
    assert res.ok, res.message


def test_glass_quad_two_sided_seen_through():
    # A glass slab made of a Box: refraction in and out, total internal reflection.
    slab = rt.Box((-1, -0.6, -0.2), (1, 0.6, 0.2), rt.Dielectric(1.33)).rotate_y(25)
    scene = _object_in_room(rt.Lambertian(0.5))
    scene = rt.Scene(scene.camera, [*scene.shapes[:3], slab], max_depth=8, background=scene.background)
    res, _, _ = agree(scene, spp=64)
    assert res.ok, res.message


@pytest.mark.parametrize("max_depth", [1, 2])
def test_depth(max_depth):
    res, ours, mit = agree(get_scene("cornell_box", width=16, height=16, max_depth=max_depth), spp=64)
    assert res.ok, res.message
    if max_depth == 1:   # only the light is visible
        lit = ours.mean.sum(-1) > 0
        assert 0 < lit.sum() < lit.size / 4


@pytest.mark.parametrize("rr_depth", [None, 1, 3])
def test_russian_roulette(rr_depth):
    scene = get_scene("cornell_box", width=16, height=16, max_depth=12, rr_depth=rr_depth)
    res, _, _ = agree(scene, spp=64)
    assert res.ok, res.message


def test_constant_background():
    bg = (0.3, 0.6, 0.9)
    scene = rt.Scene(camera=_cam(), shapes=[rt.Sphere((0, 0, 0), 1.0, rt.Lambertian((0.8, 0.5, 0.2)))],
                     max_depth=4, background=bg)
    res, ours, mit = agree(scene, spp=32)
    assert res.ok, res.message
    np.testing.assert_allclose(mit.mean[0, 0], bg, rtol=1e-6)
    np.testing.assert_allclose(ours.mean[0, 0], bg, rtol=1e-6)


def _image_mean_and_se(mean, variance, spp):
    m = mean[..., 0]
    return float(m.mean()), float(np.sqrt(variance[..., 0].sum() / spp) / m.size)


@pytest.mark.parametrize("max_depth", [1, 2, 3, 8, -1])
def test_furnace_ours_closed_form(max_depth):
    """Our tracer against Le (1 - rho^n) / (1 - rho); 4.5 SE (two-sided FPR 7e-6) + float32 rounding."""
    scene = get_scene("furnace", width=8, height=8, max_depth=max_depth)
    ours = rt.render(scene, spp=64, strategy="mis", seed=3, threads=THREADS)
    exp = expected_radiance(max_depth=max_depth)
    m, se = _image_mean_and_se(ours.mean, ours.variance, 64)
    assert abs(m - exp) <= 4.5 * se + 1e-5 * exp, (m, exp, se)


def test_mitsuba_furnace_depth1_exact():
    scene = get_scene("furnace", width=8, height=8, max_depth=1)
    mit = render_mitsuba(scene, spp=16, seed=3, batches=16, threads=THREADS)
    np.testing.assert_allclose(mit.mean, expected_radiance(max_depth=1), rtol=1e-6)


@pytest.mark.xfail(strict=True, reason=MITSUBA_FURNACE_BIAS)
def test_mitsuba_furnace_closed_form():
    """Mitsuba alone against the closed form at max_depth=2 (direct light from inside the sphere)."""
    scene = get_scene("furnace", width=8, height=8, max_depth=2)
    mit = render_mitsuba(scene, spp=256, seed=3, batches=32, threads=THREADS)
    m, se = _image_mean_and_se(mit.mean, mit.variance, 256)
    assert abs(m - expected_radiance(max_depth=2)) <= 4.5 * se + 1e-5, (m, se)
