"""Closed forms of optics that the checks hold the tracer to, written independently of its code."""
from __future__ import annotations

import numpy as np

__all__ = ["fresnel_dielectric"]


def fresnel_dielectric(cos_i, eta):
    r"""Unpolarised Fresnel reflectance of a smooth interface, index 1 outside and ``eta`` inside.

    ``cos_i`` is the cosine to the outward normal (negative from inside), elementwise with
    ``eta``. With :math:`c_i = |\cos_i|`, :math:`\eta_t` the relative index of the side
    entered (``eta`` from outside, ``1 / eta`` from inside) and
    :math:`c_t^2 = 1 - (1 - c_i^2) / \eta_t^2`,

    .. math:: F = \frac{r_s^2 + r_p^2}{2}, \quad
              r_s = \frac{c_i - \eta_t c_t}{c_i + \eta_t c_t}, \quad
              r_p = \frac{\eta_t c_i - c_t}{\eta_t c_i + c_t},

    and :math:`F = 1` under total internal reflection (:math:`c_t^2 \le 0`); NaN where
    ``cos_i`` is NaN, without a warning.

    Examples
    --------
    >>> round(float(fresnel_dielectric(1.0, 1.5)), 12)     # normal incidence: ((1.5 - 1) / (1.5 + 1))^2
    0.04
    >>> fresnel_dielectric([-0.5, np.nan], 1.5).tolist()   # from inside, beyond the critical angle
    [1.0, nan]
    """
    cos_i = np.asarray(cos_i, dtype=np.float64)
    eta_t = np.where(cos_i >= 0, eta, 1.0 / np.asarray(eta, dtype=np.float64))
    ci = np.abs(cos_i)
    ct2 = 1.0 - (1.0 - ci * ci) / (eta_t * eta_t)
    with np.errstate(invalid="ignore", divide="ignore"):
        ct = np.sqrt(np.maximum(ct2, 0.0))
        rs = (ci - eta_t * ct) / (ci + eta_t * ct)
        rp = (eta_t * ci - ct) / (eta_t * ci + ct)
    return np.where(ct2 <= 0, 1.0, 0.5 * (rs * rs + rp * rp))[()]
