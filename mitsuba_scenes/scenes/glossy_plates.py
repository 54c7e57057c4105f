"""glossy_plates: where MIS matters - Veach's four rough plates under four sphere lights.

A Veach-style multiple-importance-sampling scene: four RoughConductor plates (GGX,
alpha 0.005, 0.02, 0.05 and 0.2, from near to far) tilted so each reflects the row of
four sphere lights toward the camera; the lights have radii 0.05, 0.15, 0.4 and 1.0
and radiances scaled by 1/r^2, so all four emit the same power. BSDF sampling wins on
sharp plates with big lights, light sampling on rough plates with small lights; only
MIS is good everywhere. A dark diffuse backdrop closes the scene behind.

Examples
--------
>>> from mitsuba_scenes import get_scene
>>> [round(s.material.alpha, 3) for s in get_scene("glossy_plates").shapes[:4]]
[0.005, 0.02, 0.05, 0.2]
"""
from __future__ import annotations

import numpy as np

import reference_tracer as rt

ALPHAS = (0.005, 0.02, 0.05, 0.2)
LIGHT_RADII = (0.05, 0.15, 0.4, 1.0)
#: Radiance of the largest light; the others scale by (1.0 / r)^2 for equal power.
BASE_RADIANCE = 4.0
PLATE_ALBEDO = (0.85, 0.85, 0.85)
CAMERA = dict(lookfrom=(0.0, 2.0, 15.0), lookat=(0.0, -1.5, 0.0), vup=(0.0, 1.0, 0.0), vfov=34.0)
LIGHT_ROW = (0.0, 3.0, -3.0)           # y and z of the light centres: (x, 3, -3)
LIGHT_X = (-3.75, -1.25, 1.25, 3.75)
PLATE_CENTRES = ((0.0, -3.2, 4.2), (0.0, -2.5, 2.6), (0.0, -1.7, 1.1), (0.0, -0.8, -0.3))
PLATE_HALF = (4.0, 0.6)                 # half width along x, half depth across


def light_radiance(radius: float) -> float:
    """Radiance of a light of ``radius`` such that every light emits the same power."""
    return BASE_RADIANCE * (max(LIGHT_RADII) / radius) ** 2


def plates():
    """The four plates as (centre, u, v) with normal u x v bisecting camera and lights."""
    out = []
    eye, lights = np.array(CAMERA["lookfrom"]), np.array(LIGHT_ROW)
    for c in PLATE_CENTRES:
        c = np.array(c)
        to_eye = (eye - c) / np.linalg.norm(eye - c)
        to_light = (lights - c) / np.linalg.norm(lights - c)
        n = to_eye + to_light
        n[0] = 0.0
        n /= np.linalg.norm(n)
        across = np.cross(n, (1.0, 0.0, 0.0))      # in the yz plane, perpendicular to n
        u = np.array((2 * PLATE_HALF[0], 0.0, 0.0))
        v = across * 2 * PLATE_HALF[1]
        if np.dot(np.cross(u, v), n) < 0:
            v = -v
        out.append((c - u / 2 - v / 2, u, v))
    return out


def build(*, width: int = 96, height: int = 64, max_depth: int = 50, rr_depth=5) -> rt.Scene:
    shapes = [rt.Quad(Q, u, v, rt.RoughConductor(PLATE_ALBEDO, alpha=a))
              for (Q, u, v), a in zip(plates(), ALPHAS)]
    shapes += [rt.Sphere((x, LIGHT_ROW[1], LIGHT_ROW[2]), r, rt.DiffuseLight(light_radiance(r)))
               for x, r in zip(LIGHT_X, LIGHT_RADII)]
    # Backdrop: a dark diffuse wall behind everything, facing the camera.
    shapes.append(rt.Quad((-20, -10, -8), (40, 0, 0), (0, 30, 0), rt.Lambertian(0.1)))
    cam = rt.Camera(width=width, height=height, **CAMERA)
    return rt.Scene(camera=cam, shapes=shapes, max_depth=max_depth, rr_depth=rr_depth)
