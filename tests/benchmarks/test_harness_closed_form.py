"""Scenes with an analytic answer are measured against it, not against Mitsuba."""
import numpy as np

import reference_tracer as rt
from benchmarks.references import CLOSED_FORM, closed_form_reference_of
from benchmarks.sweep.bias import bias_verdict
from mitsuba_scenes import get_scene
from mitsuba_scenes.scenes.furnace import expected_radiance


def test_furnace_reference_is_the_closed_form():
    ref = closed_form_reference_of("furnace", 8, 6)
    assert ref.variant == CLOSED_FORM
    assert ref.mean.shape == (6, 8, 3) and not ref.variance.any()
    np.testing.assert_allclose(ref.mean, expected_radiance(), rtol=1e-7)
    # ...and our tracer reproduces it exactly per sample with cosine sampling (albedo * Le
    # every bounce), so the bias verdict sees no evidence at all.
    r = rt.render(get_scene("furnace", width=8, height=6), spp=16, strategy="cosine", seed=0)
    np.testing.assert_allclose(r.mean, ref.mean, rtol=1e-6)
    verdict = bias_verdict([r.mean, r.mean], [r.variance, r.variance], 16, ref.mean, ref.variance, ref.spp,
                            alpha=0.001)
    assert verdict["bias_significant"] is False


def test_scenes_without_closed_form_have_none():
    assert closed_form_reference_of("cornell_box", 8, 8) is None


def test_bias_verdict_catches_a_global_one_percent_bias_hidden_by_noisy_pixels():
    """A few pixels with huge variance (light edges) must not hide a 1% bias elsewhere."""
    rng = np.random.default_rng(0)
    h, w, k, spp = 32, 32, 4, 256
    ref = np.full((h, w, 3), 0.2)
    var = np.full((h, w, 3), 0.05)
    var[:2, :2] = 5e4  # four pixels with enormous variance
    ref_spp = 8192
    imgs = [ref * 0.99 + rng.normal(size=ref.shape) * np.sqrt(var / spp) for _ in range(k)]
    verdict = bias_verdict(imgs, [var] * k, spp, ref, var, ref_spp, alpha=0.001)
    assert verdict["bias_significant"] is True, verdict
    unbiased = [ref + rng.normal(size=ref.shape) * np.sqrt(var / spp) for _ in range(k)]
    assert bias_verdict(unbiased, [var] * k, spp, ref, var, ref_spp, alpha=0.001)["bias_significant"] is False
    # One render alone gets no verdict (its own variance is unreliable for heavy tails).
    assert bias_verdict(imgs[:1], [var], spp, ref, var, ref_spp, alpha=0.001)["bias_significant"] is None
