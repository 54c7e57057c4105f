"""The five sampling strategies on scenes with analytic answers (issue 3).

Every check compares with a closed form or between strategies using the measured
per-sample variance; seeds are fixed, so each test is deterministic. The stated
false-positive rates are those of the statistical rule under the normal approximation of
the mean of many samples (i.e. the chance that a correct tracer would fail at a random seed).
"""
import math

import numpy as np
import pytest

import reference_tracer as rt
from mitsuba_scenes import get_scene

UNBIASED = ("uniform", "cosine", "mixture", "mis")


def mean_and_stderr(result):
    """Mean over the whole image and its standard error, from the per-sample variance.

    All pixels here share the same expected value, so the image mean is the mean of
    H * W * spp independent samples.
    """
    n = result.mean.shape[0] * result.mean.shape[1] * result.spp
    return result.mean.mean(axis=(0, 1)), np.sqrt(result.variance.mean(axis=(0, 1)) / n)


# ---------------------------------------------------------------------------------------
# Direct lighting: a Lambertian floor under a 1x1 unit-radiance quad light at height 1.
# Irradiance below the centre is E = integral of 1/(x^2+y^2+1)^2 over the square
# = 4 X/sqrt(1+X^2) atan(X/sqrt(1+X^2)) with X = 1/2, i.e. 0.7522747 (the issue quotes
# 0.752243, 4e-5 lower; far below the test's resolution). Floor radiance = 0.5/pi * E.
IRRADIANCE = 4 * (0.5 / math.sqrt(1.25)) * math.atan(0.5 / math.sqrt(1.25))
DIRECT_EXPECTED = 0.5 / math.pi * IRRADIANCE


def direct_lighting_scene():
    floor = rt.Quad((-50, 0, -50), (0, 0, 100), (100, 0, 0), rt.Lambertian(0.5))  # normal +y
    light = rt.Quad((-0.5, 1, -0.5), (1, 0, 0), (0, 0, 1), rt.DiffuseLight(1.0))  # normal -y
    # A narrow camera looking at the point below the light's centre from the side: the
    # 8x8 pixels see a patch of ~0.004 units, where the irradiance is flat to < 1e-5.
    cam = rt.Camera(lookfrom=(0, 0.4, -2), lookat=(0, 0, 0), vfov=0.1, width=8, height=8)
    return rt.Scene(camera=cam, shapes=[floor, light], max_depth=2)


def test_direct_lighting_irradiance_constant():
    # The closed form against a midpoint-rule integral of cos cos / r^2 over the light.
    n = 2000
    x = (np.arange(n) + 0.5) / n - 0.5
    xx, yy = np.meshgrid(x, x)
    numeric = np.sum(1.0 / (xx ** 2 + yy ** 2 + 1) ** 2) / n ** 2
    assert IRRADIANCE == pytest.approx(numeric, abs=1e-7)
    assert IRRADIANCE == pytest.approx(0.752243, abs=5e-5)


@pytest.mark.parametrize("strategy", rt.STRATEGIES)
def test_direct_lighting_matches_closed_form(strategy):
    """False-positive rate of |z| > 4 for a correct estimator: 6e-5."""
    spp = {"uniform": 4096, "cosine": 2048}.get(strategy, 512)
    r = rt.render(direct_lighting_scene(), spp=spp, strategy=strategy, seed=11)
    m, se = mean_and_stderr(r)
    assert r.nonfinite_samples == 0
    z = (m - DIRECT_EXPECTED) / se
    assert np.all(np.abs(z) < 4), (m, se, z)
    assert np.all(se < 0.02 * DIRECT_EXPECTED)  # the test has power: 4 se < 8%


# ---------------------------------------------------------------------------------------
# Furnace: camera inside a sphere whose inner surface reflects (albedo rho) and emits Le.
# Radiance is Le (1 - rho^n) / (1 - rho) at max_depth = n.
def furnace_scene(max_depth, rho=0.5, le=1.0, radius=1.0):
    shell = rt.Sphere((0, 0, 0), radius, rt.DiffuseLight(le, albedo=rho), flip_normals=True)
    cam = rt.Camera(lookfrom=(0, 0, -0.3 * radius), lookat=(0, 0, 0), vfov=60, width=8, height=8)
    return rt.Scene(camera=cam, shapes=[shell], max_depth=max_depth)


def furnace_expected(n, rho=0.5, le=1.0):
    return le * (1 - rho ** n) / (1 - rho)


@pytest.mark.parametrize("strategy", UNBIASED)
@pytest.mark.parametrize("depth", [1, 2, 3, 6])
def test_furnace_matches_closed_form(strategy, depth):
    """The hard case of sampling a sphere light from inside it. FP rate per test: 6e-5."""
    r = rt.render(furnace_scene(depth), spp=256, strategy=strategy, seed=depth)
    m, se = mean_and_stderr(r)
    expected = furnace_expected(depth)
    assert r.nonfinite_samples == 0
    if depth == 1:
        np.testing.assert_allclose(r.mean, expected, rtol=1e-12)
    else:
        assert np.all(np.abs(m - expected) < 4 * se + 1e-12), (m, se, expected)
        assert np.all(se < 0.01 * expected)


def test_furnace_light_strategy_sees_only_direct_light():
    """`light` is biased on purpose: at every depth >= 2 it returns Le (1 + rho)."""
    for depth in (2, 4):
        r = rt.render(furnace_scene(depth), spp=256, strategy="light", seed=5)
        m, se = mean_and_stderr(r)
        assert np.all(np.abs(m - 1.5) < 4 * se + 1e-12)
    # ...which is the right answer at depth 2 and measurably wrong at depth 4 (1.875).
    assert abs(m.mean() - furnace_expected(4)) > 20 * se.max()


# ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("strategy", rt.STRATEGIES)
def test_glass_sphere_in_white_background_is_white(strategy):
    """Every path through smooth glass carries exactly 1 (reflection weight 1, the 1/eta^2
    of entering cancels the eta^2 of leaving), so each sample is 1 up to rounding."""
    glass = rt.Sphere((0, 0, 0), 1.0, rt.Dielectric(1.5))
    cam = rt.Camera(lookfrom=(0, 0, -4), lookat=(0, 0, 0), vfov=35, width=16, height=16)
    scene = rt.Scene(camera=cam, shapes=[glass], max_depth=-1, background=1.0)
    r = rt.render(scene, spp=16, strategy=strategy, seed=3)
    np.testing.assert_allclose(r.mean, 1.0, atol=1e-9)
    assert r.variance.max() < 1e-9
    assert r.nonfinite_samples == 0


# ---------------------------------------------------------------------------------------
def _variance_floor(v):
    """Per-pixel variance, floored by its 3x3 neighbourhood mean.

    Radiance samples in a closed room are highly skewed (a path scores only when it
    happens to reach the small light), so a pixel whose rare events did not occur in its
    N samples reports a variance far below the truth and its z-score explodes. The
    neighbourhood mean estimates the same smooth per-sample variance from 9x the samples;
    taking the max keeps the test conservative at edges where the variance jumps.
    """
    from scipy.ndimage import uniform_filter

    v = np.asarray(v, dtype=np.float64)
    pooled = np.stack([uniform_filter(v[..., c], size=3, mode="nearest") for c in range(v.shape[2])], axis=-1)
    return np.maximum(v, pooled)


def per_pixel_agreement(a, b, tile=8):
    """Per-pixel Welch z-scores of a - b with both (floored) variances.

    Returns the fraction of pixel-channels with |z| > 3.29 (two-sided p = 0.001), the max
    |z| over tile x tile tiles (pooled means and variances), and the z of the image means.
    """
    va, vb = _variance_floor(a.variance) / a.spp, _variance_floor(b.variance) / b.spp
    d = a.mean.astype(np.float64) - b.mean
    se = np.sqrt(va + vb)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(se > 0, d / se, np.where(d == 0, 0.0, np.inf))
    h, w, c = d.shape
    tiles = lambda x: x.reshape(h // tile, tile, w // tile, tile, c).mean(axis=(1, 3))
    tile_z = tiles(d) / np.sqrt(tiles(va + vb) / tile ** 2)
    z_mean = d.mean() / np.sqrt((va + vb).mean() / (h * w))
    return float(np.mean(np.abs(z) > 3.29)), float(np.nanmax(np.abs(tile_z))), float(z_mean)


@pytest.fixture(scope="module")
def cornell_renders():
    # Without Russian roulette: the bounds below were derived for these estimators alone.
    # Roulette's 1/q weights make the 8x8 tile means heavier-tailed (max tile |z| 2.5-4.4
    # over six seed pairs, against 2.0-4.0 without), so their stated false-positive rate
    # would not hold; roulette's own agreement is tested against Mitsuba (test_russian_roulette).
    scene = get_scene("cornell_box", width=64, height=64, rr_depth=None)
    return {s: rt.render(scene, spp=256, strategy=s, seed=100 + i, threads=2) for i, s in enumerate(rt.STRATEGIES)}


@pytest.mark.parametrize("strategy", ["uniform", "cosine", "mixture"])
def test_unbiased_strategies_agree_on_cornell_box(cornell_renders, strategy):
    """Each against `mis` at 64x64, 256 spp.

    Per pixel: under the normal approximation 0.1% of the 12288 pixel-channels exceed
    |z| = 3.29; the skew of the samples (see _variance_floor) leaves up to 0.5% for
    `uniform` in correct renders at this spp (measured over seeds), so the bound is 1%.
    Per 8x8 tile (64 spp x 64 pixels per mean: the normal approximation holds) and for the
    image mean: |z| < 4.5 over 193 tests, false-positive rate 193 * 6.8e-6 = 1.3e-3.
    """
    frac, tile_z, z_mean = per_pixel_agreement(cornell_renders[strategy], cornell_renders["mis"])
    assert frac < 0.01, frac
    assert tile_z < 4.5, tile_z
    assert abs(z_mean) < 4.5, z_mean


def test_light_strategy_is_measurably_darker_on_cornell_box(cornell_renders):
    frac, tile_z, z_mean = per_pixel_agreement(cornell_renders["light"], cornell_renders["mis"])
    assert z_mean < -20, z_mean
    assert frac > 0.3 and tile_z > 20
    assert cornell_renders["light"].mean.mean() < 0.9 * cornell_renders["mis"].mean.mean()


def test_variance_ordering_on_cornell_box(cornell_renders):
    """Equal spp: mis < mixture < cosine < uniform in mean per-pixel variance."""
    v = {s: float(cornell_renders[s].variance.mean()) for s in UNBIASED}
    print("mean per-pixel variance at 256 spp, 64x64:", v)
    assert v["mis"] < v["mixture"] < v["cosine"] < v["uniform"], v


def test_rough_conductor_strategies_agree():
    """GGX plate under a quad light: material sampling (visible normals), uniform, mixture
    and MIS estimate the same radiance (FP rate per comparison: 6e-5)."""
    plate = rt.Quad((-2, 0, -2), (0, 0, 4), (4, 0, 0), rt.RoughConductor((0.9, 0.8, 0.7), alpha=0.3))
    light = rt.Quad((-0.5, 2, 0.5), (1, 0, 0), (0, 0, 1), rt.DiffuseLight(4.0))
    cam = rt.Camera(lookfrom=(0, 1.2, -3), lookat=(0, 0, 0.5), vfov=1.0, width=6, height=6)
    scene = rt.Scene(camera=cam, shapes=[plate, light], max_depth=2)
    results = {s: rt.render(scene, spp=4096, strategy=s, seed=9) for s in rt.STRATEGIES}
    ref_m, ref_se = mean_and_stderr(results["mis"])
    assert np.all(ref_m > 0.01)
    for s in ("uniform", "cosine", "mixture", "light"):
        m, se = mean_and_stderr(results[s])
        z = (m - ref_m) / np.sqrt(se ** 2 + ref_se ** 2)
        assert np.all(np.abs(z) < 4), (s, m, ref_m, z)


def test_schlick_fresnel_is_a_different_glass():
    """The book's Schlick approximation (kept to measure its bias) changes the image:
    a glass sphere against black, lit by a large light behind the camera, shows mostly
    F(theta) * L, and Schlick's F differs from the exact one by a few percent at
    intermediate angles. Exact Fresnel is the default. FP rate of |z| > 6: 2e-9."""
    assert rt.Dielectric(1.5).fresnel == "exact"
    light = rt.Quad((-20, -20, -6), (40, 0, 0), (0, 40, 0), rt.DiffuseLight(1.0))  # normal +z, faces the sphere
    cam = rt.Camera(lookfrom=(0, 0, -4), lookat=(0, 0, 0), vfov=30, width=32, height=32)
    images = {}
    for fresnel in ("exact", "schlick"):
        glass = rt.Sphere((0, 0, 0), 1.0, rt.Dielectric(1.5, fresnel=fresnel))
        scene = rt.Scene(camera=cam, shapes=[light, glass], max_depth=3)
        images[fresnel] = rt.render(scene, spp=4096, strategy="mis", seed=4)
    a, b = images["exact"], images["schlick"]
    z = (a.mean.mean() - b.mean.mean()) / np.sqrt((a.variance.mean() + b.variance.mean()) / (32 * 32 * 4096))
    assert abs(z) > 6, z
