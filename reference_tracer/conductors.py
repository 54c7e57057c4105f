"""Conductors: :class:`Metal` (a mirror, optionally fuzzy), :class:`RoughConductor` (microfacets) and
Mitsuba 3's named conductors as RGB complex indices of refraction ``eta + i k``.

Conductors reflect with Fresnel 1 unless given a complex index of refraction (``eta``,
``k``) or one of Mitsuba's named materials. Mitsuba's ``conductor`` and ``roughconductor``
take ``material="Au"`` (and the others below): spectral data (``data/ior/<name>.eta.spd``
and ``.k.spd``) that its RGB variants turn into RGB by integrating against the CIE 1931
curves, negative values clamped to 0. This table
holds the values Mitsuba 3.9.1 uses in ``scalar_rgb`` and ``llvm_ad_rgb`` (the same in
both), read from it with::

    mi.traverse(mi.load_dict({"type": "conductor", "material": name}))  # eta.value, k.value

for every ``*.eta.spd`` file it ships, rounded to 9 decimals. ``"none"`` is Fresnel 1
(eta 0, k 1): a perfect mirror, scaled by the albedo.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from .materials import Material, check_alpha, check_distribution
from .textures import check_reflectance
from .validation import colour, finite_scalar

__all__ = ["CONDUCTORS", "conductor_ior", "Metal", "RoughConductor"]

#: name -> ((eta R, G, B), (k R, G, B)), as Mitsuba 3.9.1's RGB variants use them.
CONDUCTORS = {
    'Ag': ((0.155276194, 0.116727956, 0.138387635), (4.828354359, 3.122222424, 2.146901131)),
    'Al': ((1.657500863, 0.880404711, 0.521244466), (9.22381115, 6.269502163, 4.837004185)),
    'AlAs': ((3.605295897, 3.232937813, 2.216318607), (0.000679437, 0.0, 0.007512709)),
    'AlAs_palik': ((3.605295897, 3.232937813, 2.216318607), (0.000679437, 0.0, 0.007512709)),
    'AlSb': ((0.0, 4.139374733, 4.669254303), (0.0, 0.094009079, 1.300570011)),
    'AlSb_palik': ((0.0, 4.139374733, 4.669254303), (0.0, 0.094009079, 1.300570011)),
    'Au': ((0.143035978, 0.375307083, 1.442045331), (3.982996941, 2.385556459, 1.603359222)),
    'Be': ((4.185012341, 3.185029268, 2.784061193), (3.835465908, 3.010122299, 2.868993998)),
    'Be_palik': ((4.185012341, 3.185029268, 2.784061193), (3.835465908, 3.010122299, 2.868993998)),
    'Cr': ((4.36966753, 2.916505337, 1.654904604), (5.206546783, 4.231306076, 3.754698753)),
    'CsI': ((2.144899607, 1.702318907, 1.662427187), (0.0, 0.0, 0.0)),
    'CsI_palik': ((2.144899607, 1.702318907, 1.662427187), (0.0, 0.0, 0.0)),
    'Cu': ((0.201005474, 0.923749506, 1.102215409), (3.913262129, 2.45304513, 2.142089844)),
    'Cu2O': ((3.551772594, 2.949869633, 2.751875401), (0.114207022, 0.19389686, 0.606133878)),
    'Cu2O_palik': ((3.551772594, 2.949869633, 2.751875401), (0.114207022, 0.19389686, 0.606133878)),
    'CuO': ((3.247540951, 2.447805166, 2.210219622), (0.521089554, 0.570030749, 0.722178936)),
    'CuO_palik': ((3.247540951, 2.447805166, 2.210219622), (0.521089554, 0.570030749, 0.722178936)),
    'Cu_palik': ((0.213228509, 0.919715405, 1.102410793), (3.921873331, 2.457331657, 2.136584044)),
    'Hg': ((2.398938656, 1.440027952, 0.909570396), (6.327587128, 4.371924877, 3.421763659)),
    'HgTe': ((4.77903986, 3.231196165, 2.659901142), (1.631612659, 1.580810428, 1.729287386)),
    'HgTe_palik': ((4.77903986, 3.231196165, 2.659901142), (1.631612659, 1.580810428, 1.729287386)),
    'Hg_palik': ((2.398938656, 1.440027952, 0.909570396), (6.327587128, 4.371924877, 3.421763659)),
    'Ir': ((3.086299896, 2.082190514, 1.617914557), (5.592153072, 4.067088127, 3.26731205)),
    'Ir_palik': ((3.086299896, 2.082190514, 1.617914557), (5.592153072, 4.067088127, 3.26731205)),
    'K': ((0.064043187, 0.046409767, 0.038184915), (2.104199648, 1.348940015, 0.913125873)),
    'K_palik': ((0.064043187, 0.046409767, 0.038184915), (2.104199648, 1.348940015, 0.913125873)),
    'Li': ((0.265790939, 0.195618317, 0.220948622), (3.540154934, 2.311123371, 1.668607235)),
    'Li_palik': ((0.265790939, 0.195618317, 0.220948622), (3.540154934, 2.311123371, 1.668607235)),
    'MgO': ((2.089583874, 1.650723457, 1.594879031), (0.0, 0.0, 0.0)),
    'MgO_palik': ((2.089583874, 1.650723457, 1.594879031), (0.0, 0.0, 0.0)),
    'Mo': ((4.48397398, 3.525130749, 2.776310444), (4.111437321, 3.420826912, 3.150607347)),
    'Mo_palik': ((4.48397398, 3.525130749, 2.776310444), (4.111437321, 3.420826912, 3.150607347)),
    'Na_palik': ((0.060269356, 0.056140948, 0.061988432), (3.179273367, 2.112490416, 1.579041123)),
    'Nb': ((3.420073986, 2.790093184, 2.395629406), (3.441394567, 2.73766613, 2.57974577)),
    'Nb_palik': ((3.420073986, 2.790093184, 2.395629406), (3.441394567, 2.73766613, 2.57974577)),
    'Ni_palik': ((2.367304564, 1.663373113, 1.46707809), (4.498811722, 3.050153017, 2.345439196)),
    'Rh': ((2.585793495, 1.860216379, 1.554263353), (6.782260418, 4.702987194, 3.976073027)),
    'Rh_palik': ((2.585793495, 1.860216379, 1.554263353), (6.782260418, 4.702987194, 3.976073027)),
    'Se': ((4.058311462, 2.842935085, 2.820853472), (0.75404954, 0.63844353, 0.521807551)),
    'Se-e': ((5.722848892, 4.165736198, 4.081338406), (0.871136308, 1.105157495, 1.565320253)),
    'Se-e_palik': ((5.722848892, 4.165736198, 4.081338406), (0.871136308, 1.105157495, 1.565320253)),
    'Se_palik': ((4.058311462, 2.842935085, 2.820853472), (0.75404954, 0.63844353, 0.521807551)),
    'SiC': ((3.172341585, 2.525971651, 2.479370594), (7.54e-07, 0.0, 1.0193e-05)),
    'SiC_palik': ((3.172341585, 2.525971651, 2.479370594), (7.54e-07, 0.0, 1.0193e-05)),
    'SnTe': ((4.524249554, 1.981644988, 1.281591296), (0.0, 0.0, 0.0)),
    'SnTe_palik': ((4.524249554, 1.981644988, 1.281591296), (0.0, 0.0, 0.0)),
    'Ta': ((2.062721014, 2.392938852, 2.627928734), (2.408359766, 1.74148643, 1.947027802)),
    'Ta_palik': ((2.062721014, 2.392938852, 2.627928734), (2.408359766, 1.74148643, 1.947027802)),
    'Te': ((7.390233517, 4.482104778, 2.637105942), (3.256022215, 3.52705884, 3.292054176)),
    'Te-e': ((7.508906841, 4.29642868, 2.369987726), (5.583928585, 4.947205067, 3.997592211)),
    'Te-e_palik': ((7.508906841, 4.29642868, 2.369987726), (5.583928585, 4.947205067, 3.997592211)),
    'Te_palik': ((7.390233517, 4.482104778, 2.637105942), (3.256022215, 3.52705884, 3.292054176)),
    'ThF4': ((1.83071363, 1.442228556, 1.387647629), (0.0, 0.0, 0.0)),
    'ThF4_palik': ((1.83071363, 1.442228556, 1.387647629), (0.0, 0.0, 0.0)),
    'TiC': ((3.700528383, 2.837422132, 2.582287073), (3.265635014, 2.351589203, 2.172790527)),
    'TiC_palik': ((3.700528383, 2.837422132, 2.582287073), (3.265635014, 2.351589203, 2.172790527)),
    'TiN': ((1.648449659, 1.150516033, 1.379823446), (3.368328094, 1.943498135, 1.102067709)),
    'TiN_palik': ((1.648449659, 1.150516033, 1.379823446), (3.368328094, 1.943498135, 1.102067709)),
    'TiO2': ((3.456609964, 2.801735878, 2.905174971), (0.000105265, 0.0, 0.000652887)),
    'TiO2-e': ((3.106564522, 2.513168335, 2.582444429), (2.9752e-05, 0.0, 0.000182698)),
    'TiO2-e_palik': ((3.106564522, 2.513168335, 2.582444429), (2.9752e-05, 0.0, 0.000182698)),
    'TiO2_palik': ((3.456609964, 2.801735878, 2.905174971), (0.000105265, 0.0, 0.000652887)),
    'VC': ((3.657566071, 2.752736092, 2.532671928), (3.068300724, 2.198687315, 1.963192701)),
    'VC_palik': ((3.657566071, 2.752736092, 2.532671928), (3.068300724, 2.198687315, 1.963192701)),
    'VN': ((2.865602255, 2.119189024, 1.940091133), (3.032242537, 2.056115627, 1.616306305)),
    'VN_palik': ((2.865602255, 2.119189024, 1.940091133), (3.032242537, 2.056115627, 1.616306305)),
    'V_palik': ((4.277582169, 3.512948751, 2.761071444), (3.491300821, 2.889454842, 3.111521959)),
    'W': ((4.370816708, 3.300246477, 2.998407364), (3.500640631, 2.604873896, 2.273233175)),
    'a-C': ((2.944045782, 2.227136374, 1.968161702), (0.887464881, 0.799298525, 0.815289974)),
    'd-C': ((2.70871973, 2.318825722, 2.228897572), (0.0, 0.0, 0.0)),
    'd-C_palik': ((2.70871973, 2.318825722, 2.228897572), (0.0, 0.0, 0.0)),
    'none': ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0)),
}


def conductor_ior(name: str) -> tuple:
    """``(eta, k)`` RGB triples of Mitsuba's named conductor ``name``.

    Raises ``ValueError`` naming the known materials for an unknown name.

    Examples
    --------
    >>> conductor_ior("Au")[0]
    (0.143035978, 0.375307083, 1.442045331)
    """
    if name not in CONDUCTORS:
        raise ValueError(f"unknown conductor material {name!r}; Mitsuba's named materials are: "
                         f"{', '.join(sorted(CONDUCTORS, key=str.lower))}")
    return CONDUCTORS[name]


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
        object.__setattr__(self, "alpha", check_alpha("RoughConductor", self.alpha))
        object.__setattr__(self, "two_sided", bool(self.two_sided))
        check_distribution("RoughConductor", self.distribution)
        eta, k = _complex_ior("RoughConductor", self.eta, self.k, self.material)
        object.__setattr__(self, "eta", eta)
        object.__setattr__(self, "k", k)
