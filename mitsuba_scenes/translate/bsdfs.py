"""Our materials and textures as Mitsuba BSDF records (colours rounded to float32, as Mitsuba stores
them).
"""
from __future__ import annotations

import numpy as np

import reference_tracer as rt
from reference_tracer.material_textures import textures_of


def f32(x) -> np.ndarray:
    """Round to float32 (what Mitsuba stores) and back to float64."""
    return np.asarray(x, dtype=np.float64).astype(np.float32).astype(np.float64)


def rgb(c) -> list:
    return [float(x) for x in f32(c)]


def _conductor_ior(m) -> dict:
    """A conductor's Fresnel in Mitsuba's terms: ``material='none'`` (Fresnel 1) or RGB ``eta`` and ``k``."""
    if m.eta is None:
        return {"material": "none"}
    return {"eta": {"type": "rgb", "value": rgb(m.eta)}, "k": {"type": "rgb", "value": rgb(m.k)}}


def _uv_matrix(to_uv) -> np.ndarray:
    """A texture's ``to_uv`` as the 4x4 matrix Mitsuba's ``<transform>`` holds (rows and
    columns 0 and 1, the translation in column 3)."""
    m = np.eye(4)
    a = np.asarray(to_uv, dtype=np.float64)
    m[:2, :2], m[:2, 3] = a[:, :2], a[:, 2]
    return f32(m)


def value_record(v) -> dict:
    """A reflectance in Mitsuba's dict syntax: an RGB value or a texture (plain values; a
    bitmap from an array keeps the array under ``data``: the dict and XML writers give it
    to Mitsuba their own way)."""
    if isinstance(v, rt.Checkerboard):
        return {"type": "checkerboard", "color0": {"type": "rgb", "value": rgb(v.color0)},
                "color1": {"type": "rgb", "value": rgb(v.color1)}, "to_uv": _uv_matrix(v.to_uv)}
    if isinstance(v, rt.MeshAttribute):
        return {"type": "mesh_attribute", "name": v.name, "scale": float(v.scale)}
    if isinstance(v, rt.Bitmap):
        rec = {"type": "bitmap", "filter_type": v.filter, "wrap_mode": v.wrap, "to_uv": _uv_matrix(v.to_uv)}
        if v.filename is not None:
            rec.update(filename=v.filename, raw=v.raw)
        else:
            rec["data"] = v.data
        return rec
    return {"type": "rgb", "value": rgb(v)}


def is_textured(m) -> bool:
    return bool(textures_of(m))


def bsdf_record(label: str, m) -> dict:
    """A nested dict (Mitsuba dict syntax, plain values) for material ``m``."""
    if isinstance(m, rt.Mask):
        # the same texture: Mitsuba's mask reads its eval_1, as rt.Mask does
        opacity = (value_record(m.opacity) if isinstance(m.opacity, rt.Texture)
                   else float(f32(m.opacity)))
        return {"type": "mask", "opacity": opacity, "bsdf": bsdf_record(label, m.material)}
    if isinstance(m, rt.Lambertian):
        b = {"type": "diffuse", "reflectance": value_record(m.albedo)}
    elif isinstance(m, rt.Metal):
        if m.fuzz > 0:
            raise ValueError(f"{label}: Metal(fuzz={m.fuzz}) has no Mitsuba equivalent (the book's fuzz is "
                             f"not a microfacet model); use RoughConductor(albedo, alpha) or fuzz=0")
        b = {"type": "conductor", **_conductor_ior(m), "specular_reflectance": value_record(m.albedo)}
    elif isinstance(m, rt.RoughConductor):
        b = {"type": "roughconductor", "distribution": m.distribution, **_conductor_ior(m),
             "alpha": float(f32(m.alpha)), "specular_reflectance": value_record(m.albedo)}
    elif isinstance(m, (rt.Plastic, rt.RoughPlastic)):
        # specular_reflectance always given: Mitsuba multiplies by it only then, and its
        # mean (1 when absent) steers the lobe choice the same either way
        b = {"type": "plastic", "diffuse_reflectance": value_record(m.diffuse_reflectance),
             "specular_reflectance": {"type": "rgb", "value": rgb(m.specular_reflectance)},
             "int_ior": float(f32(m.int_ior)), "ext_ior": float(f32(m.ext_ior)), "nonlinear": bool(m.nonlinear)}
        if isinstance(m, rt.RoughPlastic):
            b.update(type="roughplastic", distribution=m.distribution, alpha=float(f32(m.alpha)))
    elif isinstance(m, rt.Dielectric):
        if m.fresnel != "exact":
            raise ValueError(f"{label}: Dielectric(fresnel={m.fresnel!r}) has no Mitsuba equivalent (Mitsuba's "
                             f"dielectric uses the exact Fresnel equations); use fresnel='exact'")
        return {"type": "dielectric", "int_ior": float(f32(m.ior)), "ext_ior": 1.0}
    elif isinstance(m, rt.ThinDielectric):
        return {"type": "thindielectric", "int_ior": float(f32(m.ior)), "ext_ior": 1.0}
    elif isinstance(m, rt.RoughDielectric):
        return {"type": "roughdielectric", "distribution": m.distribution, "alpha": float(f32(m.alpha)),
                "int_ior": float(f32(m.ior)), "ext_ior": 1.0}
    elif isinstance(m, rt.DiffuseLight):
        # A light without albedo reflects nothing: a black diffuse BSDF (Mitsuba would
        # otherwise give the shape its default 0.5 grey diffuse BSDF).
        albedo = m.albedo if m.albedo is not None else (0.0, 0.0, 0.0)
        return {"type": "diffuse", "reflectance": value_record(albedo)}
    else:
        raise ValueError(f"{label}: material {type(m).__name__} has no Mitsuba translation")
    if getattr(m, "two_sided", False):
        b = {"type": "twosided", "bsdf": b}
    return b
