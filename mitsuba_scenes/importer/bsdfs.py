"""Mitsuba BSDFs as our materials: diffuse, conductors, dielectrics, plastics, ``twosided`` and
``mask``.
"""
from __future__ import annotations

import math

import reference_tracer as rt
from reference_tracer.conductors import CONDUCTORS

from .textures import read_colour, read_reflectance
from .values import check_params, located, param_names, read_bool, read_ior, read_scalar


# Mitsuba defaults that matter here.
_DEFAULT_DIFFUSE = 0.5


def _plastic(ctx, node, name, two_sided):
    """Our Plastic or RoughPlastic for Mitsuba's ``plastic`` / ``roughplastic`` node, or None."""
    rough = name == "roughplastic"
    allowed = {"diffuse_reflectance", "specular_reflectance", "int_ior", "ext_ior", "nonlinear"}
    if rough:
        allowed |= {"distribution", "alpha", "alpha_u", "alpha_v", "sample_visible"}
    check_params(ctx, node, allowed, "bsdf")
    ok = True
    diffuse = read_reflectance(ctx, node, "diffuse_reflectance", _DEFAULT_DIFFUSE)
    specular = read_colour(ctx, node, "specular_reflectance", 1.0)
    int_ior, ext_ior = read_ior(ctx, node, "int_ior", "polypropylene"), read_ior(ctx, node, "ext_ior", "air")
    nonlinear = read_bool(ctx, node, "nonlinear", False)
    kw = {}
    if rough:
        dist = _distribution(ctx, node, "roughplastic")
        ok = ok and dist is not None
        alpha = _roughness(ctx, node)
        if alpha is None:
            ok = False
        else:
            kw = {"alpha": max(alpha, 1e-4), "distribution": dist}  # Mitsuba clamps alpha to 1e-4 too
    if not ok or None in (diffuse, specular, int_ior, ext_ior, nonlinear):
        return None
    return (rt.RoughPlastic if rough else rt.Plastic)(
        diffuse, specular_reflectance=specular, int_ior=int_ior, ext_ior=ext_ior, nonlinear=nonlinear,
        two_sided=two_sided, **kw)


#: BSDFs with a transmission component (a mask's and null's pass-through is one): Mitsuba's
#: twosided refuses to nest them.
_TRANSMITTING = ("dielectric", "thindielectric", "roughdielectric", "mask", "null")


@located
def read_bsdf(ctx, node, *, two_sided=False, emitter=None):
    """Material for BSDF ``node`` (None after recording a problem; a value our material
    refuses is recorded at the node by :func:`~.values.located`).

    None (no ``<bsdf>``): Mitsuba's default diffuse 0.5 on a plain shape, but *black* on an
    emitter shape - Mitsuba gives an area emitter without a BSDF a black diffuse BSDF
    (``mi.traverse`` shows reflectance 0), so the light reflects nothing.
    """
    if node is None:
        if emitter is not None:
            return rt.DiffuseLight(emitter, albedo=None)
        return rt.Lambertian((_DEFAULT_DIFFUSE,) * 3)
    name = node.props.plugin_name()
    if name == "twosided":
        subs = ctx.children(node)
        transmits = [s.props.plugin_name() for s in subs if s.props.plugin_name() in _TRANSMITTING]
        if transmits:
            ctx.bad(node, f"twosided around a {transmits[0]}, a BSDF that transmits: Mitsuba refuses it too "
                          "(\"Only materials without a transmission component can be nested!\")")
            return None
        if len(subs) != 1 or param_names(node):
            if len(subs) == 2 and subs[0].props == subs[1].props:
                pass
            else:
                ctx.bad(node, "twosided with two different BSDFs is not supported")
                return None
        if emitter is not None:
            # Mitsuba's area emitter is one-sided whatever the BSDF: a black twosided BSDF
            # reflects nothing on either side, exactly our DiffuseLight without albedo
            inner = subs[0]
            albedo = (read_reflectance(ctx, inner, "reflectance", _DEFAULT_DIFFUSE)
                      if inner.props.plugin_name() == "diffuse" and not set(param_names(inner)) - {"reflectance"}
                      else None)
            if albedo is not None and not isinstance(albedo, rt.Texture) and max(albedo) == 0.0:
                return rt.DiffuseLight(emitter, albedo=None)
            ctx.bad(node, "an area emitter on a twosided BSDF that reflects (our DiffuseLight reflects on its front "
                          "only; a black twosided diffuse is supported)")
            return None
        return read_bsdf(ctx, subs[0], two_sided=True)
    if name == "diffuse":
        check_params(ctx, node, {"reflectance"}, "bsdf")
        albedo = read_reflectance(ctx, node, "reflectance", _DEFAULT_DIFFUSE)
        if albedo is None:
            return None
        if emitter is not None:
            black = not isinstance(albedo, rt.Texture) and max(albedo) == 0
            return rt.DiffuseLight(emitter, albedo=None if black else albedo)
        return rt.Lambertian(albedo, two_sided=two_sided)
    if emitter is not None:
        ctx.bad(node, f"an area emitter on a '{name}' BSDF (our emitters reflect as diffuse only)")
        return None
    if name == "mask":
        return _mask(ctx, node, two_sided)
    if name == "conductor":
        check_params(ctx, node, {"material", "specular_reflectance", "eta", "k"}, "bsdf")
        ior = _conductor_ior(ctx, node)
        albedo = read_reflectance(ctx, node, "specular_reflectance", 1.0)
        if ior is None or albedo is None:
            return None
        return rt.Metal(albedo, fuzz=0.0, two_sided=two_sided, **ior)
    if name == "roughconductor":
        check_params(ctx, node, {"material", "specular_reflectance", "distribution", "alpha", "alpha_u", "alpha_v",
                           "sample_visible", "eta", "k"}, "bsdf")
        dist = _distribution(ctx, node, "roughconductor")
        ok = dist is not None
        alpha = _roughness(ctx, node)
        ior = _conductor_ior(ctx, node)
        albedo = read_reflectance(ctx, node, "specular_reflectance", 1.0)
        if not ok or alpha is None or ior is None or albedo is None:
            return None
        return rt.RoughConductor(albedo, alpha=alpha, distribution=dist, two_sided=two_sided, **ior)
    if name in ("plastic", "roughplastic"):
        return _plastic(ctx, node, name, two_sided)
    if name in ("dielectric", "thindielectric", "roughdielectric"):
        rough = name == "roughdielectric"
        check_params(ctx, node, {"int_ior", "ext_ior", "specular_reflectance", "specular_transmittance"}
               | ({"distribution", "alpha", "alpha_u", "alpha_v", "sample_visible"} if rough else set()), "bsdf")
        ok = True
        for k in ("specular_reflectance", "specular_transmittance"):
            c = read_colour(ctx, node, k, 1.0)
            if c is not None and c != (1.0, 1.0, 1.0):
                ctx.bad(node, f"{name} {k}={c} (only 1)")
                ok = False
        i, e = read_ior(ctx, node, "int_ior", "bk7"), read_ior(ctx, node, "ext_ior", "air")
        if rough:
            dist = _distribution(ctx, node, "roughdielectric")
            ok = ok and dist is not None
            alpha = _roughness(ctx, node)
            if not ok or alpha is None or i is None or e is None:
                return None
            return rt.RoughDielectric(i / e, alpha, distribution=dist)
        if not ok or i is None or e is None:
            return None
        # Mitsuba's (thin) dielectric depends on int_ior / ext_ior only: exact with ext = 1.
        return rt.Dielectric(i / e) if name == "dielectric" else rt.ThinDielectric(i / e)
    ctx.bad(node, f"bsdf '{name}'")
    return None


def _opacity(ctx, node):
    """A mask's opacity as Mitsuba's ``eval_1`` reads it: a number (default 0.5), the mean of an
    RGB value's channels (an ``rgb`` texture's ``eval_1``), or a ``checkerboard`` or ``bitmap``
    texture (:class:`reference_tracer.Mask` reads its ``eval_1``); None after recording a problem."""
    p = node.props
    if "opacity" in p.keys() and p.type("opacity") == ctx.mi.Properties.Type.ResolvedReference:
        sub = ctx.node(p["opacity"])
        if sub.props.plugin_name() in ("checkerboard", "bitmap", "mesh_attribute"):
            return read_reflectance(ctx, node, "opacity", 0.5)
        if sub.props.plugin_name() not in ("rgb", "srgb"):
            ctx.bad(sub, f"texture '{sub.props.plugin_name()}' for mask.opacity (a number, an RGB value, or a "
                         "checkerboard or bitmap texture)")
            return None
    c = read_colour(ctx, node, "opacity", 0.5)
    if c is None:
        return None
    return sum(c) / 3.0


def _mask(ctx, node, two_sided):
    """Mitsuba's ``mask`` around one nested BSDF (within a ``twosided``, or around one: the
    same BSDF), its opacity clipped to [0, 1] as Mitsuba clips it; None after recording a
    problem."""
    check_params(ctx, node, {"opacity"}, "bsdf")
    nested = [c for c in ctx.children(node) if c.type == ctx.mi.ObjectType.BSDF]
    if len(nested) != 1:
        ctx.bad(node, "mask without a nested BSDF" if not nested else
                f"mask with {len(nested)} nested BSDFs (Mitsuba takes exactly one)")
        return None
    opacity = _opacity(ctx, node)
    if isinstance(opacity, float) and math.isnan(opacity):
        ctx.bad(node, "mask opacity NaN")
        return None
    inner = read_bsdf(ctx, nested[0], two_sided=two_sided)
    if inner is None or opacity is None:
        return None
    if isinstance(inner, rt.Mask):
        ctx.bad(node, "a mask around a mask (one mask only)")
        return None
    return rt.Mask(inner, opacity, clip=True)


def _distribution(ctx, node, name: str):
    """A microfacet BSDF's distribution (Mitsuba's default beckmann), or None after recording a
    problem: another name, or ``sample_visible=false`` (another estimator of the same image,
    which ours does not implement)."""
    ok = True
    dist = read_scalar(ctx, node, "distribution", "beckmann")
    if dist not in rt.DISTRIBUTIONS:
        ctx.bad(node, f"{name} distribution '{dist}' (ggx or beckmann)")
        ok = False
    if read_bool(ctx, node, "sample_visible", True) is not True:
        ctx.bad(node, f"{name} sample_visible=false (the estimator differs; its image does not)")
        ok = False
    return dist if ok else None


def _roughness(ctx, node):
    """A microfacet BSDF's isotropic alpha (Mitsuba's default 0.1), or None after recording a problem:
    a texture, or alpha_u differing from alpha_v (anisotropy), is not modelled."""
    T = ctx.mi.Properties.Type
    for key in ("alpha", "alpha_u", "alpha_v"):
        if key in node.props.keys() and node.props.type(key) not in (T.Float, T.Integer):
            ctx.bad(node, f"{node.props.plugin_name()} {key} given as a texture (a textured roughness is not "
                          "supported: only a number; textures are read for reflectances)")
            return None
    au, av = read_scalar(ctx, node, "alpha_u", None), read_scalar(ctx, node, "alpha_v", None)
    if au is not None or av is not None:
        if au != av:
            ctx.bad(node, f"anisotropic {node.props.plugin_name()} (alpha_u={au}, alpha_v={av})")
            return None
        return float(au)
    return float(read_scalar(ctx, node, "alpha", 0.1))


def _conductor_ior(ctx, node):
    """``{"eta", "k"}`` or ``{"material"}`` keyword arguments of our conductors, as Mitsuba reads
    them (``material`` defaults to "none", Fresnel 1; ``eta`` with ``k`` defaulting to 1), or None."""
    keys = node.props.keys()
    if "eta" in keys or "k" in keys:
        if "material" in keys:
            ctx.bad(node, f"{node.props.plugin_name()} with both material and eta/k (Mitsuba refuses it too)")
            return None
        eta = read_colour(ctx, node, "eta", 0.0)
        k = read_colour(ctx, node, "k", 1.0)
        return None if eta is None or k is None else {"eta": eta, "k": k}
    material = read_scalar(ctx, node, "material", "none")
    if not isinstance(material, str) or material not in CONDUCTORS:
        ctx.bad(node, f"{node.props.plugin_name()} material='{material}' (not one of Mitsuba's named conductors)")
        return None
    return {"material": material}
