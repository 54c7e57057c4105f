"""Materials of the scene model.

Every material validates its parameters on construction and is immutable. The
conventions follow Mitsuba 3 (see ``shared/DESIGN.md`` section 3): surfaces are
one-sided unless ``two_sided=True``; emission is one-sided (front face only).
"""
from __future__ import annotations

from dataclasses import dataclass

from ._validate import colour, finite_scalar

__all__ = ["Material", "Lambertian", "Metal", "Dielectric", "RoughConductor", "DiffuseLight"]


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
    albedo : float or (3,) array_like
        Reflectance per RGB channel, each in [0, 1].
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
        object.__setattr__(self, "albedo", colour("Lambertian.albedo", self.albedo, upper=1.0))
        object.__setattr__(self, "two_sided", bool(self.two_sided))


@dataclass(frozen=True)
class Metal(Material):
    """Mirror reflector with optional fuzz (the book's metal).

    ``fuzz=0`` is an ideal mirror, Mitsuba ``conductor`` with ``material='none'``
    and ``specular_reflectance=albedo``. ``fuzz > 0`` perturbs the mirror direction by
    a point in a ball of radius ``fuzz``; it has no Mitsuba equivalent (translation to
    Mitsuba refuses it; use :class:`RoughConductor`).

    Examples
    --------
    >>> Metal((0.8, 0.85, 0.88)).fuzz
    0.0
    """

    albedo: tuple
    fuzz: float = 0.0
    two_sided: bool = False
    is_specular = True

    def __post_init__(self):
        object.__setattr__(self, "albedo", colour("Metal.albedo", self.albedo, upper=1.0))
        object.__setattr__(self, "fuzz", finite_scalar("Metal.fuzz", self.fuzz, lo=0.0, hi=1.0))
        object.__setattr__(self, "two_sided", bool(self.two_sided))


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
class RoughConductor(Material):
    """GGX microfacet conductor with Fresnel 1, scaled by ``albedo``.

    Mitsuba ``roughconductor`` with ``distribution='ggx'``, ``material='none'``,
    ``specular_reflectance=albedo`` and the same ``alpha`` (roughness = alpha, not
    alpha squared).

    Examples
    --------
    >>> RoughConductor((0.9, 0.9, 0.9), alpha=0.1).alpha
    0.1
    """

    albedo: tuple
    alpha: float
    two_sided: bool = False

    def __post_init__(self):
        object.__setattr__(self, "albedo", colour("RoughConductor.albedo", self.albedo, upper=1.0))
        object.__setattr__(self, "alpha", finite_scalar("RoughConductor.alpha", self.alpha, lo=1e-4, hi=4.0))
        object.__setattr__(self, "two_sided", bool(self.two_sided))


@dataclass(frozen=True)
class DiffuseLight(Material):
    """Area emitter of constant radiance on the front face; Mitsuba ``area``.

    Parameters
    ----------
    radiance : float or (3,) array_like
        Emitted radiance per channel, finite and >= 0.
    albedo : float or (3,) array_like, optional, keyword-only
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
            object.__setattr__(self, "albedo", colour("DiffuseLight.albedo", self.albedo, upper=1.0))

    @property
    def emits(self) -> bool:
        return max(self.radiance) > 0.0
