"""Tests of ``benchmarks.metrics`` on hand computations and synthetic images of known noise.

Statistical tests use fixed seeds, so they are deterministic; each states the
probability with which it would fail for a correct implementation (its false-positive
rate over random seeds), computed from the stated model.
"""
from __future__ import annotations

import math
import sys
import warnings

import numpy as np
import pytest
from scipy import stats

try:
    import benchmarks  # noqa: F401
except ModuleNotFoundError:  # not installed (no `pip install -e .` yet): use the checkout
    from repo_paths import ROOT

    sys.path.insert(0, str(ROOT))

from benchmarks import metrics as M  # noqa: E402


# ------------------------------------------------------------------ formulas by hand

@pytest.mark.parametrize("img, ref, expected", [
    ([[1.0, 2.0]], [[1.0, 4.0]], 2.0),
    ([[0.0, 0.0], [0.0, 0.0]], [[1.0, 1.0], [1.0, 3.0]], (1 + 1 + 1 + 9) / 4),
    (np.full((2, 2, 3), 0.5), np.zeros((2, 2, 3)), 0.25),
])
def test_mse_rmse_by_hand(img, ref, expected):
    assert M.mse(img, ref) == pytest.approx(expected, rel=1e-12)
    assert M.rmse(img, ref) == pytest.approx(math.sqrt(expected), rel=1e-12)


@pytest.mark.parametrize("eps", [0.01, 0.5])
def test_relmse_by_hand(eps):
    img = np.array([[1.0, 0.1], [2.0, 3.0]])
    ref = np.array([[0.0, 0.0], [1.0, 3.0]])
    expected = (1 / eps + 0.01 / eps + 1 / (1 + eps) + 0) / 4
    assert M.relmse(img, ref, eps=eps) == pytest.approx(expected, rel=1e-12)
    if eps == M.RELMSE_EPS:
        assert M.relmse(img, ref) == pytest.approx(expected, rel=1e-12)


def test_mse_corrected_by_hand():
    img, ref = [[1.0, 2.0]], [[1.0, 4.0]]
    var = [[10.0, 30.0]]
    assert M.mse_corrected(img, ref, var, 100) == pytest.approx(2.0 - 0.2)


def test_relative_noise_by_hand():
    var = np.array([[0.5, 0.02], [4.0, 0.0]])
    ref = np.array([[0.0, 0.1], [1.0, 3.0]])
    assert M.relative_noise(var, ref) == pytest.approx((50.0 + 1.0 + 4.0 / 1.01 + 0.0) / 4, rel=1e-12)
    assert M.relative_noise(var, ref, eps=1.0) == pytest.approx((0.5 + 0.02 / 1.01 + 2.0 + 0.0) / 4, rel=1e-12)
    # the expected relMSE of an unbiased image of that variance: relMSE less its corrected value
    img = ref + 0.3
    assert M.relative_noise(var / 16, ref) == pytest.approx(
        M.relmse(img, ref) - M.relmse_corrected(img, ref, var, 16), rel=1e-12)


@pytest.mark.parametrize("fn", [M.mse, M.rmse, M.relmse, M.relative_noise])
def test_shape_mismatch_is_loud(fn):
    with pytest.raises(ValueError, match="shapes differ"):
        fn(np.zeros((4, 5, 3)), np.zeros((5, 4, 3)))
    with pytest.raises(ValueError, match="shape"):
        fn(np.zeros(7), np.zeros(7))


@pytest.mark.parametrize("fn", [M.mse, M.relmse, M.relative_noise])
def test_nan_policy(fn):
    img = np.array([[1.0, np.nan], [3.0, 4.0]])
    ref = np.array([[0.0, 1.0], [3.0, 2.0]])
    assert math.isnan(fn(img, ref))
    assert math.isnan(fn(img, ref, nan_policy="propagate"))
    keep = ~np.isnan(img)
    assert fn(img, ref, nan_policy="omit") == pytest.approx(fn(img[keep][None], ref[keep][None]))
    with pytest.raises(ValueError, match="NaN"):
        fn(img, ref, nan_policy="raise")
    with pytest.raises(ValueError, match="nan_policy"):
        fn(img, ref, nan_policy="ignore")


def test_efficiency_and_time_to_error_by_hand():
    assert M.efficiency(0.01, 2.0) == pytest.approx(50.0)
    np.testing.assert_allclose(M.efficiency(np.array([0.1, 0.2]), np.array([1.0, 5.0])), [10.0, 1.0])
    assert M.efficiency(0.0, 1.0) == math.inf
    with pytest.raises(ValueError):
        M.efficiency(-0.1, 1.0)
    with pytest.raises(ValueError):
        M.efficiency(0.1, 0.0)
    # rmse ~ t^-1/2 between 1 s (0.4) and 4 s (0.2): target 0.3 at t = (0.4/0.3)^2
    assert M.time_to_error([1.0, 4.0], [0.4, 0.2], 0.3) == pytest.approx((0.4 / 0.3) ** 2)
    assert M.time_to_error([4.0, 1.0, 16.0], [0.2, 0.4, 0.1], 0.2) == pytest.approx(4.0)  # unsorted input
    assert M.time_to_error([1.0, 4.0], [0.4, 0.2], 0.5) == 1.0          # reached at once
    assert math.isnan(M.time_to_error([1.0, 4.0], [0.4, 0.2], 0.1))    # never reached
    assert M.time_to_error([1.0, 2.0, 4.0], [0.4, np.nan, 0.2], 0.2) == pytest.approx(4.0)


# ------------------------------------------------------------------ SSIM

def test_ssim_matches_skimage_on_display_images():
    from skimage.metrics import structural_similarity
    import colour

    rng = np.random.default_rng(3)
    ref = rng.gamma(2.0, 0.5, size=(24, 20, 3))
    img = ref + rng.normal(0, 0.2, ref.shape)
    k = M.exposure_from_reference(ref)
    y = ref @ M.LUMINANCE_WEIGHTS
    assert k == pytest.approx(1.0 / np.percentile(y, 99.0))
    disp = lambda a: colour.cctf_encoding(np.clip(a * k, 0, 1), function="sRGB")  # noqa: E731
    expected = structural_similarity(disp(img), disp(ref), data_range=1.0, channel_axis=-1,
                                     gaussian_weights=True, sigma=1.5, use_sample_covariance=False)
    assert M.ssim(img, ref) == pytest.approx(expected, rel=1e-12)
    assert M.ssim(ref, ref) == pytest.approx(1.0)
    assert M.ssim(img, ref) < M.ssim(0.5 * (img + ref), ref) < 1.0


def test_ssim_exposure_is_the_references():
    # a render twice too bright must not look identical after exposure
    rng = np.random.default_rng(4)
    ref = rng.uniform(0.05, 0.3, size=(16, 16, 3))
    assert M.ssim(2 * ref, ref) < 0.99
    assert M.exposure_from_reference(np.zeros((4, 4, 3))) == 1.0


@pytest.mark.parametrize("side", [3, 5, 7, 10])
def test_ssim_small_images(side):
    rng = np.random.default_rng(side)
    ref = rng.uniform(0, 1, size=(side, side + 2, 3))
    assert M.ssim(ref, ref) == pytest.approx(1.0)
    s = M.ssim(ref + rng.normal(0, 0.3, ref.shape), ref)
    assert 0 < s < 1


def test_ssim_tiny_and_nan():
    with pytest.warns(RuntimeWarning, match="smaller than 3x3"):
        assert math.isnan(M.ssim(np.ones((2, 8, 3)), np.ones((2, 8, 3))))
    img = np.ones((12, 12, 3))
    img[3, 3, 1] = np.nan
    assert math.isnan(M.ssim(img, np.ones((12, 12, 3))))
    with pytest.raises(ValueError):
        M.ssim(img, np.ones((12, 12, 3)), nan_policy="raise")
    with pytest.raises(ValueError):
        M.ssim(img, np.ones((12, 12, 3)), nan_policy="omit")


# ------------------------------------------------------------------ synthetic renders

def _pixel_stats(samples):
    """(mean, ddof=0 per-sample variance) over the last axis, like rt.render."""
    return samples.mean(axis=-1), samples.var(axis=-1)


def _truth(shape, rng):
    return rng.uniform(0.2, 2.0, size=shape)


@pytest.mark.parametrize("noise", ["gaussian", "gamma"])
def test_mse_correction_on_known_noise(noise):
    """Issue 5: the reference-noise correction on images of known noise.

    Truth mu per pixel; reference = mean of N_ref samples; test = mu + Gaussian noise of
    known variance s2 per pixel. Then E[MSE] = mean(s2) + mean(sigma_ref^2)/N_ref and
    mse_corrected estimates mean(s2). The plain MSE must be off by the reference noise
    (checked to be > 10 standard errors here) while the corrected one is within 4
    standard errors of the truth (failure probability ~1e-4 under the model).
    """
    rng = np.random.default_rng(11)
    shape, n_ref = (64, 64, 3), 16
    mu = _truth(shape, rng)
    if noise == "gaussian":
        ref_samples = mu[..., None] + rng.normal(0, 1.0, size=shape + (n_ref,)) * mu[..., None]
    else:  # gamma, shape 0.5: skewed, per-sample variance 2 mu^2
        ref_samples = rng.gamma(0.5, 2.0, size=shape + (n_ref,)) * mu[..., None]
    ref, ref_var = _pixel_stats(ref_samples)
    ref_var = ref_var * n_ref / (n_ref - 1)           # unbiased per-sample variance
    s2 = 0.01 * mu ** 2
    img = mu + rng.normal(0, 1, shape) * np.sqrt(s2)
    true_err = float(s2.mean())                        # E[(img - mu)^2]
    plain, corr = M.mse(img, ref), M.mse_corrected(img, ref, ref_var, n_ref)
    # standard error of the corrected estimate, from its per-pixel terms
    terms = (img - ref) ** 2 - ref_var / n_ref
    se = terms.std() / math.sqrt(terms.size)
    assert abs(corr - true_err) < 4 * se
    assert plain - true_err > 10 * se
    assert plain - corr == pytest.approx(float(np.mean(ref_var)) / n_ref)


def test_convergence_slope_exact_and_ci():
    fit = M.convergence_slope([1, 4, 16, 64], [1 / math.sqrt(n) for n in [1, 4, 16, 64]])
    assert fit.slope == pytest.approx(-0.5) and fit.stderr == pytest.approx(0.0, abs=1e-12)
    assert fit.r2 == pytest.approx(1.0)
    two = M.convergence_slope([1, 4], [1.0, 0.5])
    assert two.slope == pytest.approx(-0.5) and math.isnan(two.ci_low)
    with pytest.raises(ValueError):
        M.convergence_slope([1, 2], [0.0, 1.0])
    assert math.isnan(M.convergence_slope([1, 2, 4], [1.0, np.nan, 0.5]).slope)
    assert M.convergence_slope([1, 2, 4], [1.0, np.nan, 0.5], nan_policy="omit").slope \
        == pytest.approx(-0.5)


def _sweep(bias, rng, spps=(1, 2, 4, 8, 16, 32, 64, 128, 256), seeds=3, shape=(24, 24, 3)):
    """RMSE of synthetic renders: exp(1)-distributed samples (sd = mean) + a relative bias;
    the reference is the exact mean."""
    mu = _truth(shape, rng)
    xs, ys = [], []
    for n in spps:
        for _ in range(seeds):
            img = rng.gamma(n, 1.0 / n, size=shape) * mu * (1 + bias)  # mean of n Exp(1)
            xs.append(n)
            ys.append(M.rmse(img, mu))
    return xs, ys


def test_convergence_slope_unbiased_is_minus_half():
    """Unbiased MC: slope -0.5. With 27 points on 24x24x3 images the log-RMSE noise is
    ~1%, so the fitted slope is within 0.02 of -0.5 and the 95% CI covers it (a 5% miss
    chance for the CI in general; fixed seed here)."""
    fit = M.convergence_slope(*_sweep(0.0, np.random.default_rng(5)))
    assert abs(fit.slope + 0.5) < 0.02
    assert fit.ci_low < -0.5 < fit.ci_high
    assert fit.ci_high - fit.ci_low < 0.05


@pytest.mark.parametrize("bias", [0.05, 0.1, 0.2])
def test_convergence_slope_flattens_with_bias(bias):
    """A bias flattens the curve. The renders are mu (1 + b) G_N with E[G_N] = 1,
    Var[G_N] = 1/N, so MSE = mean(mu^2) (b^2 + (1 + b)^2 / N).

    The expected slope is the least-squares slope of that noise-free curve over the same
    spp ladder (about -0.47, -0.41, -0.32 for b = 0.05, 0.1, 0.2); the fit is within 0.02
    of it (log-RMSE noise ~1%) and its 95% CI excludes -0.5.
    """
    spps = np.array([1, 2, 4, 8, 16, 32, 64, 128, 256])
    expected = np.polyfit(np.log(spps), 0.5 * np.log(bias ** 2 + (1 + bias) ** 2 / spps), 1)[0]
    fit = M.convergence_slope(*_sweep(bias, np.random.default_rng(6), spps=tuple(spps)))
    assert abs(fit.slope - expected) < 0.02
    assert fit.ci_low > -0.5
    assert expected > -0.47


# ------------------------------------------------------------------ bias / variance

def _seeds(K, n, mu, rng, bias=0.0, heavy=True):
    """K renders at n spp of a pixel-wise distribution with mean mu (1 + bias):
    heavy: a gamma(0.5) body plus rare bright hits; returns images and ddof=0 variances."""
    shape = mu.shape
    if heavy:
        body = rng.gamma(0.5, 2.0, size=(K,) + shape + (n,)) * 0.8
        hits = (rng.random((K,) + shape + (n,)) < 0.01) * 20.0   # mean 0.2
        s = (body + hits) * mu[None, ..., None]
    else:
        s = rng.exponential(1.0, size=(K,) + shape + (n,)) * mu[None, ..., None]
    s *= 1 + bias
    return s.mean(axis=-1), s.var(axis=-1)


def test_bias_variance_decomposition_by_hand():
    ref = np.zeros((2, 2))
    imgs = np.array([np.full((2, 2), 1.0), np.full((2, 2), 3.0)])
    bv = M.bias_variance(imgs, ref)
    # D = 2 everywhere, between-seed var = 2, s^2 = 2 / 2 = 1 -> bias2 = 4 - 1
    assert bv.bias2 == pytest.approx(3.0)
    assert bv.variance == pytest.approx(2.0)
    assert bv.mse == pytest.approx(5.0)
    assert bv.bias == pytest.approx(2.0)
    assert bv.bias_significant  # constant offset, zero spread: z = inf
    with pytest.raises(ValueError, match="K >= 2"):
        M.bias_variance(imgs[:1], ref, variance_source="seeds")
    with pytest.raises(ValueError, match="shape"):
        M.bias_variance(imgs, np.zeros((3, 2)))


@pytest.mark.parametrize("source", ["seeds", "samples"])
def test_bias_variance_flags_injected_bias_not_unbiased(source):
    """Heavy-tailed samples (per-sample variance 5.24 mu^2), K=4 seeds at 64 spp,
    reference at 1024 spp, 32x32x3 pixels. Unbiased: not flagged at alpha=0.01 (a 1%
    chance over seeds). A 10% bias: b^2 = 0.01 mu^2 against s^2 ~ 0.026 mu^2 per pixel
    gives an expected z of about 0.01 / (sqrt(2) * 0.026) * sqrt(1024) ~ 9; the test asks
    z > 5 (missed with negligible probability) and the estimate within 4 SE of the truth.
    """
    rng = np.random.default_rng(21)
    mu = _truth((32, 32, 3), rng)
    n_ref, n, K = 1024, 64, 4
    ref_m, ref_v = _seeds(1, n_ref, mu, rng)
    ref_m, ref_v = ref_m[0], ref_v[0] * n_ref / (n_ref - 1)
    args = dict(ref_var=ref_v, ref_spp=n_ref, spp=n, variance_source=source)
    imgs, var = _seeds(K, n, mu, rng)
    ok = M.bias_variance(imgs, ref_m, var_k=var, **args)
    assert not ok.bias_significant
    assert ok.sample_variance == pytest.approx(ok.variance * n)
    # per-sample variance of the model: mu^2 (0.64 * 2 + 400 * 0.01 * 0.99) = 5.24 mu^2
    assert ok.sample_variance == pytest.approx(5.24 * float((mu ** 2).mean()), rel=0.15)
    imgs_b, var_b = _seeds(K, n, mu, rng, bias=0.1)
    bad = M.bias_variance(imgs_b, ref_m, var_k=var_b, **args)
    assert bad.bias_significant and bad.z > 5
    true_b2 = float(((0.1 * mu) ** 2).mean())
    assert abs(bad.bias2 - true_b2) < 4 * bad.bias2_se
    assert bad.relative_bias == pytest.approx(0.1, abs=0.02)


@pytest.mark.parametrize("heavy", [False, True])
def test_bias_variance_false_positive_rate(heavy):
    """Under no bias, bias_significant at alpha fires at rate <= alpha (measured).

    200 independent unbiased sets (K=3 seeds at 8 spp, 16x16 pixels, noisy reference at
    64 spp), alpha = 0.1: the count of flags is Binomial(200, <= 0.1); the test fails if it
    exceeds the 0.999 quantile of Binomial(200, 0.1) (false-failure probability <= 1e-3
    for a correct implementation). It also checks E[bias2] = 0: the mean of the 200
    estimates is within 4 standard errors of 0.
    """
    rng = np.random.default_rng(100 + heavy)
    alpha, reps = 0.1, 200
    mu = _truth((16, 16, 3), rng)
    flags, b2 = 0, []
    for _ in range(reps):
        rm, rv = _seeds(1, 64, mu, rng, heavy=heavy)
        imgs, _ = _seeds(3, 8, mu, rng, heavy=heavy)
        bv = M.bias_variance(imgs, rm[0], rv[0] * 64 / 63, 64, alpha=alpha)
        flags += bv.bias_significant
        b2.append(bv.bias2)
    assert flags <= stats.binom.ppf(0.999, reps, alpha)
    b2 = np.array(b2)
    assert abs(b2.mean()) < 4 * b2.std(ddof=1) / math.sqrt(reps)


def test_bias_variance_nan_policy():
    rng = np.random.default_rng(2)
    mu = _truth((8, 8, 3), rng)
    imgs, _ = _seeds(3, 4, mu, rng, heavy=False)
    imgs[1, 2, 3, 0] = np.nan
    assert math.isnan(M.bias_variance(imgs, mu).bias2)
    om = M.bias_variance(imgs, mu, nan_policy="omit")
    assert om.n_pixels == 63 and math.isfinite(om.bias2)
    with pytest.raises(ValueError):
        M.bias_variance(imgs, mu, nan_policy="raise")


def test_no_numpy_warnings_on_degenerate_inputs():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        M.bias_variance(np.zeros((3, 4, 4, 3)), np.zeros((4, 4, 3)))
        M.mse(np.zeros((4, 4)), np.zeros((4, 4)))
        M.efficiency(np.array([0.0, 1.0]), np.array([1.0, 1.0]))


# ----------------------------------------------------------------------------------------- FLIP (issue 16)

def test_flip_is_zero_for_identical_images_and_grows_with_the_difference():
    rng = np.random.default_rng(3)
    ref = rng.random((24, 24, 3))
    assert M.flip(ref, ref) == 0.0
    small = M.flip(np.clip(ref + 0.02 * rng.standard_normal(ref.shape), 0, None), ref)
    large = M.flip(np.clip(ref + 0.2 * rng.standard_normal(ref.shape), 0, None), ref)
    assert 0.0 < small < large <= 1.0


def test_flip_map_mean_is_the_flip_value_and_nan_propagates():
    rng = np.random.default_rng(4)
    ref = rng.random((16, 20, 3))
    img = ref * 0.8
    value, fmap = M.flip(img, ref, error_map=True)
    assert fmap.shape == (16, 20) and np.all((fmap >= 0) & (fmap <= 1))
    assert math.isclose(float(fmap.mean()), value, rel_tol=1e-5)
    bad = img.copy()
    bad[0, 0, 0] = np.nan
    assert math.isnan(M.flip(bad, ref))
    with pytest.raises(ValueError):
        M.flip(bad, ref, nan_policy="raise")
