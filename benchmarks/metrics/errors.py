"""Pixel-error metrics of one image against a reference: MSE, RMSE, relMSE, reference-noise correction, and the
relative noise of a variance image (relMSE's weights applied to a variance)."""
from __future__ import annotations

import math

from ..constants import RELMSE_EPS
from ._checks import as_image, masked_mean, nan_mask, reference_noise, same_shape

__all__ = ["mse", "rmse", "relmse", "mse_corrected", "relmse_corrected", "relative_noise"]


def mse(img, ref, *, nan_policy: str = "propagate") -> float:
    r"""Mean squared error over all pixels and channels.

    .. math:: \mathrm{MSE} = \frac{1}{HWC} \sum_{p,c} (x_{pc} - r_{pc})^2

    Examples
    --------
    >>> mse([[1.0, 2.0]], [[1.0, 4.0]])
    2.0
    """
    x, r = as_image(img, "img"), as_image(ref, "ref")
    same_shape(img=x, ref=r)
    mask = nan_mask(nan_policy, img=x, ref=r)
    return masked_mean((x - r) ** 2, mask)


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

    The epsilon keeps black reference pixels from dominating.

    Examples
    --------
    >>> relmse([[1.0, 0.1]], [[0.0, 0.0]])  # (1/0.01 + 0.01/0.01) / 2
    50.5
    """
    if not eps > 0:
        raise ValueError(f"eps must be positive; got {eps}")
    x, r = as_image(img, "img"), as_image(ref, "ref")
    same_shape(img=x, ref=r)
    mask = nan_mask(nan_policy, img=x, ref=r)
    return masked_mean((x - r) ** 2 / (r * r + eps), mask)


def relative_noise(var, ref, *, eps: float = RELMSE_EPS, nan_policy: str = "propagate") -> float:
    r"""Relative noise: a per-pixel variance weighted as :func:`relmse` weights squared errors,

    .. math:: \frac{1}{HWC} \sum_{p,c} \frac{v_{pc}}{r_{pc}^2 + \epsilon}, \qquad \epsilon = 0.01

    the expected relMSE of an unbiased image whose pixels have the variance ``var`` (a
    per-sample variance / N for an N-spp image; the per-sample variance itself gives the
    noise of one sample). ``ref`` is the reference the weights are taken at. NaN in
    ``var`` or ``ref`` follows ``nan_policy``; infinities propagate; negative variances
    are not checked.

    Examples
    --------
    >>> relative_noise([[0.5, 0.02]], [[0.0, 0.1]])  # (0.5/0.01 + 0.02/0.02) / 2
    25.5
    """
    if not eps > 0:
        raise ValueError(f"eps must be positive; got {eps}")
    v, r = as_image(var, "var"), as_image(ref, "ref")
    same_shape(var=v, ref=r)
    mask = nan_mask(nan_policy, var=v, ref=r)
    return masked_mean(v / (r * r + eps), mask)


def _corrected_terms(img, ref, ref_var, ref_spp, nan_policy) -> tuple:
    """``(r, (x - r)^2 - ref_var / ref_spp, mask)`` of the corrected metrics, inputs checked."""
    x, r = as_image(img, "img"), as_image(ref, "ref")
    same_shape(img=x, ref=r)
    noise = reference_noise(r, ref_var, ref_spp)
    return r, (x - r) ** 2 - noise, nan_mask(nan_policy, img=x, ref=r, ref_var=noise)


def mse_corrected(img, ref, ref_var, ref_spp, *, nan_policy: str = "propagate") -> float:
    r"""MSE against the *true* image: the plain MSE less the reference's own noise,

    .. math:: \mathrm{MSE}_{corr} = \mathrm{MSE}(X, R)
              - \frac{1}{HWC}\sum_{p,c} \frac{\sigma^2_{ref,pc}}{N_{ref}},

    unbiased for an independent test image (:math:`E[(X - R)^2] = E[(X - \mu)^2] +
    \mathrm{Var}(R)`); not clipped at zero (clipping would bias averages over seeds).

    Examples
    --------
    >>> mse_corrected([[1.0, 2.0]], [[1.0, 4.0]], [[10.0, 30.0]], 100)  # 2 - 0.2
    1.8
    """
    _, err, mask = _corrected_terms(img, ref, ref_var, ref_spp, nan_policy)
    return masked_mean(err, mask)


def relmse_corrected(img, ref, ref_var, ref_spp, *, eps: float = RELMSE_EPS, nan_policy: str = "propagate") -> float:
    r"""relMSE against the *true* image: :func:`relmse` less the reference's own relative noise.

    .. math:: \mathrm{relMSE}_{corr} = \frac{1}{HWC}\sum_{p,c}
              \frac{(x_{pc} - r_{pc})^2 - \sigma^2_{ref,pc} / N_{ref}}{r_{pc}^2 + \epsilon}

    The weights are taken at the noisy reference, as :func:`relmse` takes them; not clipped.

    Examples
    --------
    >>> relmse_corrected([[1.0, 2.0]], [[1.0, 4.0]], [[10.0, 30.0]], 100, eps=1.0)  # ((0 - 0.1)/2 + (4 - 0.3)/17) / 2
    0.08382352941176471
    """
    if not eps > 0:
        raise ValueError(f"eps must be positive; got {eps}")
    r, err, mask = _corrected_terms(img, ref, ref_var, ref_spp, nan_policy)
    return masked_mean(err / (r * r + eps), mask)
