"""Measured power of the regression gate on injected biases, ours against Mitsuba's per-pixel rule.

Each injection (:data:`INJECTIONS`) is a plausible bug in our render of a suite scene, compared
with the gate's own reference at the gate's defaults; ours "catches" it below the level of one
comparison of a default quick-suite run (``GATE_ALPHA / 8``). :func:`mitsuba_rule` re-implements
Mitsuba 3's render-test rule, run at its own ``alpha = 0.01`` per image.

Examples
--------
>>> list(INJECTIONS)[:2]
['scale 0.99', 'red wall albedo +3%']
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

import reference_tracer as rt

from ..constants import GATE_ALPHA
from ..stats import sidak
from ..tails import DEFAULT_TAIL_SPP
from .inputs import check_spp, image3
from .suite import (DEFAULT_REF_SPP, DEFAULT_SPP, DEFAULT_WIDTH, compare_render, gate_reference, gate_scene,
                    gate_tails)

__all__ = ["INJECTIONS", "QUICK_SUITE_COMPARISONS", "PowerRow", "injected_scene", "power_row", "MITSUBA_ALPHA",
           "MitsubaRuleResult", "mitsuba_rule"]

#: Mitsuba's own per-image false-alarm level (not the gate's ``GATE_ALPHA``).
MITSUBA_ALPHA = 0.01


@dataclass
class MitsubaRuleResult:
    """``fraction_passed``: passing pixel-channels / (C * pixels); ``alpha_sidak``: the per-pixel
    level; ``p_value``: (H, W, C) per-pixel-channel p-values."""

    passed: bool
    fraction_passed: float
    alpha_sidak: float
    n_failed: int
    min_p: float
    p_value: np.ndarray = field(repr=False)


def mitsuba_rule(test_mean, ref_mean, ref_var, test_spp, *, alpha: float = MITSUBA_ALPHA,
                 var_floor: float = 1e-4, pass_fraction: float = 0.9975) -> MitsubaRuleResult:
    """Mitsuba 3's render-test acceptance rule, re-implemented for comparison.

    ``src/render/tests/test_renders.py`` of mitsuba3 (``z_test``, ``test_render``):
    ``z = |mean - ref| * sqrt(spp / max(ref_var, 1e-4))`` with the test render's ``spp`` (neither
    the reference's noise nor the test's variance enters), ``p = 2 (1 - Phi(z))``; a
    pixel-channel passes if ``p > 1 - (1 - alpha)^(1 / (H W))`` (Sidak over pixels), the image if
    ``passing pixel-channels / C >= 0.9975 H W``. Mitsuba runs it in XYZ; here it runs in the
    arrays' colour space.

    Examples
    --------
    >>> ref = np.full((8, 8, 3), 1.0)
    >>> mitsuba_rule(ref * 1.001, ref, np.full_like(ref, 1.0), 64).passed
    True
    """
    x = image3(test_mean, "test_mean")
    r = image3(ref_mean, "ref_mean")
    v = image3(ref_var, "ref_var")
    if not (x.shape == r.shape == v.shape):
        raise ValueError(f"image shapes differ: test_mean{x.shape}, ref_mean{r.shape}, ref_var{v.shape}")
    n = check_spp(test_spp, "test_spp", 1)
    H, W, C = x.shape
    v = np.maximum(np.nan_to_num(v, nan=0.0), var_floor)
    with np.errstate(invalid="ignore"):
        z = np.abs(x - r) * np.sqrt(n / v)
    p = 2.0 * stats.norm.sf(z)
    p = np.where(np.isnan(p), 0.0, p)  # NaN test pixels fail (Mitsuba: NaN > alpha is False)
    pixel_count = H * W
    alpha_s = sidak(alpha, pixel_count)
    success = p > alpha_s
    n_pass = int(np.count_nonzero(success))
    return MitsubaRuleResult(
        passed=bool(n_pass / C >= pass_fraction * pixel_count),
        fraction_passed=n_pass / (C * pixel_count), alpha_sidak=alpha_s,
        n_failed=int(success.size - n_pass), min_p=float(p.min()), p_value=p)


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


def _scaled_moments(moments, scale: float):
    """The moments of ``scale`` times the samples (``scale`` > 0)."""
    return dataclasses.replace(moments, m2=moments.m2 * scale**2, m3=moments.m3 * scale**3,
                               m4=moments.m4 * scale**4, max=moments.max * scale)


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
              mitsuba_alpha: float = MITSUBA_ALPHA, tail_spp: int = DEFAULT_TAIL_SPP, threads=None,
              cache=None) -> PowerRow:
    """Render injection ``name`` and test it with both rules; ours as ``rtbench gate`` does by default,
    with the tail reference of the injected estimator (a build with the bug renders its own tails; a
    scaled image's moments scale with it; ``tail_spp`` 0: none). Caught: the verdict fail (an
    undetermined verdict catches nothing)."""
    if name not in INJECTIONS:
        raise ValueError(f"unknown injection {name!r}; choose from {', '.join(INJECTIONS)}")
    scene_name, strategy, scale, edit = INJECTIONS[name]
    base = gate_scene(scene_name, width=width)
    ref = gate_reference(scene_name, base, ref_spp=ref_spp, threads=threads, cache=cache)
    scene = injected_scene(base, edit)
    tails = gate_tails(scene, strategy, tail_spp=tail_spp, threads=threads, cache=cache, log=None)
    if tails is not None and scale != 1.0:
        tails = dataclasses.replace(tails, moments=_scaled_moments(tails.moments, scale))
    out = rt.render(scene, spp=spp, strategy=strategy, seed=seed, threads=threads)
    mean = out.mean.astype(np.float64) * scale
    var = out.variance.astype(np.float64) * scale**2
    g = compare_render(mean, var, spp, ref, alpha=case_alpha, tails=tails)
    m = mitsuba_rule(mean, ref.mean, ref.variance, spp, alpha=mitsuba_alpha)
    return PowerRow(injection=name, scene=scene_name, seed=seed, spp=spp, p_value=g.p_value, caught=g.failed,
                    failed_levels=list(g.failed_levels), relative_bias=g.relative_bias,
                    relative_bias_se=g.relative_bias_se, mitsuba_caught=not m.passed,
                    mitsuba_failed_fraction=1.0 - m.fraction_passed)
