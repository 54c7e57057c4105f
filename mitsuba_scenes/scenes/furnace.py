"""furnace: an analytic scene - camera inside an emitting, reflecting sphere; exact answer known.

The camera sits at the centre of a sphere whose inner surface (``flip_normals=True``)
both emits ``Le`` and reflects as a Lambertian of albedo ``rho``
(``DiffuseLight(Le, albedo=rho)``; Mitsuba: a ``diffuse`` BSDF and an ``area``
emitter on the same shape). Every pixel's radiance is exactly
``Le * (1 - rho^n) / (1 - rho)`` at ``max_depth=n`` (``Le / (1 - rho)`` for
``max_depth=-1``): see :func:`expected_radiance`. The hard case of sampling a sphere
light from inside it.

Examples
--------
>>> from mitsuba_scenes.scenes.furnace import expected_radiance
>>> expected_radiance(radiance=1.0, albedo=0.5, max_depth=2)
1.5
"""
from __future__ import annotations

import numpy as np

import reference_tracer as rt

RADIANCE = 0.5
ALBEDO = 0.8


def expected_radiance(*, radiance: float = RADIANCE, albedo: float = ALBEDO, max_depth: int = 8) -> float:
    """Exact pixel radiance of the furnace: ``Le (1 - rho^n) / (1 - rho)``.

    Parameters
    ----------
    radiance, albedo : float, keyword-only
        ``Le`` >= 0 and ``rho`` in [0, 1) (``rho = 1`` only with finite ``max_depth``).
    max_depth : int, keyword-only
        Path segments ``n`` >= 1, or -1 for unlimited.
    """
    if radiance < 0 or not 0 <= albedo <= 1:
        raise ValueError(f"need radiance >= 0 and 0 <= albedo <= 1, got {radiance}, {albedo}")
    if max_depth == -1:
        if albedo >= 1:
            raise ValueError("albedo 1 with unlimited depth has no finite radiance")
        return radiance / (1 - albedo)
    if not isinstance(max_depth, int) or max_depth < 1:
        raise ValueError(f"max_depth must be an integer >= 1 or -1, got {max_depth!r}")
    if albedo == 1:
        return radiance * max_depth
    return radiance * (1 - albedo**max_depth) / (1 - albedo)


def closed_form_image(*, width: int = 32, height: int = 32, max_depth: int = 8, radiance: float = RADIANCE,
                      albedo: float = ALBEDO, **_ignored):
    """The exact image of :func:`build` with the same parameters: every pixel
    :func:`expected_radiance` (the harness uses it as the reference, with zero variance).

    Examples
    --------
    >>> closed_form_image(width=2, height=2, max_depth=1).tolist()[0][0]
    [0.5, 0.5, 0.5]
    """
    value = expected_radiance(radiance=radiance, albedo=albedo, max_depth=max_depth)
    return np.full((height, width, 3), value, dtype=np.float32)


def build(*, width: int = 32, height: int = 32, max_depth: int = 8, rr_depth=None,
          radiance: float = RADIANCE, albedo: float = ALBEDO, radius: float = 1.0) -> rt.Scene:
    shell = rt.Sphere((0, 0, 0), radius, rt.DiffuseLight(radiance, albedo=albedo), flip_normals=True)
    cam = rt.Camera(lookfrom=(0, 0, 0), lookat=(0, 0, 1), vup=(0, 1, 0), vfov=60.0, width=width, height=height)
    return rt.Scene(camera=cam, shapes=[shell], max_depth=max_depth, rr_depth=rr_depth)
