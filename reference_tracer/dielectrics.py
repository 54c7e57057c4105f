"""Dielectrics: glass that reflects and refracts, smooth (:class:`Dielectric`), a thin pane
(:class:`ThinDielectric`) or rough (:class:`RoughDielectric`, a microfacet interface), as Mitsuba's
``dielectric``, ``thindielectric`` and ``roughdielectric``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .materials import Material, check_alpha, check_distribution
from .validation import finite_scalar

__all__ = ["Dielectric", "ThinDielectric", "RoughDielectric"]


@dataclass(frozen=True)
class Dielectric(Material):
    """Smooth glass with exact unpolarised Fresnel; Mitsuba ``dielectric``.

    The outside medium has index 1.0 (``ext_ior=1.0``). Reflection is chosen with
    probability F; transmitted radiance is scaled by ``1/eta^2`` as in Mitsuba.

    Parameters
    ----------
    ior : float
        Index of refraction inside, > 0.
    fresnel : {'exact', 'schlick'}, keyword-only
        ``'exact'`` (default): the unpolarised Fresnel equations, as Mitsuba.
        ``'schlick'``: the book's approximation ``R0 + (1 - R0)(1 - cos)^5``, kept to
        measure its bias (the regression gate must catch it); it has no Mitsuba
        equivalent, so translation to Mitsuba refuses it.

    Examples
    --------
    >>> Dielectric(1.5).ior
    1.5
    """

    ior: float
    fresnel: str = "exact"
    is_specular = True

    def __post_init__(self):
        ior = finite_scalar("Dielectric.ior", self.ior, lo=1e-3)
        object.__setattr__(self, "ior", ior)
        if self.fresnel not in ("exact", "schlick"):
            raise ValueError(f"Dielectric.fresnel must be 'exact' or 'schlick', got {self.fresnel!r}")


@dataclass(frozen=True)
class ThinDielectric(Material):
    """A thin pane of glass: Mitsuba ``thindielectric``.

    Light that enters the pane leaves it where it entered, undeflected: both faces are
    one sheet. The pane reflects ``R' = 2R / (1 + R)`` (``R`` the exact Fresnel
    reflectance of one face at relative index ``ior``: all internal round trips summed)
    and transmits the rest straight through; both lobes are Dirac and both sides behave
    alike (no ``two_sided`` option: it always is).

    Parameters
    ----------
    ior : float
        Index of the pane relative to the medium around it (Mitsuba's ``int_ior /
        ext_ior``), > 0.

    Examples
    --------
    >>> ThinDielectric(1.5).ior
    1.5
    """

    ior: float
    is_specular = True

    def __post_init__(self):
        object.__setattr__(self, "ior", finite_scalar("ThinDielectric.ior", self.ior, lo=1e-3))


@dataclass(frozen=True)
class RoughDielectric(Material):
    """Rough glass, a microfacet interface (Walter et al. 2007): Mitsuba ``roughdielectric``.

    Reflects and refracts through microfacets of an isotropic ``distribution`` of roughness
    ``alpha`` (Mitsuba's alpha: roughness = alpha, not alpha squared), each microfacet
    choosing reflection with its own exact Fresnel reflectance. Both lobes have a density,
    so lights are sampled at the surface, on both sides of it. As :class:`Dielectric`, the
    outside has index 1 and transmitted radiance is scaled by ``1/eta^2``; the surface is
    glass from both sides (no ``two_sided`` option: inside and outside differ).

    Parameters
    ----------
    ior : float
        Index inside relative to outside (Mitsuba's ``int_ior / ext_ior``), > 0 and not 1
        (Mitsuba refuses equal indices: no interface).
    alpha : float
        Roughness, in [1e-4, 4] (Mitsuba's default 0.1).
    distribution : {'beckmann', 'ggx'}, keyword-only
        The microfacet distribution (default ``'beckmann'``, as Mitsuba's).

    Examples
    --------
    >>> RoughDielectric(1.5, 0.1).distribution
    'beckmann'
    >>> RoughDielectric(1.33, 0.3, distribution="ggx").alpha
    0.3
    >>> RoughDielectric(1.5, -0.1)
    Traceback (most recent call last):
    ...
    ValueError: RoughDielectric.alpha must be >= 0.0001, got -0.1
    """

    ior: float
    alpha: float
    distribution: str = field(default="beckmann", kw_only=True)

    def __post_init__(self):
        ior = finite_scalar("RoughDielectric.ior", self.ior, lo=1e-3)
        # Mitsuba compares its single-precision indices.
        if np.float32(ior) == np.float32(1.0):
            raise ValueError(f"RoughDielectric.ior must differ from 1, got {ior}: a relative index of 1 has no "
                             "interface (Mitsuba's roughdielectric refuses int_ior == ext_ior too)")
        object.__setattr__(self, "ior", ior)
        object.__setattr__(self, "alpha", check_alpha("RoughDielectric", self.alpha))
        check_distribution("RoughDielectric", self.distribution)
