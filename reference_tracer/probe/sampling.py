"""The core's sampling routines run one batch at a time: the warps of ``sampling/warp.h``
(:func:`warp_sample`, :func:`warp_pdf`), the materials' BSDF sampling and evaluation as the
integrator calls them (:func:`bsdf_sample`, :func:`bsdf_eval_pdf`) and the rough plastic's
coating tables (:func:`rough_plastic_table`): what the chi-square tests measure.
"""
from __future__ import annotations

import numpy as np

from .layout import core

__all__ = ["warp_sample", "warp_pdf", "bsdf_sample", "bsdf_eval_pdf", "rough_plastic_table"]


def warp_sample(name: str, u, param: float = 0.0, *, packed: bool = False) -> np.ndarray:
    """Warp uniform numbers with a routine of ``sampling/warp.h``.

    Parameters
    ----------
    name : str
        ``uniform_hemisphere``, ``cosine_hemisphere``, ``uniform_sphere``, ``uniform_cone``
        or ``concentric_disk``.
    u : ndarray, shape (n, 2)
        C-contiguous float64 uniform numbers in [0, 1).
    param : float, optional
        ``1 - cos(theta_max)`` for ``uniform_cone``.
    packed : bool, optional
        The pack version the wavefront integrator runs (``cosine_hemisphere`` and
        ``concentric_disk`` only).

    Returns
    -------
    ndarray
        (n, 3) local directions (+z the normal), (n, 2) points for ``concentric_disk``.

    Examples
    --------
    >>> import numpy as np
    >>> warp_sample("cosine_hemisphere", np.array([[0.5, 0.5]])).round(6).tolist()
    [[0.0, 0.0, 1.0]]
    """
    return core().warp_sample(name, u, float(param), packed=packed)


def warp_pdf(name: str, points, param: float = 0.0) -> np.ndarray:
    """Density of :func:`warp_sample`'s output at ``points``.

    Parameters
    ----------
    name : str
        As for :func:`warp_sample`.
    points : ndarray
        (n, 3) C-contiguous float64 directions (density per solid angle) or (n, 2) disk
        points (per area).
    param : float, optional
        As for :func:`warp_sample`.

    Returns
    -------
    ndarray, shape (n,)

    Examples
    --------
    >>> import numpy as np
    >>> round(float(warp_pdf("uniform_sphere", np.array([[0.0, 0.0, 1.0]]))[0]) * 4 * np.pi, 12)
    1.0
    """
    return core().warp_pdf(name, points, float(param))


def bsdf_sample(material: str, wo, u, albedo, param: float, *, width: int = 1, **coating) -> dict:
    """``rt::bsdf_sample`` of a material for each row of ``u``, as the integrator calls it.

    Parameters
    ----------
    material : str
        ``lambertian``, ``metal`` (``param``: fuzz), ``rough_conductor`` and
        ``rough_conductor_beckmann`` (alpha), ``dielectric`` and ``dielectric_schlick``
        (index of refraction), ``plastic``, ``rough_plastic`` and ``rough_plastic_beckmann``
        (alpha).
    wo : ndarray, shape (3,)
        The unit outgoing direction in the local shading frame (+z the normal).
    u : ndarray, shape (n, 3)
        C-contiguous float64 uniform numbers.
    albedo : ndarray, shape (3,)
        The albedo (a plastic's diffuse reflectance).
    param : float
        The material's parameter (above).
    width : int, optional
        1: the scalar routine, one row at a time. 4 or 8 (``LANE_WIDTHS``), for
        ``rough_conductor`` only: the wavefront integrator's plain-GGX sampler on packs of
        that many rows, which must give width 1's valid samples bit for bit (only the valid
        rows' ``wi``, ``weight`` and ``pdf`` are filled).
    **coating
        A plastic's ``eta`` (int_ior / ext_ior), ``specular`` ((3,) specular reflectance)
        and ``nonlinear``: Mitsuba's defaults where not given.

    Returns
    -------
    dict
        ``wi`` (n, 3), ``weight`` (n, 3) = f cos / pdf, ``pdf`` (n,), ``eta`` (n,),
        ``delta`` (n,), ``valid`` (n,).

    Examples
    --------
    >>> import numpy as np
    >>> s = bsdf_sample("lambertian", np.array([0.0, 0, 1]), np.full((1, 3), 0.5), np.full(3, 0.5), 0.0)
    >>> s["weight"].round(6).tolist(), int(s["valid"][0])
    ([[0.5, 0.5, 0.5]], 1)
    """
    return core().bsdf_sample(material, wo, u, albedo, float(param), width=int(width), **coating)


def bsdf_eval_pdf(material: str, wo, wi, albedo, param: float, **coating) -> dict:
    """``rt::bsdf_eval`` and ``rt::bsdf_pdf`` of a material for each row of ``wi``.

    Parameters as for :func:`bsdf_sample`, with ``wi`` (n, 3) incident directions in
    place of the uniforms.

    Returns
    -------
    dict
        ``value`` (n, 3), f cos, and ``pdf`` (n,).

    Examples
    --------
    >>> import numpy as np
    >>> e = bsdf_eval_pdf("lambertian", np.array([0.0, 0, 1]), np.array([[0.0, 0, 1]]), np.full(3, 0.5), 0.0)
    >>> round(float(e["pdf"][0]) * np.pi, 12)
    1.0
    """
    return core().bsdf_eval_pdf(material, wo, wi, albedo, float(param), **coating)


def rough_plastic_table(distribution: str, alpha: float, eta: float) -> dict:
    """The rough plastic coating's tables, as a scene's ``RoughPlastic`` computes them.

    Parameters
    ----------
    distribution : str
        ``ggx`` or ``beckmann``.
    alpha : float
        Roughness.
    eta : float
        ``int_ior / ext_ior``.

    Returns
    -------
    dict
        ``transmittance`` (64,) at the cosines ``max(1e-6, k / 63)`` and
        ``internal_reflectance``.

    Examples
    --------
    >>> rough_plastic_table("ggx", 0.1, 1.5)["transmittance"].shape
    (64,)
    """
    return core().rough_plastic_table(distribution, float(alpha), float(eta))
