"""Case ``light_sampling``: light sampling where its pdfs degenerate."""
from __future__ import annotations

import math

import numpy as np

import reference_tracer as rt
from reference_tracer.probe import core_scene

from .probes import contiguous, probe_scene
from .record import stress_case
from .ztests import image_ztest, z_check

__all__ = ["light_sampling", "triangle_solid_angle", "quad_solid_angle"]


def triangle_solid_angle(ref, a, b, c) -> np.ndarray:
    """Solid angle of triangle ``a, b, c`` seen from (3,) or (N, 3) ``ref`` (Van Oosterom and
    Strackee 1983). An octant of the unit sphere from its centre:

    >>> bool(np.isclose(triangle_solid_angle((0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1))[0], np.pi / 2))
    True
    """
    r = np.atleast_2d(np.asarray(ref, dtype=np.float64))
    A, B, C = (np.asarray(x, dtype=np.float64) - r for x in (a, b, c))
    la, lb, lc = (np.linalg.norm(x, axis=1) for x in (A, B, C))
    num = np.abs(np.einsum("ij,ij->i", A, np.cross(B, C)))
    den = la * lb * lc + np.einsum("ij,ij->i", A, B) * lc + np.einsum("ij,ij->i", A, C) * lb \
        + np.einsum("ij,ij->i", B, C) * la
    return 2.0 * np.arctan2(num, den)


def quad_solid_angle(ref, Q, u, v) -> np.ndarray:
    """Solid angle of the parallelogram ``Q + s u + t v`` seen from ``ref``."""
    Q, u, v = (np.asarray(x, dtype=np.float64) for x in (Q, u, v))
    return triangle_solid_angle(ref, Q, Q + u, Q + u + v) + triangle_solid_angle(ref, Q, Q + u + v, Q + v)


def _reference_points() -> list:
    """The probed points: (name, emitter, point, closed-form solid angle of its front side)."""
    Q, U, V = np.array([-0.5, 1.0, -0.5]), np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0])
    quad = rt.Quad(Q, U, V, rt.DiffuseLight(1.0))                 # normal -y: emits downward
    normal = np.array([0.0, -1.0, 0.0])
    r_s = 0.5

    def closed_quad(ref):
        if (ref - Q) @ normal <= 0:   # on the plane or behind: nothing of the front is seen
            return 0.0
        return float(quad_solid_angle(ref, Q, U, V)[0])

    refs_quad = {
        "quad: below (front)": np.array([0.2, 0.3, 0.1]),
        "quad: grazing, 1e-9 below the plane, beside": np.array([1.5, 1.0 - 1e-9, 0.2]),
        "quad: grazing, 1e-6 below the plane, beside": np.array([-1.2, 1.0 - 1e-6, -0.9]),
        "quad: on the light": np.array([0.1, 1.0, 0.2]),
        "quad: on its corner": Q.copy(),
        "quad: on its plane, outside": np.array([2.0, 1.0, 0.3]),
        "quad: behind": np.array([0.1, 1.5, 0.0]),
    }
    sphere_out = rt.Sphere((0, 0, 0), r_s, rt.DiffuseLight(1.0))
    sphere_in = rt.Sphere((0, 0, 0), r_s, rt.DiffuseLight(1.0), flip_normals=True)
    on_surface = r_s * np.array([0.6, 0.0, 0.8])

    def closed_sphere(ref, inward):
        dc2 = sum(c * c for c in map(float, ref))   # as the core computes it, to pick the same branch
        if dc2 <= r_s * r_s:   # the core's branch: inside or on the sphere -> area sampling
            return 4 * np.pi if inward else 0.0
        if inward:
            return 0.0
        sin2 = r_s * r_s / dc2
        return 2 * np.pi * sin2 / (1 + math.sqrt(1 - sin2))

    refs_sphere = {
        "sphere: outside": (sphere_out, np.array([0.0, 0.0, -2.0]), False),
        "sphere: grazing, 1e-9 outside": (sphere_out, on_surface * (1 + 1e-9), False),
        "sphere: on the surface": (sphere_out, on_surface, False),
        "sphere: inside, facing out": (sphere_out, np.array([0.1, 0.2, 0.0]), False),
        "sphere: inside, facing in (centre)": (sphere_in, np.array([0.0, 0.0, 0.0]), True),
        "sphere: inside, facing in (0.6 r)": (sphere_in, np.array([0.0, 0.3, 0.0]), True),
    }
    jobs = [(k, quad, ref, closed_quad(ref)) for k, ref in refs_quad.items()]
    jobs += [(k, shp, ref, closed_sphere(ref, inward)) for k, (shp, ref, inward) in refs_sphere.items()]
    return jobs


def _check_point(shape: rt.Shape, ref, exact: float, samples: int, rng) -> dict:
    """E[valid / pdf] of light samples from ``ref`` against ``exact``, their pdfs' finiteness, and
    ``light_pdf`` in uniformly random directions against the probability of a valid sample."""
    core = core_scene(probe_scene([shape]))
    refs = contiguous(np.repeat(ref[None], samples, axis=0))
    s = core.sample_lights(refs, contiguous(rng.random((samples, 3))))
    valid = s["valid"].astype(bool)
    pdf = s["pdf"]
    nonfinite = int((~np.isfinite(pdf)).sum() + (~np.isfinite(s["pdf_all"])).sum()
                    + (~np.isfinite(s["wi"])).sum() + (valid & ~(pdf > 0)).sum())
    chk = z_check(np.where(valid, 1.0 / np.where(valid, pdf, 1.0), 0.0), exact)
    lp = core.light_pdf(refs, contiguous(rng.normal(size=(samples, 3))))
    nonfinite += int((~np.isfinite(lp)).sum() + (lp < 0).sum())
    # Only where uniform directions hit the light often enough to estimate the mass.
    mass = z_check(4 * np.pi * lp, float(valid.mean())) if exact * samples >= 400 * np.pi \
        or (exact == 0 and not valid.any()) else None
    # pdf of the procedure equals pdf_all for one emitter (valid samples)
    mismatch = int((valid & ~np.isclose(pdf, s["pdf_all"], rtol=1e-6, atol=0)).sum())
    chk.update(valid_fraction=float(valid.mean()), nonfinite=nonfinite, pdf_mass=mass, pdf_all_mismatch=mismatch)
    return chk


def _light_renders(width: int, spp: int, seed: int) -> tuple:
    """Every strategy against ``cosine`` (:func:`image_ztest`), and the NaN/Inf samples, on a floor
    inside an inward-facing sphere light, cut by a small sphere light, with quad lights in and above it."""
    floor = rt.Quad((-2, 0, -2), (0, 0, 4), (4, 0, 0), rt.Lambertian(0.6))
    shapes = [floor, rt.Sphere((0, 0, 0), 3.0, rt.DiffuseLight(0.5), flip_normals=True),
              rt.Sphere((0.4, 0.0, 0.6), 0.6, rt.DiffuseLight(3.0)),
              rt.Quad((-1.8, 0.0, -1.5), (0, 0, 1), (1, 0, 0), rt.DiffuseLight(5.0)),       # faces up, in-plane
              rt.Quad((-1.5, 2.0, 0.5), (1, 0, 0), (0, 0, 0.5), rt.DiffuseLight(2.0))]      # faces down
    scene = probe_scene(shapes, width=width, lookfrom=(0.0, 1.8, -2.0), lookat=(0.0, 0.0, 0.3), vfov=70.0, max_depth=3)
    renders = {s: rt.render(scene, spp=spp, strategy=s, seed=seed + 11 + i, threads=2)
               for i, s in enumerate(rt.STRATEGIES)}
    ref = renders["cosine"]
    agree = {s: image_ztest(r.mean, r.variance, spp, ref.mean, ref.variance, spp)
             for s, r in renders.items() if s != "cosine"}
    return agree, sum(r.nonfinite_samples for r in renders.values())


@stress_case
def light_sampling(*, samples: int = 100_000, seed: int = 0, width: int = 24, spp: int = 64):
    """Light sampling where pdfs degenerate: finite everywhere, estimates unbiased.

    From points on, beside, behind and grazing a quad light and inside, on and outside a
    sphere light: E[valid / pdf] equals the closed-form solid angle (|z| <= 5), every pdf
    is finite and ``light_pdf`` integrates to the probability of a valid sample
    (:func:`_check_point`); then every strategy agrees with ``cosine`` on a scene of such
    points (:func:`_light_renders`).
    """
    rng = np.random.default_rng(seed)
    jobs = _reference_points()
    cases = {name: _check_point(shape, ref, exact, samples, rng) for name, shape, ref, exact in jobs}
    bad_pdf = sum(c["nonfinite"] + c["pdf_all_mismatch"] for c in cases.values())
    worst_z = max(max(abs(c["z"]), abs(c["pdf_mass"]["z"]) if c["pdf_mass"] else 0.0) for c in cases.values())
    agree, render_nonfinite = _light_renders(width, spp, seed)
    passed = bad_pdf == 0 and worst_z <= 5.0 and render_nonfinite == 0 and all(a["passed"] for a in agree.values())
    figure = (f"{len(jobs)} reference points: max |z| {worst_z:.2f} (limit 5), Inf/NaN/mismatched pdfs {bad_pdf}; "
              f"floor-through-light renders agree with cosine: "
              f"{sum(a['passed'] for a in agree.values())}/{len(agree)}, NaN samples {render_nonfinite}")
    details = {"points": cases, "render_agreement": agree, "render_nonfinite": render_nonfinite, "samples": samples}
    return figure, passed, details
