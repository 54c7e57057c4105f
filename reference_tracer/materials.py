"""Materials of the scene model: the base class, the diffuse reflector, the area emitter, and the
checks the rough materials share.

Every material validates its parameters on construction and is immutable. The
conventions follow Mitsuba 3: surfaces are one-sided unless ``two_sided=True``;
emission is one-sided (front face only). The other materials, subclasses of
:class:`Material`, have a module a family: the conductors (:mod:`reference_tracer.conductors`),
the dielectrics (:mod:`reference_tracer.dielectrics`), the plastics
(:mod:`reference_tracer.plastics`) and the opacity mask (:mod:`reference_tracer.mask`);
:mod:`reference_tracer.material_textures` says which textures a material looks up.
"""
from __future__ import annotations

from dataclasses import dataclass

from .textures import check_reflectance
from .validation import colour, finite_scalar

__all__ = ["Material", "Lambertian", "DiffuseLight", "DISTRIBUTIONS", "check_alpha", "check_distribution"]

#: microfacet distributions of :class:`RoughConductor`, :class:`RoughPlastic` and :class:`RoughDielectric`,
#: in the core's order.
DISTRIBUTIONS = ("ggx", "beckmann")


def check_alpha(owner: str, alpha) -> float:
    """``alpha``, the roughness of ``owner``'s microfacets, as a float in [1e-4, 4].

    Mitsuba's alpha (roughness = alpha, not alpha squared), isotropic; the range every rough
    material takes (:class:`~reference_tracer.RoughConductor`,
    :class:`~reference_tracer.RoughDielectric`, :class:`~reference_tracer.RoughPlastic`).

    Examples
    --------
    >>> check_alpha("RoughConductor", 0.1)
    0.1
    """
    return finite_scalar(f"{owner}.alpha", alpha, lo=1e-4, hi=4.0)


def check_distribution(owner: str, distribution) -> None:
    """Refuse a microfacet ``distribution`` of ``owner`` that is not one of :data:`DISTRIBUTIONS`.

    Examples
    --------
    >>> check_distribution("RoughPlastic", "phong")
    Traceback (most recent call last):
    ...
    ValueError: RoughPlastic.distribution must be one of ('ggx', 'beckmann'), got 'phong'
    """
    if distribution not in DISTRIBUTIONS:
        raise ValueError(f"{owner}.distribution must be one of {DISTRIBUTIONS}, got {distribution!r}")


class Material:
    """Base class of all materials (not instantiated directly)."""

    #: True for materials whose scattering is a Dirac delta (mirror, glass, fuzzy metal).
    is_specular: bool = False

    @property
    def emits(self) -> bool:
        return False


@dataclass(frozen=True)
class Lambertian(Material):
    """Ideal diffuse reflector, ``albedo / pi``; Mitsuba ``diffuse``.

    Parameters
    ----------
    albedo : float, (3,) array_like or Texture
        Reflectance per RGB channel, each in [0, 1], or a texture of it
        (:class:`reference_tracer.Checkerboard`, :class:`reference_tracer.Bitmap`: Mitsuba's
        ``reflectance`` given a texture).
    two_sided : bool, keyword-only
        Reflect on both sides (Mitsuba ``twosided``). One-sided surfaces are black
        seen from the back, as in Mitsuba.

    Examples
    --------
    >>> Lambertian((0.73, 0.73, 0.73)).albedo
    (0.73, 0.73, 0.73)
    """

    albedo: tuple
    two_sided: bool = False

    def __post_init__(self):
        object.__setattr__(self, "albedo", check_reflectance("Lambertian.albedo", self.albedo))
        object.__setattr__(self, "two_sided", bool(self.two_sided))


@dataclass(frozen=True)
class DiffuseLight(Material):
    """Area emitter of constant radiance on the front face; Mitsuba ``area``.

    Parameters
    ----------
    radiance : float or (3,) array_like
        Emitted radiance per channel, finite and >= 0.
    albedo : float, (3,) array_like or Texture, optional, keyword-only
        If given, the surface also reflects as a one-sided Lambertian of this albedo
        (Mitsuba: the shape carries both a ``diffuse`` BSDF and an ``area`` emitter).

    Examples
    --------
    >>> DiffuseLight(15).radiance
    (15.0, 15.0, 15.0)
    """

    radiance: tuple
    albedo: tuple | None = None

    def __post_init__(self):
        object.__setattr__(self, "radiance", colour("DiffuseLight.radiance", self.radiance, upper=None))
        if self.albedo is not None:
            object.__setattr__(self, "albedo", check_reflectance("DiffuseLight.albedo", self.albedo))

    @property
    def emits(self) -> bool:
        return max(self.radiance) > 0.0
