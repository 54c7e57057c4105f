"""Mitsuba 3's own render-test rule (:func:`mitsuba_rule`), re-implemented to compare it with the gate's."""
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
