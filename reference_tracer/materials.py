"""Materials of the scene model.

Every material validates its parameters on construction and is immutable. The
conventions follow Mitsuba 3: surfaces are one-sided unless ``two_sided=True``;
emission is one-sided (front face only). Conductors reflect with Fresnel 1 unless given
a complex index of refraction (``eta``, ``k``) or one of Mitsuba's named materials
(:mod:`reference_tracer.conductors`). Plastics are a diffuse base under a smooth
(:class:`Plastic`) or rough (:class:`RoughPlastic`) dielectric coating.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .validation import colour, finite_scalar
from .conductors import conductor_ior
from .textures import MeshAttribute, Texture, check_reflectance


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

__all__ = ["Material", "Lambertian", "Metal", "Dielectric", "ThinDielectric", "RoughDielectric", "RoughConductor",
           "Plastic", "RoughPlastic", "DiffuseLight", "Mask", "DISTRIBUTIONS", "PLASTIC_INT_IOR", "PLASTIC_EXT_IOR",
           "reflectance_of", "textures_of"]

#: microfacet distributions of :class:`RoughConductor`, :class:`RoughPlastic` and :class:`RoughDielectric`,
#: in the core's order.
DISTRIBUTIONS = ("ggx", "beckmann")

#: Mitsuba's default plastic coating: polypropylene (``int_ior``) in air (``ext_ior``).
PLASTIC_INT_IOR, PLASTIC_EXT_IOR = 1.49, 1.000277


def _flag(name: str, value) -> bool:
    """``value`` as a bool: True, False (or 1, 0); anything else (a string, None) is refused."""
    if isinstance(value, (bool, np.bool_)) or (isinstance(value, (int, np.integer)) and value in (0, 1)):
        return bool(value)
    raise ValueError(f"{name} must be True or False, got {value!r}")


def _fresnel_diffuse_reflectance(eta: float) -> float:
    """Mitsuba's fit of the hemispherical mean of the Fresnel reflectance at relative index ``eta``."""
    if eta < 1.0:
        return -1.4399 * eta * eta + 0.7099 * eta + 0.6681 + 0.0636 / eta
    x = 1.0 / eta
    return 0.919317 + x * (-3.4793 + x * (6.75335 + x * (-7.80989 + x * (4.98554 - 1.36881 * x))))


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
class Metal(Material):
    """Mirror reflector with optional fuzz (the book's metal).

    ``fuzz=0`` is an ideal mirror, Mitsuba ``conductor`` with ``specular_reflectance=albedo``:
    Fresnel 1 (``material='none'``) by default, or the Fresnel reflectance of a complex
    index ``eta + i k`` (RGB; ``k`` defaults to 1) or of one of Mitsuba's named materials
    (``material="Au"``). ``albedo`` may be a texture (Mitsuba's ``specular_reflectance``
    given one). ``fuzz > 0`` perturbs the mirror direction by a point in a ball of
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
        object.__setattr__(self, "albedo", check_reflectance("Metal.albedo", self.albedo))
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
        object.__setattr__(self, "alpha", finite_scalar("RoughDielectric.alpha", self.alpha, lo=1e-4, hi=4.0))
        if self.distribution not in DISTRIBUTIONS:
            raise ValueError(f"RoughDielectric.distribution must be one of {DISTRIBUTIONS}, "
                             f"got {self.distribution!r}")


@dataclass(frozen=True)
class RoughConductor(Material):
    """Microfacet conductor, scaled by ``albedo``: Mitsuba ``roughconductor``.

    The same ``alpha`` as Mitsuba's (roughness = alpha, not alpha squared), isotropic;
    ``distribution`` ``'ggx'`` (the default here) or ``'beckmann'`` (Mitsuba's default);
    Fresnel 1 (``material='none'``) unless given a complex index ``eta + i k`` (RGB; ``k``
    defaults to 1) or one of Mitsuba's named materials (``material="Cu"``); albedo is
    Mitsuba's ``specular_reflectance`` (an RGB value or a texture).

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
        object.__setattr__(self, "albedo", check_reflectance("RoughConductor.albedo", self.albedo))
        object.__setattr__(self, "alpha", finite_scalar("RoughConductor.alpha", self.alpha, lo=1e-4, hi=4.0))
        object.__setattr__(self, "two_sided", bool(self.two_sided))
        if self.distribution not in DISTRIBUTIONS:
            raise ValueError(f"RoughConductor.distribution must be one of {DISTRIBUTIONS}, got {self.distribution!r}")
        eta, k = _complex_ior("RoughConductor", self.eta, self.k, self.material)
        object.__setattr__(self, "eta", eta)
        object.__setattr__(self, "k", k)


@dataclass(frozen=True)
class _Coated(Material):
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
        set_(self, "nonlinear", _flag(f"{owner}.nonlinear", self.nonlinear))
        set_(self, "two_sided", _flag(f"{owner}.two_sided", self.two_sided))

    @property
    def relative_ior(self) -> float:
        """``int_ior / ext_ior``: all of the coating that the BSDF depends on."""
        return self.int_ior / self.ext_ior


@dataclass(frozen=True)
class Plastic(_Coated):
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
class RoughPlastic(_Coated):
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
        object.__setattr__(self, "alpha", finite_scalar("RoughPlastic.alpha", self.alpha, lo=1e-4, hi=4.0))
        if self.distribution not in DISTRIBUTIONS:
            raise ValueError(f"RoughPlastic.distribution must be one of {DISTRIBUTIONS}, got {self.distribution!r}")
        super().__post_init__()
        # Mitsuba compares its single-precision values.
        if np.float32(self.int_ior) == np.float32(self.ext_ior):
            raise ValueError(f"RoughPlastic: int_ior and ext_ior must differ (got {self.int_ior} for both): a "
                             "coating of relative index 1 has no rough interface (Mitsuba's roughplastic refuses "
                             "it too)")


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


@dataclass(frozen=True)
class Mask(Material):
    """Mitsuba's ``mask``: ``material`` where the surface is opaque, nothing where it is not.

    At a hit the surface is present with probability ``opacity`` (alpha): there it
    scatters as ``material`` (its BSDF times alpha; a sample of it has its own weight and
    its density times alpha), and with probability ``1 - alpha`` the ray goes straight on
    (Mitsuba's null lobe: a Dirac lobe of weight 1). The null lobe passes from both sides,
    also where ``material`` is one-sided (black from the back). As in Mitsuba's ``path``
    integrator, a pass through the mask is a vertex of the path (``max_depth`` counts it),
    an emitter met right after it is not MIS-weighted, and shadow rays treat the surface as
    opaque.

    Parameters
    ----------
    material : Material
        The nested material: any but a :class:`DiffuseLight` (a mask around an emitter is
        not supported) or another :class:`Mask`.
    opacity : float or Texture
        alpha, a constant in [0, 1] (Mitsuba's default 0.5), or a texture
        (:class:`~reference_tracer.Checkerboard`, :class:`~reference_tracer.Bitmap`) read as
        Mitsuba's ``eval_1`` reads it (:meth:`~reference_tracer.Texture.eval_1`: a colour
        bitmap's luminance, a checkerboard's colour means with its cells swapped) at the
        hit's texture coordinates.
    clip : bool, keyword-only
        False (default): an opacity outside [0, 1] (a constant, or a texture's values) is
        refused. True: it is clipped to [0, 1] as Mitsuba's ``eval_opacity`` does (a
        constant here, a texture after each lookup): what the Mitsuba importer passes. NaN
        is refused either way.

    Raises
    ------
    ValueError
        ``material`` not a material, an emitter or a mask; ``opacity`` not a number or a
        texture, NaN or infinite, or outside [0, 1] without ``clip``.

    Examples
    --------
    >>> m = Mask(Lambertian(0.5), 0.25)
    >>> m.opacity, m.material.albedo
    (0.25, (0.5, 0.5, 0.5))
    >>> Mask(Lambertian(0.5), 1.5, clip=True).opacity
    1.0
    >>> Mask(Lambertian(0.5), 1.5)
    Traceback (most recent call last):
    ...
    ValueError: Mask.opacity must lie in [0, 1], got 1.5 (clip=True clips it, as Mitsuba does)
    """

    material: Material
    opacity: object = 0.5
    clip: bool = field(default=False, kw_only=True)

    def __post_init__(self):
        set_ = object.__setattr__
        if not isinstance(self.material, Material):
            raise ValueError(f"Mask.material must be a material, got {self.material!r}")
        if isinstance(self.material, DiffuseLight):
            raise ValueError("Mask around a DiffuseLight: a mask around an emitter is not supported")
        if isinstance(self.material, Mask):
            raise ValueError("Mask around a Mask: nest one mask only (its opacity the product of both, for "
                             "constants)")
        set_(self, "clip", _flag("Mask.clip", self.clip))
        if isinstance(self.opacity, MeshAttribute):
            return  # its values are its mesh's, clipped at each hit as Mitsuba's eval_opacity clips them
        if isinstance(self.opacity, Texture):
            lo, hi = self.opacity.scalar().value_range()
            if not (np.isfinite(lo) and np.isfinite(hi)):
                raise ValueError(f"Mask.opacity: a {type(self.opacity).__name__} texture with values that are not "
                                 "finite")
            if not self.clip and not (lo >= 0.0 and hi <= 1.0):
                raise ValueError(f"Mask.opacity: a {type(self.opacity).__name__} texture with values in "
                                 f"[{lo:.6g}, {hi:.6g}]; an opacity must lie in [0, 1] (clip=True clips it, as "
                                 "Mitsuba does)")
            return
        if isinstance(self.opacity, (bool, np.bool_)) or not isinstance(self.opacity, (int, float, np.integer,
                                                                                         np.floating)):
            raise ValueError(f"Mask.opacity must be a number in [0, 1] or a texture, got {self.opacity!r}")
        a = float(self.opacity)
        if not np.isfinite(a):
            raise ValueError(f"Mask.opacity must be finite, got {a}")
        if not self.clip and not 0.0 <= a <= 1.0:
            raise ValueError(f"Mask.opacity must lie in [0, 1], got {a} (clip=True clips it, as Mitsuba does)")
        set_(self, "opacity", min(1.0, max(0.0, a)))

    @property
    def is_specular(self) -> bool:
        return self.material.is_specular


def textures_of(material: Material) -> list:
    """The textures ``material`` looks up at a hit: its reflectance's, a mask's opacity's.

    Examples
    --------
    >>> from reference_tracer.textures import Checkerboard
    >>> len(textures_of(Mask(Lambertian(Checkerboard()), Checkerboard())))
    2
    """
    out = [t for t in (reflectance_of(material),) if isinstance(t, Texture)]
    if isinstance(material, Mask) and isinstance(material.opacity, Texture):
        out.append(material.opacity)
    return out


def reflectance_of(material: Material):
    """The reflectance of ``material`` that a texture may give: a plastic's
    ``diffuse_reflectance``, else its ``albedo`` (a Lambertian's, a conductor's
    ``specular_reflectance``, a reflecting light's); None for a material without one.

    Returns
    -------
    tuple, Texture or None
        An RGB triple, a :class:`~reference_tracer.Texture`, or None (a dielectric, a light
        that reflects nothing).

    Examples
    --------
    >>> reflectance_of(Plastic(0.3)), reflectance_of(Dielectric(1.5))
    ((0.3, 0.3, 0.3), None)
    """
    if isinstance(material, Mask):
        return reflectance_of(material.material)
    if isinstance(material, _Coated):
        return material.diffuse_reflectance
    return getattr(material, "albedo", None)
