"""Every invalid input raises ValueError naming the field; nothing reaches C++ unchecked."""
import math

import numpy as np
import pytest

import reference_tracer as rt

MAT = rt.Lambertian(0.5)


def camera(**kw):
    args = dict(lookfrom=(0, 0, -3), lookat=(0, 0, 0), vup=(0, 1, 0), vfov=40, width=8, height=8)
    args.update(kw)
    return rt.Camera(**args)


def scene(shapes=(), **kw):
    return rt.Scene(camera=camera(), shapes=list(shapes), **kw)


@pytest.mark.parametrize("make, field", [
    (lambda: rt.Sphere((0, 0, 0), -1.0, MAT), "Sphere.radius"),
    (lambda: rt.Sphere((0, 0, 0), 0.0, MAT), "Sphere.radius"),
    (lambda: rt.Sphere((0, math.nan, 0), 1.0, MAT), "Sphere.center"),
    (lambda: rt.Sphere((0, 0, 0), math.inf, MAT), "Sphere.radius"),
    (lambda: rt.Quad((0, 0, 0), (1, 0, 0), (2, 0, 0), rt.DiffuseLight(1)), "Quad light has zero area"),
    (lambda: rt.Quad((0, 0, 0), (0, 0, 0), (0, 1, 0), MAT), "zero area"),
    (lambda: rt.Quad((0, 0, 0), (1, 0, math.nan), (0, 1, 0), MAT), "Quad.u"),
    (lambda: rt.Box((0, 0, 0), (1, 0, 1), MAT), "Box.pmin"),
    (lambda: rt.Triangle((0, 0, 0), (1, 1, 1), (2, 2, 2), MAT), "Triangle has zero area"),
    (lambda: rt.Mesh(np.zeros((3, 3)), [[0, 1, 3]], MAT), "Mesh.faces: face 0 is"),
    (lambda: rt.Mesh(np.zeros((3, 3)), [[0, 1, -1]], MAT), "Mesh.faces: face 0 is"),
    (lambda: rt.Mesh([[0, 0, 0], [1, 0, math.nan], [0, 1, 0]], [[0, 1, 2]], MAT), "Mesh.vertices"),
    (lambda: rt.Mesh(np.zeros((3, 2)), [[0, 1, 2]], MAT), "Mesh.vertices"),
    (lambda: rt.Mesh(np.zeros((3, 3)), [[0.5, 1, 2]], MAT), "Mesh.faces"),
    (lambda: rt.Sphere((0, 0, 0), 1.0, "white"), "Sphere.material"),
    (lambda: rt.Sphere((0, 0, 0), 1.0, MAT).scale(0), "scale.factor"),
    (lambda: rt.Sphere((0, 0, 0), 1.0, MAT).rotate((0, 0, 0), 10), "rotate.axis"),
    (lambda: rt.Sphere((0, 0, 0), 1.0, MAT).translate((0, math.inf, 0)), "translate.offset"),
])
def test_shape_validation(make, field):
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        make()


@pytest.mark.parametrize("make, field", [
    (lambda: rt.Lambertian((0.5, 1.2, 0.5)), "Lambertian.albedo"),
    (lambda: rt.Lambertian(-0.1), "Lambertian.albedo"),
    (lambda: rt.Lambertian((0.5, math.nan, 0.5)), "Lambertian.albedo"),
    (lambda: rt.Lambertian((0.5, 0.5)), "Lambertian.albedo"),
    (lambda: rt.Metal(0.5, fuzz=2.0), "Metal.fuzz"),
    (lambda: rt.Metal(1.5), "Metal.albedo"),
    (lambda: rt.Dielectric(math.nan), "Dielectric.ior"),
    (lambda: rt.Dielectric(0.0), "Dielectric.ior"),
    (lambda: rt.Dielectric(1.5, fresnel="fast"), "Dielectric.fresnel"),
    (lambda: rt.RoughConductor(0.5, alpha=0.0), "RoughConductor.alpha"),
    (lambda: rt.RoughConductor(0.5, alpha=math.inf), "RoughConductor.alpha"),
    (lambda: rt.DiffuseLight(-1.0), "DiffuseLight.radiance"),
    (lambda: rt.DiffuseLight(math.inf), "DiffuseLight.radiance"),
    (lambda: rt.DiffuseLight(1.0, albedo=1.5), "DiffuseLight.albedo"),
])
def test_material_validation(make, field):
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        make()


@pytest.mark.parametrize("kw, field", [
    (dict(vfov=0), "Camera.vfov"),
    (dict(vfov=180), "Camera.vfov"),
    (dict(width=0), "Camera.width"),
    (dict(height=2.5), "Camera.height"),
    (dict(lookfrom=(0, 0, 0)), "Camera.lookat must differ"),
    (dict(vup=(0, 0, 1)), "Camera.vup"),
    (dict(lookfrom=(0, math.nan, -3)), "Camera.lookfrom"),
])
def test_camera_validation(kw, field):
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        camera(**kw)


@pytest.mark.parametrize("kw, field", [
    (dict(max_depth=0), "Scene.max_depth"),
    (dict(max_depth=-2), "Scene.max_depth"),
    (dict(max_depth=2.0), "Scene.max_depth"),
    (dict(rr_depth=0), "Scene.rr_depth"),
    (dict(background=(1, -1, 0)), "Scene.background"),
    (dict(background=math.nan), "Scene.background"),
    (dict(shapes=["sphere"]), r"Scene.shapes\[0\]"),
])
def test_scene_validation(kw, field):
    shapes = kw.pop("shapes", ())
    with pytest.raises(ValueError, match=field.replace(".", r"\.") if "[" not in field else field):
        scene(shapes, **kw)


def test_scene_camera_must_be_camera():
    with pytest.raises(ValueError, match="Scene.camera"):
        rt.Scene(camera="cam", shapes=[])


@pytest.mark.parametrize("kw, field", [
    (dict(spp=0), "spp"),
    (dict(spp=-4), "spp"),
    (dict(spp=2.5), "spp"),
    (dict(strategy="bdpt"), "strategy"),
    (dict(seed=-1), "seed"),
    (dict(seed=2**64), "seed"),
    (dict(threads=0), "threads"),
    (dict(triangle_test="moller"), "triangle_test"),
    (dict(progress=3), "progress"),
])
def test_render_validation(kw, field):
    s = scene([rt.Sphere((0, 0, 0), 1, MAT)], background=1.0)
    args = dict(spp=1)
    args.update(kw)
    with pytest.raises(ValueError, match=field):
        rt.render(s, **args)


def test_render_rejects_non_scene():
    with pytest.raises(ValueError, match="scene must be"):
        rt.render("cornell_box", spp=1)


@pytest.mark.parametrize("shapes, cam, what", [
    ([rt.Sphere((1e31, 0, 0), 1, MAT)], {}, r"shapes\[0\] \(Sphere\)"),
    ([rt.Sphere((0, 0, 0), 1, MAT), rt.Sphere((0, 0, 0), 2e30, MAT)], {}, r"shapes\[1\] \(Sphere\)"),
    ([rt.Quad((0, 0, 0), (3e30, 0, 0), (0, 1, 0), MAT)], {}, r"shapes\[0\] \(Quad\)"),
    ([rt.Mesh([(0, 0, 0), (1, 0, 0), (0, 5e30, 0)], [(0, 1, 2)], MAT)], {}, r"shapes\[0\] \(Mesh\)"),
    ([rt.Sphere((0, 0, 0), 1, MAT).translate((0, 0, -2e30))], {}, r"shapes\[0\] \(Sphere\)"),
    ([rt.Sphere((0, 0, 0), 1, MAT)], dict(lookfrom=(0, 0, -1e31)), "the camera"),
])
def test_render_rejects_coordinates_beyond_single_precision_headroom(shapes, cam, what):
    # The BVH tests boxes in single precision (wide_bvh.h); a world-space coordinate
    # beyond 1e30 is refused with the shape named, never rendered wrong.
    s = rt.Scene(camera=camera(**cam), shapes=shapes, background=1.0)
    with pytest.raises(ValueError, match=what + r".*beyond 1e\+30"):
        rt.render(s, spp=1)


def test_render_accepts_large_but_representable_coordinates():
    # 1e29 is within the limit: the sphere fills the view.
    cam = camera(lookfrom=(0, 0, -3e29), lookat=(0, 0, 0))
    s = rt.Scene(camera=cam, shapes=[rt.Sphere((0, 0, 0), 1e29, rt.DiffuseLight(1.0))])
    img = rt.render(s, spp=1).mean
    assert np.all(np.isfinite(img)) and img[4, 4, 0] == pytest.approx(1.0)


def test_replaced_scene_does_not_render_with_the_original_core():
    """``dataclasses.replace`` is the idiomatic way to vary a scene: the new scene must get
    its own compiled core, not the original's (it rendered the old scene's image)."""
    import dataclasses

    import numpy as np

    cam = rt.Camera(lookfrom=(0, 0, -3), lookat=(0, 0, 0), width=4, height=4)
    scene = rt.Scene(camera=cam, shapes=[rt.Sphere((0, 0, 0), 1, rt.Lambertian(0.5))], background=1.0,
                     max_depth=8)
    deep = rt.render(scene, spp=8, strategy="mis", seed=1, threads=1)
    shallow_scene = dataclasses.replace(scene, max_depth=1)
    assert shallow_scene._core_cache is not scene._core_cache and not shallow_scene._core_cache
    shallow = rt.render(shallow_scene, spp=8, strategy="mis", seed=1, threads=1)
    # max_depth 1: only the background seen directly; the sphere is black
    assert not np.array_equal(deep.mean, shallow.mean)
    assert float(shallow.mean[2, 2].max()) == 0.0
