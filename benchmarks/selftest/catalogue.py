"""The catalogue of seeded bugs ("mutants"): what each breaks and where it is tested.

Each mutant is one ``if constexpr`` in ``reference_tracer/cpp/mutants.h``, compiled into the
self-test's own extension module only. Each is tested on one scene and strategy where the bug
changes the image: several real bugs cancel in most scenes (a wrong pdf in both MIS weights,
the 1/eta^2 of refraction on closed glass, a two-sided light whose back no one sees).

Three scenes are the self-test's own (:data:`SELFTEST_SCENES`, each with a cached Mitsuba
reference): ``cornell_box_rr3`` (roulette from depth 3, for ``roulette_no_reweight``),
``hanging_lamp`` (the ceiling light lowered to ``y = 450`` over a diffuser plate 2 units under
it, for ``two_sided_light`` and ``shadow_epsilon_leak``) and ``glass_lamp`` (the light embedded
in a glass slab, for ``glass_no_eta_scale``).

Examples
--------
>>> [m.scene for m in resolve_mutants("max_depth_off_by_one")]
['furnace']
>>> selftest_scene("cornell_box_rr3", width=8).rr_depth
3
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

import reference_tracer as rt
from mitsuba_scenes import get_scene, list_scenes
from mitsuba_scenes.scenes.cornell_box import WHITE, camera, ceiling_light, room, short_box, tall_box

from ..gate.suite import gate_scene, names_of

__all__ = ["Mutant", "CATALOGUE", "resolve_mutants", "SELFTEST_SCENES", "selftest_scene", "is_suite_scene"]


@dataclass(frozen=True)
class Mutant:
    """One seeded bug: the core's ``name``, the bug, what it ``breaks``, the ``scene`` and
    ``strategy`` it is tested with and ``why``."""

    name: str
    description: str
    breaks: str
    scene: str
    strategy: str
    why: str

    def to_dict(self) -> dict:
        return asdict(self)


CATALOGUE = (
    Mutant("missing_cosine",
           "Lambertian BSDF evaluation returns f = albedo/pi without the cosine factor",
           "next-event estimation at diffuse vertices (f*cos/pdf_light): direct light too bright, most at grazing "
           "angles; BSDF sampling is unaffected (its weight is the albedo, computed analytically)",
           "cornell_box", "mis",
           "all-diffuse scene lit mostly by next-event estimation; mis is the gated strategy"),
    Mutant("pdf_off_by_pi",
           "Lambertian sampling density cos(theta) instead of cos(theta)/pi (in pdf() and in the sample's pdf)",
           "estimators that divide by the material's density: mixture's one-sample estimator divides by "
           "0.5 pdf_light + 0.5 pdf_bsdf, now too large, so the image is too dark",
           "cornell_box", "mixture",
           "under mis the same wrong density enters both MIS weights, which still sum to one: the mutant is "
           "unbiased there (image within noise of the tracer's); mixture is the strategy that exposes it"),
    Mutant("emitter_weight_one",
           "emitters hit by BSDF sampling are counted with MIS weight 1 beside next-event estimation",
           "direct light is counted by both techniques: nearly twice the direct illumination",
           "cornell_box", "mis",
           "only mis combines the two techniques; direct light dominates cornell_box"),
    Mutant("light_pdf_no_jacobian",
           "light sampling returns the area density 1/A as if it were the solid-angle density "
           "(dist^2 / (cos_light A) missing)",
           "next-event estimation divides by a density wrong by cos/dist^2 (about 1e-5 in a 555-unit room) and "
           "its MIS weight collapses: most direct light is lost",
           "cornell_box", "mis",
           "a quad light sampled by area, the common case; the emitter-hit MIS weight uses the correct "
           "density, so the two disagree"),
    Mutant("roulette_no_reweight",
           "Russian roulette terminates paths but does not divide the survivors' throughput by q",
           "energy of every path longer than rr_depth is lost in proportion to the termination probability: "
           "indirect light too dark",
           "cornell_box_rr3", "mis",
           "the mutant needs paths longer than rr_depth; cornell_box with rr_depth=3 (against Mitsuba's render "
           "of that same scene) starts roulette earlier than the suite's rr_depth=5 and has interreflections "
           "long enough to lose"),
    Mutant("glass_no_eta_scale",
           "refraction through a dielectric does not scale radiance by (eta_i/eta_t)^2",
           "radiance carried across a single interface is off by eta^2 (2.25 for glass)",
           "glass_lamp", "mis",
           "on closed glass lit and seen from outside (cornell_glass without roulette) the factors of entering "
           "and leaving cancel exactly: the mutant renders it bit-identically. In glass_lamp the light is "
           "embedded in a glass slab, so every path that reaches it ends inside glass"),
    Mutant("ggx_masking_alpha",
           "GGX Smith masking G1 uses alpha where alpha^2 belongs (2 / (1 + sqrt(1 + alpha tan^2)))",
           "rough-conductor reflectance too dark, most at grazing angles and on rough plates (G1 of both "
           "directions, in eval, pdf and the sampled weight)",
           "glossy_plates", "mis",
           "the suite's only rough conductors (GGX alpha 0.005 to 0.2), seen near grazing"),
    Mutant("two_sided_light",
           "an area emitter hit from its back emits too (the front-side test dropped)",
           "light leaves the back of one-sided emitters: surfaces behind lights are lit",
           "hanging_lamp", "mis",
           "in the suite's Cornell boxes the light's back faces the ceiling 1 unit away and is practically "
           "unseen; hanging_lamp lowers the light to 105 units under the ceiling"),
    Mutant("max_depth_off_by_one",
           "the path-length test uses > where >= belongs: one segment more than max_depth allows",
           "one more bounce of light: brighter by the energy of that bounce",
           "furnace", "mis",
           "at max_depth=50 (the Cornell scenes) one more bounce adds ~rho^50; the furnace has max_depth=8 and "
           "a closed-form reference, and mis is exact per sample there, so any change is caught"),
    Mutant("shadow_epsilon_leak",
           "shadow rays stop 1% of their length short of the sampled light point (relative epsilon 1e-2 "
           "instead of 1e-7; Mitsuba's is ~9e-4)",
           "occluders within 1% of the distance from a light do not shadow next-event estimation: light "
           "leaks through them",
           "hanging_lamp", "mis",
           "the suite has no occluder near a light; hanging_lamp has a diffuser plate 2 units under the light, "
           "whose shadow leaks for points more than ~200 units away"),
    Mutant("half_pixel_jitter",
           "camera samples jittered in [x - 1/2, x + 1/2) instead of [x, x + 1): every pixel integrates "
           "a pixel-sized square centred on its upper-left corner",
           "the image is shifted by half a pixel: wrong at every edge",
           "cornell_box", "mis",
           "sharp, bright edges (the light, the boxes, the wall corners)"),
    Mutant("correlated_pixel_streams",
           "every pixel draws from the same random stream (the pixel index dropped from the seeding)",
           "each pixel's mean is still unbiased but neighbouring pixels' errors are strongly correlated: "
           "structured noise, tile and image averages far noisier than independent pixels allow",
           "cornell_box", "mis",
           "large surfaces of similar radiance where shared random numbers give nearly the same error"),
)

_BY_NAME = {m.name: m for m in CATALOGUE}


def resolve_mutants(mutants=None) -> list:
    """Catalogue entries by name (None: all; a string may be comma-separated), de-duplicated."""
    if mutants is None:
        return list(CATALOGUE)
    names = names_of(mutants)
    if not names:
        raise ValueError("no mutant selected")
    for name in names:
        if name not in _BY_NAME:
            raise ValueError(f"unknown mutant {name!r}; the catalogue has: {', '.join(_BY_NAME)}")
    return [_BY_NAME[n] for n in names]


def _cornell_box_rr3(width: int, height: int) -> rt.Scene:
    return get_scene("cornell_box", width=width, height=height, rr_depth=3)


def _hanging_lamp(width: int, height: int) -> rt.Scene:
    x, z = (213.0, 343.0), (227.0, 332.0)  # the cornell_box light's extent
    w, d = x[1] - x[0], z[1] - z[0]
    plate = rt.Quad((x[0] + w / 4, 448.0, z[0] + d / 4), (w / 2, 0, 0), (0, 0, d / 2),
                    rt.Lambertian(WHITE))  # 2 units under the light; normal u x v = -y: faces the room
    return rt.Scene(camera=camera(width, height),
                    shapes=[*room(), ceiling_light(x=x, z=z, y=450.0), plate, tall_box(), short_box()],
                    max_depth=50)


def _glass_lamp(width: int, height: int) -> rt.Scene:
    slab = rt.Box((203.0, 535.0, 217.0), (353.0, 552.0, 342.0), rt.Dielectric(1.5))
    return rt.Scene(camera=camera(width, height),
                    shapes=[*room(), ceiling_light(y=545.0), slab, tall_box(), short_box()],
                    max_depth=50)


#: self-test scene name -> builder(width, height).
SELFTEST_SCENES = {
    "cornell_box_rr3": _cornell_box_rr3,
    "hanging_lamp": _hanging_lamp,
    "glass_lamp": _glass_lamp,
}


def is_suite_scene(name: str) -> bool:
    return name in list_scenes()


def selftest_scene(name: str, *, width: int, height: int | None = None) -> rt.Scene:
    """Scene ``name`` at ``width`` x ``height`` (default square): a suite scene as the gate
    builds it (:func:`benchmarks.gate.gate_scene`) or one of :data:`SELFTEST_SCENES`."""
    height = width if height is None else height
    if name in SELFTEST_SCENES:
        return SELFTEST_SCENES[name](width, height)
    if is_suite_scene(name):
        return gate_scene(name, width=width, height=height)
    raise ValueError(f"unknown self-test scene {name!r}")
