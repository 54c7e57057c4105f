"""Image-error metrics and Monte Carlo convergence statistics (DESIGN.md section 4).

Pure numpy/scipy (plus scikit-image and colour-science for SSIM). Every function takes
linear-radiance images as arrays of shape ``(H, W)`` or ``(H, W, C)`` unless stated and
returns plain floats or small dataclasses, so the harness can write them straight into
``results.jsonl`` / ``summary.json``.

Conventions
-----------
Per-sample variance
    ``var`` images hold the variance of *one sample* of a pixel (as ``rt.render``'s
    ``result.variance``); the variance of the pixel *mean* at ``N`` spp is ``var / N``.
NaN policy
    Functions that reduce over pixels take ``nan_policy`` with scipy's meaning:

    * ``'propagate'`` (default): any NaN in an input makes the result NaN. A NaN pixel
      in a render is a bug, and a NaN metric keeps it visible in the results store.
    * ``'omit'``: pixel-channels where *any* input is NaN are left out of the mean.
    * ``'raise'``: a NaN in any input raises ``ValueError``.

    Infinities are not NaN: they propagate through the arithmetic (an infinite pixel gives
    an infinite MSE).
Shapes
    All images passed together must have exactly the same shape; a mismatch raises
    ``ValueError`` naming the shapes (no broadcasting, which would hide a transposed or
    cropped image).
"""
from __future__ import annotations

import math
import warnings
from dataclasses import asdict, dataclass
from typing import Sequence

import numpy as np
from scipy import stats

__all__ = [
    "mse", "rmse", "relmse", "mse_corrected", "reference_noise",
    "exposure_from_reference", "to_display", "ssim",
    "BiasVariance", "bias_variance",
    "SlopeFit", "convergence_slope",
    "efficiency", "time_to_error",
    "RELMSE_EPS", "LUMINANCE_WEIGHTS",
]

#: epsilon in the relMSE denominator, ``d^2 / (ref^2 + RELMSE_EPS)``.
RELMSE_EPS = 0.01
#: Rec. 709 / sRGB luminance weights used for exposure.
LUMINANCE_WEIGHTS = np.array([0.2126, 0.7152, 0.0722])

_NAN_POLICIES = ("propagate", "omit", "raise")


# ---------------------------------------------------------------------------------------
# validation helpers

def _as_image(a, name: str) -> np.ndarray:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim not in (2, 3):
        raise ValueError(f"{name} must have shape (H, W) or (H, W, C); got shape {arr.shape}")
    if arr.size == 0:
        raise ValueError(f"{name} is empty (shape {arr.shape})")
    return arr


def _same_shape(**arrays: np.ndarray) -> None:
    shapes = {k: v.shape for k, v in arrays.items()}
    if len(set(shapes.values())) > 1:
        desc = ", ".join(f"{k}{s}" for k, s in shapes.items())
        raise ValueError(f"image shapes differ: {desc}")


def _check_policy(nan_policy: str) -> None:
    if nan_policy not in _NAN_POLICIES:
        raise ValueError(f"nan_policy must be one of {_NAN_POLICIES}; got {nan_policy!r}")


def _nan_mask(nan_policy: str, **arrays: np.ndarray):
    """Return a boolean mask of the entries to use, or None for 'use all'."""
    _check_policy(nan_policy)
    bad = np.zeros(next(iter(arrays.values())).shape, dtype=bool)
    for a in arrays.values():
        bad |= np.isnan(a)
    if not bad.any():
        return None
    if nan_policy == "raise":
        names = [k for k, a in arrays.items() if np.isnan(a).any()]
        raise ValueError(f"NaN in {', '.join(names)} ({int(bad.sum())} entries) with nan_policy='raise'")
    if nan_policy == "propagate":
        return "nan"
    return ~bad


def _masked_mean(values: np.ndarray, mask) -> float:
    if mask is None:
        return float(np.mean(values))
    if isinstance(mask, str):
        return math.nan
    if not mask.any():
        return math.nan
    return float(np.mean(values[mask]))


def _positive_spp(spp, name: str = "spp") -> float:
    n = float(spp)
    if not (n > 0 and math.isfinite(n)):
        raise ValueError(f"{name} must be a positive finite number; got {spp!r}")
    return n


# ---------------------------------------------------------------------------------------
# pixel-error metrics

def mse(img, ref, *, nan_policy: str = "propagate") -> float:
    r"""Mean squared error over all pixels and channels.

    .. math:: \mathrm{MSE} = \frac{1}{HWC} \sum_{p,c} (x_{pc} - r_{pc})^2

    Parameters
    ----------
    img, ref : array_like, shape (H, W) or (H, W, C)
        Test image and reference, linear radiance, same shape.
    nan_policy : {'propagate', 'omit', 'raise'}
        See the module docstring.

    Returns
    -------
    float

    Examples
    --------
    >>> mse([[1.0, 2.0]], [[1.0, 4.0]])
    2.0
    """
    x, r = _as_image(img, "img"), _as_image(ref, "ref")
    _same_shape(img=x, ref=r)
    mask = _nan_mask(nan_policy, img=x, ref=r)
    return _masked_mean((x - r) ** 2, mask)


def rmse(img, ref, *, nan_policy: str = "propagate") -> float:
    r"""Root mean squared error, :math:`\sqrt{\mathrm{MSE}}`.

    Examples
    --------
    >>> rmse([[1.0, 2.0]], [[1.0, 4.0]])  # sqrt(2)
    1.4142135623730951
    """
    return math.sqrt(mse(img, ref, nan_policy=nan_policy))


def relmse(img, ref, *, eps: float = RELMSE_EPS, nan_policy: str = "propagate") -> float:
    r"""Relative mean squared error.

    .. math:: \mathrm{relMSE} = \frac{1}{HWC} \sum_{p,c}
              \frac{(x_{pc} - r_{pc})^2}{r_{pc}^2 + \epsilon}, \qquad \epsilon = 0.01

    The epsilon keeps black reference pixels from dominating (DESIGN.md section 4).

    Examples
    --------
    >>> relmse([[1.0, 0.1]], [[0.0, 0.0]])  # (1/0.01 + 0.01/0.01) / 2
    50.5
    """
    if not eps > 0:
        raise ValueError(f"eps must be positive; got {eps}")
    x, r = _as_image(img, "img"), _as_image(ref, "ref")
    _same_shape(img=x, ref=r)
    mask = _nan_mask(nan_policy, img=x, ref=r)
    return _masked_mean((x - r) ** 2 / (r * r + eps), mask)


def reference_noise(ref_var, ref_spp, *, nan_policy: str = "propagate") -> float:
    r"""Mean variance of the reference's pixel means, :math:`\overline{\sigma^2_{ref}} / N_{ref}`.

    This is how much the reference's own Monte Carlo noise adds to the expected MSE of
    any image measured against it.

    Examples
    --------
    >>> reference_noise([[2.0, 4.0]], 100)
    0.03
    """
    v = _as_image(ref_var, "ref_var")
    n = _positive_spp(ref_spp, "ref_spp")
    if np.any(v < 0):
        raise ValueError("ref_var has negative entries")
    mask = _nan_mask(nan_policy, ref_var=v)
    return _masked_mean(v / n, mask)


def mse_corrected(img, ref, ref_var, ref_spp, *, nan_policy: str = "propagate") -> float:
    r"""MSE against the *true* image, estimated by removing the reference's own noise.

    A reference ``R`` rendered at :math:`N_{ref}` spp is itself noisy. For a test image
    ``X`` independent of it,

    .. math:: E[(X - R)^2] = E[(X - \mu)^2] + \mathrm{Var}(R),
              \qquad \mathrm{Var}(R) = \sigma^2_{ref} / N_{ref},

    so the plain MSE is biased *up* by the reference noise. This returns

    .. math:: \mathrm{MSE}_{corr} = \mathrm{MSE}(X, R)
              - \frac{1}{HWC}\sum_{p,c} \frac{\sigma^2_{ref,pc}}{N_{ref}},

    an unbiased estimate of the MSE against the noise-free image (given an unbiased
    per-sample ``ref_var``). **It is a reference-noise correction**: it can come out
    slightly negative when the test image is nearly perfect or the reference is very
    noisy; it is deliberately not clipped (clipping would bias averages over seeds).

    Parameters
    ----------
    img, ref : array_like
        Test image and reference mean, same shape.
    ref_var : array_like
        Per-sample variance of the reference, same shape.
    ref_spp : int
        Samples per pixel of the reference.

    Examples
    --------
    >>> mse_corrected([[1.0, 2.0]], [[1.0, 4.0]], [[10.0, 30.0]], 100)  # 2 - 0.2
    1.8
    """
    x, r, v = _as_image(img, "img"), _as_image(ref, "ref"), _as_image(ref_var, "ref_var")
    _same_shape(img=x, ref=r, ref_var=v)
    n = _positive_spp(ref_spp, "ref_spp")
    if np.any(v < 0):
        raise ValueError("ref_var has negative entries")
    mask = _nan_mask(nan_policy, img=x, ref=r, ref_var=v)
    return _masked_mean((x - r) ** 2 - v / n, mask)


# ---------------------------------------------------------------------------------------
# display images and SSIM

def _luminance(img: np.ndarray) -> np.ndarray:
    if img.ndim == 3 and img.shape[-1] == 3:
        return img @ LUMINANCE_WEIGHTS
    if img.ndim == 3:
        return img.mean(axis=-1)
    return img


def exposure_from_reference(ref, *, percentile: float = 99.0) -> float:
    r"""Exposure scale that maps the reference's bright end to display white.

    Returns :math:`k = 1 / Y_q`, where :math:`Y_q` is the ``percentile``-th percentile of
    the reference's luminance (Rec. 709 weights for RGB, the channel mean otherwise),
    ignoring NaNs. The same ``k`` is applied to the test image and the reference, so a
    too-bright render is not normalised away. An all-black (or all-NaN) reference gives
    ``k = 1``.

    Examples
    --------
    >>> exposure_from_reference(np.full((4, 4, 3), 2.0))
    0.5
    """
    r = _as_image(ref, "ref")
    if not 0 < percentile <= 100:
        raise ValueError(f"percentile must be in (0, 100]; got {percentile}")
    y = _luminance(r)
    y = y[np.isfinite(y)]
    if y.size == 0:
        return 1.0
    q = float(np.percentile(y, percentile))
    return 1.0 / q if q > 0 else 1.0


def to_display(img, exposure: float) -> np.ndarray:
    """Linear radiance -> display sRGB in [0, 1]: scale by ``exposure``, clip to [0, 1],
    then the sRGB transfer function (``colour.cctf_encoding(..., function='sRGB')``).
    NaNs stay NaN.

    Examples
    --------
    >>> to_display(np.array([[0.0, 0.5, 4.0]]), 0.5).round(4).tolist()
    [[0.0, 0.5371, 1.0]]
    """
    import colour

    x = np.clip(_as_image(img, "img") * float(exposure), 0.0, 1.0)
    return np.asarray(colour.cctf_encoding(x, function="sRGB"), dtype=np.float64)


#: side of the Gaussian SSIM window used by scikit-image with sigma=1.5 (truncate 3.5)
_SSIM_WINDOW = 2 * int(3.5 * 1.5 + 0.5) + 1  # = 11


def ssim(img, ref, *, exposure: float | None = None, nan_policy: str = "propagate") -> float:
    r"""Structural similarity of the *display* images (DESIGN.md section 4).

    Steps: exposure ``k`` from the reference (:func:`exposure_from_reference` unless
    given), both images scaled by ``k``, clipped to [0, 1], sRGB-encoded with
    colour-science, then::

        skimage.metrics.structural_similarity(x, r, data_range=1.0, channel_axis=-1,
            gaussian_weights=True, sigma=1.5, use_sample_covariance=False)

    (``channel_axis=None`` for single-channel ``(H, W)`` images). 1 means identical.

    Small images: with ``sigma=1.5`` scikit-image uses an 11 x 11 Gaussian window and
    rejects images whose smaller side is below 11. Here images with smaller side ``s``,
    ``3 <= s < 11``, are compared with ``win_size`` set to the largest odd number
    ``<= s`` (the Gaussian weights are unchanged; only the border crop shrinks), so tiny
    test renders still get a number. Below 3 pixels SSIM is meaningless: the result is
    NaN with a ``RuntimeWarning``.

    NaN policy: ``'propagate'`` (default) returns NaN if any input pixel is NaN;
    ``'raise'`` raises; ``'omit'`` is not supported (a window statistic cannot skip
    pixels) and raises ``ValueError``.

    Examples
    --------
    >>> ref = np.random.default_rng(0).random((16, 16, 3))
    >>> ssim(ref, ref)
    1.0
    """
    from skimage.metrics import structural_similarity

    if nan_policy == "omit":
        raise ValueError("ssim does not support nan_policy='omit'")
    x, r = _as_image(img, "img"), _as_image(ref, "ref")
    _same_shape(img=x, ref=r)
    if _nan_mask(nan_policy, img=x, ref=r) is not None:
        return math.nan
    side = min(x.shape[0], x.shape[1])
    if side < 3:
        warnings.warn(f"ssim: image {x.shape[:2]} is smaller than 3x3; returning NaN",
                      RuntimeWarning, stacklevel=2)
        return math.nan
    k = exposure_from_reference(r) if exposure is None else float(exposure)
    xd, rd = to_display(x, k), to_display(r, k)
    win = None if side >= _SSIM_WINDOW else (side if side % 2 == 1 else side - 1)
    return float(structural_similarity(
        xd, rd, data_range=1.0, channel_axis=-1 if x.ndim == 3 else None,
        gaussian_weights=True, sigma=1.5, use_sample_covariance=False, win_size=win))


# ---------------------------------------------------------------------------------------
# bias / variance decomposition over independent seeds

@dataclass(frozen=True)
class BiasVariance:
    """Result of :func:`bias_variance`. All figures are means over pixel-channels.

    Attributes
    ----------
    bias2 : float
        Unbiased estimate of mean squared bias, ``mean_p b_p^2`` (can be slightly < 0).
    bias2_se : float
        Standard error of ``bias2`` (from the spread of per-pixel terms).
    z : float
        ``bias2 / bias2_se``.
    p_value : float
        One-sided p-value of ``H0: all b_p = 0`` against ``bias2 > 0``.
    bias_significant : bool
        ``p_value < alpha``; false-positive rate ``alpha`` (asymptotically in the pixel
        count; conservative for right-skewed per-pixel terms).
    alpha : float
    variance : float
        Mean variance of *one* image (one seed, ``spp`` samples): ``E[MSE] ~ bias2 +
        variance + reference_noise``.
    sample_variance : float
        Mean per-sample variance, ``variance * spp`` (NaN if ``spp`` unknown).
    mse : float
        Mean over seeds of each image's MSE against ``ref``.
    mse_corrected : float
        ``mse`` minus the reference noise (NaN without ``ref_var``/``ref_spp``).
    bias : float
        Mean signed difference ``mean_p (mean_k x_k - r)`` (direction of the bias).
    relative_bias : float
        ``sum(mean_k x_k - r) / sum(r)`` (NaN if the reference sums to 0).
    k : int
        Number of seeds.
    n_pixels : int
        Number of pixels that entered the estimate.
    variance_source : str
        ``'seeds'`` (between-seed variance) or ``'samples'`` (``var_k``).
    """

    bias2: float
    bias2_se: float
    z: float
    p_value: float
    bias_significant: bool
    alpha: float
    variance: float
    sample_variance: float
    mse: float
    mse_corrected: float
    bias: float
    relative_bias: float
    k: int
    n_pixels: int
    variance_source: str

    def to_dict(self) -> dict:
        return asdict(self)


def bias_variance(images_k, ref, ref_var=None, ref_spp=None, var_k=None, spp=None, *,
                  alpha: float = 0.01, variance_source: str = "auto", var_ddof: int = 0,
                  nan_policy: str = "propagate") -> BiasVariance:
    r"""Squared bias and variance of a renderer from ``K`` independent seeds, with a test.

    Model. Seed ``k`` gives pixel means :math:`x_{kp} = \mu_p + b_p + e_{kp}`, independent
    over ``k`` and ``p``, :math:`\mathrm{Var}(e_{kp}) = \sigma^2_p / N` (``N`` = ``spp``).
    The reference is :math:`r_p = \mu_p + f_p`, :math:`\mathrm{Var}(f_p) = \tau^2_p /
    N_{ref}`, independent of the seeds. With :math:`\bar x_p = \frac1K\sum_k x_{kp}` and
    :math:`D_p = \bar x_p - r_p`:

    .. math:: E[D_p^2] = b_p^2 + s_p^2, \qquad
              s_p^2 = \frac{\sigma^2_p}{K N} + \frac{\tau^2_p}{N_{ref}}.

    With an unbiased :math:`\hat s_p^2` the per-pixel term
    :math:`T_p = D_p^2 - \hat s_p^2` has :math:`E[T_p] = b_p^2` **exactly**, so

    .. math:: \widehat{\mathrm{bias}^2} = \frac{1}{P}\sum_p T_p

    is unbiased for the mean squared bias and has expectation 0 when there is no bias.
    :math:`\hat s_p^2` uses the between-seed variance :math:`S_p^2 / K`
    (:math:`S_p^2` with ``ddof=1``, ``K >= 2``; ``variance_source='seeds'``) or the
    renderer's per-sample variance, :math:`\overline{v_{kp}} \cdot
    \frac{N-\mathrm{ddof}}{N-1} / (K N)` (``variance_source='samples'``; ``var_k`` from ``rt.render`` is second moment
    minus mean squared, ``var_ddof=0``). ``'auto'`` picks ``'seeds'`` when ``K >= 2`` else
    ``'samples'``. Without ``ref_var`` the reference is taken as noise-free.

    Test. The :math:`T_p` are independent across pixels (channels of one pixel are not,
    so they are averaged within the pixel first: :math:`\bar T_p`). The standard error is
    the empirical one, :math:`\mathrm{se} = \mathrm{sd}(\bar T_p)/\sqrt{P}`, valid whatever
    the noise distribution, and :math:`z = \widehat{\mathrm{bias}^2}/\mathrm{se}` is
    asymptotically standard normal under :math:`H_0: b_p = 0\ \forall p` (CLT over
    pixels). ``p_value = 1 - Phi(z)`` (one-sided: bias can only add), and
    ``bias_significant = p_value < alpha`` has false-positive rate ``alpha`` for large
    ``P``; because :math:`T_p` is right-skewed the studentised mean is left-skewed, so for
    moderate ``P`` the rate is at most about ``alpha`` (measured in
    ``tests/test_metrics.py``). The reference must be independent of the seeds.

    Parameters
    ----------
    images_k : array_like, shape (K, H, W[, C])
        ``K`` independent renders (distinct seeds) at ``spp`` each.
    ref : array_like, shape (H, W[, C])
        Reference image.
    ref_var : array_like, optional
        Per-sample variance of the reference (needs ``ref_spp``).
    ref_spp : int, optional
    var_k : array_like, shape (K, H, W[, C]), optional
        Per-sample variance of each render (needs ``spp``).
    spp : int, optional
        Samples per pixel of each render.
    alpha : float
        Level of ``bias_significant``.
    nan_policy : {'propagate', 'omit', 'raise'}
        ``'omit'`` drops a whole pixel if any of its entries (any seed, channel or input)
        is NaN.

    Returns
    -------
    BiasVariance

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> ref = np.ones((32, 32, 3))
    >>> imgs = ref + 0.1 * rng.standard_normal((4, 32, 32, 3))
    >>> bv = bias_variance(imgs, ref)
    >>> bool(bv.bias_significant), round(bv.variance, 3)
    (False, 0.01)
    >>> bool(bias_variance(imgs + 0.05, ref).bias_significant)
    True
    """
    if not 0 < alpha < 1:
        raise ValueError(f"alpha must be in (0, 1); got {alpha}")
    imgs = np.asarray(images_k, dtype=np.float64)
    r = _as_image(ref, "ref")
    if imgs.ndim != r.ndim + 1 or imgs.shape[1:] != r.shape:
        raise ValueError(f"images_k must have shape (K,) + ref.shape = (K,) + {r.shape}; "
                         f"got {imgs.shape}")
    K = imgs.shape[0]
    if K < 1:
        raise ValueError("images_k holds no image")
    if (ref_var is None) != (ref_spp is None):
        raise ValueError("give ref_var and ref_spp together (or neither)")
    rv = None
    if ref_var is not None:
        rv = _as_image(ref_var, "ref_var")
        _same_shape(ref=r, ref_var=rv)
        if np.any(rv < 0):
            raise ValueError("ref_var has negative entries")
        n_ref = _positive_spp(ref_spp, "ref_spp")
    vk = None
    if var_k is not None:
        vk = np.asarray(var_k, dtype=np.float64)
        if vk.shape != imgs.shape:
            raise ValueError(f"var_k shape {vk.shape} differs from images_k shape {imgs.shape}")
        if np.any(vk < 0):
            raise ValueError("var_k has negative entries")
    n = _positive_spp(spp) if spp is not None else None

    if variance_source == "auto":
        variance_source = "seeds" if K >= 2 else "samples"
    if variance_source == "seeds":
        if K < 2:
            raise ValueError("variance_source='seeds' needs K >= 2 seeds")
    elif variance_source == "samples":
        if vk is None or n is None:
            raise ValueError("variance_source='samples' (or K == 1) needs var_k and spp")
        if n < 2 or var_ddof not in (0, 1):
            raise ValueError(f"variance_source='samples' needs spp >= 2 and var_ddof 0 or 1; "
                             f"got spp={n}, var_ddof={var_ddof}")
    else:
        raise ValueError(f"variance_source must be 'auto', 'seeds' or 'samples'; got {variance_source!r}")

    # pixel mask for NaNs (whole pixels)
    _check_policy(nan_policy)
    parts = [imgs, r[None]] + ([rv[None]] if rv is not None else []) + ([vk] if vk is not None else [])
    bad = np.zeros(r.shape[:2], dtype=bool)
    for a in parts:
        nan = np.isnan(a)
        bad |= nan.reshape(nan.shape[0], r.shape[0], r.shape[1], -1).any(axis=(0, 3))
    if bad.any():
        if nan_policy == "raise":
            raise ValueError(f"NaN in inputs ({int(bad.sum())} pixels) with nan_policy='raise'")
        if nan_policy == "propagate":
            nanf = math.nan
            return BiasVariance(nanf, nanf, nanf, nanf, False, alpha, nanf, nanf, nanf, nanf,
                                nanf, nanf, K, int(bad.size), variance_source)
    keep = ~bad
    if not keep.any():
        raise ValueError("no pixel left after omitting NaNs")

    # flatten to (K, P, C) over kept pixels
    C = 1 if r.ndim == 2 else r.shape[2]
    X = imgs.reshape(K, -1, C)[:, keep.ravel()]
    R = r.reshape(-1, C)[keep.ravel()]
    P = R.shape[0]
    xbar = X.mean(axis=0)
    D = xbar - R
    if variance_source == "seeds":
        var_img = X.var(axis=0, ddof=1)                      # variance of one image
    else:
        V = vk.reshape(K, -1, C)[:, keep.ravel()]
        # ddof -> unbiased per-sample variance -> variance of one image's pixel mean
        var_img = V.mean(axis=0) * ((n - var_ddof) / (n - 1)) / n
    s2 = var_img / K
    ref_noise = np.zeros_like(R)
    if rv is not None:
        ref_noise = rv.reshape(-1, C)[keep.ravel()] / n_ref
        s2 = s2 + ref_noise
    T = (D * D - s2).mean(axis=1)                            # per pixel, channels averaged
    bias2 = float(T.mean())
    se = float(T.std(ddof=1) / math.sqrt(P)) if P > 1 else math.nan
    if se > 0:
        z = bias2 / se
    elif P > 1:
        # every per-pixel term equal: all-zero means exact agreement, otherwise a constant offset
        z = 0.0 if bias2 <= 0 else math.inf
    else:
        z = math.nan
    p = float(stats.norm.sf(z)) if not math.isnan(z) else math.nan
    variance = float(var_img.mean())
    per_image_mse = ((X - R[None]) ** 2).mean(axis=(1, 2))
    mse_k = float(per_image_mse.mean())
    sum_r = float(R.sum())
    return BiasVariance(
        bias2=bias2, bias2_se=se, z=float(z), p_value=p,
        bias_significant=bool(p < alpha), alpha=float(alpha),
        variance=variance, sample_variance=variance * n if n is not None else math.nan,
        mse=mse_k, mse_corrected=mse_k - float(ref_noise.mean()) if rv is not None else math.nan,
        bias=float(D.mean()), relative_bias=float(D.sum() / sum_r) if sum_r != 0 else math.nan,
        k=int(K), n_pixels=int(P), variance_source=variance_source)


# ---------------------------------------------------------------------------------------
# convergence

@dataclass(frozen=True)
class SlopeFit:
    """Least-squares fit ``log(rmse) = intercept + slope * log(spp)``.

    ``ci_low``/``ci_high`` is the two-sided ``confidence`` interval of the slope
    (Student t with ``n - 2`` dof; NaN when ``n < 3``); ``stderr`` its standard error;
    ``r2`` the coefficient of determination; ``n`` the number of points used.
    """

    slope: float
    intercept: float
    stderr: float
    ci_low: float
    ci_high: float
    confidence: float
    r2: float
    n: int

    def to_dict(self) -> dict:
        return asdict(self)


def convergence_slope(spp, rmse, *, confidence: float = 0.95,
                      nan_policy: str = "propagate") -> SlopeFit:
    r"""Slope of log RMSE over log spp, with a confidence interval.

    Unbiased Monte Carlo has :math:`\mathrm{RMSE} = \sigma / \sqrt{N}`: slope -0.5. With
    a bias ``b``, :math:`\mathrm{RMSE} = \sqrt{b^2 + \sigma^2/N}` flattens towards slope 0
    at high ``N``. Note that RMSE against a noisy reference flattens the same way at the
    reference's noise floor: fit RMSE from :func:`mse_corrected` (or use a reference with
    many more spp than the sweep) when that matters.

    Repeated ``spp`` values (several seeds) are fine: every (spp, rmse) pair is one point.
    The interval treats the points as independent with equal log-scale noise.

    Parameters
    ----------
    spp, rmse : array_like, 1-D, same length
        Positive sample counts and positive RMSEs (zero or negative values cannot be put
        on a log scale and raise ``ValueError``).
    confidence : float
    nan_policy : {'propagate', 'omit', 'raise'}
        ``'omit'`` drops the points where either value is NaN.

    Examples
    --------
    >>> s = [1, 4, 16, 64]
    >>> fit = convergence_slope(s, [1 / np.sqrt(n) for n in s])
    >>> round(fit.slope, 6), round(fit.stderr, 6)
    (-0.5, 0.0)
    """
    x = np.asarray(spp, dtype=np.float64).ravel()
    y = np.asarray(rmse, dtype=np.float64).ravel()
    if x.shape != y.shape:
        raise ValueError(f"spp and rmse have different lengths: {x.shape} vs {y.shape}")
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must be in (0, 1); got {confidence}")
    _check_policy(nan_policy)
    nan = np.isnan(x) | np.isnan(y)
    if nan.any():
        if nan_policy == "raise":
            raise ValueError("NaN in spp or rmse with nan_policy='raise'")
        if nan_policy == "propagate":
            return SlopeFit(math.nan, math.nan, math.nan, math.nan, math.nan,
                            float(confidence), math.nan, int(x.size))
        x, y = x[~nan], y[~nan]
    if np.any(x <= 0) or np.any(y <= 0):
        raise ValueError("spp and rmse must be positive to fit on a log-log scale")
    n = x.size
    if n < 2:
        raise ValueError(f"need at least 2 points to fit a slope; got {n}")
    lx, ly = np.log(x), np.log(y)
    mx, my = lx.mean(), ly.mean()
    sxx = float(((lx - mx) ** 2).sum())
    if sxx == 0:
        raise ValueError("all spp values are equal: slope undefined")
    slope = float(((lx - mx) * (ly - my)).sum() / sxx)
    intercept = float(my - slope * mx)
    resid = ly - (intercept + slope * lx)
    ss_res = float((resid ** 2).sum())
    ss_tot = float(((ly - my) ** 2).sum())
    r2 = 1.0 - ss_res / ss_tot if ss_tot > 0 else 1.0
    if n >= 3:
        stderr = math.sqrt(ss_res / (n - 2) / sxx)
        half = float(stats.t.ppf(0.5 + confidence / 2, n - 2)) * stderr
        lo, hi = slope - half, slope + half
    else:
        stderr, lo, hi = math.nan, math.nan, math.nan
    return SlopeFit(slope, intercept, stderr, lo, hi, float(confidence), float(r2), int(n))


# ---------------------------------------------------------------------------------------
# cost

def efficiency(mse, seconds):
    r"""Monte Carlo efficiency, :math:`1 / (\mathrm{MSE} \cdot t)`: higher is better.

    Vectorised over arrays (returns an array then, a float for scalars). ``mse == 0``
    gives ``inf``; NaN propagates; negative ``mse`` (e.g. a noise-corrected MSE that came
    out below zero) or ``seconds <= 0`` raise ``ValueError``, since the efficiency is
    then undefined rather than merely large.

    Examples
    --------
    >>> efficiency(0.01, 2.0)
    50.0
    """
    m = np.asarray(mse, dtype=np.float64)
    t = np.asarray(seconds, dtype=np.float64)
    if np.any(m < 0):
        raise ValueError("efficiency: mse must be >= 0")
    if np.any(t <= 0):
        raise ValueError("efficiency: seconds must be > 0")
    with np.errstate(divide="ignore"):
        out = 1.0 / (m * t)
    return float(out) if out.ndim == 0 else out


def time_to_error(seconds, rmse, target: float) -> float:
    r"""Seconds needed to reach ``rmse <= target``, interpolated on a log-log scale.

    The points are sorted by time; the first segment ``(t_i, e_i) -> (t_{i+1}, e_{i+1})``
    with :math:`e_i > \mathrm{target} \ge e_{i+1}` is interpolated linearly in
    :math:`(\log t, \log e)` (a power law between the two points; exact for
    :math:`e \propto t^{-1/2}`).

    Conventions (documented, not errors):

    * never reached (all ``rmse > target``): returns ``math.nan`` - there is no
      extrapolation beyond the measured curve;
    * already reached at the cheapest point: returns ``seconds[0]``, an upper bound;
    * points with NaN are ignored; an ``rmse`` of 0 counts as reached.

    Examples
    --------
    >>> time_to_error([1.0, 4.0, 16.0], [0.4, 0.2, 0.1], 0.2)
    4.0
    >>> round(time_to_error([1.0, 4.0], [0.4, 0.2], 0.2828427), 4)  # halfway in log
    2.0
    >>> time_to_error([1.0, 4.0], [0.4, 0.2], 0.01)
    nan
    """
    t = np.asarray(seconds, dtype=np.float64).ravel()
    e = np.asarray(rmse, dtype=np.float64).ravel()
    if t.shape != e.shape:
        raise ValueError(f"seconds and rmse have different lengths: {t.shape} vs {e.shape}")
    if not target > 0:
        raise ValueError(f"target must be positive; got {target}")
    ok = ~(np.isnan(t) | np.isnan(e))
    t, e = t[ok], e[ok]
    if np.any(t <= 0) or np.any(e < 0):
        raise ValueError("seconds must be > 0 and rmse >= 0")
    if t.size == 0:
        return math.nan
    order = np.argsort(t, kind="stable")
    t, e = t[order], e[order]
    if e[0] <= target:
        return float(t[0])
    for i in range(1, t.size):
        if e[i] <= target:
            if e[i] == 0 or t[i] == t[i - 1]:
                return float(t[i])
            lt0, lt1 = math.log(t[i - 1]), math.log(t[i])
            le0, le1 = math.log(e[i - 1]), math.log(e[i])
            frac = (math.log(target) - le0) / (le1 - le0)
            return float(math.exp(lt0 + frac * (lt1 - lt0)))
    return math.nan
