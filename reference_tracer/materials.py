"""Materials of the scene model.

Every material validates its parameters on construction and is immutable. The
conventions follow Mitsuba 3: surfaces are one-sided unless ``two_sided=True``;
emission is one-sided (front face only). Conductors reflect with Fresnel 1 unless given
a complex index of refraction (``eta``, ``k``) or one of Mitsuba's named materials
(:mod:`reference_tracer.conductors`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

from ._validate import colour, finite_scalar
from .conductors import conductor_ior


def _complex_ior(owner: str, eta, k, material):
    """``(eta, k)`` RGB triples, or ``(None, None)`` for Fresnel 1, from the conductor options.

    As Mitsuba: ``material`` names a preset ("none": Fresnel 1); ``eta`` (with ``k``, which
    defaults to 1) gives the index directly; both at once is an error.
    """
    if material is not None and (eta is not None or k is not None):
        raise ValueError(f"{owner}: give material or eta and k, not both (got material={material!r})")
    if material is not None:
        if not isinstance(material, str):
            raise ValueError(f"{owner}.material must be a name, got {material!r}")
        if material == "none":
            return None, None
        return conductor_ior(material)
    if eta is None:
        if k is not None:
            raise ValueError(f"{owner}: k needs eta (the real part of the index)")
        return None, None
    return (colour(f"{owner}.eta", eta, upper=None),
            colour(f"{owner}.k", 1.0 if k is None else k, upper=None))

__all__ = ["Material", "Lambertian", "Metal", "Dielectric", "RoughConductor", "DiffuseLight", "DISTRIBUTIONS"]

#: microfacet distributions of :class:`RoughConductor`, in the core's order.
DISTRIBUTIONS = ("ggx", "beckmann")


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

    ``fuzz=0`` is an ideal mirror, Mitsuba ``conductor`` with ``specular_reflectance=albedo``:
    Fresnel 1 (``material='none'``) by default, or the Fresnel reflectance of a complex
    index ``eta + i k`` (RGB; ``k`` defaults to 1) or of one of Mitsuba's named materials
    (``material="Au"``). ``fuzz > 0`` perturbs the mirror direction by a point in a ball of
    radius ``fuzz``; it has no Mitsuba equivalent (translation to Mitsuba refuses it; use
    :class:`RoughConductor`) and no Fresnel.

    Examples
    --------
    >>> Metal((0.8, 0.85, 0.88)).fuzz
    0.0
    >>> Metal(1.0, material="Au").eta[2] > 1.0
    True
    """

    albedo: tuple
    fuzz: float = 0.0
    two_sided: bool = False
    eta: tuple | None = field(default=None, kw_only=True)
    k: tuple | None = field(default=None, kw_only=True)
    material: str | None = field(default=None, kw_only=True)
    is_specular = True

    def __post_init__(self):
        object.__setattr__(self, "albedo", colour("Metal.albedo", self.albedo, upper=1.0))
        object.__setattr__(self, "fuzz", finite_scalar("Metal.fuzz", self.fuzz, lo=0.0, hi=1.0))
        object.__setattr__(self, "two_sided", bool(self.two_sided))
        eta, k = _complex_ior("Metal", self.eta, self.k, self.material)
        if eta is not None and self.fuzz > 0:
            raise ValueError("Metal: a fuzzy metal (fuzz > 0) has no Fresnel; give eta, k or material only with "
                             "fuzz=0 (or use RoughConductor)")
        object.__setattr__(self, "eta", eta)
        object.__setattr__(self, "k", k)


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
    """Microfacet conductor, scaled by ``albedo``: Mitsuba ``roughconductor``.

    The same ``alpha`` as Mitsuba's (roughness = alpha, not alpha squared), isotropic;
    ``distribution`` ``'ggx'`` (the default here) or ``'beckmann'`` (Mitsuba's default);
    Fresnel 1 (``material='none'``) unless given a complex index ``eta + i k`` (RGB; ``k``
    defaults to 1) or one of Mitsuba's named materials (``material="Cu"``); albedo is
    Mitsuba's ``specular_reflectance``.

    Examples
    --------
    >>> RoughConductor((0.9, 0.9, 0.9), alpha=0.1).alpha
    0.1
    >>> RoughConductor(1.0, alpha=0.2, distribution="beckmann", material="Cu").distribution
    'beckmann'
    """

    albedo: tuple
    alpha: float
    two_sided: bool = False
    distribution: str = field(default="ggx", kw_only=True)
    eta: tuple | None = field(default=None, kw_only=True)
    k: tuple | None = field(default=None, kw_only=True)
    material: str | None = field(default=None, kw_only=True)

    def __post_init__(self):
        object.__setattr__(self, "albedo", colour("RoughConductor.albedo", self.albedo, upper=1.0))
        object.__setattr__(self, "alpha", finite_scalar("RoughConductor.alpha", self.alpha, lo=1e-4, hi=4.0))
        object.__setattr__(self, "two_sided", bool(self.two_sided))
        if self.distribution not in DISTRIBUTIONS:
            raise ValueError(f"RoughConductor.distribution must be one of {DISTRIBUTIONS}, got {self.distribution!r}")
        eta, k = _complex_ior("RoughConductor", self.eta, self.k, self.material)
        object.__setattr__(self, "eta", eta)
        object.__setattr__(self, "k", k)


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
