"""Plastics: a diffuse base under a dielectric coating, smooth (:class:`Plastic`, Mitsuba's
``plastic``) or rough (:class:`RoughPlastic`, ``roughplastic``), and :class:`Coated`, the fields and
checks the two share.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .materials import Material, check_alpha, check_distribution
from .textures import check_reflectance
from .validation import colour, finite_scalar, flag

__all__ = ["Coated", "Plastic", "RoughPlastic", "PLASTIC_INT_IOR", "PLASTIC_EXT_IOR"]

#: Mitsuba's default plastic coating: polypropylene (``int_ior``) in air (``ext_ior``).
PLASTIC_INT_IOR, PLASTIC_EXT_IOR = 1.49, 1.000277


def _fresnel_diffuse_reflectance(eta: float) -> float:
    """Mitsuba's fit of the hemispherical mean of the Fresnel reflectance at relative index ``eta``."""
    if eta < 1.0:
        return -1.4399 * eta * eta + 0.7099 * eta + 0.6681 + 0.0636 / eta
    x = 1.0 / eta
    return 0.919317 + x * (-3.4793 + x * (6.75335 + x * (-7.80989 + x * (4.98554 - 1.36881 * x))))


@dataclass(frozen=True)
class Coated(Material):
    """A diffuse base under a dielectric coating: the fields plastic and rough plastic share,
    validated and normalised (the parameters: :class:`Plastic`)."""

    diffuse_reflectance: tuple
    specular_reflectance: tuple = field(default=1.0, kw_only=True)
    int_ior: float = field(default=PLASTIC_INT_IOR, kw_only=True)
    ext_ior: float = field(default=PLASTIC_EXT_IOR, kw_only=True)
    nonlinear: bool = field(default=False, kw_only=True)
    two_sided: bool = field(default=False, kw_only=True)

    def __post_init__(self):
        owner, set_ = type(self).__name__, object.__setattr__
        set_(self, "diffuse_reflectance", check_reflectance(f"{owner}.diffuse_reflectance", self.diffuse_reflectance))
        set_(self, "specular_reflectance", colour(f"{owner}.specular_reflectance", self.specular_reflectance,
                                                  upper=1.0))
        set_(self, "int_ior", finite_scalar(f"{owner}.int_ior", self.int_ior, lo=0.0, lo_open=True))
        set_(self, "ext_ior", finite_scalar(f"{owner}.ext_ior", self.ext_ior, lo=0.0, lo_open=True))
        set_(self, "nonlinear", flag(f"{owner}.nonlinear", self.nonlinear))
        set_(self, "two_sided", flag(f"{owner}.two_sided", self.two_sided))

    @property
    def relative_ior(self) -> float:
        """``int_ior / ext_ior``: all of the coating that the BSDF depends on."""
        return self.int_ior / self.ext_ior


@dataclass(frozen=True)
class Plastic(Coated):
    """A diffuse base under a smooth dielectric coating: Mitsuba ``plastic``.

    The coating reflects specularly, a Dirac lobe of weight ``F(cos) specular_reflectance``
    (exact unpolarised Fresnel of the relative index ``int_ior / ext_ior``); the light it
    transmits scatters off the base of reflectance ``diffuse_reflectance``, and from the
    coating's inside, before leaving as a diffuse lobe. One-sided unless ``two_sided``.

    Parameters
    ----------
    diffuse_reflectance : float, (3,) array_like or Texture
        The base's reflectance per RGB channel, in [0, 1] (Mitsuba's default 0.5), or a
        texture of it; the lobe choice then takes the texture's mean (Mitsuba's
        ``Texture::mean``), as Mitsuba's does.
    specular_reflectance : float or (3,) array_like, keyword-only
        Scale of the specular lobe, in [0, 1] (default 1).
    int_ior, ext_ior : float, keyword-only
        Indices of refraction inside the coating and outside, > 0 (defaults: Mitsuba's
        polypropylene 1.49 and air 1.000277). Only their ratio matters. Beyond about 3.7
        Mitsuba's fit of the coating's internal reflectance exceeds 1 and is refused.
    nonlinear : bool, keyword-only
        Mitsuba's ``nonlinear``: the base's light divided by ``1 - rho Fi`` (the exact sum of
        its internal scattering, which darkens and saturates colours) instead of ``1 - Fi``
        (default False, which keeps the colour of ``diffuse_reflectance``).
    two_sided : bool, keyword-only
        Reflect on both sides (Mitsuba ``twosided``); black from the back otherwise.

    Notes
    -----
    Used with the ``light`` strategy, which takes only the direct light that light sampling
    finds at the first vertex that is not a mirror or glass, a smooth plastic shows its
    diffuse lobe alone: no light sample can meet the specular one. The other strategies
    sample the specular lobe with the material's own probability.

    Examples
    --------
    >>> Plastic((0.1, 0.3, 0.7)).int_ior
    1.49
    >>> round(Plastic(0.5, int_ior=1.5, ext_ior=1.0).relative_ior, 3)
    1.5
    """

    def __post_init__(self):
        super().__post_init__()
        if _fresnel_diffuse_reflectance(self.ext_ior / self.int_ior) >= 1.0:
            raise ValueError(f"Plastic: int_ior / ext_ior = {self.relative_ior:.4g} is beyond Mitsuba's fit of the "
                             "coating's internal reflectance (it reaches 1 near 3.7: the diffuse lobe would be "
                             "negative or infinite)")


@dataclass(frozen=True)
class RoughPlastic(Coated):
    """A diffuse base under a rough dielectric coating: Mitsuba ``roughplastic``.

    As :class:`Plastic` with a microfacet coating: a glossy lobe (``distribution``
    ``'beckmann'``, Mitsuba's default, or ``'ggx'``, isotropic ``alpha`` as Mitsuba's), and a
    diffuse lobe scaled by the coating's transmittance on the way in and out (Mitsuba's
    table of it, and the coating's internal reflectance, computed once per coating when
    the scene is compiled).

    Parameters
    ----------
    diffuse_reflectance : float, (3,) array_like or Texture
        The base's reflectance per RGB channel, in [0, 1] (Mitsuba's default 0.5), or a
        texture of it (as :class:`Plastic`'s).
    alpha : float, keyword-only
        Roughness, in [1e-4, 4] (Mitsuba's default 0.1; roughness = alpha, not alpha squared).
    distribution : {'beckmann', 'ggx'}, keyword-only
        The microfacet distribution (default ``'beckmann'``, as Mitsuba's).
    specular_reflectance, int_ior, ext_ior, nonlinear, two_sided : keyword-only
        As :class:`Plastic`; ``int_ior`` and ``ext_ior`` must differ (as Mitsuba requires).

    Examples
    --------
    >>> RoughPlastic((0.1, 0.3, 0.7), alpha=0.2).distribution
    'beckmann'
    >>> RoughPlastic(0.5, int_ior=1.5, ext_ior=1.5)
    Traceback (most recent call last):
    ...
    ValueError: RoughPlastic: int_ior and ext_ior must differ (got 1.5 for both): a coating of relative index 1 has no rough interface (Mitsuba's roughplastic refuses it too)
    """

    alpha: float = field(default=0.1, kw_only=True)
    distribution: str = field(default="beckmann", kw_only=True)

    def __post_init__(self):
        object.__setattr__(self, "alpha", check_alpha("RoughPlastic", self.alpha))
        check_distribution("RoughPlastic", self.distribution)
        super().__post_init__()
        # Mitsuba compares its single-precision values.
        if np.float32(self.int_ior) == np.float32(self.ext_ior):
            raise ValueError(f"RoughPlastic: int_ior and ext_ior must differ (got {self.int_ior} for both): a "
                             "coating of relative index 1 has no rough interface (Mitsuba's roughplastic refuses "
                             "it too)")
