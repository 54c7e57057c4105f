"""Measured power of the regression gate: injected biases, ours vs Mitsuba's per-pixel rule.

This module computes the table's rows (:func:`power_table`); the Markdown printing is
:func:`benchmarks.commands._gate_tables.format_table`.

Each injection is a plausible rendering bug applied to *our* tracer's render of an
unmodified suite scene; the reference is the gate's own, the cached Mitsuba render of
the unmodified scene at the gate's defaults (:mod:`benchmarks.gate.suite`). So the table says
what ``rtbench gate`` would report in CI, not what an idealised test could do.

Injections (:data:`INJECTIONS`):

``scale 0.99``
    ``cornell_box``: the whole image (mean, and variance by 0.99^2) scaled by 0.99.
``red wall albedo +3%``
    ``cornell_box`` with the red wall's (x = 0) albedo times 1.03.
``light moved 1%``
    ``cornell_box`` with the ceiling light moved 1.3 units (1% of its 130-unit width)
    along +x, towards the green wall.
``Schlick Fresnel``
    ``cornell_glass`` with ``Dielectric(1.5, fresnel='schlick')`` instead of the exact
    Fresnel equations.
``light strategy``
    ``cornell_box`` rendered with ``strategy='light'`` (misses all indirect light)
    instead of ``mis``.

Ours "catches" an injection when its p-value is below the per-comparison level of a
default gate run over the quick suite (``GATE_ALPHA / 8`` = 0.00125: eight scenes,
``mis`` only). Mitsuba's rule (:func:`benchmarks.gate.mitsuba_rule`) is applied as
Mitsuba applies it, at its own ``alpha = 0.01`` per image, on the same render and
reference.

Examples
--------
>>> from benchmarks.gate.power import INJECTIONS
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

__all__ = ["INJECTIONS", "QUICK_SUITE_COMPARISONS", "PowerRow", "injected_scene", "power_row", "power_table"]

#: comparisons in a default gate run of the quick suite (eight scenes, ``mis``).
QUICK_SUITE_COMPARISONS = 8
#: fraction of the light's width it is moved by.
LIGHT_SHIFT = 0.01
#: relative change of the wall albedo.
ALBEDO_CHANGE = 0.03

#: name -> (suite scene, strategy, image scale, scene edit or None); see the module doc.
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
    return rt.Scene(camera=scene.camera, shapes=shapes, max_depth=scene.max_depth, rr_depth=scene.rr_depth,
                    background=scene.background, direct=scene.direct)


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
        width = float(np.linalg.norm(light.u))
        q = tuple(float(c) + d for c, d in zip(light.Q, np.asarray(light.u) / width * LIGHT_SHIFT * width))
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
    """Render injection ``name`` and test it with both rules (see the module doc)."""
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


def power_table(names=None, **kw) -> list:
    """:func:`power_row` for each injection (default: all of :data:`INJECTIONS`)."""
    return [power_row(n, **kw) for n in (names or list(INJECTIONS))]

