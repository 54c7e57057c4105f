"""Mitsuba 3's own render-test rule, re-implemented to compare it with the gate's.

:func:`mitsuba_rule` is the acceptance rule of Mitsuba's ``test_renders.py``: a per-pixel
z-test against the reference's variance only. ``tests/benchmarks/gate/test_gate_stats.py`` and the power
table (:mod:`benchmarks.gate.power`) run it beside :func:`benchmarks.gate.compare` on the
same data.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from ..stats import sidak
from .inputs import check_spp, image3

__all__ = ["MitsubaRuleResult", "mitsuba_rule"]

#: Mitsuba's own per-image false-alarm level (not the gate's ``GATE_ALPHA``).
MITSUBA_ALPHA = 0.01


@dataclass
class MitsubaRuleResult:
    """Result of :func:`mitsuba_rule`.

    ``passed``; ``fraction_passed`` = passing pixel-channels / (C * pixels);
    ``alpha_sidak`` the per-pixel level; ``n_failed`` failing pixel-channels;
    ``p_value`` (H, W, C) per-pixel-channel p-values; ``min_p``.
    """

    passed: bool
    fraction_passed: float
    alpha_sidak: float
    n_failed: int
    min_p: float
    p_value: np.ndarray = field(repr=False)


def mitsuba_rule(test_mean, ref_mean, ref_var, test_spp, *, alpha: float = MITSUBA_ALPHA,
                 var_floor: float = 1e-4, pass_fraction: float = 0.9975) -> MitsubaRuleResult:
    """Mitsuba 3's render-test acceptance rule, re-implemented for comparison.

    Source: ``src/render/tests/test_renders.py`` in mitsuba-renderer/mitsuba3 (functions
    ``z_test`` and ``test_render``), read for this re-implementation. Its rule:

    * the reference's per-sample variance is floored, ``v = max(ref_var, 1e-4)``;
    * ``z = |mean - ref| * sqrt(spp / v)`` where ``spp`` is the sample count of the
      render *under test* (the reference's own spp and noise do not enter; neither does
      the test render's variance);
    * ``p = 2 * (1 - Phi(z))``;
    * Sidak-corrected level over *pixels* (not pixel-channels):
      ``alpha_s = 1 - (1 - alpha)^(1 / (H * W))`` with ``alpha = 0.01``;
    * a pixel-channel passes if ``p > alpha_s``; the image passes if
      ``passing pixel-channels / C >= 0.9975 * H * W``.

    Mitsuba applies it in XYZ (it converts RGB references to XYZ first); here it runs
    in whatever colour space the arrays are in.

    Parameters
    ----------
    test_mean : array_like, (H, W) or (H, W, C)
    ref_mean, ref_var : array_like, same shape
        Reference mean and per-sample variance.
    test_spp : int
        Samples per pixel of the render under test (Mitsuba's ``sample_count``).

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
