"""The catalogue of sampling routines under test (:data:`ROUTINES`, :func:`select`): every
routine of the tracer that draws a direction, with the parameters that change its
distribution. What each entry checks: README.md here, "What is tested"; the runner:
:mod:`.runner`.
"""
from __future__ import annotations

import math

import numpy as np

import reference_tracer as rt

from ..constants import LUMINANCE_WEIGHTS
from ..optics import fresnel_dielectric
from .pearson import DEFAULT_RESOLUTION
from .probes import BsdfProbe, LightProbe, direction, frame, fresnel_schlick, warp
from .runner import Routine

__all__ = ["ROUTINES", "select"]

_LUM = np.asarray(LUMINANCE_WEIGHTS)


def _warp(name, domain, param=0.0, cos_range=None, params=()):
    def make():
        sample, pdf = warp(name, param)
        return {"sample": sample, "pdf": pdf, "domain": domain, "dims": 2, "cos_range": cos_range}
    return Routine(f"warp.{name}", tuple(params), "warp", make)


#: Mitsuba's default coating of its plastics: polypropylene in air.
PLASTIC_ETA = 1.49 / 1.000277


def _bsdf(material, theta, alpha=None, resolution=DEFAULT_RESOLUTION, *, coating=None, albedo=(0.8, 0.6, 0.4),
          domain="hemisphere"):
    """``coating``: a plastic's options (``eta``, ``specular``, ``nonlinear``), or a rough
    dielectric's ``eta``, also shown in the label. ``domain``: where the directions lie
    (``'sphere'`` for a BSDF that transmits; ``theta`` > 90 puts wo below the surface).
    The smooth ``plastic`` is a mixed routine: its diffuse samples against pdf() (its specular
    ones count as failed there), its specular ones counted against Ps = F sw / (F sw + (1 - F)(1 - sw)),
    F from :func:`benchmarks.optics.fresnel_dielectric`, sw = mean(ks) / (mean(rho) + mean(ks)) (Mitsuba's weight)."""
    coating = dict(coating or {})
    params = (("theta_o", theta),) + ((("alpha", alpha),) if alpha is not None else ()) + tuple(coating.items())

    def make():
        wo = direction(theta, 40.0)
        probe = BsdfProbe(material, wo, param=alpha or 0.0, albedo=albedo, coating=coating)
        spec = {"probe": probe, "sample": probe.sample, "pdf": probe.pdf, "domain": domain, "dims": 3,
                "resolution": resolution}
        if material == "plastic":
            ks = np.broadcast_to(np.asarray(coating.get("specular", 1.0), dtype=np.float64), (3,))
            F = fresnel_dielectric(float(wo[2]), coating.get("eta", PLASTIC_ETA))
            sw = ks.mean() / (np.mean(albedo) + ks.mean())
            spec.update(F=F, p_specular=F * sw / (F * sw + (1.0 - F) * (1.0 - sw)), specular=ks)
        return spec
    return Routine(f"bsdf.{material}", params, "mixed" if material == "plastic" else "bsdf", make)


def _lobes(material, ior, theta, inside=False):
    params = (("ior", ior), ("theta_o", theta), ("side", "inside" if inside else "outside"))

    def make():
        wo = direction(180.0 - theta if inside else theta, 25.0)
        fresnel = fresnel_schlick if material == "dielectric_schlick" else fresnel_dielectric
        return {"probe": BsdfProbe(material, wo, param=ior), "F": fresnel(float(wo[2]), ior)}
    return Routine(f"lobes.{material}", params, "lobes", make)


def _polygon_cap(corners, margin=0.02):
    """A function (ref) -> (rotation with +z from ``ref`` toward the polygon's centre, the cos
    theta range of a cap holding every direction toward its edges plus a margin)."""
    v = np.asarray(corners, float)
    t = np.linspace(0.0, 1.0, 400)[:, None]
    boundary = np.concatenate([(1 - t) * v[i] + t * v[(i + 1) % len(v)] for i in range(len(v))])

    def cap(ref):
        rot = frame(v.mean(axis=0) - ref)
        d = boundary - ref
        cos = (d / np.linalg.norm(d, axis=1, keepdims=True)) @ rot[2]
        return rot, (max(-1.0, float(cos.min()) - margin), 1.0)
    return cap


def _light(label, shapes, ref, *, background=0.0, cap=None, params=(), densities=None, lights=(), deltas=None):
    """``shapes`` and ``lights`` (those that are not shapes: an EnvMap, delta lights) seen from ``ref``.
    ``cap``: None (the whole sphere), or a function (ref) -> (rotation, cos_range).
    ``densities``: None (the directions' density is ``light_pdf``), or a function (ref) ->
    (true, reported): the density of the directions drawn and the one ``light_pdf`` must
    report, each a function of (m, 3) world directions (a smooth emitter's).
    ``deltas``: a function (ref) -> the delta lights' expected samples, ``(name, wi,
    radiance, pmf)`` each (``runner._delta_checks``)."""
    def make():
        r = np.asarray(ref, float)
        rot, cos_range = cap(r) if cap else (np.eye(3), None)
        probe = LightProbe(shapes, r, background=background, rotation=rot, lights=tuple(lights))
        emitters = sum(1 for s in shapes if s.material.emits) + (1 if background > 0 else 0) + len(lights)
        spec = {"probe": probe, "sample": probe.sample, "pdf": probe.pdf, "domain": "sphere", "dims": 3,
                "cos_range": cos_range, "single": emitters == 1}
        if deltas is not None:
            spec["deltas"] = deltas(r)
        if densities is not None:
            true, reported = densities(r)
            spec["pdf"] = lambda dirs: true(np.asarray(dirs) @ rot)
            spec["reported"] = reported
        return spec
    return Routine(f"light.{label}", tuple(params), "light", make)


def _smooth_triangle_densities(vertices, normals):
    """For a triangle light with vertex normals, seen from ``ref``: (the density of the
    directions light sampling draws, the density it reports), as functions of unit world
    directions. A direction meets the triangle at p, barycentrics b, shading normal
    n_s = normalize(sum b_i n_i): both vanish unless -d . n_s > 0 (the side test);
    there the drawn density is dist^2 / (|d . n_g| area) (points uniform by area) and the
    reported one Mitsuba's dist^2 / (-d . n_s area)."""
    a, b, c = (np.asarray(x, float) for x in vertices)
    n = np.asarray(normals, float)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    e1, e2 = b - a, c - a
    g = np.cross(e1, e2)
    area = 0.5 * np.linalg.norm(g)
    g = g / np.linalg.norm(g)

    def densities(ref):
        def at(dirs):
            d = np.asarray(dirs, float)
            with np.errstate(divide="ignore", invalid="ignore"):
                cos_g = d @ g
                t = ((a - ref) @ g) / cos_g
                p = ref + t[:, None] * d
                dp = p - a
                d11, d12, d22 = e1 @ e1, e1 @ e2, e2 @ e2
                d1, d2 = dp @ e1, dp @ e2
                den = d11 * d22 - d12 * d12
                b1, b2 = (d22 * d1 - d12 * d2) / den, (d11 * d2 - d12 * d1) / den
                b0 = 1.0 - b1 - b2
                ns = b0[:, None] * n[0] + b1[:, None] * n[1] + b2[:, None] * n[2]
                ns /= np.linalg.norm(ns, axis=1, keepdims=True)
                cos_s = -np.einsum("ij,ij->i", ns, d)
                hit = (t > 0) & (b0 >= 0) & (b1 >= 0) & (b2 >= 0) & (cos_s > 0) & np.isfinite(t)
                dist2 = t * t
                true = np.where(hit, dist2 / (np.abs(cos_g) * area), 0.0)
                reported = np.where(hit, dist2 / (cos_s * area), 0.0)
            return true, reported
        return (lambda dirs: at(dirs)[0]), (lambda dirs: at(dirs)[1])
    return densities


def _catalogue() -> tuple:
    routines = [
        _warp("uniform_hemisphere", "hemisphere"),
        _warp("cosine_hemisphere", "hemisphere"),
        _warp("uniform_sphere", "sphere"),
        _warp("concentric_disk", "disk"),
    ]
    # the cone on a cap exactly its size (a whole hemisphere / sphere at 1 and 2)
    for omc in (1e-3, 0.3, 1.0, 2.0):
        routines.append(_warp("uniform_cone", "sphere", omc, None if omc >= 2 else (1.0 - omc, 1.0),
                              params=(("1-cos_max", omc),)))
    routines += [_bsdf("lambertian", theta) for theta in (30, 85)]
    routines += [_bsdf(m, theta, alpha) for m in ("rough_conductor", "rough_conductor_beckmann")
                 for alpha in (0.1, 0.3, 0.6, 1.0) for theta in (0, 30, 60, 85)]
    routines += [_bsdf(m, theta, alpha) for m in ("rough_plastic", "rough_plastic_beckmann")
                 for alpha in (0.1, 0.3, 0.7) for theta in (0, 30, 60, 85)]
    routines += [_bsdf("rough_plastic_beckmann", 45, 0.2, coating={"nonlinear": True}),
                 _bsdf("rough_plastic", 60, 0.3, coating={"eta": 1.9, "specular": (0.9, 0.5, 0.2)}),
                 _bsdf("rough_plastic_beckmann", 30, 0.3, coating={"eta": 0.75}),   # coating thinner than outside
                 _bsdf("rough_plastic", 70, 0.05, coating={"nonlinear": True}, albedo=(0.1, 0.9, 0.3))]
    # rough glass over the whole sphere, wo outside (theta < 90) and inside (> 90: 110 is
    # beyond the critical angle of 1.5, most microfacets reflect totally); twice the cells
    # along cos theta, so that each hemisphere is binned as finely as the others' one
    sphere_cells = (2 * DEFAULT_RESOLUTION[0], DEFAULT_RESOLUTION[1])
    routines += [_bsdf(m, theta, alpha, sphere_cells, coating={"eta": 1.5}, domain="sphere")
                 for m in ("rough_dielectric", "rough_dielectric_beckmann")
                 for alpha in (0.1, 0.3, 0.7) for theta in (0, 45, 80, 110, 160)]
    routines += [_bsdf("rough_dielectric", 60, 0.2, sphere_cells, coating={"eta": 0.7}, domain="sphere"),
                 _bsdf("rough_dielectric_beckmann", 130, 0.4, sphere_cells, coating={"eta": 0.7}, domain="sphere"),
                 _bsdf("rough_dielectric", 30, 1.0, sphere_cells, coating={"eta": 2.4}, domain="sphere")]
    routines += [_bsdf("plastic", theta) for theta in (0, 30, 60, 85)]
    routines += [_bsdf("plastic", 45, coating={"nonlinear": True}),
                 _bsdf("plastic", 60, coating={"eta": 1.9, "specular": (0.9, 0.5, 0.2)}),
                 _bsdf("plastic", 30, coating={"eta": 0.75})]
    routines += [_lobes("dielectric", 1.5, theta) for theta in (0, 45, 80)]
    routines += [_lobes("dielectric", 1.5, theta, inside=True) for theta in (20, 60)]   # 60: total reflection
    routines += [_lobes("dielectric", 1.33, 60), _lobes("dielectric", 0.7, 30), _lobes("dielectric", 0.7, 50),
                 _lobes("dielectric_schlick", 1.5, 60)]                                 # ior 0.7 at 50: TIR

    light = rt.DiffuseLight(1.0)
    quad = [rt.Quad((-1.0, 1.0, -1.0), (2.0, 0.0, 0.0), (0.0, 0.0, 2.0), light)]        # faces -y
    quad_cap = _polygon_cap([(-1.0, 1.0, -1.0), (1.0, 1.0, -1.0), (1.0, 1.0, 1.0), (-1.0, 1.0, 1.0)])
    tri = [(-1.0, 1.0, -1.0), (1.0, 1.0, -1.0), (0.0, 1.0, 1.0)]                          # faces -y
    sphere = [rt.Sphere((0.0, 0.0, 0.0), 1.0, light)]
    inward = [rt.Sphere((0.0, 0.0, 0.0), 1.0, light, flip_normals=True)]

    def sphere_cap(r):  # the cone the unit sphere at the origin subtends, and a margin
        d = float(np.linalg.norm(r))
        cos_max = math.sqrt(1.0 - 1.0 / (d * d))
        return frame(-r), (cos_max - 0.02 * (1.0 - cos_max), 1.0)

    # vertex normals leaning up to ~40 degrees off the triangle's -y: seen from below, every
    # point faces the reference; from beside, part of the triangle faces away by its shading
    # normal (no samples there) while its geometry faces the point
    smooth_normals = [(0.6, -1.0, 0.0), (-0.3, -1.0, 0.5), (0.0, -1.0, -0.8)]
    smooth_triangle = [rt.Mesh(tri, [[0, 1, 2]], light, normals=smooth_normals)]
    smooth_densities = _smooth_triangle_densities(tri, smooth_normals)
    mixed = [rt.Quad((-2.0, 1.5, -1.0), (1.5, 0.0, 0.0), (0.0, 0.0, 1.5), rt.DiffuseLight(2.0)),
             rt.Triangle((1.0, -1.0, 1.5), (2.0, 1.0, 1.5), (0.5, 1.0, 1.5), rt.DiffuseLight((1.0, 3.0, 0.5))),
             rt.Sphere((0.5, -1.2, -1.0), 0.4, rt.DiffuseLight(5.0))]
    routines += [
        _light("quad", quad, (0.3, 0.4, -0.2), params=(("ref", "0.6 below"),)),
        _light("quad", quad, (2.0, 0.5, 0.3), cap=quad_cap, params=(("ref", "beside, 0.5 below"),)),
        _light("triangle", [rt.Triangle(*tri, light)], (0.2, 0.3, 0.1), params=(("ref", "0.7 below"),)),
        _light("smooth_triangle", smooth_triangle, (0.2, 0.3, 0.1), densities=smooth_densities,
               params=(("ref", "0.7 below"), ("normals", "leaning"))),
        _light("smooth_triangle", smooth_triangle, (-2.0, 0.85, 0.2), cap=_polygon_cap(tri),
               densities=smooth_densities, params=(("ref", "beside, 0.15 below"), ("normals", "leaning"))),
        _light("sphere", sphere, (0.9, -0.6, -1.0), cap=sphere_cap, params=(("ref", "outside, d=1.48 r"),)),
        _light("sphere", sphere, (2.4, 0.0, -3.2), cap=sphere_cap, params=(("ref", "outside, d=4 r"),)),
        _light("sphere", inward, (0.3, -0.2, 0.4), params=(("ref", "inside, inward normals"),)),
        _light("sphere", inward, (0.0, 0.0, 1.0), cap=lambda r: (frame(-r), (-0.02, 1.0)),
               params=(("ref", "on the surface, inward normals"),)),
        _light("scene", mixed, (0.0, 0.0, 0.0), background=0.2,
               params=(("emitters", "quad+sphere+background+triangle seen from behind"),)),
    ]
    routines += _envmap_routines()
    return tuple(routines)


def _envmap_image(seed: int, shape, sun=None) -> np.ndarray:
    """A test environment: texels of luminance spread over two decades (a few black), and
    optionally a "sun" of radiance 200 at texel ``sun`` (row, column)."""
    rng = np.random.default_rng(seed)
    img = rng.uniform(0.0, 1.0, (*shape, 3)) ** 3 * 2.0
    img[rng.random(shape) < 0.05] = 0.0
    if sun is not None:
        img[sun] = (200.0, 180.0, 150.0)
    return img


def _envmap_density(env):
    """The density of an EnvMap's light sampling stated independently of the tracer (README.md here),
    a function of (m, 3) world directions: the map's cells between texel centres (columns wrapping
    around, rows from pole to pole) weigh their four corners' mean luminance; a direction's density
    is its cell's weight over the sum of weight times solid angle."""
    px = np.asarray(env.pixels, dtype=np.float64)
    h, w = px.shape[:2]
    lum = px @ _LUM
    cell = 0.25 * (lum[:-1] + np.roll(lum[:-1], -1, axis=1) + lum[1:] + np.roll(lum[1:], -1, axis=1))
    cos = np.cos(np.arange(h) * math.pi / (h - 1))
    total = float((cell * ((2 * math.pi / w) * (cos[:-1] - cos[1:]))[:, None]).sum())
    rot = np.asarray(env.to_world)

    def pdf(dirs):
        d = np.asarray(dirs, dtype=np.float64) @ rot            # the map's frame: R^T d
        u = np.mod(np.arctan2(d[:, 0], -d[:, 2]) / (2 * math.pi), 1.0)
        v = np.arccos(np.clip(d[:, 1] / np.linalg.norm(d, axis=1), -1.0, 1.0)) / math.pi
        j = np.mod(np.floor(u * w - 0.5).astype(np.int64), w)
        k = np.minimum(np.floor(v * (h - 1)).astype(np.int64), h - 2)
        return cell[k, j] / total
    return pdf


def _lum(rgb) -> float:
    return float(np.asarray(rgb) @ _LUM)


def _envmap_routines() -> list:
    """The environment map alone (its distribution: cells of four texels, uniform in solid
    angle; rotated, mirrored, a tiny padded map whose cells span quarter spheres), and
    scenes of every kind of light (delta lights' samples checked by ``runner._delta_checks``,
    the rest by the chi-square test against ``light_pdf``)."""
    tilt = [[0.6, 0.0, 0.8], [0.64, 0.6, -0.48], [-0.48, 0.8, 0.36]]   # a rotation
    mirror = [[-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]     # a reflection

    def env(shape, sun=None, seed=3, to_world=None):
        return rt.EnvMap(_envmap_image(seed, shape, sun), to_world=to_world)

    def stated(e):   # the independent density, as both the drawn and the reported one
        pdf = _envmap_density(e)
        return lambda ref: (pdf, pdf)

    maps = [(env((12, 24), sun=(3, 17), to_world=tilt), (0.0, 0.0, 0.0),
             (("map", "12x24, a sun"), ("to_world", "rotation"))),
            (env((9, 16), seed=5, to_world=mirror), (0.3, -2.0, 5.0), (("map", "9x16"), ("to_world", "reflection"))),
            (rt.EnvMap([[[1.0, 0.2, 0.1], [0.1, 0.3, 2.0]]]), (0.0, 0.0, 0.0),
             (("map", "1x2, padded to 3x2: cells of quarter spheres, one across u = 0"),))]

    # Every light of the mixed scene, and what its delta lights' samples must be from ref.
    big = rt.Sphere((0.0, 0.0, 0.0), 3.0, rt.Lambertian(0.5))        # the scene's bounds: R = 3 sqrt(3)
    quad = rt.Quad((-1.0, 1.0, -1.0), (2.0, 0.0, 0.0), (0.0, 0.0, 2.0), rt.DiffuseLight((2.0, 1.0, 0.5)))
    quad_weight = 4.0 * _lum(quad.material.radiance)
    point = rt.PointLight((1.0, 0.5, 1.5), (3.0, 2.0, 1.0))
    spot = rt.SpotLight((-1.0, -1.5, 0.5), (0.8, 1.0, -0.3), (40.0, 30.0, 20.0), cutoff_angle=50.0, beam_width=20.0)
    sun = rt.DirectionalLight((0.3, -1.0, 0.2), (1.5, 1.4, 1.2))

    def spot_power(light):   # lights.h: 2 pi (1 - (sin c - sin b) / (c - b)) luminance(I), over pi
        c, b = math.radians(light.cutoff_angle), math.radians(light.beam_width)
        return 2.0 * _lum(light.intensity) * (1.0 - (math.sin(c) - math.sin(b)) / (c - b))

    def mixed_deltas(ref):
        weights = {"quad": quad_weight, "point": 4.0 * _lum(point.intensity), "spot": spot_power(spot),
                   "directional": 27.0 * _lum(sun.irradiance)}
        total = sum(weights.values())
        pmf = {k: 0.5 * w / total for k, w in weights.items()}   # the environment takes half
        out = []
        for name, light in (("point", point), ("spot", spot)):
            d = np.asarray(light.position) - ref
            dist2 = float(d @ d)
            wi = d / math.sqrt(dist2)
            falloff = 1.0 if light is point else float(light.falloff(-wi @ np.asarray(light.direction)))
            out.append((name, wi, np.asarray(light.intensity) * (falloff / dist2), pmf[name]))
        out.append(("directional", -np.asarray(sun.direction), np.asarray(sun.irradiance), pmf["directional"]))
        return out

    # A projector of a bitmap, one of a constant and a textured spot beside the quad, all
    # aimed near the reference point (each lights it; off the image's centre).
    pref = np.array([0.2, -0.3, 0.1])
    bitmap = rt.Bitmap(np.random.default_rng(5).random((4, 6, 3)) + 0.1)
    projectors = [rt.ProjectorLight((0.5, 2.5, 2.0), pref + (0.1, 0.05, 0.0) - (0.5, 2.5, 2.0), bitmap, fov=50,
                                    scale=2.0),
                  rt.ProjectorLight((-1.0, 2.0, 1.0), pref - (0.1, 0.0, 0.1) - (-1.0, 2.0, 1.0), (1.0, 2.0, 3.0),
                                    fov=60, up=(0, 0, 1))]
    tspot = rt.SpotLight((1.0, 2.0, -1.0), pref + (0.05, 0.0, 0.1) - (1.0, 2.0, -1.0), (20.0, 15.0, 10.0),
                         cutoff_angle=40.0, beam_width=30.0,
                         texture=rt.Checkerboard(1.0, 0.2, to_uv=np.diag([5.0, 5.0, 1.0])))

    def projector_deltas(ref):
        def projector_weight(p):   # lights.h: luminance(scale E) mean(texture) 4 tan^2(x_fov / 2) / aspect
            e = (np.ones(3) if p.textured else np.asarray(p.irradiance)) * p.scale
            mean = p.irradiance.mean() if p.textured else 1.0
            return _lum(e) * mean * p.image_area()
        weights = {"quad": quad_weight, "projector_bitmap": projector_weight(projectors[0]),
                   "projector_constant": projector_weight(projectors[1]),
                   "spot_texture": spot_power(tspot) * tspot.texture.mean()}
        total = sum(weights.values())
        out = []
        for name, light in (("projector_bitmap", projectors[0]), ("projector_constant", projectors[1]),
                            ("spot_texture", tspot)):
            d = np.asarray(light.position) - ref
            out.append((name, d / np.linalg.norm(d), light.arriving(ref[None, :])[0], weights[name] / total))
        return out

    return [
        *(_light("envmap", [], ref, lights=[e], densities=stated(e), params=params) for e, ref, params in maps),
        _light("scene_projector", [big, quad], tuple(pref), lights=[*projectors, tspot], deltas=projector_deltas,
               params=(("lights", "quad+projector(bitmap)+projector(constant)+spot(texture)"),)),
        _light("scene_envmap", [big, quad], tuple(pref), lights=[env((8, 16), sun=(2, 5), seed=7), point, spot, sun],
               deltas=mixed_deltas, params=(("lights", "envmap+quad+point+spot+directional"),)),
    ]


#: Every routine of the catalogue, in table order.
ROUTINES: tuple = _catalogue()


def select(patterns=None) -> tuple:
    """Routines whose label starts with any of ``patterns`` (all when None or empty)."""
    if not patterns:
        return ROUTINES
    chosen = tuple(r for r in ROUTINES if any(r.label.startswith(p) for p in patterns))
    unknown = [p for p in patterns if not any(r.label.startswith(p) for r in ROUTINES)]
    if unknown:
        raise ValueError(f"no routine matches {', '.join(map(repr, unknown))} "
                         f"(names start with warp., bsdf., lobes., light.)")
    return chosen
