"""Measured power of the regression gate on injected biases, ours against Mitsuba's per-pixel rule.

Each injection (:data:`INJECTIONS`) is a plausible bug applied to our render of an unmodified
suite scene, compared with the gate's own reference of that scene at the gate's defaults, so a
row says what ``rtbench gate`` would report. Ours "catches" it when its p-value is below the
level of one comparison of a default quick-suite run (``GATE_ALPHA / 8``); Mitsuba's rule runs
at its own ``alpha = 0.01`` per image.

Examples
--------
>>> list(INJECTIONS)[:2]
['scale 0.99', 'red wall albedo +3%']
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

import reference_tracer as rt

from ..constants import GATE_ALPHA
from .mitsuba_rule import MITSUBA_ALPHA, mitsuba_rule
from .suite import DEFAULT_REF_SPP, DEFAULT_SPP, DEFAULT_WIDTH, compare_render, gate_reference, gate_scene

__all__ = ["INJECTIONS", "QUICK_SUITE_COMPARISONS", "PowerRow", "injected_scene", "power_row"]

#: comparisons in a default gate run of the quick suite (eight scenes, ``mis``).
QUICK_SUITE_COMPARISONS = 8
#: fraction of the light's width it is moved by along its edge ``u``.
LIGHT_SHIFT = 0.01
#: relative change of the wall albedo.
ALBEDO_CHANGE = 0.03

#: name -> (suite scene, strategy, image scale, scene edit or None): the image scaled by 0.99 (its
#: variance by 0.99^2); the red wall's (x = 0) albedo times 1.03; the ceiling light moved 1% of its
#: width along +x; ``Dielectric(1.5, fresnel='schlick')`` on the glass; ``light`` instead of ``mis``.
INJECTIONS = {
    "scale 0.99": ("cornell_box", "mis", 0.99, None),
    "red wall albedo +3%": ("cornell_box", "mis", 1.0, "red_wall"),
    "light moved 1%": ("cornell_box", "mis", 1.0, "move_light"),
    "Schlick Fresnel": ("cornell_glass", "mis", 1.0, "schlick"),
    "light strategy": ("cornell_box", "light", 1.0, None),
}


def _replace_shape(scene, index, shape):
    shapes = list(scene.shapes)
    shapes[index] = shape
    return dataclasses.replace(scene, shapes=shapes)


def injected_scene(scene, edit):
    """``scene`` with the named ``edit`` applied (a modified copy; None returns ``scene``).

    Examples
    --------
    >>> from benchmarks.gate import gate_scene
    >>> s = injected_scene(gate_scene("cornell_box", width=8), "move_light")
    >>> s.shapes[5].Q
    (214.3, 554.0, 227.0)
    """
    if edit is None:
        return scene
    if edit == "red_wall":
        (i,) = [k for k, s in enumerate(scene.shapes) if isinstance(s, rt.Quad) and s.Q == (0.0, 0.0, 0.0)
                and s.u == (0.0, 555.0, 0.0)]
        wall = scene.shapes[i]
        albedo = tuple(float(a) * (1.0 + ALBEDO_CHANGE) for a in wall.material.albedo)
        material = dataclasses.replace(wall.material, albedo=albedo)
        return _replace_shape(scene, i, dataclasses.replace(wall, material=material))
    if edit == "move_light":
        (i,) = [k for k, s in enumerate(scene.shapes) if isinstance(s.material, rt.DiffuseLight)]
        light = scene.shapes[i]
        q = tuple(float(c) + float(d) * LIGHT_SHIFT for c, d in zip(light.Q, light.u))
        return _replace_shape(scene, i, dataclasses.replace(light, Q=q))
    if edit == "schlick":
        (i,) = [k for k, s in enumerate(scene.shapes) if isinstance(s.material, rt.Dielectric)]
        glass = scene.shapes[i]
        return _replace_shape(scene, i, dataclasses.replace(
            glass, material=rt.Dielectric(glass.material.ior, fresnel="schlick")))
    raise ValueError(f"unknown edit {edit!r}")


@dataclass
class PowerRow:
    """One injection: our gate's verdict and p-value, Mitsuba's rule's verdict."""

    injection: str
    scene: str
    seed: int
    spp: int
    p_value: float
    caught: bool
    failed_levels: list
    relative_bias: float
    relative_bias_se: float
    mitsuba_caught: bool
    mitsuba_failed_fraction: float


def power_row(name: str, *, seed: int = 1, spp: int = DEFAULT_SPP, width: int = DEFAULT_WIDTH,
              ref_spp: int = DEFAULT_REF_SPP, case_alpha: float = GATE_ALPHA / QUICK_SUITE_COMPARISONS,
              mitsuba_alpha: float = MITSUBA_ALPHA, threads=None, cache=None) -> PowerRow:
    """Render injection ``name`` and test it with both rules."""
    if name not in INJECTIONS:
        raise ValueError(f"unknown injection {name!r}; choose from {', '.join(INJECTIONS)}")
    scene_name, strategy, scale, edit = INJECTIONS[name]
    base = gate_scene(scene_name, width=width)
    ref = gate_reference(scene_name, base, ref_spp=ref_spp, threads=threads, cache=cache)
    out = rt.render(injected_scene(base, edit), spp=spp, strategy=strategy, seed=seed, threads=threads)
    mean = out.mean.astype(np.float64) * scale
    var = out.variance.astype(np.float64) * scale**2
    g = compare_render(mean, var, spp, ref, alpha=case_alpha)
    m = mitsuba_rule(mean, ref.mean, ref.variance, spp, alpha=mitsuba_alpha)
    return PowerRow(injection=name, scene=scene_name, seed=seed, spp=spp, p_value=g.p_value, caught=not g.passed,
                    failed_levels=list(g.failed_levels), relative_bias=g.relative_bias,
                    relative_bias_se=g.relative_bias_se, mitsuba_caught=not m.passed,
                    mitsuba_failed_fraction=1.0 - m.fraction_passed)
