"""Mitsuba's first-hit AOVs at pixel centres (``sensor.sample_ray``, ``scene.ray_intersect``):
the distance from the camera's centre, ``si.sh_frame.n``, ``eval_diffuse_reflectance``, the
emitter's or the environment's radiance, and our index of the shape hit (matched by
bounding box; -2: a Mitsuba shape with no counterpart).
"""
from __future__ import annotations

import os

import numpy as np

import reference_tracer as rt
from mitsuba_scenes import to_mitsuba
from mitsuba_scenes.render import load_file
from mitsuba_scenes.variants import select_variant

from .compare import shape_bounds

__all__ = ["mitsuba_scene_for", "mitsuba_aovs", "match_shapes"]

#: bounding boxes match when they agree to this fraction of the scene's extent (float32)
BOX_RTOL = 1e-4


def mitsuba_scene_for(scene: rt.Scene, source=None, *, params=None, film_size=None):
    """The loaded Mitsuba scene: ``source`` (dict or XML path, its films resized to
    ``film_size`` when given: :func:`mitsuba_scenes.render.load_file`) or ``to_mitsuba(scene)``;
    no mesh merging."""
    select_variant(None)
    import mitsuba as mi  # deferred: after the variant and libLLVM are chosen (select_variant)

    if isinstance(source, (str, os.PathLike)):
        return load_file(source, params=params, film_size=film_size, optimize=False)
    if film_size is not None:
        raise ValueError("film_size applies to Mitsuba XML files only")
    return mi.load_dict(to_mitsuba(scene) if source is None else source, optimize=False)


def match_shapes(mscene, scene: rt.Scene) -> list:
    """Our shape index for each of Mitsuba's shapes (by bounding box), -2 where none matches."""
    ours = shape_bounds(scene)
    if not len(ours):
        return [-2] * len(mscene.shapes())
    extent = max(float(np.abs(ours).max()), 1e-6)
    out = []
    for sh in mscene.shapes():
        b = sh.bbox()
        box = np.concatenate([np.array(b.min, dtype=np.float64).ravel(), np.array(b.max, dtype=np.float64).ravel()])
        err = np.abs(ours - box).max(axis=1) / extent
        k = int(np.argmin(err))
        out.append(k if err[k] <= BOX_RTOL else -2)
    return out


def _arr(x, n: int, width: int) -> np.ndarray:
    """A Dr.Jit value as an (n, width) float64 array (Mitsuba gives (width, n) or (n,))."""
    a = np.array(x, dtype=np.float64)
    if a.size == width:   # a uniform value (e.g. a constant environment) comes back unbroadcast
        return np.broadcast_to(a.reshape(1, width) if width > 1 else a.reshape(1), (n, width) if width > 1 else (n,))
    if width == 1:
        return a.reshape(n)
    return (a.T if a.shape[0] == width and a.ndim == 2 else a).reshape(n, width)


def mitsuba_aovs(mscene, scene: rt.Scene, *, offset=(0.5, 0.5)) -> dict:
    """Mitsuba's AOVs through ``pixel + offset`` (default: the centres), in the form of
    :func:`reference_tracer.probe.first_hit_aovs` (shape: our indices)."""
    import drjit as dr  # deferred: after the variant and libLLVM are chosen (select_variant)
    import mitsuba as mi  # deferred: after the variant and libLLVM are chosen (select_variant)

    sensor = mscene.sensors()[0]
    w, h = (int(v) for v in sensor.film().size())
    yy, xx = np.mgrid[0:h, 0:w]
    fx, fy = (xx.ravel() + offset[0]) / w, (yy.ravel() + offset[1]) / h
    n = w * h
    eye = np.array(sensor.world_transform().translation(), dtype=np.float64).ravel()[:3]
    if mi.variant().startswith("scalar"):
        rows = [_scalar_hit(mi, mscene, sensor, float(a), float(b), eye) for a, b in zip(fx, fy)]
        t = np.array([r[0] for r in rows])
        normal, albedo, emitted = (np.array([r[k] for r in rows], dtype=np.float64).reshape(n, 3) for k in (1, 2, 3))
        ids = [r[4] for r in rows]
        shape_ids = [s.id() for s in mscene.shapes()]
    else:
        ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(fx, fy), mi.Point2f(0.5, 0.5))
        si = mscene.ray_intersect(ray)
        valid = si.is_valid()
        # distance from the camera's centre: Mitsuba's rays start on the near plane
        t = np.where(_arr(valid, n, 1) > 0, np.linalg.norm(_arr(si.p, n, 3) - eye, axis=1), np.inf)
        normal = _arr(si.sh_frame.n, n, 3)
        bsdf = si.bsdf(ray)
        diffuse = mi.has_flag(bsdf.flags(), mi.BSDFFlags.DiffuseReflection)
        albedo = _arr(dr.select(valid & diffuse, bsdf.eval_diffuse_reflectance(si, valid), 0.0), n, 3)
        emitted = _arr(si.emitter(mscene).eval(si, valid), n, 3)
        env = mscene.environment()
        if env is not None:
            miss = _arr(env.eval(si, ~valid), n, 3)
            emitted = np.where(np.isfinite(t)[:, None], emitted, miss)
        ids = np.array(dr.reinterpret_array(mi.UInt32, si.shape), dtype=np.int64).reshape(n).tolist()
        shape_ids = [int(np.array(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(s))).ravel()[0]) for s in mscene.shapes()]
    valid = np.isfinite(t)
    ours_of = dict(zip(shape_ids, match_shapes(mscene, scene)))
    shape = np.array([ours_of.get(i, -2) if v else -1 for i, v in zip(ids, valid)], dtype=np.int64)
    normal = np.where(valid[:, None], normal, 0.0)
    albedo = np.where(valid[:, None], albedo, 0.0)
    return {"t": t.reshape(h, w), "normal": normal.reshape(h, w, 3), "albedo": albedo.reshape(h, w, 3),
            "emitted": emitted.reshape(h, w, 3), "shape": shape.reshape(h, w)}


def _scalar_hit(mi, mscene, sensor, fx: float, fy: float, eye) -> tuple:
    """One pixel in ``scalar_rgb``: (t, normal, albedo, emitted, the shape's id string)."""
    ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(fx, fy), mi.Point2f(0.5, 0.5))
    si = mscene.ray_intersect(ray)
    if not bool(si.is_valid()):
        env = mscene.environment()
        em = [0.0, 0.0, 0.0] if env is None else list(np.array(env.eval(si), dtype=np.float64).ravel()[:3])
        return np.inf, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], em, -1
    bsdf = si.bsdf(ray)
    alb = (list(np.array(bsdf.eval_diffuse_reflectance(si), dtype=np.float64).ravel()[:3])
           if mi.has_flag(bsdf.flags(), mi.BSDFFlags.DiffuseReflection) else [0.0, 0.0, 0.0])
    em = si.emitter(mscene)
    emitted = [0.0, 0.0, 0.0] if em is None else list(np.array(em.eval(si), dtype=np.float64).ravel()[:3])
    return (float(np.linalg.norm(np.array(si.p, dtype=np.float64).ravel() - eye)),
            list(np.array(si.sh_frame.n, dtype=np.float64).ravel()), alb, emitted, si.shape.id())
