"""Bias and variance of a renderer from independent seeds, with a one-sided test for bias."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy import stats

from ._checks import as_image, check_policy, positive_spp, reference_noise

__all__ = ["BiasVariance", "bias_variance"]


@dataclass(frozen=True)
class BiasVariance:
    """Result of :func:`bias_variance`; figures are means over pixel-channels.

    ``bias2`` (unbiased for the mean squared bias, can be slightly < 0), its standard error
    ``bias2_se``, ``z = bias2 / bias2_se``, the one-sided ``p_value`` of ``H0: all b_p = 0`` and
    ``bias_significant = p_value < alpha``. ``variance``: of one image's pixel means
    (``sample_variance = variance * spp``); ``mse``: the seeds' mean MSE (``mse_corrected``:
    less the reference noise); ``bias``: mean signed difference; ``relative_bias``:
    ``sum(mean_k x_k - r) / sum(r)``; ``k`` seeds, ``n_pixels`` used, ``variance_source``.
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

    With :math:`D_p = \bar x_p - r_p` (seed mean minus reference) and :math:`\hat s_p^2` an
    unbiased estimate of its variance (:math:`\sigma^2_p / (K N) + \tau^2_p / N_{ref}`),

    .. math:: \widehat{\mathrm{bias}^2} = \frac{1}{P}\sum_p (D_p^2 - \hat s_p^2)

    is unbiased for the mean squared bias. :math:`\hat s_p^2` uses the between-seed variance
    (``'seeds'``, ``ddof=1``) or the renderer's per-sample variance (``'samples'``); without
    ``ref_var`` the reference is taken as noise-free and must be independent of the seeds.
    The per-pixel terms (channels averaged) are independent, so
    :math:`z = \widehat{\mathrm{bias}^2} / (\mathrm{sd} / \sqrt{P})` is asymptotically normal
    under :math:`H_0: b_p = 0`; ``p_value = 1 - Phi(z)`` (one-sided; conservative for
    moderate ``P``, the terms being right-skewed).

    Parameters
    ----------
    images_k, ref : array_like, shapes (K, H, W[, C]) and (H, W[, C])
        ``K`` independent renders (distinct seeds) at ``spp`` each, and the reference.
    ref_var, ref_spp : optional
        Per-sample variance of the reference and its samples per pixel (together).
    var_k, spp : optional
        Per-sample variance of each render, shape (K, H, W[, C]), and their samples per pixel.
    alpha : float
        Level of ``bias_significant``.
    variance_source, var_ddof : keyword-only
        Where :math:`\hat s_p^2` comes from (``'auto'``: ``'seeds'`` when ``K >= 2``, else
        ``'samples'``) and the ddof of ``var_k`` (``rt.render``'s: 0).
    nan_policy : {'propagate', 'omit', 'raise'}
        ``'omit'`` drops a whole pixel if any of its entries is NaN.

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
    imgs, r, noise, vk, n = _checked_inputs(images_k, ref, ref_var, ref_spp, var_k, spp)
    K, P = imgs.shape[0], r.shape[0] * r.shape[1]
    variance_source = _variance_source(variance_source, K, vk, n, var_ddof)
    check_policy(nan_policy)
    # (K or 1, pixels, channels); a pixel with a NaN in any part, seed or channel is bad
    X, R = imgs.reshape(K, P, -1), r.reshape(1, P, -1)
    N, V = (None if a is None else a.reshape(-1, P, R.shape[2]) for a in (noise, vk))
    bad = np.any([np.isnan(a).any(axis=(0, 2)) for a in (X, R, N, V) if a is not None], axis=0)
    if bad.any() and nan_policy == "raise":
        raise ValueError(f"NaN in inputs ({int(bad.sum())} pixels) with nan_policy='raise'")
    if bad.any() and nan_policy == "propagate":
        nanf = math.nan
        return BiasVariance(nanf, nanf, nanf, nanf, False, alpha, nanf, nanf, nanf, nanf,
                            nanf, nanf, K, P, variance_source)
    if bad.all():
        raise ValueError("no pixel left after omitting NaNs")
    X, R = X[:, ~bad], R[0, ~bad]
    D = X.mean(axis=0) - R
    if variance_source == "seeds":
        var_img = X.var(axis=0, ddof=1)  # variance of one image
    else:  # ddof -> unbiased per-sample variance -> variance of one image's pixel mean
        var_img = V[:, ~bad].mean(axis=0) * ((n - var_ddof) / (n - 1)) / n
    ref_noise = np.zeros_like(R) if N is None else N[0, ~bad]
    bias2, se, z, p = _one_sided_test((D * D - (var_img / K + ref_noise)).mean(axis=1))  # per pixel
    variance = float(var_img.mean())
    mse_k = float(((X - R[None]) ** 2).mean(axis=(1, 2)).mean())
    sum_r = float(R.sum())
    return BiasVariance(
        bias2=bias2, bias2_se=se, z=float(z), p_value=p,
        bias_significant=bool(p < alpha), alpha=float(alpha),
        variance=variance, sample_variance=variance * n if n is not None else math.nan,
        mse=mse_k, mse_corrected=mse_k - float(ref_noise.mean()) if N is not None else math.nan,
        bias=float(D.mean()), relative_bias=float(D.sum() / sum_r) if sum_r != 0 else math.nan,
        k=int(K), n_pixels=int(R.shape[0]), variance_source=variance_source)


def _checked_inputs(images_k, ref, ref_var, ref_spp, var_k, spp):
    """``(imgs, r, ref_var / ref_spp, vk, n)`` of :func:`bias_variance`, checked for shape and sign."""
    imgs = np.asarray(images_k, dtype=np.float64)
    r = as_image(ref, "ref")
    if imgs.ndim != r.ndim + 1 or imgs.shape[1:] != r.shape:
        raise ValueError(f"images_k must have shape (K,) + ref.shape = (K,) + {r.shape}; "
                         f"got {imgs.shape}")
    if imgs.shape[0] < 1:
        raise ValueError("images_k holds no image")
    if (ref_var is None) != (ref_spp is None):
        raise ValueError("give ref_var and ref_spp together (or neither)")
    noise = None if ref_var is None else reference_noise(r, ref_var, ref_spp)
    vk = None if var_k is None else np.asarray(var_k, dtype=np.float64)
    if vk is not None and vk.shape != imgs.shape:
        raise ValueError(f"var_k shape {vk.shape} differs from images_k shape {imgs.shape}")
    if vk is not None and np.any(vk < 0):
        raise ValueError("var_k has negative entries")
    return imgs, r, noise, vk, positive_spp(spp) if spp is not None else None


def _variance_source(variance_source: str, K: int, vk, n, var_ddof: int) -> str:
    """Resolve ``'auto'`` and check that the chosen source has what it needs."""
    if variance_source == "auto":
        variance_source = "seeds" if K >= 2 else "samples"
    if variance_source == "seeds" and K < 2:
        raise ValueError("variance_source='seeds' needs K >= 2 seeds")
    if variance_source == "samples" and (vk is None or n is None):
        raise ValueError("variance_source='samples' (or K == 1) needs var_k and spp")
    if variance_source == "samples" and (n < 2 or var_ddof not in (0, 1)):
        raise ValueError(f"variance_source='samples' needs spp >= 2 and var_ddof 0 or 1; "
                         f"got spp={n}, var_ddof={var_ddof}")
    if variance_source not in ("seeds", "samples"):
        raise ValueError(f"variance_source must be 'auto', 'seeds' or 'samples'; got {variance_source!r}")
    return variance_source


def _one_sided_test(T: np.ndarray) -> tuple[float, float, float, float]:
    """Mean of the per-pixel terms, its empirical standard error, z and the one-sided p-value."""
    P = T.shape[0]
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
    return bias2, se, z, p
