"""The inputs of :func:`benchmarks.gate.compare`, checked once by :func:`prepare`: float64
``(H, W, C)`` images of the means, the variances of the means and the tails' cumulants
(:func:`tail_moments`, :func:`pixel_shape`)."""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from scipy.ndimage import uniform_filter

from ..display import as_image
from .filtered import filtered_moments

__all__ = ["Inputs", "prepare", "image3", "check_spp", "tail_moments", "pixel_shape", "neighbourhood_floor"]


def image3(a, name: str) -> np.ndarray:
    arr = as_image(a, name)
    return arr[..., None] if arr.ndim == 2 else arr


def check_spp(n, name: str, minimum: int) -> float:
    v = float(n)
    if not (math.isfinite(v) and v >= minimum):
        raise ValueError(f"{name} must be a number >= {minimum}; got {n!r}")
    return v


def neighbourhood_floor(v: np.ndarray, size: int) -> np.ndarray:
    """``max(v, mean of v over the size x size neighbourhood)`` per channel."""
    pooled = np.stack([uniform_filter(v[..., c], size=size, mode="nearest") for c in range(v.shape[2])], axis=-1)
    return np.maximum(v, pooled)


def tail_moments(tails, shape) -> tuple:
    """``(m2, m3, kappa4)`` per sample from a ``SampleMoments``, checked against the image."""
    m2, m3, k4 = (np.asarray(v, dtype=np.float64) for v in (tails.m2, tails.m3, tails.kappa4))
    if m2.ndim == 2:
        m2, m3, k4 = m2[..., None], m3[..., None], k4[..., None]
    if m2.shape != shape:
        raise ValueError(f"tails have shape {m2.shape}, the images {shape}")
    if not (np.all(np.isfinite(m2)) and np.all(np.isfinite(m3)) and np.all(np.isfinite(k4))):
        raise ValueError("tails have non-finite moments")
    if int(tails.n) < 2:
        raise ValueError(f"tails need >= 2 samples per pixel; got {tails.n}")
    return m2, m3, k4


def pixel_shape(m2, m3, k4, *, exact, n_t) -> tuple:
    """Skewness and excess kurtosis of each pixel mean: the worse of the pixel's own per-sample
    shape and its 3x3 neighbourhood's (whose noise the pixel level borrows), over ``sqrt(n)``, ``n``."""
    m2 = np.where(exact, 0.0, m2)

    def shape(s3, s4, s2):
        with np.errstate(divide="ignore", invalid="ignore"):
            ok = s2 > 0
            safe = np.where(ok, s2, 1.0)
            return np.where(ok, np.abs(s3) / safe ** 1.5, 0.0), np.where(ok, np.abs(s4) / safe ** 2, 0.0)

    pool = lambda v: neighbourhood_floor(v, 3)  # noqa: E731
    own = shape(m3, k4, m2)
    nb = shape(pool(np.abs(m3)), pool(np.abs(k4)), pool(m2))
    return np.maximum(own[0], nb[0]) / math.sqrt(n_t), np.maximum(own[1], nb[1]) / n_t


def _variance(v: np.ndarray, name: str, n: float, ddof: int) -> np.ndarray:
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} has non-finite entries")
    # second moment minus squared mean can come out slightly negative in float32
    scale = max(np.abs(v).max(), 1.0)
    if np.any(v < -1e-5 * scale):
        raise ValueError(f"{name} has negative entries (min {v.min():g})")
    v = np.maximum(v, 0.0)
    if ddof not in (0, 1):
        raise ValueError(f"var_ddof must be 0 or 1; got {ddof}")
    if ddof == 0:
        v = v * (n / (n - 1.0))  # second moment minus squared mean -> unbiased
    return v


@dataclass(frozen=True)
class Inputs:
    """Checked inputs of :func:`compare`, float64 ``(H, W, C)`` images.

    ``x``, ``r``: means (``x`` set to ``r`` where the test is non-finite, ``bad``); ``a``,
    ``b``: variances of the pixel means; ``fa``: floor of ``a`` or None; ``k3``, ``k4``:
    cumulants of the test's pixel means; ``g1``, ``g2``: the pixel level's shapes;
    ``summed``: the variances and cumulants the tile and image levels sum (a filtered
    render's samples'), or None where they are the pixels' own.
    """

    x: np.ndarray
    r: np.ndarray
    a: np.ndarray
    b: np.ndarray
    fa: np.ndarray | None
    k3: np.ndarray
    k4: np.ndarray
    g1: np.ndarray
    g2: np.ndarray
    bad: np.ndarray
    diff: np.ndarray
    abs_scale: np.ndarray
    n_t: float
    n_r: float
    zero_var_rtol: float
    summed: dict | None = None

    def for_sums(self, name: str) -> np.ndarray:
        """``a``, ``b``, ``fa``, ``k3`` or ``k4`` as the tile and image levels sum them."""
        return getattr(self, name) if self.summed is None else self.summed[name]

    def sums(self, reduce, *, summed: bool = False) -> dict:
        """The variance sums of :func:`benchmarks.gate.levels._welch_from_sums`, reduced by ``reduce``."""
        a, b, fa = ((self.for_sums(k) for k in ("a", "b", "fa")) if summed else (self.a, self.b, self.fa))
        out = dict(a=reduce(a), b=reduce(b), a2=reduce(a * a), b2=reduce(b * b))
        if fa is not None:
            out.update(fa=reduce(fa), fa2=reduce(fa * fa))
        return out


def prepare(test_mean, test_var, test_spp, ref_mean, ref_var, ref_spp, *, var_ddof, zero_var_rtol,
             variance_floor, tails, pixel_samples=None, filter_weights=None) -> Inputs:
    """Validate and convert the images of :func:`compare` (see its parameters)."""
    if filter_weights is not None:
        return _prepare_filtered(test_mean, test_spp, ref_mean, ref_var, ref_spp, var_ddof=var_ddof,
                                 zero_var_rtol=zero_var_rtol, variance_floor=variance_floor, tails=tails,
                                 pixel_samples=pixel_samples, weights=filter_weights)
    x, vx = image3(test_mean, "test_mean"), image3(test_var, "test_var")
    r, vr = image3(ref_mean, "ref_mean"), image3(ref_var, "ref_var")
    shapes = {"test_mean": x.shape, "test_var": vx.shape, "ref_mean": r.shape, "ref_var": vr.shape}
    if len(set(shapes.values())) > 1:
        raise ValueError("image shapes differ: " + ", ".join(f"{k}{s}" for k, s in shapes.items()))
    n_t = check_spp(test_spp, "test_spp", 2)
    n_r = check_spp(ref_spp, "ref_spp", 2)
    if not np.all(np.isfinite(r)):
        raise ValueError("ref_mean has non-finite entries")
    vr = _variance(vr, "ref_var", n_r, var_ddof)
    bad = ~np.isfinite(x) | ~np.isfinite(vx)
    vx = _variance(np.where(bad, 0.0, vx), "test_var", n_t, var_ddof)
    x = np.where(bad, r, x)  # neutral stand-in; these pixel-channels fail at the pixel level
    zeros = np.zeros_like(x)
    k3 = k4 = g1 = g2 = zeros
    fa = vr / n_t if variance_floor == "reference" else None
    if tails is not None:
        m2, m3, k4s = tail_moments(tails, x.shape)
        if variance_floor == "reference":
            # the same estimator's variance, from many more samples: the floor that holds
            vx = np.maximum(vx, m2 * (tails.n / (tails.n - 1.0)))
            fa = None
        k3, k4 = m3 / n_t ** 2, k4s / n_t ** 3
    # a per-sample variance at float-rounding level (~1e-15 on a directly seen light) is zero:
    # else a 1e-6 relative difference in the emitters' constants would be "significant"
    vx = np.where(vx <= (0.1 * zero_var_rtol * x) ** 2, 0.0, vx)
    vr = np.where(vr <= (0.1 * zero_var_rtol * r) ** 2, 0.0, vr)
    if tails is not None:
        g1, g2 = pixel_shape(m2, m3, k4s, exact=(vx == 0) & (vr == 0), n_t=n_t)
    return Inputs(x=x, r=r, a=vx / n_t, b=vr / n_r, fa=fa, k3=k3, k4=k4, g1=g1, g2=g2, bad=bad,
                  diff=x - r, abs_scale=np.maximum(np.abs(x), np.abs(r)), n_t=n_t, n_r=n_r,
                  zero_var_rtol=zero_var_rtol)


def _prepare_filtered(test_mean, test_spp, ref_mean, ref_var, ref_spp, *, var_ddof, zero_var_rtol,
                      variance_floor, tails, pixel_samples, weights) -> Inputs:
    """:func:`prepare` for a filtered render: the pixels' moments from the samples'
    (:func:`benchmarks.gate.filtered.filtered_moments`), the samples' own for the sums."""
    try:
        box_mean, box_var = pixel_samples
    except (TypeError, ValueError):
        raise ValueError("pixel_samples must be a (mean, variance) pair of images") from None
    d = prepare(test_mean, box_var, test_spp, ref_mean, ref_var, ref_spp, var_ddof=var_ddof,
                 zero_var_rtol=zero_var_rtol, variance_floor="none", tails=None)
    mu = image3(box_mean, "pixel_samples mean")
    if mu.shape != d.x.shape or not np.all(np.isfinite(mu)):
        raise ValueError(f"pixel_samples mean must be finite with the images' shape {d.x.shape}")
    n_t = d.n_t
    v_box = d.a * n_t  # the samples' per-sample variance, de-biased and zero below rounding
    m3 = k4 = None
    if tails is not None:
        m2t, m3, k4 = tail_moments(tails, d.x.shape)
        if variance_floor == "reference":
            v_box = np.maximum(v_box, m2t * (tails.n / (tails.n - 1.0)))
    m2f, m3f, k4f = filtered_moments(weights, mean=mu, variance=v_box, filtered_mean=d.x, m3=m3, k4=k4)
    a = np.where(d.bad, 0.0, m2f) / n_t
    a_sum = np.where(d.bad, 0.0, v_box) / n_t
    with np.errstate(divide="ignore", invalid="ignore"):
        # the reference shares the filter: its sums' variance relates to its pixels' as ours
        inflate = np.where(a > 0, a_sum / np.where(a > 0, a, 1.0), 1.0)
    fa = d.b * d.n_r / n_t if variance_floor == "reference" and tails is None else None
    summed = dict(a=a_sum, b=d.b * inflate, fa=None if fa is None else fa * inflate, k3=d.k3, k4=d.k4)
    shape = {}
    if tails is not None:
        summed.update(k3=m3 / n_t ** 2, k4=k4 / n_t ** 3)
        g1, g2 = pixel_shape(m2f, m3f, k4f, exact=(a == 0) & (d.b == 0), n_t=n_t)
        shape = dict(k3=m3f / n_t ** 2, k4=k4f / n_t ** 3, g1=g1, g2=g2)
    return dataclasses.replace(d, a=a, fa=fa, summed=summed, **shape)
