"""Case ``glass``: a camera inside a glass sphere (rays start inside; total internal
reflection traps the tangential ones) against closed forms, and ior 1.0 against no glass."""
from __future__ import annotations

import numpy as np

import reference_tracer as rt
from reference_tracer.probe import camera_rays

from ..optics import fresnel_dielectric
from .probes import probe_scene
from .record import stress_case
from .ztests import image_ztest

__all__ = ["glass"]


@stress_case
def glass(*, width: int = 32, spp: int = 32, ior: float = 1.5, seed: int = 0, compare_spp: int = 128,
          compare_width: int = 24):
    """Glass: rays starting inside, total internal reflection, ior 1.0 equals no glass.

    A camera at the centre of a glass sphere in a background of 1 sees exactly ``ior^2``
    (normal incidence at every bounce; 1/eta^2 on leaving, as Mitsuba). At 0.8 of the
    radius a ray's incidence is the same at every bounce: pixels whose whole footprint
    (17 x 17 rays) is beyond the critical angle are exactly 0, those that surely leave
    exactly ``ior^2``. A diffuse sphere inside an ior-1.0 glass sphere agrees with no
    glass (:func:`image_ztest`, ``cosine`` and ``mis``).
    """
    g = rt.Dielectric(ior)
    expected = ior * ior
    nonfinite = 0
    # --- camera at the centre
    centre = rt.render(probe_scene([rt.Sphere((0, 0, 0), 1.0, g)], width=width, lookfrom=(0, 0, 0),
                                   lookat=(0.3, 0.2, 1.0), vfov=100.0, background=1.0),
                       spp=spp, strategy="mis", seed=seed, threads=2)
    nonfinite += centre.nonfinite_samples
    centre_bad = int((centre.mean != np.float32(expected)).sum())
    # --- off-centre camera: TIR
    rho = 0.8
    max_depth = 50
    off_centre = probe_scene([rt.Sphere((0, 0, 0), 1.0, g)], width=width, lookfrom=(rho, 0, 0), lookat=(rho, 0, 1),
                             vfov=100.0, background=1.0, max_depth=max_depth)
    tir = rt.render(off_centre, spp=spp, strategy="mis", seed=seed + 1, threads=2)
    nonfinite += tir.nonfinite_samples
    grid = np.linspace(0.0, 1.0, 17)   # each pixel's footprint: 17 x 17 rays
    ys, xs, gy, gx = np.meshgrid(np.arange(width), np.arange(width), grid, grid, indexing="ij")
    d = camera_rays(off_centre.camera, (xs + gx).ravel(), (ys + gy).ravel())[1].reshape(xs.shape + (3,))
    sin_inc = np.linalg.norm(np.cross([rho, 0.0, 0.0], d), axis=-1)        # R = 1
    smin, smax = sin_inc.min(axis=(-1, -2)), sin_inc.max(axis=(-1, -2))
    margin = 1e-3
    critical = 1.0 / ior
    all_tir = smin > critical + margin
    cos_max = np.sqrt(1 - np.minimum(smax + margin, 1.0) ** 2)
    all_exit = (smax + margin < critical) & (fresnel_dielectric(-cos_max, ior) ** (max_depth - 1) < 1e-12)
    tir_bad = int((tir.mean.max(axis=-1)[all_tir] != 0.0).sum())
    exit_bad = int((tir.mean[all_exit] != np.float32(expected)).sum())
    # --- ior 1.0 against no glass
    floor = rt.Quad((-4, -1.02, -4), (0, 0, 8), (8, 0, 0), rt.Lambertian(0.5))
    lamp = rt.Quad((-1, 2.5, -1), (2, 0, 0), (0, 0, 2), rt.DiffuseLight(6.0))
    inner = rt.Sphere((0.1, -0.4, 0.0), 0.55, rt.Lambertian((0.7, 0.4, 0.2)))
    shell = rt.Sphere((0.0, -0.05, 0.0), 0.95, rt.Dielectric(1.0))
    view = dict(width=compare_width, lookfrom=(0.5, 1.0, -4.0), lookat=(0.0, -0.3, 0.0), vfov=40.0, background=0.3)
    with_glass = probe_scene([floor, lamp, inner, shell], **view)
    without = probe_scene([floor, lamp, inner], **view)
    ior1 = {}
    for i, strategy in enumerate(("cosine", "mis")):
        a = rt.render(with_glass, spp=compare_spp, strategy=strategy, seed=seed + 20 + 2 * i, threads=2)
        b = rt.render(without, spp=compare_spp, strategy=strategy, seed=seed + 21 + 2 * i, threads=2)
        nonfinite += a.nonfinite_samples + b.nonfinite_samples
        ior1[strategy] = image_ztest(a.mean, a.variance, compare_spp, b.mean, b.variance, compare_spp)
    passed = (centre_bad == 0 and tir_bad == 0 and exit_bad == 0 and int(all_tir.sum()) > 0
              and int(all_exit.sum()) > 0 and nonfinite == 0 and all(z["passed"] for z in ior1.values()))
    figure = (f"inside at centre: {centre_bad} px != {expected:g}; TIR px != 0: {tir_bad}/{int(all_tir.sum())}, "
              f"exiting px != {expected:g}: {exit_bad}/{int(all_exit.sum())}; ior 1 vs none: max |Z| "
              f"{max(max(abs(x) for x in z['z_global']) for z in ior1.values()):.2f}")
    details = {"centre_pixels_wrong": centre_bad, "tir_pixels": int(all_tir.sum()), "tir_pixels_wrong": tir_bad,
               "exit_pixels": int(all_exit.sum()), "exit_pixels_wrong": exit_bad, "ior1_vs_none": ior1,
               "nonfinite_samples": nonfinite, "expected_inside": expected}
    return figure, passed, details
