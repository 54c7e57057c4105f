"""Case ``degenerate_input``: degenerate triangles are never hit and change no pixel;
triangles with one bounding box build a balanced tree."""
from __future__ import annotations

import math

import numpy as np

import reference_tracer as rt
from reference_tracer.probe import core_scene

from .probes import contiguous, count_escapes, edge_and_vertex_rays, icosphere, probe_scene
from .record import stress_case

__all__ = ["degenerate_input", "same_box_triangles"]


def _build_seconds(scene: rt.Scene, repeats: int) -> tuple:
    """Minimum C++ build time over ``repeats`` fresh builds, and the last core scene."""
    best, core = math.inf, None
    for _ in range(repeats):
        core = core_scene(scene, cached=False)  # every repeat builds afresh
        best = min(best, core.build_seconds)
    return best, core


def same_box_triangles(n: int, rng) -> np.ndarray:
    """``n`` random triangles whose bounding boxes are all exactly [-1, 1]^3 (one centroid:
    the binned SAH finds no extent to split).

    >>> tris = same_box_triangles(5, np.random.default_rng(0))
    >>> tris.shape, bool((tris.min(axis=1) == -1).all() and (tris.max(axis=1) == 1).all())
    ((5, 3, 3), True)
    """
    r = rng.uniform(-0.99, 0.99, (n, 3))
    one = np.ones(n)
    return np.stack([np.c_[-one, -one, r[:, 0]], np.c_[one, r[:, 1], -one], np.c_[r[:, 2], one, one]], axis=1)


def _soup(tris) -> rt.Scene:
    """A probe scene of one mesh of ``tris`` (n, 3, 3), three private vertices per triangle."""
    return probe_scene([rt.Mesh(tris.reshape(-1, 3), np.arange(3 * len(tris)).reshape(-1, 3), rt.Lambertian(0.5))])


def _degenerate_faces(rng, seed: int) -> dict:
    """Degenerate faces beside ordinary shapes: rays, renders and emitters with and without them."""
    lam = rt.Lambertian(0.5)
    light = rt.DiffuseLight(4.0)
    V = np.array([[0.0, 0.0, 0.0], [1.0, 0.5, 0.25], [2.0, 1.0, 0.5], [0.0, 1.0, 0.0],
                  [0.25, 0.75, 0.5], [0.25, 0.75, 0.5], [-1.0, 0.5, 1.5]])
    F = np.array([[0, 0, 3],      # repeated index
                  [4, 5, 3],      # duplicate positions under distinct indices
                  [0, 1, 2],      # exactly collinear (2 = 2 * 1)
                  [1, 0, 2],      # collinear, other order
                  [3, 3, 3],      # one point
                  [6, 6, 0]])     # segment
    ordinary_face = np.array([[-2.0, -2.0, 3.0], [3.0, -2.0, 3.0], [0.0, 3.0, 3.0]])
    same_points = np.full((30, 3), 0.3)                                                  # all vertices equal
    # The scene model refuses a mesh without area: the degenerate faces ride on a mesh whose
    # first face is the ordinary triangle (prim 2 with or without them, the quads first).
    mesh_v = np.vstack([ordinary_face, V, same_points])
    mesh_f = np.vstack([[[0, 1, 2]], F + 3, rng.integers(0, 30, (40, 3)) + 3 + len(V)])
    degenerate = rt.Mesh(mesh_v, mesh_f, lam)
    ordinary = rt.Triangle(*ordinary_face, lam)
    floor = rt.Quad((-5, -2.5, -5), (0, 0, 10), (10, 0, 0), lam)
    lamp = rt.Quad((-1, 3, -1), (2, 0, 0), (0, 0, 2), light)
    view = dict(background=0.2, lookfrom=(0.3, 0.4, -6), lookat=(0.2, 0.3, 0), width=24)
    with_deg = probe_scene([floor, lamp, degenerate], **view)
    without = probe_scene([floor, lamp, ordinary], **view)
    # An emitting mesh of one triangle and 40 all-equal ones: only the triangle is a light.
    lights = probe_scene([rt.Mesh(np.vstack([ordinary_face, same_points]),
                                  np.vstack([[[0, 1, 2]], rng.integers(0, 30, (40, 3)) + 3]), light)])
    n_base = 2 + 1  # quads then the ordinary triangle: ids 0..2
    # Rays at every degenerate vertex and along their segments, from random origins.
    pts = np.vstack([V, V[0] + rng.random((200, 1)) * (V[2] - V[0]), V[6] + rng.random((200, 1)) * (V[0] - V[6]),
                     np.full((1, 3), 0.3)])
    origins = contiguous(rng.uniform(-4, 4, (len(pts) * 4, 3)) + np.array([0, 0, -6.0]))
    dirs = contiguous(np.repeat(pts, 4, axis=0) - origins)
    ray_hits = {}
    for test in rt.TRIANGLE_TESTS:
        cs = core_scene(with_deg, triangle_test=test)
        h, hb = cs.intersect(origins, dirs), cs.intersect(origins, dirs, brute_force=True)
        h0 = core_scene(without, triangle_test=test).intersect(origins, dirs)
        ray_hits[test] = {
            "degenerate_hits": int((h["prim"] >= n_base).sum()),
            "brute_force_mismatch": int((h["prim"] != hb["prim"]).sum() + (h["t"] != hb["t"]).sum()),
            "differs_from_without": int((h["prim"] != h0["prim"]).sum() + (h["t"] != h0["t"]).sum()),
            "nan": int(np.isnan(h["t"]).sum() + (~np.isfinite(h["point"][h["prim"] >= 0])).sum()),
        }
    img_diff, nonfinite = 0, 0
    for strategy in rt.STRATEGIES:
        a = rt.render(with_deg, spp=4, strategy=strategy, seed=seed, threads=1)
        b = rt.render(without, spp=4, strategy=strategy, seed=seed, threads=1)
        img_diff += int((a.mean != b.mean).sum())
        nonfinite += a.nonfinite_samples + b.nonfinite_samples
    return {"ray_hits": ray_hits, "image_differences": img_diff, "nonfinite_samples": nonfinite,
            "emitters": int(core_scene(lights).emitter_count)}


def _split_vertex_escapes(rng) -> int:
    """Escapes of 20,000 edge/vertex rays from inside a closed icosphere of private vertices per face."""
    Vi, Fi, Ei = icosphere(3)
    o = contiguous(np.zeros((20_000, 3)) + rng.uniform(-0.3, 0.3, (20_000, 3)))
    d, _ = edge_and_vertex_rays(Vi, Ei, o, rng)
    return count_escapes(_soup(Vi[Fi]), o, d, triangle_test="watertight")["escapes"]


def _coincident_builds(coincident: int, rng, repeats: int) -> dict:
    """Build times of same-box and of small scattered triangles (n and n / 10), the same-box tree's
    shape and its closest hits on 200 rays against brute force."""
    tris = same_box_triangles(coincident, rng)
    centres = rng.uniform(-1.0, 1.0, (coincident, 1, 3))
    ordinary_tris = centres + 0.02 * rng.normal(size=(coincident, 3, 3))
    t_tenth, _ = _build_seconds(_soup(tris[: coincident // 10]), repeats)
    t_big, core_big = _build_seconds(_soup(tris), repeats)
    t_ordinary, _ = _build_seconds(_soup(ordinary_tris), repeats)
    t_ordinary_tenth, _ = _build_seconds(_soup(ordinary_tris[: coincident // 10]), repeats)
    o = contiguous(rng.uniform(-3, 3, (200, 3)) * [1, 1, 0] + [0, 0, -5])
    d = contiguous(rng.uniform(-0.8, 0.8, (200, 3)) - o * [1, 1, 0] + [0, 0, 5])
    hb = core_big.intersect(o, d, brute_force=True)
    hh = core_big.intersect(o, d)
    return {"build_seconds": {"same_box": {str(coincident // 10): t_tenth, str(coincident): t_big},
                              "ordinary": {str(coincident // 10): t_ordinary_tenth, str(coincident): t_ordinary}},
            "build_ratio_to_ordinary": t_big / max(t_ordinary, 1e-9),
            "growth_10x": t_big / max(t_tenth, 1e-9),
            "growth_10x_ordinary": t_ordinary / max(t_ordinary_tenth, 1e-9),
            "growth_10x_n_log_n": 10 * math.log(coincident) / math.log(coincident / 10),
            "bvh_depth": int(core_big.bvh_depth), "bvh_nodes": int(core_big.bvh_nodes),
            "bvh_blocks": int(core_big.bvh_blocks),
            "coincident_brute_force_mismatch": int((hh["prim"] != hb["prim"]).sum() + (hh["t"] != hb["t"]).sum())}


@stress_case
def degenerate_input(*, coincident: int = 100_000, seed: int = 0, repeats: int = 3):
    """Zero-area, collinear, all-equal and coincident triangles: balanced tree, never hit.

    Degenerate faces beside an ordinary triangle are never reported, agree with brute
    force and change no pixel; an icosphere with private vertices per face stays
    watertight; ``coincident`` same-box triangles build a tree at most ``log2(n)`` levels
    deep with at least ``n / 4`` leaf blocks (counted, not timed; the build time, best of
    ``repeats``, is reported against an ordinary mesh's and n log n growth).

    Parameters
    ----------
    coincident : int
        Triangles with one bounding box (>= 1000).
    repeats : int
        Builds timed per size (the minimum counts).
    """
    rng = np.random.default_rng(seed)
    # One generator through the three parts, in this order (the figures depend on it).
    faces = _degenerate_faces(rng, seed)
    split_escapes = _split_vertex_escapes(rng)
    builds = _coincident_builds(coincident, rng, repeats)
    ray_hits, img_diff, nonfinite = faces["ray_hits"], faces["image_differences"], faces["nonfinite_samples"]
    depth_bound = math.ceil(math.log2(coincident))
    balanced = builds["bvh_depth"] <= depth_bound and 4 * builds["bvh_blocks"] >= coincident
    passed = (all(v["degenerate_hits"] == 0 and v["brute_force_mismatch"] == 0 and v["differs_from_without"] == 0
                  and v["nan"] == 0 for v in ray_hits.values())
              and img_diff == 0 and nonfinite == 0 and split_escapes == 0 and balanced
              and builds["coincident_brute_force_mismatch"] == 0 and faces["emitters"] == 1)
    figure = (f"{coincident:,} same-box tris: tree depth {builds['bvh_depth']} (bound {depth_bound}), build "
              f"{builds['build_seconds']['same_box'][str(coincident)] * 1e3:.0f} ms = "
              f"x{builds['build_ratio_to_ordinary']:.2f} an ordinary mesh's (x{builds['growth_10x']:.0f} for 10x n); "
              f"degenerate hits {sum(v['degenerate_hits'] for v in ray_hits.values())}, image diffs {img_diff}, NaN "
              f"{sum(v['nan'] for v in ray_hits.values()) + nonfinite}")
    details = {"ray_hits": ray_hits, "image_differences": img_diff, "nonfinite_samples": nonfinite,
               "emitters_with_degenerate": faces["emitters"], "split_vertex_escapes": split_escapes,
               "bvh_depth_bound": depth_bound, **builds}
    return figure, passed, details
